//! Exact-visibility renderer for PINHOLE cameras.
//!
//! Every pixel takes 5 samples: its centre (COLMAP convention, pixel `(i, j)` has its
//! centre at `(i + 0.5, j + 0.5)`) and a 4-sample rotated grid. Each quad is scanned over
//! the pixels its projection covers; a sample belongs to the quad when its ray meets the
//! quad's plane inside the rectangle, in front of the camera, nearer than what the sample
//! holds (ties keep the lower quad index, as [`Scene::raycast`] does). Visibility is thus
//! decided per sample by the same ray-rectangle test as the ray cast, not by interpolated
//! depths. Shading is then done once per pixel and visible quad (trilinear texture lookup
//! with the pixel footprint as level of detail, flat per-face shading) and weighted by the
//! quad's sample count. The depth map is the camera-frame z of the centre sample's hit.

use super::error::{Result, SynthError};
use super::scene::Scene;
use super::texture::Rgb;
use geometry::{Camera, CameraModel, Pose};
use image::{ImageBuffer, Luma, RgbImage};
use nalgebra::{Matrix3, Vector3};

/// Sample positions relative to the pixel's top-left corner: centre, then rotated grid.
pub const SAMPLES: [(f64, f64); 5] = [
    (0.5, 0.5),
    (0.875, 0.625),
    (0.375, 0.875),
    (0.125, 0.375),
    (0.625, 0.125),
];
const S: usize = SAMPLES.len();

/// Nearest distance (camera z) that is drawn.
pub const NEAR_Z: f64 = 1e-3;

/// `quad_ids` value of a pixel whose centre ray hits nothing.
pub const NO_SURFACE: u32 = u32::MAX;

/// Depth PNG value where there is no surface (7-Scenes convention).
pub const DEPTH_INVALID_MM: u16 = 65535;

/// A rendered frame.
#[derive(Clone, Debug)]
pub struct Rendered {
    pub width: u32,
    pub height: u32,
    pub rgb: RgbImage,
    /// Camera-frame z (metres) of the surface seen through each pixel centre, row-major;
    /// 0.0 where the centre ray hits nothing.
    pub depth_m: Vec<f32>,
    /// The quad seen through each pixel centre ([`NO_SURFACE`] if none), row-major.
    pub quad_ids: Vec<u32>,
}

impl Rendered {
    /// 16-bit depth in millimetres, [`DEPTH_INVALID_MM`] where there is no surface or the
    /// depth does not fit.
    pub fn depth_mm(&self) -> ImageBuffer<Luma<u16>, Vec<u16>> {
        let data = self
            .depth_m
            .iter()
            .map(|&z| {
                let mm = (z as f64 * 1000.0).round();
                if z > 0.0 && mm < DEPTH_INVALID_MM as f64 {
                    mm as u16
                } else {
                    DEPTH_INVALID_MM
                }
            })
            .collect();
        ImageBuffer::from_raw(self.width, self.height, data).expect("buffer size matches")
    }
}

/// A quad's plane and extent in the camera frame, with the linear forms (in pixel
/// coordinates) that the per-sample test evaluates.
struct CamQuad {
    /// n . d = na * px + nb * py + nc, for the ray d = ((px-cx)/fx, (py-cy)/fy, 1).
    n: [f64; 3],
    h: f64,
    /// u . d and v . d as linear forms, and u . o, v . o.
    u: [f64; 3],
    v: [f64; 3],
    a0: f64,
    b0: f64,
    size: [f64; 2],
}

/// Pinhole intrinsics.
#[derive(Clone, Copy)]
pub(crate) struct Intr {
    fx: f64,
    fy: f64,
    cx: f64,
    cy: f64,
}

impl Intr {
    /// Linear form of `w . d(px, py)` for a camera-frame vector `w`.
    fn form(&self, w: &Vector3<f64>) -> [f64; 3] {
        [
            w.x / self.fx,
            w.y / self.fy,
            w.z - w.x * self.cx / self.fx - w.y * self.cy / self.fy,
        ]
    }
}

#[inline]
fn eval(f: &[f64; 3], px: f64, py: f64) -> f64 {
    f[0] * px + f[1] * py + f[2]
}

pub(crate) fn check_camera(camera: &Camera) -> Result<Intr> {
    // The size first: `Camera::validate` refuses a size of 0 too.
    if !(1..=16384).contains(&camera.width) || !(1..=16384).contains(&camera.height) {
        return Err(SynthError::InvalidCameraSize {
            width: camera.width,
            height: camera.height,
        });
    }
    if camera.model != CameraModel::Pinhole || camera.validate().is_err() {
        return Err(SynthError::UnsupportedCamera(
            camera.model.name().to_string(),
        ));
    }
    let p = &camera.params;
    if !(p[0] > 0.0 && p[1] > 0.0) {
        return Err(SynthError::UnsupportedCamera(
            "PINHOLE with non-positive focal length".into(),
        ));
    }
    Ok(Intr {
        fx: p[0],
        fy: p[1],
        cx: p[2],
        cy: p[3],
    })
}

impl Scene {
    /// Renders the view of `camera` (PINHOLE) at the world-to-camera `pose`.
    pub fn render(&self, camera: &Camera, pose: &Pose) -> Result<Rendered> {
        let k = check_camera(camera)?;
        if !pose.is_finite() {
            return Err(SynthError::NonFinitePose);
        }
        let (w, h) = (camera.width as usize, camera.height as usize);
        let r: Matrix3<f64> = pose.rotation_matrix();
        let t = pose.translation;

        let mut zbuf = vec![f64::INFINITY; w * h * S];
        let mut ids = vec![NO_SURFACE; w * h * S];
        let mut cam_quads = Vec::with_capacity(self.quads.len());
        let mut spans: Vec<(i64, i64)> = vec![(0, -1); h];
        for (qi, q) in self.quads.iter().enumerate() {
            let o = r * q.origin + t;
            let n = r * q.normal;
            let hh = n.dot(&o);
            // The camera must be on the visible side of the plane.
            if hh.is_nan() || hh >= 0.0 {
                cam_quads.push(None);
                continue;
            }
            let u = r * q.u;
            let v = r * q.v;
            let cq = CamQuad {
                n: k.form(&n),
                h: hh,
                u: k.form(&u),
                v: k.form(&v),
                a0: u.dot(&o),
                b0: v.dot(&o),
                size: q.size,
            };
            let du = u * q.size[0];
            let dv = v * q.size[1];
            let corners = [o, o + du, o + du + dv, o + dv];
            if !row_spans(&corners, &k, w, h, &mut spans) {
                cam_quads.push(Some(cq));
                continue;
            }
            for (j, &(x0, x1)) in spans.iter().enumerate() {
                if x0 > x1 {
                    continue;
                }
                for i in x0 as usize..=x1 as usize {
                    let base = (j * w + i) * S;
                    for (s, &(sx, sy)) in SAMPLES.iter().enumerate() {
                        let px = i as f64 + sx;
                        let py = j as f64 + sy;
                        let nd = eval(&cq.n, px, py);
                        // z = h / nd with h, nd < 0: z < zbuf <=> h > zbuf * nd, which
                        // rejects hidden samples without a division.
                        let visible_side = nd < 0.0;
                        if !visible_side || cq.h <= zbuf[base + s] * nd || nd.is_nan() {
                            continue;
                        }
                        let z = cq.h / nd;
                        if z <= NEAR_Z || z >= zbuf[base + s] {
                            continue;
                        }
                        let a = z * eval(&cq.u, px, py) - cq.a0;
                        if !(a >= 0.0 && a <= cq.size[0]) {
                            continue;
                        }
                        let b = z * eval(&cq.v, px, py) - cq.b0;
                        if !(b >= 0.0 && b <= cq.size[1]) {
                            continue;
                        }
                        zbuf[base + s] = z;
                        ids[base + s] = qi as u32;
                    }
                }
            }
            cam_quads.push(Some(cq));
        }

        let mut rgb = RgbImage::new(w as u32, h as u32);
        let mut depth_m = vec![0f32; w * h];
        let mut quad_ids = vec![NO_SURFACE; w * h];
        let buf: &mut [u8] = &mut rgb;
        for j in 0..h {
            for i in 0..w {
                let base = (j * w + i) * S;
                let sid = &ids[base..base + S];
                quad_ids[j * w + i] = sid[0];
                if sid[0] != NO_SURFACE {
                    depth_m[j * w + i] = zbuf[base] as f32;
                }
                let mut acc = [0f32; 3];
                let mut done = [false; S];
                for s in 0..S {
                    let qi = sid[s];
                    if done[s] || qi == NO_SURFACE {
                        continue;
                    }
                    // Shade once per visible quad, at the mean of its samples.
                    let (mut mx, mut my, mut cnt) = (0.0, 0.0, 0usize);
                    for s2 in s..S {
                        if sid[s2] == qi {
                            done[s2] = true;
                            mx += SAMPLES[s2].0;
                            my += SAMPLES[s2].1;
                            cnt += 1;
                        }
                    }
                    let px = i as f64 + mx / cnt as f64;
                    let py = j as f64 + my / cnt as f64;
                    let Some(cq) = &cam_quads[qi as usize] else {
                        continue;
                    };
                    let c = self.shade_at(qi, cq, px, py);
                    let wgt = cnt as f32 / S as f32;
                    for ch in 0..3 {
                        acc[ch] += c[ch] * wgt;
                    }
                }
                let o = (j * w + i) * 3;
                for ch in 0..3 {
                    buf[o + ch] = (acc[ch] * 255.0).round().clamp(0.0, 255.0) as u8;
                }
            }
        }
        Ok(Rendered {
            width: w as u32,
            height: h as u32,
            rgb,
            depth_m,
            quad_ids,
        })
    }

    fn shade_at(&self, qi: u32, cq: &CamQuad, px: f64, py: f64) -> Rgb {
        let q = &self.quads[qi as usize];
        let nd = eval(&cq.n, px, py);
        let z = cq.h / nd;
        let ud = eval(&cq.u, px, py);
        let vd = eval(&cq.v, px, py);
        let a = (z * ud - cq.a0).clamp(0.0, q.size[0]);
        let b = (z * vd - cq.b0).clamp(0.0, q.size[1]);
        // Derivatives of (a, b) per pixel step: d(zU)/dpx = z (U_x - U n_x / N).
        let dax = z * (cq.u[0] - ud * cq.n[0] / nd);
        let dbx = z * (cq.v[0] - vd * cq.n[0] / nd);
        let day = z * (cq.u[1] - ud * cq.n[1] / nd);
        let dby = z * (cq.v[1] - vd * cq.n[1] / nd);
        let foot = (dax * dax + dbx * dbx).max(day * day + dby * dby).sqrt();
        let c = self.textures[q.texture as usize].sample(a, b, foot);
        [c[0] * q.shade, c[1] * q.shade, c[2] * q.shade]
    }
}

/// Per-row pixel spans `[x0, x1]` (inclusive, x0 > x1 for none) that contain every sample
/// of the polygon `corners` (camera frame) after clipping at `NEAR_Z`; false when nothing
/// of it is in view.
fn row_spans(
    corners: &[Vector3<f64>; 4],
    k: &Intr,
    w: usize,
    h: usize,
    spans: &mut [(i64, i64)],
) -> bool {
    // Clip against z >= NEAR_Z (Sutherland-Hodgman on one plane).
    let mut poly: Vec<Vector3<f64>> = Vec::with_capacity(6);
    for idx in 0..4 {
        let p = corners[idx];
        let q = corners[(idx + 1) % 4];
        let pin = p.z >= NEAR_Z;
        let qin = q.z >= NEAR_Z;
        if pin {
            poly.push(p);
        }
        if pin != qin {
            let s = (NEAR_Z - p.z) / (q.z - p.z);
            poly.push(p + (q - p) * s);
        }
    }
    for s in spans.iter_mut() {
        *s = (i64::MAX, i64::MIN);
    }
    if poly.len() < 3 {
        return false;
    }
    let pts: Vec<(f64, f64)> = poly
        .iter()
        .map(|p| (k.fx * p.x / p.z + k.cx, k.fy * p.y / p.z + k.cy))
        .collect();
    let ymin = pts.iter().map(|p| p.1).fold(f64::INFINITY, f64::min);
    let ymax = pts.iter().map(|p| p.1).fold(f64::NEG_INFINITY, f64::max);
    if !(ymin.is_finite() && ymax.is_finite()) {
        return false;
    }
    // One pixel of margin on every side absorbs rounding in the projection.
    let j0 = (ymin.floor() as i64 - 1).max(0);
    let j1 = (ymax.ceil() as i64 + 1).min(h as i64 - 1);
    if j0 > j1 {
        return false;
    }
    let mut any = false;
    for j in j0..=j1 {
        let (b0, b1) = (j as f64 - 1.0, j as f64 + 2.0);
        let mut xmin = f64::INFINITY;
        let mut xmax = f64::NEG_INFINITY;
        for e in 0..pts.len() {
            let (p, q) = (pts[e], pts[(e + 1) % pts.len()]);
            // Clip the edge to the band b0 <= y <= b1 and take its x extent.
            let (lo, hi) = if p.1 <= q.1 { (p, q) } else { (q, p) };
            if hi.1 < b0 || lo.1 > b1 {
                continue;
            }
            let x_at = |y: f64| {
                if (hi.1 - lo.1).abs() < 1e-12 {
                    (lo.0, hi.0)
                } else {
                    let x = lo.0 + (hi.0 - lo.0) * (y - lo.1) / (hi.1 - lo.1);
                    (x, x)
                }
            };
            let ya = lo.1.max(b0);
            let yb = hi.1.min(b1);
            for (x1, x2) in [x_at(ya), x_at(yb)] {
                xmin = xmin.min(x1.min(x2));
                xmax = xmax.max(x1.max(x2));
            }
        }
        if xmin > xmax {
            continue;
        }
        let x0 = (xmin.floor() as i64 - 1).max(0);
        let x1 = (xmax.ceil() as i64 + 1).min(w as i64 - 1);
        if x0 <= x1 {
            spans[j as usize] = (x0, x1);
            any = true;
        }
    }
    any
}
