//! Microsoft 7-Scenes: `<scene>/{TrainSplit.txt, TestSplit.txt}` and
//! `<scene>/seq-XX/frame-XXXXXX.{color.png|color.jpg, depth.png, pose.txt}`.
//!
//! - Split files list `sequenceN` lines; the folder is `seq-` + the digits zero-padded to
//!   two characters (ACE's rule `'seq-' + s[8:].zfill(2)`, so `sequence10` -> `seq-10`).
//! - `pose.txt` is the camera-to-world 4x4 matrix of the Kinect *depth* camera (the poses
//!   come from KinectFusion on the depth stream). `published` keeps it as the colour
//!   camera's pose, as the dataset and kapture's trajectories do; `calibrated` moves it to
//!   the colour camera with the Kinect depth-to-RGB extrinsic, as ACE/DSAC* do.
//! - The split file names, the cameras and the extrinsic are the dataset descriptor's
//!   (`[layouts.7scenes]` of `datasets/7scenes.toml`, which says where each comes from).
//!   The cameras are uncalibrated. Colour: SIMPLE_PINHOLE f=525 at the image centre;
//!   depth: f=585 at (320, 240). Both are read in COLMAP's pixel convention (the top-left
//!   pixel's centre is (0.5, 0.5)), so (320, 240) is the exact image centre.

use super::error::{IngestError, Result};
use super::text::{numbered_lines, parse_err, parse_f64, read_text};
use fileio::io_err;
use geometry::pose::check_rotation;
use geometry::{GeometryError, Matrix3, Matrix4, Pose};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Tolerance of the pose.txt rotation check (max |R^T R - I|, |det R - 1|). The published
/// rotations are not quite orthonormal (KinectFusion output, slightly scaled): in the 12
/// frames of the shared stairs sample |det R - 1| reaches 1.9e-4 and max |R^T R - I|
/// 1.5e-4, beyond geometry's 1e-4 default. 1e-2 keeps a 50x margin over that and still
/// refuses a corrupted matrix (a row scaled by 1 %, a wrong entry). The rotation kept is
/// the closest one, as kapture's `quaternion.from_rotation_matrix` keeps.
pub const POSE_ORTHONORMAL_TOLERANCE: f64 = 1e-2;

/// Reads a split file into `(line, sequence folder name)`, in file order.
pub(crate) fn parse_split_file(path: &Path) -> Result<Vec<(usize, String)>> {
    let text = read_text(path, "7-Scenes split file")?;
    let mut out: Vec<(usize, String)> = Vec::new();
    for (line, raw) in numbered_lines(&text) {
        let s = raw.trim();
        if s.is_empty() {
            continue;
        }
        let digits = s
            .strip_prefix("sequence")
            .filter(|d| !d.is_empty() && d.bytes().all(|b| b.is_ascii_digit()))
            .ok_or_else(|| {
                parse_err(
                    path,
                    line,
                    format!("expected `sequenceN` (N digits), got {s:?}"),
                )
            })?;
        let seq = format!("seq-{digits:0>2}");
        if let Some((first, _)) = out.iter().find(|(_, q)| *q == seq) {
            return Err(IngestError::Duplicate {
                path: path.to_path_buf(),
                line,
                name: seq,
                first: format!("first at line {first}"),
            });
        }
        out.push((line, seq));
    }
    if out.is_empty() {
        return Err(parse_err(
            path,
            1,
            "expected at least one `sequenceN` line, the file lists none",
        ));
    }
    Ok(out)
}

/// The files of one 7-Scenes frame.
#[derive(Clone, Debug)]
pub(crate) struct FrameFiles {
    /// `seq-01/frame-000000.color.png`
    pub name: String,
    /// `seq-01/frame-000000`
    pub stem: String,
    pub colour: PathBuf,
    pub pose: PathBuf,
    pub depth: Option<PathBuf>,
}

#[derive(Default)]
struct Found {
    png: bool,
    jpg: bool,
    pose: bool,
    depth: bool,
}

/// Lists the frames of `scene_dir/seq`: every `frame-XXXXXX` that has any of its files.
/// Each must have a colour image (exactly one of .color.png / .color.jpg) and a pose.
pub(crate) fn list_sequence(
    scene_dir: &Path,
    seq: &str,
    listed_in: (&Path, usize),
) -> Result<Vec<FrameFiles>> {
    let dir = scene_dir.join(seq);
    let entries = match std::fs::read_dir(&dir) {
        Ok(e) => e,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            return Err(IngestError::Missing {
                path: dir,
                what: format!(
                    "sequence folder (listed at {}:{})",
                    listed_in.0.display(),
                    listed_in.1
                ),
            });
        }
        Err(e) => return Err(io_err(&dir)(e).into()),
    };
    let mut frames: BTreeMap<String, Found> = BTreeMap::new();
    for entry in entries {
        let entry = entry.map_err(io_err(&dir))?;
        let file_name = entry.file_name();
        // A name that is not UTF-8 cannot be one of the layout's names.
        let Some(file_name) = file_name.to_str() else {
            continue;
        };
        let Some(rest) = file_name.strip_prefix("frame-") else {
            continue;
        };
        let Some((index, suffix)) = rest.split_once('.') else {
            continue;
        };
        if index.is_empty() || !index.bytes().all(|b| b.is_ascii_digit()) {
            continue;
        }
        let f = frames.entry(format!("frame-{index}")).or_default();
        match suffix {
            "color.png" => f.png = true,
            "color.jpg" => f.jpg = true,
            "pose.txt" => f.pose = true,
            "depth.png" => f.depth = true,
            _ => {}
        }
    }
    let mut out = Vec::with_capacity(frames.len());
    for (stem, found) in frames {
        let ext = match (found.png, found.jpg) {
            (true, true) => {
                return Err(IngestError::Ambiguous {
                    path: dir.join(&stem),
                    what: "colour image".into(),
                    candidates: vec![format!("{stem}.color.png"), format!("{stem}.color.jpg")],
                });
            }
            (true, false) => "png",
            (false, true) => "jpg",
            (false, false) => {
                return Err(IngestError::MissingColour {
                    dir: dir.clone(),
                    stem,
                });
            }
        };
        let pose = dir.join(format!("{stem}.pose.txt"));
        if !found.pose {
            return Err(IngestError::Missing {
                path: pose,
                what: "pose file of a frame".into(),
            });
        }
        out.push(FrameFiles {
            name: format!("{seq}/{stem}.color.{ext}"),
            colour: dir.join(format!("{stem}.color.{ext}")),
            depth: found.depth.then(|| dir.join(format!("{stem}.depth.png"))),
            stem: format!("{seq}/{stem}"),
            pose,
        });
    }
    if out.is_empty() {
        return Err(IngestError::Missing {
            path: dir,
            what: "frames (frame-XXXXXX.color.png or .color.jpg with frame-XXXXXX.pose.txt)".into(),
        });
    }
    Ok(out)
}

/// Reads a `pose.txt` (camera-to-world 4x4, whitespace separated, blank lines ignored)
/// and returns the world-to-camera pose of the camera it describes. Errors name the line
/// of the offending row.
pub fn read_pose_file(path: &Path) -> Result<Pose> {
    let text = read_text(path, "pose file")?;
    let mut rows: Vec<(usize, [f64; 4])> = Vec::with_capacity(4);
    let mut last_line = 0;
    for (line, raw) in numbered_lines(&text) {
        last_line = line;
        let tokens: Vec<&str> = raw.split_whitespace().collect();
        if tokens.is_empty() {
            continue;
        }
        if rows.len() == 4 {
            return Err(parse_err(
                path,
                line,
                "expected 4 rows of a 4x4 matrix, found a 5th row",
            ));
        }
        if tokens.len() != 4 {
            return Err(parse_err(
                path,
                line,
                format!("expected 4 numbers per row, found {}", tokens.len()),
            ));
        }
        let mut row = [0.0; 4];
        for (k, t) in tokens.iter().enumerate() {
            row[k] = parse_f64(path, line, t, "a matrix entry")?;
        }
        if !row.iter().all(|v| v.is_finite()) {
            return Err(IngestError::Pose {
                path: path.to_path_buf(),
                line,
                source: GeometryError::NonFinite {
                    what: "row of the 4x4 pose matrix",
                },
            });
        }
        rows.push((line, row));
    }
    if rows.len() != 4 {
        return Err(parse_err(
            path,
            last_line.max(1),
            format!("expected 4 rows of a 4x4 matrix, found {}", rows.len()),
        ));
    }
    let (line4, last) = rows[3];
    if last != [0.0, 0.0, 0.0, 1.0] {
        return Err(IngestError::Pose {
            path: path.to_path_buf(),
            line: line4,
            source: GeometryError::NotRigid(last),
        });
    }
    let m = Matrix4::from_fn(|i, j| rows[i].1[j]);
    let r: Matrix3<f64> = m.fixed_view::<3, 3>(0, 0).into();
    if let Err(source) = check_rotation(&r, POSE_ORTHONORMAL_TOLERANCE) {
        return Err(IngestError::Pose {
            path: path.to_path_buf(),
            line: rows[worst_row(&r)].0,
            source,
        });
    }
    Pose::from_cam_to_world(&m, POSE_ORTHONORMAL_TOLERANCE).map_err(|source| IngestError::Pose {
        path: path.to_path_buf(),
        line: rows[0].0,
        source,
    })
}

/// The row of a near-rotation that deviates most from orthonormality: the largest
/// `sum_j |(R R^T - I)_ij| + |(R R^T - I)_ii|` (a row that lost its unit norm scores
/// higher than the row it is no longer orthogonal to); row 0 for a reflection.
fn worst_row(r: &Matrix3<f64>) -> usize {
    let d = r * r.transpose() - Matrix3::identity();
    let score = |i: usize| (0..3).map(|j| d[(i, j)].abs()).sum::<f64>() + d[(i, i)].abs();
    let mut best = (0, score(0));
    for i in 1..3 {
        if score(i) > best.1 {
            best = (i, score(i));
        }
    }
    best.0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn split_lines_map_like_ace() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("TrainSplit.txt");
        std::fs::write(&p, "sequence1\r\n\r\nsequence10\nsequence003\n  \n").unwrap();
        let s = parse_split_file(&p).unwrap();
        assert_eq!(
            s,
            vec![
                (1, "seq-01".to_string()),
                (3, "seq-10".to_string()),
                (4, "seq-003".to_string())
            ]
        );
    }

    #[test]
    fn worst_row_points_at_the_scaled_row() {
        let mut r = Matrix3::identity();
        r[(2, 1)] = 0.01;
        // Rows 1 and 2 are no longer orthogonal, and row 2 is no longer unit.
        assert_eq!(worst_row(&r), 2);
        let mut r = Matrix3::identity();
        r[(2, 2)] = 1.02;
        assert_eq!(worst_row(&r), 2);
    }
}
