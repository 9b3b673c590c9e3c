//! `pl2map refine`: moves the label tables of an import onto the depth maps of the
//! frames table (`OUT/{points,lines,poses}.parquet`, `OUT/refine_report.json`,
//! `OUT/stage.json`). The flags are those of `labels::refine::RefineConfig` (metres).

use anyhow::Context;
use labels::LabelTables;
use labels::label_error::{self, ExactLabels};
use labels::refine::RefineConfig;
use labels::refine_stage;
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
pub struct Args {
    /// The frames table (with depth maps), with the ingest stage's stage.json beside it.
    #[arg(long)]
    pub frames: PathBuf,
    /// Label folder of the import stage (its tables are read only as its stage.json
    /// records them).
    #[arg(long)]
    pub labels: PathBuf,
    /// Stage folder to write.
    #[arg(long)]
    pub out: PathBuf,
    /// Print the report as JSON instead of a table.
    #[arg(long)]
    pub json: bool,
    /// Exact labels (the synthetic scene's `sfm_gt/exact.json`): also print the
    /// ablation, the 3D label error before and after refinement.
    #[arg(long)]
    pub exact: Option<PathBuf>,
    #[command(flatten)]
    pub config: RefineConfig,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let done = refine_stage::run(&args.config, &args.frames, &args.labels, &args.out)
        .with_context(|| {
            format!(
                "refining {} with the depth of {}",
                args.labels.display(),
                args.frames.display()
            )
        })?;
    if args.json {
        crate::outln!("{}", serde_json::to_string_pretty(&done.output.report)?);
    } else {
        crate::outln!("{}", done.line("refine"));
        crate::out!("{}", done.output.report.table());
    }
    if let Some(exact) = &args.exact {
        let exact = ExactLabels::read(exact)?;
        let before = LabelTables::read(&args.labels)?;
        let after = LabelTables::read(&args.out)?;
        crate::out!(
            "{}",
            label_error::table(&label_error::compare(&exact, &before, &after)?)
        );
    }
    Ok(())
}
