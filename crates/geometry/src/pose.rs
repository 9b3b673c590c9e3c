//! Rigid world-to-camera poses: `X_cam = R X_world + t`, quaternion Hamilton, w-first.

use crate::error::GeometryError;
use nalgebra::{Matrix3, Matrix4, Quaternion, Rotation3, UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};

/// Default tolerance on `|q| - 1` for quaternions read from files (COLMAP writes
/// 17 digits; hand-written or 6-digit files are off by ~1e-6).
pub const QUATERNION_NORM_TOLERANCE: f64 = 1e-3;
/// Default tolerance on `max |R^T R - I|` for rotation matrices read from files
/// (7-Scenes pose.txt carries about 7 significant digits).
pub const ORTHONORMAL_TOLERANCE: f64 = 1e-4;

/// A world-to-camera rigid transform.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Pose {
    pub rotation: UnitQuaternion<f64>,
    pub translation: Vector3<f64>,
}

impl Default for Pose {
    fn default() -> Self {
        Self::identity()
    }
}

fn check_finite(values: &[f64], what: &'static str) -> Result<(), GeometryError> {
    if values.iter().all(|v| v.is_finite()) {
        Ok(())
    } else {
        Err(GeometryError::NonFinite { what })
    }
}

impl Pose {
    pub fn identity() -> Self {
        Pose {
            rotation: UnitQuaternion::identity(),
            translation: Vector3::zeros(),
        }
    }

    pub fn new(rotation: UnitQuaternion<f64>, translation: Vector3<f64>) -> Self {
        Pose {
            rotation,
            translation,
        }
    }

    /// From a w-first quaternion and a translation, as COLMAP and hloc write them.
    /// The quaternion is normalised; its norm must be within `QUATERNION_NORM_TOLERANCE`
    /// of 1 and every value finite.
    pub fn from_qvec_tvec(q_wxyz: [f64; 4], t: [f64; 3]) -> Result<Self, GeometryError> {
        Self::from_qvec_tvec_tol(q_wxyz, t, QUATERNION_NORM_TOLERANCE)
    }

    pub fn from_qvec_tvec_tol(
        q_wxyz: [f64; 4],
        t: [f64; 3],
        tolerance: f64,
    ) -> Result<Self, GeometryError> {
        check_finite(&q_wxyz, "quaternion")?;
        check_finite(&t, "translation")?;
        let q = Quaternion::new(q_wxyz[0], q_wxyz[1], q_wxyz[2], q_wxyz[3]);
        let norm = q.norm();
        if (norm - 1.0).abs() > tolerance {
            return Err(GeometryError::QuaternionNorm { norm, tolerance });
        }
        Ok(Pose {
            rotation: UnitQuaternion::new_normalize(q),
            translation: Vector3::from(t),
        })
    }

    /// From a rotation matrix and translation; the matrix must be a proper rotation
    /// within `tolerance` (max abs entry of `R^T R - I`, and det within tolerance of 1).
    pub fn from_rotation_matrix(
        r: &Matrix3<f64>,
        t: &Vector3<f64>,
        tolerance: f64,
    ) -> Result<Self, GeometryError> {
        check_finite(r.as_slice(), "rotation matrix")?;
        check_finite(t.as_slice(), "translation")?;
        check_rotation(r, tolerance)?;
        // Closest rotation; exact for an exactly orthonormal input.
        let rot = Rotation3::from_matrix_eps(r, 1e-15, 100, Rotation3::identity());
        Ok(Pose {
            rotation: UnitQuaternion::from_rotation_matrix(&rot),
            translation: *t,
        })
    }

    /// From a 4x4 camera-to-world matrix (7-Scenes `pose.txt`): inverted once, here.
    pub fn from_cam_to_world(m: &Matrix4<f64>, tolerance: f64) -> Result<Self, GeometryError> {
        check_finite(m.as_slice(), "4x4 pose matrix")?;
        let last = [m[(3, 0)], m[(3, 1)], m[(3, 2)], m[(3, 3)]];
        if last != [0.0, 0.0, 0.0, 1.0] {
            return Err(GeometryError::NotRigid(last));
        }
        let r_cw: Matrix3<f64> = m.fixed_view::<3, 3>(0, 0).into();
        let c: Vector3<f64> = m.fixed_view::<3, 1>(0, 3).into();
        let cam_to_world = Pose::from_rotation_matrix(&r_cw, &c, tolerance)?;
        Ok(cam_to_world.inverse())
    }

    /// From a camera centre and a w-first world-to-camera quaternion (Cambridge
    /// Landmarks `dataset_*.txt`): `t = -R c`.
    pub fn from_centre_qvec(centre: [f64; 3], q_wxyz: [f64; 4]) -> Result<Self, GeometryError> {
        check_finite(&centre, "camera centre")?;
        let p = Pose::from_qvec_tvec(q_wxyz, [0.0; 3])?;
        let t = -(p.rotation * Vector3::from(centre));
        Ok(Pose {
            rotation: p.rotation,
            translation: t,
        })
    }

    /// Quaternion as `[w, x, y, z]`.
    pub fn qvec(&self) -> [f64; 4] {
        let q = self.rotation.quaternion();
        [q.w, q.i, q.j, q.k]
    }

    pub fn tvec(&self) -> [f64; 3] {
        [self.translation.x, self.translation.y, self.translation.z]
    }

    pub fn rotation_matrix(&self) -> Matrix3<f64> {
        self.rotation.to_rotation_matrix().into_inner()
    }

    /// The 4x4 matrix of this transform.
    pub fn to_matrix(&self) -> Matrix4<f64> {
        let mut m = Matrix4::identity();
        m.fixed_view_mut::<3, 3>(0, 0)
            .copy_from(&self.rotation_matrix());
        m.fixed_view_mut::<3, 1>(0, 3).copy_from(&self.translation);
        m
    }

    /// Camera centre in world coordinates, `-R^T t`.
    pub fn centre(&self) -> Vector3<f64> {
        -(self.rotation.inverse() * self.translation)
    }

    pub fn inverse(&self) -> Pose {
        let r_inv = self.rotation.inverse();
        Pose {
            rotation: r_inv,
            translation: -(r_inv * self.translation),
        }
    }

    /// `self * other`: apply `other` first, then `self`
    /// (e.g. `cam_from_rig * rig_from_world = cam_from_world`).
    pub fn compose(&self, other: &Pose) -> Pose {
        Pose {
            rotation: self.rotation * other.rotation,
            translation: self.rotation * other.translation + self.translation,
        }
    }

    /// `R X + t`.
    pub fn transform_point(&self, x: &Vector3<f64>) -> Vector3<f64> {
        self.rotation * x + self.translation
    }

    /// Whether every value is finite (a pose built from typed values can still hold NaN).
    pub fn is_finite(&self) -> bool {
        self.qvec()
            .iter()
            .chain(self.tvec().iter())
            .all(|v| v.is_finite())
    }
}

/// Checks that `r` is a proper rotation within `tolerance`.
pub fn check_rotation(r: &Matrix3<f64>, tolerance: f64) -> Result<(), GeometryError> {
    let deviation = (r.transpose() * r - Matrix3::identity()).abs().max();
    let det = r.determinant();
    if !(deviation <= tolerance && (det - 1.0).abs() <= tolerance) {
        return Err(GeometryError::NotOrthonormal {
            deviation,
            det,
            tolerance,
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Unit;

    fn sample_pose() -> Pose {
        let axis = Unit::new_normalize(Vector3::new(0.3, -0.5, 0.8));
        Pose::new(
            UnitQuaternion::from_axis_angle(&axis, 0.7),
            Vector3::new(1.0, -2.0, 0.5),
        )
    }

    #[test]
    fn inverse_and_centre() {
        let p = sample_pose();
        let id = p.compose(&p.inverse());
        assert!(id.rotation.angle() < 1e-12);
        assert!(id.translation.norm() < 1e-12);
        // The centre maps to the camera origin.
        assert!(p.transform_point(&p.centre()).norm() < 1e-12);
    }

    #[test]
    fn compose_applies_right_first() {
        let a = sample_pose();
        let b = Pose::new(
            UnitQuaternion::from_euler_angles(0.1, 0.2, 0.3),
            Vector3::new(0.0, 1.0, 2.0),
        );
        let x = Vector3::new(0.4, 0.5, -0.6);
        let lhs = a.compose(&b).transform_point(&x);
        let rhs = a.transform_point(&b.transform_point(&x));
        assert!((lhs - rhs).norm() < 1e-12);
    }

    #[test]
    fn qvec_roundtrip_w_first() {
        let p = Pose::from_qvec_tvec([0.5, 0.5, 0.5, 0.5], [1.0, 2.0, 3.0]).unwrap();
        assert_eq!(p.qvec(), [0.5, 0.5, 0.5, 0.5]);
        // 120 deg about (1,1,1): x -> y.
        let y = p.rotation * Vector3::x();
        assert!((y - Vector3::y()).norm() < 1e-12);
    }

    #[test]
    fn cam_to_world_matrix_is_inverted() {
        let p = sample_pose();
        let c2w = p.inverse().to_matrix();
        let q = Pose::from_cam_to_world(&c2w, 1e-9).unwrap();
        assert!((q.translation - p.translation).norm() < 1e-12);
        assert!(q.rotation.angle_to(&p.rotation) < 1e-12);
    }

    #[test]
    fn cambridge_centre_quaternion() {
        let p = sample_pose();
        let c = p.centre();
        let q = Pose::from_centre_qvec([c.x, c.y, c.z], p.qvec()).unwrap();
        assert!((q.translation - p.translation).norm() < 1e-12);
    }

    #[test]
    fn rejects_bad_rotations_and_nan() {
        let mut m = sample_pose().to_matrix();
        m[(0, 0)] *= 1.01;
        assert!(matches!(
            Pose::from_cam_to_world(&m, 1e-4),
            Err(GeometryError::NotOrthonormal { .. })
        ));
        let mut m = sample_pose().to_matrix();
        m[(1, 2)] = f64::NAN;
        assert!(matches!(
            Pose::from_cam_to_world(&m, 1e-4),
            Err(GeometryError::NonFinite { .. })
        ));
        // A reflection is orthonormal but not a rotation.
        let refl = Matrix3::new(-1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0);
        assert!(Pose::from_rotation_matrix(&refl, &Vector3::zeros(), 1e-4).is_err());
        assert!(Pose::from_qvec_tvec([2.0, 0.0, 0.0, 0.0], [0.0; 3]).is_err());
        assert!(Pose::from_qvec_tvec([1.0, 0.0, 0.0, 0.0], [0.0, f64::INFINITY, 0.0]).is_err());
        let mut m = sample_pose().to_matrix();
        m[(3, 0)] = 0.5;
        assert!(matches!(
            Pose::from_cam_to_world(&m, 1e-4),
            Err(GeometryError::NotRigid(_))
        ));
    }
}
