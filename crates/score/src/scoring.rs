//! Scoring a shard folder, the work of the score stage ([`crate::score_stage`], which
//! records it): read the frames of the localiser's split, correspond, estimate both
//! poses, measure them, and write every output atomically.

use crate::error::ScoreError;
use crate::evaluate::{FrameResult, ScoreConfig, Variant, measure};
use crate::localiser::{Localiser, TestFrame, Timing, split_name};
use crate::summary::{Summary, summarize_variant};
use fileio::io_err;
use shards::{MANIFEST_FILE, shards_of_split};
use shards::{ShardReader, Split};
use std::path::{Path, PathBuf};
use std::time::Instant;

pub const PER_FRAME_FILE: &str = "per_frame.parquet";
pub const SUMMARY_MD_FILE: &str = "summary.md";
pub const SUMMARY_JSON_FILE: &str = "summary.json";
pub const PLOT_FILE: &str = "cdf.png";

/// `results_points.txt`, `results_points_lines.txt` (hloc format).
pub fn results_file(v: Variant) -> String {
    format!("results_{}.txt", v.key())
}

/// What [`score_shards`] measured and wrote.
#[derive(Clone, Debug)]
pub struct ScoreOutput {
    pub summary: Summary,
    pub results: Vec<FrameResult>,
    /// Every file written, in `out`.
    pub files: Vec<PathBuf>,
}

/// The shard files of `split` listed in the folder's complete manifest.
pub fn shard_paths(shards_dir: &Path, split: Split) -> Result<Vec<PathBuf>, ScoreError> {
    // The one manifest check of every reader (crates/shards/src/shard_stage/checked.rs):
    // the shard stage's record, the shards' hashes, a complete plan.
    let manifest = shards::checked_manifest(shards_dir).map_err(|e| ScoreError::Manifest {
        path: shards_dir.join(MANIFEST_FILE),
        reason: e.to_string(),
    })?;
    let paths: Vec<PathBuf> = shards_of_split(&manifest, split)
        .into_iter()
        .map(|s| shards_dir.join(&s.file))
        .collect();
    if paths.is_empty() {
        return Err(ScoreError::NoFrames {
            dir: shards_dir.to_path_buf(),
            split: split_name(split),
            reason: match split {
                Split::Test => "was the shard stage run with --no-test?",
                Split::Train => "the oracle needs labelled training frames",
            },
        });
    }
    Ok(paths)
}

/// Scores every frame of the localiser's split in `shards_dir` and writes the outputs
/// to `out` (see the crate docs). Not a recorded stage: no `stage.json`, no skipping
/// ([`crate::score_stage::run`] is).
pub fn score_shards(
    shards_dir: &Path,
    out: &Path,
    localiser: &mut dyn Localiser,
    config: &ScoreConfig,
) -> Result<ScoreOutput, ScoreError> {
    score_shards_with_visual(shards_dir, out, localiser, config, false)
}

/// [`score_shards`], and with `visual` also `visual.mcap` ([`crate::visual`]): every frame's
/// image, estimated and ground-truth cameras and predictions, for Foxglove.
pub fn score_shards_with_visual(
    shards_dir: &Path,
    out: &Path,
    localiser: &mut dyn Localiser,
    config: &ScoreConfig,
    visual: bool,
) -> Result<ScoreOutput, ScoreError> {
    config.validate()?;
    let mut visual = if visual {
        Some(crate::visual::VisualWriter::create(
            &out.join(crate::visual::VISUAL_FILE),
        )?)
    } else {
        None
    };
    let split = localiser.split();
    let paths = shard_paths(shards_dir, split)?;
    let shard_err = |source| ScoreError::Shards {
        dir: shards_dir.to_path_buf(),
        source,
    };
    let reader = ShardReader::open(&paths).map_err(shard_err)?;
    let bar = stage::progress_bar(reader.frame_count() as u64, "score");
    let mut results = Vec::with_capacity(reader.frame_count());
    let mut reader = reader;
    // A few frames per round, so a localiser can run their front-ends side by side
    // (`Localiser::correspond_each`) and their RANSAC too; results are the same as
    // frame by frame.
    let round = 2 * rayon::current_num_threads().max(1);
    let mut frames = Vec::with_capacity(round);
    let mut read_ms = Vec::with_capacity(round);
    loop {
        frames.clear();
        read_ms.clear();
        while frames.len() < round {
            let t = Instant::now();
            let Some(record) = reader.next() else { break };
            let record = record.map_err(shard_err)?;
            read_ms.push(t.elapsed().as_secs_f64() * 1e3);
            if record.split != split {
                return Err(ScoreError::WrongSplit {
                    frame_id: record.frame_id,
                    name: record.name,
                    found: split_name(record.split),
                    expected: split_name(split),
                });
            }
            frames.push(TestFrame { record });
        }
        if frames.is_empty() {
            break;
        }
        let before = read_ms
            .iter()
            .map(|&ms| {
                vec![Timing {
                    step: "read".into(),
                    ms,
                }]
            })
            .collect();
        // The one localisation path (crate::localize); the first error in frame order
        // stops the run.
        let batch = crate::localize::localize_batch(localiser, &frames, before, config);
        for (frame, l) in frames.iter().zip(batch) {
            let mut l = l?;
            measure(&mut l.result, frame.gt_pose());
            if let Some(v) = visual.as_mut() {
                v.add(frame, &l, Some(frame.gt_pose()), config)?;
            }
            results.push(l.result);
            bar.inc(1);
        }
    }
    bar.finish_and_clear();

    let summary = Summary {
        source: localiser.describe(),
        split: split_name(split).to_string(),
        min_point_reliability: config.min_point_reliability,
        min_line_reliability: config.min_line_reliability,
        point_threshold_px: config.ransac.point_threshold_px,
        line_threshold_px: config.ransac.line_threshold_px,
        seed: config.ransac.seed,
        variants: Variant::ALL
            .iter()
            .map(|&v| summarize_variant(&results, v))
            .collect(),
    };
    let mut files = write_outputs(out, &summary, &results)?;
    if let Some(v) = visual {
        files.push(v.finish()?);
    }
    Ok(ScoreOutput {
        summary,
        results,
        files,
    })
}

/// Writes the per-frame table, the hloc result files, the summaries and the plot, each
/// through a temp file and a rename. The result files are formatted first, so a name
/// the format cannot hold stops the run before anything is written.
pub fn write_outputs(
    out: &Path,
    summary: &Summary,
    results: &[FrameResult],
) -> Result<Vec<PathBuf>, ScoreError> {
    let hloc: Vec<(Variant, String)> = Variant::ALL
        .iter()
        .map(|&v| {
            let entries = results.iter().filter_map(|r| {
                r.variant(v)
                    .pose
                    .as_ref()
                    .map(|p| (r.frame_id, r.name.as_str(), p))
            });
            crate::hloc::format_results(entries).map(|text| (v, text))
        })
        .collect::<Result<_, _>>()?;
    std::fs::create_dir_all(out).map_err(io_err(out))?;
    let mut files = Vec::new();
    let p = out.join(PER_FRAME_FILE);
    crate::table::write_table(&p, results, &summary.source, &summary.split)?;
    files.push(p);
    for (v, text) in hloc {
        let p = out.join(results_file(v));
        stage::write_atomic(&p, text.as_bytes())?;
        files.push(p);
    }
    let p = out.join(SUMMARY_MD_FILE);
    stage::write_atomic(&p, summary.markdown().as_bytes())?;
    files.push(p);
    let p = out.join(SUMMARY_JSON_FILE);
    stage::write_atomic(&p, &summary.to_json())?;
    files.push(p);
    let p = out.join(PLOT_FILE);
    crate::plot::write_plot(&p, results)?;
    files.push(p);
    Ok(files)
}
