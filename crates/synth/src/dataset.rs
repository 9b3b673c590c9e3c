//! The dataset before anything is written: the scene, the camera and every frame's
//! pose ([`SynthDataset`]). Its own file because both the writer (`generate.rs`) and the
//! ground truth (`gt/`) work on it, and the writer calls the ground truth.

use crate::error::{Result, SynthError};
use crate::render::Rendered;
use crate::scene::Scene;
use crate::trajectory::{FrameSpec, Split, default_camera, plan_frames, plan_sequences};
use geometry::Camera;
use std::collections::BTreeSet;
use std::sync::Arc;

/// The scene, the camera and every frame's pose: everything needed to render or
/// raycast any frame again, without touching the disk.
#[derive(Clone, Debug)]
pub struct SynthDataset {
    pub scene: Arc<Scene>,
    pub camera: Camera,
    pub frames: Vec<FrameSpec>,
    pub seed: u64,
}

impl SynthDataset {
    /// Builds the scene for `seed` and plans `frames` frames (or the tiny plan).
    pub fn new(frames: usize, seed: u64, tiny: bool) -> Result<Self> {
        let plans = plan_sequences(frames, tiny)?;
        let scene = Scene::shared(seed);
        let frames = plan_frames(&scene, &plans, seed)?;
        Ok(SynthDataset {
            scene,
            camera: default_camera(),
            frames,
            seed,
        })
    }

    /// Drops the training sequences after the first `n` (test frames stay).
    pub fn keep_train_sequences(&mut self, n: usize) -> Result<()> {
        let train = self.sequences(Split::Train);
        if n == 0 || n > train.len() {
            return Err(SynthError::InvalidConfig(format!(
                "train_sequences {n}: the scene has {} training sequences (1..={0})",
                train.len()
            )));
        }
        let dropped: BTreeSet<u32> = train[n..].iter().copied().collect();
        self.frames.retain(|f| !dropped.contains(&f.sequence));
        Ok(())
    }

    pub fn len(&self) -> usize {
        self.frames.len()
    }

    pub fn is_empty(&self) -> bool {
        self.frames.is_empty()
    }

    /// Renders frame `i` (deterministic: the same pixels on every call and thread).
    pub fn render_frame(&self, i: usize) -> Result<Rendered> {
        let f = self.frames.get(i).ok_or(SynthError::FrameIndex {
            index: i,
            count: self.frames.len(),
        })?;
        self.scene.render(&self.camera, &f.pose)
    }

    /// Sequence numbers of a split, ascending.
    pub fn sequences(&self, split: Split) -> Vec<u32> {
        self.frames
            .iter()
            .filter(|f| f.split == split)
            .map(|f| f.sequence)
            .collect::<BTreeSet<_>>()
            .into_iter()
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Fewer training sequences: a subset of the full scene's frames, same poses, same
    /// test frames.
    #[test]
    fn keeping_train_sequences_only_drops_frames() {
        let full = SynthDataset::new(0, 0, true).unwrap();
        let mut part = full.clone();
        part.keep_train_sequences(3).unwrap();
        assert_eq!(part.sequences(Split::Train), vec![1, 2, 4]);
        assert_eq!(part.sequences(Split::Test), full.sequences(Split::Test));
        let kept: Vec<&FrameSpec> = full.frames.iter().filter(|f| f.sequence != 5).collect();
        assert_eq!(part.frames.iter().collect::<Vec<_>>(), kept);
        assert_eq!(part.len(), full.len() - 6);
        for bad in [0, 5] {
            let err = full.clone().keep_train_sequences(bad).unwrap_err();
            assert!(err.to_string().contains("4 training sequences"), "{err}");
        }
    }
}
