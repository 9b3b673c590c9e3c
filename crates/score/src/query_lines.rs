//! Test images' line segments from a LIMAP-format folder, instead of the front-end's line
//! detector: the user ran the detector that made the map's segments (LIMAP's, e.g.
//! DeepLSD) on the query images too, so query lines and map lines come from one detector
//! (docs/method.md section 6). The folder holds `image_list.txt` (`id, name`) and one
//! segments folder (`line_detections/<detector>/segments/` or `segments/`) of
//! `segments_<id>.txt` files, as LIMAP writes them (docs/formats.md section 2).

use crate::error::ScoreError;
use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};

/// Segments per image name, in COLMAP pixels of the image.
#[derive(Clone, Debug)]
pub struct QuerySegments {
    /// The folder read.
    pub dir: PathBuf,
    /// The segments folder inside it.
    pub segments_dir: PathBuf,
    /// sha256 over image_list.txt and every segments file read, with the scale: a
    /// record input of the score stage.
    pub sha256: String,
    by_name: HashMap<String, Vec<[f64; 4]>>,
}

impl QuerySegments {
    /// Reads `dir`; LIMAP coordinates times `scale` are pixels (LIMAP detects on images
    /// resized to `max_image_dim`).
    pub fn load(dir: &Path, scale: f64) -> Result<Self, ScoreError> {
        let err = |e: limap::LimapError| ScoreError::QuerySegments {
            dir: dir.to_path_buf(),
            reason: e.to_string(),
        };
        if !(scale.is_finite() && scale > 0.0) {
            return Err(ScoreError::Config(format!(
                "query_segment_scale must be positive and finite, got {scale}"
            )));
        }
        let list_path = dir.join(limap::dir::IMAGE_LIST_FILE);
        let list = limap::io::read_image_list(&list_path).map_err(err)?;
        let mut candidates = limap::dir::segments_dir_candidates(dir).map_err(err)?;
        let segments_dir = match candidates.len() {
            1 => candidates.remove(0),
            0 => {
                return Err(ScoreError::QuerySegments {
                    dir: dir.to_path_buf(),
                    reason: "no segments folder (line_detections/<detector>/segments or \
                             segments)"
                        .into(),
                });
            }
            _ => {
                return Err(ScoreError::QuerySegments {
                    dir: dir.to_path_buf(),
                    reason: format!("more than one segments folder: {candidates:?}"),
                });
            }
        };
        let files: BTreeMap<u32, limap::Segments> =
            limap::dir::read_segments_dir(&segments_dir).map_err(err)?;
        let mut by_name = HashMap::new();
        let mut hashed = vec![format!("scale {scale:e}")];
        hashed.push(stage::sha256_file(&list_path)?);
        for (id, name) in &list.images {
            let Some(segments) = files.get(id) else {
                continue;
            };
            let file = segments_dir.join(format!("segments_{id}.txt"));
            hashed.push(format!("{name}\0{}", stage::sha256_file(&file)?));
            let scaled: Vec<[f64; 4]> = segments
                .lines
                .iter()
                .map(|s| [s[0] * scale, s[1] * scale, s[2] * scale, s[3] * scale])
                .collect();
            by_name.insert(name.clone(), scaled);
        }
        Ok(QuerySegments {
            dir: dir.to_path_buf(),
            segments_dir,
            sha256: stage::sha256_bytes(hashed.join("\n").as_bytes()),
            by_name,
        })
    }

    /// The segments of the image `name` (the frames table's name).
    pub fn get(&self, name: &str) -> Result<&[[f64; 4]], String> {
        self.by_name.get(name).map(Vec::as_slice).ok_or_else(|| {
            format!(
                "no segments for {name} in {} (image_list.txt must name it and \
                 segments_<id>.txt must exist)",
                self.dir.display()
            )
        })
    }

    /// How many images have segments.
    pub fn len(&self) -> usize {
        self.by_name.len()
    }

    pub fn is_empty(&self) -> bool {
        self.by_name.is_empty()
    }
}
