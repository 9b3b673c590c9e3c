//! Test support for the workspace's crates. Dev-only: every crate that uses it lists it
//! under `[dev-dependencies]`; no library or binary depends on it.
//!
//! - [`sample`]: the real sample data (README.md, "Tests": where it is looked for).
//! - [`python`]: the Python peer (`PL2MAP_PYTHON`) the interop tests compare against, and
//!   running it.
//! - [`files`]: folder walkers and copies, for byte-identity checks.
//! - [`images`]: seeded RGB and 16-bit depth images.
//! - [`on_threads`]: runs a closure in a rayon pool of a given size.
//! - [`process`]: child processes with a closed standard output.
//! - Fixtures on workspace crates, each behind its feature: `layouts` (7-Scenes and
//!   Cambridge dataset folders), `scene` (an analytic room with its frames table, COLMAP
//!   model and LIMAP folder), `shard_frames` (seeded shard frames).
//!
//! A test that cannot run here (no sample data, no Python peer, no compiler) prints one
//! line `SKIPPED <test>: <reason>` to stderr ([`skip`]) and returns.

pub mod files;
pub mod images;
#[cfg(feature = "layouts")]
pub mod layouts;
pub mod process;
pub mod python;
pub mod sample;
#[cfg(feature = "scene")]
pub mod scene;
#[cfg(feature = "shard-frames")]
pub mod shard_frames;

use std::fmt::Display;

/// Prints `SKIPPED <test>: <reason>` to stderr: the one line a test prints when it
/// returns early because something it needs is missing. `<test>` is [`test_name`].
pub fn skip(reason: impl Display) {
    eprintln!("SKIPPED {}: {reason}", test_name());
}

/// The name of the running test: the test harness runs each test on a thread named after
/// it (`module::test` for a test inside a module); `main` or `unnamed` elsewhere.
pub fn test_name() -> String {
    std::thread::current()
        .name()
        .unwrap_or("unnamed")
        .to_string()
}

/// Runs `f` inside a fresh rayon pool of `threads` threads (for the "same bytes for any
/// thread count" checks).
pub fn on_threads<R: Send>(threads: usize, f: impl FnOnce() -> R + Send) -> R {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("building a rayon pool")
        .install(f)
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_test_name_is_the_harness_thread_name() {
        assert_eq!(
            super::test_name(),
            "tests::the_test_name_is_the_harness_thread_name"
        );
    }

    #[test]
    fn on_threads_runs_in_a_pool_of_that_size() {
        assert_eq!(super::on_threads(3, rayon::current_num_threads), 3);
    }
}
