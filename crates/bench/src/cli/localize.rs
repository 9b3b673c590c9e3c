//! `pl2map bench localize`: each phase of a query (decode, detect, describe points,
//! detect lines, describe lines, the one-pass descriptors of the query path, network,
//! RANSAC points, RANSAC points + lines), the latency of one query and queries/s on 1
//! and 2 threads, and a check that the query path's poses equal the per-call path's
//! (`score::localize::bench`).

use anyhow::{Context, bail};
use score::localize;
use score::{NetworkLocaliser, ScoreStageConfig};
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
pub struct Args {
    /// Trained network checkpoint.
    #[arg(long)]
    checkpoint: PathBuf,
    /// hloc query list with intrinsics (names relative to --images or its folder).
    #[arg(long)]
    queries: Option<PathBuf>,
    /// One camera `MODEL W H PARAMS...` for every image under --images.
    #[arg(long, requires = "images")]
    camera: Option<String>,
    #[arg(long)]
    images: Option<PathBuf>,
    /// Use at most this many queries.
    #[arg(long, default_value_t = 24)]
    limit: usize,
    #[command(flatten)]
    config: ScoreStageConfig,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let (mut queries, images) = match (&args.queries, &args.camera, &args.images) {
        (Some(list), _, images) => (
            localize::read_query_list(list)?,
            images.clone().unwrap_or_else(|| {
                list.parent()
                    .map(|p| p.to_path_buf())
                    .unwrap_or_else(|| PathBuf::from("."))
            }),
        ),
        (None, Some(spec), Some(images)) => (
            localize::folder_queries(images, &pose::io::parse_camera(spec)?)?.0,
            images.clone(),
        ),
        _ => bail!("give --queries LIST or --camera SPEC with --images DIR"),
    };
    queries.truncate(args.limit);
    if queries.is_empty() {
        bail!("no queries");
    }
    let mut localiser = NetworkLocaliser::load_on(&args.checkpoint, args.config.device)?;
    let b = crate::localize::run(
        &mut localiser,
        &queries,
        &images,
        &args.config.resolve(),
        &[1, 2],
    )
    .context("localisation benchmark")?;
    stage::outln!(
        "localisation benchmark: {} queries from {}, mean {:.0} keypoints and {:.0} segments per image",
        b.images,
        images.display(),
        b.mean_keypoints,
        b.mean_segments
    );
    stage::outln!(
        "poses identical between the query path and the per-call path: {} of {}; localised (points + lines): {}",
        b.identical_poses,
        b.images,
        b.localised
    );
    stage::outln!();
    stage::out!("{}", b.table());
    if let Some(line) = b.median_line() {
        stage::outln!();
        stage::outln!("{line}");
    }
    if b.identical_poses != b.images {
        bail!("the query path's poses differ from the per-call path's");
    }
    Ok(())
}
