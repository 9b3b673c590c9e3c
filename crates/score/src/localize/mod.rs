//! Localising images with a trained map: `pl2map localize`, and the per-batch step the
//! score stage shares with it.
//!
//! - [`localize_batch`]: the one localisation path. The localiser's correspondences
//!   (the network's front-ends side by side on the rayon pool, then the network frame
//!   by frame), then [`crate::evaluate::localize_frame`] (reliability filters, RANSAC
//!   with points and with points + lines) for every frame side by side. Each frame's
//!   RANSAC is seeded from the run's seed and its image name, so results do not depend on the
//!   thread count or on which frames share a batch. The score stage ([`crate::score_shards`])
//!   adds the errors against the ground truth.
//! - [`queries`]: hloc's query list with intrinsics, or a folder of images with one
//!   camera.
//! - [`run()`]: localises every query into an output folder: `results.txt` (hloc
//!   format, the poses of the chosen variant), `per_image.csv` ([`table`]) and, on
//!   request, a Foxglove MCAP file ([`crate::visual`]). A query that cannot be read
//!   (missing or unreadable image, bad camera line, image of another size than its
//!   camera) is a row of the table with its reason; the others are still localised.

mod output;
pub mod queries;
pub mod table;

use crate::error::ScoreError;
use crate::evaluate::{Localised, ScoreConfig, Variant, localize_frame};
use crate::localiser::{Localiser, TestFrame, Timing};
use fileio::io_err;
use rayon::prelude::*;
use std::path::{Path, PathBuf};
use std::time::Instant;

pub use output::{LocalizeOutput, QueryResult};
pub use queries::{Query, folder_queries, load_query, parse_query_list, read_query_list};

/// Corresponds and localises a batch of frames, in their order, each with its own
/// result (see the module docs). `before[i]` holds frame i's earlier timings (reading).
pub fn localize_batch(
    localiser: &mut dyn Localiser,
    frames: &[TestFrame],
    before: Vec<Vec<Timing>>,
    config: &ScoreConfig,
) -> Vec<Result<Localised, ScoreError>> {
    debug_assert_eq!(frames.len(), before.len());
    let corrs = localiser.correspond_each(frames);
    frames
        .par_iter()
        .zip(corrs)
        .zip(before)
        .map(|((frame, corr), mut timings)| {
            let corr = corr?;
            timings.extend(corr.timings.iter().cloned());
            let result = localize_frame(
                frame.frame_id(),
                frame.name(),
                frame.camera(),
                &corr,
                config,
                timings,
            );
            Ok(Localised {
                result,
                correspondences: corr,
            })
        })
        .collect()
}

/// What `pl2map localize` does besides the RANSAC settings.
#[derive(Clone, Debug)]
pub struct LocalizeOptions {
    pub config: ScoreConfig,
    /// The pose written to the results file: points + lines (true) or points only.
    pub lines: bool,
    /// Write this MCAP file for Foxglove (images, cameras, predicted points and lines).
    pub visual: Option<PathBuf>,
}

impl LocalizeOptions {
    pub fn variant(&self) -> Variant {
        if self.lines {
            Variant::PointsLines
        } else {
            Variant::Points
        }
    }
}

pub const RESULTS_FILE: &str = "results.txt";
pub const TABLE_FILE: &str = "per_image.csv";

/// Localises `queries` (images under `images`) into `out`: `results.txt`,
/// `per_image.csv`, and `opts.visual` when given. Errors only when nothing can be
/// written; a query that cannot be read is recorded in the output (see the module
/// docs).
pub fn run(
    localiser: &mut dyn Localiser,
    queries: &[Query],
    images: &Path,
    out: &Path,
    opts: &LocalizeOptions,
) -> Result<LocalizeOutput, ScoreError> {
    opts.config.validate()?;
    let variant = opts.variant();
    let bar = stage::progress_bar(queries.len() as u64, "localize");
    let mut visual = match &opts.visual {
        Some(path) => Some(crate::visual::VisualWriter::create(path)?),
        None => None,
    };
    let mut results = Vec::with_capacity(queries.len());
    // A few images per round, as the score stage: their front-ends run side by side
    // and memory stays bounded.
    let round = 2 * rayon::current_num_threads().max(1);
    for chunk in queries.chunks(round) {
        let loaded: Vec<(Result<TestFrame, String>, f64)> = chunk
            .par_iter()
            .map(|q| {
                let t = Instant::now();
                let f = load_query(images, q).map_err(|e| format!("{}: {e}", q.origin));
                (f, t.elapsed().as_secs_f64() * 1e3)
            })
            .collect();
        let mut frames = Vec::with_capacity(chunk.len());
        let mut before = Vec::with_capacity(chunk.len());
        let mut slots = Vec::with_capacity(chunk.len());
        for (f, ms) in loaded {
            match f {
                Ok(f) => {
                    slots.push(Ok(frames.len()));
                    frames.push(f);
                    before.push(vec![Timing {
                        step: "read".into(),
                        ms,
                    }]);
                }
                Err(e) => slots.push(Err(e)),
            }
        }
        let mut batch: Vec<Option<Result<Localised, ScoreError>>> =
            localize_batch(localiser, &frames, before, &opts.config)
                .into_iter()
                .map(Some)
                .collect();
        for (q, slot) in chunk.iter().zip(slots) {
            let outcome = match slot {
                Err(e) => Err(e),
                Ok(i) => match batch[i].take().expect("each frame once") {
                    Err(e) => Err(format!("{}: {}", q.origin, frame_reason(e))),
                    Ok(l) => {
                        if let Some(v) = visual.as_mut() {
                            v.add(&frames[i], &l, None, &opts.config)?;
                        }
                        Ok(l.result)
                    }
                },
            };
            results.push(QueryResult {
                query: q.clone(),
                outcome,
            });
            bar.inc(1);
        }
    }
    bar.finish_and_clear();
    let files = write_outputs(out, &results, variant, visual)?;
    Ok(LocalizeOutput {
        variant,
        results,
        files,
    })
}

/// A localiser's error on one frame without the frame's id and name, which the query's
/// origin already gives.
fn frame_reason(e: ScoreError) -> String {
    match e {
        ScoreError::Frame { reason, .. } => reason,
        e => e.to_string(),
    }
}

fn write_outputs(
    out: &Path,
    results: &[QueryResult],
    variant: Variant,
    visual: Option<crate::visual::VisualWriter>,
) -> Result<Vec<PathBuf>, ScoreError> {
    let entries = results.iter().filter_map(|r| {
        r.pose(variant)
            .map(|p| (r.query.id, r.query.name.as_str(), p))
    });
    let hloc = crate::hloc::format_results(entries)?;
    std::fs::create_dir_all(out).map_err(io_err(out))?;
    let mut files = Vec::new();
    let p = out.join(RESULTS_FILE);
    stage::write_atomic(&p, hloc.as_bytes())?;
    files.push(p);
    let p = out.join(TABLE_FILE);
    stage::write_atomic(&p, table::csv(results).as_bytes())?;
    files.push(p);
    if let Some(v) = visual {
        files.push(v.finish()?);
    }
    Ok(files)
}
