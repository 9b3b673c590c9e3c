//! `pl2map bench ...`: each benchmark's command lives in its own file (`<name>.rs`).

pub mod colmap;
pub mod features;
pub mod localize;
pub mod pose;
pub mod scale;
pub mod stages;

use clap::Subcommand;

#[derive(Subcommand)]
pub enum Command {
    /// Reading a large binary COLMAP model, against pycolmap when available.
    Colmap(colmap::Args),
    /// Pose solvers and RANSAC against poselib when available.
    Pose(pose::Args),
    /// Front-end: SIFT, LSD and line sampling per image; images/s on 1 and 2 threads.
    Features(features::Args),
    /// Localisation: each phase's median ms per query, latency and queries/s on 1 and 2 threads.
    Localize(localize::Args),
    /// Frames/s of ingest + import + shard against decoding the images alone.
    Stages(stages::Args),
    /// Every stage's seconds and peak memory, and the training step, at several scene sizes.
    Scale(scale::Args),
}

pub fn run(cmd: Command) -> anyhow::Result<()> {
    match cmd {
        Command::Colmap(a) => colmap::run(a),
        Command::Pose(a) => pose::run(a),
        Command::Features(a) => features::run(a),
        Command::Stages(a) => stages::run(a),
        Command::Localize(a) => localize::run(a),
        Command::Scale(a) => scale::run(a),
    }
}
