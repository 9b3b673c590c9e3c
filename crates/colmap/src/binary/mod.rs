//! COLMAP's binary model files (`*.bin`), parsed from and written to memory.

mod cursor;
mod read;
mod write;

pub use read::{parse_cameras, parse_frames, parse_images, parse_points3d, parse_rigs};
pub use write::{write_cameras, write_frames, write_images, write_points3d, write_rigs};

use crate::error::Table;
use crate::model::Reconstruction;
use std::path::{Path, PathBuf};

/// The contents of a model's binary files; rigs and frames are optional (models written
/// before COLMAP 3.12 lack them).
#[derive(Clone, Copy, Debug)]
pub struct BinaryFiles<'a> {
    pub cameras: &'a [u8],
    pub images: &'a [u8],
    pub points3d: &'a [u8],
    pub rigs: Option<&'a [u8]>,
    pub frames: Option<&'a [u8]>,
}

pub(crate) fn file(dir: &Path, table: Table) -> PathBuf {
    dir.join(format!("{}.bin", table.stem()))
}

/// Parses a whole model; `dir` only names the files in errors. Adds COLMAP's trivial
/// rigs and frames to a legacy model, then checks the model's invariants.
pub fn parse_model(dir: &Path, files: &BinaryFiles<'_>) -> crate::Result<Reconstruction> {
    let cameras = parse_cameras(&file(dir, Table::Cameras), files.cameras)?;
    let rigs = match files.rigs {
        Some(b) => parse_rigs(&file(dir, Table::Rigs), b)?,
        None => Vec::new(),
    };
    let frames = match files.frames {
        Some(b) => parse_frames(&file(dir, Table::Frames), b)?,
        None => Vec::new(),
    };
    // The two big files are independent: parse them side by side.
    let (images, points3d) = std::thread::scope(|s| {
        let points = s.spawn(|| parse_points3d(&file(dir, Table::Points3D), files.points3d));
        let images = parse_images(&file(dir, Table::Images), files.images);
        let points = points
            .join()
            .unwrap_or_else(|panic| std::panic::resume_unwind(panic));
        (images, points)
    });
    assemble(dir, cameras, images?, points3d?, rigs, frames)
}

/// The last step of reading: COLMAP's trivial rigs/frames for a legacy model, then the
/// model's invariants, with errors naming the binary file of the offending table.
pub(crate) fn assemble(
    dir: &Path,
    cameras: Vec<crate::CameraRecord>,
    images: Vec<crate::Image>,
    points3d: Vec<crate::Point3D>,
    rigs: Vec<crate::Rig>,
    frames: Vec<crate::Frame>,
) -> crate::Result<Reconstruction> {
    let mut rec = Reconstruction {
        cameras,
        images,
        points3d,
        rigs,
        frames,
    };
    rec.add_trivial_rigs_and_frames();
    rec.check().map_err(|e| {
        let path = file(dir, e.table);
        e.into_parse(path)
    })?;
    Ok(rec)
}
