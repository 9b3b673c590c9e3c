//! Pipeline files and lock files (issue 7):
//! - [`config`]: `pipeline/*.toml`, one section per stage, paths relative to the file or
//!   from `${ENV}` variables;
//! - [`run()`]: the stages in order into `<work>/<stage>/`, each skipping itself when its
//!   `stage.json` matches; train and score keep their records in [`train_stage`];
//! - [`ablation`]: the pipeline with and without `[refine]`, scored side by side;
//! - [`lock`]: `manifests/*.toml`, the hashes of a reproducible training set, and
//!   [`lock::verify`], which rebuilds it and compares.

pub mod ablation;
pub mod config;
pub mod error;
pub mod expand;
pub mod lock;
pub mod run;
pub mod synth_stage;
pub mod train_stage;

pub use ablation::{Ablation, run_ablation};
pub use config::{Pipeline, PipelineFile, STAGES, WITHOUT_REFINE, WarmStartSection};
pub use error::{PipelineError, Result};
pub use lock::{Lock, VerifyReport, verify};
pub use run::{RunOptions, RunReport, StageReport, Status, run};
