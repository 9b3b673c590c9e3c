//! `pl2map`: a thin command line over the stage libraries. Each subcommand lives in
//! `commands/<name>.rs`, parses its arguments and calls one library function.

mod commands;
// `crate::outln!` / `crate::out!`: stdout that survives a closed pipe (crates/stage/src/out.rs).
#[allow(unused_imports)]
pub(crate) use stage::{out, outln};

use clap::{CommandFactory, FromArgMatches, Parser, Subcommand};

#[derive(Parser)]
#[command(
    name = "pl2map",
    version,
    about = "Learned point + line relocalisation maps: datasets, SfM labels, shards, training, scoring"
)]
struct Cli {
    /// Hide progress bars and informational logs.
    #[arg(long, global = true)]
    quiet: bool,
    /// Wait for a work or stage folder another pl2map process is writing, instead of
    /// refusing it.
    #[arg(long, global = true)]
    wait: bool,
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// COLMAP sparse models: summary and bin <-> txt conversion.
    #[command(subcommand)]
    Colmap(commands::colmap::Command),
    /// LIMAP line-track folders: summary and consistency checks.
    #[command(subcommand)]
    Limap(commands::limap::Command),
    /// Render the built-in synthetic room (7-Scenes or Cambridge layout).
    Synth(commands::synth::Args),
    /// Stage 1: read a dataset folder into the frames table.
    Ingest(commands::ingest::Args),
    /// Stage 2: join a COLMAP model and LIMAP tracks to the frames into label tables.
    Import(Box<commands::import::Args>),
    /// Stage 3 (optional): move labels onto the depth maps.
    Refine(commands::refine::Args),
    /// Stage 4: write label shards (MCAP) and their manifest.
    Shard(commands::shard::Args),
    /// Stage 5: train the PL2Map network on the training shards.
    Train(Box<commands::train::Args>),
    /// Stage 6: localise the frames of a shard folder (network or oracle) and score the poses.
    Score(commands::score::Args),
    /// Localise new images (hloc query list or a folder) with a trained map: hloc results, per-image table.
    Localize(commands::localize::Args),
    /// Run a pipeline file (pipeline/*.toml): every stage in order, skipping up-to-date ones.
    Run(commands::run::Args),
    /// Write the lock file (manifests/*.toml) of a pipeline's training set.
    Lock(commands::verify::LockArgs),
    /// Rebuild a lock file's training set and compare every hash.
    Verify(commands::verify::VerifyArgs),
    /// Keypoints and descriptors of images (SIFT or SuperPoint) in hloc's HDF5 layout.
    Features(commands::features::Args),
    /// Absolute pose from 2D-3D point (and line) correspondences.
    Pose(commands::pose::Args),
    /// Checkpoints: import the reference implementation's released models.
    #[command(subcommand)]
    Checkpoint(commands::checkpoint::Command),
    /// Benchmarks that print a table (never run as tests).
    #[command(subcommand)]
    Bench(bench::cli::Command),
}

fn main() -> std::process::ExitCode {
    let matches = Cli::command().get_matches();
    let cli = match Cli::from_arg_matches(&matches) {
        Ok(cli) => cli,
        Err(e) => e.exit(),
    };
    // The subcommand's own matches: `pl2map train` tells the flags given on the
    // command line from their defaults.
    let sub = matches
        .subcommand()
        .map(|(_, m)| m.clone())
        .unwrap_or_default();
    commands::init_logging(cli.quiet);
    stage::set_wait(cli.wait);
    let result = match cli.command {
        Command::Colmap(c) => commands::colmap::run(c),
        Command::Limap(c) => commands::limap::run(c),
        Command::Synth(a) => commands::synth::run(a, cli.quiet),
        Command::Ingest(a) => commands::ingest::run(a),
        Command::Import(a) => commands::import::run(*a),
        Command::Refine(a) => commands::refine::run(a),
        Command::Shard(a) => commands::shard::run(a),
        Command::Train(a) => commands::train::run(*a, &sub, cli.quiet),
        Command::Score(a) => commands::score::run(a),
        Command::Localize(a) => commands::localize::run(a),
        Command::Run(a) => commands::run::run(a, cli.quiet),
        Command::Lock(a) => commands::verify::lock(a, cli.quiet),
        Command::Verify(a) => commands::verify::verify(a, cli.quiet),
        Command::Features(a) => commands::features::run(a),
        Command::Pose(a) => commands::pose::run(a),
        Command::Checkpoint(c) => commands::checkpoint::run(c),
        Command::Bench(c) => bench::cli::run(c),
    };
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {}", error_text(&e));
            std::process::ExitCode::FAILURE
        }
    }
}

/// The error and its causes, each said once: the project's errors often put their
/// cause's text in their own message (`{path}: {source}`), which anyhow's `{:#}` would
/// repeat.
fn error_text(e: &anyhow::Error) -> String {
    let mut text = String::new();
    for cause in e.chain() {
        let part = cause.to_string();
        if !text.contains(&part) {
            if !text.is_empty() {
                text.push_str(": ");
            }
            text.push_str(&part);
        }
    }
    text
}

#[cfg(test)]
mod tests {
    use super::error_text;

    /// An error whose message already holds its cause's text, as `{path}: {source}`.
    #[derive(Debug)]
    struct WithPath(std::io::Error);

    impl std::fmt::Display for WithPath {
        fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
            write!(f, "frames.parquet: {}", self.0)
        }
    }

    impl std::error::Error for WithPath {
        fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
            Some(&self.0)
        }
    }

    #[test]
    fn each_cause_is_said_once() {
        let e = anyhow::Error::new(WithPath(std::io::Error::other("No space left on device")))
            .context("stage ingest");
        assert_eq!(
            error_text(&e),
            "stage ingest: frames.parquet: No space left on device"
        );
        let plain = anyhow::Error::new(std::io::Error::other("gone")).context("reading x");
        assert_eq!(error_text(&plain), "reading x: gone");
    }
}
