//! `pl2map localize`: new images through a trained map. Reads hloc's query list with
//! intrinsics (`--queries`) or a folder of images with one camera (`--camera`), and
//! writes `OUT/results.txt` (hloc format), `OUT/per_image.csv` and, with `--visual`,
//! `OUT/visual.mcap`, through `score::localize::run` (the score stage's localisation
//! path). Exits non-zero when any query could not be read; the others are localised.

use anyhow::{Context, bail};
use score::localize::{self, LocalizeOptions};
use score::{NetworkLocaliser, ScoreStageConfig};
use std::path::PathBuf;

#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum OnOff {
    On,
    Off,
}

#[derive(clap::Args, Debug)]
#[command(group(clap::ArgGroup::new("list").required(true).args(["queries", "camera"])))]
pub struct Args {
    /// Trained network checkpoint (`model.ckpt` of `pl2map train`).
    #[arg(long)]
    pub checkpoint: PathBuf,
    /// hloc's query list with intrinsics: `name MODEL W H PARAMS...` per line.
    #[arg(long)]
    pub queries: Option<PathBuf>,
    /// One camera `MODEL W H PARAMS...` for every image under --images (instead of
    /// --queries).
    #[arg(long, requires = "images")]
    pub camera: Option<String>,
    /// Folder the image names are relative to (default: the query list's folder).
    #[arg(long)]
    pub images: Option<PathBuf>,
    /// Output folder.
    #[arg(long)]
    pub out: PathBuf,
    /// The pose written to results.txt: from points + lines (on) or from points only
    /// (off). The network sees the image's lines either way (they are part of its input,
    /// as in training); `off` only leaves them out of RANSAC, as the score stage's
    /// points variant does. per_image.csv has both poses' inliers.
    #[arg(long, value_enum, default_value_t = OnOff::On)]
    pub lines: OnOff,
    #[command(flatten)]
    pub config: ScoreStageConfig,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let (queries, images) = match (&args.queries, &args.camera) {
        (Some(list), _) => {
            let q = localize::read_query_list(list)?;
            let images = match &args.images {
                Some(d) => d.clone(),
                None => list
                    .parent()
                    .map(|p| p.to_path_buf())
                    .unwrap_or_else(|| PathBuf::from(".")),
            };
            (q, images)
        }
        (None, Some(spec)) => {
            let camera =
                pose::io::parse_camera(spec).with_context(|| format!("--camera {spec:?}"))?;
            let images = args.images.clone().expect("clap requires --images");
            let (queries, skipped) = localize::folder_queries(&images, &camera)?;
            for line in &skipped {
                tracing::warn!("{line}");
            }
            (queries, images)
        }
        (None, None) => bail!("give --queries LIST or --camera SPEC with --images DIR"),
    };
    if queries.is_empty() {
        bail!("no queries to localise");
    }
    let mut localiser = NetworkLocaliser::load_on(&args.checkpoint, args.config.device)?;
    // The query lines from LIMAP-format segment files, as the score stage takes them:
    // read (and refused) before any image, so a wrong folder never falls back to LSD.
    if let Some(dir) = &args.config.query_segments {
        let segments =
            score::query_lines::QuerySegments::load(dir, args.config.query_segment_scale)
                .with_context(|| format!("--query-segments {}", dir.display()))?;
        localiser = localiser.with_query_segments(segments);
    }
    let opts = LocalizeOptions {
        config: args.config.resolve(),
        lines: args.lines == OnOff::On,
        visual: args
            .config
            .visual
            .then(|| args.out.join(score::visual::VISUAL_FILE)),
    };
    let out = localize::run(&mut localiser, &queries, &images, &args.out, &opts)
        .with_context(|| format!("localising into {}", args.out.display()))?;
    crate::out!("{}", out.summary());
    for f in &out.files {
        crate::outln!("wrote {}", f.display());
    }
    let bad = out.failed_inputs().count();
    if bad > 0 {
        bail!(
            "{bad} of {} queries could not be read (reasons in {})",
            out.results.len(),
            args.out.join(localize::TABLE_FILE).display()
        );
    }
    Ok(())
}
