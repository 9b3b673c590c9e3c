//! `pl2map score`: localises the frames of a shard folder with the network
//! (`--checkpoint`, test shards) or the shard labels (`--oracle`, training shards: test
//! shards carry no labels), from points only and from points + lines, and writes
//! `OUT/per_frame.parquet`, `OUT/results_points.txt`, `OUT/results_points_lines.txt`
//! (hloc format), `OUT/summary.md`, `OUT/summary.json` and `OUT/cdf.png`.

use anyhow::Context;
use score::{Localiser, OracleLocaliser, ScoreConfig};
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
#[command(group(clap::ArgGroup::new("source").required(true).args(["checkpoint", "oracle"])))]
pub struct Args {
    /// Shard folder (with its complete manifest.json) of the shard stage.
    #[arg(long)]
    pub shards: PathBuf,
    /// Output folder.
    #[arg(long)]
    pub out: PathBuf,
    /// Trained network checkpoint (`pl2map train`): scores the test frames.
    #[arg(long)]
    pub checkpoint: Option<PathBuf>,
    /// Use the label correspondences of the shards instead of the network: an upper
    /// bound and a check of the solvers. Scores the training frames (the only labelled
    /// ones).
    #[arg(long)]
    pub oracle: bool,
    /// RANSAC inlier threshold on point reprojection errors, pixels.
    #[arg(long, default_value_t = 12.0)]
    pub point_threshold: f64,
    /// RANSAC inlier threshold on line errors (sum of both endpoint distances), pixels.
    #[arg(long, default_value_t = 10.0)]
    pub line_threshold: f64,
    /// Keep points predicted with at least this reliability.
    #[arg(long, default_value_t = 0.5)]
    pub min_point_reliability: f64,
    /// Keep lines predicted with at least this reliability.
    #[arg(long, default_value_t = 0.02)]
    pub min_line_reliability: f64,
    /// RANSAC seed (mixed with each frame id; same inputs and seed, same poses).
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// RANSAC iterations at most (PoseLib's default). A weak model leaves few inliers
    /// and RANSAC runs to this cap (seconds per frame): lower it for quick looks.
    #[arg(long, default_value_t = 100_000)]
    pub max_iterations: usize,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let config = ScoreConfig::with_ransac(
        args.min_point_reliability,
        args.min_line_reliability,
        args.point_threshold,
        args.line_threshold,
        args.seed,
        Some(args.max_iterations),
    );
    let mut localiser: Box<dyn Localiser> = match &args.checkpoint {
        Some(ckpt) => Box::new(score::NetworkLocaliser::load(ckpt)?),
        None => Box::new(OracleLocaliser),
    };
    let output = score::run(&args.shards, &args.out, localiser.as_mut(), &config)
        .with_context(|| format!("scoring the shards in {}", args.shards.display()))?;
    print!("{}", output.summary.markdown());
    println!("\nMedian time per frame and step (not written: it differs between runs):\n");
    print!("{}", score::summary::timing_table(&output.results));
    println!();
    for f in &output.files {
        println!("wrote {}", f.display());
    }
    Ok(())
}
