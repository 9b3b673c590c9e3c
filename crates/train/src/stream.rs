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
//! epoch). A background reader reads the frames and a pool of workers runs a
//! caller-given preparation function on them (decoding, augmentation, descriptors),
//! `prefetch` items ahead of the consumer, who gets them back in stream order.

use crate::descriptor_cache::HeldRecords;
use crate::error::TrainError;
use crate::seeds::{self, Purpose};
use rand::Rng;
use rand::seq::SliceRandom;
use shards::{FrameRecord, ReaderOptions, ShardReader};
use std::collections::BTreeMap;
use std::panic::AssertUnwindSafe;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::mpsc::{Receiver, SyncSender, channel, sync_channel};
use std::sync::{Arc, Mutex};
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
    /// Prepared items kept ready ahead of the consumer (besides those in the workers'
    /// hands).
    pub prefetch: usize,
    pub seed: u64,
    /// Decompressed shard chunks the reader keeps (bytes; see
    /// `shards::ReaderOptions::cache_bytes`). Speed only: the shuffle buffer reads
    /// frames out of file order, and without it most reads decompress a whole chunk.
    pub chunk_cache_bytes: u64,
    /// Threads running the preparation function (at least 1). The items come out in
    /// stream order whatever the number: it changes the speed, never the items.
    pub workers: usize,
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
///
/// Threads: one reader walks the stream order and reads each frame from its shard; it
/// hands (position, frame) to `workers` threads, which run the preparation function and
/// send the result back tagged with its position; [`FrameStream::next_item`] puts the
/// results back into stream order. The reader takes a credit before each frame and the
/// consumer returns one with each item it hands out, so at most `prefetch + workers`
/// frames are read and not yet consumed, however slow one preparation is.
pub struct FrameStream<T: Send + 'static> {
    results: Option<Receiver<(u64, Item<T>)>>,
    places: Arc<Places>,
    /// Results that came before the one the consumer waits for.
    pending: BTreeMap<u64, Item<T>>,
    next: u64,
    stop: Arc<AtomicBool>,
    threads: Vec<JoinHandle<()>>,
    frames_per_epoch: usize,
}

impl<T: Send + 'static> FrameStream<T> {
    /// Opens `paths` and starts the reader and the workers at stream position `start`.
    /// `prepare(position, frame)` runs on the workers; its result is what
    /// [`Self::next_item`] returns.
    pub fn start<F>(
        paths: &[PathBuf],
        config: StreamConfig,
        start: u64,
        prepare: F,
    ) -> Result<Self, TrainError>
    where
        F: Fn(&StreamPosition, FrameRecord) -> Result<T, TrainError> + Send + Sync + 'static,
    {
        Self::start_with_records(paths, config, start, None, prepare)
    }

    /// [`Self::start`], with the records of some frames already in memory: the reader
    /// hands those out instead of reading them from their shard (a record there may
    /// lack its image: `descriptor_cache::HeldRecords`; only for a `prepare` that does
    /// not need it).
    pub fn start_with_records<F>(
        paths: &[PathBuf],
        config: StreamConfig,
        start: u64,
        records: Option<Arc<HeldRecords>>,
        prepare: F,
    ) -> Result<Self, TrainError>
    where
        F: Fn(&StreamPosition, FrameRecord) -> Result<T, TrainError> + Send + Sync + 'static,
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
        let workers = config.workers.max(1);
        let in_flight = config.prefetch.max(1) + workers;
        let (credit_tx, credit_rx) = sync_channel::<()>(in_flight);
        for _ in 0..in_flight {
            // The channel holds exactly `in_flight`: these sends cannot block or fail.
            let _ = credit_tx.try_send(());
        }
        let (job_tx, job_rx) = channel::<(StreamPosition, FrameRecord)>();
        let job_rx = Arc::new(Mutex::new(job_rx));
        let (result_tx, result_rx) = channel::<(u64, Item<T>)>();
        let stop = Arc::new(AtomicBool::new(false));
        let spawn_err =
            |e: std::io::Error| TrainError::Stream(format!("cannot start a thread: {e}"));
        let mut threads = Vec::with_capacity(workers + 1);

        let prepare = Arc::new(prepare);
        for w in 0..workers {
            let (jobs, results, stop, prepare) = (
                Arc::clone(&job_rx),
                result_tx.clone(),
                Arc::clone(&stop),
                Arc::clone(&prepare),
            );
            let handle = std::thread::Builder::new()
                .name(format!("pl2map-sample-{w}"))
                .spawn(move || {
                    loop {
                        // The lock is held only to take a job, not while preparing it.
                        let job = match jobs.lock() {
                            Ok(rx) => rx.recv(),
                            Err(_) => return,
                        };
                        let Ok((at, record)) = job else { return };
                        if stop.load(Ordering::Relaxed) {
                            return;
                        }
                        // A panic in the preparation ends the stream with an error
                        // instead of leaving the consumer waiting for this position.
                        let prepared =
                            std::panic::catch_unwind(AssertUnwindSafe(|| prepare(&at, record)))
                                .unwrap_or_else(|panic| {
                                    Err(TrainError::Stream(format!(
                                        "preparing frame {} panicked: {}",
                                        at.frame.frame_id,
                                        panic_text(panic.as_ref())
                                    )))
                                });
                        let item = prepared.map(|t| (at, t));
                        if results.send((at.position, item)).is_err() {
                            return;
                        }
                    }
                })
                .map_err(spawn_err)?;
            threads.push(handle);
        }

        let reader_stop = Arc::clone(&stop);
        let handle = std::thread::Builder::new()
            .name("pl2map-frames".into())
            .spawn(move || {
                let mut epoch = u64::MAX;
                let mut order = Vec::new();
                let mut position = start;
                // Blocks while `in_flight` frames are out; fails once the stream is
                // dropped (and any credits left are ignored after `stop`).
                while credit_rx.recv().is_ok() && !reader_stop.load(Ordering::Relaxed) {
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
                    let held = records.as_ref().and_then(|r| r.get(&frame.frame_id));
                    let record = match held {
                        Some(r) => Ok(r.clone()),
                        None => reader.read_frame(frame.frame_id),
                    };
                    match record {
                        Ok(record) => {
                            if job_tx.send((at, record)).is_err() {
                                return;
                            }
                        }
                        Err(e) => {
                            // Ends the stream at this position.
                            let _ = result_tx.send((position, Err(e.into())));
                            return;
                        }
                    }
                    position += 1;
                }
            })
            .map_err(spawn_err)?;
        threads.push(handle);
        Ok(FrameStream {
            results: Some(result_rx),
            places: Arc::new(Places {
                credits: Mutex::new(Some(credit_tx)),
                hold: AtomicBool::new(false),
                held: AtomicUsize::new(0),
            }),
            pending: BTreeMap::new(),
            next: start,
            stop,
            threads,
            frames_per_epoch: n,
        })
    }

    pub fn frames_per_epoch(&self) -> usize {
        self.frames_per_epoch
    }

    /// From now on the places of the items taken are given back to the reader only when
    /// the returned handle's [`PlaceRelease::release`] is called, not as each item is
    /// taken.
    ///
    /// Why: a CPU training step takes its 16 samples at once, and the reader and
    /// preparation threads then woke for about 5 ms of work while the two gradient
    /// groups wanted both cores; the group they held back kept the other waiting at the
    /// step's barrier. The trainer releases the places when the step's gradients are
    /// made, so that work overlaps the memory-bound Adam update instead: the main job's
    /// step took 0.0350-0.0354 s instead of 0.0372-0.0375 s (docs/performance.md, "The
    /// sample stream's places"). The items are the same either way. The caller must
    /// release before it takes more than the stream's places (`prefetch + workers`)
    /// in a row, or [`FrameStream::next_item`] waits for an item the reader cannot read
    /// (the trainer's prefetch is at least two steps' samples, and it releases every
    /// step).
    pub fn hold_places(&mut self) -> PlaceRelease {
        self.places.hold.store(true, Ordering::SeqCst);
        PlaceRelease(Arc::clone(&self.places))
    }

    /// The next prepared frame, in stream order. An error (a frame that does not read
    /// or decode, a failed preparation) ends the stream.
    pub fn next_item(&mut self) -> Result<(StreamPosition, T), TrainError> {
        let ended = || TrainError::Stream("the stream has ended".into());
        let item = loop {
            if let Some(item) = self.pending.remove(&self.next) {
                break item;
            }
            let rx = self.results.as_ref().ok_or_else(ended)?;
            match rx.recv() {
                Ok((position, item)) => {
                    self.pending.insert(position, item);
                }
                Err(_) => {
                    self.results = None;
                    return Err(TrainError::Stream("the sample threads exited".into()));
                }
            }
        };
        match item {
            Ok(item) => {
                self.next += 1;
                self.places.taken();
                Ok(item)
            }
            Err(e) => {
                self.shut_down();
                Err(e)
            }
        }
    }

    /// Stops the threads: the reader at its next credit, the workers at their next job.
    fn shut_down(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        // The reader's credit channel closes even while a [`PlaceRelease`] lives on.
        self.places.close();
        self.results = None;
        self.pending.clear();
        for h in self.threads.drain(..) {
            let _ = h.join();
        }
    }
}

/// The reader's credits: one per place of the stream ([`FrameStream::hold_places`]).
struct Places {
    /// None once the stream shut down (the reader then stops at its next credit).
    credits: Mutex<Option<SyncSender<()>>>,
    hold: AtomicBool,
    held: AtomicUsize,
}

impl Places {
    /// An item was handed out: its place goes back now, or is held.
    fn taken(&self) {
        if self.hold.load(Ordering::SeqCst) {
            self.held.fetch_add(1, Ordering::SeqCst);
        } else {
            self.give(1);
        }
    }

    fn give(&self, n: usize) {
        if let Ok(credits) = self.credits.lock()
            && let Some(tx) = credits.as_ref()
        {
            for _ in 0..n {
                // The reader may be gone (it stopped at an error further on): then
                // nothing waits for the credit.
                let _ = tx.try_send(());
            }
        }
    }

    fn close(&self) {
        if let Ok(mut credits) = self.credits.lock() {
            *credits = None;
        }
    }
}

/// Gives the held places of a [`FrameStream`] back to its reader (any thread; a no-op
/// once the stream is gone).
#[derive(Clone)]
pub struct PlaceRelease(Arc<Places>);

impl PlaceRelease {
    pub fn release(&self) {
        let n = self.0.held.swap(0, Ordering::SeqCst);
        self.0.give(n);
    }
}

fn panic_text(panic: &(dyn std::any::Any + Send)) -> String {
    panic
        .downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| panic.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "(no message)".into())
}

impl<T: Send + 'static> Drop for FrameStream<T> {
    fn drop(&mut self) {
        self.shut_down();
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
            workers: 1,
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

    fn config(workers: usize) -> StreamConfig {
        StreamConfig {
            shuffle_buffer: 3,
            prefetch: 2,
            seed: 5,
            chunk_cache_bytes: 0,
            workers,
        }
    }

    /// Workers that finish out of order (each sleeps a position-dependent time) still
    /// give the items in stream order, equal to one worker's.
    #[test]
    fn any_number_of_workers_gives_the_same_items_in_order() {
        let dir = tempfile::tempdir().unwrap();
        let paths = write_synthetic_shards(dir.path(), 3, 4, 0.0);
        let items = |workers: usize, start: u64| -> Vec<(u64, u64, usize)> {
            let mut s = FrameStream::start(&paths, config(workers), start, |at, f| {
                // Later positions often finish first.
                let ms = [3, 0, 2, 0, 1][(at.position % 5) as usize];
                std::thread::sleep(std::time::Duration::from_millis(ms));
                Ok((f.frame_id, f.keypoints.len()))
            })
            .unwrap();
            (0..30)
                .map(|_| {
                    let (at, (id, n)) = s.next_item().unwrap();
                    (at.position, id, n)
                })
                .collect()
        };
        let one = items(1, 0);
        assert_eq!(
            one.iter().map(|x| x.0).collect::<Vec<_>>(),
            (0..30).collect::<Vec<u64>>()
        );
        assert_eq!(items(2, 0), one);
        assert_eq!(items(4, 0), one);
        assert_eq!(items(3, 7), items(1, 7));
    }

    /// With its places held, the reader makes no more than the stream's places until
    /// they are released; the items are those of a stream that gives each place back at
    /// once; and a release handle that outlives its stream neither keeps the reader
    /// alive (dropping the stream returns) nor fails afterwards.
    #[test]
    fn held_places_bound_the_reader_until_released() {
        let dir = tempfile::tempdir().unwrap();
        let paths = write_synthetic_shards(dir.path(), 2, 4, 0.0);
        let plain: Vec<u64> = {
            let mut s = FrameStream::start(&paths, config(1), 0, |_, f| Ok(f.frame_id)).unwrap();
            (0..6).map(|_| s.next_item().unwrap().1).collect()
        };
        let made = Arc::new(AtomicUsize::new(0));
        let counter = Arc::clone(&made);
        let mut s = FrameStream::start(&paths, config(1), 0, move |_, f| {
            counter.fetch_add(1, Ordering::SeqCst);
            Ok(f.frame_id)
        })
        .unwrap();
        let places = s.hold_places();
        // config(1): 2 prefetched + 1 in the worker's hands.
        let mut got: Vec<u64> = (0..3).map(|_| s.next_item().unwrap().1).collect();
        std::thread::sleep(std::time::Duration::from_millis(100));
        assert_eq!(
            made.load(Ordering::SeqCst),
            3,
            "the reader waits for its places"
        );
        places.release();
        got.extend((0..3).map(|_| s.next_item().unwrap().1));
        assert_eq!(got, plain);
        drop(s);
        places.release();
    }

    /// A failed or panicking preparation ends the stream with its error at its
    /// position; the items before it come out first.
    #[test]
    fn a_failed_preparation_ends_the_stream_at_its_position() {
        let dir = tempfile::tempdir().unwrap();
        let paths = write_synthetic_shards(dir.path(), 2, 4, 0.0);
        for panics in [false, true] {
            let mut s = FrameStream::start(&paths, config(3), 0, move |at, f| {
                if at.position == 4 {
                    if panics {
                        panic!("bad frame {}", f.frame_id);
                    }
                    return Err(TrainError::Stream("refused".into()));
                }
                Ok(at.position)
            })
            .unwrap();
            for p in 0..4 {
                assert_eq!(s.next_item().unwrap().1, p);
            }
            let e = s.next_item().unwrap_err().to_string();
            let expected = if panics {
                "panicked: bad frame"
            } else {
                "refused"
            };
            assert!(e.contains(expected), "{e}");
            assert!(s.next_item().is_err());
        }
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
                workers: 1,
            },
            0,
            |_, f| Ok(f.frame_id),
        );
        assert!(matches!(r, Err(TrainError::NoFrames)));
    }
}
