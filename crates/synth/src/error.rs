use std::path::PathBuf;
use thiserror::Error;

/// Errors of the synthetic scene generator.
#[derive(Debug, Error)]
pub enum SynthError {
    #[error("the synthetic renderer needs a PINHOLE camera, got {0}")]
    UnsupportedCamera(String),
    #[error("camera size {width}x{height} is invalid for rendering (1..=16384 per side)")]
    InvalidCameraSize { width: u64, height: u64 },
    #[error("pose is not finite")]
    NonFinitePose,
    #[error("invalid synthetic configuration: {0}")]
    InvalidConfig(String),
    #[error(
        "sequence {sequence}: could not keep {clearance_m} m clearance from walls and objects (best {best_m:.3} m)"
    )]
    Trajectory {
        sequence: u32,
        clearance_m: f64,
        best_m: f64,
    },
    #[error("frame index {index} out of range (the dataset has {count} frames)")]
    FrameIndex { index: usize, count: usize },
    #[error("output {0} already exists (pass overwrite to replace it)")]
    OutputExists(PathBuf),
    /// `fileio::IoError` displays `<path>: <source>`: the message stays
    /// "I/O error on <path>: <source>".
    #[error("I/O error on {0}")]
    Io(#[from] fileio::IoError),
    #[error(transparent)]
    Stage(#[from] stage::StageError),
    #[error(
        "{}: {count} file(s) that no record of this stage names (first: {}): the scene is \
         rendered again into this folder; move them out, remove the folder, or replace \
         them with `pl2map synth --overwrite`",
        dir.display(),
        first.join(", ")
    )]
    Foreign {
        dir: PathBuf,
        count: usize,
        first: Vec<String>,
    },
    #[error("could not encode {path}: {source}")]
    Encode {
        path: PathBuf,
        #[source]
        source: image::ImageError,
    },
}

pub type Result<T, E = SynthError> = std::result::Result<T, E>;
