//! The score stage (docs/method.md section 6): localise each frame of a shard folder
//! from 2D-3D correspondences, with points only and with points + lines, and measure
//! the poses against the ground truth.
//!
//! - [`Localiser`]: where correspondences come from. [`OracleLocaliser`] takes them
//!   from the shard labels (training frames: test shards carry no labels); the network
//!   adapter ([`network`], feature `network`, on by default) runs a trained checkpoint
//!   through `train::Predictor`.
//! - [`evaluate`]: per frame, keep predictions with reliability >= 0.5 (points) /
//!   0.02 (lines), then `pose::estimate_pose` (12 px / 10 px, seeded per frame) for both
//!   variants, and the errors of `geometry::metrics`.
//! - [`localize`]: the localisation path the stage shares with `pl2map localize`
//!   (correspondences, then [`evaluate::localize_frame`] for a batch of frames side by
//!   side), hloc query lists, the per-image table and `localize::run`.
//! - [`query_lines`]: test images' segments from a LIMAP-format folder (the map's line
//!   detector run on the queries) instead of the front-end's detector.
//! - [`visual`]: `visual.mcap` for Foxglove (the score stage's `visual`, `pl2map
//!   localize --visual`).
//! - [`score_stage::run`]: the stage, which records [`score_shards`]'s work in its
//!   folder and skips it when up to date. [`score_shards`] writes its outputs in the
//!   output folder, each atomically:
//!   `per_frame.parquet` ([`table`]), `results_points.txt` and
//!   `results_points_lines.txt` ([`hloc`] format), `summary.md` and `summary.json`
//!   ([`summary`]), `cdf.png` ([`plot`]). For the same shards, localiser and seed every
//!   file is the same bytes except the `time_*` columns of the table.
//!
//! A crate of its own rather than part of `pose`: scoring reads shards and writes
//! parquet (polars) and runs the network (burn), while `pose` stays a small solver
//! library with no such dependencies, usable on correspondences from anywhere.

mod error;
pub mod evaluate;
pub mod hloc;
mod localiser;
pub mod localize;
#[cfg(feature = "network")]
pub mod network;
pub mod oracle;
pub mod plot;
pub mod query_lines;
pub mod score_stage;
pub mod scoring;
pub mod summary;
pub mod table;
pub mod visual;

pub use error::ScoreError;
pub use evaluate::{FrameResult, ScoreConfig, Variant, VariantResult, localize_frame};
pub use localiser::{
    Correspondences, LineCorrespondence, Localiser, PointCorrespondence, TestFrame, Timing,
};
#[cfg(feature = "network")]
pub use network::NetworkLocaliser;
pub use oracle::OracleLocaliser;
pub use score_stage::{ScoreStageConfig, ScoreStageOutput, Source};
pub use scoring::{ScoreOutput, score_shards};
pub use summary::Summary;
