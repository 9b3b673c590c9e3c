//! hloc-format result files: one line `name qw qx qy qz tx ty tz` per localised image,
//! world-to-camera (COLMAP's convention, which hloc's evaluation scripts read).
//! Frames without a pose have no line; readers count a missing name as a failure.
//! Numbers are written in Rust's shortest round-trip form, so reading a file back
//! gives the same poses bit for bit.

use crate::error::ScoreError;
use fileio::io_err;
use geometry::Pose;
use std::path::Path;

/// The file's text for `(name, pose)` pairs, in the given order. Names must not
/// contain whitespace (the format separates fields by spaces).
pub fn format_results<'a>(
    entries: impl IntoIterator<Item = (u64, &'a str, &'a Pose)>,
) -> Result<String, ScoreError> {
    let mut s = String::new();
    for (frame_id, name, pose) in entries {
        if name.is_empty() || name.chars().any(char::is_whitespace) {
            return Err(ScoreError::NameWithSpace {
                frame_id,
                name: name.to_string(),
            });
        }
        let q = pose.qvec();
        let t = pose.tvec();
        s.push_str(&format!(
            "{name} {} {} {} {} {} {} {}\n",
            q[0], q[1], q[2], q[3], t[0], t[1], t[2]
        ));
    }
    Ok(s)
}

/// Writes a result file atomically.
pub fn write_results<'a>(
    path: &Path,
    entries: impl IntoIterator<Item = (u64, &'a str, &'a Pose)>,
) -> Result<(), ScoreError> {
    let text = format_results(entries)?;
    stage::write_atomic(path, text.as_bytes())?;
    Ok(())
}

/// One line of a result file, with the numbers as written.
#[derive(Clone, Debug, PartialEq)]
pub struct HlocEntry {
    pub name: String,
    pub qvec: [f64; 4],
    pub tvec: [f64; 3],
    /// The pose (quaternion normalised).
    pub pose: Pose,
}

/// Reads a result file (blank lines and `#` comments skipped); the quaternion must be
/// of unit norm (geometry's tolerance).
pub fn read_results(path: &Path) -> Result<Vec<HlocEntry>, ScoreError> {
    let text = std::fs::read_to_string(path).map_err(io_err(path))?;
    let bad = |line: usize, reason: String| ScoreError::HlocFormat {
        path: path.to_path_buf(),
        line,
        reason,
    };
    let mut out = Vec::new();
    for (i, raw) in text.lines().enumerate() {
        let line = raw.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let fields: Vec<&str> = line.split_whitespace().collect();
        if fields.len() != 8 {
            return Err(bad(
                i + 1,
                format!(
                    "expected `name qw qx qy qz tx ty tz`, got {} fields",
                    fields.len()
                ),
            ));
        }
        let mut v = [0.0; 7];
        for (k, f) in fields[1..].iter().enumerate() {
            v[k] = f
                .parse::<f64>()
                .map_err(|_| bad(i + 1, format!("field {} is not a number: {f:?}", k + 2)))?;
        }
        let qvec = [v[0], v[1], v[2], v[3]];
        let tvec = [v[4], v[5], v[6]];
        let pose = Pose::from_qvec_tvec(qvec, tvec).map_err(|e| bad(i + 1, e.to_string()))?;
        out.push(HlocEntry {
            name: fields[0].to_string(),
            qvec,
            tvec,
            pose,
        });
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Unit, UnitQuaternion, Vector3};

    fn pose(a: f64) -> Pose {
        let axis = Unit::new_normalize(Vector3::new(0.3, -1.0, 0.7));
        Pose::new(
            UnitQuaternion::from_axis_angle(&axis, a),
            Vector3::new(0.1 * a, -2.5, 1.0 / 3.0),
        )
    }

    #[test]
    fn format_is_name_then_wxyz_then_t() {
        let p = Pose::new(UnitQuaternion::identity(), Vector3::new(1.0, -2.0, 0.5));
        let s = format_results([(0, "seq-01/frame-000000.color.png", &p)]).unwrap();
        assert_eq!(s, "seq-01/frame-000000.color.png 1 0 0 0 1 -2 0.5\n");
    }

    #[test]
    fn round_trip_is_exact() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("results.txt");
        let (a, b) = (pose(0.4), pose(2.9));
        write_results(&path, [(1, "a.png", &a), (2, "dir/b.png", &b)]).unwrap();
        let back = read_results(&path).unwrap();
        assert_eq!(back.len(), 2);
        assert_eq!(back[0].name, "a.png");
        assert_eq!(back[1].name, "dir/b.png");
        // The written numbers come back bit for bit.
        assert_eq!(back[0].qvec, a.qvec());
        assert_eq!(back[0].tvec, a.tvec());
        assert_eq!(back[1].qvec, b.qvec());
        assert_eq!(back[1].tvec, b.tvec());
        let r = back[1].pose.rotation.angle_to(&b.rotation);
        assert!(r < 1e-15, "{r}");
    }

    #[test]
    fn refuses_names_with_spaces_and_bad_lines() {
        let p = pose(0.1);
        assert!(matches!(
            format_results([(7, "my image.png", &p)]),
            Err(ScoreError::NameWithSpace { frame_id: 7, .. })
        ));
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("bad.txt");
        std::fs::write(&path, "# comment\n\na.png 1 0 0 0 1 2\n").unwrap();
        let e = read_results(&path).unwrap_err().to_string();
        assert!(e.contains("line 3") && e.contains("7 fields"), "{e}");
        std::fs::write(&path, "a.png 1 0 0 0 1 2 x\n").unwrap();
        let e = read_results(&path).unwrap_err().to_string();
        assert!(e.contains("field 8"), "{e}");
        // Not a rotation: the quaternion's norm is 2.
        std::fs::write(&path, "a.png 2 0 0 0 1 2 3\n").unwrap();
        assert!(read_results(&path).is_err());
    }
}
