//! Grey images as floats in [0, 1] and their area-interpolated resize (OpenCV's
//! `INTER_AREA`), the input of a learned front-end (docs/method.md section 2b).

use crate::error::{CvContext, FeatureError};
use image::GrayImage;
use opencv::core::{Mat, MatTraitConst, MatTraitConstManual, Size};

/// The image as row-major floats in [0, 1] (value / 255).
pub fn gray_f32(img: &GrayImage) -> Vec<f32> {
    img.as_raw().iter().map(|&v| f32::from(v) / 255.0).collect()
}

/// Resizes a row-major float image of `width` x `height` to `new_width` x `new_height`
/// with OpenCV's area interpolation (pixel-area averaging when shrinking), in single
/// precision. The result does not depend on the thread count (OpenCV runs
/// single-threaded here, as everywhere in this crate).
pub fn resize_area(
    pixels: &[f32],
    width: usize,
    height: usize,
    new_width: usize,
    new_height: usize,
) -> Result<Vec<f32>, FeatureError> {
    crate::sift::single_threaded_opencv();
    let too_big = |v: usize| v == 0 || v > i32::MAX as usize;
    if too_big(width) || too_big(height) || too_big(new_width) || too_big(new_height) {
        return Err(FeatureError::ImageSize {
            width: width.min(u32::MAX as usize) as u32,
            height: height.min(u32::MAX as usize) as u32,
        });
    }
    if pixels.len() != width * height {
        return Err(FeatureError::Config(format!(
            "resize: {} pixels for a {width}x{height} image",
            pixels.len()
        )));
    }
    let src = Mat::new_rows_cols_with_data(height as i32, width as i32, pixels).cv("wrap image")?;
    let mut dst = Mat::default();
    opencv::imgproc::resize(
        &src,
        &mut dst,
        Size::new(new_width as i32, new_height as i32),
        0.0,
        0.0,
        opencv::imgproc::INTER_AREA,
    )
    .cv("resize")?;
    let data = dst.data_typed::<f32>().cv("resized data")?;
    debug_assert_eq!(dst.cols() as usize, new_width);
    Ok(data.to_vec())
}
