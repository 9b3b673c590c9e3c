//! The working form of a pose inside the solvers and RANSAC: a rotation matrix and a
//! translation (world-to-camera, `X_cam = R X + t`). Scoring applies thousands of
//! poses to thousands of points, and a matrix is cheaper to apply than a quaternion.

use geometry::Pose;
use nalgebra::{Matrix3, Rotation3, UnitQuaternion, Vector3};

#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Rigid {
    pub r: Matrix3<f64>,
    pub t: Vector3<f64>,
}

impl Rigid {
    pub(crate) fn identity() -> Self {
        Rigid {
            r: Matrix3::identity(),
            t: Vector3::zeros(),
        }
    }

    /// The nearest unit quaternion of `r` (exact for a rotation; solvers return
    /// matrices orthonormal to rounding).
    pub(crate) fn to_pose(self) -> Pose {
        let q = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(self.r));
        Pose::new(UnitQuaternion::new_normalize(q.into_inner()), self.t)
    }

    #[inline]
    pub(crate) fn apply(&self, x: &Vector3<f64>) -> Vector3<f64> {
        self.r * x + self.t
    }

    pub(crate) fn is_finite(&self) -> bool {
        self.r.iter().chain(self.t.iter()).all(|v| v.is_finite())
    }

    /// Left update in the camera frame: `X_cam <- exp([w]x) X_cam + v`, i.e. the camera
    /// turns about its own centre. Well conditioned whatever the world origin.
    pub(crate) fn perturbed(&self, w: &Vector3<f64>, v: &Vector3<f64>) -> Rigid {
        let q = Rotation3::new(*w).into_inner();
        Rigid {
            r: q * self.r,
            t: q * self.t + v,
        }
    }
}

/// Up to 8 solutions of a minimal problem, without allocation.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Solutions {
    items: [Rigid; 8],
    len: usize,
}

impl Solutions {
    pub(crate) fn new() -> Self {
        Solutions {
            items: [Rigid::identity(); 8],
            len: 0,
        }
    }

    pub(crate) fn clear(&mut self) {
        self.len = 0;
    }

    pub(crate) fn push(&mut self, p: Rigid) {
        if self.len < self.items.len() && p.is_finite() {
            self.items[self.len] = p;
            self.len += 1;
        }
    }

    pub(crate) fn as_slice(&self) -> &[Rigid] {
        &self.items[..self.len]
    }
}

/// A unit vector orthogonal to the unit vector `n`.
pub(crate) fn orthogonal_unit(n: &Vector3<f64>) -> Vector3<f64> {
    // Cross with the axis least aligned with n.
    let a = n.abs();
    let axis = if a.x <= a.y && a.x <= a.z {
        Vector3::x()
    } else if a.y <= a.z {
        Vector3::y()
    } else {
        Vector3::z()
    };
    n.cross(&axis).normalize()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pose_roundtrip_and_perturbation() {
        let p = Pose::new(
            UnitQuaternion::from_euler_angles(0.3, -1.2, 2.0),
            Vector3::new(1.0, 2.0, -3.0),
        );
        let r = Rigid {
            r: p.rotation_matrix(),
            t: p.translation,
        };
        let back = r.to_pose();
        assert!(back.rotation.angle_to(&p.rotation) < 1e-14);
        let x = Vector3::new(0.5, -0.25, 4.0);
        assert!((r.apply(&x) - p.transform_point(&x)).norm() < 1e-13);
        // The perturbation acts on camera-frame points.
        let w = Vector3::new(0.01, -0.02, 0.03);
        let v = Vector3::new(0.1, 0.0, -0.1);
        let moved = r.perturbed(&w, &v);
        let expect = Rotation3::new(w) * r.apply(&x) + v;
        assert!((moved.apply(&x) - expect).norm() < 1e-13);
        let n = Vector3::new(0.0, 0.6, 0.8);
        assert!(orthogonal_unit(&n).dot(&n).abs() < 1e-15);
    }
}
