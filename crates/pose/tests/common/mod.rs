//! Random noise-free minimal problems shared by the solver tests.

use geometry::{Pose, UnitQuaternion, Vector2, Vector3};
use pose::solvers::{Line3D, image_line_normal};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// A random camera (uniform orientation, centre in a 10 m box) and its own generator.
pub struct Scene {
    pub gt: Pose,
    pub rng: ChaCha8Rng,
}

impl Scene {
    pub fn new(rng: &mut ChaCha8Rng) -> Scene {
        let axis = random_unit(rng);
        let angle = rng.random_range(-std::f64::consts::PI..std::f64::consts::PI);
        let rot = UnitQuaternion::from_axis_angle(&nalgebra::Unit::new_normalize(axis), angle);
        let centre = Vector3::new(
            rng.random_range(-5.0..5.0),
            rng.random_range(-5.0..5.0),
            rng.random_range(-5.0..5.0),
        );
        let gt = Pose::new(rot, -(rot * centre));
        Scene {
            gt,
            rng: ChaCha8Rng::seed_from_u64(rng.random()),
        }
    }

    /// A camera-frame point seen inside a 60 degree field of view.
    pub fn cam_point(&mut self) -> Vector3<f64> {
        let u = self.rng.random_range(-0.6..0.6);
        let v = self.rng.random_range(-0.6..0.6);
        let z = self.rng.random_range(0.5..10.0);
        Vector3::new(u * z, v * z, z)
    }

    pub fn to_world(&self, p: &Vector3<f64>) -> Vector3<f64> {
        self.gt.inverse().transform_point(p)
    }

    /// Ray and world point.
    pub fn point(&mut self) -> (Vector3<f64>, Vector3<f64>) {
        let p = self.cam_point();
        (p / p.z, self.to_world(&p))
    }

    /// Image-line normal and world line through two camera-frame points; the normal is
    /// computed from two other points of the line, as a detector would see them.
    pub fn line_through(
        &mut self,
        a: Vector3<f64>,
        b: Vector3<f64>,
    ) -> Option<(Vector3<f64>, Line3D)> {
        let s1 = self.rng.random_range(-0.3..0.4);
        let s2 = self.rng.random_range(0.6..1.3);
        let (p1, p2) = (a + (b - a) * s1, a + (b - a) * s2);
        if p1.z <= 0.0 || p2.z <= 0.0 {
            return None;
        }
        let n = image_line_normal(
            &Vector2::new(p1.x / p1.z, p1.y / p1.z),
            &Vector2::new(p2.x / p2.z, p2.y / p2.z),
        )?;
        Some((n, Line3D::through(&self.to_world(&a), &self.to_world(&b))))
    }

    pub fn line(&mut self) -> (Vector3<f64>, Line3D) {
        loop {
            let (a, b) = (self.cam_point(), self.cam_point());
            if let Some(l) = self.line_through(a, b) {
                return l;
            }
        }
    }
}

pub fn random_unit(rng: &mut ChaCha8Rng) -> Vector3<f64> {
    loop {
        let v = Vector3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        );
        let n = v.norm();
        if n > 0.1 && n <= 1.0 {
            return v / n;
        }
    }
}
