//! Absolute camera pose from 2D-3D point and line correspondences.
//!
//! - [`PointMatch`], [`LineMatch`]: the 2D-3D correspondences a pose is estimated from
//!   (`matches.rs`); RANSAC and the refinement work on them lifted to the normalised
//!   image plane (`normalized.rs`).
//! - [`solvers`]: minimal solvers P3P, P2P1LL, P1P2LL, P3LL returning every real pose.
//! - [`ransac`]: hybrid LO-RANSAC over mixed minimal samples, then Levenberg-Marquardt
//!   refinement of points and lines jointly with a Cauchy loss, for any perspective
//!   camera model of the geometry crate ([`estimate_pose`]).
//! - [`io`]: the text formats of `pl2map pose` (correspondence files, camera string).
//! - [`synthetic`]: random problems with ground truth, for tests and benchmarks.
//!
//! Poses are world-to-camera (`X_cam = R X + t`); pixels follow COLMAP.

// `!(x > 0.0)` is deliberate throughout: it rejects NaN along with the negatives.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

mod error;
pub mod io;
mod matches;
mod normalized;
mod poly;
pub mod ransac;
mod refine;
mod rigid;
pub mod solvers;
pub mod synthetic;

pub use error::PoseError;
pub use matches::{LineMatch, PointMatch};
pub use ransac::{PoseEstimate, RansacOptions, estimate_pose};
