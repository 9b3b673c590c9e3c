use std::path::PathBuf;
use thiserror::Error;

#[derive(Debug, Error)]
pub enum PipelineError {
    #[error(transparent)]
    Io(#[from] fileio::IoError),
    /// A TOML syntax or schema error; toml's message already names line and column.
    #[error("{}: {message}", path.display())]
    Toml { path: PathBuf, message: String },
    /// A value that parsed but is not acceptable (unset variable, bad option).
    #[error("{}:{line}:{column}: {key}: {message}", path.display())]
    Value {
        path: PathBuf,
        line: usize,
        column: usize,
        key: String,
        message: String,
    },
    /// Sections that do not go together (e.g. `[synth]` and a dataset root).
    #[error("{}: {message}", path.display())]
    Config { path: PathBuf, message: String },
    #[error("stage {stage}: {message}")]
    Stage {
        stage: &'static str,
        message: String,
    },
    #[error(transparent)]
    Record(#[from] stage::StageError),
    #[error("{}: verification failed, {count} difference(s): {}", manifest.display(), differences.join("; "))]
    Verify {
        manifest: PathBuf,
        count: usize,
        differences: Vec<String>,
    },
}

pub type Result<T, E = PipelineError> = std::result::Result<T, E>;

/// A stage's own error, kept with its full cause chain (the stage errors name their
/// files already).
pub(crate) fn stage_err(
    stage: &'static str,
) -> impl FnOnce(&dyn std::error::Error) -> PipelineError {
    move |e| {
        let mut message = e.to_string();
        let mut source = e.source();
        while let Some(s) = source {
            let text = s.to_string();
            if !message.contains(&text) {
                message.push_str(": ");
                message.push_str(&text);
            }
            source = s.source();
        }
        PipelineError::Stage { stage, message }
    }
}
