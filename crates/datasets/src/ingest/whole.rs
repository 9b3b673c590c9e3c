//! Reading an image file whole: its structure walked to the end, then every pixel
//! decoded. Decoders fill in a JPEG cut short and may stop early in a PNG, so decoding
//! alone would let a truncated download through (docs/errors.md).

use super::error::{IngestError, Result};
use image::DynamicImage;
use std::path::Path;

/// The decoded image, or [`IngestError::DamagedImage`] naming the file and what is
/// wrong (truncated at which byte, a failed chunk checksum, a decoder error).
pub(super) fn decode_whole(path: &Path) -> Result<DynamicImage> {
    let bytes = std::fs::read(path).map_err(fileio::io_err(path))?;
    let damaged = |reason: String| IngestError::DamagedImage {
        path: path.to_path_buf(),
        reason,
    };
    tables::image_file::check_complete(&bytes).map_err(damaged)?;
    image::load_from_memory(&bytes).map_err(|e| damaged(format!("the image does not decode: {e}")))
}
