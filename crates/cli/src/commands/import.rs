//! `pl2map import`: joins a COLMAP model and a LIMAP folder to the frames table and
//! writes the label tables (`OUT/{points,lines,poses}.parquet`, `OUT/import_report.json`,
//! `OUT/stage.json`).

use anyhow::Context;
use labels::import::{self, ImportConfig};
use labels::{NameMapping, PoseSource};
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
pub struct Args {
    /// The frames table (frames.parquet of the ingest stage).
    #[arg(long)]
    pub frames: PathBuf,
    /// COLMAP model folder (cameras/images/points3D, .bin or .txt).
    #[arg(long)]
    pub model: PathBuf,
    /// LIMAP output folder (image_list.txt, finaltracks/, line_detections/*/segments/).
    #[arg(long)]
    pub limap: PathBuf,
    /// Stage folder to write.
    #[arg(long)]
    pub out: PathBuf,
    /// Strip this prefix from model image names to get frames table names.
    #[arg(long)]
    pub name_strip_prefix: Option<String>,
    /// Then prepend this prefix to model image names (e.g. "seq-01/").
    #[arg(long)]
    pub name_prefix: Option<String>,
    /// Then replace this extension of model image names: FROM:TO (e.g. ".jpg:.png").
    #[arg(long, value_parser = parse_ext)]
    pub name_ext: Option<(String, String)>,
    /// Same three rules for LIMAP's image_list.txt names.
    #[arg(long)]
    pub limap_strip_prefix: Option<String>,
    #[arg(long)]
    pub limap_prefix: Option<String>,
    #[arg(long, value_parser = parse_ext)]
    pub limap_ext: Option<(String, String)>,
    /// Camera and pose of the labels: sfm (the model's, default) or dataset.
    #[arg(long, default_value = "sfm")]
    pub pose_source: PoseSource,
    /// Skip test frames found in the model or in LIMAP instead of refusing them.
    #[arg(long)]
    pub allow_test_images: bool,
    /// LIMAP segment coordinates times this are image pixels (LIMAP's max_image_dim).
    #[arg(long, default_value_t = 1.0)]
    pub segment_scale: f64,
    /// LIMAP segments folder relative to --limap (default: the only one found).
    #[arg(long)]
    pub limap_segments: Option<PathBuf>,
    /// LIMAP track folder relative to --limap (default: finaltracks).
    #[arg(long)]
    pub limap_tracks: Option<PathBuf>,
    /// Print the report as JSON instead of a table.
    #[arg(long)]
    pub json: bool,
}

fn parse_ext(s: &str) -> Result<(String, String), String> {
    let (a, b) = s
        .split_once(':')
        .ok_or_else(|| format!("expected FROM:TO (e.g. .jpg:.png), got {s:?}"))?;
    if a.is_empty() {
        return Err("the extension to replace is empty".into());
    }
    Ok((a.to_string(), b.to_string()))
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let config = ImportConfig {
        model_names: NameMapping {
            strip_prefix: args.name_strip_prefix,
            add_prefix: args.name_prefix,
            replace_extension: args.name_ext,
        },
        limap_names: NameMapping {
            strip_prefix: args.limap_strip_prefix,
            add_prefix: args.limap_prefix,
            replace_extension: args.limap_ext,
        },
        pose_source: args.pose_source,
        allow_test_images: args.allow_test_images,
        segment_scale: args.segment_scale,
        limap_segments: args.limap_segments,
        limap_tracks: args.limap_tracks,
        ..ImportConfig::default()
    };
    let output = import::run(&config, &args.frames, &args.model, &args.limap, &args.out)
        .with_context(|| {
            format!(
                "importing {} and {} for {}",
                args.model.display(),
                args.limap.display(),
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
    Ok(())
}
