//! `pl2map run PIPELINE.toml`: the stages of a pipeline file in order into
//! `<work>/<stage>/`; a stage whose record matches is skipped.

use anyhow::Context;
use std::ops::Range;
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
pub struct Args {
    /// Pipeline file (pipeline/*.toml).
    pub pipeline: PathBuf,
    /// Work folder instead of the file's `work`.
    #[arg(long)]
    pub work: Option<PathBuf>,
    /// Last stage to run.
    #[arg(long, value_enum)]
    pub until: Option<pipeline::StageName>,
    /// One scene of a multi-scene dataset (a work unit): replaces `ingest.scene` and
    /// `${SCENE}` in the file's paths.
    #[arg(long)]
    pub scene: Option<String>,
    /// A work unit of the shard stage: shards a..b of its plan (end exclusive); the
    /// stages after it run once every unit is done.
    #[arg(long, value_parser = super::shard::parse_range)]
    pub shards: Option<Range<usize>>,
    /// Nightly retraining: continue from this model ([warm_start] says how many
    /// iterations) when the training shards changed since the last model.
    #[arg(long)]
    pub warm_start: Option<PathBuf>,
    /// Label ablation: also run the pipeline without [refine] (shards, model and score
    /// in <work>/without-refine/) and print both scores in one table.
    #[arg(long)]
    pub compare_refine: bool,
    /// Where the network trains and scores (`cpu`, `cuda`, `cuda:N`), instead of the
    /// file's `[train] device` / `[score] device`.
    #[arg(long)]
    pub device: Option<train::Device>,
}

pub fn run(args: Args, quiet: bool) -> anyhow::Result<()> {
    if args.shards.is_some() {
        // Work units run side by side: the stages they share (the data stages before
        // the shards, and the shard folder's merge) take turns instead of refusing.
        stage::set_wait(true);
    }
    let mut p = pipeline::Pipeline::load_unit(&args.pipeline, args.work, args.scene.as_deref())?;
    if let Some(device) = args.device {
        p.set_device(device)?;
    }
    let options = pipeline::RunOptions {
        until: args.until,
        progress: !quiet,
        warm_start: args.warm_start,
        shards: args.shards,
    };
    let context = || format!("running {}", args.pipeline.display());
    crate::outln!(
        "{} (work folder {})",
        args.pipeline.display(),
        p.work.display()
    );
    if args.compare_refine {
        let a = pipeline::run_compare_refine(&p, &options).with_context(context)?;
        crate::outln!("with [refine]:");
        crate::out!("{}", a.refined.table());
        crate::outln!(
            "\nwithout [refine] ({}):",
            p.without_refine()
                .work
                .join(pipeline::WITHOUT_REFINE)
                .display()
        );
        crate::out!("{}", a.imported.table());
        crate::outln!("\nscore on the test frames, labels refined on depth vs as imported:\n");
        crate::out!("{}", a.table());
        return Ok(());
    }
    let report = pipeline::run(&p, &options).with_context(context)?;
    crate::out!("{}", report.table());
    if let Some(summary) = &report.score {
        crate::outln!(
            "\nscore on the {} frames ({}):\n",
            summary.split,
            p.stage_dir(pipeline::StageName::Score)
                .join(score::scoring::SUMMARY_MD_FILE)
                .display()
        );
        crate::out!("{}", summary.table());
    }
    // The gate's decision is the run's last line (docs/operations.md, "Nightly retraining").
    if let Some(promotion) = &report.promotion {
        crate::outln!(
            "\npromotion gate: the new and the previous model on the same test frames:\n"
        );
        crate::out!("{}", promotion.table());
        crate::outln!("\n{}", promotion.verdict());
    }
    Ok(())
}
