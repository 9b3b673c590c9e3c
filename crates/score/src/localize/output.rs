//! What `pl2map localize` gives back: each query's outcome and the files written.

use super::queries::Query;
use crate::evaluate::{FrameResult, Variant};
use std::path::PathBuf;

/// One query's outcome: localised (with or without a pose), or why it could not be
/// read.
#[derive(Clone, Debug)]
pub struct QueryResult {
    pub query: Query,
    pub outcome: Result<FrameResult, String>,
}

impl QueryResult {
    /// The chosen variant's pose, when there is one.
    pub fn pose(&self, v: Variant) -> Option<&geometry::Pose> {
        self.outcome.as_ref().ok()?.variant(v).pose.as_ref()
    }
}

/// What [`super::run`] did.
#[derive(Clone, Debug)]
pub struct LocalizeOutput {
    pub variant: Variant,
    pub results: Vec<QueryResult>,
    /// Every file written.
    pub files: Vec<PathBuf>,
}

impl LocalizeOutput {
    /// Queries that could not be read (bad input).
    pub fn failed_inputs(&self) -> impl Iterator<Item = &QueryResult> {
        self.results.iter().filter(|r| r.outcome.is_err())
    }

    pub fn localised(&self) -> usize {
        self.results
            .iter()
            .filter(|r| r.pose(self.variant).is_some())
            .count()
    }

    // `summary`, the lines printed at the end, is in table.rs with the table's columns.
}
