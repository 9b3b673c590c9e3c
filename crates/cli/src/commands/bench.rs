//! `pl2map bench ...`: each benchmark lives in its own file (`bench_<name>.rs`).
use clap::Subcommand;

#[derive(Subcommand)]
pub enum Command {
    /// Reading a large binary COLMAP model, against pycolmap when available.
    Colmap(super::bench_colmap::Args),
    /// Pose solvers and RANSAC against poselib when available.
    Pose(super::bench_pose::Args),
    /// Front-end: SIFT, LSD and line sampling per image; images/s on 1 and 2 threads.
    Features(super::bench_features::Args),
    /// Localisation: each phase's median ms per query, latency and queries/s on 1 and 2 threads.
    Localize(super::bench_localize::Args),
    /// Frames/s of ingest + import + shard against decoding the images alone.
    Stages(super::bench_stages::Args),
}

pub fn run(cmd: Command) -> anyhow::Result<()> {
    match cmd {
        Command::Colmap(a) => super::bench_colmap::run(a),
        Command::Pose(a) => super::bench_pose::run(a),
        Command::Features(a) => super::bench_features::run(a),
        Command::Stages(a) => super::bench_stages::run(a),
        Command::Localize(a) => super::bench_localize::run(a),
    }
}
