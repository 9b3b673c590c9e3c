pub mod checkpoint;
pub mod colmap;
pub mod features;
pub mod flags;
pub mod import;
pub mod ingest;
pub mod limap;
pub mod localize;
pub mod pose;
pub mod refine;
pub mod run;
pub mod score;
pub mod shard;
pub mod synth;
pub mod train;
pub mod verify;

/// Logs go to stderr through `tracing`; `RUST_LOG` overrides the level.
pub fn init_logging(quiet: bool) {
    // Progress bars of every stage (stage::progress_bar) follow --quiet too.
    stage::set_quiet(quiet);
    let default = if quiet { "warn" } else { "info" };
    let filter = tracing_subscriber::EnvFilter::try_from_default_env()
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new(default));
    let _ = tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        // Colour codes only for a person at a terminal, not in a cron job's log file.
        .with_ansi(std::io::IsTerminal::is_terminal(&std::io::stderr()))
        .with_target(false)
        .try_init();
}
