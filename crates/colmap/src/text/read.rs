//! Parsers of the text files. Lines are trimmed; empty lines and lines starting with
//! `#` are skipped, except the second line of an image in images.txt, which is read
//! unconditionally (an image without 2D points has an empty one). Tokens are separated
//! by whitespace. Every number must parse completely and be finite.

use crate::error::{ColmapError, Location, Problem, RecordRef, Table};
use crate::model::{CameraRecord, INVALID_POINT3D_ID, Image, Point2D, Point3D, TrackElement};
use crate::rig::{DataId, Frame, Rig, RigSensor, RigidTransform, SensorId, SensorType};
use geometry::{Camera, CameraModel, Pose};
use std::path::Path;
use std::str::FromStr;

/// Raw lines with 1-based numbers.
struct Lines<'a> {
    rest: &'a str,
    number: usize,
}

impl<'a> Lines<'a> {
    fn new(text: &'a str) -> Self {
        Lines {
            rest: text,
            number: 0,
        }
    }

    fn next_raw(&mut self) -> Option<(usize, &'a str)> {
        if self.rest.is_empty() {
            return None;
        }
        self.number += 1;
        let (line, rest) = match self.rest.find('\n') {
            Some(i) => (&self.rest[..i], &self.rest[i + 1..]),
            None => (self.rest, ""),
        };
        self.rest = rest;
        Some((self.number, line))
    }

    /// Next line that is neither empty nor a comment.
    fn next_data(&mut self) -> Option<(usize, &'a str)> {
        while let Some((n, line)) = self.next_raw() {
            let t = line.trim();
            if !t.is_empty() && !t.starts_with('#') {
                return Some((n, line));
            }
        }
        None
    }
}

type Fail = Box<(Location, Problem)>;

/// Whitespace-separated tokens of one line, with their columns.
struct Tokens<'a> {
    line: &'a str,
    pos: usize,
    number: usize,
    record: Option<RecordRef>,
}

impl<'a> Tokens<'a> {
    fn new(number: usize, line: &'a str, record: Option<RecordRef>) -> Self {
        Tokens {
            line,
            pos: 0,
            number,
            record,
        }
    }

    fn at(&self, column: usize) -> Location {
        Location::Line {
            line: self.number,
            column,
            record: self.record,
        }
    }

    fn fail(&self, column: usize, problem: Problem) -> Fail {
        Box::new((self.at(column), problem))
    }

    /// Next token and its 1-based column.
    fn next_token(&mut self) -> Option<(usize, &'a str)> {
        let bytes = self.line.as_bytes();
        let mut i = self.pos;
        while i < bytes.len() && bytes[i].is_ascii_whitespace() {
            i += 1;
        }
        if i >= bytes.len() {
            self.pos = i;
            return None;
        }
        let start = i;
        while i < bytes.len() && !bytes[i].is_ascii_whitespace() {
            i += 1;
        }
        self.pos = i;
        Some((start + 1, &self.line[start..i]))
    }

    fn expect(&mut self, expected: &'static str) -> Result<(usize, &'a str), Fail> {
        self.next_token().ok_or_else(|| {
            let column = self
                .line
                .trim_end_matches(|c: char| c.is_ascii_whitespace())
                .len()
                + 1;
            self.fail(column, Problem::MissingToken { expected })
        })
    }

    fn parse<T: FromStr>(&mut self, expected: &'static str) -> Result<(usize, T), Fail> {
        let (col, tok) = self.expect(expected)?;
        tok.parse().map(|v| (col, v)).map_err(|_| {
            self.fail(
                col,
                Problem::BadToken {
                    expected,
                    token: tok.to_string(),
                },
            )
        })
    }

    fn u32(&mut self, expected: &'static str) -> Result<u32, Fail> {
        Ok(self.parse(expected)?.1)
    }

    fn f64(&mut self, expected: &'static str) -> Result<f64, Fail> {
        let (col, tok) = self.expect(expected)?;
        self.finite(col, tok, expected)
    }

    /// A token already taken, as a finite double.
    fn finite(&self, col: usize, tok: &str, expected: &'static str) -> Result<f64, Fail> {
        match tok.parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(v),
            Ok(_) => Err(self.fail(col, Problem::NonFinite { what: expected })),
            Err(_) => Err(self.fail(
                col,
                Problem::BadToken {
                    expected,
                    token: tok.to_string(),
                },
            )),
        }
    }

    /// Column of the next token (or of the end of the line).
    fn peek_column(&self) -> usize {
        let rest = &self.line.as_bytes()[self.pos..];
        let skipped = rest.iter().take_while(|b| b.is_ascii_whitespace()).count();
        self.pos + skipped + 1
    }

    /// A pose as 7 numbers; rejected unless its quaternion has unit norm.
    fn rigid(&mut self, what: &'static str) -> Result<RigidTransform, Fail> {
        let col0 = self.peek_column();
        let mut v = [0.0; 7];
        for slot in v.iter_mut() {
            *slot = self.f64(what)?;
        }
        let t = RigidTransform {
            qvec: [v[0], v[1], v[2], v[3]],
            tvec: [v[4], v[5], v[6]],
        };
        Pose::from_qvec_tvec(t.qvec, t.tvec)
            .map_err(|source| self.fail(col0, Problem::Geometry { what, source }))?;
        Ok(t)
    }

    fn sensor_type(&mut self) -> Result<SensorType, Fail> {
        let (col, tok) = self.expect("sensor type (CAMERA, IMU)")?;
        SensorType::from_name(tok)
            .ok_or_else(|| self.fail(col, Problem::UnknownSensorType(tok.to_string())))
    }

    /// Tokens left on the line (to bound counts read from the line).
    fn remaining(&self) -> usize {
        self.line[self.pos..].split_ascii_whitespace().count()
    }

    fn finish(&mut self) -> Result<(), Fail> {
        if let Some((col, first)) = self.next_token() {
            let count = 1 + self.remaining();
            return Err(self.fail(
                col,
                Problem::ExtraTokens {
                    count,
                    first: first.to_string(),
                },
            ));
        }
        Ok(())
    }
}

// `Fail` is boxed to keep the parsers' Result small; it is unboxed only here.
#[allow(clippy::boxed_local)]
fn wrap(path: &Path, f: Fail) -> ColmapError {
    let (at, problem) = *f;
    ColmapError::Parse {
        path: path.to_path_buf(),
        at,
        problem: Box::new(problem),
    }
}

fn record(table: Table, index: usize, id: Option<u64>) -> Option<RecordRef> {
    Some(RecordRef { table, index, id })
}

/// Text files must be UTF-8 (COLMAP writes ASCII plus the image names' bytes).
pub fn decode<'a>(path: &Path, bytes: &'a [u8]) -> crate::Result<&'a str> {
    std::str::from_utf8(bytes).map_err(|e| ColmapError::Parse {
        path: path.to_path_buf(),
        at: Location::Byte {
            offset: e.valid_up_to(),
            record: None,
        },
        problem: Box::new(Problem::NotUtf8),
    })
}

pub fn parse_cameras(path: &Path, text: &str) -> crate::Result<Vec<CameraRecord>> {
    let mut lines = Lines::new(text);
    let mut out = Vec::new();
    while let Some((n, line)) = lines.next_data() {
        let index = out.len();
        let mut t = Tokens::new(n, line, record(Table::Cameras, index, None));
        let one = |t: &mut Tokens<'_>| -> Result<CameraRecord, Fail> {
            let camera_id = t.u32("CAMERA_ID (unsigned 32-bit integer)")?;
            t.record = record(Table::Cameras, index, Some(u64::from(camera_id)));
            let (col, name) = t.expect("MODEL name")?;
            let model = CameraModel::from_name(name).map_err(|source| {
                t.fail(
                    col,
                    Problem::Geometry {
                        what: "camera model",
                        source,
                    },
                )
            })?;
            let width = t.parse("WIDTH (unsigned integer)")?.1;
            let height = t.parse("HEIGHT (unsigned integer)")?.1;
            let col = t.peek_column();
            let mut params = Vec::with_capacity(model.num_params());
            while let Some((col, tok)) = t.next_token() {
                params.push(t.finite(col, tok, "camera parameter")?);
            }
            Camera::new(model, width, height, params)
                .map_err(|source| {
                    t.fail(
                        col,
                        Problem::Geometry {
                            what: "camera params",
                            source,
                        },
                    )
                })
                .map(|camera| CameraRecord { camera_id, camera })
        };
        out.push(one(&mut t).map_err(|f| wrap(path, f))?);
    }
    Ok(out)
}

pub fn parse_images(path: &Path, text: &str) -> crate::Result<Vec<Image>> {
    let mut lines = Lines::new(text);
    let mut out = Vec::new();
    while let Some((n, line)) = lines.next_data() {
        let index = out.len();
        let mut t = Tokens::new(n, line, record(Table::Images, index, None));
        let head = |t: &mut Tokens<'_>| -> Result<Image, Fail> {
            let image_id = t.u32("IMAGE_ID (unsigned 32-bit integer)")?;
            t.record = record(Table::Images, index, Some(u64::from(image_id)));
            let pose = t.rigid("cam_from_world (QW QX QY QZ TX TY TZ)")?;
            let camera_id = t.u32("CAMERA_ID (unsigned 32-bit integer)")?;
            let name = t.expect("NAME")?.1.to_string();
            t.finish()?;
            Ok(Image {
                image_id,
                qvec: pose.qvec,
                tvec: pose.tvec,
                camera_id,
                name,
                points2d: Vec::new(),
            })
        };
        let mut image = head(&mut t).map_err(|f| wrap(path, f))?;
        let rec = t.record;
        let Some((n2, line2)) = lines.next_raw() else {
            return Err(wrap(
                path,
                Box::new((
                    Location::Line {
                        line: n + 1,
                        column: 1,
                        record: rec,
                    },
                    Problem::MissingPointsLine,
                )),
            ));
        };
        let mut t = Tokens::new(n2, line2, rec);
        let points = |t: &mut Tokens<'_>| -> Result<Vec<Point2D>, Fail> {
            let mut pts = Vec::with_capacity(t.remaining() / 3);
            while let Some((col, tok)) = t.next_token() {
                let x = t.finite(col, tok, "X of a point2D")?;
                let y = t.f64("Y of a point2D")?;
                let (col, tok) = t.expect("POINT3D_ID of a point2D (-1 for none)")?;
                let point3d_id = if tok == "-1" {
                    INVALID_POINT3D_ID
                } else {
                    match tok.parse::<u64>() {
                        Ok(v) if v != INVALID_POINT3D_ID => v,
                        _ => {
                            return Err(t.fail(
                                col,
                                Problem::BadToken {
                                    expected: "POINT3D_ID (unsigned integer or -1)",
                                    token: tok.to_string(),
                                },
                            ));
                        }
                    }
                };
                pts.push(Point2D {
                    xy: [x, y],
                    point3d_id,
                });
            }
            Ok(pts)
        };
        image.points2d = points(&mut t).map_err(|f| wrap(path, f))?;
        out.push(image);
    }
    Ok(out)
}

pub fn parse_points3d(path: &Path, text: &str) -> crate::Result<Vec<Point3D>> {
    let mut lines = Lines::new(text);
    let mut out = Vec::new();
    while let Some((n, line)) = lines.next_data() {
        let index = out.len();
        let mut t = Tokens::new(n, line, record(Table::Points3D, index, None));
        let one = |t: &mut Tokens<'_>| -> Result<Point3D, Fail> {
            let (col, id): (usize, u64) = t.parse("POINT3D_ID (unsigned integer)")?;
            if id == INVALID_POINT3D_ID {
                return Err(t.fail(col, Problem::ReservedPointId));
            }
            t.record = record(Table::Points3D, index, Some(id));
            let xyz = [t.f64("X")?, t.f64("Y")?, t.f64("Z")?];
            let rgb = [
                t.parse::<u8>("R (0-255)")?.1,
                t.parse::<u8>("G (0-255)")?.1,
                t.parse::<u8>("B (0-255)")?.1,
            ];
            let error = t.f64("ERROR")?;
            let mut track = Vec::with_capacity(t.remaining() / 2);
            while let Some((col, tok)) = t.next_token() {
                let image_id = tok.parse().map_err(|_| {
                    t.fail(
                        col,
                        Problem::BadToken {
                            expected: "IMAGE_ID of a track element",
                            token: tok.to_string(),
                        },
                    )
                })?;
                let point2d_idx = t.u32("POINT2D_IDX of a track element")?;
                track.push(TrackElement {
                    image_id,
                    point2d_idx,
                });
            }
            Ok(Point3D {
                id,
                xyz,
                rgb,
                error,
                track,
            })
        };
        out.push(one(&mut t).map_err(|f| wrap(path, f))?);
    }
    Ok(out)
}

pub fn parse_rigs(path: &Path, text: &str) -> crate::Result<Vec<Rig>> {
    let mut lines = Lines::new(text);
    let mut out = Vec::new();
    while let Some((n, line)) = lines.next_data() {
        let index = out.len();
        let mut t = Tokens::new(n, line, record(Table::Rigs, index, None));
        let one = |t: &mut Tokens<'_>| -> Result<Rig, Fail> {
            let rig_id = t.u32("RIG_ID (unsigned 32-bit integer)")?;
            t.record = record(Table::Rigs, index, Some(u64::from(rig_id)));
            let num = t.u32("NUM_SENSORS (unsigned 32-bit integer)")? as usize;
            let mut rig = Rig {
                rig_id,
                ref_sensor: None,
                sensors: Vec::with_capacity(num.saturating_sub(1).min(t.remaining() / 3)),
            };
            if num > 0 {
                let kind = t.sensor_type()?;
                let id = t.u32("REF_SENSOR_ID (unsigned 32-bit integer)")?;
                rig.ref_sensor = Some(SensorId { kind, id });
            }
            for _ in 1..num {
                let kind = t.sensor_type()?;
                let id = t.u32("SENSOR_ID (unsigned 32-bit integer)")?;
                let (col, has_pose) = t.expect("HAS_POSE (0 or 1)")?;
                let sensor_from_rig = match has_pose {
                    "0" => None,
                    "1" => Some(t.rigid("sensor_from_rig (QW QX QY QZ TX TY TZ)")?),
                    other => {
                        return Err(t.fail(
                            col,
                            Problem::BadToken {
                                expected: "HAS_POSE (0 or 1)",
                                token: other.to_string(),
                            },
                        ));
                    }
                };
                rig.sensors.push(RigSensor {
                    sensor: SensorId { kind, id },
                    sensor_from_rig,
                });
            }
            t.finish()?;
            Ok(rig)
        };
        out.push(one(&mut t).map_err(|f| wrap(path, f))?);
    }
    Ok(out)
}

pub fn parse_frames(path: &Path, text: &str) -> crate::Result<Vec<Frame>> {
    let mut lines = Lines::new(text);
    let mut out = Vec::new();
    while let Some((n, line)) = lines.next_data() {
        let index = out.len();
        let mut t = Tokens::new(n, line, record(Table::Frames, index, None));
        let one = |t: &mut Tokens<'_>| -> Result<Frame, Fail> {
            let frame_id = t.u32("FRAME_ID (unsigned 32-bit integer)")?;
            t.record = record(Table::Frames, index, Some(u64::from(frame_id)));
            let rig_id = t.u32("RIG_ID (unsigned 32-bit integer)")?;
            let rig_from_world = t.rigid("rig_from_world (QW QX QY QZ TX TY TZ)")?;
            let num = t.u32("NUM_DATA_IDS (unsigned 32-bit integer)")? as usize;
            let mut data_ids = Vec::with_capacity(num.min(t.remaining() / 3));
            for _ in 0..num {
                let kind = t.sensor_type()?;
                let sensor_id = t.u32("SENSOR_ID (unsigned 32-bit integer)")?;
                let id = t.parse("DATA_ID (unsigned integer)")?.1;
                data_ids.push(DataId {
                    sensor: SensorId {
                        kind,
                        id: sensor_id,
                    },
                    id,
                });
            }
            t.finish()?;
            Ok(Frame {
                frame_id,
                rig_id,
                rig_from_world,
                data_ids,
            })
        };
        out.push(one(&mut t).map_err(|f| wrap(path, f))?);
    }
    Ok(out)
}

/// The number of points the header of a points3D.txt announces (COLMAP writes
/// `# Number of points: N, mean track length: M`), and its line. (M is the images'
/// observations per point, not a count of the file's track elements: it cannot tell a
/// cut track from a model that was inconsistent when written.)
fn points3d_header(text: &str) -> Option<(usize, u64)> {
    let mut lines = Lines::new(text);
    while let Some((n, line)) = lines.next_raw() {
        let t = line.trim();
        if !t.is_empty() && !t.starts_with('#') {
            return None;
        }
        if let Some(rest) = t.strip_prefix("# Number of points:") {
            let count = rest.split(',').next()?.trim().parse().ok()?;
            return Some((n, count));
        }
    }
    None
}

/// Whether `text`, the points3D.txt that gave `points`, shows that it was cut short:
/// it ends without the line end COLMAP writes after every point (a cut inside a line,
/// at a token boundary or not), or it holds fewer points than its header says (a cut
/// at a line end). Then the place (the last point's line) and what shows it. Only asked
/// when the model's check fails: a file a tool wrote without the last line end, or with
/// a header it did not update, is read as it is while the model is consistent.
pub(crate) fn points3d_cut_short(text: &str, points: &[Point3D]) -> Option<(Location, String)> {
    let mut lines = Lines::new(text);
    let mut last = None;
    while let Some((n, line)) = lines.next_data() {
        last = Some((n, line));
    }
    let (line_no, line) = last?;
    let record = points.last().map(|p| RecordRef {
        table: Table::Points3D,
        index: points.len() - 1,
        id: Some(p.id),
    });
    let at = |column| Location::Line {
        line: line_no,
        column,
        record,
    };
    if !text.ends_with('\n') {
        let column = line.trim_end().len() + 1;
        return Some((
            at(column),
            "it ends inside this line, without the line end COLMAP writes after every point".into(),
        ));
    }
    let (header_line, announced) = points3d_header(text)?;
    (announced > points.len() as u64).then(|| {
        (
            at(1),
            format!(
                "its header (line {header_line}) says {announced} points, but it holds {} \
                 (this line is the last)",
                points.len()
            ),
        )
    })
}
