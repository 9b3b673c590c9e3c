//! Reading an image file whole: read within bounds, its structure walked to the end, then
//! every pixel decoded. Decoders fill in a JPEG cut short and may stop early in a PNG, so
//! decoding alone would let a truncated download through (docs/errors.md).

use super::error::{IngestError, Result};
use image::DynamicImage;
use std::path::Path;

/// The decoded image, or [`IngestError::DamagedImage`] naming the file and what is
/// wrong (truncated at which byte, a failed chunk checksum, a decoder error). A path that
/// is not a regular file, or an image over the pixel limit, is refused as such (the
/// file's own error, not a damaged download), before the file is read
/// (`fileio::image::read_image`).
pub(super) fn decode_whole(path: &Path) -> Result<DynamicImage> {
    let damaged = |reason: String| IngestError::DamagedImage {
        path: path.to_path_buf(),
        reason,
    };
    let bytes = fileio::image::read_image(path).map_err(|e| match e.kind() {
        std::io::ErrorKind::InvalidData => damaged(e.source.to_string()),
        _ => IngestError::Io(e),
    })?;
    tables::image_file::check_complete(&bytes).map_err(damaged)?;
    let mut reader = image::ImageReader::new(std::io::Cursor::new(&bytes))
        .with_guessed_format()
        .map_err(fileio::io_err(path))?;
    // The pixel limit was checked on the header; the image crate's own allocation limit
    // (512 MiB) would otherwise refuse an image under a raised PL2MAP_MAX_IMAGE_PIXELS as
    // a decoding error.
    reader.no_limits();
    reader.decode().map_err(|e| {
        damaged(format!(
            "the image does not decode: {}",
            fileio::image::printable(e.to_string().as_bytes())
        ))
    })
}
