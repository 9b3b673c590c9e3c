//! `Camera::scaled(s)`: with COLMAP's corner-origin pixels, resizing an image by `s`
//! maps every pixel `x` to `s * x`, for every model.

use super::cameras;
use super::domain::ray;
use super::roundtrip::{cameras_with_domains, config, visible};
use nalgebra::Vector2;
use proptest::prelude::*;

proptest! {
    #![proptest_config(config(400))]

    #[test]
    fn scaled_camera_projects_to_scaled_pixels(
        index in 0..cameras::all().len(),
        s in prop::sample::select(vec![0.25, 0.5, 1.0 / 3.0, 0.8, 1.5, 2.0, 3.7]),
        points in prop::collection::vec(
            (0.0..=1.0f64, -std::f64::consts::PI..std::f64::consts::PI, 0.01..100.0f64),
            8,
        ),
    ) {
        let (cam, dom) = &cameras_with_domains()[index];
        let scaled = cam.scaled(s).unwrap();
        prop_assert_eq!(scaled.width, (cam.width as f64 * s).round() as u64);
        prop_assert_eq!(scaled.height, (cam.height as f64 * s).round() as u64);
        for (t, phi, depth) in points {
            let theta = dom.map_or(t * std::f64::consts::PI, |d| t * d.max_angle);
            let x = ray(theta * phi.cos(), theta * phi.sin()) * depth;
            let p = cam.project(&x).unwrap();
            let q = scaled.project(&x).unwrap();
            if !visible(cam, &p) {
                continue;
            }
            let err = (q - p * s).norm();
            prop_assert!(err <= 1e-9 * (1.0 + q.norm()), "{:?} x{}: {:?} vs {:?}", cam, s, q, p * s);
            // And the scaled pixel lifts to the same ray.
            let r0 = cam.unproject(&p).unwrap();
            let r1 = scaled.unproject(&(p * s)).unwrap();
            prop_assert!(r0.normalize().cross(&r1.normalize()).norm() <= 1e-9);
        }
    }
}

#[test]
fn scaling_by_one_is_the_identity_and_bad_scales_are_rejected() {
    for cam in cameras::all() {
        assert_eq!(cam.scaled(1.0).unwrap(), cam);
        for s in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            assert!(cam.scaled(s).is_err());
        }
    }
    // Pixel centres of a 640x480 image halved land on the halved grid's corners as
    // expected: the image corner (0, 0) stays, the far corner goes to (320, 240).
    let cam = cameras::all()[0].clone();
    let half = cam.scaled(0.5).unwrap();
    let corner = cam.unproject(&Vector2::new(640.0, 480.0)).unwrap();
    assert!((half.project(&corner).unwrap() - Vector2::new(320.0, 240.0)).norm() < 1e-9);
}
