//! Opening a LIMAP output folder of either layout: the layout is detected here
//! (`image_list.txt`: LIMAP 1.x, read by `dir.rs`; `final_model/structures/`: LIMAP 2.0,
//! read by `limap2.rs`), and the files a folder was read from are listed here. Its own
//! file so that the two readers, which both build a [`LimapDir`], do not depend on each
//! other.

use std::path::Path;

use crate::dir::{
    ALLTRACKS_FILE, IMAGE_LIST_FILE, InputFiles, Layout, LimapDir, LimapDirOptions, SegmentsOrigin,
    open_limap1, sorted_files,
};
use crate::error::LimapError;
use crate::limap2;
use crate::structures::{LINES3D_FILE, STRUCTURES2D_FILE};

impl LimapDir {
    /// Reads the folder and refuses it when any consistency check finds an error.
    pub fn load(root: impl AsRef<Path>, options: &LimapDirOptions) -> Result<Self, LimapError> {
        let dir = Self::open_unchecked(root, options)?;
        let report = dir.check();
        if report.is_ok() {
            Ok(dir)
        } else {
            Err(LimapError::Inconsistent {
                root: dir.root.clone(),
                problems: report.errors().cloned().collect(),
            })
        }
    }

    /// Reads and parses every file, without the cross-file checks (see [`LimapDir::check`]).
    /// A file that cannot be read or parsed is still an error.
    pub fn open_unchecked(
        root: impl AsRef<Path>,
        options: &LimapDirOptions,
    ) -> Result<Self, LimapError> {
        let root = root.as_ref().to_path_buf();
        if !root.is_dir() {
            return Err(LimapError::NotADirectory { path: root });
        }
        if !root.join(IMAGE_LIST_FILE).exists() {
            if let Some((output, model_dir)) = limap2::locate(&root) {
                return limap2::open(output, model_dir, options);
            }
            return Err(LimapError::UnknownLayout { root });
        }
        open_limap1(root, options)
    }

    /// The files the folder was read from, in three groups (the import hashes each):
    /// `limap` (1.x: `image_list.txt` and `alltracks.txt`; 2.0: the model's files),
    /// `limap_segments` (the `segments_<id>.txt` files, or `structures2d.bin`) and
    /// `limap_tracks` (1.x: `track*.txt`; 2.0: `lines3D.bin` and `structures2d.bin`).
    pub fn input_files(&self) -> Result<Vec<InputFiles>, LimapError> {
        let s2d = STRUCTURES2D_FILE.to_string();
        let (top_dir, top) = match (&self.layout, &self.model_dir) {
            (Layout::Limap2, Some(model)) => (
                model.clone(),
                limap2::MODEL_FILES
                    .iter()
                    .filter(|f| model.join(f).is_file())
                    .map(|f| f.to_string())
                    .collect(),
            ),
            _ => {
                let mut top = vec![IMAGE_LIST_FILE.to_string()];
                if self.root.join(ALLTRACKS_FILE).is_file() {
                    top.push(ALLTRACKS_FILE.to_string());
                }
                (self.root.clone(), top)
            }
        };
        let segments = if self.segments_origin == SegmentsOrigin::Structures {
            vec![s2d.clone()]
        } else {
            sorted_files(&self.segments_dir, |n| {
                n.starts_with("segments_") && n.ends_with(".txt")
            })?
        };
        let tracks = match self.layout {
            Layout::Limap1 => sorted_files(&self.tracks_dir, |n| {
                n.starts_with("track") && n.ends_with(".txt")
            })?,
            Layout::Limap2 => vec![LINES3D_FILE.to_string(), s2d],
        };
        Ok(vec![
            InputFiles {
                name: "limap",
                dir: top_dir,
                files: top,
            },
            InputFiles {
                name: "limap_segments",
                dir: self.segments_dir.clone(),
                files: segments,
            },
            InputFiles {
                name: "limap_tracks",
                dir: self.tracks_dir.clone(),
                files: tracks,
            },
        ])
    }
}
