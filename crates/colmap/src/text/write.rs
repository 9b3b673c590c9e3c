//! Writers of the text files, byte for byte as COLMAP's writer lays them out: the same
//! header comments, doubles as `%.17g`, single spaces, `-1` for a missing 3D point, a
//! space after every (X, Y, POINT3D_ID) triple of images.txt and after the ERROR of a
//! point with an empty track.

use super::float::push_g17;
use crate::error::{ColmapError, Location, Problem, RecordRef, Table};
use crate::model::Reconstruction;
use crate::rig::RigidTransform;
use fileio::IoResultExt;
use std::fmt::Write as _;
use std::io::Write;
use std::path::Path;

/// Flushes the line buffer to the writer once it holds this much.
const CHUNK: usize = 1 << 16;

struct Out<'a, W: Write> {
    path: &'a Path,
    w: &'a mut W,
    buf: String,
}

impl<'a, W: Write> Out<'a, W> {
    fn new(path: &'a Path, w: &'a mut W) -> Self {
        Out {
            path,
            w,
            buf: String::with_capacity(CHUNK * 2),
        }
    }

    fn f(&mut self, x: f64) {
        push_g17(&mut self.buf, x);
    }

    fn int(&mut self, v: impl std::fmt::Display) {
        let _ = write!(self.buf, "{v}");
    }

    fn s(&mut self, s: &str) {
        self.buf.push_str(s);
    }

    fn rigid(&mut self, t: &RigidTransform) {
        for (i, &v) in t.qvec.iter().chain(&t.tvec).enumerate() {
            if i > 0 {
                self.buf.push(' ');
            }
            self.f(v);
        }
    }

    fn maybe_flush(&mut self) -> crate::Result<()> {
        if self.buf.len() >= CHUNK {
            self.flush()?;
        }
        Ok(())
    }

    fn flush(&mut self) -> crate::Result<()> {
        self.w.write_all(self.buf.as_bytes()).at(self.path)?;
        self.buf.clear();
        Ok(())
    }
}

/// Names are written with `<<` and read with `>>` by COLMAP: they must be one token.
fn check_name(index: usize, image_id: u32, name: &str) -> crate::Result<()> {
    if name.is_empty() || name.bytes().any(|b| b.is_ascii_whitespace() || b == 0) {
        return Err(ColmapError::Invalid {
            at: Location::Record(RecordRef {
                table: Table::Images,
                index,
                id: Some(u64::from(image_id)),
            }),
            problem: Box::new(Problem::BadName(name.to_string())),
        });
    }
    Ok(())
}

pub fn write_cameras<W: Write>(path: &Path, w: &mut W, rec: &Reconstruction) -> crate::Result<()> {
    let mut o = Out::new(path, w);
    o.s("# Camera list with one line of data per camera:\n");
    o.s("#   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n");
    o.s("# Number of cameras: ");
    o.int(rec.cameras.len());
    o.s("\n");
    for c in &rec.cameras {
        o.int(c.camera_id);
        o.s(" ");
        o.s(c.camera.model.name());
        o.s(" ");
        o.int(c.camera.width);
        o.s(" ");
        o.int(c.camera.height);
        for &p in &c.camera.params {
            o.s(" ");
            o.f(p);
        }
        o.s("\n");
        o.maybe_flush()?;
    }
    o.flush()
}

pub fn write_images<W: Write>(path: &Path, w: &mut W, rec: &Reconstruction) -> crate::Result<()> {
    let mut o = Out::new(path, w);
    o.s("# Image list with two lines of data per image:\n");
    o.s("#   IMAGE_ID, QW, QX, QY, QZ, TX, TY, TZ, CAMERA_ID, NAME\n");
    o.s("#   POINTS2D[] as (X, Y, POINT3D_ID)\n");
    o.s("# Number of images: ");
    o.int(rec.images.len());
    o.s(", mean observations per image: ");
    o.f(rec.mean_observations_per_image());
    o.s("\n");
    for (i, im) in rec.images.iter().enumerate() {
        check_name(i, im.image_id, &im.name)?;
        o.int(im.image_id);
        o.s(" ");
        o.rigid(&im.cam_from_world());
        o.s(" ");
        o.int(im.camera_id);
        o.s(" ");
        o.s(&im.name);
        o.s("\n");
        for p in &im.points2d {
            o.f(p.xy[0]);
            o.s(" ");
            o.f(p.xy[1]);
            o.s(" ");
            if p.has_point3d() {
                o.int(p.point3d_id);
            } else {
                o.s("-1");
            }
            o.s(" ");
            o.maybe_flush()?;
        }
        o.s("\n");
    }
    o.flush()
}

pub fn write_points3d<W: Write>(path: &Path, w: &mut W, rec: &Reconstruction) -> crate::Result<()> {
    let mut o = Out::new(path, w);
    o.s("# 3D point list with one line of data per point:\n");
    o.s("#   POINT3D_ID, X, Y, Z, R, G, B, ERROR, TRACK[] as (IMAGE_ID, POINT2D_IDX)\n");
    o.s("# Number of points: ");
    o.int(rec.points3d.len());
    o.s(", mean track length: ");
    o.f(rec.mean_track_length());
    o.s("\n");
    for p in &rec.points3d {
        o.int(p.id);
        for v in p.xyz {
            o.s(" ");
            o.f(v);
        }
        for c in p.rgb {
            o.s(" ");
            o.int(c);
        }
        o.s(" ");
        o.f(p.error);
        o.s(" ");
        for (k, el) in p.track.iter().enumerate() {
            if k > 0 {
                o.s(" ");
            }
            o.int(el.image_id);
            o.s(" ");
            o.int(el.point2d_idx);
        }
        o.s("\n");
        o.maybe_flush()?;
    }
    o.flush()
}

pub fn write_rigs<W: Write>(path: &Path, w: &mut W, rec: &Reconstruction) -> crate::Result<()> {
    let mut o = Out::new(path, w);
    o.s("# Rig calib list with one line of data per calib:\n");
    o.s("#   RIG_ID, NUM_SENSORS, REF_SENSOR_TYPE, REF_SENSOR_ID, SENSORS[] as (SENSOR_TYPE, SENSOR_ID, HAS_POSE, [QW, QX, QY, QZ, TX, TY, TZ])\n");
    o.s("# Number of rigs: ");
    o.int(rec.rigs.len());
    o.s("\n");
    for (i, r) in rec.rigs.iter().enumerate() {
        if r.ref_sensor.is_none() && !r.sensors.is_empty() {
            return Err(ColmapError::Invalid {
                at: Location::Record(RecordRef {
                    table: Table::Rigs,
                    index: i,
                    id: Some(u64::from(r.rig_id)),
                }),
                problem: Box::new(Problem::SensorsWithoutReference {
                    count: r.sensors.len(),
                }),
            });
        }
        o.int(r.rig_id);
        o.s(" ");
        o.int(r.num_sensors());
        if let Some(s) = r.ref_sensor {
            o.s(" ");
            o.s(s.kind.name());
            o.s(" ");
            o.int(s.id);
        }
        for s in &r.sensors {
            o.s(" ");
            o.s(s.sensor.kind.name());
            o.s(" ");
            o.int(s.sensor.id);
            match &s.sensor_from_rig {
                Some(t) => {
                    o.s(" 1 ");
                    o.rigid(t);
                }
                None => o.s(" 0"),
            }
        }
        o.s("\n");
        o.maybe_flush()?;
    }
    o.flush()
}

pub fn write_frames<W: Write>(path: &Path, w: &mut W, rec: &Reconstruction) -> crate::Result<()> {
    let mut o = Out::new(path, w);
    o.s("# Frame list with one line of data per frame:\n");
    o.s("#   FRAME_ID, RIG_ID, RIG_FROM_WORLD[QW, QX, QY, QZ, TX, TY, TZ], NUM_DATA_IDS, DATA_IDS[] as (SENSOR_TYPE, SENSOR_ID, DATA_ID)\n");
    o.s("# Number of frames: ");
    o.int(rec.frames.len());
    o.s("\n");
    for f in &rec.frames {
        o.int(f.frame_id);
        o.s(" ");
        o.int(f.rig_id);
        o.s(" ");
        o.rigid(&f.rig_from_world);
        o.s(" ");
        o.int(f.data_ids.len());
        for d in &f.data_ids {
            o.s(" ");
            o.s(d.sensor.kind.name());
            o.s(" ");
            o.int(d.sensor.id);
            o.s(" ");
            o.int(d.id);
        }
        o.s("\n");
        o.maybe_flush()?;
    }
    o.flush()
}
