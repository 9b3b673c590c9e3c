//! Shared helpers of the integration tests.
#![allow(dead_code)]

use std::path::PathBuf;

/// The real sample data (PL2MAP_SAMPLE_DATA, else `<workspace>/../shared/data`), or None
/// with a printed reason so the caller can skip.
pub fn sample_data(sub: &str) -> Option<PathBuf> {
    let root = std::env::var_os("PL2MAP_SAMPLE_DATA")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data"));
    let dir = root.join(sub);
    if dir.is_dir() {
        Some(dir)
    } else {
        eprintln!(
            "SKIP: sample data {} not found (set PL2MAP_SAMPLE_DATA)",
            dir.display()
        );
        None
    }
}

pub const TABLES: [&str; 5] = ["cameras", "images", "points3D", "rigs", "frames"];
