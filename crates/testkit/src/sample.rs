//! The real sample data (README.md, "Tests"): `PL2MAP_SAMPLE_DATA` when set, else the
//! default location the README names. Tests that read it skip when it is absent.

use std::path::{Path, PathBuf};

/// The sample data root: `PL2MAP_SAMPLE_DATA` when set, else the default location that
/// README.md, "Tests", names, beside the workspace (whether or not it exists).
pub fn root() -> PathBuf {
    match std::env::var_os("PL2MAP_SAMPLE_DATA") {
        Some(dir) => PathBuf::from(dir),
        None => Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data"),
    }
}

/// The folder `sub` of the sample data (e.g. `colmap-maupertuis`, or
/// `7scenes-stairs-mini/stairs`), or None after printing `SKIPPED <test>: ...`
/// ([`crate::skip`]) when it is not a folder: the caller returns.
pub fn sample_data(sub: &str) -> Option<PathBuf> {
    let dir = root().join(sub);
    if dir.is_dir() {
        Some(dir)
    } else {
        crate::skip(format_args!(
            "sample data {} not found (set PL2MAP_SAMPLE_DATA; README.md, \"Tests\")",
            dir.display()
        ));
        None
    }
}
