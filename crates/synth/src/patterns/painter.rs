//! The painter every recipe draws with: the canvas, the recipe's seed and the list of
//! straight steps drawn so far, and its tools: value-noise fills and modulation,
//! scattered blobs, listed rectangle borders, the final grain, random and contrasting
//! colours.

use crate::texture::{Canvas, Ellipse, Octave, Rect, Rgb, hash64, hsv, luma, mix, scale};
use rand::Rng;
use rand_chacha::ChaCha8Rng;

/// A straight intensity step inside a texture, in local metres.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LocalEdge {
    pub a: [f64; 2],
    pub b: [f64; 2],
    /// Luma difference of the flat colours on both sides (0..1).
    pub contrast: f32,
}

pub(super) fn random_colour(rng: &mut ChaCha8Rng, s: (f32, f32), v: (f32, f32)) -> Rgb {
    hsv(
        rng.random::<f32>(),
        rng.random_range(s.0..s.1),
        rng.random_range(v.0..v.1),
    )
}

/// A colour whose luma differs from `from` by at least `min` (tries, then falls back to
/// black or white, whichever is farther).
pub(super) fn contrasting(rng: &mut ChaCha8Rng, from: Rgb, min: f32, s: (f32, f32)) -> Rgb {
    for _ in 0..32 {
        let c = random_colour(rng, s, (0.15, 1.0));
        if (luma(c) - luma(from)).abs() >= min {
            return c;
        }
    }
    if luma(from) > 0.5 {
        [0.08; 3]
    } else {
        [0.95; 3]
    }
}

pub(super) struct Painter {
    pub(super) canvas: Canvas,
    pub(super) size: [f64; 2],
    pub(super) edges: Vec<LocalEdge>,
    pub(super) seed: u64,
}

impl Painter {
    pub(super) fn full(&self) -> Rect {
        Rect::new(0.0, 0.0, self.size[0], self.size[1])
    }

    pub(super) fn sub_seed(&self, k: u64) -> u64 {
        hash64(self.seed ^ k.wrapping_mul(0xD6E8_FEB8_6659_FD93))
    }

    pub(super) fn rect_edges(&mut self, r: Rect, contrast: f32) {
        for s in r.sides() {
            self.edges.push(LocalEdge {
                a: [s[0], s[1]],
                b: [s[2], s[3]],
                contrast,
            });
        }
    }

    /// Per-texel multiplicative grain on everything (+-3 %): fine texture at close range
    /// that moves no edge.
    pub(super) fn grain(&mut self) {
        let seed = self.sub_seed(999);
        self.canvas.white_noise(seed, 0.03);
    }

    /// Two-colour value-noise background over `region`.
    pub(super) fn noise_fill(
        &mut self,
        region: Rect,
        c0: Rgb,
        c1: Rgb,
        octaves: &[Octave],
        k: u64,
    ) {
        let seed = self.sub_seed(k);
        let total: f32 = octaves.iter().map(|o| o.amp).sum();
        self.canvas.fbm_rows(region, seed, octaves, |t, v| {
            let x = (v / total - 0.5) * 2.2 + 0.5;
            *t = mix(c0, c1, x.clamp(0.0, 1.0));
        });
    }

    /// Luminance modulation by value noise inside `region` (factor in [1-amp, 1+amp]).
    pub(super) fn modulate(&mut self, region: Rect, amp: f32, octaves: &[Octave], k: u64) {
        let seed = self.sub_seed(k);
        let total: f32 = octaves.iter().map(|o| o.amp).sum();
        self.canvas.fbm_rows(region, seed, octaves, |t, v| {
            *t = scale(*t, 1.0 + amp * ((v / total) * 2.0 - 1.0));
        });
    }

    /// Scatters ellipses, rings and dots inside `region` (kept `margin` inside it):
    /// `coverage` is the expected fraction of area covered, radii log-uniform.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn blobs(
        &mut self,
        rng: &mut ChaCha8Rng,
        region: Rect,
        margin: f64,
        radii: (f64, f64),
        coverage: f64,
        palette: &[Rgb],
        ring_prob: f64,
        opacity: (f32, f32),
    ) {
        let inner = region.inset(margin);
        if inner.width() <= 2.0 * radii.0 || inner.height() <= 2.0 * radii.0 || palette.is_empty() {
            return;
        }
        let (l0, l1) = (radii.0.ln(), radii.1.ln());
        // Mean of r^2 under a log-uniform law.
        let mean_r2 = if (l1 - l0).abs() < 1e-9 {
            radii.0 * radii.0
        } else {
            (radii.1 * radii.1 - radii.0 * radii.0) / (2.0 * (l1 - l0))
        };
        let area = inner.width() * inner.height();
        let n = (coverage * area / (std::f64::consts::PI * mean_r2 * 0.75)).round() as usize;
        let n = n.min(200_000);
        for _ in 0..n {
            let r = rng.random_range(l0..=l1).exp();
            let aspect = rng.random_range(0.45..1.0);
            let rmax = r.min(inner.width() * 0.5).min(inner.height() * 0.5);
            let cx = uniform(rng, inner.x0 + rmax, inner.x1 - rmax);
            let cy = uniform(rng, inner.y0 + rmax, inner.y1 - rmax);
            let colour = palette[rng.random_range(0..palette.len())];
            let colour = scale(colour, rng.random_range(0.8..1.15));
            let ring = if rng.random_bool(ring_prob) {
                Some(rmax * rng.random_range(0.15..0.4))
            } else {
                None
            };
            let ring_pad = ring.unwrap_or(0.0) * 0.5;
            let rx = (rmax - ring_pad).max(1e-4);
            self.canvas.ellipse(&Ellipse {
                cx,
                cy,
                rx,
                ry: rx * aspect,
                angle: rng.random_range(0.0..std::f64::consts::PI),
                ring,
                colour,
                opacity: rng.random_range(opacity.0..=opacity.1),
            });
        }
    }
}

/// Uniform in `[lo, hi]`, or `lo` when rounding made the range empty.
fn uniform(rng: &mut ChaCha8Rng, lo: f64, hi: f64) -> f64 {
    if hi > lo {
        rng.random_range(lo..=hi)
    } else {
        lo
    }
}
