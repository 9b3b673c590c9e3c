//! The ingest stage's steps: reads a dataset in its published layout into the frames
//! table (ARCHITECTURE.md, "Data flow"; the layouts read are in docs/formats.md section
//! 3). One adapter per dataset converts its conventions once, here: poses become
//! world-to-camera, cameras COLMAP models, names dataset-relative paths. The stage
//! itself (its folder, record and skip) is [`crate::ingest_stage`].
//!
//! Frame ids: frames sorted by split (train, then test), then by name in byte order,
//! numbered from 0.

mod build;
pub mod cambridge;
mod config;
pub mod depth;
mod error;
pub mod nvm;
mod plan;
pub mod sevenscenes;
mod text;
mod whole;

pub use crate::dataset_kind::DatasetKind;
pub use config::{DepthOption, IngestConfig, PoseOption};
pub use error::{DamagedImagesError, FrameCountError, IngestError, Result};

use std::collections::BTreeMap;
use std::path::Path;
use tables::frames::FramesTable;

/// A dataset planned (every frame and every file it reads listed, the configuration
/// normalised) and its inputs hashed: what the stage records before it reads a frame.
pub(crate) struct Planned {
    plan: plan::Plan,
    hashes: build::InputHashes,
}

impl Planned {
    pub(crate) fn new(config: &IngestConfig) -> Result<Planned> {
        let plan = plan::plan(config)?;
        let hashes = build::hash_inputs(&plan)?;
        Ok(Planned { plan, hashes })
    }

    /// The configuration with its paths made absolute: what the record hashes.
    pub(crate) fn config(&self) -> &IngestConfig {
        &self.plan.normalised_config
    }

    /// Input name -> content hash.
    pub(crate) fn inputs(&self) -> &BTreeMap<String, String> {
        &self.hashes.inputs
    }

    /// Reads every frame into the table; registered depth goes to `depth_out`
    /// (required with `depth = raw`).
    pub(crate) fn build(&self, depth_out: Option<&Path>) -> Result<FramesTable> {
        build::build(&self.plan, &self.hashes, depth_out)
    }
}

/// Reads a dataset into a frames table without a stage folder. `depth_out` is where
/// registered depth goes (required with `depth = raw`).
pub fn read_dataset(config: &IngestConfig, depth_out: Option<&Path>) -> Result<FramesTable> {
    Planned::new(config)?.build(depth_out)
}
