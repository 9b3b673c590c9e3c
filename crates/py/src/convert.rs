//! A shard frame as plain Python values: a dict of ints, strings, bytes and NumPy
//! arrays (the keys are listed in docs/formats.md section 6).

use geometry::Camera;
use nalgebra::Vector2;
use numpy::{PyArray1, PyArrayMethods};
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict};
use shards::{FrameRecord, ImageFormat};

/// A decoded image: 8-bit samples, row-major, `(height, width)` for grey images and
/// `(height, width, 3)` for colour ones.
pub struct Pixels {
    pub data: Vec<u8>,
    pub height: usize,
    pub width: usize,
    pub channels: usize,
}

/// Decodes the frame's image file (PNG or JPEG) with the `image` crate's default
/// limits. Grey stays grey; colour (with or without alpha) becomes RGB; 16-bit samples
/// are scaled to 8 bits.
pub fn decode_image(bytes: &[u8], format: ImageFormat) -> Result<Pixels, String> {
    let format = match format {
        ImageFormat::Png => image::ImageFormat::Png,
        ImageFormat::Jpeg => image::ImageFormat::Jpeg,
    };
    let mut reader = image::ImageReader::with_format(std::io::Cursor::new(bytes), format);
    reader.limits(image::Limits::default());
    let img = reader.decode().map_err(|e| e.to_string())?;
    let (width, height) = (img.width() as usize, img.height() as usize);
    Ok(if img.color().has_color() {
        Pixels {
            data: img.into_rgb8().into_raw(),
            height,
            width,
            channels: 3,
        }
    } else {
        Pixels {
            data: img.into_luma8().into_raw(),
            height,
            width,
            channels: 1,
        }
    })
}

/// Keypoints in normalised camera coordinates (`x/z`, `y/z`, the camera model's
/// distortion undone); NaN where the model cannot lift a keypoint.
fn normalised(camera: &Camera, keypoints: &[[f64; 2]]) -> Vec<[f64; 2]> {
    keypoints
        .iter()
        .map(|k| match camera.cam_from_img(&Vector2::new(k[0], k[1])) {
            Some(p) => [p.x, p.y],
            None => [f64::NAN; 2],
        })
        .collect()
}

fn array2<'py, const N: usize>(py: Python<'py>, rows: &[[f64; N]]) -> PyResult<Bound<'py, PyAny>> {
    Ok(PyArray1::from_slice(py, rows.as_flattened())
        .reshape([rows.len(), N])?
        .into_any())
}

/// The frame as a dict; `pixels` is the decoded image when the caller asked for it.
pub fn frame_dict<'py>(
    py: Python<'py>,
    f: &FrameRecord,
    pixels: Option<Pixels>,
) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("frame_id", f.frame_id)?;
    d.set_item("name", &f.name)?;
    d.set_item("split", f.split.as_str())?;
    d.set_item("image", PyBytes::new(py, &f.image_bytes))?;
    d.set_item("image_format", f.image_format.as_str())?;
    if let Some(p) = pixels {
        let shape: Vec<usize> = if p.channels == 1 {
            vec![p.height, p.width]
        } else {
            vec![p.height, p.width, p.channels]
        };
        d.set_item("pixels", PyArray1::from_vec(py, p.data).reshape(shape)?)?;
    }

    let camera = PyDict::new(py);
    camera.set_item("model", f.camera.model.name())?;
    camera.set_item("width", f.camera.width)?;
    camera.set_item("height", f.camera.height)?;
    camera.set_item("params", PyArray1::from_slice(py, &f.camera.params))?;
    let k = f.camera.calibration_matrix();
    let k_rows: Vec<[f64; 3]> = (0..3).map(|r| [k[(r, 0)], k[(r, 1)], k[(r, 2)]]).collect();
    camera.set_item("K", array2(py, &k_rows)?)?;
    d.set_item("camera", camera)?;

    let pose = PyDict::new(py);
    pose.set_item("qvec", PyArray1::from_slice(py, &f.pose.qvec()))?;
    pose.set_item("tvec", PyArray1::from_slice(py, &f.pose.tvec()))?;
    let r = f.pose.rotation_matrix();
    let r_rows: Vec<[f64; 3]> = (0..3).map(|i| [r[(i, 0)], r[(i, 1)], r[(i, 2)]]).collect();
    pose.set_item("R", array2(py, &r_rows)?)?;
    d.set_item("pose", pose)?;

    d.set_item("keypoints", array2(py, &f.keypoints)?)?;
    d.set_item(
        "keypoints_normalized",
        array2(py, &normalised(&f.camera, &f.keypoints))?,
    )?;
    d.set_item("point3d_ids", PyArray1::from_slice(py, &f.point3d_ids))?;
    d.set_item("points3d", array2(py, &f.points3d)?)?;
    d.set_item("point_valid", PyArray1::from_slice(py, &f.point_valid))?;
    d.set_item("segments", array2(py, &f.segments)?)?;
    d.set_item("track_ids", PyArray1::from_slice(py, &f.track_ids))?;
    d.set_item("lines3d", array2(py, &f.lines3d)?)?;
    d.set_item("line_valid", PyArray1::from_slice(py, &f.line_valid))?;
    d.set_item("label_source", f.label_source.as_str())?;
    d.set_item("endpoints_aligned", f.endpoints_aligned)?;
    Ok(d)
}
