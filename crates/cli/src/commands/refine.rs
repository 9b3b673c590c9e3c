//! `pl2map refine`: moves the label tables of an import onto the depth maps of the
//! frames table (`OUT/{points,lines,poses}.parquet`, `OUT/refine_report.json`,
//! `OUT/stage.json`).

use anyhow::Context;
use labels::LabelTables;
use labels::ablation::{self, ExactLabels};
use labels::refine::{self, PointSampling, RefineConfig};
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
pub struct Args {
    /// The frames table (with depth maps).
    #[arg(long)]
    pub frames: PathBuf,
    /// Label folder of the import stage.
    #[arg(long)]
    pub labels: PathBuf,
    /// Stage folder to write.
    #[arg(long)]
    pub out: PathBuf,
    /// Where point depth is read: keypoint (default) or projection (upstream).
    #[arg(long, default_value = "keypoint")]
    pub point_sampling: PointSampling,
    /// Point observations farther than this from their median are dropped (cm).
    #[arg(long, default_value_t = 5.0)]
    pub point_threshold_cm: f64,
    /// RANSAC inlier distance of line samples (cm).
    #[arg(long, default_value_t = 2.0)]
    pub line_threshold_cm: f64,
    /// Fraction of a segment's samples that must be on its 3D line.
    #[arg(long, default_value_t = 0.9)]
    pub line_min_inlier_ratio: f64,
    /// Distance between depth samples along a segment (pixels).
    #[arg(long, default_value_t = 2.0)]
    pub line_sample_spacing_px: f64,
    /// Depth beyond this is invalid (metres).
    #[arg(long, default_value_t = 1000.0)]
    pub max_depth_m: f64,
    /// Seed of the RANSAC draws.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Print the report as JSON instead of a table.
    #[arg(long)]
    pub json: bool,
    /// Exact labels (the synthetic scene's `sfm_gt/exact.json`): also print the
    /// ablation, the 3D label error before and after refinement.
    #[arg(long)]
    pub exact: Option<PathBuf>,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let config = RefineConfig {
        point_sampling: args.point_sampling,
        point_inlier_threshold_m: args.point_threshold_cm / 100.0,
        line_inlier_threshold_m: args.line_threshold_cm / 100.0,
        line_min_inlier_ratio: args.line_min_inlier_ratio,
        line_sample_spacing_px: args.line_sample_spacing_px,
        max_depth_m: args.max_depth_m,
        seed: args.seed,
        ..RefineConfig::default()
    };
    let output =
        refine::run(&config, &args.frames, &args.labels, &args.out).with_context(|| {
            format!(
                "refining {} with the depth of {}",
                args.labels.display(),
                args.frames.display()
            )
        })?;
    if args.json {
        println!("{}", serde_json::to_string_pretty(&output.report)?);
    } else {
        let state = if output.skipped {
            "up to date, skipped"
        } else {
            "written"
        };
        println!("{} ({state})", args.out.display());
        print!("{}", output.report.table());
    }
    if let Some(exact) = &args.exact {
        let exact = ExactLabels::read(exact)?;
        let before = LabelTables::read(&args.labels)?;
        let after = LabelTables::read(&args.out)?;
        print!(
            "{}",
            ablation::table(&ablation::compare(&exact, &before, &after)?)
        );
    }
    Ok(())
}
