//! The training configuration (TOML-friendly; every field has a default) and the
//! learning-rate schedule.

use crate::augment::AugmentConfig;
use crate::error::TrainError;
use features::FrontEndConfig;
use model::{Device, LossConfig, ModelConfig};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// Per-sample limits (the rest is subsampled, seeded).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Limits {
    pub max_keypoints: usize,
    pub max_lines: usize,
}

impl Default for Limits {
    fn default() -> Self {
        Limits {
            max_keypoints: 1024,
            max_lines: 128,
        }
    }
}

/// The shape of the learning-rate decay.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum LrSchedule {
    /// The reference's: `lr_halvings + 1` equal parts, part k at `learning_rate / 2^k`.
    #[default]
    Steps,
    /// A half cosine from `learning_rate` down to `learning_rate / 2^lr_halvings`. Each
    /// halving of the step schedule gives an immediate drop of the loss (the steps were
    /// noise-limited), so a smooth decay spends fewer iterations at a too-high rate.
    Cosine,
}

/// Whether a run pads its images to shape buckets (`TrainConfig::shape_buckets`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ShapeBuckets {
    /// On the JIT engine (`cuda[:N]`), off elsewhere.
    #[default]
    Auto,
    On,
    Off,
}

impl ShapeBuckets {
    fn is_auto(&self) -> bool {
        *self == ShapeBuckets::Auto
    }

    /// Whether a run on `device` pads.
    pub fn pads_on(self, device: Device) -> bool {
        match self {
            ShapeBuckets::On => true,
            ShapeBuckets::Off => false,
            ShapeBuckets::Auto => matches!(device, Device::Cuda(_)),
        }
    }
}

impl std::fmt::Display for ShapeBuckets {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            ShapeBuckets::Auto => "auto",
            ShapeBuckets::On => "on",
            ShapeBuckets::Off => "off",
        })
    }
}

impl std::str::FromStr for ShapeBuckets {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "auto" => Ok(ShapeBuckets::Auto),
            "on" => Ok(ShapeBuckets::On),
            "off" => Ok(ShapeBuckets::Off),
            _ => Err(format!("expected auto, on or off, got {s:?}")),
        }
    }
}

/// The train stage's configuration: `[train]` of a pipeline file, `pl2map train
/// --config FILE` and the flags of `pl2map train` (the top-level settings; the nested
/// sections come from a file); the only place its settings and defaults live.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, clap::Args)]
#[serde(default, deny_unknown_fields)]
pub struct TrainConfig {
    /// The network (D must be the front-end's descriptor size: 128 for SIFT, 256 for
    /// SuperPoint).
    #[arg(skip = TrainConfig::default().model)]
    pub model: ModelConfig,
    #[arg(skip = TrainConfig::default().loss)]
    pub loss: LossConfig,
    /// The front-end: descriptors at training positions, and the whole detection path
    /// of the predictor (stored in every checkpoint so both sides agree).
    #[arg(skip = TrainConfig::default().front_end)]
    pub front_end: FrontEndConfig,
    /// Keypoints the predictor keeps per query image (top-K by the detector's score).
    #[arg(long, default_value_t = TrainConfig::default().query_max_keypoints)]
    pub query_max_keypoints: usize,
    /// One iteration = one Adam step on `batch_frames` images.
    #[arg(long, default_value_t = TrainConfig::default().iterations)]
    pub iterations: u64,
    /// Images per step (their losses averaged). The reference uses 1 and 1.5 M steps; a
    /// step's images come from one region of the scene, and on a short CPU budget
    /// several images per step learn much faster (docs/training-notes.md, "Earlier measurements"). Images of equal
    /// size (the limits make most so) go through the network stacked, so a step of 8
    /// costs far less than 8 steps of 1.
    #[arg(long, default_value_t = TrainConfig::default().batch_frames)]
    pub batch_frames: usize,
    /// Gradient groups per step: the step's images split into this many groups whose
    /// forward and backward passes run side by side on the CPU's cores (one after
    /// another on a GPU), their gradients summed (`crates/train/src/step/groups.rs`). 1: one stacked
    /// pass. On 2 cores two groups make the main job's step about a third faster: its
    /// products are too small for two threads to share one. Part of the result, not a
    /// speed setting: a group sums its own rows, so the grouping changes the rounding
    /// (never the thread count).
    // Written only when not 1: records of runs made before it existed hold.
    #[serde(skip_serializing_if = "is_one")]
    #[arg(long, default_value_t = TrainConfig::default().batch_groups)]
    pub batch_groups: usize,
    /// Pad each step's images to a few fixed sizes (`crates/model/src/buckets.rs`: the
    /// next size of a short ladder of `limits`; padded rows are masked out of attention
    /// and of every loss term): `on`, `off`, or `auto`, which pads on the JIT engine
    /// (`cuda[:N]`, CubeCL, which compiles its kernels for each new tensor shape: without
    /// buckets nearly every step has new ones) and not on the others (the Flex CPU
    /// default keeps its speed; LibTorch runs precompiled kernels for any shape). The
    /// real rows' losses and gradients are the same up to float rounding, but dropout
    /// masks are drawn for the padded tensors. The predictor pads the same way.
    // Written only when not auto: records of runs made before it existed hold.
    #[serde(skip_serializing_if = "ShapeBuckets::is_auto")]
    #[arg(long, default_value_t = TrainConfig::default().shape_buckets)]
    pub shape_buckets: ShapeBuckets,
    #[arg(long, default_value_t = TrainConfig::default().learning_rate)]
    /// Adam's learning rate at the start.
    pub learning_rate: f64,
    /// How the learning rate falls from `learning_rate` to `learning_rate / 2^lr_halvings`.
    #[arg(long, default_value_t = TrainConfig::default().lr_schedule)]
    pub lr_schedule: LrSchedule,
    /// The learning rate ends at `learning_rate / 2^lr_halvings`.
    #[arg(long, default_value_t = TrainConfig::default().lr_halvings)]
    pub lr_halvings: u32,
    /// Write a checkpoint every N iterations (and always at the end).
    #[arg(long, default_value_t = TrainConfig::default().checkpoint_every)]
    pub checkpoint_every: u64,
    #[arg(long, default_value_t = TrainConfig::default().seed)]
    /// Seed of the run (initial weights, order, augmentation, dropout).
    pub seed: u64,
    #[arg(skip = TrainConfig::default().augment)]
    pub augment: AugmentConfig,
    #[arg(skip = TrainConfig::default().limits)]
    pub limits: Limits,
    /// Frames in the stream's shuffle buffer. The default, 4096, holds a whole 7-Scenes or
    /// Cambridge training split, so every batch draws from the whole scene. A buffer much
    /// smaller than the split makes batches of neighbouring frames of one sequence (shards
    /// keep file order), and the network chases the window: on the synthetic scene,
    /// 5000 steps of the same configuration gave a median test error of 17.6 cm with 64
    /// frames and 9.4 cm with 256 (all 200 training frames). The buffer holds frame ids
    /// only; what a large one costs is reads out of file order, which `chunk_cache_mib`
    /// absorbs.
    #[arg(long, default_value_t = TrainConfig::default().shuffle_buffer)]
    pub shuffle_buffer: usize,
    /// Prepared samples kept ready by the background thread (at least two steps' worth,
    /// `2 * batch_frames`, whatever this says).
    #[arg(long, default_value_t = TrainConfig::default().prefetch)]
    pub prefetch: usize,
    /// Memory for the descriptors of unaugmented images (MiB; 0: none): such a sample
    /// then needs no front-end call. Changes speed only, never values.
    #[arg(long, default_value_t = TrainConfig::default().descriptor_cache_mib)]
    pub descriptor_cache_mib: usize,
    /// Memory for decompressed shard chunks (MiB): the shuffle buffer reads frames out
    /// of file order, and each read outside the cache decompresses a whole chunk
    /// (4 MiB by default) on the reader thread. Changes speed only, never values.
    #[arg(long, default_value_t = TrainConfig::default().chunk_cache_mib)]
    pub chunk_cache_mib: usize,
    /// Where the network trains: `cpu`, `cuda` or `cuda:N` (builds with the `cuda`
    /// feature; README.md, "GPUs and sample workers").
    // Written only when not the CPU: records of CPU runs made before it existed hold.
    #[serde(skip_serializing_if = "Device::is_cpu")]
    #[arg(long, default_value_t = TrainConfig::default().device)]
    pub device: Device,
    /// Threads that prepare samples (decode, augment, describe) ahead of the step; 0:
    /// the cores the step leaves (1 on the CPU, all but one with CUDA). The samples and
    /// the weights are the same for any number (each sample's randomness comes from its
    /// place in the stream). Speed only: not part of the stage record.
    #[serde(skip_serializing_if = "is_zero")]
    #[arg(long, default_value_t = TrainConfig::default().workers)]
    pub workers: usize,
}

/// `over`'s keys written into `base`: tables merged key by key at every depth, any other
/// value (arrays included) replaced whole.
fn merge_over(base: &mut toml::Table, over: toml::Table) {
    for (key, value) in over {
        match (base.get_mut(&key), value) {
            (Some(toml::Value::Table(b)), toml::Value::Table(o)) => merge_over(b, o),
            (_, v) => {
                base.insert(key, v);
            }
        }
    }
}

fn is_zero(v: &usize) -> bool {
    *v == 0
}

fn is_one(v: &usize) -> bool {
    *v == 1
}

impl std::fmt::Display for LrSchedule {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            LrSchedule::Steps => "steps",
            LrSchedule::Cosine => "cosine",
        })
    }
}

impl std::str::FromStr for LrSchedule {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "steps" => Ok(LrSchedule::Steps),
            "cosine" => Ok(LrSchedule::Cosine),
            _ => Err(format!("expected steps or cosine, got {s:?}")),
        }
    }
}

impl Default for TrainConfig {
    fn default() -> Self {
        TrainConfig {
            model: ModelConfig::sift(),
            loss: LossConfig::indoor(),
            front_end: FrontEndConfig::default(),
            query_max_keypoints: 2048,
            iterations: 10_000,
            batch_frames: 1,
            batch_groups: 1,
            shape_buckets: ShapeBuckets::Auto,
            learning_rate: 3e-4,
            lr_schedule: LrSchedule::Steps,
            lr_halvings: 7,
            checkpoint_every: 1000,
            seed: 0,
            augment: AugmentConfig::default(),
            limits: Limits::default(),
            shuffle_buffer: 4096,
            prefetch: 4,
            descriptor_cache_mib: 1024,
            chunk_cache_mib: 256,
            device: Device::Cpu,
            workers: 0,
        }
    }
}

impl TrainConfig {
    /// A training configuration file: the bare form (`iterations = ...`, `[model]` ...)
    /// or a file holding only a pipeline's `[train]` section as it is (`[train]`,
    /// `[train.model]` ...). Keys left out take their defaults at any depth (a `[model]`
    /// table that names only `head_hidden` keeps the default network otherwise); an
    /// unknown key is refused. A whole pipeline file is refused, saying how to run it.
    pub fn from_toml_file(path: &Path) -> Result<Self, TrainError> {
        let file_err = |reason: String| TrainError::ConfigFile {
            path: path.to_path_buf(),
            reason,
        };
        let text = std::fs::read_to_string(path).map_err(|e| file_err(e.to_string()))?;
        let cfg = Self::from_toml_str(&text).map_err(file_err)?;
        cfg.validate()?;
        Ok(cfg)
    }

    /// [`TrainConfig::from_toml_file`] of a file's text; the error is the reason.
    pub fn from_toml_str(text: &str) -> Result<Self, String> {
        let mut table: toml::Table = toml::from_str(text).map_err(|e| e.to_string())?;
        if let Some(toml::Value::Table(section)) = table.get("train") {
            let others: Vec<&String> = table.keys().filter(|k| *k != "train").collect();
            if !others.is_empty() {
                return Err(format!(
                    "holds a [train] section beside {}: a pipeline file runs with `pl2map run                      FILE` (its [features] section also sets the network's descriptor size);                      give `pl2map train --config` the [train] section alone, or its keys                      without the section header",
                    others
                        .iter()
                        .map(|k| format!("`{k}`"))
                        .collect::<Vec<_>>()
                        .join(", ")
                ));
            }
            table = section.clone();
        }
        let mut merged = toml::Table::try_from(TrainConfig::default())
            .map_err(|e| format!("the default configuration as TOML: {e}"))?;
        merge_over(&mut merged, table);
        toml::Value::Table(merged)
            .try_into()
            .map_err(|e: toml::de::Error| e.to_string())
    }

    pub fn to_toml(&self) -> String {
        // Every field is a plain table or value: serialisation cannot fail.
        toml::to_string_pretty(self).unwrap_or_default()
    }

    pub fn validate(&self) -> Result<(), TrainError> {
        let bad = |m: String| Err(TrainError::Config(m));
        self.model.validate()?;
        self.loss.validate()?;
        self.front_end.validate()?;
        if self.model.descriptor_dim != self.front_end.dim() {
            return bad(format!(
                "model.descriptor_dim is {} but the {} front-end's descriptors have {}",
                self.model.descriptor_dim,
                self.front_end.kind,
                self.front_end.dim()
            ));
        }
        if self.model.line_tokens != self.front_end.samples_per_line {
            return bad(format!(
                "model.line_tokens ({}) must equal front_end.samples_per_line ({})",
                self.model.line_tokens, self.front_end.samples_per_line
            ));
        }
        if self.iterations == 0 {
            return bad("iterations must be at least 1".into());
        }
        if self.batch_frames == 0 {
            return bad("batch_frames must be at least 1".into());
        }
        if self.batch_groups == 0 || self.batch_groups > self.batch_frames {
            return bad(format!(
                "batch_groups must be between 1 and batch_frames ({}), got {}",
                self.batch_frames, self.batch_groups
            ));
        }
        if !(self.learning_rate.is_finite() && self.learning_rate > 0.0) {
            return bad(format!(
                "learning_rate must be positive, got {}",
                self.learning_rate
            ));
        }
        if self.checkpoint_every == 0 {
            return bad("checkpoint_every must be at least 1".into());
        }
        let a = &self.augment;
        let in_range = (0.0..=1.0).contains(&a.probability)
            && a.scale_min > 0.0
            && a.scale_min <= a.scale_max
            && a.scale_max.is_finite()
            && a.brightness >= 0.0
            && a.contrast >= 0.0
            && a.max_rotation_deg >= 0.0
            && a.descriptor_noise.is_finite()
            && a.descriptor_noise >= 0.0;
        if !in_range {
            return bad(format!("augment is out of range: {a:?}"));
        }
        if self.limits.max_keypoints == 0 && self.limits.max_lines == 0 {
            return bad("limits leave nothing to train on".into());
        }
        if self.query_max_keypoints == 0 {
            return bad("query_max_keypoints must be at least 1".into());
        }
        self.device.check_built().or_else(|e| bad(e.to_string()))?;
        Ok(())
    }

    /// The sample workers of a run: `workers`, or when 0 the cores the step leaves. On
    /// the CPU the step's matrix products take every core, so one worker prepares ahead
    /// of it; with CUDA the step needs one core to drive the GPU and the rest prepare.
    pub fn sample_workers(&self) -> usize {
        if self.workers > 0 {
            return self.workers;
        }
        let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
        match self.device {
            Device::Cpu | Device::LibTorchCpu => 1,
            Device::Cuda(_) | Device::LibTorchCuda(_) => cores.saturating_sub(1).max(1),
        }
    }

    /// The bucket limits of a training run on `device` (`shape_buckets`): the
    /// `limits`, or None when it does not pad.
    pub fn training_buckets(&self, device: Device) -> Option<model::buckets::BucketLimits> {
        self.shape_buckets
            .pads_on(device)
            .then_some(model::buckets::BucketLimits {
                points: self.limits.max_keypoints,
                lines: self.limits.max_lines,
            })
    }

    /// The bucket limits of the predictor on `device`: the query's top-K keypoints, and
    /// no line limit (a query image keeps all its segments, padded to the next power of
    /// two, `buckets::bucket`); None when it does not pad.
    pub fn query_buckets(&self, device: Device) -> Option<model::buckets::BucketLimits> {
        self.shape_buckets
            .pads_on(device)
            .then_some(model::buckets::BucketLimits {
                points: self.query_max_keypoints,
                lines: 0,
            })
    }

    /// The configuration as a stage record hashes it: without the settings that change
    /// only the speed of a run (`workers`), so a rerun with more workers is up to date.
    pub fn for_record(&self) -> TrainConfig {
        TrainConfig {
            workers: 0,
            ..self.clone()
        }
    }

    /// A network of a few thousand parameters on 4 samples per line and at most 50 query
    /// keypoints: for tests and smoke runs of the code paths, not for maps.
    pub fn tiny() -> TrainConfig {
        let mut c = TrainConfig::default();
        c.model.line_tokens = 4;
        c.front_end.samples_per_line = 4;
        c.model.ffn_dim = 32;
        c.model.layers = vec![model::LayerKind::SelfAttention];
        c.model.head_hidden = vec![16];
        c.query_max_keypoints = 50;
        c
    }

    /// The learning rate of iteration `i` (0-based); see [`LrSchedule`]. A pure function
    /// of the configuration and `i`, so a resumed run follows the same schedule.
    pub fn learning_rate_at(&self, i: u64) -> f64 {
        let n = self.iterations.max(1);
        match self.lr_schedule {
            LrSchedule::Steps => {
                let parts = self.lr_halvings as u64 + 1;
                let k = ((i as u128 * parts as u128) / n as u128) as u64;
                self.learning_rate * 0.5f64.powi(k.min(self.lr_halvings as u64) as i32)
            }
            LrSchedule::Cosine => {
                let last = self.learning_rate * 0.5f64.powi(self.lr_halvings as i32);
                // Progress runs 0 -> 1 over iterations 0 .. n-1; later ones stay at the end.
                let t = (i.min(n - 1) as f64 / (n - 1).max(1) as f64).clamp(0.0, 1.0);
                last + (self.learning_rate - last) * 0.5 * (1.0 + (std::f64::consts::PI * t).cos())
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_config_is_valid_and_round_trips_through_toml() {
        let c = TrainConfig::default();
        c.validate().unwrap();
        let back: TrainConfig = toml::from_str(&c.to_toml()).unwrap();
        assert_eq!(back, c);
        // A partial file keeps the defaults for the rest.
        let p: TrainConfig = toml::from_str("iterations = 50\n[limits]\nmax_lines = 8\n").unwrap();
        assert_eq!(p.iterations, 50);
        assert_eq!(p.limits.max_lines, 8);
        assert_eq!(p.limits.max_keypoints, 1024);
        // Partial nested tables too (pipeline/synthetic.toml sets one loss weight).
        let p: TrainConfig = toml::from_str("[loss]\nweight_reprojection = 0.0\n").unwrap();
        assert_eq!(p.loss.weight_reprojection, 0.0);
        assert_eq!(p.loss.tau_max, LossConfig::indoor().tau_max);
        assert!(toml::from_str::<TrainConfig>("iteration = 5").is_err());
    }

    #[test]
    fn shape_buckets_default_to_auto_and_are_written_only_when_set() {
        let c = TrainConfig::default();
        assert_eq!(c.shape_buckets, ShapeBuckets::Auto);
        // A file written before the setting existed loads; a default one omits it.
        assert!(!c.to_toml().contains("shape_buckets"), "{}", c.to_toml());
        let old: TrainConfig = toml::from_str("iterations = 5\n").unwrap();
        assert_eq!(old.shape_buckets, ShapeBuckets::Auto);
        let on = TrainConfig::from_toml_str("[train]\nshape_buckets = \"on\"\n").unwrap();
        assert_eq!(on.shape_buckets, ShapeBuckets::On);
        assert!(on.to_toml().contains("shape_buckets = \"on\""));
        assert!(TrainConfig::from_toml_str("shape_buckets = \"maybe\"").is_err());
        // auto: the JIT engine pads, the Flex CPU default and LibTorch do not.
        assert!(ShapeBuckets::Auto.pads_on(Device::Cuda(0)));
        assert!(!ShapeBuckets::Auto.pads_on(Device::Cpu));
        assert!(!ShapeBuckets::Auto.pads_on(Device::LibTorchCuda(0)));
        assert!(ShapeBuckets::On.pads_on(Device::Cpu));
        assert!(!ShapeBuckets::Off.pads_on(Device::Cuda(1)));
        let limits = on.training_buckets(Device::Cpu).unwrap();
        assert_eq!((limits.points, limits.lines), (1024, 128));
        assert_eq!(c.training_buckets(Device::Cpu), None);
        assert_eq!(c.query_buckets(Device::Cuda(0)).unwrap().points, 2048);
    }

    #[test]
    fn learning_rate_halves_k_times_evenly() {
        let c = TrainConfig {
            iterations: 800,
            learning_rate: 1.0,
            lr_halvings: 3,
            ..Default::default()
        };
        assert_eq!(c.learning_rate_at(0), 1.0);
        assert_eq!(c.learning_rate_at(199), 1.0);
        assert_eq!(c.learning_rate_at(200), 0.5);
        assert_eq!(c.learning_rate_at(400), 0.25);
        assert_eq!(c.learning_rate_at(799), 0.125);
        assert_eq!(c.learning_rate_at(10_000), 0.125);
    }

    #[test]
    fn cosine_schedule_falls_smoothly_to_the_same_end() {
        let c = TrainConfig {
            iterations: 101,
            learning_rate: 1.0,
            lr_halvings: 3,
            lr_schedule: LrSchedule::Cosine,
            ..Default::default()
        };
        assert_eq!(c.learning_rate_at(0), 1.0);
        // Half way: the mean of the two ends.
        assert!((c.learning_rate_at(50) - (1.0 + 0.125) / 2.0).abs() < 1e-12);
        assert!((c.learning_rate_at(100) - 0.125).abs() < 1e-12);
        assert!((c.learning_rate_at(5_000) - 0.125).abs() < 1e-12);
        for i in 1..101 {
            assert!(c.learning_rate_at(i) < c.learning_rate_at(i - 1));
        }
        let one = TrainConfig { iterations: 1, ..c };
        assert_eq!(one.learning_rate_at(0), 1.0);
        let parsed: TrainConfig = toml::from_str("lr_schedule = \"cosine\"").unwrap();
        assert_eq!(parsed.lr_schedule, LrSchedule::Cosine);
        assert!(toml::from_str::<TrainConfig>("lr_schedule = \"linear\"").is_err());
    }

    /// One group (the default) is not written, so the records of runs made before the
    /// key existed still match; more groups than images is refused.
    #[test]
    fn batch_groups_default_to_one_and_are_written_only_when_not() {
        let text = TrainConfig::default().to_toml();
        assert!(!text.contains("batch_groups"), "{text}");
        let c: TrainConfig = toml::from_str("batch_frames = 16\nbatch_groups = 2").unwrap();
        assert_eq!(c.batch_groups, 2);
        c.validate().unwrap();
        assert!(c.to_toml().contains("batch_groups = 2"));
        assert_eq!(
            c.for_record().batch_groups,
            2,
            "the grouping is part of the result"
        );
        for (frames, groups) in [(2, 3), (4, 0)] {
            let bad = TrainConfig {
                batch_frames: frames,
                batch_groups: groups,
                ..Default::default()
            };
            let e = bad.validate().unwrap_err().to_string();
            assert!(
                e.contains("batch_groups") && e.contains(&groups.to_string()),
                "{e}"
            );
        }
    }

    /// `pl2map train --config` takes a pipeline's `[train]` section as it is or the bare
    /// form, the same configuration either way; keys left out of a nested table keep
    /// their defaults; a whole pipeline file and an unknown key are refused.
    #[test]
    fn config_files_in_both_forms_with_defaults_at_any_depth() {
        let bare = "iterations = 40\nseed = 3\n[model]\nhead_hidden = [64]\n";
        let section = "[train]\niterations = 40\nseed = 3\n[train.model]\nhead_hidden = [64]\n";
        let a = TrainConfig::from_toml_str(bare).unwrap();
        assert_eq!(a, TrainConfig::from_toml_str(section).unwrap());
        let mut expected = TrainConfig {
            iterations: 40,
            seed: 3,
            ..TrainConfig::default()
        };
        expected.model.head_hidden = vec![64];
        assert_eq!(a, expected);
        a.validate().unwrap();
        let pipeline = "work = \"w\"\n[synth]\ntiny = true\n[train]\niterations = 4\n";
        let e = TrainConfig::from_toml_str(pipeline).unwrap_err();
        assert!(e.contains("pl2map run") && e.contains("`synth`"), "{e}");
        let e = TrainConfig::from_toml_str("[model]\nheadz = 3\n").unwrap_err();
        assert!(e.contains("headz"), "{e}");
        // The file's own name and what is wrong.
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.toml");
        std::fs::write(&path, "iterations = \"many\"\n").unwrap();
        let e = TrainConfig::from_toml_file(&path).unwrap_err().to_string();
        assert!(e.contains("t.toml") && e.contains("iterations"), "{e}");
    }

    #[test]
    fn tiny_config_is_valid() {
        TrainConfig::tiny().validate().unwrap();
    }

    #[test]
    fn mismatched_front_end_is_refused() {
        let mut c = TrainConfig::default();
        c.front_end.samples_per_line = 8;
        assert!(
            c.validate()
                .unwrap_err()
                .to_string()
                .contains("line_tokens")
        );
        let c = TrainConfig {
            model: ModelConfig::superpoint(),
            ..Default::default()
        };
        assert!(c.validate().is_err());
    }
}
