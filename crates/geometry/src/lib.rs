//! Geometry shared by every stage of pl2map-rs.
//!
//! Conventions (see README.md, "Conventions"): poses are world-to-camera (`X_cam = R X_world + t`,
//! Hamilton quaternion stored w-first); pixels follow COLMAP, so the centre of the
//! top-left pixel is (0.5, 0.5); metres, pixels and radians everywhere.

pub mod camera;
pub mod error;
pub mod lines;
pub mod metrics;
pub mod pose;

pub use camera::{Camera, CameraModel};
pub use error::GeometryError;
pub use pose::Pose;

pub use nalgebra::{Matrix3, Matrix4, UnitQuaternion, Vector2, Vector3};
