//! A LIMAP output folder (`cfg.output_dir` of line triangulation), in either layout:
//! LIMAP 1.x (below) or LIMAP 2.0 (`final_model/`, see the `limap2` module). The layout is
//! detected (`open.rs`): `image_list.txt` makes a 1.x folder, `final_model/structures/` (or a path
//! that is `final_model/` itself) a 2.0 folder. LIMAP 1.x:
//!
//! ```text
//! image_list.txt
//! line_detections/<detector>/segments/segments_<image id>.txt
//! finaltracks/track_<i>.txt          (i = 0..n-1, no gaps)
//! alltracks.txt                      (optional here)
//! ```
//! The segments folder is never guessed silently: it is either given, or the only candidate
//! among `line_detections/*/segments` and `segments/`, and [`LimapDir::segments_origin`]
//! says which.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use fileio::IoResultExt;
use serde::Serialize;

use crate::alltracks::{AlltracksLayout, select_for_alltracks};
use crate::check::{CheckReport, check};
use crate::error::LimapError;
use crate::image_list::ImageList;
use crate::io::{
    read_alltracks, read_image_list, read_segments, read_track, read_track_allow_legacy,
    temp_sibling, write_alltracks, write_image_list, write_segments, write_track,
};
use crate::segments::{Segments, segments_file_name};
use crate::track::LineTrack;

pub const IMAGE_LIST_FILE: &str = "image_list.txt";
pub const ALLTRACKS_FILE: &str = "alltracks.txt";
/// LIMAP's default `output_folder`.
pub const DEFAULT_TRACKS_FOLDER: &str = "finaltracks";
pub const LINE_DETECTIONS_FOLDER: &str = "line_detections";
pub const SEGMENTS_FOLDER: &str = "segments";

#[derive(Debug, Clone, Default)]
pub struct LimapDirOptions {
    /// The segments folder; `None` auto-detects it (exactly one candidate must exist).
    pub segments: Option<PathBuf>,
    /// The track folder, relative to the LIMAP folder; `None` is `finaltracks`.
    pub tracks_folder: Option<PathBuf>,
    /// Also read track files of older LIMAP versions, which stop after the line ids. Off by
    /// default because a truncated file looks the same.
    pub allow_legacy_tracks: bool,
}

/// How the segments folder was chosen.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum SegmentsOrigin {
    /// Passed by the caller.
    Given,
    /// The only candidate found in the folder.
    Detected,
    /// LIMAP 2.0 without its `frontend/` folder: the 2D lines of `structures2d.bin`.
    Structures,
}

/// Which LIMAP wrote the folder.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Layout {
    /// `image_list.txt`, `finaltracks/`, `alltracks.txt`, segments text files.
    Limap1,
    /// `final_model/`: a COLMAP model and `structures/*.bin`.
    Limap2,
}

impl Layout {
    pub fn name(self) -> &'static str {
        match self {
            Layout::Limap1 => "LIMAP 1.x",
            Layout::Limap2 => "LIMAP 2.0",
        }
    }
}

/// Everything of a LIMAP folder the labels need, whichever layout it has.
#[derive(Debug, Clone)]
pub struct LimapDir {
    /// The LIMAP output folder (for a path given as `final_model/`, its parent).
    pub root: PathBuf,
    pub layout: Layout,
    /// LIMAP 2.0: the `final_model/` folder the image list comes from.
    pub model_dir: Option<PathBuf>,
    /// LIMAP 1.x: `image_list.txt`; LIMAP 2.0: the model's images by id.
    pub image_list: ImageList,
    pub segments_dir: PathBuf,
    pub segments_origin: SegmentsOrigin,
    /// Segments per image id.
    pub segments: BTreeMap<u32, Segments>,
    /// LIMAP 1.x: the track folder; LIMAP 2.0: `final_model/structures/`.
    pub tracks_dir: PathBuf,
    /// `track_<i>.txt` at index i (LIMAP 2.0: the records of `lines3D.bin` in file order).
    pub tracks: Vec<LineTrack>,
    /// LIMAP 2.0: the id of each track in `lines3D.bin`.
    pub line3d_ids: Option<Vec<u64>>,
    /// `alltracks.txt`, when present (LIMAP 2.0: the tracks seen in >= 4 images, always).
    pub alltracks: Option<Vec<LineTrack>>,
}

/// A group of files a [`LimapDir`] was read from: a folder and file names in it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct InputFiles {
    /// `limap` (image list, alltracks / the model), `limap_segments` or `limap_tracks`.
    pub name: &'static str,
    pub dir: PathBuf,
    pub files: Vec<String>,
}

impl LimapDir {
    /// Runs every consistency check.
    pub fn check(&self) -> CheckReport {
        check(
            &self.image_list,
            &self.segments,
            &self.tracks,
            self.alltracks.as_deref(),
        )
    }
}

/// Reads a LIMAP 1.x folder (`root` holds `image_list.txt`), without the cross-file
/// checks.
pub(crate) fn open_limap1(
    root: PathBuf,
    options: &LimapDirOptions,
) -> Result<LimapDir, LimapError> {
    let image_list = read_image_list(root.join(IMAGE_LIST_FILE))?;
    let (segments_dir, segments_origin) = match &options.segments {
        Some(p) => (p.clone(), SegmentsOrigin::Given),
        None => (detect_segments_dir(&root)?, SegmentsOrigin::Detected),
    };
    let segments = read_segments_dir(&segments_dir)?;
    let tracks_dir = root.join(
        options
            .tracks_folder
            .as_deref()
            .unwrap_or(Path::new(DEFAULT_TRACKS_FOLDER)),
    );
    let tracks = read_tracks_dir(&tracks_dir, options.allow_legacy_tracks)?;
    let all_path = root.join(ALLTRACKS_FILE);
    let alltracks = if all_path.exists() {
        Some(read_alltracks(&all_path)?)
    } else {
        None
    };
    Ok(LimapDir {
        root,
        layout: Layout::Limap1,
        model_dir: None,
        image_list,
        segments_dir,
        segments_origin,
        segments,
        tracks_dir,
        tracks,
        line3d_ids: None,
        alltracks,
    })
}

/// Segments folders that exist under a LIMAP folder: `line_detections/*/segments` and
/// `segments`, sorted.
pub fn segments_dir_candidates(root: &Path) -> Result<Vec<PathBuf>, LimapError> {
    let mut out = Vec::new();
    let detections = root.join(LINE_DETECTIONS_FOLDER);
    if detections.is_dir() {
        for entry in sorted_entries(&detections)? {
            let candidate = entry.join(SEGMENTS_FOLDER);
            if candidate.is_dir() {
                out.push(candidate);
            }
        }
    }
    let plain = root.join(SEGMENTS_FOLDER);
    if plain.is_dir() {
        out.push(plain);
    }
    Ok(out)
}

fn detect_segments_dir(root: &Path) -> Result<PathBuf, LimapError> {
    let mut candidates = segments_dir_candidates(root)?;
    match candidates.len() {
        1 => Ok(candidates.remove(0)),
        0 => Err(LimapError::SegmentsNotFound {
            root: root.to_path_buf(),
            looked_for: format!(
                "{LINE_DETECTIONS_FOLDER}/*/{SEGMENTS_FOLDER} and {SEGMENTS_FOLDER}"
            ),
        }),
        _ => Err(LimapError::SegmentsAmbiguous {
            root: root.to_path_buf(),
            candidates,
        }),
    }
}

fn sorted_entries(dir: &Path) -> Result<Vec<PathBuf>, LimapError> {
    let read = std::fs::read_dir(dir).at(dir)?;
    let mut out = Vec::new();
    for entry in read {
        out.push(entry.at(dir)?.path());
    }
    out.sort();
    Ok(out)
}

/// The names of the plain files of `dir` that `keep` accepts, sorted.
pub(crate) fn sorted_files(
    dir: &Path,
    keep: impl Fn(&str) -> bool,
) -> Result<Vec<String>, LimapError> {
    let mut out = Vec::new();
    for path in sorted_entries(dir)? {
        let name = file_name(&path);
        if keep(&name) && path.is_file() {
            out.push(name);
        }
    }
    out.sort();
    Ok(out)
}

fn file_name(path: &Path) -> String {
    path.file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default()
}

/// `digits` as written by Python/C++ for a non-negative integer: no sign, no leading zero.
fn canonical_index(digits: &str) -> Option<u64> {
    let canonical = !digits.is_empty()
        && digits.bytes().all(|b| b.is_ascii_digit())
        && (digits == "0" || !digits.starts_with('0'));
    if canonical { digits.parse().ok() } else { None }
}

/// Reads every `segments_<id>.txt` of a folder; other files are ignored.
pub fn read_segments_dir(dir: &Path) -> Result<BTreeMap<u32, Segments>, LimapError> {
    if !dir.is_dir() {
        return Err(LimapError::NotADirectory {
            path: dir.to_path_buf(),
        });
    }
    let mut out = BTreeMap::new();
    for path in sorted_entries(dir)? {
        let name = file_name(&path);
        let Some(middle) = name
            .strip_prefix("segments_")
            .and_then(|n| n.strip_suffix(".txt"))
        else {
            continue;
        };
        let id = canonical_index(middle)
            .and_then(|v| u32::try_from(v).ok())
            .ok_or_else(|| LimapError::BadSegmentsFileName {
                dir: dir.to_path_buf(),
                name: name.clone(),
            })?;
        out.insert(id, read_segments(&path)?);
    }
    Ok(out)
}

/// Reads a track folder as LIMAP's `read_folder_linetracks` does: it counts the files named
/// `track*.txt` and reads `track_0.txt` .. `track_<count-1>.txt`. Any gap, or a counted file
/// that is not one of those, is an error.
pub fn read_tracks_dir(dir: &Path, allow_legacy: bool) -> Result<Vec<LineTrack>, LimapError> {
    if !dir.is_dir() {
        return Err(LimapError::NotADirectory {
            path: dir.to_path_buf(),
        });
    }
    let mut indices = Vec::new();
    for path in sorted_entries(dir)? {
        let name = file_name(&path);
        if !(name.starts_with("track") && name.ends_with(".txt")) {
            continue;
        }
        let index = name
            .strip_prefix("track_")
            .and_then(|n| n.strip_suffix(".txt"))
            .and_then(canonical_index)
            .ok_or_else(|| LimapError::StrayTrackFile {
                dir: dir.to_path_buf(),
                name: name.clone(),
            })?;
        indices.push(index);
    }
    let count = indices.len();
    indices.sort_unstable();
    // Canonical names are distinct, so 0..count is complete iff the largest index is count-1;
    // otherwise the first position whose index is off names the missing file.
    if let Some(missing) = (0..count).find(|&i| indices[i] != i as u64) {
        return Err(LimapError::MissingTrack {
            dir: dir.to_path_buf(),
            count,
            missing,
        });
    }
    (0..count)
        .map(|i| {
            let path = dir.join(track_file_name(i));
            if allow_legacy {
                read_track_allow_legacy(path)
            } else {
                read_track(path)
            }
        })
        .collect()
}

pub fn track_file_name(index: usize) -> String {
    format!("track_{index}.txt")
}

/// Writes a LIMAP output folder: `image_list.txt`, the segments under
/// `line_detections/<detector>/segments/`, `finaltracks/` and `alltracks.txt` (tracks seen
/// in at least 4 images). Folders are built beside their final place and renamed into it,
/// replacing an older one, so no stale `track_<i>.txt` survives.
pub fn write_limap_dir(
    root: impl AsRef<Path>,
    detector: &str,
    image_list: &ImageList,
    segments: &BTreeMap<u32, Segments>,
    tracks: &[LineTrack],
) -> Result<(), LimapError> {
    let root = root.as_ref();
    if detector.is_empty() || detector.contains(['/', '\\']) || detector == "." || detector == ".."
    {
        return Err(LimapError::invalid(
            "LIMAP folder",
            format!("detector name {detector:?} is not a folder name"),
        ));
    }
    let seg_parent = root.join(LINE_DETECTIONS_FOLDER).join(detector);
    std::fs::create_dir_all(&seg_parent).at(&seg_parent)?;
    replace_dir(&seg_parent.join(SEGMENTS_FOLDER), |dir| {
        for (id, segs) in segments {
            write_segments(dir.join(segments_file_name(*id)), segs)?;
        }
        Ok(())
    })?;
    replace_dir(&root.join(DEFAULT_TRACKS_FOLDER), |dir| {
        for (i, t) in tracks.iter().enumerate() {
            write_track(dir.join(track_file_name(i)), t)?;
        }
        Ok(())
    })?;
    write_alltracks(
        root.join(ALLTRACKS_FILE),
        select_for_alltracks(tracks),
        AlltracksLayout::Limap,
    )?;
    write_image_list(root.join(IMAGE_LIST_FILE), image_list)
}

fn replace_dir(
    target: &Path,
    fill: impl FnOnce(&Path) -> Result<(), LimapError>,
) -> Result<(), LimapError> {
    let staging = temp_sibling(target);
    if staging.exists() {
        std::fs::remove_dir_all(&staging).at(&staging)?;
    }
    std::fs::create_dir_all(&staging).at(&staging)?;
    if let Err(e) = fill(&staging) {
        let _ = std::fs::remove_dir_all(&staging);
        return Err(e);
    }
    if target.exists() {
        let mut old = staging.clone().into_os_string();
        old.push(".old");
        let old = PathBuf::from(old);
        std::fs::rename(target, &old).at(target)?;
        std::fs::rename(&staging, target).at(target)?;
        std::fs::remove_dir_all(&old).at(&old)?;
    } else {
        std::fs::rename(&staging, target).at(target)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn canonical_indices() {
        assert_eq!(canonical_index("0"), Some(0));
        assert_eq!(canonical_index("12"), Some(12));
        assert_eq!(canonical_index("012"), None);
        assert_eq!(canonical_index("+1"), None);
        assert_eq!(canonical_index(""), None);
    }
}
