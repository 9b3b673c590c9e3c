//! Image and coordinate conversions at the OpenCV boundary.
//!
//! OpenCV puts pixel centres at integer coordinates; COLMAP (and this project) at
//! +0.5. The conversion happens here and nowhere else.

use crate::error::{CvContext, FeatureError};
use image::{GrayImage, RgbImage};
use opencv::boxed_ref::BoxedRef;
use opencv::core::{Mat, MatTraitConst};
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

/// Luma of an RGB image (ITU-R 601 weights, as OpenCV's cvtColor and `image`'s
/// `to_luma8` use), so grey values agree whatever decoded the file.
pub fn gray_from_rgb(img: &RgbImage) -> GrayImage {
    image::DynamicImage::ImageRgb8(img.clone()).to_luma8()
}

/// Reads an image file (PNG or JPEG) as 8-bit grey.
pub fn load_gray(path: &Path) -> Result<GrayImage, FeatureError> {
    image::open(path)
        .map(|i| i.to_luma8())
        .map_err(|source| FeatureError::Image {
            path: path.to_path_buf(),
            source,
        })
}
