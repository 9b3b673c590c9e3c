//! The one IO error of the workspace: an [`std::io::Error`] together with the path it
//! happened on, so that every message names the file (ARCHITECTURE.md, "The rules every
//! crate follows").
//!
//! Each crate's error enum holds it as one variant,
//! `#[error(transparent)] Io(#[from] fileio::IoError)`, and turns an `io::Result` into it
//! with [`io_err`] (`.map_err(io_err(&path))?`) or [`IoResultExt::at`]
//! (`fs::read(&path).at(&path)?`).
//!
//! [`image`] reads image files within bounds (the header first, the pixel limit, no
//! device or FIFO): every crate that reads a PNG or JPEG from disk goes through it.

#![forbid(unsafe_code)]

pub mod image;

use std::path::{Path, PathBuf};

/// An IO error on a path. Displays as `<path>: <error>`.
#[derive(Debug, thiserror::Error)]
#[error("{}: {source}", path.display())]
pub struct IoError {
    /// The file or folder the operation was on.
    pub path: PathBuf,
    /// What the operating system said.
    #[source]
    pub source: std::io::Error,
}

impl IoError {
    pub fn new(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        IoError {
            path: path.into(),
            source,
        }
    }

    /// The operating system's error kind.
    pub fn kind(&self) -> std::io::ErrorKind {
        self.source.kind()
    }
}

/// A `map_err` adapter: `.map_err(io_err(&path))`.
pub fn io_err(path: impl Into<PathBuf>) -> impl FnOnce(std::io::Error) -> IoError {
    let path = path.into();
    move |source| IoError { path, source }
}

/// `io::Result` -> `Result<_, IoError>` with the path named.
pub trait IoResultExt<T> {
    fn at(self, path: impl AsRef<Path>) -> Result<T, IoError>;
}

impl<T> IoResultExt<T> for std::io::Result<T> {
    fn at(self, path: impl AsRef<Path>) -> Result<T, IoError> {
        self.map_err(|source| IoError::new(path.as_ref(), source))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_the_path_and_keeps_the_kind() {
        let missing = Path::new("/nonexistent/pl2map-fileio-test");
        let err = std::fs::read(missing).at(missing).unwrap_err();
        assert_eq!(err.kind(), std::io::ErrorKind::NotFound);
        let text = err.to_string();
        assert!(
            text.starts_with("/nonexistent/pl2map-fileio-test: "),
            "{text}"
        );
        let via_map = std::fs::read(missing).map_err(io_err(missing)).unwrap_err();
        assert_eq!(via_map.to_string(), text);
        assert!(std::error::Error::source(&err).is_some());
    }
}
