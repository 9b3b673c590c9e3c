//! Frames from a list of shard files, in a seeded order, prefetched on a background
//! thread.
//!
//! Order of one epoch (a pure function of the seed and the epoch number): the shards are
//! visited in a seeded random order, each shard's frames in file order, through a shuffle
//! buffer of `shuffle_buffer` frames (a full buffer emits a uniformly drawn element).
//! Reads therefore stay within a window of the shards, as a streaming reader wants,
//! while frames of different shards mix. The order is computed on frame ids alone, so a
//! stream can start at any position (resume) without reading the frames before it.
//!
//! Position `p` of the endless stream is frame `p mod n` of epoch `p / n` (n frames per
//! epoch). The background thread decodes frames and runs a caller-given preparation
//! function on them (augmentation, descriptors), `prefetch` items ahead of the consumer.

use crate::error::TrainError;
use crate::seeds::{self, Purpose};
use rand::Rng;
use rand::seq::SliceRandom;
use shards::{FrameRecord, ReaderOptions, ShardReader};
use std::path::PathBuf;
use std::sync::mpsc::{Receiver, SyncSender, sync_channel};
use std::thread::JoinHandle;

/// A frame of the stream: index of its shard in the given list, and its id.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct FrameRef {
    pub shard: usize,
    pub frame_id: u64,
}

/// The order of one epoch over shards holding `shard_frames[s]` (frame ids in file order).
pub fn epoch_order(
    shard_frames: &[Vec<u64>],
    shuffle_buffer: usize,
    seed: u64,
    epoch: u64,
) -> Vec<FrameRef> {
    let mut rng = seeds::rng(seed, Purpose::EpochOrder, epoch);
    let mut shard_order: Vec<usize> = (0..shard_frames.len()).collect();
    shard_order.shuffle(&mut rng);
    let total: usize = shard_frames.iter().map(Vec::len).sum();
    let capacity = shuffle_buffer.max(1);
    let mut buffer: Vec<FrameRef> = Vec::with_capacity(capacity);
    let mut out = Vec::with_capacity(total);
    for &s in &shard_order {
        for &frame_id in &shard_frames[s] {
            buffer.push(FrameRef { shard: s, frame_id });
            if buffer.len() == capacity {
                let j = rng.random_range(0..buffer.len());
                out.push(buffer.swap_remove(j));
            }
        }
    }
    while !buffer.is_empty() {
        let j = rng.random_range(0..buffer.len());
        out.push(buffer.swap_remove(j));
    }
    out
}

/// Stream settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StreamConfig {
    pub shuffle_buffer: usize,
    /// Prepared items kept ready ahead of the consumer.
    pub prefetch: usize,
    pub seed: u64,
    /// Decompressed shard chunks the reader keeps (bytes; see
    /// `shards::ReaderOptions::cache_bytes`). Speed only: the shuffle buffer reads
    /// frames out of file order, and without it most reads decompress a whole chunk.
    pub chunk_cache_bytes: u64,
}

/// Where the stream is: the endless position and the frame there.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StreamPosition {
    pub position: u64,
    pub epoch: u64,
    pub frame: FrameRef,
}

type Item<T> = Result<(StreamPosition, T), TrainError>;

/// The endless, prefetched stream of prepared frames.
pub struct FrameStream<T: Send + 'static> {
    rx: Option<Receiver<Item<T>>>,
    handle: Option<JoinHandle<()>>,
    frames_per_epoch: usize,
}

impl<T: Send + 'static> FrameStream<T> {
    /// Opens `paths` and starts the background thread at stream position `start`.
    /// `prepare(position, frame)` runs on that thread; its result is what [`Self::next`]
    /// returns.
    pub fn start<F>(
        paths: &[PathBuf],
        config: StreamConfig,
        start: u64,
        mut prepare: F,
    ) -> Result<Self, TrainError>
    where
        F: FnMut(&StreamPosition, FrameRecord) -> Result<T, TrainError> + Send + 'static,
    {
        let options = ReaderOptions {
            cache_bytes: config.chunk_cache_bytes,
            ..Default::default()
        };
        let mut reader = ShardReader::open_with(paths, options)?;
        let shard_frames: Vec<Vec<u64>> = reader
            .shards()
            .iter()
            .map(|s| s.frame_ids().collect())
            .collect();
        let n = shard_frames.iter().map(Vec::len).sum::<usize>();
        if n == 0 {
            return Err(TrainError::NoFrames);
        }
        let (tx, rx): (SyncSender<Item<T>>, _) = sync_channel(config.prefetch.max(1));
        let handle = std::thread::Builder::new()
            .name("pl2map-frames".into())
            .spawn(move || {
                let mut epoch = u64::MAX;
                let mut order = Vec::new();
                let mut position = start;
                loop {
                    let e = position / n as u64;
                    if e != epoch {
                        epoch = e;
                        order = epoch_order(&shard_frames, config.shuffle_buffer, config.seed, e);
                    }
                    let frame = order[(position % n as u64) as usize];
                    let at = StreamPosition {
                        position,
                        epoch,
                        frame,
                    };
                    let item = reader
                        .read_frame(frame.frame_id)
                        .map_err(TrainError::from)
                        .and_then(|record| prepare(&at, record))
                        .map(|t| (at, t));
                    let failed = item.is_err();
                    // Blocks while the consumer is `prefetch` items behind; an error
                    // means the stream was dropped.
                    if tx.send(item).is_err() || failed {
                        return;
                    }
                    position += 1;
                }
            })
            .map_err(|e| TrainError::Stream(format!("cannot start the reader thread: {e}")))?;
        Ok(FrameStream {
            rx: Some(rx),
            handle: Some(handle),
            frames_per_epoch: n,
        })
    }

    pub fn frames_per_epoch(&self) -> usize {
        self.frames_per_epoch
    }

    /// The next prepared frame. An error (a frame that does not decode, a failed
    /// preparation) ends the stream.
    pub fn next_item(&mut self) -> Result<(StreamPosition, T), TrainError> {
        let rx = self
            .rx
            .as_ref()
            .ok_or_else(|| TrainError::Stream("the stream has ended".into()))?;
        match rx.recv() {
            Ok(Ok(item)) => Ok(item),
            Ok(Err(e)) => {
                self.rx = None;
                Err(e)
            }
            Err(_) => {
                self.rx = None;
                Err(TrainError::Stream("the reader thread exited".into()))
            }
        }
    }
}

impl<T: Send + 'static> Drop for FrameStream<T> {
    fn drop(&mut self) {
        // Dropping the receiver makes the thread's next send fail, so it exits after at
        // most one more preparation.
        self.rx = None;
        if let Some(h) = self.handle.take() {
            let _ = h.join();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testutil::write_synthetic_shards;
    use std::collections::HashSet;

    fn layout() -> Vec<Vec<u64>> {
        vec![(0..7).collect(), (100..110).collect(), (200..203).collect()]
    }

    #[test]
    fn epoch_order_is_a_permutation_and_a_function_of_seed_and_epoch() {
        let shards = layout();
        let a = epoch_order(&shards, 4, 11, 0);
        assert_eq!(a.len(), 20);
        let ids: HashSet<u64> = a.iter().map(|f| f.frame_id).collect();
        assert_eq!(ids.len(), 20);
        for f in &a {
            assert!(shards[f.shard].contains(&f.frame_id));
        }
        assert_eq!(a, epoch_order(&shards, 4, 11, 0));
        assert_ne!(a, epoch_order(&shards, 4, 11, 1));
        assert_ne!(a, epoch_order(&shards, 4, 12, 0));
        // Frames of several shards mix inside the first window of the order.
        let first: HashSet<usize> = a[..10].iter().map(|f| f.shard).collect();
        assert!(first.len() >= 2, "{a:?}");
    }

    #[test]
    fn the_default_buffer_mixes_a_whole_scene_into_the_first_steps() {
        // 2000 frames in four shards of 500 (the pipeline's shard size), as 7-Scenes'
        // larger scenes have: the first 64 frames of an epoch (four steps of 16) come
        // from every shard.
        let shards: Vec<Vec<u64>> = (0..4).map(|s| (s * 500..(s + 1) * 500).collect()).collect();
        let shards_in = |order: &[FrameRef]| -> HashSet<usize> {
            order[..64].iter().map(|f| f.shard).collect()
        };
        let buffer = crate::TrainConfig::default().shuffle_buffer;
        for epoch in 0..3 {
            let order = epoch_order(&shards, buffer, 5, epoch);
            assert_eq!(
                shards_in(&order).len(),
                4,
                "epoch {epoch}: {:?}",
                &order[..64]
            );
        }
        // A 64-frame buffer (the old default) keeps them inside the first shard read.
        assert_eq!(shards_in(&epoch_order(&shards, 64, 5, 0)).len(), 1);
    }

    #[test]
    fn a_buffer_of_one_keeps_file_order_within_shards() {
        let shards = layout();
        let a = epoch_order(&shards, 1, 3, 0);
        for (s, frames) in shards.iter().enumerate() {
            let ids: Vec<u64> = a
                .iter()
                .filter(|f| f.shard == s)
                .map(|f| f.frame_id)
                .collect();
            assert_eq!(&ids, frames);
        }
    }

    #[test]
    fn stream_started_late_continues_the_same_sequence() {
        let dir = tempfile::tempdir().unwrap();
        let paths = write_synthetic_shards(dir.path(), 3, 4, 0.0);
        let cfg = StreamConfig {
            shuffle_buffer: 3,
            prefetch: 2,
            seed: 5,
            chunk_cache_bytes: 0,
        };
        let ids = |start: u64, count: usize| -> Vec<(u64, u64)> {
            let mut s = FrameStream::start(&paths, cfg, start, |_, f| Ok(f.frame_id)).unwrap();
            (0..count)
                .map(|_| {
                    let (at, id) = s.next_item().unwrap();
                    assert_eq!(at.frame.frame_id, id);
                    (at.position, id)
                })
                .collect()
        };
        let full = ids(0, 30);
        // Epochs of 12 frames, each a permutation.
        for e in 0..2 {
            let set: HashSet<u64> = full[e * 12..(e + 1) * 12].iter().map(|x| x.1).collect();
            assert_eq!(set.len(), 12);
        }
        assert_ne!(full[..12], full[12..24]);
        assert_eq!(ids(0, 30), full);
        assert_eq!(ids(17, 13), full[17..]);
    }

    #[test]
    fn empty_input_is_an_error() {
        let r = FrameStream::<u64>::start(
            &[],
            StreamConfig {
                shuffle_buffer: 2,
                prefetch: 1,
                seed: 0,
                chunk_cache_bytes: 0,
            },
            0,
            |_, f| Ok(f.frame_id),
        );
        assert!(matches!(r, Err(TrainError::NoFrames)));
    }
}
