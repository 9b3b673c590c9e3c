//! `pl2map bench stages`: frames/s of ingest + import + shard on the synthetic scene (or
//! a given scene with its ground truth), against the floor of decoding the colour images
//! alone, measured in the same run on the same files.
//!
//! The floor decodes every colour image once (rayon, all threads) and does nothing else;
//! the stages hash every image (ingest), join the labels (import) and copy the original
//! image bytes into zstd-compressed MCAP (shard; images are never re-encoded). A ratio
//! below 1 means the stages together cost less than decoding the images would.

use anyhow::{Context, bail};
use datasets::ingest::{DatasetKind, IngestConfig};
use datasets::ingest_stage;
use labels::import::{self, ImportConfig};
use labels::import_stage;
use rayon::prelude::*;
use shards::shard_stage::{self, ShardStageConfig};
use std::path::{Path, PathBuf};
use std::time::Instant;
use synth::{SynthConfig, WriteOptions, generate};

#[derive(clap::Args)]
pub struct Args {
    /// A 7-Scenes-layout scene with `sfm_gt/colmap` and `sfm_gt/limap` inside (default:
    /// render the synthetic room into a temporary folder first).
    #[arg(long)]
    scene: Option<PathBuf>,
    /// Frames of the synthetic scene.
    #[arg(long, default_value_t = synth::trajectory::DEFAULT_FRAMES)]
    frames: usize,
    /// Repetitions; the table shows the fastest.
    #[arg(long, default_value_t = 3)]
    repeat: usize,
}

struct Row {
    name: &'static str,
    seconds: f64,
}

fn best_of<F: FnMut() -> anyhow::Result<()>>(repeat: usize, mut f: F) -> anyhow::Result<f64> {
    let mut best = f64::INFINITY;
    for _ in 0..repeat.max(1) {
        let t = Instant::now();
        f()?;
        best = best.min(t.elapsed().as_secs_f64());
    }
    Ok(best)
}

fn decode_all(paths: &[PathBuf]) -> anyhow::Result<()> {
    paths.par_iter().try_for_each(|p| {
        let bytes = std::fs::read(p).with_context(|| format!("reading {}", p.display()))?;
        let img =
            image::load_from_memory(&bytes).with_context(|| format!("decoding {}", p.display()))?;
        std::hint::black_box(img);
        Ok(())
    })
}

fn fresh(dir: &Path) -> anyhow::Result<()> {
    if dir.exists() {
        std::fs::remove_dir_all(dir).with_context(|| format!("removing {}", dir.display()))?;
    }
    Ok(())
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let tmp = tempfile::tempdir().context("creating a temporary folder")?;
    let scene = match args.scene {
        Some(s) => s,
        None => {
            let cfg = SynthConfig {
                frames: args.frames,
                ..SynthConfig::default()
            };
            generate(&cfg, &WriteOptions::new(tmp.path().join("dataset")))
                .context("rendering the synthetic scene")?
                .root
        }
    };
    let (model, limap) = (
        scene.join(synth::gt::GT_DIR).join("colmap"),
        scene.join(synth::gt::GT_DIR).join("limap"),
    );
    if !model.is_dir() || !limap.is_dir() {
        bail!(
            "{} has no sfm_gt/colmap and sfm_gt/limap folders (write them with `pl2map synth`)",
            scene.display()
        );
    }
    let ingest_cfg = IngestConfig::new(DatasetKind::SevenScenes, &scene);
    let work = tmp.path().join("work");
    let (frames_dir, labels_dir, shards_dir) = (
        work.join("frames"),
        work.join("labels"),
        work.join("shards"),
    );

    // One untimed pass warms the page cache and yields the inputs of the later stages.
    let frames = ingest_stage::run(&ingest_cfg, &frames_dir)?.output;
    let import_cfg = ImportConfig {
        model: Some(model),
        limap: Some(limap),
        ..ImportConfig::default()
    };
    let run_import = || {
        import_stage::run(
            &import_cfg,
            &frames.frames_path,
            &labels_dir,
            &import::sift_only,
        )
    };
    run_import()?;
    let paths: Vec<PathBuf> = frames.table.frames.iter().map(|f| f.path.clone()).collect();
    let n = paths.len();
    decode_all(&paths)?;

    let rows = vec![
        Row {
            name: "decode images (floor)",
            seconds: best_of(args.repeat, || decode_all(&paths))?,
        },
        Row {
            name: "ingest",
            seconds: best_of(args.repeat, || {
                fresh(&frames_dir)?;
                ingest_stage::run(&ingest_cfg, &frames_dir)?;
                Ok(())
            })?,
        },
        Row {
            name: "import",
            seconds: best_of(args.repeat, || {
                fresh(&labels_dir)?;
                run_import()?;
                Ok(())
            })?,
        },
        Row {
            name: "shard",
            seconds: best_of(args.repeat, || {
                fresh(&shards_dir)?;
                shard_stage::run(
                    &ShardStageConfig::default(),
                    &frames.frames_path,
                    &labels_dir,
                    &shards_dir,
                    None,
                )?;
                Ok(())
            })?,
        },
    ];
    let floor = rows[0].seconds;
    let stages: f64 = rows[1..].iter().map(|r| r.seconds).sum();
    stage::outln!(
        "{n} frames, {} rayon threads, best of {}",
        rayon::current_num_threads(),
        args.repeat
    );
    stage::outln!(
        "{:<28} {:>10} {:>10} {:>10}",
        "step",
        "seconds",
        "frames/s",
        "x floor"
    );
    for r in &rows {
        stage::outln!(
            "{:<28} {:>10.3} {:>10.1} {:>10.2}",
            r.name,
            r.seconds,
            n as f64 / r.seconds,
            r.seconds / floor
        );
    }
    stage::outln!(
        "{:<28} {:>10.3} {:>10.1} {:>10.2}",
        "ingest + import + shard",
        stages,
        n as f64 / stages,
        stages / floor
    );
    Ok(())
}
