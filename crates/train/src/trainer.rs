//! The training loop: stream -> sample -> Adam step, with the learning-rate schedule,
//! checkpoints, the metrics table, a progress bar and the loss plot.
//!
//! Exact resume: a checkpoint holds the weights, Adam's state and the iteration count;
//! the stream position is the iteration, and every random choice (epoch order,
//! augmentation, subsampling, dropout) is derived from the seed and the iteration or
//! stream position (`seeds.rs`). The CPU backend's results do not depend on the thread
//! count (model crate tests), so a resumed run reproduces the uninterrupted one bit for
//! bit (test `resumed_run_matches_an_uninterrupted_one`).
//!
//! Output folder: `config.toml` (the effective configuration), `checkpoint.ckpt` (latest
//! checkpoint, with optimiser state), `model.ckpt` (final weights + configuration, what
//! the predictor loads), `metrics.csv`, `losses.png`.

use crate::checkpoint::{
    CHECKPOINT_FILE, CheckpointFile, CheckpointHeader, MODEL_FILE, save, write_atomic,
};
use crate::config::TrainConfig;
use crate::descriptor_cache::SpillTarget;
use crate::descriptor_spill::SPILL_FILE;
use crate::error::{TrainError, io_err};
use crate::metrics::{MetricsRow, MetricsWriter};
use crate::plot::{PLOT_FILE, plot_metrics};
use crate::sample::{DescriptorCache, Prepared, label_centre, prepare_with_cache, recentre};
use crate::seeds::{self, Purpose};
use crate::step::{StepOptions, TrainState};
use crate::stream::{FrameStream, StreamConfig};
use indicatif::ProgressBar;
use model::burn::tensor::backend::AutodiffBackend;
use model::{Device, LossValues, Pl2MapBackend};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

pub const CONFIG_FILE: &str = "config.toml";

/// How to run (what is not part of the configuration).
#[derive(Clone, Debug, Default)]
pub struct RunOptions {
    pub out_dir: PathBuf,
    /// Continue from `out_dir/checkpoint.ckpt` with its configuration.
    pub resume: bool,
    /// Start from the weights of this checkpoint (same network configuration); the
    /// optimiser starts fresh.
    pub init: Option<PathBuf>,
    /// Replaces the configuration's iteration count (also when resuming; the learning
    /// rate schedule follows the new count).
    pub iterations: Option<u64>,
    /// Show a progress bar (only drawn on a terminal).
    pub progress: bool,
    /// Stop after this many iterations in total as a killed run would (no final
    /// checkpoint, model or plot): for tests of `resume`.
    pub stop_after: Option<u64>,
}

/// Loss terms averaged over the last iterations of the run.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MeanLosses {
    pub iterations: usize,
    pub total: f64,
    pub map_points: f64,
    pub map_lines: f64,
    pub reliability: f64,
    pub reprojection: f64,
}

#[derive(Clone, Debug)]
pub struct TrainSummary {
    pub config: TrainConfig,
    pub resumed_from: Option<u64>,
    pub iterations_done: u64,
    pub finished: bool,
    pub frames_per_epoch: usize,
    pub seconds: f64,
    /// Steps that changed nothing (a frame with no point and no line left).
    pub skipped_steps: u64,
    pub last: MeanLosses,
    pub checkpoint: PathBuf,
    pub model: Option<PathBuf>,
    pub metrics: PathBuf,
    pub plot: Option<PathBuf>,
}

/// Trains on the configuration's device (`device`: the CPU backend, or CUDA in builds
/// with the `cuda` feature; a CUDA device in a build without it is refused, saying how to
/// build one).
pub fn train(
    config: TrainConfig,
    shards: &[PathBuf],
    options: &RunOptions,
) -> Result<TrainSummary, TrainError> {
    match config.device {
        Device::Cpu => {
            train_on::<model::CpuAutodiffBackend>(config, shards, options, &Default::default())
        }
        #[cfg(feature = "cuda")]
        Device::Cuda(i) => {
            train_on::<model::CudaAutodiffBackend>(config, shards, options, &Device::cuda(i))
        }
        #[cfg(not(feature = "cuda"))]
        Device::Cuda(_) => Err(config.device.not_built().into()),
        #[cfg(feature = "tch")]
        Device::LibTorchCpu | Device::LibTorchCuda(_) => {
            let device = config.device.libtorch();
            train_on::<model::LibTorchAutodiffBackend>(config, shards, options, &device)
        }
        #[cfg(not(feature = "tch"))]
        Device::LibTorchCpu | Device::LibTorchCuda(_) => Err(config.device.not_built().into()),
    }
}

fn mean_losses(window: &[LossValues]) -> MeanLosses {
    if window.is_empty() {
        return MeanLosses::default();
    }
    let n = window.len().max(1) as f64;
    let avg = |f: &dyn Fn(&LossValues) -> f64| window.iter().map(f).sum::<f64>() / n;
    MeanLosses {
        iterations: window.len(),
        total: avg(&|l| l.total),
        map_points: avg(&|l| l.map_points),
        map_lines: avg(&|l| l.map_lines),
        reliability: avg(&|l| l.reliability_points + l.reliability_lines),
        reprojection: avg(&|l| l.reprojection_points + l.reprojection_lines),
    }
}

/// The run's bar (the workspace's one progress mechanism: hidden when stderr is not a
/// terminal or with `--quiet`), at the resumed iteration.
fn progress_bar(total: u64, start: u64, show: bool) -> ProgressBar {
    if !show {
        return ProgressBar::hidden();
    }
    let bar = stage::progress_bar(total, "train");
    bar.set_position(start);
    bar
}

/// Trains on any autodiff backend (see [`train`]).
pub fn train_on<B: AutodiffBackend<InnerBackend: Pl2MapBackend> + Pl2MapBackend>(
    config: TrainConfig,
    shards: &[PathBuf],
    options: &RunOptions,
    device: &B::Device,
) -> Result<TrainSummary, TrainError> {
    let out = &options.out_dir;
    std::fs::create_dir_all(out).map_err(io_err(out))?;
    let ckpt_path = out.join(CHECKPOINT_FILE);
    let start = if options.resume {
        resumed_state::<B>(config, &ckpt_path, options, device)?
    } else {
        fresh_state::<B>(config, &ckpt_path, shards, options, device)?
    };
    let Start {
        config,
        mut state,
        iteration: start,
        centre,
    } = start;
    config.validate()?;
    // The front-end describes every training sample. Its configuration as built (for
    // SuperPoint: with the weights file's sha256) is what the checkpoints record, so the
    // predictor and a resumed run use the same weights or refuse to start.
    // SuperPoint runs on the training device (SIFT and LSD on the CPU).
    let front_end = frontends::build_on(&config.front_end, config.device.gpu())?;
    let mut config = config;
    config.front_end = front_end.config().clone();
    write_atomic(&out.join(CONFIG_FILE), config.to_toml().as_bytes())?;
    // Gradient groups run side by side on the CPU's threads; on a GPU one thread queues
    // them one after another (the same weights either way).
    let group_threads = config.device.is_cpu().then(rayon::current_num_threads);
    state.set_batch_groups(config.batch_groups, group_threads)?;
    // Shape buckets (crates/model/src/buckets.rs): `auto` pads on the JIT engine only.
    state.set_shape_buckets(config.training_buckets(config.device));
    let spill_path = out.join(SPILL_FILE);
    let mut stream = sample_stream(
        &config,
        shards,
        front_end,
        (centre, start),
        &spill_path,
        options.progress,
    )?;
    let frames_per_epoch = stream.frames_per_epoch();
    // On the CPU the stream refills while Adam runs, not while the groups want the cores
    // (stream.rs, `hold_places`); on a GPU it refills at once, as the device waits on it.
    let places = config.device.is_cpu().then(|| stream.hold_places());
    if let Some(p) = &places {
        let p = p.clone();
        state.set_on_gradients(Some(Box::new(move || p.release())));
    }

    let mut metrics = MetricsWriter::open(out, start)?;
    let bar = progress_bar(config.iterations, start, options.progress);
    let t0 = Instant::now();
    let mut recent: Vec<LossValues> = Vec::new();
    let mut skipped = 0u64;
    let mut done = start;
    let header = |iteration: u64, config: &TrainConfig| CheckpointHeader {
        tool_version: env!("CARGO_PKG_VERSION").to_string(),
        // Without the speed-only settings: the same weights make the same file.
        config: config.for_record(),
        iteration,
        has_optimizer: true,
        scene_centre: centre,
        weights_hash: String::new(),
        optimizer_hash: String::new(),
    };
    let mut killed = false;
    // Steps run on threads that flush denormals (crates/kernels/src/denormals.rs): up to
    // 40 % faster on Intel cores once the optimiser's moments underflow.
    let pool = kernels::denormals::flushing_pool()
        .map_err(|e| TrainError::Config(format!("starting the training threads: {e}")))?;
    // Steps reuse freed buffers instead of mapping fresh pages for each
    // (crates/kernels/src/alloc.rs).
    kernels::alloc::keep_freed_memory();
    for i in start..config.iterations {
        if options.stop_after.is_some_and(|s| i >= s) {
            killed = true;
            break;
        }
        let t = Instant::now();
        let (samples, frame_id) = next_batch(&mut stream, config.batch_frames)?;
        let data_seconds = t.elapsed().as_secs_f64();
        let lr = config.learning_rate_at(i);
        let step = StepOptions {
            progress: i as f64 / config.iterations as f64,
            learning_rate: lr,
            dropout_seed: seeds::derive(config.seed, Purpose::Dropout, i),
        };
        let report = pool.install(|| state.step_batch(&samples, &step))?;
        // A step that made no gradients, or one stacked pass, has not released them yet.
        if let Some(p) = &places {
            p.release();
        }
        if !report.updated {
            skipped += 1;
        }
        done = i + 1;
        let timing = (t.elapsed().as_secs_f64(), data_seconds);
        metrics.append(&metrics_row(
            done,
            frame_id,
            &samples,
            report.losses,
            lr,
            timing,
        ))?;
        if recent.len() == 100 {
            recent.remove(0);
        }
        recent.push(report.losses);
        bar.set_position(done);
        if done % 10 == 0 || done == config.iterations {
            let m = mean_losses(&recent);
            bar.set_message(format!(
                "loss {:.3} (map {:.3}+{:.3}, rel {:.3}, reproj {:.3}) lr {lr:.2e}",
                m.total, m.map_points, m.map_lines, m.reliability, m.reprojection
            ));
        }
        if done % config.checkpoint_every == 0 || done == config.iterations {
            save(
                &ckpt_path,
                &header(done, &config),
                state.model(),
                Some(&state.optimizer),
            )?;
            tracing::debug!("checkpoint at iteration {done}");
        }
    }
    bar.finish_and_clear();
    drop(stream);

    let finished = !killed && done >= config.iterations;
    if finished {
        // The spilled descriptors serve only this run (and its resumption).
        match std::fs::remove_file(&spill_path) {
            Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
                return Err(io_err(&spill_path)(e).into());
            }
            _ => {}
        }
    }
    let (model_path, plot_path) = if finished {
        if start == done {
            // Nothing left to train: the checkpoint already holds the final state.
            tracing::info!("{} already at iteration {done}", ckpt_path.display());
        }
        let model_path = out.join(MODEL_FILE);
        save::<B>(&model_path, &header(done, &config), state.model(), None)?;
        let plot_path = out.join(PLOT_FILE);
        plot_metrics(metrics.path(), &plot_path)?;
        (Some(model_path), Some(plot_path))
    } else {
        (None, None)
    };
    Ok(TrainSummary {
        config,
        resumed_from: options.resume.then_some(start),
        iterations_done: done,
        finished,
        frames_per_epoch,
        seconds: t0.elapsed().as_secs_f64(),
        skipped_steps: skipped,
        last: mean_losses(&recent),
        checkpoint: ckpt_path,
        model: model_path,
        metrics: metrics.path().to_path_buf(),
        plot: plot_path,
    })
}

/// Where a run starts: its configuration, network and optimiser, iteration and the scene
/// centre its network predicts around.
struct Start<B: AutodiffBackend<InnerBackend: Pl2MapBackend> + Pl2MapBackend> {
    config: TrainConfig,
    state: TrainState<B>,
    iteration: u64,
    centre: [f64; 3],
}

/// `--resume`: the checkpoint's weights, optimiser and iteration, continued under the
/// requested configuration. The requested configuration may change what does not change
/// the run's results so far (`iterations`: the run continues to the new count, and the
/// learning-rate schedule follows it; where and how fast it runs: `device`, `workers`,
/// `prefetch`, the caches); anything else that differs from the checkpoint's is refused,
/// naming each key, so a run never trains with one configuration and records another.
fn resumed_state<B: AutodiffBackend<InnerBackend: Pl2MapBackend> + Pl2MapBackend>(
    config: TrainConfig,
    ckpt_path: &Path,
    options: &RunOptions,
    device: &B::Device,
) -> Result<Start<B>, TrainError> {
    let ck = CheckpointFile::read(ckpt_path)?;
    let mut requested = config;
    if let Some(n) = options.iterations {
        requested.iterations = n;
    }
    let cfg = resumed_config(&ck.header.config, requested, ckpt_path)?;
    let model = ck.model::<B>(device)?;
    let optimizer = ck
        .optimizer::<B>(device)?
        .ok_or_else(|| TrainError::Checkpoint {
            path: ckpt_path.to_path_buf(),
            reason: "holds no optimiser state: cannot resume from it".into(),
        })?;
    let state = TrainState::from_parts(model, optimizer, cfg.loss.clone())?;
    Ok(Start {
        config: cfg,
        state,
        iteration: ck.header.iteration,
        centre: ck.header.scene_centre,
    })
}

/// The configuration a resumed run continues with: the checkpoint's, with the settings a
/// resume may change taken from `requested`; an error naming every other key in which
/// the two differ.
pub fn resumed_config(
    checkpoint: &TrainConfig,
    requested: TrainConfig,
    ckpt_path: &Path,
) -> Result<TrainConfig, TrainError> {
    let mut comparable = requested.clone();
    // The trainer fills in the hash of the SuperPoint weights it was built with; a
    // request names the file only (the weights' own check happens when they load).
    if comparable.front_end.superpoint.weights_sha256.is_none() {
        comparable.front_end.superpoint.weights_sha256 =
            checkpoint.front_end.superpoint.weights_sha256.clone();
    }
    let effective = TrainConfig {
        iterations: requested.iterations,
        device: requested.device,
        workers: requested.workers,
        prefetch: requested.prefetch,
        descriptor_cache_mib: requested.descriptor_cache_mib,
        chunk_cache_mib: requested.chunk_cache_mib,
        ..checkpoint.clone()
    };
    let differing = differing_keys(&effective, &comparable);
    if !differing.is_empty() {
        return Err(TrainError::Checkpoint {
            path: ckpt_path.to_path_buf(),
            reason: format!(
                "--resume continues this checkpoint's run, whose configuration differs from                  the one asked for in: {}. Resume with the checkpoint's settings (only                  `iterations` and speed settings may change), or train into another folder",
                differing.join("; ")
            ),
        });
    }
    if effective.iterations != checkpoint.iterations {
        tracing::info!(
            "resuming to {} iterations (the checkpoint's run was set to {}); the learning              rate schedule follows the new count",
            effective.iterations,
            checkpoint.iterations
        );
    }
    Ok(effective)
}

/// The top-level keys in which two configurations differ, each as
/// `key (checkpoint X, asked Y)`.
fn differing_keys(checkpoint: &TrainConfig, asked: &TrainConfig) -> Vec<String> {
    let as_map = |c: &TrainConfig| match toml::Value::try_from(c) {
        Ok(toml::Value::Table(t)) => t,
        _ => toml::Table::new(),
    };
    let (a, b) = (as_map(checkpoint), as_map(asked));
    let mut keys: Vec<&String> = a.keys().chain(b.keys()).collect();
    keys.sort();
    keys.dedup();
    let show = |v: Option<&toml::Value>| match v {
        Some(v) => v.to_string(),
        None => "default".into(),
    };
    keys.into_iter()
        .filter(|k| a.get(*k) != b.get(*k))
        .map(|k| {
            format!(
                "{k} (checkpoint {}, asked {})",
                show(a.get(k)),
                show(b.get(k))
            )
        })
        .collect()
}

/// A new run: fresh weights from the seed (centred on the training labels), or the
/// weights of `--init` (a warm start, in that network's own coordinates); the optimiser
/// starts fresh either way.
fn fresh_state<B: AutodiffBackend<InnerBackend: Pl2MapBackend> + Pl2MapBackend>(
    config: TrainConfig,
    ckpt_path: &Path,
    shards: &[PathBuf],
    options: &RunOptions,
    device: &B::Device,
) -> Result<Start<B>, TrainError> {
    if ckpt_path.exists() {
        return Err(TrainError::Config(format!(
            "{} already exists: pass --resume to continue that run, or use another folder",
            ckpt_path.display()
        )));
    }
    let mut cfg = config;
    if let Some(n) = options.iterations {
        cfg.iterations = n;
    }
    cfg.validate()?;
    let (state, centre) = match &options.init {
        Some(path) => {
            let ck = init_checkpoint(path, &cfg)?;
            (
                TrainState::new(ck.model::<B>(device)?, cfg.loss.clone())?,
                ck.header.scene_centre,
            )
        }
        None => (
            TrainState::init(&cfg.model, cfg.loss.clone(), cfg.seed, device)?,
            label_centre(shards)?,
        ),
    };
    Ok(Start {
        config: cfg,
        state,
        iteration: 0,
        centre,
    })
}

/// The starting model of a warm start (`--init`): a pl2map checkpoint of the configured
/// network, or an error naming `path`.
pub fn init_checkpoint(path: &Path, config: &TrainConfig) -> Result<CheckpointFile, TrainError> {
    let ck = CheckpointFile::read(path)?;
    if ck.header.config.model != config.model {
        return Err(TrainError::Checkpoint {
            path: path.to_path_buf(),
            reason: format!(
                "its network ({:?}) is not the configured one ({:?})",
                ck.header.config.model, config.model
            ),
        });
    }
    Ok(ck)
}

/// The stream of training samples from iteration `start` on: frames from the shards,
/// augmented and described by `front_end` on the sample workers, recentred on `centre`.
/// The configuration reaches the samples here, once. Public for the tests that count
/// what the trainer's data path yields (tests/shape_buckets.rs).
pub fn sample_stream(
    config: &TrainConfig,
    shards: &[PathBuf],
    front_end: Arc<dyn features::FrontEnd>,
    (centre, start): ([f64; 3], u64),
    spill_path: &Path,
    progress: bool,
) -> Result<FrameStream<Prepared>, TrainError> {
    let stream_cfg = StreamConfig {
        shuffle_buffer: config.shuffle_buffer,
        // A step takes `batch_frames` samples at once: a smaller queue would leave the
        // reader idle during the step and the step waiting for it at the next one.
        prefetch: config.prefetch.max(2 * config.batch_frames),
        seed: config.seed,
        chunk_cache_bytes: (config.chunk_cache_mib as u64) << 20,
        workers: config.sample_workers(),
    };
    let (aug, limits, seed) = (config.augment.clone(), config.limits.clone(), config.seed);
    let batch = config.batch_frames as u64;
    let mut cache = DescriptorCache::new(config.descriptor_cache_mib);
    // Unaugmented samples take their descriptors from the cache: describe every frame
    // once, up front on every core, into memory and past its budget into the spill file
    // (descriptor_cache.rs). Results do not depend on it.
    if config.descriptor_cache_mib > 0 && config.augment.probability < 1.0 {
        let bar = progress_bar(0, 0, progress);
        bar.set_message("describing frames for the descriptor cache");
        let key = spill_key(front_end.config(), shards)?;
        let target = SpillTarget {
            path: spill_path,
            key,
        };
        // No augmentation: no sample decodes an image, so the reader can hand out the
        // frames' labels from memory instead of decompressing their chunks.
        if config.augment.probability == 0.0 {
            cache.hold_records();
        }
        cache.prefill(shards, front_end.as_ref(), &bar, Some(target))?;
        bar.finish_and_clear();
        if cache.spilled() > 0 {
            tracing::info!(
                "descriptors: {} frames in memory, {} in {}",
                cache.len(),
                cache.spilled(),
                spill_path.display()
            );
        }
    }
    let records = cache.take_records().map(Arc::new);
    let cache = Arc::new(cache);
    // Runs on the sample workers: a sample's randomness is its stream position's, so
    // the samples do not depend on which worker prepares them or how many there are.
    FrameStream::start_with_records(
        shards,
        stream_cfg,
        start * batch,
        records,
        move |at, frame| {
            let mut rng = seeds::rng(seed, Purpose::Sample, at.position);
            let mut p = prepare_with_cache(
                &frame,
                front_end.as_ref(),
                Some(&aug),
                &limits,
                &mut rng,
                Some(&cache),
            )?;
            recentre(&mut p.sample, &centre);
            Ok(p)
        },
    )
}

/// The key of a spill file: the front-end's configuration and each shard's name, size
/// and modification time (a rewritten shard set is another set).
fn spill_key(
    front_end: &features::FrontEndConfig,
    shards: &[PathBuf],
) -> Result<[u8; 32], TrainError> {
    let mut text = serde_json::to_string(front_end)
        .map_err(|e| TrainError::Config(format!("front-end configuration: {e}")))?;
    for path in shards {
        let meta = std::fs::metadata(path).map_err(io_err(path))?;
        let modified = meta
            .modified()
            .ok()
            .and_then(|t| t.duration_since(std::time::UNIX_EPOCH).ok())
            .map_or(0, |d| d.as_nanos());
        text.push_str(&format!("\n{} {} {modified}", path.display(), meta.len()));
    }
    let hex = stage::sha256_bytes(text.as_bytes());
    let mut key = [0u8; 32];
    key.copy_from_slice(&hex.as_bytes()[..32]);
    Ok(key)
}

/// The next `n` samples of the stream, and the frame id of the first (the metrics row's).
fn next_batch(
    stream: &mut FrameStream<Prepared>,
    n: usize,
) -> Result<(Vec<model::Sample>, u64), TrainError> {
    let mut samples = Vec::with_capacity(n);
    let mut frame_id = 0;
    for k in 0..n {
        let (_, p) = stream.next_item()?;
        if k == 0 {
            frame_id = p.frame_id;
        }
        samples.push(p.sample);
    }
    Ok((samples, frame_id))
}

/// One row of `metrics.csv`; `(seconds, data_seconds)`: the step's wall time and the
/// part of it spent waiting for samples.
fn metrics_row(
    iteration: u64,
    frame_id: u64,
    samples: &[model::Sample],
    losses: LossValues,
    lr: f64,
    (seconds, data_seconds): (f64, f64),
) -> MetricsRow {
    MetricsRow {
        iteration,
        frame_id,
        losses,
        lr,
        keypoints: samples.iter().map(|s| s.keypoints.len()).sum(),
        labelled_points: samples
            .iter()
            .map(|s| s.point_valid.iter().filter(|v| **v).count())
            .sum(),
        lines: samples.iter().map(|s| s.segments.len()).sum(),
        labelled_lines: samples
            .iter()
            .map(|s| s.line_valid.iter().filter(|v| **v).count())
            .sum(),
        seconds,
        data_seconds,
    }
}

/// [`crate::checkpoint::parameter_bytes`]), for comparisons.
pub fn model_parameter_bytes(path: &Path) -> Result<Vec<u8>, TrainError> {
    let net = CheckpointFile::read(path)?.model::<model::CpuBackend>(&Default::default())?;
    Ok(crate::checkpoint::parameter_bytes(&net))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::augment::AugmentConfig;
    use crate::sample::Limits;
    use crate::testutil::write_synthetic_shards;
    use model::LayerKind;

    fn tiny_config() -> TrainConfig {
        let mut c = TrainConfig::default();
        c.model.line_tokens = 4;
        c.front_end.samples_per_line = 4;
        c.model.ffn_dim = 32;
        c.model.layers = vec![LayerKind::SelfAttention, LayerKind::Cross];
        c.model.head_hidden = vec![32];
        c.iterations = 9;
        c.checkpoint_every = 3;
        c.learning_rate = 1e-3;
        c.lr_halvings = 2;
        c.seed = 21;
        c.shuffle_buffer = 3;
        c.prefetch = 2;
        c.limits = Limits {
            max_keypoints: 24,
            max_lines: 4,
        };
        c.augment = AugmentConfig {
            probability: 0.5,
            ..Default::default()
        };
        c
    }

    fn opts(out: &Path) -> RunOptions {
        RunOptions {
            out_dir: out.to_path_buf(),
            ..Default::default()
        }
    }

    /// A run stopped after 5 iterations (last checkpoint at 3) and resumed ends with
    /// byte-identical weights (and files) to an uninterrupted run, and its metrics table lists every
    /// iteration once with the same losses.
    #[test]
    fn resumed_run_matches_an_uninterrupted_one() {
        resume_matches(1);
    }

    /// The same with 3 images per step: the stream resumes at 3 x the iteration.
    #[test]
    fn resumed_batched_run_matches_an_uninterrupted_one() {
        resume_matches(3);
    }

    /// And in two gradient groups (side by side on the training threads): the resumed
    /// run's groups make the same weights as the uninterrupted run's.
    #[test]
    fn resumed_run_in_gradient_groups_matches_an_uninterrupted_one() {
        let dir = tempfile::tempdir().unwrap();
        let mut cfg = tiny_config();
        cfg.batch_groups = 2;
        resume_matches_with(dir.path(), 3, cfg);
    }

    /// `--resume` of a finished run with more iterations continues to the new count (and
    /// says so in the summary's configuration); a resume asking another learning rate is
    /// refused naming it, before anything is written.
    #[test]
    fn resume_continues_to_a_new_count_and_refuses_other_settings() {
        let dir = tempfile::tempdir().unwrap();
        let shards = write_synthetic_shards(dir.path(), 2, 4, 0.0);
        let cfg = tiny_config();
        let out = dir.path().join("run");
        train(cfg.clone(), &shards, &opts(&out)).unwrap();
        let nine = model_parameter_bytes(&out.join(MODEL_FILE)).unwrap();
        let resume = RunOptions {
            resume: true,
            ..opts(&out)
        };
        let faster = TrainConfig {
            learning_rate: 1e-2,
            iterations: 12,
            ..cfg.clone()
        };
        let e = train(faster, &shards, &resume).unwrap_err().to_string();
        assert!(
            e.contains("learning_rate (checkpoint 0.001, asked 0.01)"),
            "{e}"
        );
        assert_eq!(model_parameter_bytes(&out.join(MODEL_FILE)).unwrap(), nine);
        let longer = TrainConfig {
            iterations: 12,
            workers: 2,
            ..cfg.clone()
        };
        let s = train(longer, &shards, &resume).unwrap();
        assert_eq!((s.resumed_from, s.iterations_done), (Some(9), 12));
        assert_eq!(s.config.iterations, 12);
        assert!(s.finished);
        assert_ne!(model_parameter_bytes(&out.join(MODEL_FILE)).unwrap(), nine);
        let header = CheckpointFile::read(&out.join(MODEL_FILE)).unwrap().header;
        assert_eq!((header.iteration, header.config.iterations), (12, 12));
    }

    fn resume_matches(batch_frames: usize) {
        let dir = tempfile::tempdir().unwrap();
        resume_matches_with(dir.path(), batch_frames, tiny_config());
    }

    /// SuperPoint weights made by the PyTorch peer (random, seeded), or None after a
    /// printed skip when PL2MAP_PYTHON has no torch.
    fn superpoint_weights(dir: &Path, seed: u64) -> Option<PathBuf> {
        let python = testkit::python::python(&["torch"])?;
        let path = dir.join(format!("superpoint-{seed}.pth"));
        testkit::python::run(
            std::process::Command::new(python)
                .arg(concat!(
                    env!("CARGO_MANIFEST_DIR"),
                    "/../superpoint/tests/superpoint_torch.py"
                ))
                .arg("weights")
                .arg(&path)
                .arg(seed.to_string()),
        );
        Some(path)
    }

    fn superpoint_config(weights: &Path) -> TrainConfig {
        let mut c = tiny_config();
        c.front_end.kind = features::FrontEndKind::Superpoint;
        c.front_end.superpoint.weights = Some(weights.to_path_buf());
        c.model.descriptor_dim = features::SUPERPOINT_DIM;
        c
    }

    /// D = 256 with SuperPoint descriptors recomputed on augmented images: a stopped and
    /// resumed run equals the uninterrupted one; the checkpoint records the weights'
    /// hash, and a predictor refuses other weights.
    #[test]
    fn superpoint_run_resumes_exactly_and_records_its_weights() {
        let dir = tempfile::tempdir().unwrap();
        let Some(weights) = superpoint_weights(dir.path(), 5) else {
            return;
        };
        let cfg = superpoint_config(&weights);
        // The model's width must follow the front-end.
        let mut wrong = cfg.clone();
        wrong.model.descriptor_dim = 128;
        let e = wrong.validate().unwrap_err().to_string();
        assert!(e.contains("superpoint") && e.contains("256"), "{e}");
        let out = resume_matches_with(dir.path(), 2, cfg);
        let ck = CheckpointFile::read(&out.join(MODEL_FILE)).unwrap();
        let fe = &ck.header.config.front_end;
        assert_eq!(fe.kind, features::FrontEndKind::Superpoint);
        assert_eq!(
            fe.superpoint.weights_sha256.as_deref(),
            Some(superpoint::file_sha256(&weights).unwrap().as_str())
        );
        let p = crate::Predictor::load(&out.join(MODEL_FILE)).unwrap();
        assert_eq!(p.front_end().dim(), 256);
        let f = crate::testutil::frame(3, 40, 6, 0.0);
        let gray = crate::sample::decode_gray(&f).unwrap();
        let pred = p.predict(&gray, &f.camera).unwrap();
        assert!(!pred.points.is_empty());
        // Other weights under the recorded file name: refused, naming both.
        let other = superpoint_weights(dir.path(), 6).unwrap();
        std::fs::copy(&other, &weights).unwrap();
        let e = crate::Predictor::load(&out.join(MODEL_FILE))
            .err()
            .unwrap()
            .to_string();
        assert!(
            e.contains("sha256") && e.contains(&weights.display().to_string()),
            "{e}"
        );
    }

    /// A few hundred steps at D = 256 on SuperPoint descriptors lower the map loss.
    #[test]
    fn superpoint_training_lowers_the_map_loss() {
        let dir = tempfile::tempdir().unwrap();
        let Some(weights) = superpoint_weights(dir.path(), 5) else {
            return;
        };
        let mut cfg = superpoint_config(&weights);
        // Unit 256-d rows have a per-channel scale of 1/16 (docs/method.md section 2,
        // "Input scale").
        cfg.model.point_input_scale = 16.0;
        lowers_the_map_loss(cfg, 0.8);
    }

    /// Runs the comparison in `dir`; returns the uninterrupted run's folder.
    fn resume_matches_with(dir: &Path, batch_frames: usize, cfg: TrainConfig) -> PathBuf {
        let shards = write_synthetic_shards(&dir.join("."), 2, 4, 0.0);
        let mut cfg = cfg;
        cfg.batch_frames = batch_frames;

        let a = dir.join("a");
        let full = train(cfg.clone(), &shards, &opts(&a)).unwrap();
        assert!(full.finished);
        assert_eq!(full.iterations_done, 9);
        assert_eq!(full.frames_per_epoch, 8);

        let b = dir.join("b");
        let stopped = train(
            cfg.clone(),
            &shards,
            &RunOptions {
                stop_after: Some(5),
                ..opts(&b)
            },
        )
        .unwrap();
        assert!(!stopped.finished);
        assert!(!b.join(MODEL_FILE).exists());
        assert_eq!(
            CheckpointFile::read(&b.join(CHECKPOINT_FILE))
                .unwrap()
                .header
                .iteration,
            3
        );
        // Without --resume the folder is refused.
        assert!(train(cfg.clone(), &shards, &opts(&b)).is_err());
        // A resume under another configuration is refused, naming what differs, and
        // leaves the folder as it was.
        let ckpt_before = std::fs::read(b.join(CHECKPOINT_FILE)).unwrap();
        let other = TrainConfig {
            batch_frames,
            ..TrainConfig::default()
        };
        let e = train(
            other,
            &shards,
            &RunOptions {
                resume: true,
                ..opts(&b)
            },
        )
        .unwrap_err()
        .to_string();
        assert!(
            e.contains("model (checkpoint") && e.contains("--resume"),
            "{e}"
        );
        assert_eq!(std::fs::read(b.join(CHECKPOINT_FILE)).unwrap(), ckpt_before);
        assert!(!b.join(MODEL_FILE).exists());
        let resumed = train(
            cfg.clone(),
            &shards,
            &RunOptions {
                resume: true,
                ..opts(&b)
            },
        )
        .unwrap();
        assert_eq!(resumed.resumed_from, Some(3));
        assert!(resumed.finished);
        let wa = model_parameter_bytes(&a.join(MODEL_FILE)).unwrap();
        assert_eq!(wa, model_parameter_bytes(&b.join(MODEL_FILE)).unwrap());
        // The files too, Adam's state included: parameter ids follow the network's
        // structure and the optimiser record is written in id order.
        for file in [MODEL_FILE, CHECKPOINT_FILE] {
            let read = |dir: &Path| std::fs::read(dir.join(file)).unwrap();
            assert!(read(&a) == read(&b), "{file} differs between the two runs");
        }
        // Training changed the weights (the comparison is not vacuous).
        let init = cfg
            .model
            .init::<model::CpuBackend>(cfg.seed, &Default::default())
            .unwrap();
        assert_ne!(wa, crate::checkpoint::parameter_bytes(&init));
        let strip_seconds = |p: &Path| -> Vec<String> {
            std::fs::read_to_string(p)
                .unwrap()
                .lines()
                .map(|l| l.rsplitn(3, ',').nth(2).unwrap().to_string())
                .collect()
        };
        let rows = strip_seconds(&a.join("metrics.csv"));
        assert_eq!(rows.len(), 10);
        assert_eq!(rows, strip_seconds(&b.join("metrics.csv")));
        assert!(a.join(PLOT_FILE).is_file());

        // A warm start from the finished model: same weights at iteration 0, fresh Adam.
        let c = dir.join("c");
        let warm = train(
            cfg.clone(),
            &shards,
            &RunOptions {
                init: Some(a.join(MODEL_FILE)),
                iterations: Some(2),
                ..opts(&c)
            },
        )
        .unwrap();
        assert_eq!(warm.iterations_done, 2);
        let mut other = cfg.clone();
        other.model.head_hidden = vec![16];
        let e = train(
            other,
            &shards,
            &RunOptions {
                init: Some(a.join(MODEL_FILE)),
                ..opts(&dir.join("d"))
            },
        )
        .unwrap_err();
        assert!(e.to_string().contains("network"), "{e}");
        a
    }

    /// With image augmentation at the reference's rate, 1, 2 and 3 sample workers give
    /// byte-identical models and checkpoints (Adam's state included) and the same
    /// losses at every step.
    #[test]
    fn any_number_of_workers_trains_the_same_weights() {
        let dir = tempfile::tempdir().unwrap();
        let shards = write_synthetic_shards(dir.path(), 2, 4, 0.0);
        let mut cfg = tiny_config();
        cfg.batch_frames = 2;
        cfg.augment.probability = 0.5;
        let run = |workers: usize| -> (Vec<u8>, Vec<u8>, Vec<String>) {
            let out = dir.path().join(format!("w{workers}"));
            let mut c = cfg.clone();
            c.workers = workers;
            train(c, &shards, &opts(&out)).unwrap();
            let read = |f: &str| std::fs::read(out.join(f)).unwrap();
            // Every column but the two timings.
            let rows = std::fs::read_to_string(out.join("metrics.csv"))
                .unwrap()
                .lines()
                .map(|l| l.rsplitn(3, ',').nth(2).unwrap().to_string())
                .collect();
            (read(MODEL_FILE), read(CHECKPOINT_FILE), rows)
        };
        let one = run(1);
        assert!(one.2.len() == 10, "{:?}", one.2);
        assert!(run(2) == one, "2 workers differ from 1");
        assert!(run(3) == one, "3 workers differ from 1");
        // The record does not count the workers: more of them is not a new run.
        let mut more = cfg.clone();
        more.workers = 4;
        assert_eq!(more.for_record(), cfg.for_record());
        assert!(!more.to_toml().contains("device"));
    }

    #[test]
    fn cuda_in_a_cpu_build_is_refused_before_anything_is_written() {
        if model::device::CUDA_BUILT {
            return;
        }
        let dir = tempfile::tempdir().unwrap();
        let shards = write_synthetic_shards(dir.path(), 1, 2, 0.0);
        let mut cfg = tiny_config();
        cfg.device = Device::Cuda(1);
        let out = dir.path().join("o");
        let e = train(cfg.clone(), &shards, &opts(&out))
            .unwrap_err()
            .to_string();
        assert!(e.contains("cuda:1") && e.contains("--features cuda"), "{e}");
        assert!(!out.exists());
        assert!(cfg.validate().is_err());
    }

    #[test]
    fn training_lowers_the_map_loss() {
        lowers_the_map_loss(tiny_config(), 0.7);
    }

    /// The mean map loss of the last 10 of 200 steps is under `ratio` x that of the first 5
    /// (random-weight SuperPoint descriptors are weak: 0.8 for them).
    fn lowers_the_map_loss(cfg: TrainConfig, ratio: f64) {
        let dir = tempfile::tempdir().unwrap();
        let shards = write_synthetic_shards(dir.path(), 1, 2, 0.0);
        let mut cfg = cfg;
        cfg.iterations = 200;
        cfg.checkpoint_every = 1000;
        cfg.augment.probability = 0.0;
        cfg.model.dropout = 0.0;
        cfg.learning_rate = 3e-3;
        cfg.lr_halvings = 1;
        let out = dir.path().join("o");
        let s = train(cfg, &shards, &opts(&out)).unwrap();
        let cols = crate::metrics::read_columns(&s.metrics, &["map_points", "lr"]).unwrap();
        let first: f64 = cols[0][..5].iter().sum::<f64>() / 5.0;
        let last: f64 = cols[0][190..].iter().sum::<f64>() / 10.0;
        assert!(last < ratio * first, "{first} -> {last}");
        assert_eq!(cols[1][0], 3e-3);
        assert_eq!(cols[1][199], 1.5e-3);
    }
}
