use thiserror::Error;

/// Errors of the geometry crate. They describe *what* is wrong with a value; the
/// callers (file parsers) add *where* it came from (file, line, record).
#[derive(Debug, Error, Clone, PartialEq)]
pub enum GeometryError {
    #[error("unknown camera model id {0} (COLMAP knows ids 0-17)")]
    UnknownModelId(i64),
    #[error("unknown camera model name {0:?}")]
    UnknownModelName(String),
    #[error("camera model {model} takes {expected} parameters, got {got}")]
    ParamCount {
        model: &'static str,
        expected: usize,
        got: usize,
    },
    #[error("camera parameter {index} ({name}) is not finite: {value}")]
    NonFiniteParam {
        index: usize,
        name: &'static str,
        value: f64,
    },
    #[error("camera size {width}x{height} is invalid: width and height must be positive")]
    InvalidSize { width: u64, height: u64 },
    #[error("{what} {name} = {value} must be positive and finite")]
    NonPositiveParam {
        what: &'static str,
        name: &'static str,
        value: f64,
    },
    #[error(
        "principal point {name} = {value} lies more than an image size outside the \
         {width}x{height} image (expected {low} <= {name} <= {high})"
    )]
    PrincipalPointOutside {
        name: &'static str,
        value: f64,
        width: u64,
        height: u64,
        low: f64,
        high: f64,
    },
    #[error("non-finite value in {what}")]
    NonFinite { what: &'static str },
    #[error("quaternion has norm {norm}, expected 1 (tolerance {tolerance})")]
    QuaternionNorm { norm: f64, tolerance: f64 },
    #[error(
        "rotation is not orthonormal: max |R^T R - I| = {deviation:.3e} (tolerance {tolerance:.1e}), det = {det}"
    )]
    NotOrthonormal {
        deviation: f64,
        det: f64,
        tolerance: f64,
    },
    #[error("last row of a rigid 4x4 transform must be [0 0 0 1], got {0:?}")]
    NotRigid([f64; 4]),
    #[error("scale factor must be finite and > 0, got {0}")]
    InvalidScale(f64),
}
