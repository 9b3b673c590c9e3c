//! `pl2map score`: the score stage alone. Localises the frames of a shard folder with the
//! network (`--checkpoint`, test shards) or the shard labels (`--oracle`, training
//! shards: test shards carry no labels), from points only and from points + lines, and
//! writes `OUT/per_frame.parquet`, `OUT/results_points.txt`, `OUT/results_points_lines.txt`
//! (hloc format), `OUT/summary.md`, `OUT/summary.json`, `OUT/cdf.png` and
//! `OUT/stage.json`; a second run with the same inputs and settings says so and does
//! nothing. The settings are those of `score::ScoreStageConfig`.

use anyhow::Context;
use score::{ScoreStageConfig, Source};
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
#[command(group(clap::ArgGroup::new("source").required(true).args(["checkpoint", "oracle"])))]
pub struct Args {
    /// Shard folder (with its complete manifest.json) of the shard stage, or the URL of
    /// one: `s3://bucket/prefix`, `https://host/path` (fetched into a local cache;
    /// docs/operations.md, "Shards from object storage").
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
    #[command(flatten)]
    pub config: ScoreStageConfig,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let source = match &args.checkpoint {
        Some(ckpt) => Source::Network(ckpt.clone()),
        None => Source::Oracle,
    };
    // A URL becomes the cache folder it was fetched into, each shard checked.
    let (shards, fetched) = remote::resolve(&args.shards)?;
    if let Some(report) = &fetched {
        crate::outln!("{}", report.line());
    }
    let done = score::score_stage::run(&args.config, &shards, &source, &args.out)
        .with_context(|| format!("scoring the shards in {}", args.shards.display()))?;
    crate::outln!("{}", done.line("score"));
    crate::out!("{}", done.output.summary.markdown());
    if let Some(run) = &done.output.run {
        crate::outln!("\nMedian time per frame and step (not written: it differs between runs):\n");
        crate::out!("{}", score::summary::timing_table(&run.results));
        crate::outln!();
        for f in &run.files {
            crate::outln!("wrote {}", f.display());
        }
    }
    Ok(())
}
