use std::path::{Path, PathBuf};
use thiserror::Error;

#[derive(Debug, Error)]
pub enum SuperPointError {
    /// The weights file: missing, unreadable, a missing key or a wrong shape.
    #[error("{}{}: {reason}", path.display(), key.as_ref().map(|k| format!(", key {k}")).unwrap_or_default())]
    Weights {
        path: PathBuf,
        key: Option<String>,
        reason: String,
    },
    /// No weights file was named anywhere.
    #[error(
        "the superpoint front-end needs its weights file: set [features] superpoint_weights \
         in the pipeline file, pass --weights FILE or set {env} (README.md, \"SuperPoint \
         weights\")",
        env = features::SUPERPOINT_WEIGHTS_ENV
    )]
    NoWeights,
    /// The weights file is not the one a checkpoint was trained with.
    #[error(
        "{}: sha256 {found}, but the model was trained with SuperPoint weights of sha256 \
         {expected}: use that file",
        path.display()
    )]
    WeightsMismatch {
        path: PathBuf,
        expected: String,
        found: String,
    },
    /// A GPU asked of a build without the `cuda` feature (callers refuse such a device
    /// earlier, with the build command: `model::Device::check_built`).
    #[error("SuperPoint on cuda:{0}: this build has no CUDA backend (the `cuda` feature)")]
    NoCuda(usize),
    /// A file that cannot be read (the weights file, while hashing it).
    #[error(transparent)]
    Io(#[from] fileio::IoError),
    #[error(transparent)]
    Features(#[from] features::FeatureError),
}

impl SuperPointError {
    pub(crate) fn weights(path: &Path, key: Option<&str>, reason: impl ToString) -> Self {
        SuperPointError::Weights {
            path: path.to_path_buf(),
            key: key.map(str::to_string),
            reason: reason.to_string(),
        }
    }
}

impl From<SuperPointError> for features::FeatureError {
    fn from(e: SuperPointError) -> Self {
        match e {
            SuperPointError::Features(f) => f,
            other => features::FeatureError::FrontEnd(other.to_string()),
        }
    }
}
