use thiserror::Error;

/// Errors of the model crate. Input problems name the field and the element index.
#[derive(Debug, Error)]
pub enum ModelError {
    #[error("invalid model configuration: {0}")]
    InvalidConfig(String),
    #[error("invalid loss configuration: {0}")]
    InvalidLossConfig(String),
    #[error("sample field `{field}`: expected {expected} values, found {found}")]
    Length {
        field: &'static str,
        expected: usize,
        found: usize,
    },
    #[error("sample field `{field}`: value at element {index} is not finite")]
    NonFinite { field: &'static str, index: usize },
    #[error("sample intrinsics: {0}")]
    Intrinsics(String),
    #[error("sample pose: {0}")]
    Pose(String),
    #[error("sample has {found} {what}, more than the limit of {limit}")]
    TooMany {
        what: &'static str,
        found: usize,
        limit: usize,
    },
    #[error("{0}")]
    DeviceUnavailable(String),
}
