//! Parsers of the binary files (layouts in docs/formats.md section 1). Each parser
//! takes the whole file as bytes; counts are checked against the bytes that remain
//! before anything is allocated from them.

use super::cursor::{At, Cursor, f64_at, u32_at, u64_at};
use crate::error::{ColmapError, Location, Problem, RecordRef, Table};
use crate::model::{CameraRecord, Image, Point2D, Point3D, TrackElement};
use crate::rig::{DataId, Frame, Rig, RigSensor, RigidTransform, SensorId, SensorType};
use geometry::{Camera, CameraModel, Pose};
use std::path::Path;

/// Smallest encoded size of each record, to bound counts.
const CAMERA_MIN: usize = 4 + 4 + 8 + 8;
const IMAGE_MIN: usize = 4 + 7 * 8 + 4 + 1 + 8;
const POINT2D_SIZE: usize = 24;
const POINT3D_MIN: usize = 8 + 3 * 8 + 3 + 8 + 8;
const TRACK_ELEMENT_SIZE: usize = 8;
const RIG_MIN: usize = 4 + 4;
const SENSOR_MIN: usize = 4 + 4;
const FRAME_MIN: usize = 4 + 4 + 7 * 8 + 4;
const DATA_ID_SIZE: usize = 4 + 4 + 8;

struct Ctx<'p> {
    path: &'p Path,
    table: Table,
}

impl Ctx<'_> {
    fn err(
        &self,
        (offset, problem): (usize, Problem),
        index: usize,
        id: Option<u64>,
    ) -> ColmapError {
        ColmapError::Parse {
            path: self.path.to_path_buf(),
            at: Location::Byte {
                offset,
                record: Some(RecordRef {
                    table: self.table,
                    index,
                    id,
                }),
            },
            problem: Box::new(problem),
        }
    }

    fn header_err(&self, (offset, problem): (usize, Problem)) -> ColmapError {
        ColmapError::Parse {
            path: self.path.to_path_buf(),
            at: Location::Byte {
                offset,
                record: None,
            },
            problem: Box::new(problem),
        }
    }
}

fn sensor_type(c: &mut Cursor<'_>) -> At<SensorType> {
    let at = c.pos();
    let v = c.i32("sensor type (i32)")?;
    SensorType::from_i32(v).ok_or((at, Problem::UnknownSensorType(v.to_string())))
}

/// A pose read as 7 doubles; rejected unless finite with a unit quaternion.
fn rigid(c: &mut Cursor<'_>, what: &'static str) -> At<RigidTransform> {
    let at = c.pos();
    let v: [f64; 7] = c.f64s(what)?;
    let t = RigidTransform {
        qvec: [v[0], v[1], v[2], v[3]],
        tvec: [v[4], v[5], v[6]],
    };
    Pose::from_qvec_tvec(t.qvec, t.tvec)
        .map_err(|source| (at, Problem::Geometry { what, source }))?;
    Ok(t)
}

pub fn parse_cameras(path: &Path, bytes: &[u8]) -> crate::Result<Vec<CameraRecord>> {
    let ctx = Ctx {
        path,
        table: Table::Cameras,
    };
    let mut c = Cursor::new(bytes);
    let n = c
        .count("cameras", CAMERA_MIN)
        .map_err(|e| ctx.header_err(e))?;
    let mut out = Vec::with_capacity(n);
    for i in 0..n {
        let mut id = None;
        let mut one = |c: &mut Cursor<'_>| -> At<CameraRecord> {
            let camera_id = c.u32("camera_id (u32)")?;
            id = Some(u64::from(camera_id));
            let at = c.pos();
            let model_id = c.i32("model_id (i32)")?;
            let model = CameraModel::from_id(i64::from(model_id)).map_err(|source| {
                (
                    at,
                    Problem::Geometry {
                        what: "camera model",
                        source,
                    },
                )
            })?;
            let width = c.u64("width (u64)")?;
            let height = c.u64("height (u64)")?;
            let at = c.pos();
            let raw = c.take(8 * model.num_params(), "camera params (f64)")?;
            let params: Vec<f64> = raw.chunks_exact(8).map(f64_at).collect();
            let camera = Camera::new(model, width, height, params).map_err(|source| {
                (
                    at,
                    Problem::Geometry {
                        what: "camera params",
                        source,
                    },
                )
            })?;
            Ok(CameraRecord { camera_id, camera })
        };
        let r = one(&mut c);
        out.push(r.map_err(|e| ctx.err(e, i, id))?);
    }
    c.finish().map_err(|e| ctx.header_err(e))?;
    Ok(out)
}

pub fn parse_images(path: &Path, bytes: &[u8]) -> crate::Result<Vec<Image>> {
    let ctx = Ctx {
        path,
        table: Table::Images,
    };
    let mut c = Cursor::new(bytes);
    let n = c
        .count("images", IMAGE_MIN)
        .map_err(|e| ctx.header_err(e))?;
    let mut out = Vec::with_capacity(n);
    for i in 0..n {
        let mut id = None;
        let mut one = |c: &mut Cursor<'_>| -> At<Image> {
            let image_id = c.u32("image_id (u32)")?;
            id = Some(u64::from(image_id));
            let pose = rigid(c, "cam_from_world (7 x f64)")?;
            let camera_id = c.u32("camera_id (u32)")?;
            let at = c.pos();
            let name = std::str::from_utf8(c.c_string()?)
                .map_err(|_| (at, Problem::NameNotUtf8))?
                .to_owned();
            let num = c.count("points2D", POINT2D_SIZE)?;
            let raw = c.take(num * POINT2D_SIZE, "points2D")?;
            let points2d = raw
                .chunks_exact(POINT2D_SIZE)
                .map(|b| Point2D {
                    xy: [f64_at(b), f64_at(&b[8..])],
                    point3d_id: u64_at(&b[16..]),
                })
                .collect();
            Ok(Image {
                image_id,
                qvec: pose.qvec,
                tvec: pose.tvec,
                camera_id,
                name,
                points2d,
            })
        };
        let r = one(&mut c);
        out.push(r.map_err(|e| ctx.err(e, i, id))?);
    }
    c.finish().map_err(|e| ctx.header_err(e))?;
    Ok(out)
}

pub fn parse_points3d(path: &Path, bytes: &[u8]) -> crate::Result<Vec<Point3D>> {
    let ctx = Ctx {
        path,
        table: Table::Points3D,
    };
    let mut c = Cursor::new(bytes);
    let n = c
        .count("points3D", POINT3D_MIN)
        .map_err(|e| ctx.header_err(e))?;
    let mut out = Vec::with_capacity(n);
    for i in 0..n {
        let mut id = None;
        let mut one = |c: &mut Cursor<'_>| -> At<Point3D> {
            let start = c.pos();
            let head = c.take(8 + 24 + 3 + 8, "point3D id, xyz, rgb and error")?;
            let pid = u64_at(head);
            id = Some(pid);
            let xyz = [f64_at(&head[8..]), f64_at(&head[16..]), f64_at(&head[24..])];
            if !xyz.iter().all(|v| v.is_finite()) {
                return Err((start + 8, Problem::NonFinite { what: "xyz" }));
            }
            let rgb = [head[32], head[33], head[34]];
            let error = f64_at(&head[35..]);
            let len = c.count("track elements", TRACK_ELEMENT_SIZE)?;
            let raw = c.take(len * TRACK_ELEMENT_SIZE, "track elements")?;
            let track = raw
                .chunks_exact(TRACK_ELEMENT_SIZE)
                .map(|b| TrackElement {
                    image_id: u32_at(b),
                    point2d_idx: u32_at(&b[4..]),
                })
                .collect();
            Ok(Point3D {
                id: pid,
                xyz,
                rgb,
                error,
                track,
            })
        };
        let r = one(&mut c);
        out.push(r.map_err(|e| ctx.err(e, i, id))?);
    }
    c.finish().map_err(|e| ctx.header_err(e))?;
    Ok(out)
}

pub fn parse_rigs(path: &Path, bytes: &[u8]) -> crate::Result<Vec<Rig>> {
    let ctx = Ctx {
        path,
        table: Table::Rigs,
    };
    let mut c = Cursor::new(bytes);
    let n = c.count("rigs", RIG_MIN).map_err(|e| ctx.header_err(e))?;
    let mut out = Vec::with_capacity(n);
    for i in 0..n {
        let mut id = None;
        let mut one = |c: &mut Cursor<'_>| -> At<Rig> {
            let rig_id = c.u32("rig_id (u32)")?;
            id = Some(u64::from(rig_id));
            let num = c.count_u32("sensors", SENSOR_MIN)?;
            let mut rig = Rig {
                rig_id,
                ref_sensor: None,
                sensors: Vec::with_capacity(num.saturating_sub(1)),
            };
            if num > 0 {
                let kind = sensor_type(c)?;
                let id = c.u32("reference sensor id (u32)")?;
                rig.ref_sensor = Some(SensorId { kind, id });
            }
            for _ in 1..num {
                let kind = sensor_type(c)?;
                let id = c.u32("sensor id (u32)")?;
                let at = c.pos();
                let sensor_from_rig = match c.u8("has_pose (u8)")? {
                    0 => None,
                    1 => Some(rigid(c, "sensor_from_rig (7 x f64)")?),
                    v => {
                        return Err((
                            at,
                            Problem::BadToken {
                                expected: "has_pose 0 or 1",
                                token: v.to_string(),
                            },
                        ));
                    }
                };
                rig.sensors.push(RigSensor {
                    sensor: SensorId { kind, id },
                    sensor_from_rig,
                });
            }
            Ok(rig)
        };
        let r = one(&mut c);
        out.push(r.map_err(|e| ctx.err(e, i, id))?);
    }
    c.finish().map_err(|e| ctx.header_err(e))?;
    Ok(out)
}

pub fn parse_frames(path: &Path, bytes: &[u8]) -> crate::Result<Vec<Frame>> {
    let ctx = Ctx {
        path,
        table: Table::Frames,
    };
    let mut c = Cursor::new(bytes);
    let n = c
        .count("frames", FRAME_MIN)
        .map_err(|e| ctx.header_err(e))?;
    let mut out = Vec::with_capacity(n);
    for i in 0..n {
        let mut id = None;
        let mut one = |c: &mut Cursor<'_>| -> At<Frame> {
            let frame_id = c.u32("frame_id (u32)")?;
            id = Some(u64::from(frame_id));
            let rig_id = c.u32("rig_id (u32)")?;
            let rig_from_world = rigid(c, "rig_from_world (7 x f64)")?;
            let num = c.count_u32("data ids", DATA_ID_SIZE)?;
            let mut data_ids = Vec::with_capacity(num);
            for _ in 0..num {
                let kind = sensor_type(c)?;
                let sensor_id = c.u32("sensor id (u32)")?;
                let data = c.u64("data id (u64)")?;
                data_ids.push(DataId {
                    sensor: SensorId {
                        kind,
                        id: sensor_id,
                    },
                    id: data,
                });
            }
            Ok(Frame {
                frame_id,
                rig_id,
                rig_from_world,
                data_ids,
            })
        };
        let r = one(&mut c);
        out.push(r.map_err(|e| ctx.err(e, i, id))?);
    }
    c.finish().map_err(|e| ctx.header_err(e))?;
    Ok(out)
}
