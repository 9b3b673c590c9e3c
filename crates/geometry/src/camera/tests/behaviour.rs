//! Where projection and lifting fail, and hand-checked values of the closed-form
//! models.

use super::cameras;
use crate::camera::{Camera, CameraModel};
use nalgebra::{Vector2, Vector3};
use std::f64::consts::{FRAC_PI_2, FRAC_PI_4, PI};

fn cam(model: CameraModel, params: &[f64]) -> Camera {
    Camera::new(model, 640, 480, params.to_vec()).unwrap()
}

#[test]
fn points_behind_or_beside_the_camera_do_not_project() {
    let behind = [
        Vector3::new(0.1, 0.2, -1.0),
        Vector3::new(0.0, 0.0, -1.0),
        Vector3::new(1.0, -1.0, 0.0),
        // Below COLMAP's depth threshold (machine epsilon), and the origin.
        Vector3::new(0.3, -0.2, 1e-17),
        Vector3::zeros(),
    ];
    for c in cameras::all() {
        let division = matches!(c.model, CameraModel::SimpleDivision | CameraModel::Division);
        if c.model == CameraModel::Equirectangular || division {
            continue;
        }
        for x in &behind {
            assert_eq!(c.project(x), None, "{c:?} {x:?}");
        }
        // Just above the threshold it projects (far away, but finite).
        if !matches!(c.model, CameraModel::SimpleRadial | CameraModel::Radial) || c.params[3] >= 0.0
        {
            assert!(
                c.project(&Vector3::new(0.3, -0.2, 3e-16)).is_some(),
                "{c:?}"
            );
        }
    }
}

#[test]
fn division_model_sees_behind_the_camera_only_with_barrel_distortion() {
    // k < 0: the pixel at normalised radius rho sees the ray (rho, 1 + k rho^2), which
    // points backwards for rho^2 > -1/k. A point 100 degrees off axis projects to the
    // radius rho solving rho / (1 + k rho^2) = tan(100 deg) with 1 + k rho^2 < 0.
    let k = -0.5;
    let c = cam(CameraModel::SimpleDivision, &[300.0, 320.0, 240.0, k]);
    let theta = 100f64.to_radians();
    let px = c
        .project(&Vector3::new(theta.sin(), 0.0, theta.cos()))
        .unwrap();
    let rho = (px.x - 320.0) / 300.0;
    assert!(1.0 + k * rho * rho < 0.0);
    assert!((rho / (1.0 + k * rho * rho) - theta.tan()).abs() < 1e-12);
    // Such a ray cannot be written as (u, v, 1): lifting returns None.
    assert_eq!(c.unproject(&px), None);
    // k > 0: no positive scale solves the projection for points behind the camera
    // (COLMAP returns the pixel of the opposite direction there).
    let c = cam(CameraModel::SimpleDivision, &[300.0, 320.0, 240.0, 0.8]);
    assert_eq!(c.project(&Vector3::new(0.1, 0.0, -0.5)), None);
    // Beyond its fold at rho^2 = 1/k no point projects, so lifting fails there.
    let fold = 320.0 + 300.0 / 0.8f64.sqrt();
    assert!(c.unproject(&Vector2::new(fold - 1.0, 240.0)).is_some());
    assert_eq!(c.unproject(&Vector2::new(fold + 1.0, 240.0)), None);
}

#[test]
fn equirectangular_axis_conventions() {
    let c = Camera::new(CameraModel::Equirectangular, 1000, 500, vec![1000.0, 500.0]).unwrap();
    let p = |x, y, z| c.project(&Vector3::new(x, y, z)).unwrap();
    // Forward at the centre, +x (right) at 3/4 of the width, -x at 1/4, backward at
    // the right edge (longitude pi), up (-y) on the top row, down on the bottom row.
    assert!((p(0.0, 0.0, 1.0) - Vector2::new(500.0, 250.0)).norm() < 1e-12);
    assert!((p(2.0, 0.0, 0.0) - Vector2::new(750.0, 250.0)).norm() < 1e-12);
    assert!((p(-1.0, 0.0, 0.0) - Vector2::new(250.0, 250.0)).norm() < 1e-12);
    assert!((p(0.0, 0.0, -1.0) - Vector2::new(1000.0, 250.0)).norm() < 1e-12);
    assert!((p(0.0, -1.0, 0.0).y).abs() < 1e-12);
    assert!((p(0.0, 1.0, 0.0).y - 500.0).abs() < 1e-12);
    // 45 degrees up and to the right.
    let q = p(1.0, -(2f64.sqrt()), 1.0);
    assert!((q - Vector2::new(625.0, 125.0)).norm() < 1e-12);
    assert_eq!(c.project(&Vector3::zeros()), None);
    // Lifting gives unit bearings for every pixel, back hemisphere included.
    let r = c.unproject(&Vector2::new(125.0, 250.0)).unwrap();
    assert!((r - Vector3::new(-FRAC_PI_4.sin(), 0.0, -FRAC_PI_4.cos())).norm() < 1e-12);
    assert!(c.cam_from_img(&Vector2::new(500.0, 250.0)).is_none());
}

#[test]
fn fisheye_angles_and_their_90_degree_limit() {
    // Equidistant: the pixel radius is f * theta.
    let c = cam(CameraModel::SimpleFisheye, &[200.0, 320.0, 240.0]);
    let theta: f64 = 1.2;
    let px = c
        .project(&Vector3::new(
            theta.sin() * 0.6,
            theta.sin() * 0.8,
            theta.cos(),
        ))
        .unwrap();
    assert!(
        (px - Vector2::new(320.0 + 200.0 * 1.2 * 0.6, 240.0 + 200.0 * 1.2 * 0.8)).norm() < 1e-9
    );
    let r = c.unproject(&px).unwrap();
    assert!((r.x.hypot(r.y).atan() - theta).abs() < 1e-12);
    // At and beyond theta = 90 degrees (radius f * pi/2) lifting fails: COLMAP's
    // fisheye models image only points in front of the camera.
    let edge = 200.0 * FRAC_PI_2;
    assert!(
        c.unproject(&Vector2::new(320.0 + edge - 1e-6, 240.0))
            .is_some()
    );
    assert_eq!(c.unproject(&Vector2::new(320.0 + edge + 1e-9, 240.0)), None);
    // OPENCV_FISHEYE with theta_d = theta (1 + k1 theta^2): the pixel radius of the
    // 60 degree ray is f * theta_d.
    let k1 = 0.1;
    let c = cam(
        CameraModel::OpenCvFisheye,
        &[300.0, 300.0, 320.0, 240.0, k1, 0.0, 0.0, 0.0],
    );
    let t = PI / 3.0;
    let px = c.project(&Vector3::new(t.sin(), 0.0, t.cos())).unwrap();
    assert!((px.x - (320.0 + 300.0 * t * (1.0 + k1 * t * t))).abs() < 1e-9);
}

#[test]
fn fov_model_follows_its_formula_for_small_omega() {
    // r_d = atan(2 r tan(omega / 2)) / omega, written out here with std functions.
    // COLMAP uses a series below omega = 0.01 whose signs are those of the inverse, so
    // it is 5e-3 px off at this point (pycolmap 4.2.1: x = 620.0025).
    let (u, v): (f64, f64) = (1.0, 0.5);
    let r = u.hypot(v);
    for omega in [0.005, 0.0099999, 0.0100001, 0.3, 1e-9] {
        let c = cam(CameraModel::Fov, &[300.0, 300.0, 320.0, 240.0, omega]);
        let factor = (2.0 * r * (omega / 2.0).tan()).atan() / (r * omega);
        let px = c.project(&Vector3::new(u, v, 1.0)).unwrap();
        let expected = Vector2::new(320.0 + 300.0 * u * factor, 240.0 + 300.0 * v * factor);
        assert!(
            (px - expected).norm() < 1e-9,
            "omega {omega}: {px:?} vs {expected:?}"
        );
        let back = c.unproject(&px).unwrap();
        assert!(
            (back - Vector3::new(u, v, 1.0)).norm() < 1e-12,
            "omega {omega}"
        );
    }
    // omega = 0 is the pinhole.
    let c = cam(CameraModel::Fov, &[300.0, 300.0, 320.0, 240.0, 0.0]);
    assert!(
        (c.project(&Vector3::new(u, v, 1.0)).unwrap() - Vector2::new(620.0, 390.0)).norm() < 1e-12
    );
    // Lifting fails where r_d omega reaches 90 degrees (the ray at infinity).
    let c = cam(CameraModel::Fov, &[250.0, 250.0, 320.0, 240.0, 1.2]);
    let edge = 250.0 * FRAC_PI_2 / 1.2;
    assert!(
        c.unproject(&Vector2::new(320.0 + edge - 1e-3, 240.0))
            .is_some()
    );
    assert_eq!(c.unproject(&Vector2::new(320.0 + edge + 1e-3, 240.0)), None);
}

#[test]
fn eucm_image_circle() {
    // The image of the 90-degree cone is the circle |m| = 1 / (alpha sqrt(beta)).
    let (alpha, beta) = (0.65, 1.2);
    let c = cam(
        CameraModel::Eucm,
        &[250.0, 250.0, 320.0, 240.0, alpha, beta],
    );
    let edge = 250.0 / (alpha * beta.sqrt());
    let px = c.project(&Vector3::new(1.0, 0.0, 1e-9)).unwrap();
    assert!((px.x - 320.0 - edge).abs() < 1e-6);
    assert!(
        c.unproject(&Vector2::new(320.0 + edge - 1e-3, 240.0))
            .is_some()
    );
    assert_eq!(c.unproject(&Vector2::new(320.0 + edge + 1e-3, 240.0)), None);
    // alpha = 0 is the pinhole.
    let c = cam(CameraModel::Eucm, &[250.0, 250.0, 320.0, 240.0, 0.0, 1.0]);
    assert!(
        (c.project(&Vector3::new(0.4, -0.2, 2.0)).unwrap() - Vector2::new(370.0, 215.0)).norm()
            < 1e-12
    );
}

#[test]
fn iterative_lifting_fails_past_the_fold_of_a_barrel_distortion() {
    // r_d = r (1 + k r^2) peaks at r = 1/sqrt(-3k) with r_d = 2/3 of that.
    let k = -0.35;
    let c = cam(CameraModel::SimpleRadial, &[300.0, 320.0, 240.0, k]);
    let peak = 2.0 / 3.0 / (-3.0 * k).sqrt() * 300.0;
    let inside = c
        .unproject(&Vector2::new(320.0 + peak - 0.5, 240.0))
        .unwrap();
    assert!(inside.x < 1.0 / (-3.0 * k).sqrt());
    assert_eq!(c.unproject(&Vector2::new(320.0 + peak + 0.5, 240.0)), None);
}

#[test]
fn bad_input_returns_none_without_panicking() {
    for c in cameras::all() {
        for x in [
            Vector3::new(f64::NAN, 0.0, 1.0),
            Vector3::new(0.0, f64::INFINITY, 1.0),
        ] {
            assert_eq!(c.project(&x), None, "{c:?}");
        }
        assert_eq!(c.unproject(&Vector2::new(f64::NAN, 1.0)), None, "{c:?}");
        // A camera built field by field with the wrong parameter count.
        let mut short = c.clone();
        short.params.pop();
        assert_eq!(short.project(&Vector3::new(0.0, 0.0, 1.0)), None);
        assert_eq!(short.unproject(&Vector2::new(1.0, 1.0)), None);
    }
    // Degenerate parameters: zero focal length or image size give no pixel. Built field
    // by field: `Camera::new` refuses both (tests.rs).
    let c = Camera {
        model: CameraModel::SimpleRadial,
        width: 640,
        height: 480,
        params: vec![0.0, 320.0, 240.0, 0.1],
    };
    assert_eq!(c.unproject(&Vector2::new(1.0, 1.0)), None);
    let c = Camera {
        model: CameraModel::Equirectangular,
        width: 0,
        height: 0,
        params: vec![0.0, 0.0],
    };
    assert_eq!(c.unproject(&Vector2::new(1.0, 1.0)), None);
}
