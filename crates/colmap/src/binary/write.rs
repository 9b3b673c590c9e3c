//! Writers of the binary files, in the order of the records in memory (COLMAP's own
//! order when the model was read from COLMAP's files).

use crate::error::{ColmapError, Location, Problem, RecordRef, Table};
use crate::model::{CameraRecord, Image, Point3D};
use crate::rig::{Frame, Rig, RigidTransform};
use fileio::IoResultExt;
use std::io::Write;
use std::path::Path;

struct Out<'a, W: Write> {
    path: &'a Path,
    w: &'a mut W,
}

impl<W: Write> Out<'_, W> {
    fn bytes(&mut self, b: &[u8]) -> crate::Result<()> {
        Ok(self.w.write_all(b).at(self.path)?)
    }
    fn u8(&mut self, v: u8) -> crate::Result<()> {
        self.bytes(&[v])
    }
    fn u32(&mut self, v: u32) -> crate::Result<()> {
        self.bytes(&v.to_le_bytes())
    }
    fn i32(&mut self, v: i32) -> crate::Result<()> {
        self.bytes(&v.to_le_bytes())
    }
    fn u64(&mut self, v: u64) -> crate::Result<()> {
        self.bytes(&v.to_le_bytes())
    }
    fn f64(&mut self, v: f64) -> crate::Result<()> {
        self.bytes(&v.to_le_bytes())
    }
    fn rigid(&mut self, t: &RigidTransform) -> crate::Result<()> {
        let mut b = [0u8; 56];
        for (c, v) in b.chunks_exact_mut(8).zip(t.qvec.iter().chain(&t.tvec)) {
            c.copy_from_slice(&v.to_le_bytes());
        }
        self.bytes(&b)
    }
    fn count_u32(&self, n: usize, record: RecordRef) -> crate::Result<u32> {
        u32::try_from(n).map_err(|_| invalid(record, Problem::CountOverflow { count: n }))
    }
}

fn invalid(record: RecordRef, problem: Problem) -> ColmapError {
    ColmapError::Invalid {
        at: Location::Record(record),
        problem: Box::new(problem),
    }
}

fn rec(table: Table, index: usize, id: u64) -> RecordRef {
    RecordRef {
        table,
        index,
        id: Some(id),
    }
}

pub fn write_cameras<W: Write>(
    path: &Path,
    w: &mut W,
    cameras: &[CameraRecord],
) -> crate::Result<()> {
    let mut o = Out { path, w };
    o.u64(cameras.len() as u64)?;
    for c in cameras {
        o.u32(c.camera_id)?;
        o.i32(c.camera.model.id())?;
        o.u64(c.camera.width)?;
        o.u64(c.camera.height)?;
        for &p in &c.camera.params {
            o.f64(p)?;
        }
    }
    Ok(())
}

pub fn write_images<W: Write>(path: &Path, w: &mut W, images: &[Image]) -> crate::Result<()> {
    let mut o = Out { path, w };
    o.u64(images.len() as u64)?;
    let mut buf = Vec::new();
    for (i, im) in images.iter().enumerate() {
        if im.name.as_bytes().contains(&0) {
            return Err(invalid(
                rec(Table::Images, i, u64::from(im.image_id)),
                Problem::BadName(im.name.clone()),
            ));
        }
        o.u32(im.image_id)?;
        o.rigid(&im.cam_from_world())?;
        o.u32(im.camera_id)?;
        o.bytes(im.name.as_bytes())?;
        o.u8(0)?;
        o.u64(im.points2d.len() as u64)?;
        buf.clear();
        buf.reserve(im.points2d.len() * 24);
        for p in &im.points2d {
            buf.extend_from_slice(&p.xy[0].to_le_bytes());
            buf.extend_from_slice(&p.xy[1].to_le_bytes());
            buf.extend_from_slice(&p.point3d_id.to_le_bytes());
        }
        o.bytes(&buf)?;
    }
    Ok(())
}

pub fn write_points3d<W: Write>(path: &Path, w: &mut W, points: &[Point3D]) -> crate::Result<()> {
    let mut o = Out { path, w };
    o.u64(points.len() as u64)?;
    let mut buf = Vec::new();
    for p in points {
        buf.clear();
        buf.extend_from_slice(&p.id.to_le_bytes());
        for v in p.xyz {
            buf.extend_from_slice(&v.to_le_bytes());
        }
        buf.extend_from_slice(&p.rgb);
        buf.extend_from_slice(&p.error.to_le_bytes());
        buf.extend_from_slice(&(p.track.len() as u64).to_le_bytes());
        for el in &p.track {
            buf.extend_from_slice(&el.image_id.to_le_bytes());
            buf.extend_from_slice(&el.point2d_idx.to_le_bytes());
        }
        o.bytes(&buf)?;
    }
    Ok(())
}

pub fn write_rigs<W: Write>(path: &Path, w: &mut W, rigs: &[Rig]) -> crate::Result<()> {
    let mut o = Out { path, w };
    o.u64(rigs.len() as u64)?;
    for (i, r) in rigs.iter().enumerate() {
        let at = rec(Table::Rigs, i, u64::from(r.rig_id));
        let Some(reference) = r.ref_sensor else {
            if !r.sensors.is_empty() {
                return Err(invalid(
                    at,
                    Problem::SensorsWithoutReference {
                        count: r.sensors.len(),
                    },
                ));
            }
            o.u32(r.rig_id)?;
            o.u32(0)?;
            continue;
        };
        let n = o.count_u32(r.num_sensors(), at)?;
        o.u32(r.rig_id)?;
        o.u32(n)?;
        o.i32(reference.kind as i32)?;
        o.u32(reference.id)?;
        for s in &r.sensors {
            o.i32(s.sensor.kind as i32)?;
            o.u32(s.sensor.id)?;
            match &s.sensor_from_rig {
                Some(t) => {
                    o.u8(1)?;
                    o.rigid(t)?;
                }
                None => o.u8(0)?,
            }
        }
    }
    Ok(())
}

pub fn write_frames<W: Write>(path: &Path, w: &mut W, frames: &[Frame]) -> crate::Result<()> {
    let mut o = Out { path, w };
    o.u64(frames.len() as u64)?;
    for (i, f) in frames.iter().enumerate() {
        let n = o.count_u32(
            f.data_ids.len(),
            rec(Table::Frames, i, u64::from(f.frame_id)),
        )?;
        o.u32(f.frame_id)?;
        o.u32(f.rig_id)?;
        o.rigid(&f.rig_from_world)?;
        o.u32(n)?;
        for d in &f.data_ids {
            o.i32(d.sensor.kind as i32)?;
            o.u32(d.sensor.id)?;
            o.u64(d.id)?;
        }
    }
    Ok(())
}
