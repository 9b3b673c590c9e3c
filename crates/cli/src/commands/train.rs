//! `pl2map train`: trains a PL2Map network on the training shards of a shard folder
//! (`DIR/manifest.json`, the `train-*.mcap` shards) into OUT (`model.ckpt`,
//! `checkpoint.ckpt`, `metrics.csv`, `losses.png`, `config.toml`).

use anyhow::Context;
use datasets::frames::Split;
use std::path::PathBuf;
use train::{RunOptions, TrainConfig};

#[derive(clap::Args, Debug)]
pub struct Args {
    /// Shard folder (holds manifest.json).
    #[arg(long)]
    pub shards: PathBuf,
    /// Output folder.
    #[arg(long)]
    pub out: PathBuf,
    /// Training configuration (TOML; missing fields take their defaults).
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Iterations (one image each); overrides the configuration, also with --resume.
    #[arg(long)]
    pub iterations: Option<u64>,
    /// Continue the run in OUT from its checkpoint, with the checkpoint's configuration.
    #[arg(long)]
    pub resume: bool,
    /// Start from the weights of this checkpoint (same network); fresh optimiser.
    #[arg(long, conflicts_with = "resume")]
    pub init: Option<PathBuf>,
    /// Seed of the run (initial weights, order, augmentation, dropout).
    #[arg(long)]
    pub seed: Option<u64>,
}

pub fn run(args: Args, quiet: bool) -> anyhow::Result<()> {
    let manifest_path = args.shards.join(labels::shard::MANIFEST_FILE);
    let manifest = shards::Manifest::load(&manifest_path)
        .with_context(|| format!("reading {}", manifest_path.display()))?;
    let paths: Vec<PathBuf> = labels::shard::shards_of_split(&manifest, Split::Train)
        .into_iter()
        .map(|s| args.shards.join(&s.file))
        .collect();
    if paths.is_empty() {
        anyhow::bail!("{} lists no training shards", manifest_path.display());
    }
    let mut config = match &args.config {
        Some(p) => TrainConfig::from_toml_file(p)?,
        None => TrainConfig::default(),
    };
    if let Some(s) = args.seed {
        if args.resume {
            anyhow::bail!("--seed cannot change a resumed run (its seed is in the checkpoint)");
        }
        config.seed = s;
    }
    let options = RunOptions {
        out_dir: args.out.clone(),
        resume: args.resume,
        init: args.init.clone(),
        iterations: args.iterations,
        progress: !quiet,
        stop_after: None,
    };
    let s = train::train(config, &paths, &options)
        .with_context(|| format!("training into {}", args.out.display()))?;
    let c = &s.config;
    println!(
        "trained {} iteration(s){} on {} training frame(s) from {} shard(s) in {:.1} s \
         ({:.3} s/iteration), seed {}",
        s.iterations_done,
        s.resumed_from
            .map(|i| format!(" (resumed at {i})"))
            .unwrap_or_default(),
        s.frames_per_epoch,
        paths.len(),
        s.seconds,
        s.seconds / (s.iterations_done - s.resumed_from.unwrap_or(0)).max(1) as f64,
        c.seed
    );
    println!(
        "network: D = {}, {} layers, head widths {:?}; lr {:.1e} to 1/2^{} ({:?}); limits {} keypoints, {} lines",
        c.model.descriptor_dim,
        c.model.layers.len(),
        c.model.head_hidden,
        c.learning_rate,
        c.lr_halvings,
        c.lr_schedule,
        c.limits.max_keypoints,
        c.limits.max_lines
    );
    let m = &s.last;
    println!(
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
    println!("metrics: {}", s.metrics.display());
    if let Some(p) = &s.plot {
        println!("loss plot: {} ({})", p.display(), train::plot::LEGEND);
    }
    if let Some(p) = &s.model {
        println!("model: {}", p.display());
    }
    println!("checkpoint: {}", s.checkpoint.display());
    Ok(())
}
