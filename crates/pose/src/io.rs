//! Text inputs of `pl2map pose`.
//!
//! Correspondence files: UTF-8 text, one correspondence per line, fields separated by
//! whitespace, `#` starts a comment (whole line or after the fields), blank lines are
//! skipped. Pixels follow COLMAP (centre of the top-left pixel at (0.5, 0.5)).
//! - points: `x y X Y Z`
//! - lines: `x1 y1 x2 y2 X1 Y1 Z1 X2 Y2 Z2` (a detected 2D segment and a 3D segment on
//!   the same line; the endpoints need not correspond)
//!
//! Camera string: `MODEL WIDTH HEIGHT PARAMS...` as in COLMAP's cameras.txt without the
//! id, e.g. `PINHOLE 640 480 525 525 320 240`.

use crate::matches::{LineMatch, PointMatch};
use fileio::IoResultExt;
use geometry::lines::{Segment2, Segment3};
use geometry::{Camera, CameraModel, GeometryError};
use nalgebra::{Vector2, Vector3};
use std::path::{Path, PathBuf};
use thiserror::Error;

/// What is wrong with a correspondence file, and where.
#[derive(Debug, Error)]
pub enum InputError {
    /// The message says "cannot read", as it always has (crates/cli/tests/pose_cli.rs).
    /// No `#[source]`: the message holds the cause's text already, and a source would
    /// add its `<path>: <error>` once more to the CLI's cause chain
    /// (crates/cli/src/main.rs, `error_text`).
    #[error("{}: cannot read: {}", .0.path.display(), .0.source)]
    Io(fileio::IoError),
    #[error("{path}: not UTF-8 text (invalid byte at offset {offset}, line {line})")]
    NotUtf8 {
        path: PathBuf,
        offset: usize,
        line: usize,
    },
    #[error("{path}:{line}: expected {expected} numbers ({format}), found {found}")]
    FieldCount {
        path: PathBuf,
        line: usize,
        expected: usize,
        found: usize,
        format: &'static str,
    },
    #[error("{path}:{line}: field {field} ({name}) is not a finite number: {text:?}")]
    BadNumber {
        path: PathBuf,
        line: usize,
        field: usize,
        name: &'static str,
        text: String,
    },
    #[error("{path}:{line}: the {which} segment has coincident endpoints")]
    DegenerateSegment {
        path: PathBuf,
        line: usize,
        which: &'static str,
    },
}

/// What is wrong with a camera string.
#[derive(Debug, Error, PartialEq)]
pub enum CameraSpecError {
    #[error("camera: expected \"MODEL WIDTH HEIGHT PARAMS...\", got {0:?}")]
    Shape(String),
    #[error("camera: {0}")]
    Model(GeometryError),
    #[error("camera: {what} must be a positive integer, got {text:?}")]
    Size { what: &'static str, text: String },
    #[error("camera: parameter {index} ({name}) is not a finite number: {text:?}")]
    Param {
        index: usize,
        name: String,
        text: String,
    },
}

const POINT_FIELDS: [&str; 5] = ["x", "y", "X", "Y", "Z"];
const LINE_FIELDS: [&str; 10] = ["x1", "y1", "x2", "y2", "X1", "Y1", "Z1", "X2", "Y2", "Z2"];

/// The data lines of a file: (1-based line number, fields).
fn records(text: &str) -> impl Iterator<Item = (usize, Vec<&str>)> {
    text.lines().enumerate().filter_map(|(i, line)| {
        let data = line.split('#').next().unwrap_or("");
        let fields: Vec<&str> = data.split_whitespace().collect();
        (!fields.is_empty()).then_some((i + 1, fields))
    })
}

fn numbers<const N: usize>(
    path: &Path,
    line: usize,
    fields: &[&str],
    names: &[&'static str; N],
    format: &'static str,
) -> Result<[f64; N], InputError> {
    if fields.len() != N {
        return Err(InputError::FieldCount {
            path: path.to_path_buf(),
            line,
            expected: N,
            found: fields.len(),
            format,
        });
    }
    let mut out = [0.0; N];
    for (k, text) in fields.iter().enumerate() {
        match text.parse::<f64>() {
            Ok(v) if v.is_finite() => out[k] = v,
            _ => {
                return Err(InputError::BadNumber {
                    path: path.to_path_buf(),
                    line,
                    field: k + 1,
                    name: names[k],
                    text: text.to_string(),
                });
            }
        }
    }
    Ok(out)
}

/// Parses point correspondences from `text`; `path` names the source in errors.
pub fn parse_points(text: &str, path: &Path) -> Result<Vec<PointMatch>, InputError> {
    records(text)
        .map(|(line, f)| {
            let v = numbers(path, line, &f, &POINT_FIELDS, "x y X Y Z")?;
            Ok(PointMatch {
                pixel: Vector2::new(v[0], v[1]),
                world: Vector3::new(v[2], v[3], v[4]),
            })
        })
        .collect()
}

/// Parses line correspondences from `text`; `path` names the source in errors.
pub fn parse_lines(text: &str, path: &Path) -> Result<Vec<LineMatch>, InputError> {
    records(text)
        .map(|(line, f)| {
            let v = numbers(
                path,
                line,
                &f,
                &LINE_FIELDS,
                "x1 y1 x2 y2 X1 Y1 Z1 X2 Y2 Z2",
            )?;
            let segment = Segment2::new(Vector2::new(v[0], v[1]), Vector2::new(v[2], v[3]));
            let world = Segment3::new(
                Vector3::new(v[4], v[5], v[6]),
                Vector3::new(v[7], v[8], v[9]),
            );
            let degenerate = |which| InputError::DegenerateSegment {
                path: path.to_path_buf(),
                line,
                which,
            };
            if segment.start == segment.end {
                return Err(degenerate("2D"));
            }
            if world.start == world.end {
                return Err(degenerate("3D"));
            }
            Ok(LineMatch { segment, world })
        })
        .collect()
}

fn read_text(path: &Path) -> Result<String, InputError> {
    let bytes = std::fs::read(path).at(path).map_err(InputError::Io)?;
    String::from_utf8(bytes).map_err(|e| {
        let offset = e.utf8_error().valid_up_to();
        let line = 1 + e.as_bytes()[..offset]
            .iter()
            .filter(|&&b| b == b'\n')
            .count();
        InputError::NotUtf8 {
            path: path.to_path_buf(),
            offset,
            line,
        }
    })
}

/// Reads a points file (`x y X Y Z` per line).
pub fn read_points(path: &Path) -> Result<Vec<PointMatch>, InputError> {
    parse_points(&read_text(path)?, path)
}

/// Reads a lines file (`x1 y1 x2 y2 X1 Y1 Z1 X2 Y2 Z2` per line).
pub fn read_lines(path: &Path) -> Result<Vec<LineMatch>, InputError> {
    parse_lines(&read_text(path)?, path)
}

/// Parses `MODEL WIDTH HEIGHT PARAMS...` (model names as COLMAP's, case-insensitive).
pub fn parse_camera(spec: &str) -> Result<Camera, CameraSpecError> {
    let f: Vec<&str> = spec.split_whitespace().collect();
    if f.len() < 3 {
        return Err(CameraSpecError::Shape(spec.to_string()));
    }
    let model =
        CameraModel::from_name(&f[0].to_ascii_uppercase()).map_err(CameraSpecError::Model)?;
    let size = |what: &'static str, text: &str| {
        text.parse::<u64>()
            .ok()
            .filter(|&v| v > 0)
            .ok_or_else(|| CameraSpecError::Size {
                what,
                text: text.to_string(),
            })
    };
    let width = size("width", f[1])?;
    let height = size("height", f[2])?;
    let names = model.param_names();
    let mut params = Vec::with_capacity(f.len() - 3);
    for (index, text) in f[3..].iter().enumerate() {
        match text.parse::<f64>() {
            Ok(v) if v.is_finite() => params.push(v),
            _ => {
                return Err(CameraSpecError::Param {
                    index,
                    name: names.get(index).unwrap_or(&"extra").to_string(),
                    text: text.to_string(),
                });
            }
        }
    }
    Camera::new(model, width, height, params).map_err(CameraSpecError::Model)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p() -> &'static Path {
        Path::new("pts.txt")
    }

    #[test]
    fn points_with_comments_and_blank_lines() {
        let text = "# header\n\n 10.5 20.5  1 2 3 # trailing\n\t1e1 2E0 -1 -2 -3.5\n";
        let pts = parse_points(text, p()).unwrap();
        assert_eq!(pts.len(), 2);
        assert_eq!(pts[0].pixel, Vector2::new(10.5, 20.5));
        assert_eq!(pts[1].world, Vector3::new(-1.0, -2.0, -3.5));
    }

    #[test]
    fn point_errors_name_file_line_and_field() {
        let e = parse_points("1 2 3 4 5\n1 2 3 4\n", p()).unwrap_err();
        assert_eq!(
            e.to_string(),
            "pts.txt:2: expected 5 numbers (x y X Y Z), found 4"
        );
        let e = parse_points("# c\n1 2 3 four 5\n", p()).unwrap_err();
        assert_eq!(
            e.to_string(),
            "pts.txt:2: field 4 (Y) is not a finite number: \"four\""
        );
        let e = parse_points("1 2 3 4 nan\n", p()).unwrap_err();
        assert!(
            matches!(
                e,
                InputError::BadNumber {
                    line: 1,
                    field: 5,
                    ..
                }
            ),
            "{e}"
        );
        let e = parse_points("1 2 3 4 inf\n", p()).unwrap_err();
        assert!(matches!(e, InputError::BadNumber { .. }));
    }

    #[test]
    fn lines_and_degenerate_segments() {
        let l = parse_lines("1 2 3 4 0 0 1 1 0 1\n", Path::new("l.txt")).unwrap();
        assert_eq!(l[0].segment.end, Vector2::new(3.0, 4.0));
        assert_eq!(l[0].world.end, Vector3::new(1.0, 0.0, 1.0));
        let e = parse_lines("\n1 2 1 2 0 0 1 1 0 1\n", Path::new("l.txt")).unwrap_err();
        assert_eq!(
            e.to_string(),
            "l.txt:2: the 2D segment has coincident endpoints"
        );
        let e = parse_lines("1 2 3 4 0 0 1 0 0 1\n", Path::new("l.txt")).unwrap_err();
        assert!(matches!(
            e,
            InputError::DegenerateSegment { which: "3D", .. }
        ));
        let e = parse_lines("1 2 3 4 0 0 1 0 0\n", Path::new("l.txt")).unwrap_err();
        assert!(matches!(
            e,
            InputError::FieldCount {
                expected: 10,
                found: 9,
                ..
            }
        ));
    }

    #[test]
    fn files_missing_and_not_utf8() {
        let dir = tempfile::tempdir().unwrap();
        let missing = dir.path().join("nope.txt");
        let e = read_points(&missing).unwrap_err();
        assert!(e.to_string().contains("nope.txt: cannot read"), "{e}");
        let bad = dir.path().join("bad.txt");
        std::fs::write(&bad, b"1 2 3 4 5\n1 2 \xff 4 5\n").unwrap();
        let e = read_points(&bad).unwrap_err();
        assert!(
            matches!(
                e,
                InputError::NotUtf8 {
                    offset: 14,
                    line: 2,
                    ..
                }
            ),
            "{e}"
        );
    }

    #[test]
    fn camera_strings() {
        let c = parse_camera("PINHOLE 640 480 525 525 320 240").unwrap();
        assert_eq!(c.model, CameraModel::Pinhole);
        assert_eq!((c.width, c.height), (640, 480));
        let c = parse_camera("  opencv 100 50 1 2 3 4 0.1 0.01 0 0 ").unwrap();
        assert_eq!(c.model, CameraModel::OpenCv);
        assert!(matches!(
            parse_camera("PINHOLE 640"),
            Err(CameraSpecError::Shape(_))
        ));
        assert!(matches!(
            parse_camera("PINHOL 640 480 1 2 3 4"),
            Err(CameraSpecError::Model(_))
        ));
        assert!(matches!(
            parse_camera("PINHOLE 640 480 1 2 3"),
            Err(CameraSpecError::Model(GeometryError::ParamCount {
                expected: 4,
                got: 3,
                ..
            }))
        ));
        assert_eq!(
            parse_camera("PINHOLE 0 480 1 2 3 4")
                .unwrap_err()
                .to_string(),
            "camera: width must be a positive integer, got \"0\""
        );
        assert_eq!(
            parse_camera("SIMPLE_PINHOLE 10 10 500 x 5")
                .unwrap_err()
                .to_string(),
            "camera: parameter 1 (cx) is not a finite number: \"x\""
        );
    }
}
