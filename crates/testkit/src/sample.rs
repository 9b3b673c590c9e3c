//! The real sample data (README.md, "Tests"): the folder `PL2MAP_SAMPLE_DATA` names.
//! Cargo sets it for its commands to the default location the README names
//! (`.cargo/config.toml`) unless the user set it. Tests that read it skip when it is absent.

use std::path::PathBuf;

/// The sample data root, `PL2MAP_SAMPLE_DATA` (whether or not the folder exists); None
/// when the variable is unset (a test binary run outside cargo).
pub fn root() -> Option<PathBuf> {
    std::env::var_os("PL2MAP_SAMPLE_DATA").map(PathBuf::from)
}

/// The folder `sub` of the sample data (e.g. `colmap-maupertuis`, or
/// `7scenes-stairs-mini/stairs`), or None after printing `SKIPPED <test>: ...`
/// ([`crate::skip`]) when it is not a folder: the caller returns.
pub fn sample_data(sub: &str) -> Option<PathBuf> {
    let Some(root) = root() else {
        crate::skip(format_args!(
            "sample data {sub}: PL2MAP_SAMPLE_DATA is unset (README.md, \"Tests\")"
        ));
        return None;
    };
    let dir = root.join(sub);
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
