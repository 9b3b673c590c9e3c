//! Pose error metrics of docs/method.md section 6.

use crate::pose::Pose;

/// The accuracy thresholds reported everywhere: (cm, deg), each strict.
pub const ACCURACY_THRESHOLDS: [(f64, f64); 5] =
    [(1.0, 1.0), (2.0, 2.0), (3.0, 3.0), (5.0, 5.0), (10.0, 10.0)];

/// Error of an estimated pose against the ground truth.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PoseError {
    /// `|| c_gt - c_est ||` with `c = -R^T t`, in metres.
    pub translation_m: f64,
    /// `arccos((trace(R_gt^T R_est) - 1) / 2)`, in degrees.
    pub rotation_deg: f64,
}

impl PoseError {
    pub fn translation_cm(&self) -> f64 {
        self.translation_m * 100.0
    }

    /// Strictly under both thresholds (cm, deg).
    pub fn within(&self, cm: f64, deg: f64) -> bool {
        self.translation_cm() < cm && self.rotation_deg < deg
    }
}

/// Translation (camera centre distance) and rotation (angle of `R_gt^T R_est`) errors.
pub fn pose_error(gt: &Pose, est: &Pose) -> PoseError {
    let translation_m = (gt.centre() - est.centre()).norm();
    let r = gt.rotation_matrix().transpose() * est.rotation_matrix();
    // Clamp: rounding can push the cosine just outside [-1, 1].
    let cos = ((r.trace() - 1.0) / 2.0).clamp(-1.0, 1.0);
    PoseError {
        translation_m,
        rotation_deg: cos.acos().to_degrees(),
    }
}

/// Median of finite values (mean of the two middle ones for an even count); NaN when
/// empty. A failed localisation should be entered as an infinite error, which sorts last.
pub fn median(values: &[f64]) -> f64 {
    if values.is_empty() {
        return f64::NAN;
    }
    let mut v = values.to_vec();
    v.sort_by(|a, b| a.total_cmp(b));
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// Summary over a test set: medians and the fraction under each accuracy threshold.
#[derive(Clone, Debug, PartialEq)]
pub struct ErrorSummary {
    pub count: usize,
    pub median_cm: f64,
    pub median_deg: f64,
    /// Fractions in [0, 1], one per `ACCURACY_THRESHOLDS` entry.
    pub accuracy: Vec<f64>,
}

/// Summarises per-frame errors; `None` entries (failed localisations) count as
/// infinitely wrong, so they lower the accuracies and push the medians up.
pub fn summarize(errors: &[Option<PoseError>]) -> ErrorSummary {
    let inf = PoseError {
        translation_m: f64::INFINITY,
        rotation_deg: f64::INFINITY,
    };
    let e: Vec<PoseError> = errors.iter().map(|e| e.unwrap_or(inf)).collect();
    let cm: Vec<f64> = e.iter().map(|e| e.translation_cm()).collect();
    let deg: Vec<f64> = e.iter().map(|e| e.rotation_deg).collect();
    let n = e.len().max(1) as f64;
    let accuracy = ACCURACY_THRESHOLDS
        .iter()
        .map(|&(c, d)| e.iter().filter(|x| x.within(c, d)).count() as f64 / n)
        .collect();
    ErrorSummary {
        count: e.len(),
        median_cm: median(&cm),
        median_deg: median(&deg),
        accuracy,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Unit, UnitQuaternion, Vector3};

    #[test]
    fn known_errors() {
        let gt = Pose::new(UnitQuaternion::identity(), Vector3::new(0.0, 0.0, 1.0));
        let axis = Unit::new_normalize(Vector3::new(1.0, 2.0, 3.0));
        let rot = UnitQuaternion::from_axis_angle(&axis, 3f64.to_radians());
        // Same centre (0, 0, -1), rotated by 3 degrees.
        let c = Vector3::new(0.0, 0.0, -1.0);
        let est = Pose::new(rot, -(rot * c));
        let e = pose_error(&gt, &est);
        assert!(e.translation_m < 1e-12);
        assert!((e.rotation_deg - 3.0).abs() < 1e-9);
        // Centre moved by 4 cm.
        let est2 = Pose::new(UnitQuaternion::identity(), Vector3::new(0.04, 0.0, 1.0));
        let e2 = pose_error(&gt, &est2);
        assert!((e2.translation_cm() - 4.0).abs() < 1e-9);
        assert!(e2.rotation_deg.abs() < 1e-6);
    }

    #[test]
    fn strict_thresholds_and_failures() {
        let at = |cm: f64, deg: f64| {
            Some(PoseError {
                translation_m: cm / 100.0,
                rotation_deg: deg,
            })
        };
        let s = summarize(&[at(0.5, 0.5), at(2.0, 0.1), at(4.0, 4.0), None]);
        assert_eq!(s.count, 4);
        // (1,1): only the first; (2,2): 2.0 cm is not < 2 (strict); (5,5): three.
        assert_eq!(s.accuracy, vec![0.25, 0.25, 0.5, 0.75, 0.75]);
        assert!((s.median_cm - 3.0).abs() < 1e-12);
        assert!(median(&[]).is_nan());
    }
}
