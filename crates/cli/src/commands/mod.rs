pub mod bench;
pub mod bench_colmap;
pub mod bench_features;
pub mod bench_pose;
pub mod bench_stages;
pub mod colmap;
pub mod import;
pub mod ingest;
pub mod limap;
pub mod pose;
pub mod refine;
pub mod shard;
pub mod synth;

/// Logs go to stderr through `tracing`; `RUST_LOG` overrides the level.
pub fn init_logging(quiet: bool) {
    let default = if quiet { "warn" } else { "info" };
    let filter = tracing_subscriber::EnvFilter::try_from_default_env()
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new(default));
    let _ = tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .with_target(false)
        .try_init();
}
