//! Cameras of every COLMAP model (ids 0-17), following COLMAP's sensor/models.h:
//! parameter layout, projection (camera frame -> pixel, with distortion) and lifting
//! (pixel -> ray, iterative undistortion with a convergence check).

mod camera_model;
mod models;

pub use camera_model::CameraModel;

use crate::error::GeometryError;
use nalgebra::{Matrix3, Vector2, Vector3};
use serde::{Deserialize, Serialize};

/// A camera: model, image size in pixels and parameters in COLMAP order.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Camera {
    pub model: CameraModel,
    pub width: u64,
    pub height: u64,
    pub params: Vec<f64>,
}

impl Camera {
    /// Checked constructor: the camera must pass [`Camera::validate`]. Every reader of a
    /// camera (COLMAP models, the frames and label tables, query lists, `--camera`) builds
    /// it here, so an impossible camera is refused where it is read, with the reader's
    /// file and place around the message.
    pub fn new(
        model: CameraModel,
        width: u64,
        height: u64,
        params: Vec<f64>,
    ) -> Result<Self, GeometryError> {
        let cam = Camera {
            model,
            width,
            height,
            params,
        };
        cam.validate()?;
        Ok(cam)
    }

    /// Checks that the camera can exist: the parameter count of its model, every
    /// parameter finite, a positive size, positive focal lengths (for EQUIRECTANGULAR,
    /// positive `w` and `h`), and a principal point no further outside the image than
    /// the image's own size. A negative focal length images the scene turned 180 degrees
    /// about the optical axis and a focal length of 0 images nothing; a principal point
    /// a million pixels away puts every pixel far off the axis: poses estimated with
    /// such a camera are wrong without any sign of it, so they are refused here.
    pub fn validate(&self) -> Result<(), GeometryError> {
        let expected = self.model.num_params();
        if self.params.len() != expected {
            return Err(GeometryError::ParamCount {
                model: self.model.name(),
                expected,
                got: self.params.len(),
            });
        }
        let names = self.model.param_names();
        for (index, &value) in self.params.iter().enumerate() {
            if !value.is_finite() {
                return Err(GeometryError::NonFiniteParam {
                    index,
                    name: names[index],
                    value,
                });
            }
        }
        if self.width == 0 || self.height == 0 {
            return Err(GeometryError::InvalidSize {
                width: self.width,
                height: self.height,
            });
        }
        let (what, positive): (&'static str, &[usize]) = if self.model.is_perspective() {
            ("focal length", self.model.focal_length_idxs())
        } else {
            ("sphere size", &[0, 1])
        };
        for &i in positive {
            let value = self.params[i];
            if value <= 0.0 {
                return Err(GeometryError::NonPositiveParam {
                    what,
                    name: names[i],
                    value,
                });
            }
        }
        let sizes = [self.width, self.height];
        for (&i, size) in self.model.principal_point_idxs().iter().zip(sizes) {
            let value = self.params[i];
            let s = size as f64;
            if !(-s..=2.0 * s).contains(&value) {
                return Err(GeometryError::PrincipalPointOutside {
                    name: names[i],
                    value,
                    width: self.width,
                    height: self.height,
                    low: -s,
                    high: 2.0 * s,
                });
            }
        }
        Ok(())
    }

    /// Mean focal length in pixels (fx, fy averaged; f for single-focal models).
    /// For EQUIRECTANGULAR, the pixels per radian along x.
    pub fn mean_focal_length(&self) -> f64 {
        let idx = self.model.focal_length_idxs();
        if idx.is_empty() {
            return self.params[0] / (2.0 * std::f64::consts::PI);
        }
        idx.iter().map(|&i| self.params[i]).sum::<f64>() / idx.len() as f64
    }

    /// (fx, fy) of the pinhole part. For EQUIRECTANGULAR, pixels per radian.
    pub fn focal_xy(&self) -> (f64, f64) {
        let idx = self.model.focal_length_idxs();
        match idx.len() {
            1 => (self.params[idx[0]], self.params[idx[0]]),
            2 => (self.params[idx[0]], self.params[idx[1]]),
            _ => {
                let f = self.params[0] / (2.0 * std::f64::consts::PI);
                (f, self.params[1] / std::f64::consts::PI)
            }
        }
    }

    /// (cx, cy); the image centre for EQUIRECTANGULAR.
    pub fn principal_point(&self) -> (f64, f64) {
        let idx = self.model.principal_point_idxs();
        if idx.is_empty() {
            (self.params[0] / 2.0, self.params[1] / 2.0)
        } else {
            (self.params[idx[0]], self.params[idx[1]])
        }
    }

    /// Pinhole calibration matrix K (distortion ignored).
    pub fn calibration_matrix(&self) -> Matrix3<f64> {
        let (fx, fy) = self.focal_xy();
        let (cx, cy) = self.principal_point();
        Matrix3::new(fx, 0.0, cx, 0.0, fy, cy, 0.0, 0.0, 1.0)
    }

    /// Projects a point in the camera frame to pixels (COLMAP `ImgFromCam`).
    /// Returns None for points the model cannot image (behind a perspective camera,
    /// outside a fisheye's valid angle, at the centre of a spherical camera).
    pub fn project(&self, p_cam: &Vector3<f64>) -> Option<Vector2<f64>> {
        models::img_from_cam(self.model, &self.params, p_cam)
    }

    /// Lifts a pixel to a ray in the camera frame (COLMAP `CamFromImg` / `CamRayFromImg`).
    /// For perspective models the ray is (u, v, 1) on the normalised image plane; for
    /// EQUIRECTANGULAR a unit bearing. None when the iterative undistortion does not
    /// converge or the pixel is outside the model's domain.
    pub fn unproject(&self, px: &Vector2<f64>) -> Option<Vector3<f64>> {
        models::cam_ray_from_img(self.model, &self.params, px)
    }

    /// Pixel -> normalised image plane (u, v) with w = 1. None for EQUIRECTANGULAR.
    pub fn cam_from_img(&self, px: &Vector2<f64>) -> Option<Vector2<f64>> {
        if !self.model.is_perspective() {
            return None;
        }
        self.unproject(px)
            .map(|r| Vector2::new(r.x / r.z, r.y / r.z))
    }

    /// A pixel threshold expressed on the normalised image plane (COLMAP
    /// `CamFromImgThreshold`: divided by the mean focal length).
    pub fn cam_from_img_threshold(&self, px: f64) -> f64 {
        px / self.mean_focal_length()
    }

    /// The camera of the same sensor after resizing the image by `s` (augmentation,
    /// rescaled datasets): focal lengths and principal point times `s` (for
    /// EQUIRECTANGULAR its width and height parameters), distortion unchanged (every
    /// distortion parameter acts on normalised coordinates or angles), size rounded.
    /// With COLMAP's corner-origin pixels, a pixel `x` of the original maps exactly to
    /// `s * x`, for every model.
    pub fn scaled(&self, s: f64) -> Result<Camera, GeometryError> {
        if !(s.is_finite() && s > 0.0) {
            return Err(GeometryError::InvalidScale(s));
        }
        let mut params = self.params.clone();
        let m = self.model;
        if m.is_perspective() {
            for &i in m.focal_length_idxs().iter().chain(m.principal_point_idxs()) {
                params[i] *= s;
            }
        } else {
            params[0] *= s;
            params[1] *= s;
        }
        Ok(Camera {
            model: m,
            width: (self.width as f64 * s).round() as u64,
            height: (self.height as f64 * s).round() as u64,
            params,
        })
    }

    /// Whether a pixel lies inside the image rectangle [0, width) x [0, height).
    pub fn contains(&self, px: &Vector2<f64>) -> bool {
        px.x >= 0.0 && px.y >= 0.0 && px.x < self.width as f64 && px.y < self.height as f64
    }
}

#[cfg(test)]
mod tests;
