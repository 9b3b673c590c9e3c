//! COLMAP's text model files (`*.txt`), parsed from and written to memory.

mod float;
mod read;
mod write;

pub use float::{push_g, push_g17};
pub use read::{decode, parse_cameras, parse_frames, parse_images, parse_points3d, parse_rigs};
pub use write::{write_cameras, write_frames, write_images, write_points3d, write_rigs};

use crate::error::{ColmapError, Problem, Table};
use crate::model::Reconstruction;
use read::points3d_cut_short;
use std::path::{Path, PathBuf};

/// The contents of a model's text files; rigs and frames are optional (models written
/// before COLMAP 3.12 lack them).
#[derive(Clone, Copy, Debug)]
pub struct TextFiles<'a> {
    pub cameras: &'a str,
    pub images: &'a str,
    pub points3d: &'a str,
    pub rigs: Option<&'a str>,
    pub frames: Option<&'a str>,
}

pub(crate) fn file(dir: &Path, table: Table) -> PathBuf {
    dir.join(format!("{}.txt", table.stem()))
}

/// Parses a whole model; `dir` only names the files in errors. Adds COLMAP's trivial
/// rigs and frames to a legacy model, then checks the model's invariants.
pub fn parse_model(dir: &Path, files: &TextFiles<'_>) -> crate::Result<Reconstruction> {
    let mut rec = Reconstruction {
        cameras: parse_cameras(&file(dir, Table::Cameras), files.cameras)?,
        rigs: match files.rigs {
            Some(t) => parse_rigs(&file(dir, Table::Rigs), t)?,
            None => Vec::new(),
        },
        frames: match files.frames {
            Some(t) => parse_frames(&file(dir, Table::Frames), t)?,
            None => Vec::new(),
        },
        images: parse_images(&file(dir, Table::Images), files.images)?,
        points3d: parse_points3d(&file(dir, Table::Points3D), files.points3d)?,
    };
    rec.add_trivial_rigs_and_frames();
    rec.check().map_err(|e| {
        let path = file(dir, e.table);
        // A points3D.txt cut between two track elements still parses; the tracks it
        // lost then show in the check as 2D points of images.txt whose 3D point does not
        // list them. Name the cut, not the image.
        if tracks_broken(&e.problem)
            && let Some((at, evidence)) = points3d_cut_short(files.points3d, &rec.points3d)
        {
            let then = format!("{}: {}: {}", path.display(), e.at, e.problem);
            return ColmapError::Parse {
                path: file(dir, Table::Points3D),
                at,
                problem: Box::new(Problem::CutShort { evidence, then }),
            };
        }
        e.into_parse(path)
    })?;
    Ok(rec)
}

/// The check's problems that tracks cut short cause.
fn tracks_broken(p: &Problem) -> bool {
    matches!(
        p,
        Problem::DanglingObservation { .. }
            | Problem::TrackMismatch { .. }
            | Problem::UnknownImage(_)
            | Problem::Point2DOutOfRange { .. }
            | Problem::DuplicateObservation { .. }
    )
}
