//! The correspondences the pose is estimated from: what [`crate::estimate_pose`] takes,
//! the correspondence files of `pl2map pose` hold ([`crate::io`]) and the synthetic
//! problems generate ([`crate::synthetic`]).

use geometry::lines::{Segment2, Segment3};
use nalgebra::{Vector2, Vector3};

/// A 2D keypoint (pixels, COLMAP convention) and its 3D world point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PointMatch {
    pub pixel: Vector2<f64>,
    pub world: Vector3<f64>,
}

/// A detected 2D segment (pixels) and a 3D world segment on the same line. The
/// endpoints need not correspond: only the lines they span matter.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LineMatch {
    pub segment: Segment2,
    pub world: Segment3,
}
