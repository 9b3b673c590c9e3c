//! `pl2map import`: joins a COLMAP model and a LIMAP folder to the frames table and
//! writes the label tables (`OUT/{points,lines,poses}.parquet`, `OUT/import_report.json`,
//! `OUT/stage.json`). The flags are those of `labels::import::ImportConfig`.

use anyhow::Context;
use labels::import::ImportConfig;
use labels::import_stage;
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
pub struct Args {
    /// The frames table (frames.parquet of the ingest stage).
    #[arg(long)]
    pub frames: PathBuf,
    /// Stage folder to write.
    #[arg(long)]
    pub out: PathBuf,
    /// Print the report as JSON instead of a table.
    #[arg(long)]
    pub json: bool,
    /// The front-end the detector check compares the model's keypoints with: sift or
    /// superpoint (a pipeline's `[features] kind`).
    #[arg(long, default_value = "sift")]
    pub front_end: features::FrontEndKind,
    /// The SuperPoint weights file for `--front-end superpoint` (else
    /// PL2MAP_SUPERPOINT_WEIGHTS).
    #[arg(long)]
    pub superpoint_weights: Option<PathBuf>,
    #[command(flatten)]
    pub config: ImportConfig,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let mut config = args.config;
    config.front_end.kind = args.front_end;
    config.front_end.superpoint.weights = args.superpoint_weights;
    let make = |c: &features::FrontEndConfig| frontends::build(c).map_err(|e| e.to_string());
    let done = import_stage::run(&config, &args.frames, &args.out, &make).with_context(|| {
        format!(
            "importing {} and {} for {}",
            config.model.clone().unwrap_or_default().display(),
            config.limap.clone().unwrap_or_default().display(),
            args.frames.display()
        )
    })?;
    if args.json {
        crate::outln!("{}", serde_json::to_string_pretty(&done.output.report)?);
    } else {
        crate::outln!("{}", done.line("import"));
        crate::out!("{}", done.output.report.table());
    }
    Ok(())
}
