//! Descriptors of whole unaugmented frames, described once per run, so that an
//! unaugmented sample needs no image decoding and no front-end call.
//!
//! Two places, filled up front by [`DescriptorCache::prefill`] in the shards' file order:
//! memory up to `descriptor_cache_mib`, and the frames past it in a file under the train
//! folder (`descriptor_spill.rs`), read row by row as samples need them. Before the file
//! existed, frames past the budget were decoded and described again at every use: at a
//! 7-Scenes scene's size (2,000 training frames, 2.4 MB of descriptors each) most of a
//! step was spent waiting for them (docs/performance.md, "A real scene's size").
//!
//! Every keypoint of a kind has the same fixed size, so a subset's descriptors equal the
//! rows of the whole set's (the test `cached_descriptors_are_the_described_ones` holds
//! that): where a frame's rows come from changes the speed of a run, never its samples.

use crate::descriptor_spill::{SpillFile, SpillWriter};
use crate::error::TrainError;
use crate::sample::decode_checked;
use features::FrontEnd;
use image::GrayImage;
use shards::FrameRecord;
use std::collections::HashMap;
use std::path::Path;
use std::sync::{Arc, RwLock};

/// A frame's descriptor rows: (points, N x D; line samples, M x T x D).
pub(crate) type FrameDescriptors = (Vec<f32>, Vec<f32>);

/// The selected rows of one sample: (points, line samples).
pub(crate) type Rows = (Vec<f32>, Vec<f32>);

/// Where the frames past the memory budget go: the file and the key of this run's
/// shards and front-end (a file written for other ones is rebuilt).
#[derive(Clone, Debug)]
pub struct SpillTarget<'a> {
    pub path: &'a Path,
    pub key: [u8; 32],
}

/// Shared by the sample workers: readers take a frame's rows under a read lock, a
/// described frame goes in under a write lock (describing happens outside any lock).
#[derive(Debug, Default)]
pub struct DescriptorCache {
    inner: RwLock<CacheInner>,
    budget_bytes: usize,
    spill: Option<SpillFile>,
    /// With [`DescriptorCache::hold_records`]: every frame's record seen by
    /// [`DescriptorCache::prefill`], without its image.
    records: Option<HeldRecords>,
}

/// Frames' records without their images (`image_bytes` empty), by frame id: what an
/// unaugmented sample of a described frame needs from its shard
/// (`FrameStream::start_with_records`).
pub type HeldRecords = HashMap<u64, FrameRecord>;

#[derive(Debug, Default)]
struct CacheInner {
    frames: HashMap<u64, Arc<FrameDescriptors>>,
    bytes: usize,
}

impl DescriptorCache {
    pub fn new(budget_mib: usize) -> Self {
        DescriptorCache {
            budget_bytes: budget_mib << 20,
            ..Default::default()
        }
    }

    /// The map; a worker that panicked while holding the lock left it consistent (every
    /// change is one insert), so a poisoned lock is used as it is.
    fn read(&self) -> std::sync::RwLockReadGuard<'_, CacheInner> {
        self.inner.read().unwrap_or_else(|p| p.into_inner())
    }

    fn write(&self) -> std::sync::RwLockWriteGuard<'_, CacheInner> {
        self.inner.write().unwrap_or_else(|p| p.into_inner())
    }

    /// Frames held in memory.
    pub fn len(&self) -> usize {
        self.read().frames.len()
    }

    pub fn is_empty(&self) -> bool {
        self.read().frames.is_empty()
    }

    /// Frames held in the spill file.
    pub fn spilled(&self) -> usize {
        self.spill.as_ref().map_or(0, SpillFile::len)
    }

    /// Makes the next [`DescriptorCache::prefill`] keep every frame's record without its
    /// image ([`DescriptorCache::take_records`]). Why: past the shard reader's chunk
    /// cache, reading a sampled frame's labels decompresses the whole chunk around it,
    /// images included; at 2,000 training frames that cost the reader thread about
    /// 30 ms of CPU a step, taken from the step's two threads (the step went from 0.041
    /// to 0.073 s with no data wait; docs/performance.md, "A real scene's size"). The
    /// records cost about 80 KB a frame of the synthetic room (1,250 keypoints).
    pub fn hold_records(&mut self) {
        self.records = Some(HashMap::new());
    }

    /// The records kept by the last prefill (frames whose unaugmented samples need no
    /// image), when every one of them is described (in memory or in the spill file):
    /// otherwise a sample may need an image, and None. Frames not held are read from
    /// their shards as before.
    pub fn take_records(&mut self) -> Option<HeldRecords> {
        let records = self.records.take()?;
        let described =
            |id: &u64| self.contains(*id) || self.spill.as_ref().is_some_and(|s| s.contains(*id));
        records.keys().all(described).then_some(records)
    }

    /// Keeps the frame's record without its image, if its samples never need the image.
    fn hold(&mut self, frame: &FrameRecord) {
        let Some(records) = &mut self.records else {
            return;
        };
        if crate::sample::unaugmented_needs_no_image(frame) {
            records.insert(
                frame.frame_id,
                FrameRecord {
                    image_bytes: Default::default(),
                    ..frame.clone()
                },
            );
        }
    }

    /// The spill file, taken out (to remove it once a run has finished).
    pub fn take_spill(&mut self) -> Option<SpillFile> {
        self.spill.take()
    }

    /// Describes the frames of `paths` (in file order, on the rayon pool, a few frames
    /// at a time): into memory until the budget is full, then, with a `spill` target,
    /// the rest into its file (kept as it is when a file of the same key already holds
    /// every one of them: a resumed run). Without a target the rest are described at
    /// each use. Changes the speed of a run, never its samples.
    pub fn prefill(
        &mut self,
        paths: &[std::path::PathBuf],
        fe: &dyn FrontEnd,
        bar: &indicatif::ProgressBar,
        spill: Option<SpillTarget<'_>>,
    ) -> Result<(), TrainError> {
        let chunk = 2 * rayon::current_num_threads().max(1);
        let mut planned = self.read().bytes;
        let mut batch = Vec::with_capacity(chunk);
        let reader = shards::ShardReader::open(paths)?;
        let order: Vec<u64> = reader.shards().iter().flat_map(|s| s.frame_ids()).collect();
        bar.set_length(order.len() as u64);
        let mut frames = reader.enumerate();
        // Memory first: a prefix of the file order.
        let mut first_past = None;
        for (k, frame) in frames.by_ref() {
            let frame = frame?;
            self.hold(&frame);
            if self.contains(frame.frame_id) {
                bar.inc(1);
                continue;
            }
            // Sized before describing, as `describe_and_keep` does.
            let size = 4 * fe.dim() * rows(&frame, fe);
            if planned + size > self.budget_bytes {
                first_past = Some((k, frame));
                break;
            }
            planned += size;
            batch.push(frame);
            if batch.len() == chunk {
                self.keep(describe_batch(std::mem::take(&mut batch), fe)?, bar);
            }
        }
        self.keep(describe_batch(batch, fe)?, bar);
        let (Some((k, frame)), Some(target)) = (first_past, spill) else {
            return Ok(());
        };
        // The rest into the file, unless this run's file already holds them all.
        let (dim, t) = (fe.dim(), fe.samples_per_line());
        if let Some(s) = SpillFile::open(target.path, &target.key, dim, t)?
            && order[k..]
                .iter()
                .all(|id| self.contains(*id) || s.contains(*id))
        {
            bar.inc((order.len() - k) as u64);
            self.spill = Some(s);
            if self.records.is_some() {
                for (_, frame) in frames {
                    self.hold(&frame?);
                }
            }
            return Ok(());
        }
        let mut writer = SpillWriter::create(target.path, &target.key, dim, t)?;
        let mut batch = vec![frame];
        for (_, frame) in frames {
            let frame = frame?;
            self.hold(&frame);
            batch.push(frame);
            if batch.len() == chunk {
                spill_batch(&mut writer, std::mem::take(&mut batch), fe, bar)?;
            }
        }
        spill_batch(&mut writer, batch, fe, bar)?;
        writer.finish()?;
        let written = SpillFile::open(target.path, &target.key, dim, t)?;
        self.spill = Some(written.ok_or_else(|| {
            TrainError::Config(format!(
                "descriptor file {} could not be read back after writing it",
                target.path.display()
            ))
        })?);
        Ok(())
    }

    fn keep(&self, described: Vec<(u64, FrameDescriptors)>, bar: &indicatif::ProgressBar) {
        for (id, (p, l)) in described {
            self.insert(id, p, l);
            bar.inc(1);
        }
    }

    /// Adds a frame if the budget has room for it; returns what the cache holds for it.
    fn insert(&self, frame_id: u64, p: Vec<f32>, l: Vec<f32>) -> Option<Arc<FrameDescriptors>> {
        let mut inner = self.write();
        if let Some(d) = inner.frames.get(&frame_id) {
            return Some(Arc::clone(d));
        }
        let size = 4 * (p.len() + l.len());
        if inner.bytes + size > self.budget_bytes {
            return None;
        }
        inner.bytes += size;
        let d = Arc::new((p, l));
        inner.frames.insert(frame_id, Arc::clone(&d));
        Some(d)
    }

    /// Whether the frame's descriptors are held in memory.
    pub fn contains(&self, frame_id: u64) -> bool {
        self.read().frames.contains_key(&frame_id)
    }

    /// The rows of the frame's keypoints `points` and segments `segments` (indices into
    /// the frame's arrays), from memory or the spill file; None if neither holds it.
    pub(crate) fn rows(
        &self,
        frame_id: u64,
        points: &[usize],
        segments: &[usize],
        fe: &dyn FrontEnd,
    ) -> Option<Result<Rows, TrainError>> {
        let held = self.read().frames.get(&frame_id).map(Arc::clone);
        match held {
            Some(all) => Some(Ok(select(&all, points, segments, fe))),
            None => self.spill.as_ref()?.rows(frame_id, points, segments),
        }
    }

    /// Describes a frame that is not cached (`image` is its unaugmented image) and keeps
    /// its rows if the budget has room; None (and no work) when it has none.
    pub(crate) fn describe_and_keep(
        &self,
        frame: &FrameRecord,
        image: &GrayImage,
        fe: &dyn FrontEnd,
    ) -> Result<Option<Arc<FrameDescriptors>>, TrainError> {
        // Sized before describing: a frame past the budget costs nothing extra.
        let size = 4 * fe.dim() * rows(frame, fe);
        if self.read().bytes + size > self.budget_bytes {
            return Ok(None);
        }
        let (p, l) = fe.describe(image, &frame.keypoints, &frame.segments)?;
        Ok(self.insert(frame.frame_id, p, l))
    }

    #[cfg(test)]
    pub(crate) fn bytes(&self) -> usize {
        self.read().bytes
    }

    #[cfg(test)]
    pub(crate) fn with_budget_bytes(budget_bytes: usize) -> Self {
        DescriptorCache {
            budget_bytes,
            ..Default::default()
        }
    }
}

/// The rows `points` and `segments` of a whole frame's descriptors, in that order.
/// Whole rows copied as slices (the cost is reading rows scattered over the cache, not
/// the copy: docs/performance.md, "The reader thread's image copy").
pub(crate) fn select(
    (p, l): &FrameDescriptors,
    points: &[usize],
    segments: &[usize],
    fe: &dyn FrontEnd,
) -> Rows {
    let rows_of = |all: &[f32], index: &[usize], width: usize| -> Vec<f32> {
        let mut out = Vec::with_capacity(index.len() * width);
        for &i in index {
            out.extend_from_slice(&all[i * width..(i + 1) * width]);
        }
        out
    };
    let d = fe.dim();
    (
        rows_of(p, points, d),
        rows_of(l, segments, fe.samples_per_line() * d),
    )
}

/// Descriptor rows of a whole frame (keypoints, and T samples per segment).
pub(crate) fn rows(frame: &FrameRecord, fe: &dyn FrontEnd) -> usize {
    frame.keypoints.len() + frame.segments.len() * fe.samples_per_line()
}

/// Decodes the frames side by side, then describes them as one batch (SuperPoint runs
/// one network pass per image size; SIFT describes the images side by side).
fn describe_batch(
    frames: Vec<FrameRecord>,
    fe: &dyn FrontEnd,
) -> Result<Vec<(u64, FrameDescriptors)>, TrainError> {
    use rayon::prelude::*;
    let images: Vec<Result<GrayImage, TrainError>> =
        frames.par_iter().map(decode_checked).collect();
    let images = images.into_iter().collect::<Result<Vec<_>, _>>()?;
    let items: Vec<features::LabelledImage<'_>> = images
        .iter()
        .zip(&frames)
        .map(|(i, f)| (i, f.keypoints.as_slice(), f.segments.as_slice()))
        .collect();
    let described = fe.describe_batch(&items);
    frames
        .iter()
        .zip(described)
        .map(|(f, d)| Ok((f.frame_id, d?)))
        .collect()
}

fn spill_batch(
    writer: &mut SpillWriter,
    frames: Vec<FrameRecord>,
    fe: &dyn FrontEnd,
    bar: &indicatif::ProgressBar,
) -> Result<(), TrainError> {
    for (id, (p, l)) in describe_batch(frames, fe)? {
        writer.push(id, &p, &l)?;
        bar.inc(1);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::augment::AugmentConfig;
    use crate::sample::{Limits, prepare, prepare_with_cache};
    use crate::seeds::{self, Purpose};
    use crate::testutil::{frame, sift_front_end, write_synthetic_shards};

    /// A cached unaugmented sample is exactly the described one, for many subsets; an
    /// augmented one bypasses the cache; a zero budget caches nothing.
    #[test]
    fn cached_descriptors_are_the_described_ones() {
        let f = frame(3, 40, 6, 0.0);
        let fe = sift_front_end();
        let limits = Limits {
            max_keypoints: 12,
            max_lines: 3,
        };
        let cache = DescriptorCache::new(64);
        for seed in 0..6 {
            let mut r1 = seeds::rng(seed, Purpose::Sample, 0);
            let mut r2 = seeds::rng(seed, Purpose::Sample, 0);
            let plain = prepare(&f, &fe, None, &limits, &mut r1).unwrap();
            let cached = prepare_with_cache(&f, &fe, None, &limits, &mut r2, Some(&cache)).unwrap();
            assert_eq!(plain.sample, cached.sample, "seed {seed}");
        }
        assert_eq!(cache.len(), 1);
        // A cached frame's image is not decoded again (the cost it saves).
        let mut broken = f.clone();
        broken.image_bytes.truncate(40);
        let mut r1 = seeds::rng(9, Purpose::Sample, 0);
        let mut r2 = seeds::rng(9, Purpose::Sample, 0);
        let plain = prepare(&f, &fe, None, &limits, &mut r1).unwrap();
        let cached = prepare_with_cache(&f, &fe, None, &limits, &mut r2, Some(&cache)).unwrap();
        assert_eq!(plain.sample, cached.sample);
        let aug = AugmentConfig {
            probability: 1.0,
            ..AugmentConfig::default()
        };
        let fresh = DescriptorCache::new(64);
        let mut r = seeds::rng(1, Purpose::Sample, 0);
        prepare_with_cache(&f, &fe, Some(&aug), &limits, &mut r, Some(&fresh)).unwrap();
        assert!(fresh.is_empty());
        let none = DescriptorCache::new(0);
        let mut r = seeds::rng(1, Purpose::Sample, 0);
        prepare_with_cache(&f, &fe, None, &limits, &mut r, Some(&none)).unwrap();
        assert!(none.is_empty());
    }

    /// The limits of these tests: fewer rows than the synthetic frames have.
    const SMALL_LIMITS: Limits = Limits {
        max_keypoints: 7,
        max_lines: 2,
    };

    /// What one synthetic frame's descriptors take in the cache.
    fn one_frame_bytes(fe: &dyn FrontEnd) -> usize {
        4 * features::SIFT_DIM * rows(&frame(0, 40, 6, 0.0), fe)
    }

    /// Prefilling describes every frame of the shards (up to the budget) exactly as a
    /// sample would: a prefilled cache gives the plain samples.
    #[test]
    fn prefilled_cache_gives_the_described_samples() {
        let dir = tempfile::tempdir().unwrap();
        let paths = write_synthetic_shards(dir.path(), 2, 3, 0.0);
        let fe = sift_front_end();
        let limits = SMALL_LIMITS;
        let mut cache = DescriptorCache::new(64);
        cache
            .prefill(&paths, &fe, &indicatif::ProgressBar::hidden(), None)
            .unwrap();
        assert_eq!(cache.len(), 6);
        for frame in shards::ShardReader::open(&paths).unwrap() {
            let f = frame.unwrap();
            assert!(cache.contains(f.frame_id));
            let mut r1 = seeds::rng(3, Purpose::Sample, f.frame_id);
            let mut r2 = seeds::rng(3, Purpose::Sample, f.frame_id);
            let plain = prepare(&f, &fe, None, &limits, &mut r1).unwrap();
            let cached = prepare_with_cache(&f, &fe, None, &limits, &mut r2, Some(&cache)).unwrap();
            assert_eq!(plain.sample, cached.sample);
        }
        // A budget for about one frame caches a prefix of the file order, no more.
        let one = one_frame_bytes(&fe);
        let mut small = DescriptorCache::with_budget_bytes(one + one / 2);
        small
            .prefill(&paths, &fe, &indicatif::ProgressBar::hidden(), None)
            .unwrap();
        assert!(!small.is_empty() && small.len() < 6, "{}", small.len());
        assert!(small.bytes() <= one + one / 2);
        assert_eq!(small.spilled(), 0);
    }

    /// With a budget for about one frame, the frames past it go to the spill file and
    /// every sample is the described one; a second prefill with the same key reuses the
    /// file untouched, another key rebuilds it.
    #[test]
    fn spilled_frames_give_the_described_samples() {
        let dir = tempfile::tempdir().unwrap();
        let paths = write_synthetic_shards(dir.path(), 2, 3, 0.0);
        let fe = sift_front_end();
        let limits = SMALL_LIMITS;
        let one = one_frame_bytes(&fe);
        let path = dir.path().join("descriptors.spill");
        let target = |key: u8| SpillTarget {
            path: &path,
            key: [key; 32],
        };
        let bar = indicatif::ProgressBar::hidden();
        let mut cache = DescriptorCache::with_budget_bytes(one + one / 2);
        cache.prefill(&paths, &fe, &bar, Some(target(1))).unwrap();
        assert!(!cache.is_empty() && cache.spilled() >= 1);
        assert_eq!(cache.len() + cache.spilled(), 6);
        for frame in shards::ShardReader::open(&paths).unwrap() {
            let f = frame.unwrap();
            for seed in 0..3 {
                let mut r1 = seeds::rng(seed, Purpose::Sample, f.frame_id);
                let mut r2 = seeds::rng(seed, Purpose::Sample, f.frame_id);
                let plain = prepare(&f, &fe, None, &limits, &mut r1).unwrap();
                let cached =
                    prepare_with_cache(&f, &fe, None, &limits, &mut r2, Some(&cache)).unwrap();
                assert_eq!(plain.sample, cached.sample, "frame {}", f.frame_id);
            }
        }
        let written = std::fs::metadata(&path).unwrap().modified().unwrap();
        let mut again = DescriptorCache::with_budget_bytes(one + one / 2);
        again.prefill(&paths, &fe, &bar, Some(target(1))).unwrap();
        assert_eq!(again.spilled(), cache.spilled());
        assert_eq!(
            std::fs::metadata(&path).unwrap().modified().unwrap(),
            written
        );
        let mut other = DescriptorCache::with_budget_bytes(one + one / 2);
        std::thread::sleep(std::time::Duration::from_millis(20));
        other.prefill(&paths, &fe, &bar, Some(target(2))).unwrap();
        assert_ne!(
            std::fs::metadata(&path).unwrap().modified().unwrap(),
            written
        );
        other.take_spill().unwrap().remove().unwrap();
        assert!(!path.exists());
    }

    /// Held records are the shards' records without their images, for every frame whose
    /// samples need no image, whether the frame is described in memory, into the spill
    /// file, or found in a spill file of an earlier run; their samples are the shard
    /// records' samples.
    #[test]
    fn held_records_give_the_shards_samples_without_images() {
        let dir = tempfile::tempdir().unwrap();
        // Positions on a 1/8 px grid go through the identity transform exactly (other
        // values may not: the transform recentres on the principal point and back), so
        // these frames' unaugmented samples need no image; frame 5 keeps its unrounded
        // positions.
        let on_grid = |v: f64| (v * 8.0).round() / 8.0;
        let frames: Vec<FrameRecord> = (0..6)
            .map(|id| {
                let mut f = frame(id, 40, 6, 0.0);
                if id != 5 {
                    f.keypoints
                        .iter_mut()
                        .flatten()
                        .for_each(|v| *v = on_grid(*v));
                    f.segments
                        .iter_mut()
                        .flatten()
                        .for_each(|v| *v = on_grid(*v));
                }
                f
            })
            .collect();
        let paths: Vec<std::path::PathBuf> = frames
            .chunks(3)
            .enumerate()
            .map(|(s, chunk)| {
                let path = dir.path().join(format!("train-{s:05}.mcap"));
                shards::write_shard(&path, chunk, &shards::ShardConfig::default()).unwrap();
                path
            })
            .collect();
        let fe = sift_front_end();
        let limits = SMALL_LIMITS;
        let one = one_frame_bytes(&fe);
        let path = dir.path().join("descriptors.spill");
        let bar = indicatif::ProgressBar::hidden();
        let from_shards: Vec<FrameRecord> = shards::ShardReader::open(&paths)
            .unwrap()
            .map(Result::unwrap)
            .collect();
        // Written, then reused by a second run.
        for run in 0..2 {
            let mut cache = DescriptorCache::with_budget_bytes(one + one / 2);
            cache.hold_records();
            let target = SpillTarget {
                path: &path,
                key: [7; 32],
            };
            cache.prefill(&paths, &fe, &bar, Some(target)).unwrap();
            assert!(cache.spilled() >= 1, "run {run}");
            let records = cache.take_records().expect("every frame is described");
            let needs_none: Vec<u64> = from_shards
                .iter()
                .filter(|f| crate::sample::unaugmented_needs_no_image(f))
                .map(|f| f.frame_id)
                .collect();
            assert_eq!(needs_none, [0, 1, 2, 3, 4], "run {run}");
            assert_eq!(records.len(), needs_none.len(), "run {run}");
            for f in &from_shards {
                let Some(held) = records.get(&f.frame_id) else {
                    continue;
                };
                assert!(held.image_bytes.is_empty());
                let mut same = f.clone();
                same.image_bytes = Default::default();
                // (Compared as text: unlabelled points hold NaN, which is not equal to itself.)
                assert_eq!(format!("{held:?}"), format!("{same:?}"));
                for seed in 0..3 {
                    let mut r1 = seeds::rng(seed, Purpose::Sample, f.frame_id);
                    let mut r2 = seeds::rng(seed, Purpose::Sample, f.frame_id);
                    let from_shard =
                        prepare_with_cache(f, &fe, None, &limits, &mut r1, Some(&cache)).unwrap();
                    let from_memory =
                        prepare_with_cache(held, &fe, None, &limits, &mut r2, Some(&cache))
                            .unwrap();
                    assert_eq!(from_shard.sample, from_memory.sample);
                }
            }
        }
        // Without a spill target the frames past the budget are not described: no records.
        let mut small = DescriptorCache::with_budget_bytes(one + one / 2);
        small.hold_records();
        small.prefill(&paths, &fe, &bar, None).unwrap();
        assert!(small.take_records().is_none());
    }
}
