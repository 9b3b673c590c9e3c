//! Cambridge Landmarks: `<scene>/{dataset_train.txt, dataset_test.txt,
//! reconstruction.nvm, seqN/frameXXXXX.png}`.
//!
//! - Split files: three header lines (`Visual Landmark Dataset V1`,
//!   `ImageFile, Camera Position [X Y Z W P Q R]`, an empty line), then rows
//!   `seqN/frameXXXXX.png X Y Z W P Q R`: the camera centre and the w-first quaternion of
//!   the world-to-camera rotation.
//! - Poses whose world-to-camera translation has a component beyond a threshold (in
//!   absolute value; 1e4 for Cambridge Landmarks, `outlier_max_abs_translation` of the
//!   descriptor `datasets/cambridge.toml`) are outliers of the published reconstruction;
//!   ACE's `setup_cambridge.py` skips them with the same rule, and so do we (listed in
//!   the table's `excluded`).
//! - Focal lengths come from `reconstruction.nvm` (one camera per image; names end in
//!   `.jpg` where the files are `.png`, see [`super::nvm`]); the principal point is the
//!   image centre, the image size is read from the file header.
//! - The file names are the descriptor's (`[layouts.cambridge]`).

use super::error::{IngestError, Result};
use super::text::{numbered_lines, parse_err, parse_f64, read_text};
use geometry::Pose;
use std::path::Path;

/// One row of a split file.
#[derive(Clone, Debug, PartialEq)]
pub struct SplitRow {
    pub name: String,
    pub line: usize,
    /// World-to-camera.
    pub pose: Pose,
}

/// A dataset-relative name must stay inside the scene folder.
pub(crate) fn check_relative_name(path: &Path, line: usize, name: &str) -> Result<()> {
    let bad = name.starts_with('/')
        || name.contains('\\')
        || name
            .split('/')
            .any(|c| c.is_empty() || c == "." || c == "..");
    if bad {
        return Err(parse_err(
            path,
            line,
            format!("expected a relative image path like seq1/frame00001.png, got {name:?}"),
        ));
    }
    Ok(())
}

/// Reads `dataset_train.txt` / `dataset_test.txt`.
pub fn read_split_file(path: &Path) -> Result<Vec<SplitRow>> {
    let text = read_text(path, "Cambridge split file")?;
    let mut lines = numbered_lines(&text);
    let mut header =
        |line_no: usize, check: &dyn Fn(&str) -> bool, expected: &str| match lines.next() {
            Some((line, l)) if check(l.trim()) => Ok(line),
            Some((line, l)) => Err(parse_err(
                path,
                line,
                format!(
                    "expected the header line {line_no} ({expected}), got {:?}",
                    l.trim()
                ),
            )),
            None => Err(parse_err(
                path,
                line_no,
                format!("expected the header line {line_no} ({expected}), the file ends"),
            )),
        };
    header(
        1,
        &|l| l.starts_with("Visual Landmark Dataset"),
        "`Visual Landmark Dataset V1`",
    )?;
    header(
        2,
        &|l| l.starts_with("ImageFile"),
        "`ImageFile, Camera Position [X Y Z W P Q R]`",
    )?;
    header(3, &|l| l.is_empty(), "an empty line")?;

    let mut rows = Vec::new();
    for (line, l) in lines {
        let t: Vec<&str> = l.split_whitespace().collect();
        if t.is_empty() {
            continue;
        }
        if t.len() != 8 {
            return Err(parse_err(
                path,
                line,
                format!(
                    "expected `image X Y Z W P Q R` (8 fields), found {}",
                    t.len()
                ),
            ));
        }
        check_relative_name(path, line, t[0])?;
        let mut v = [0.0; 7];
        for (x, tok) in v.iter_mut().zip(&t[1..]) {
            *x = parse_f64(path, line, tok, "a pose value")?;
        }
        let pose = Pose::from_centre_qvec([v[0], v[1], v[2]], [v[3], v[4], v[5], v[6]]).map_err(
            |source| IngestError::Pose {
                path: path.to_path_buf(),
                line,
                source,
            },
        )?;
        rows.push(SplitRow {
            name: t[0].to_string(),
            line,
            pose,
        });
    }
    Ok(rows)
}

/// Why a pose is an outlier under ACE's rule (a world-to-camera translation component
/// beyond `max_abs_translation` metres), or None.
pub fn outlier_reason(pose: &Pose, max_abs_translation: f64) -> Option<String> {
    let t = pose.tvec();
    let max = t.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    (max > max_abs_translation).then(|| {
        format!(
            "world-to-camera translation [{}, {}, {}] has |t_i| = {max} > {max_abs_translation} \
             (outlier pose; ACE's setup_cambridge.py rule)",
            t[0], t[1], t[2]
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const HEADER: &str =
        "Visual Landmark Dataset V1\nImageFile, Camera Position [X Y Z W P Q R]\n\n";

    fn parse(text: &str) -> Result<Vec<SplitRow>> {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("dataset_train.txt");
        std::fs::write(&p, text).unwrap();
        read_split_file(&p)
    }

    #[test]
    fn rows_are_centre_and_world_to_camera_quaternion() {
        // 90 degrees about z: q = (cos 45, 0, 0, sin 45); centre (1, 2, 3).
        let h = std::f64::consts::FRAC_1_SQRT_2;
        let rows = parse(&format!(
            "{HEADER}seq1/frame00001.png 1 2 3 {h} 0 0 {h}\r\n\n"
        ))
        .unwrap();
        assert_eq!(rows.len(), 1);
        assert_eq!(rows[0].line, 4);
        let p = rows[0].pose;
        // R maps x to y; t = -R c = -(-2, 1, 3).
        let t = p.tvec();
        assert!(
            (t[0] - 2.0).abs() < 1e-12 && (t[1] + 1.0).abs() < 1e-12 && (t[2] + 3.0).abs() < 1e-12
        );
        assert!((p.centre() - geometry::Vector3::new(1.0, 2.0, 3.0)).norm() < 1e-12);
    }

    #[test]
    fn header_is_required() {
        let e = parse("seq1/frame00001.png 1 2 3 1 0 0 0\n").unwrap_err();
        assert!(
            matches!(&e, IngestError::Parse { line: 1, message, .. } if message.contains("Visual Landmark Dataset")),
            "{e}"
        );
        let e =
            parse("Visual Landmark Dataset V1\nseq1/frame00001.png 1 2 3 1 0 0 0\n").unwrap_err();
        assert!(matches!(e, IngestError::Parse { line: 2, .. }), "{e}");
        let e = parse(
            "Visual Landmark Dataset V1\nImageFile, Camera Position\nseq1/frame00001.png 1 2 3 1 0 0 0\n",
        )
        .unwrap_err();
        assert!(matches!(e, IngestError::Parse { line: 3, .. }), "{e}");
    }

    #[test]
    fn malformed_rows_name_the_line() {
        for (row, want) in [
            ("seq1/frame00001.png 1 2 3 1 0 0", "8 fields"),
            ("seq1/frame00001.png 1 2 x 1 0 0 0", "expected a number"),
            ("../frame00001.png 1 2 3 1 0 0 0", "relative image path"),
            ("/abs/frame00001.png 1 2 3 1 0 0 0", "relative image path"),
        ] {
            match parse(&format!("{HEADER}{row}\n")) {
                Err(IngestError::Parse {
                    line: 4, message, ..
                }) => {
                    assert!(message.contains(want), "{row}: {message}")
                }
                other => panic!("{row}: {other:?}"),
            }
        }
        for row in [
            "seq1/frame00001.png 1 2 3 2 0 0 0",
            "seq1/frame00001.png 1 NaN 3 1 0 0 0",
        ] {
            assert!(
                matches!(
                    parse(&format!("{HEADER}{row}\n")),
                    Err(IngestError::Pose { line: 4, .. })
                ),
                "{row}"
            );
        }
    }

    #[test]
    fn outlier_rule_is_on_the_largest_translation_component() {
        let ok = Pose::from_centre_qvec([9999.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0]).unwrap();
        assert!(outlier_reason(&ok, 1e4).is_none());
        let bad = Pose::from_centre_qvec([0.0, -10000.5, 0.0], [1.0, 0.0, 0.0, 0.0]).unwrap();
        let why = outlier_reason(&bad, 1e4).unwrap();
        assert!(why.contains("|t_i| = 10000.5 > 10000 "), "{why}");
    }
}
