//! Image and coordinate conversions at the OpenCV boundary.
//!
//! OpenCV puts pixel centres at integer coordinates; COLMAP (and this project) at
//! +0.5. The conversion happens here and nowhere else.

use crate::error::{CvContext, FeatureError};
use image::{GrayImage, RgbImage};
use opencv::boxed_ref::BoxedRef;
use opencv::core::{CV_8UC1, Mat, MatTraitConst, MatTraitConstManual};
use opencv::imgcodecs;
use std::path::Path;

/// OpenCV pixel coordinate -> COLMAP pixel coordinate.
#[inline]
pub(crate) fn from_cv(v: f32) -> f64 {
    v as f64 + 0.5
}

/// COLMAP pixel coordinate -> OpenCV pixel coordinate.
#[inline]
pub(crate) fn to_cv(v: f64) -> f32 {
    (v - 0.5) as f32
}

/// A borrowed 8-bit single-channel Mat over the image buffer (no copy).
pub(crate) fn mat_view(img: &GrayImage) -> Result<BoxedRef<'_, Mat>, FeatureError> {
    let (w, h) = img.dimensions();
    if w == 0 || h == 0 || w > i32::MAX as u32 || h > i32::MAX as u32 {
        return Err(FeatureError::ImageSize {
            width: w,
            height: h,
        });
    }
    let m = Mat::new_rows_cols_with_data(h as i32, w as i32, img.as_raw().as_slice())
        .cv("wrap image")?;
    debug_assert_eq!(m.cols(), w as i32);
    Ok(m)
}

/// Decodes a PNG or JPEG file's bytes to 8-bit grey exactly as OpenCV's grey reader does
/// (`cv::imdecode` / `cv::imread` with `IMREAD_GRAYSCALE`), the way the reference
/// implementation and hloc read their images (docs/method.md section 2b, "Grey images"):
/// for a JPEG, libjpeg's own luma channel; for a colour PNG, libpng's ITU-R BT.601
/// conversion. The `image` crate's `to_luma8` weights the channels as BT.709 and differs
/// on about half the pixels of a real colour frame, so no grey path of this project uses it.
///
/// The header is read first and an image over the pixel limit
/// (`fileio::image::max_image_pixels`) is refused before OpenCV allocates anything:
/// shards carry the image files' bytes, and a header can ask for gigabytes. Bytes that
/// are neither a PNG nor a JPEG header are refused too. The rest is not checked for
/// completeness here (a JPEG cut short decodes with its missing part filled in): callers
/// that read files a user gave read them with [`crate::image_file::read_image`] and
/// check them with `tables::image_file::check_complete`.
pub fn decode_gray(bytes: &[u8]) -> Result<GrayImage, FeatureError> {
    if bytes.is_empty() {
        return Err(FeatureError::Decode("the file is empty".into()));
    }
    fileio::image::check_bytes(bytes).map_err(|e| match e.kind() {
        std::io::ErrorKind::InvalidData => FeatureError::Decode(e.to_string()),
        _ => FeatureError::Limit(e.to_string()),
    })?;
    let buf = Mat::from_slice(bytes).cv("wrap the file's bytes")?;
    let mat = imgcodecs::imdecode(&buf, imgcodecs::IMREAD_GRAYSCALE).cv("decode an image")?;
    if mat.empty() {
        return Err(FeatureError::Decode(
            "OpenCV cannot decode it as an image".into(),
        ));
    }
    if mat.typ() != CV_8UC1 || !mat.is_continuous() {
        return Err(FeatureError::Decode(format!(
            "OpenCV decoded it to a matrix of type {} instead of 8-bit grey",
            mat.typ()
        )));
    }
    let (w, h) = (mat.cols() as u32, mat.rows() as u32);
    let data = mat.data_bytes().cv("read the decoded pixels")?.to_vec();
    GrayImage::from_raw(w, h, data).ok_or_else(|| {
        FeatureError::Decode(format!("OpenCV returned a {w}x{h} image of the wrong size"))
    })
}

/// Reads an image file (PNG or JPEG) as 8-bit grey, as [`decode_gray`] does. The file is
/// read within bounds (`fileio::image::read_image`: no device or FIFO, the header and
/// the pixel limit first, no more bytes than the header's image can take).
pub fn load_gray(path: &Path) -> Result<GrayImage, FeatureError> {
    let bytes = fileio::image::read_image(path).map_err(FeatureError::ReadImage)?;
    decode_gray(&bytes).map_err(|e| FeatureError::Image {
        path: path.to_path_buf(),
        reason: match e {
            FeatureError::Decode(reason) => reason,
            e => e.to_string(),
        },
    })
}

/// The grey image OpenCV's grey reader gives for a PNG file of this RGB image (see
/// [`decode_gray`]): libpng's RGB-to-grey with the BT.601 weights 0.299 / 0.587 / 0.114
/// in 15-bit fixed point. The synthetic scene's ground truth detects its features on
/// this image, so that they are the ones a query's front-end finds in the written PNG
/// (a test checks the two are byte-identical).
pub fn gray_from_rgb(img: &RgbImage) -> GrayImage {
    let (w, h) = img.dimensions();
    let data = img
        .as_raw()
        .chunks_exact(3)
        .map(|p| png_luma(p[0], p[1], p[2]))
        .collect();
    GrayImage::from_raw(w, h, data).expect("one grey value per RGB pixel")
}

/// libpng's `png_do_rgb_to_gray` for 8-bit samples without gamma correction, with the
/// weights OpenCV sets (`png_set_rgb_to_gray(.., 0.299, 0.587)`): each weight in units
/// of 1/32768, truncated as libpng does, blue the remainder, and the sum truncated too
/// (libpng's "historical approach"); a grey pixel keeps its value.
#[inline]
fn png_luma(r: u8, g: u8, b: u8) -> u8 {
    const RC: u32 = 29_900 * 32_768 / 100_000;
    const GC: u32 = 58_700 * 32_768 / 100_000;
    const BC: u32 = 32_768 - RC - GC;
    if r == g && g == b {
        return r;
    }
    ((RC * r as u32 + GC * g as u32 + BC * b as u32) >> 15) as u8
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_unreadable_image_file_is_named() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("missing.png");
        let e = load_gray(&path).unwrap_err();
        assert!(matches!(e, FeatureError::ReadImage(_)), "{e:?}");
        let text = e.to_string();
        let expected = format!("{}: cannot read image: ", path.display());
        assert!(text.starts_with(&expected), "{text}");
    }
}
