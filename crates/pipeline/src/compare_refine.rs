//! `pl2map run PIPELINE --compare-refine` (the label ablation in one command): the
//! pipeline as written (labels refined on depth) and the same pipeline on the imported
//! labels as they are, scored side by side. The data stages (synth, ingest, import,
//! refine) are shared; the variant without refinement keeps its shards, model and score
//! in `<work>/without-refine/`. Both runs are recorded stages, so a rerun only redoes
//! what changed.

use crate::config::Pipeline;
use crate::error::{PipelineError, Result};
use crate::run::{RunOptions, RunReport, run};
use score::Summary;
use score::summary::{align_cells, header_cells};

/// Both runs and their scores.
#[derive(Clone, Debug)]
pub struct RefineComparison {
    pub refined: RunReport,
    pub imported: RunReport,
    pub refined_score: Summary,
    pub imported_score: Summary,
}

/// Runs `p` (which must refine, train and score) and its variant without refinement.
pub fn run_compare_refine(p: &Pipeline, options: &RunOptions) -> Result<RefineComparison> {
    let missing: Vec<&str> = [
        ("[refine]", p.refine().is_some()),
        ("[train]", p.file.train.is_some()),
        ("[score]", p.file.score.is_some()),
    ]
    .into_iter()
    .filter(|(_, has)| !has)
    .map(|(name, _)| name)
    .collect();
    if !missing.is_empty() {
        return Err(PipelineError::Config {
            path: p.origin.clone(),
            message: format!(
                "--compare-refine scores the pipeline with and without [refine]: it needs {}",
                missing.join(", ")
            ),
        });
    }
    if options.until.is_some() || options.shards.is_some() {
        return Err(PipelineError::Config {
            path: p.origin.clone(),
            message: "--compare-refine runs both pipelines to the score: drop --until / --shards"
                .into(),
        });
    }
    let refined = run(p, options)?;
    let without = p.without_refine();
    let imported = run(&without, options)?;
    let read = |r: &RunReport, q: &Pipeline| {
        r.score.clone().ok_or_else(|| PipelineError::Stage {
            stage: "score",
            message: format!(
                "no score summary in {}",
                q.stage_dir(crate::StageName::Score).display()
            ),
        })
    };
    Ok(RefineComparison {
        refined_score: read(&refined, p)?,
        imported_score: read(&imported, &without)?,
        refined,
        imported,
    })
}

impl RefineComparison {
    /// One markdown table: a row per (labels, variant), the medians and the strict
    /// accuracies at every threshold (the score summary's own cells).
    pub fn table(&self) -> String {
        let mut s = format!("| labels |{}\n|---|{}\n", header_cells(), align_cells());
        for (labels, summary) in [
            ("refined", &self.refined_score),
            ("as imported", &self.imported_score),
        ] {
            for v in &summary.variants {
                s.push_str(&format!("| {labels} |{}\n", v.row_cells()));
            }
        }
        s
    }
}
