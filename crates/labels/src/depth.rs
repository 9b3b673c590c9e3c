//! Depth maps for refinement: 16-bit single-channel images of z-depth along the camera's
//! optical axis, `units_per_metre` units per metre (1000 for the millimetres of
//! 7-Scenes). 0 and 65535 mean "no depth", and so does anything beyond `max_depth_m`
//! (upstream: 1000 m).
//!
//! Sampling follows COLMAP pixels: pixel (i, j) covers [i, i+1) x [j, j+1) and its value
//! sits at its centre (i + 0.5, j + 0.5). A position is sampled bilinearly from the four
//! pixel centres around it when all four are valid, else from the pixel that contains it
//! (nearest neighbour) when that one is valid: this keeps the most positions with depth
//! without ever mixing an invalid value in.

use geometry::{Camera, Pose, Vector2, Vector3};
use image::DynamicImage;
use std::path::{Path, PathBuf};
use thiserror::Error;

pub const INVALID_DEPTH_MAX: u16 = u16::MAX;

#[derive(Debug, Error)]
pub enum DepthError {
    #[error("{path}: cannot read the depth map: {source}")]
    Read {
        path: PathBuf,
        #[source]
        source: image::ImageError,
    },
    #[error("{path}: expected a 16-bit single-channel depth map, got {color:?}")]
    Format {
        path: PathBuf,
        color: image::ColorType,
    },
    #[error(
        "{path}: depth map is {width}x{height}, but the image of frame {frame_id} ({name}) is \
         {expected_width}x{expected_height}"
    )]
    Size {
        path: PathBuf,
        frame_id: u32,
        name: String,
        width: u32,
        height: u32,
        expected_width: u64,
        expected_height: u64,
    },
    #[error("depth units per metre must be positive and finite, got {0}")]
    Units(f64),
}

#[derive(Clone, Debug)]
pub struct DepthMap {
    width: u32,
    height: u32,
    data: Vec<u16>,
    metres_per_unit: f64,
    max_depth_m: f64,
}

impl DepthMap {
    /// A depth map from raw values, row-major.
    pub fn from_raw(
        width: u32,
        height: u32,
        data: Vec<u16>,
        units_per_metre: f64,
        max_depth_m: f64,
    ) -> Result<DepthMap, DepthError> {
        if !(units_per_metre.is_finite() && units_per_metre > 0.0) {
            return Err(DepthError::Units(units_per_metre));
        }
        debug_assert_eq!(data.len(), width as usize * height as usize);
        Ok(DepthMap {
            width,
            height,
            data,
            metres_per_unit: 1.0 / units_per_metre,
            max_depth_m,
        })
    }

    /// Reads a 16-bit PNG (or any 16-bit single-channel format the image crate reads).
    pub fn read(
        path: &Path,
        units_per_metre: f64,
        max_depth_m: f64,
    ) -> Result<DepthMap, DepthError> {
        let read_err = |source| DepthError::Read {
            path: path.to_path_buf(),
            source,
        };
        // `load_from_memory` (the format from the bytes) rather than `image::open`,
        // which is generic over its reader and so compiled every decoder again here.
        // Within bounds (no device or FIFO, the pixel limit checked on the header first):
        // crates/fileio/src/image.rs.
        let bytes = fileio::image::read_image(path)
            .map_err(|e| read_err(image::ImageError::IoError(e.source)))?;
        let img = image::load_from_memory(&bytes).map_err(read_err)?;
        match img {
            DynamicImage::ImageLuma16(d) => {
                let (w, h) = d.dimensions();
                Self::from_raw(w, h, d.into_raw(), units_per_metre, max_depth_m)
            }
            other => Err(DepthError::Format {
                path: path.to_path_buf(),
                color: other.color(),
            }),
        }
    }

    pub fn width(&self) -> u32 {
        self.width
    }

    pub fn height(&self) -> u32 {
        self.height
    }

    /// Depth of pixel (i, j) in metres, None when invalid or outside.
    pub fn pixel(&self, i: i64, j: i64) -> Option<f64> {
        if i < 0 || j < 0 || i >= i64::from(self.width) || j >= i64::from(self.height) {
            return None;
        }
        let raw = self.data[j as usize * self.width as usize + i as usize];
        if raw == 0 || raw == INVALID_DEPTH_MAX {
            return None;
        }
        let d = f64::from(raw) * self.metres_per_unit;
        (d <= self.max_depth_m).then_some(d)
    }

    /// Depth at a position in COLMAP pixels: bilinear, else nearest, else None.
    pub fn sample(&self, px: &Vector2<f64>) -> Option<f64> {
        if !(px.x >= 0.0 && px.y >= 0.0 && px.x < self.width as f64 && px.y < self.height as f64) {
            return None;
        }
        let u = px.x - 0.5;
        let v = px.y - 0.5;
        let (i0, j0) = (u.floor() as i64, v.floor() as i64);
        let (a, b) = (u - i0 as f64, v - j0 as f64);
        let corners = (
            self.pixel(i0, j0),
            self.pixel(i0 + 1, j0),
            self.pixel(i0, j0 + 1),
            self.pixel(i0 + 1, j0 + 1),
        );
        if let (Some(d00), Some(d10), Some(d01), Some(d11)) = corners {
            return Some((1.0 - b) * ((1.0 - a) * d00 + a * d10) + b * ((1.0 - a) * d01 + a * d11));
        }
        self.pixel(px.x.floor() as i64, px.y.floor() as i64)
    }
}

/// The world point seen at pixel `px` at z-depth `depth` (metres) by a camera with
/// world-to-camera pose `pose`. None when the camera cannot lift the pixel.
pub fn back_project(
    camera: &Camera,
    pose: &Pose,
    px: &Vector2<f64>,
    depth: f64,
) -> Option<Vector3<f64>> {
    let ray = camera.unproject(px)?;
    if !(ray.z > 0.0) {
        return None;
    }
    let p_cam = ray * (depth / ray.z);
    Some(pose.inverse().transform_point(&p_cam))
}

#[cfg(test)]
mod tests {
    use super::*;
    use geometry::CameraModel;

    fn map(w: u32, h: u32, f: impl Fn(u32, u32) -> u16) -> DepthMap {
        let data = (0..h)
            .flat_map(|j| (0..w).map(move |i| (i, j)))
            .map(|(i, j)| f(i, j))
            .collect();
        DepthMap::from_raw(w, h, data, 1000.0, 1000.0).unwrap()
    }

    #[test]
    fn bilinear_between_centres_and_exact_at_centres() {
        // Depth (mm) = 1000 + 10 i + 100 j: bilinear is exact on a linear ramp.
        let d = map(4, 3, |i, j| (1000 + 10 * i + 100 * j) as u16);
        assert_eq!(d.sample(&Vector2::new(0.5, 0.5)), Some(1.0));
        assert_eq!(d.sample(&Vector2::new(2.5, 1.5)), Some(1.12));
        let v = d.sample(&Vector2::new(1.75, 1.0)).unwrap();
        // u = 1.25, v = 0.5 in centre coordinates: 1000 + 12.5 + 50 mm.
        assert!((v - 1.0625).abs() < 1e-12, "{v}");
        // Outside the image: nothing.
        assert_eq!(d.sample(&Vector2::new(-0.1, 1.0)), None);
        assert_eq!(d.sample(&Vector2::new(4.0, 1.0)), None);
    }

    #[test]
    fn invalid_neighbours_fall_back_to_the_containing_pixel() {
        // Pixel (1, 1) is invalid (0), (2, 1) is 65535, the rest 2000 mm.
        let d = map(4, 3, |i, j| match (i, j) {
            (1, 1) => 0,
            (2, 1) => u16::MAX,
            _ => 2000,
        });
        // Between centres of (0,0),(1,0),(0,1),(1,1): one invalid -> nearest = pixel (0, 0).
        assert_eq!(d.sample(&Vector2::new(0.9, 0.9)), Some(2.0));
        // Containing pixel is the invalid one: None.
        assert_eq!(d.sample(&Vector2::new(1.2, 1.2)), None);
        assert_eq!(d.sample(&Vector2::new(2.7, 1.9)), None);
        // Border: fewer than four neighbours -> nearest.
        assert_eq!(d.sample(&Vector2::new(0.2, 0.2)), Some(2.0));
        // Depth beyond max_depth_m is invalid.
        let far = DepthMap::from_raw(1, 1, vec![5000], 1000.0, 4.0).unwrap();
        assert_eq!(far.pixel(0, 0), None);
        assert!(DepthMap::from_raw(1, 1, vec![1], 0.0, 4.0).is_err());
    }

    #[test]
    fn back_projection_inverts_projection() {
        let cam = Camera::new(
            CameraModel::SimpleRadial,
            640,
            480,
            vec![500.0, 320.0, 240.0, 0.05],
        )
        .unwrap();
        let pose = Pose::new(
            geometry::UnitQuaternion::from_euler_angles(0.2, -0.1, 0.4),
            Vector3::new(0.3, -0.2, 1.0),
        );
        let x = Vector3::new(0.5, 0.7, 2.0);
        let pc = pose.transform_point(&x);
        let px = cam.project(&pc).unwrap();
        let back = back_project(&cam, &pose, &px, pc.z).unwrap();
        assert!((back - x).norm() < 1e-9, "{back} vs {x}");
    }
}
