//! `pl2map run PIPELINE.toml`: the stages of a pipeline file in order into
//! `<work>/<stage>/`; a stage whose record matches is skipped.

use anyhow::Context;
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
pub struct Args {
    /// Pipeline file (pipeline/*.toml).
    pub pipeline: PathBuf,
    /// Work folder instead of the file's `work`.
    #[arg(long)]
    pub work: Option<PathBuf>,
    /// Last stage to run: synth, ingest, import, refine, shard, train or score.
    #[arg(long)]
    pub until: Option<String>,
}

pub fn run(args: Args, quiet: bool) -> anyhow::Result<()> {
    let p = pipeline::Pipeline::load_with_work(&args.pipeline, args.work)?;
    let options = pipeline::RunOptions {
        until: args.until,
        progress: !quiet,
    };
    let report = pipeline::run(&p, &options)
        .with_context(|| format!("running {}", args.pipeline.display()))?;
    println!(
        "{} (work folder {})",
        args.pipeline.display(),
        p.work.display()
    );
    print!("{}", report.table());
    Ok(())
}
