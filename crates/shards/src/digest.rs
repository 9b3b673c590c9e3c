//! Source digests: what a shard file is made from, so that a rerun whose inputs changed
//! (frames added before a nightly warm start, a new label variant) rewrites only the
//! shards whose frames changed.
//!
//! A shard's bytes are a pure function of the shard layout, the library string, the
//! writer's configuration, its file name's plan position and its frames (writer.rs). The
//! digest hashes exactly those, each frame as its `pl2map.FrameLabels` message (every
//! field but the image) followed by the sha256 of its image bytes, which also fixes the
//! image format. It is kept next to the shard in `<file>.source.json`, written after the
//! shard: a crash between the two leaves a shard without a digest, which is rewritten. A
//! shard is reused only when that file names the same digest and frames and the shard's
//! sha256 is still the one recorded, so a shard edited or truncated since is rewritten.
//!
//! The manifest (the reproducibility contract, locked under `manifests/`) does not carry
//! the digests: they are a cache index of one folder, not part of what a run produced.

use crate::error::ShardError;
use crate::manifest::ManifestShard;
use crate::plan::ShardPlan;
use crate::record::FrameRecord;
use crate::schema::to_proto;
use crate::writer::{LIBRARY, SHARD_FORMAT_VERSION, ShardConfig};
use prost::Message;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// Suffix of a shard's digest file (`train-00000.mcap.source.json`).
pub const SOURCE_SUFFIX: &str = ".source.json";

/// Accumulates the digest of one planned shard.
pub struct SourceDigest {
    bytes: Vec<u8>,
}

impl SourceDigest {
    pub fn new(config: &ShardConfig, file_name: &str) -> Self {
        let mut bytes = Vec::new();
        // Length-prefixed fields: no two different inputs give the same byte string.
        for field in [
            SHARD_FORMAT_VERSION.to_string().as_bytes(),
            LIBRARY.as_bytes(),
            &config.chunk_size.to_le_bytes(),
            &config.zstd_level.to_le_bytes(),
            file_name.as_bytes(),
        ] {
            push_field(&mut bytes, field);
        }
        SourceDigest { bytes }
    }

    /// Adds a frame. Its image bytes and format are not read: `image_sha256` (the hash
    /// of the image file, which the frames table holds) stands for both.
    pub fn add_frame(&mut self, frame: &FrameRecord, image_sha256: &str) {
        push_field(&mut self.bytes, &to_proto(frame).encode_to_vec());
        push_field(&mut self.bytes, image_sha256.as_bytes());
    }

    /// Hex sha256 of everything added.
    pub fn finish(self) -> String {
        stage::sha256_bytes(&self.bytes)
    }
}

fn push_field(out: &mut Vec<u8>, field: &[u8]) {
    out.extend_from_slice(&(field.len() as u64).to_le_bytes());
    out.extend_from_slice(field);
}

/// The digest file of a written shard.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct SourceFile {
    source_digest: String,
    sha256: String,
    bytes: u64,
    first_frame: u64,
    last_frame: u64,
    frame_count: u64,
}

fn source_path(dir: &Path, file_name: &str) -> PathBuf {
    dir.join(format!("{file_name}{SOURCE_SUFFIX}"))
}

/// Records that `shard` (just written under `dir`) was made from `digest`.
pub(crate) fn save(dir: &Path, shard: &ManifestShard, digest: &str) -> Result<(), ShardError> {
    let file = SourceFile {
        source_digest: digest.to_string(),
        sha256: shard.sha256.clone(),
        bytes: shard.bytes,
        first_frame: shard.first_frame,
        last_frame: shard.last_frame,
        frame_count: shard.frame_count,
    };
    let mut json = serde_json::to_vec_pretty(&file).unwrap_or_default();
    json.push(b'\n');
    stage::write_atomic(source_path(dir, &shard.file), &json)?;
    Ok(())
}

/// The manifest entry of `plan`'s shard under `dir` when it was made from `digest` and
/// is intact; None when it must be written (no digest file, another digest, other
/// frames, a changed or missing shard, or an unreadable digest file).
pub(crate) fn reusable(
    dir: &Path,
    plan: &ShardPlan,
    digest: &str,
) -> Result<Option<ManifestShard>, ShardError> {
    let Ok(text) = std::fs::read(source_path(dir, &plan.file_name)) else {
        return Ok(None);
    };
    let Ok(s) = serde_json::from_slice::<SourceFile>(&text) else {
        return Ok(None);
    };
    let (Some(&first), Some(&last)) = (plan.frame_ids.first(), plan.frame_ids.last()) else {
        return Ok(None);
    };
    if s.source_digest != digest
        || (s.first_frame, s.last_frame, s.frame_count)
            != (first, last, plan.frame_ids.len() as u64)
    {
        return Ok(None);
    }
    let path = dir.join(&plan.file_name);
    match std::fs::metadata(&path) {
        Ok(m) if m.is_file() && m.len() == s.bytes => {}
        _ => return Ok(None),
    }
    if stage::sha256_file(&path)? != s.sha256 {
        return Ok(None);
    }
    Ok(Some(ManifestShard {
        index: plan.index,
        file: plan.file_name.clone(),
        first_frame: s.first_frame,
        last_frame: s.last_frame,
        frame_count: s.frame_count,
        sha256: s.sha256,
        bytes: s.bytes,
    }))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::record::{ImageFormat, Split};
    use geometry::{Camera, CameraModel, Pose};

    fn frame(id: u64) -> FrameRecord {
        let camera = Camera::new(CameraModel::SimplePinhole, 64, 48, vec![50.0, 32.0, 24.0])
            .expect("a valid camera");
        FrameRecord::unlabelled(
            id,
            format!("f{id}.png"),
            Split::Train,
            camera,
            Pose::identity(),
            Vec::new(),
            ImageFormat::Png,
        )
    }

    #[test]
    fn digest_follows_every_input() {
        let config = ShardConfig::default();
        let digest = |config: &ShardConfig, name: &str, frames: &[(FrameRecord, &str)]| {
            let mut d = SourceDigest::new(config, name);
            for (f, sha) in frames {
                d.add_frame(f, sha);
            }
            d.finish()
        };
        let base = digest(&config, "a.mcap", &[(frame(1), "x"), (frame(2), "y")]);
        assert_eq!(
            base,
            digest(&config, "a.mcap", &[(frame(1), "x"), (frame(2), "y")])
        );
        let mut moved = frame(2);
        moved.keypoints.push([1.0, 2.0]);
        moved.point3d_ids.push(-1);
        moved.points3d.push([0.0; 3]);
        moved.point_valid.push(false);
        let others = [
            digest(&config, "b.mcap", &[(frame(1), "x"), (frame(2), "y")]),
            digest(&config, "a.mcap", &[(frame(1), "x"), (frame(2), "z")]),
            digest(&config, "a.mcap", &[(frame(1), "x"), (moved, "y")]),
            digest(&config, "a.mcap", &[(frame(1), "x")]),
            digest(
                &ShardConfig {
                    zstd_level: 4,
                    ..config.clone()
                },
                "a.mcap",
                &[(frame(1), "x"), (frame(2), "y")],
            ),
        ];
        for o in others {
            assert_ne!(o, base);
        }
    }
}
