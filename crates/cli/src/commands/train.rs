//! `pl2map train`: the train stage alone. Trains a PL2Map network on the training shards
//! of a shard folder (`DIR/manifest.json`) into OUT (`model.ckpt`, `checkpoint.ckpt`,
//! `metrics.csv`, `losses.png`, `config.toml`, `stage.json`); a second run with the same
//! configuration and shards says so and does nothing. The settings are those of
//! `train::TrainConfig`: from `--config FILE.toml` (the `[train]` section of a pipeline,
//! as its own file), then the flags given on the command line.

use super::flags::override_given;
use anyhow::Context;
use std::path::PathBuf;
use train::{TrainConfig, TrainStageOptions};

#[derive(clap::Args, Debug)]
pub struct Args {
    /// Shard folder (holds manifest.json), or the URL of one: `s3://bucket/prefix`,
    /// `https://host/path` (fetched into a local cache; docs/operations.md, "Shards from
    /// object storage").
    #[arg(long)]
    pub shards: PathBuf,
    /// Output folder.
    #[arg(long)]
    pub out: PathBuf,
    /// Training configuration (TOML; missing keys take their defaults); flags given on
    /// the command line override it.
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Continue the checkpoint in OUT (the folder's own interrupted run is resumed
    /// without this flag) with its configuration; `--iterations N` continues it to N.
    /// Other settings that differ from the checkpoint's are refused, naming them.
    #[arg(long)]
    pub resume: bool,
    /// Start from the weights of this checkpoint (same network); fresh optimiser.
    #[arg(long, conflicts_with = "resume")]
    pub init: Option<PathBuf>,
    #[command(flatten)]
    pub settings: TrainConfig,
}

pub fn run(args: Args, matches: &clap::ArgMatches, quiet: bool) -> anyhow::Result<()> {
    let base = match (&args.config, args.resume) {
        (Some(p), _) => TrainConfig::from_toml_file(p)?,
        // `--resume` alone continues the checkpoint's own run: its configuration is the
        // base, and a flag (`--iterations 150`) changes only its key. The trainer refuses
        // a resume whose configuration differs in anything but the iteration count and
        // speed settings (crates/train/src/trainer.rs, `resumed_config`).
        (None, true) => {
            let ckpt = args.out.join(train::checkpoint::CHECKPOINT_FILE);
            train::checkpoint::CheckpointFile::read(&ckpt)
                .with_context(|| "--resume needs the folder's checkpoint".to_string())?
                .header
                .config
        }
        (None, false) => TrainConfig::default(),
    };
    let config = override_given(&base, &args.settings, matches)?;
    let options = TrainStageOptions {
        init: args.init.clone(),
        resume: args.resume,
        progress: !quiet,
        ..TrainStageOptions::default()
    };
    // A URL becomes the cache folder it was fetched into, each shard checked.
    let (shards, fetched) = remote::resolve(&args.shards)?;
    if let Some(report) = &fetched {
        crate::outln!("{}", report.line());
    }
    let done = train::train_stage::run(&config, &shards, &args.out, &options)
        .with_context(|| format!("training into {}", args.out.display()))?;
    crate::outln!("{}", done.line("train"));
    let c = &done.output.config;
    crate::outln!(
        "network: D = {}, {} layers, head widths {:?}; lr {:.1e} to 1/2^{} ({}); limits {} keypoints, {} lines",
        c.model.descriptor_dim,
        c.model.layers.len(),
        c.model.head_hidden,
        c.learning_rate,
        c.lr_halvings,
        c.lr_schedule,
        c.limits.max_keypoints,
        c.limits.max_lines
    );
    if let Some(s) = &done.output.summary {
        crate::outln!(
            "trained {} iteration(s){} on {} training frame(s) in {:.1} s ({:.3} s/iteration)",
            s.iterations_done,
            s.resumed_from
                .map(|i| format!(" (resumed at {i})"))
                .unwrap_or_default(),
            s.frames_per_epoch,
            s.seconds,
            s.seconds / (s.iterations_done - s.resumed_from.unwrap_or(0)).max(1) as f64,
        );
        let m = &s.last;
        crate::outln!(
            "last {} iterations: loss {:.4} = L_m {:.4} (points) + {:.4} (lines), L_r {:.4}, L_pi {:.4}; \
             {} step(s) skipped (nothing to learn)",
            m.iterations,
            m.total,
            m.map_points,
            m.map_lines,
            m.reliability,
            m.reprojection,
            s.skipped_steps
        );
        crate::outln!("metrics: {}", s.metrics.display());
        if let Some(p) = &s.plot {
            crate::outln!("loss plot: {} ({})", p.display(), train::plot::LEGEND);
        }
    }
    crate::outln!("model: {}", done.output.model.display());
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::{CommandFactory, FromArgMatches, Parser};

    #[derive(Parser)]
    struct Cli {
        #[command(flatten)]
        args: Args,
    }

    fn config(argv: &[&str], file: &str) -> TrainConfig {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("train.toml");
        std::fs::write(&path, file).unwrap();
        let mut full = vec!["x", "--shards", "s", "--out", "o", "--config"];
        let p = path.to_str().unwrap().to_string();
        full.push(&p);
        full.extend_from_slice(argv);
        let matches = Cli::command().get_matches_from(full);
        let cli = Cli::from_arg_matches(&matches).unwrap();
        let base = TrainConfig::from_toml_file(&path).unwrap();
        override_given(&base, &cli.args.settings, &matches).unwrap()
    }

    /// `pl2map train --config` gives the trainer exactly the `[train]` section a
    /// pipeline would (so it finds the pipeline's train stage up to date), and a flag
    /// given on the command line replaces only its own key.
    #[test]
    fn a_config_file_and_flags() {
        let text =
            "iterations = 100\ncheckpoint_every = 50\nseed = 0\n[augment]\nprobability = 0.0\n";
        let from_pipeline: TrainConfig = toml::from_str(text).unwrap();
        assert_eq!(config(&[], text), from_pipeline);
        assert_eq!(
            stage::hash_config(&config(&[], text)).unwrap(),
            stage::hash_config(&from_pipeline).unwrap()
        );
        let c = config(&["--seed", "3"], text);
        assert_eq!((c.seed, c.iterations), (3, 100));
    }
}
