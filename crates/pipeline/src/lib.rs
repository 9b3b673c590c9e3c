//! Pipeline files and lock files:
//! - [`config`]: `pipeline/*.toml`, one section per stage, each deserialised straight
//!   into its stage's configuration; paths relative to the file or from `${ENV}`
//!   variables;
//! - [`stages`]: the typed list of stages, in run order;
//! - [`run()`]: the stages in order into `<work>/<stage>/`, each skipping itself when its
//!   `stage.json` matches (the stage runner of the `stage` crate);
//! - [`compare_refine`]: the pipeline with and without `[refine]`, scored side by side
//!   (`--compare-refine`);
//! - [`promotion`]: the gate of `--warm-start`: the better of the new and the previous
//!   model, scored on the same test frames, is kept;
//! - [`lock`]: `manifests/*.toml`, the hashes of a reproducible training set, and
//!   [`lock::verify`], which rebuilds it and compares.

pub mod compare_refine;
pub mod config;
pub mod error;
pub mod expand;
pub mod lock;
pub mod promotion;
mod resolver;
pub mod run;
pub mod stages;

pub use compare_refine::{RefineComparison, run_compare_refine};
pub use config::{Pipeline, PipelineFile, WITHOUT_REFINE, WarmStartSection};
pub use error::{PipelineError, Result};
pub use lock::{Lock, VerifyReport, verify};
pub use promotion::{Kept, PREVIOUS_SCORE_DIR, Promotion};
pub use run::{RunOptions, RunReport, StageReport, Status, run};
pub use stages::StageName;
