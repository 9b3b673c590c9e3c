use std::path::PathBuf;
use thiserror::Error;

#[derive(Debug, Error)]
pub enum FeatureError {
    #[error("OpenCV {what}: {source}")]
    OpenCv {
        what: &'static str,
        #[source]
        source: opencv::Error,
    },
    /// An image file that cannot be read.
    #[error("{}: cannot read image: {}", .0.path.display(), .0.source)]
    ReadImage(fileio::IoError),
    /// An image file whose bytes cannot be decoded.
    #[error("{path}: cannot read image: {reason}")]
    Image { path: PathBuf, reason: String },
    /// Image bytes that OpenCV's decoder refuses (the caller names the file or frame).
    #[error("cannot decode the image: {0}")]
    Decode(String),
    /// An image over the pixel limit (`fileio::image::max_image_pixels`), or an
    /// unreadable limit setting: refused before decoding.
    #[error("{0}")]
    Limit(String),
    #[error("image {width}x{height} is too large or empty for OpenCV")]
    ImageSize { width: u32, height: u32 },
    #[error("OpenCV returned {got} descriptors for {expected} positions")]
    DescriptorCount { expected: usize, got: usize },
    #[error("LSD: {0}")]
    Lsd(String),
    #[error("invalid front-end configuration: {0}")]
    Config(String),
    /// A front-end outside this crate (SuperPoint's network) failed.
    #[error("{0}")]
    FrontEnd(String),
}

pub(crate) trait CvContext<T> {
    fn cv(self, what: &'static str) -> Result<T, FeatureError>;
}

impl<T> CvContext<T> for opencv::Result<T> {
    fn cv(self, what: &'static str) -> Result<T, FeatureError> {
        self.map_err(|source| FeatureError::OpenCv { what, source })
    }
}
