//! `pl2map`: a thin command line over the stage libraries. Each subcommand lives in
//! `commands/<name>.rs`, parses its arguments and calls one library function.

mod commands;

use clap::{Parser, Subcommand};

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
    /// Absolute pose from 2D-3D point (and line) correspondences.
    Pose(commands::pose::Args),
    /// Benchmarks that print a table (never run as tests).
    #[command(subcommand)]
    Bench(commands::bench::Command),
}

fn main() -> std::process::ExitCode {
    let cli = Cli::parse();
    commands::init_logging(cli.quiet);
    let result = match cli.command {
        Command::Colmap(c) => commands::colmap::run(c),
        Command::Limap(c) => commands::limap::run(c),
        Command::Pose(a) => commands::pose::run(a),
        Command::Bench(c) => commands::bench::run(c),
    };
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}
