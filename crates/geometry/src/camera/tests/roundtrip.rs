//! Lifting and projection invert each other on each model's valid domain (see
//! `domain` for how it is chosen), and lifting fails outside it.

use super::cameras;
use super::domain::{Domain, Region, domain, ray, region};
use crate::camera::{Camera, CameraModel};
use nalgebra::{Vector2, Vector3};
use proptest::prelude::*;
use proptest::test_runner::{Config, RngAlgorithm, RngSeed};
use std::sync::OnceLock;

/// project(unproject(p)) must reproduce p to this many pixels.
const PX_TOL: f64 = 1e-6;
/// unproject(project(X)) must be parallel to X to this angle (radians).
const ANGLE_TOL: f64 = 1e-9;

/// The test cameras with their domains (None for EQUIRECTANGULAR), computed once.
pub fn cameras_with_domains() -> &'static [(Camera, Option<Domain>)] {
    static CACHE: OnceLock<Vec<(Camera, Option<Domain>)>> = OnceLock::new();
    CACHE.get_or_init(|| {
        cameras::all()
            .into_iter()
            .map(|cam| {
                let dom = (cam.model != CameraModel::Equirectangular).then(|| domain(&cam));
                (cam, dom)
            })
            .collect()
    })
}

/// Deterministic proptest configuration: fixed seed, no failure files in the source
/// tree.
pub fn config(cases: u32) -> Config {
    Config {
        cases,
        rng_algorithm: RngAlgorithm::ChaCha,
        rng_seed: RngSeed::Fixed(0x706c_326d_6170),
        failure_persistence: None,
        ..Config::default()
    }
}

/// Whether a pixel is in the image or near it: within half the image size of its
/// border. Near 90 degrees a pinhole or polynomial model sends rays to pixels 1e9 px
/// away, where lifting gives up (as COLMAP's does: its Newton iteration needs more
/// than 100 trust-region steps to come back from there).
pub fn visible(cam: &Camera, px: &Vector2<f64>) -> bool {
    let (w, h) = (cam.width as f64, cam.height as f64);
    px.x >= -0.5 * w && px.x <= 1.5 * w && px.y >= -0.5 * h && px.y <= 1.5 * h
}

fn angle(a: &Vector3<f64>, b: &Vector3<f64>) -> f64 {
    a.cross(b).norm().atan2(a.dot(b))
}

/// Checks one pixel; the image rectangle (and for EQUIRECTANGULAR its open interior)
/// is where pixels are drawn from.
fn check_pixel(cam: &Camera, dom: &Option<Domain>, px: &Vector2<f64>) -> Result<(), String> {
    let lifted = cam.unproject(px);
    let where_ = match dom {
        Some(d) => region(cam, d, px),
        None => Region::Inside,
    };
    match (where_, lifted) {
        (Region::Inside, None) => Err(format!(
            "{cam:?}: {px:?} is in the domain but lifting failed"
        )),
        (Region::Outside, Some(r)) => Err(format!(
            "{cam:?}: {px:?} is outside the domain but lifts to {r:?}"
        )),
        (_, Some(r)) => {
            let back = cam
                .project(&r)
                .ok_or_else(|| format!("{cam:?}: {px:?} lifts to {r:?}, which does not project"))?;
            let err = (back - px).norm();
            if err <= PX_TOL {
                Ok(())
            } else {
                Err(format!(
                    "{cam:?}: {px:?} -> {r:?} -> {back:?}, error {err:e} px"
                ))
            }
        }
        (_, None) => Ok(()),
    }
}

proptest! {
    #![proptest_config(config(600))]

    /// Pixels drawn uniformly over the image: inside the valid domain, lifting succeeds
    /// and projecting the ray gives the pixel back; outside, lifting fails; on the thin
    /// eccentric band in between, whatever lifting returns must still be an inverse.
    #[test]
    fn projecting_a_lifted_pixel_returns_it(
        index in 0..cameras::all().len(),
        fractions in prop::collection::vec((0.0..=1.0f64, 0.0..=1.0f64), 24),
    ) {
        let (cam, dom) = &cameras_with_domains()[index];
        for (fx, fy) in fractions {
            let mut px = Vector2::new(fx * cam.width as f64, fy * cam.height as f64);
            if dom.is_none() {
                // The seam (x = 0 ~ w) and the poles have no unique pixel.
                px.x = px.x.clamp(1e-6, cam.width as f64 - 1e-6);
                px.y = px.y.clamp(1e-6, cam.height as f64 - 1e-6);
            }
            if let Err(e) = check_pixel(cam, dom, &px) {
                prop_assert!(false, "{}", e);
            }
        }
    }

    /// Points drawn over the valid cone (any direction for EQUIRECTANGULAR), at depths
    /// from 1 cm to 1 km: they project, and if visible (see [`visible`]) the pixel
    /// lifts to a ray through them.
    #[test]
    fn lifting_a_projected_point_gives_its_ray(
        index in 0..cameras::all().len(),
        points in prop::collection::vec(
            (0.0..=1.0f64, -std::f64::consts::PI..std::f64::consts::PI, -2.0..3.0f64),
            24,
        ),
    ) {
        let (cam, dom) = &cameras_with_domains()[index];
        for (t, phi, log_depth) in points {
            let theta = match dom {
                Some(d) => t * d.max_angle,
                // Polar angle from +z over the whole sphere.
                None => t * std::f64::consts::PI,
            };
            let x = ray(theta * phi.cos(), theta * phi.sin()) * 10f64.powf(log_depth);
            let px = cam.project(&x);
            prop_assert!(px.is_some(), "{:?}: {:?} in the domain does not project", cam, x);
            if !visible(cam, &px.unwrap()) {
                continue;
            }
            let r = cam.unproject(&px.unwrap());
            prop_assert!(r.is_some(), "{:?}: {:?} -> {:?} does not lift", cam, x, px);
            let err = angle(&r.unwrap(), &x);
            prop_assert!(err <= ANGLE_TOL, "{:?}: {:?} -> {:?} -> {:?}: {:e} rad", cam, x, px, r, err);
        }
    }
}

/// A dense grid over every test image, so the edge of each domain is crossed
/// everywhere; also reports how much of each image the domain covers.
#[test]
fn lifting_inverts_projection_on_an_image_grid() {
    let (nx, ny) = (97, 73);
    for (cam, dom) in cameras_with_domains() {
        let (mut inside, mut outside, mut lifted) = (0, 0, 0);
        for i in 0..nx {
            for j in 0..ny {
                let px = Vector2::new(
                    (i as f64 + 0.5) / nx as f64 * cam.width as f64,
                    (j as f64 + 0.5) / ny as f64 * cam.height as f64,
                );
                check_pixel(cam, dom, &px).unwrap();
                match dom.map(|d| region(cam, &d, &px)) {
                    None | Some(Region::Inside) => inside += 1,
                    Some(Region::Outside) => outside += 1,
                    Some(Region::Edge) => {}
                }
                lifted += cam.unproject(&px).is_some() as usize;
            }
        }
        let n = (nx * ny) as f64;
        eprintln!(
            "{:<26} {:?}: valid up to {:6.2} deg; image in domain {:5.1}%, outside {:5.1}%, \
             lifted {:5.1}%",
            cam.model.name(),
            cam.params,
            dom.map_or(180.0, |d| d.max_angle.to_degrees()),
            100.0 * inside as f64 / n,
            100.0 * outside as f64 / n,
            100.0 * lifted as f64 / n,
        );
    }
}
