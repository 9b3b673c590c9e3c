//! What goes into each frame's record: the frames table's row (name, split, camera,
//! pose, image file) and, for a training frame, the label tables' camera and pose (in
//! place of the frames table's), points and lines; the image file must still be the one
//! ingested. Also each planned shard's source digest, made of the same records without
//! their images.

use super::error::ShardStageError;
use crate::{FrameRecord, ImageFormat, ShardConfig, ShardError, ShardPlan, SourceDigest};
use std::collections::HashMap;
use std::ops::Range;
use std::path::PathBuf;
use tables::{Frame, LabelTables};
use thiserror::Error;

/// Why one frame could not be loaded (reported by the shards crate with its frame id).
#[derive(Debug, Error)]
pub(super) enum SourceError {
    #[error(transparent)]
    Read(#[from] fileio::IoError),
    #[error(
        "{}: the file changed since ingest (sha256 {actual}, the frames table says {expected})",
        path.display()
    )]
    Changed {
        path: PathBuf,
        expected: String,
        actual: String,
    },
    #[error("{}: not a PNG or JPEG file", path.display())]
    Format { path: PathBuf },
    /// Ingest checked every image; this one was damaged afterwards (or ingested by a
    /// version without the check).
    #[error("{}: {reason}; ingest the dataset again from a whole copy", path.display())]
    Damaged { path: PathBuf, reason: String },
    #[error("frame {0} is not in the plan's tables")]
    Unknown(u64),
}

/// One frame's record: labels for training frames, none for test frames.
pub(super) struct Source<'a> {
    pub(super) frames: HashMap<u64, &'a Frame>,
    pub(super) labels: &'a LabelTables,
    /// frame id -> (pose row, point rows, line rows)
    pub(super) train: HashMap<u64, (usize, Range<usize>, Range<usize>)>,
}

pub(super) fn ranges_by_frame(ids: impl Iterator<Item = u32>) -> HashMap<u32, Range<usize>> {
    let mut out: HashMap<u32, Range<usize>> = HashMap::new();
    for (i, f) in ids.enumerate() {
        out.entry(f)
            .and_modify(|r| r.end = i + 1)
            .or_insert(i..i + 1);
    }
    out
}

impl Source<'_> {
    /// The frame's record without its image (bytes empty, format a placeholder) and the
    /// image's content hash from the frames table: what its shard's digest is made of.
    pub(super) fn describe(&self, frame_id: u64) -> Result<(FrameRecord, &Frame), SourceError> {
        let f = *self
            .frames
            .get(&frame_id)
            .ok_or(SourceError::Unknown(frame_id))?;
        let split = f.split;
        let mut rec = FrameRecord {
            label_source: self.labels.source,
            ..FrameRecord::unlabelled(
                frame_id,
                f.name.clone(),
                split,
                f.camera.clone(),
                f.pose,
                Vec::new(),
                ImageFormat::Png,
            )
        };
        if let Some((pose_row, prange, lrange)) = self.train.get(&frame_id) {
            let view = &self.labels.poses[*pose_row];
            rec.camera = view.camera.clone();
            rec.pose = view.pose;
            for p in &self.labels.points[prange.clone()] {
                rec.keypoints.push(p.xy);
                rec.point3d_ids.push(p.point3d_id);
                rec.points3d.push(p.xyz.unwrap_or([f64::NAN; 3]));
                rec.point_valid.push(p.xyz.is_some());
            }
            for l in &self.labels.lines[lrange.clone()] {
                rec.segments.push(l.segment);
                rec.track_ids.push(l.track_id);
                let e = l.endpoints.unwrap_or([[f64::NAN; 3]; 2]);
                rec.lines3d
                    .push([e[0][0], e[0][1], e[0][2], e[1][0], e[1][1], e[1][2]]);
                rec.line_valid.push(l.endpoints.is_some());
            }
        }
        Ok((rec, f))
    }

    /// The frame's record with its image file, which must still be the one ingested.
    pub(super) fn load(&self, frame_id: u64) -> Result<FrameRecord, SourceError> {
        let (mut rec, f) = self.describe(frame_id)?;
        // Within bounds: no device or FIFO, the pixel limit checked on the header first
        // (crates/fileio/src/image.rs).
        let bytes = fileio::image::read_image(&f.path)?;
        let actual = stage::sha256_bytes(&bytes);
        if actual != f.content_hash {
            return Err(SourceError::Changed {
                path: f.path.clone(),
                expected: f.content_hash.clone(),
                actual,
            });
        }
        rec.image_format = ImageFormat::sniff(&bytes).ok_or_else(|| SourceError::Format {
            path: f.path.clone(),
        })?;
        // A shard never holds a frame that cannot be decoded: the structure is walked to
        // its end (cheap next to compression); ingest decoded the pixels.
        tables::image_file::check_complete(&bytes).map_err(|reason| SourceError::Damaged {
            path: f.path.clone(),
            reason,
        })?;
        rec.image_bytes = bytes.into();
        Ok(rec)
    }

    /// The source digest of every planned shard (`crate::SourceDigest`).
    pub(super) fn digests(
        &self,
        plans: &[ShardPlan],
        config: &ShardConfig,
    ) -> Result<Vec<String>, ShardStageError> {
        plans
            .iter()
            .map(|plan| {
                let mut d = SourceDigest::new(config, &plan.file_name);
                for &id in &plan.frame_ids {
                    let (rec, f) = self.describe(id).map_err(|e| {
                        ShardStageError::Shards(ShardError::Source {
                            frame_id: id,
                            source: Box::new(e),
                        })
                    })?;
                    d.add_frame(&rec, &f.content_hash);
                }
                Ok(d.finish())
            })
            .collect()
    }
}
