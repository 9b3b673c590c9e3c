//! LIMAP 2.0's output folder (docs/formats.md section 2, "LIMAP 2.0"), read into the
//! same [`LimapDir`] content as a LIMAP 1.x folder:
//!
//! ```text
//! <output>/final_model/{cameras,images,points3D,rigs,frames}.bin   a COLMAP model
//! <output>/final_model/structures/{structures2d,lines3D,groups3D,wireframe3D}.bin
//! <output>/frontend/line_detections/<detector>/segments/segments_<id>.txt  (deleted by
//!                                                   LIMAP's default clean-up)
//! <output>/metainfos.txt
//! ```
//! - image list: the model's images (id, name), by id;
//! - segments: the `frontend/` segments folder when there is exactly one, else the 2D
//!   lines of `structures2d.bin` (every detection of every image, in detection order);
//! - tracks: the records of `lines3D.bin` in file order (LIMAP writes them by id); a
//!   support `(image, row)` is row `row` of the image's lines in `structures2d.bin`,
//!   whose segment becomes the support's `lines2d` entry;
//! - alltracks: the tracks seen in >= 4 images, as LIMAP 1.x's `alltracks.txt` holds them.

use fileio::IoResultExt;
use std::collections::{BTreeMap, HashSet};
use std::path::{Path, PathBuf};

use crate::alltracks::select_for_alltracks;
use crate::dir::{
    DEFAULT_TRACKS_FOLDER, Layout, LimapDir, LimapDirOptions, SegmentsOrigin, read_segments_dir,
    segments_dir_candidates,
};
use crate::error::LimapError;
use crate::image_list::ImageList;
use crate::segments::Segments;
use crate::structures::{
    GROUPS3D_FILE, LINES3D_FILE, STRUCTURES2D_FILE, WIREFRAME3D_FILE, parse_groups3d,
    parse_lines3d, parse_structures2d, parse_wireframe3d,
};
use crate::track::LineTrack;

pub const FINAL_MODEL_FOLDER: &str = "final_model";
pub const STRUCTURES_FOLDER: &str = "structures";
pub const FRONTEND_FOLDER: &str = "frontend";
/// The COLMAP files of `final_model/` the reader hashes (those present).
pub const MODEL_FILES: [&str; 5] = [
    "cameras.bin",
    "frames.bin",
    "images.bin",
    "points3D.bin",
    "rigs.bin",
];

/// Where a LIMAP 2.0 folder is: `(output folder, final_model folder)`, for a path that is
/// either the output folder (holding `final_model/structures/`) or `final_model/` itself.
pub fn locate(path: &Path) -> Option<(PathBuf, PathBuf)> {
    let inside = path.join(FINAL_MODEL_FOLDER);
    if inside.join(STRUCTURES_FOLDER).is_dir() {
        return Some((path.to_path_buf(), inside));
    }
    if path.join(STRUCTURES_FOLDER).is_dir() && path.join("images.bin").is_file() {
        let output = path
            .parent()
            .filter(|p| !p.as_os_str().is_empty())
            .map(Path::to_path_buf)
            .unwrap_or_else(|| path.to_path_buf());
        return Some((output, path.to_path_buf()));
    }
    None
}

fn read_bytes(path: &Path) -> Result<Vec<u8>, LimapError> {
    Ok(std::fs::read(path).at(path)?)
}

fn binary<T>(
    path: &Path,
    parse: impl FnOnce(&[u8]) -> Result<T, crate::error::BinaryError>,
) -> Result<T, LimapError> {
    let bytes = read_bytes(path)?;
    parse(&bytes).map_err(|source| LimapError::Binary {
        path: path.to_path_buf(),
        source,
    })
}

/// Reads a LIMAP 2.0 folder located by [`locate`].
pub(crate) fn open(
    root: PathBuf,
    model_dir: PathBuf,
    options: &LimapDirOptions,
) -> Result<LimapDir, LimapError> {
    if let Some(t) = &options.tracks_folder
        && t != Path::new(DEFAULT_TRACKS_FOLDER)
    {
        return Err(LimapError::invalid_option(format!(
            "{}: a LIMAP 2.0 folder keeps its tracks in {}/{STRUCTURES_FOLDER}/{LINES3D_FILE}; \
             the tracks folder {} applies to LIMAP 1.x folders only",
            root.display(),
            FINAL_MODEL_FOLDER,
            t.display()
        )));
    }
    let model = colmap::read(&model_dir).map_err(|source| LimapError::Colmap {
        dir: model_dir.clone(),
        source: Box::new(source),
    })?;
    let mut images: Vec<(u32, String)> = model
        .images
        .iter()
        .map(|i| (i.image_id, i.name.clone()))
        .collect();
    images.sort();
    let known: HashSet<u32> = images.iter().map(|(id, _)| *id).collect();
    let image_list = ImageList { images };

    let structures_dir = model_dir.join(STRUCTURES_FOLDER);
    let s2d_path = structures_dir.join(STRUCTURES2D_FILE);
    let structures = binary(&s2d_path, parse_structures2d)?;
    for (k, s) in structures.iter().enumerate() {
        if !known.contains(&s.image_id) {
            return Err(LimapError::Record {
                path: s2d_path.clone(),
                record: format!("record {k} (image {})", s.image_id),
                problem: format!(
                    "image {} is not in the model {}/images.bin",
                    s.image_id,
                    model_dir.display()
                ),
            });
        }
    }
    let l3d_path = structures_dir.join(LINES3D_FILE);
    let lines3d = binary(&l3d_path, parse_lines3d)?;
    // Not needed for the labels, but part of the model: a damaged file is refused.
    for (name, parse) in [
        (
            GROUPS3D_FILE,
            (|b| parse_groups3d(b).map(drop)) as fn(&[u8]) -> _,
        ),
        (WIREFRAME3D_FILE, |b| parse_wireframe3d(b).map(drop)),
    ] {
        let path = structures_dir.join(name);
        if path.exists() {
            binary(&path, parse)?;
        }
    }

    let rows: BTreeMap<u32, &[crate::structures::Line2dRecord]> = structures
        .iter()
        .map(|s| (s.image_id, s.lines.as_slice()))
        .collect();
    let mut tracks = Vec::with_capacity(lines3d.len());
    let mut line3d_ids = Vec::with_capacity(lines3d.len());
    for (k, l) in lines3d.iter().enumerate() {
        let mut lines2d = Vec::with_capacity(l.track.len());
        for (e, &(image_id, row)) in l.track.iter().enumerate() {
            let record = || format!("record {k} (3D line {}), track element {e}", l.id);
            let Some(lines) = rows.get(&image_id) else {
                return Err(LimapError::Record {
                    path: l3d_path.clone(),
                    record: record(),
                    problem: format!("image {image_id} has no record in {STRUCTURES2D_FILE}"),
                });
            };
            let Some(line) = lines.get(row as usize) else {
                return Err(LimapError::Record {
                    path: l3d_path.clone(),
                    record: record(),
                    problem: format!(
                        "line {row} of image {image_id}, but {STRUCTURES2D_FILE} holds {} \
                         line(s) of that image",
                        lines.len()
                    ),
                });
            };
            lines2d.push(line.segment);
        }
        line3d_ids.push(l.id);
        tracks.push(LineTrack {
            line: l.line,
            image_ids: l.track.iter().map(|t| t.0).collect(),
            line_ids: l.track.iter().map(|t| t.1).collect(),
            lines2d: Some(lines2d),
            extras: None,
        });
    }
    let alltracks = Some(
        select_for_alltracks(&tracks)
            .map(|t| LineTrack {
                lines2d: None,
                extras: None,
                ..t.clone()
            })
            .collect(),
    );

    let (segments_dir, segments_origin, segments) = match &options.segments {
        Some(p) => (p.clone(), SegmentsOrigin::Given, read_segments_dir(p)?),
        None => {
            let frontend = root.join(FRONTEND_FOLDER);
            let candidates = segments_dir_candidates(&frontend)?;
            match candidates.len() {
                0 => {
                    let segments: BTreeMap<u32, Segments> = structures
                        .iter()
                        .map(|s| {
                            (
                                s.image_id,
                                Segments::new(s.lines.iter().map(|l| l.segment).collect()),
                            )
                        })
                        .collect();
                    (structures_dir.clone(), SegmentsOrigin::Structures, segments)
                }
                1 => {
                    let dir = candidates.into_iter().next().unwrap_or_default();
                    let segments = read_segments_dir(&dir)?;
                    (dir, SegmentsOrigin::Detected, segments)
                }
                _ => {
                    return Err(LimapError::SegmentsAmbiguous {
                        root: frontend,
                        candidates,
                    });
                }
            }
        }
    };

    Ok(LimapDir {
        root,
        layout: Layout::Limap2,
        model_dir: Some(model_dir),
        image_list,
        segments_dir,
        segments_origin,
        segments,
        tracks_dir: structures_dir,
        tracks,
        line3d_ids: Some(line3d_ids),
        alltracks,
    })
}
