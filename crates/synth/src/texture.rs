//! Procedural textures: a floating-point canvas to paint on (multi-scale value noise,
//! anti-aliased ellipses, rectangles and convex polygons, all positioned in metres), and
//! the finished mip-mapped 8-bit texture that the renderer samples trilinearly.
//!
//! Texel `(i, j)` covers local coordinates `[i, i+1) / rho` by `[j, j+1) / rho` metres,
//! so a shape drawn at a position in metres keeps that position exactly (up to the
//! anti-aliasing), whatever the texel density.

use rayon::prelude::*;

pub type Rgb = [f32; 3];

/// Rec. 709 luma of a display-referred colour in [0, 1].
pub fn luma(c: Rgb) -> f32 {
    0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]
}

pub fn mix(a: Rgb, b: Rgb, t: f32) -> Rgb {
    [
        a[0] + (b[0] - a[0]) * t,
        a[1] + (b[1] - a[1]) * t,
        a[2] + (b[2] - a[2]) * t,
    ]
}

/// A colour from hue (0..1), saturation and value.
pub fn hsv(h: f32, s: f32, v: f32) -> Rgb {
    let h = (h.rem_euclid(1.0)) * 6.0;
    let i = h.floor();
    let f = h - i;
    let p = v * (1.0 - s);
    let q = v * (1.0 - s * f);
    let t = v * (1.0 - s * (1.0 - f));
    match i as i32 {
        0 => [v, t, p],
        1 => [q, v, p],
        2 => [p, v, t],
        3 => [p, q, v],
        4 => [t, p, v],
        _ => [v, p, q],
    }
}

pub fn scale(c: Rgb, s: f32) -> Rgb {
    [c[0] * s, c[1] * s, c[2] * s]
}

/// Axis-aligned rectangle in local metres.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rect {
    pub x0: f64,
    pub y0: f64,
    pub x1: f64,
    pub y1: f64,
}

impl Rect {
    pub fn new(x0: f64, y0: f64, x1: f64, y1: f64) -> Self {
        Rect { x0, y0, x1, y1 }
    }
    pub fn width(&self) -> f64 {
        self.x1 - self.x0
    }
    pub fn height(&self) -> f64 {
        self.y1 - self.y0
    }
    pub fn inset(&self, m: f64) -> Rect {
        Rect::new(self.x0 + m, self.y0 + m, self.x1 - m, self.y1 - m)
    }
    /// The four sides as segments (bottom, right, top, left), counter-clockwise.
    pub fn sides(&self) -> [[f64; 4]; 4] {
        [
            [self.x0, self.y0, self.x1, self.y0],
            [self.x1, self.y0, self.x1, self.y1],
            [self.x1, self.y1, self.x0, self.y1],
            [self.x0, self.y1, self.x0, self.y0],
        ]
    }
}

/// 64-bit mix (splitmix64 finaliser): the lattice values of the value noise are pure
/// functions of their integer coordinates, so rows can be filled in any order.
#[inline]
pub fn hash64(mut x: u64) -> u64 {
    x = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
    x = (x ^ (x >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    x = (x ^ (x >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    x ^ (x >> 31)
}

#[inline]
fn lattice(seed: u64, ix: i64, iy: i64) -> f32 {
    let h = hash64(
        seed ^ hash64((ix as u64).wrapping_mul(0x1000_0000_01B3) ^ (iy as u64).rotate_left(32)),
    );
    (h >> 40) as f32 / (1u64 << 24) as f32
}

#[inline]
fn smooth(t: f32) -> f32 {
    t * t * (3.0 - 2.0 * t)
}

/// One octave of value noise: lattice spacing in metres (x and y may differ, which
/// stretches the noise into streaks such as wood grain) and an amplitude.
#[derive(Clone, Copy, Debug)]
pub struct Octave {
    pub scale_x: f64,
    pub scale_y: f64,
    pub amp: f32,
}

impl Octave {
    pub fn iso(scale: f64, amp: f32) -> Self {
        Octave {
            scale_x: scale,
            scale_y: scale,
            amp,
        }
    }
}

/// Floating-point RGB canvas in local metres.
pub struct Canvas {
    pub w: usize,
    pub h: usize,
    pub rho: f64,
    pub data: Vec<Rgb>,
}

impl Canvas {
    /// A canvas covering `size` metres at `rho` texels per metre (at least 1 x 1 texel).
    pub fn new(size: [f64; 2], rho: f64, fill: Rgb) -> Self {
        let w = ((size[0] * rho).ceil() as usize).max(1);
        let h = ((size[1] * rho).ceil() as usize).max(1);
        Canvas {
            w,
            h,
            rho,
            data: vec![fill; w * h],
        }
    }

    /// Texel index range `[lo, hi)` touched by the interval `[a, b]` metres along an axis of `n` texels.
    fn span(&self, a: f64, b: f64, n: usize) -> (usize, usize) {
        let lo = ((a * self.rho).floor().max(0.0) as usize).min(n);
        let hi = (((b * self.rho).ceil().max(0.0)) as usize).min(n);
        (lo, hi)
    }

    /// Texel index range `[lo, hi)` whose centres lie in `[a, b]`.
    fn centre_span(&self, a: f64, b: f64, n: usize) -> (usize, usize) {
        let lo = ((a * self.rho - 0.5).ceil().max(0.0) as usize).min(n);
        let hi = (((b * self.rho - 0.5).floor() + 1.0).max(0.0) as usize).min(n);
        (lo, hi)
    }

    /// Calls `f(texel, noise)` for every texel whose centre lies in `region`, with a sum of
    /// octaves of value noise in [0, sum of amps]; `seed` selects the field. Rows run in
    /// parallel; each value depends only on its position, so the result does not depend on
    /// the thread count.
    pub fn fbm_rows<F>(&mut self, region: Rect, seed: u64, octaves: &[Octave], f: F)
    where
        F: Fn(&mut Rgb, f32) + Sync,
    {
        let rho = self.rho;
        let w = self.w;
        let (x0, x1) = self.centre_span(region.x0, region.x1, self.w);
        let (y0, y1) = self.centre_span(region.y0, region.y1, self.h);
        if x0 >= x1 || y0 >= y1 {
            return;
        }
        self.data
            .par_chunks_mut(w)
            .enumerate()
            .skip(y0)
            .take(y1 - y0)
            .for_each(|(j, row)| {
                let y = (j as f64 + 0.5) / rho;
                let mut acc = vec![0f32; x1 - x0];
                let mut cols: Vec<f32> = Vec::new();
                for (k, o) in octaves.iter().enumerate() {
                    let oseed = hash64(seed ^ (k as u64 + 1).wrapping_mul(0xA24B_AED4_963E_E407));
                    let gy = y / o.scale_y;
                    let iy = gy as i64;
                    let fy = smooth((gy - iy as f64) as f32);
                    // Walk the lattice cells incrementally along the row (no floor per texel).
                    let step = 1.0 / (rho * o.scale_x);
                    let g0 = (x0 as f64 + 0.5) * step;
                    let gx_first = g0.floor() as i64;
                    let gx_last = ((x1 as f64 + 0.5) * step).floor() as i64 + 2;
                    cols.clear();
                    for ix in gx_first..=gx_last {
                        let a = lattice(oseed, ix, iy);
                        let b = lattice(oseed, ix, iy + 1);
                        cols.push(a + (b - a) * fy);
                    }
                    let last = cols.len() - 2;
                    let off = g0 - gx_first as f64;
                    for (n, v) in acc.iter_mut().enumerate() {
                        // Coordinates are >= 0, so truncation is the floor.
                        let gx = n as f64 * step + off;
                        let c = (gx as usize).min(last);
                        let fx = (gx - c as f64) as f32;
                        let (a, b) = (cols[c], cols[c + 1]);
                        *v += (a + (b - a) * smooth(fx.clamp(0.0, 1.0))) * o.amp;
                    }
                }
                for (n, v) in acc.iter().enumerate() {
                    f(&mut row[x0 + n], *v);
                }
            });
    }

    /// Multiplies every texel by `1 + amp * u`, u uniform in [-1, 1] from a per-texel hash.
    pub fn white_noise(&mut self, seed: u64, amp: f32) {
        let w = self.w;
        self.data
            .par_chunks_mut(w)
            .enumerate()
            .for_each(|(j, row)| {
                for (i, t) in row.iter_mut().enumerate() {
                    let h = hash64(seed ^ ((j as u64) << 32 | i as u64));
                    let u = (h >> 40) as f32 / (1u64 << 23) as f32 - 1.0;
                    *t = scale(*t, 1.0 + amp * u);
                }
            });
    }

    /// Anti-aliased filled rectangle (exact area coverage per texel).
    pub fn rect(&mut self, r: Rect, c: Rgb) {
        let (x0, x1) = self.span(r.x0, r.x1, self.w);
        let (y0, y1) = self.span(r.y0, r.y1, self.h);
        let rho = self.rho;
        let cover = |i: usize, lo: f64, hi: f64| -> f32 {
            let a = i as f64 / rho;
            let b = (i + 1) as f64 / rho;
            ((hi.min(b) - lo.max(a)).max(0.0) * rho) as f32
        };
        for j in y0..y1 {
            let cy = cover(j, r.y0, r.y1);
            for i in x0..x1 {
                let alpha = cy * cover(i, r.x0, r.x1);
                let t = &mut self.data[j * self.w + i];
                *t = mix(*t, c, alpha.clamp(0.0, 1.0));
            }
        }
    }

    /// Anti-aliased convex polygon (counter-clockwise or clockwise), 4 x 4 supersampling;
    /// `clip` bounds the painted texels.
    pub fn convex_polygon(&mut self, pts: &[[f64; 2]], clip: Rect, c: Rgb) {
        if pts.len() < 3 {
            return;
        }
        let mut bb = Rect::new(
            f64::INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NEG_INFINITY,
        );
        for p in pts {
            bb.x0 = bb.x0.min(p[0]);
            bb.y0 = bb.y0.min(p[1]);
            bb.x1 = bb.x1.max(p[0]);
            bb.y1 = bb.y1.max(p[1]);
        }
        let bb = Rect::new(
            bb.x0.max(clip.x0),
            bb.y0.max(clip.y0),
            bb.x1.min(clip.x1),
            bb.y1.min(clip.y1),
        );
        if bb.x0 >= bb.x1 || bb.y0 >= bb.y1 {
            return;
        }
        // Orientation-independent inside test.
        let area: f64 = (0..pts.len())
            .map(|k| {
                let p = pts[k];
                let q = pts[(k + 1) % pts.len()];
                p[0] * q[1] - q[0] * p[1]
            })
            .sum();
        let sign = if area >= 0.0 { 1.0 } else { -1.0 };
        let inside = |x: f64, y: f64| {
            (0..pts.len()).all(|k| {
                let p = pts[k];
                let q = pts[(k + 1) % pts.len()];
                sign * ((q[0] - p[0]) * (y - p[1]) - (q[1] - p[1]) * (x - p[0])) >= 0.0
            }) && x >= clip.x0
                && x <= clip.x1
                && y >= clip.y0
                && y <= clip.y1
        };
        let (x0, x1) = self.span(bb.x0, bb.x1, self.w);
        let (y0, y1) = self.span(bb.y0, bb.y1, self.h);
        const N: usize = 4;
        for j in y0..y1 {
            for i in x0..x1 {
                let mut n = 0;
                for sj in 0..N {
                    for si in 0..N {
                        let x = (i as f64 + (si as f64 + 0.5) / N as f64) / self.rho;
                        let y = (j as f64 + (sj as f64 + 0.5) / N as f64) / self.rho;
                        n += inside(x, y) as usize;
                    }
                }
                if n > 0 {
                    let t = &mut self.data[j * self.w + i];
                    *t = mix(*t, c, n as f32 / (N * N) as f32);
                }
            }
        }
    }

    /// Parallel stripes inside `region`: stripe `k` is `bounds[k] <= n . p < bounds[k+1]`
    /// (n unit, bounds ascending) painted `colours[k % len]`; 4 x 4 supersampling near
    /// stripe boundaries and the region's border, flat fill elsewhere.
    pub fn stripes(&mut self, region: Rect, n: [f64; 2], bounds: &[f64], colours: &[Rgb]) {
        if bounds.len() < 2 || colours.is_empty() {
            return;
        }
        let (x0, x1) = self.span(region.x0, region.x1, self.w);
        let (y0, y1) = self.span(region.y0, region.y1, self.h);
        let rho = self.rho;
        let colour_at = |x: f64, y: f64| -> Option<Rgb> {
            if !(x >= region.x0 && x <= region.x1 && y >= region.y0 && y <= region.y1) {
                return None;
            }
            let d = n[0] * x + n[1] * y;
            let k = bounds
                .partition_point(|&b| b <= d)
                .saturating_sub(1)
                .min(bounds.len() - 2);
            Some(colours[k % colours.len()])
        };
        const N: usize = 4;
        let half_diag = std::f64::consts::SQRT_2 * 0.5 / rho;
        for j in y0..y1 {
            for i in x0..x1 {
                let (tx0, ty0) = (i as f64 / rho, j as f64 / rho);
                let (cx, cy) = (tx0 + 0.5 / rho, ty0 + 0.5 / rho);
                let inside_region = tx0 >= region.x0
                    && ty0 >= region.y0
                    && tx0 + 1.0 / rho <= region.x1
                    && ty0 + 1.0 / rho <= region.y1;
                let d = n[0] * cx + n[1] * cy;
                let k = bounds.partition_point(|&b| b <= d);
                let near = [k.wrapping_sub(1), k]
                    .iter()
                    .filter_map(|&m| bounds.get(m))
                    .any(|&b| (b - d).abs() <= half_diag);
                let t = &mut self.data[j * self.w + i];
                if inside_region && !near {
                    if let Some(c) = colour_at(cx, cy) {
                        *t = c;
                    }
                    continue;
                }
                let mut acc = [0f32; 3];
                for sj in 0..N {
                    for si in 0..N {
                        let x = tx0 + (si as f64 + 0.5) / (N as f64 * rho);
                        let y = ty0 + (sj as f64 + 0.5) / (N as f64 * rho);
                        let c = colour_at(x, y).unwrap_or(*t);
                        for ch in 0..3 {
                            acc[ch] += c[ch];
                        }
                    }
                }
                *t = acc.map(|v| v / (N * N) as f32);
            }
        }
    }

    /// Anti-aliased ellipse (or ring of the given thickness) centred at `(cx, cy)` metres.
    pub fn ellipse(&mut self, e: &Ellipse) {
        let r = e.rx.max(e.ry) + e.ring.unwrap_or(0.0);
        let (x0, x1) = self.span(e.cx - r, e.cx + r, self.w);
        let (y0, y1) = self.span(e.cy - r, e.cy + r, self.h);
        let (s, c) = e.angle.sin_cos();
        let rmin = e.rx.min(e.ry);
        // Beyond this radial scale the texel is certainly outside (plus a texel of AA).
        let reject2 = (1.0 + (e.ring.unwrap_or(0.0) * 0.5 + 1.0 / self.rho) / rmin).powi(2);
        for j in y0..y1 {
            let y = (j as f64 + 0.5) / self.rho - e.cy;
            for i in x0..x1 {
                let x = (i as f64 + 0.5) / self.rho - e.cx;
                let xr = c * x + s * y;
                let yr = -s * x + c * y;
                let q2 = (xr / e.rx).powi(2) + (yr / e.ry).powi(2);
                if q2 > reject2 {
                    continue;
                }
                let q = q2.sqrt();
                // Distance to the outline, approximated by the radial scale (exact for circles).
                let d = (q - 1.0) * rmin;
                let d = match e.ring {
                    Some(th) => d.abs() - th * 0.5,
                    None => d,
                };
                let alpha = (0.5 - d * self.rho).clamp(0.0, 1.0) as f32;
                if alpha > 0.0 {
                    let t = &mut self.data[j * self.w + i];
                    *t = mix(*t, e.colour, alpha * e.opacity);
                }
            }
        }
    }

    /// Quantises to 8 bits and builds the mip chain.
    pub fn finish(self) -> Texture {
        let mut base = Vec::with_capacity(self.data.len() * 3);
        for c in &self.data {
            for v in c {
                // Saturating float-to-int cast; + 0.5 rounds (values are >= 0 after the clamp).
                base.push((v.clamp(0.0, 1.0) * 255.0 + 0.5) as u8);
            }
        }
        Texture::from_base(self.w, self.h, self.rho, base)
    }
}

/// An ellipse (filled, or a ring of thickness `ring`) in local metres.
#[derive(Clone, Copy, Debug)]
pub struct Ellipse {
    pub cx: f64,
    pub cy: f64,
    pub rx: f64,
    pub ry: f64,
    pub angle: f64,
    pub ring: Option<f64>,
    pub colour: Rgb,
    pub opacity: f32,
}

/// One mip level: RGB8, row-major.
#[derive(Clone, Debug)]
struct Level {
    w: usize,
    h: usize,
    data: Vec<u8>,
}

/// A mip-mapped RGB8 texture of a quad, addressed in local metres.
#[derive(Clone, Debug)]
pub struct Texture {
    rho: f64,
    levels: Vec<Level>,
}

impl Texture {
    fn from_base(w: usize, h: usize, rho: f64, data: Vec<u8>) -> Self {
        let mut levels = vec![Level { w, h, data }];
        loop {
            let prev = &levels[levels.len() - 1];
            if prev.w == 1 && prev.h == 1 {
                break;
            }
            let nw = prev.w.div_ceil(2);
            let nh = prev.h.div_ceil(2);
            let mut out = vec![0u8; nw * nh * 3];
            for j in 0..nh {
                let ja = (2 * j).min(prev.h - 1);
                let jb = (2 * j + 1).min(prev.h - 1);
                for i in 0..nw {
                    let ia = (2 * i).min(prev.w - 1);
                    let ib = (2 * i + 1).min(prev.w - 1);
                    for ch in 0..3 {
                        let s = prev.data[(ja * prev.w + ia) * 3 + ch] as u32
                            + prev.data[(ja * prev.w + ib) * 3 + ch] as u32
                            + prev.data[(jb * prev.w + ia) * 3 + ch] as u32
                            + prev.data[(jb * prev.w + ib) * 3 + ch] as u32;
                        out[(j * nw + i) * 3 + ch] = ((s + 2) / 4) as u8;
                    }
                }
            }
            levels.push(Level {
                w: nw,
                h: nh,
                data: out,
            });
        }
        Texture { rho, levels }
    }

    /// Texels per metre of the base level.
    pub fn texels_per_metre(&self) -> f64 {
        self.rho
    }

    /// Size of the base level in texels.
    pub fn size(&self) -> (usize, usize) {
        (self.levels[0].w, self.levels[0].h)
    }

    pub fn num_levels(&self) -> usize {
        self.levels.len()
    }

    /// Base-level texel `(i, j)` as RGB in [0, 1] (clamped to the edge).
    pub fn texel(&self, i: usize, j: usize) -> Rgb {
        let l = &self.levels[0];
        let i = i.min(l.w - 1);
        let j = j.min(l.h - 1);
        let k = (j * l.w + i) * 3;
        [
            l.data[k] as f32 / 255.0,
            l.data[k + 1] as f32 / 255.0,
            l.data[k + 2] as f32 / 255.0,
        ]
    }

    fn bilinear(&self, level: usize, a: f64, b: f64) -> Rgb {
        let l = &self.levels[level];
        let s = self.rho / (1u64 << level) as f64;
        let x = (a * s - 0.5).clamp(0.0, (l.w - 1) as f64);
        let y = (b * s - 0.5).clamp(0.0, (l.h - 1) as f64);
        // Non-negative after the clamp: truncation is the floor.
        let x0 = x as usize;
        let y0 = y as usize;
        let x1 = (x0 + 1).min(l.w - 1);
        let y1 = (y0 + 1).min(l.h - 1);
        let fx = (x - x0 as f64) as f32;
        let fy = (y - y0 as f64) as f32;
        let r0 = &l.data[y0 * l.w * 3..(y0 + 1) * l.w * 3];
        let r1 = &l.data[y1 * l.w * 3..(y1 + 1) * l.w * 3];
        let mut out = [0f32; 3];
        for (ch, o) in out.iter_mut().enumerate() {
            let (p00, p10) = (r0[x0 * 3 + ch] as f32, r0[x1 * 3 + ch] as f32);
            let (p01, p11) = (r1[x0 * 3 + ch] as f32, r1[x1 * 3 + ch] as f32);
            let top = p00 + (p10 - p00) * fx;
            let bot = p01 + (p11 - p01) * fx;
            *o = (top + (bot - top) * fy) * (1.0 / 255.0);
        }
        out
    }

    /// Trilinear sample at local `(a, b)` metres for a pixel footprint of `footprint_m`
    /// metres on the surface (the level of detail is log2 of the footprint in texels).
    pub fn sample(&self, a: f64, b: f64, footprint_m: f64) -> Rgb {
        let lod = ((footprint_m * self.rho).max(1.0) as f32).log2();
        let max = (self.levels.len() - 1) as f32;
        let lod = lod.min(max);
        let l0 = lod as usize;
        let f = lod - l0 as f32;
        let c0 = self.bilinear(l0, a, b);
        if f <= 1e-3 || l0 + 1 >= self.levels.len() {
            return c0;
        }
        let c1 = self.bilinear(l0 + 1, a, b);
        mix(c0, c1, f)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rect_coverage_is_exact_area() {
        let mut c = Canvas::new([0.1, 0.1], 100.0, [0.0; 3]);
        // Covers texel 2 fully and a quarter of texel 3 along x; half of texel 5 along y.
        c.rect(Rect::new(0.02, 0.055, 0.0325, 0.06), [1.0; 3]);
        assert!((c.data[5 * 10 + 2][0] - 0.5).abs() < 1e-5);
        assert!((c.data[5 * 10 + 3][0] - 0.125).abs() < 1e-5);
        assert_eq!(c.data[4 * 10 + 2][0], 0.0);
    }

    #[test]
    fn mip_levels_average() {
        let mut c = Canvas::new([0.04, 0.02], 100.0, [0.0; 3]);
        c.rect(Rect::new(0.0, 0.0, 0.02, 0.02), [1.0; 3]);
        let t = c.finish();
        // 4 x 2 -> 2 x 1 -> 1 x 1.
        assert_eq!(t.num_levels(), 3);
        let coarse = t.sample(0.02, 0.01, 100.0);
        assert!((coarse[0] - 0.5).abs() < 0.01, "{coarse:?}");
        // Fine level keeps the edge at x = 0.02 m: left and right halves differ.
        let l = t.sample(0.005, 0.01, 0.0);
        let r = t.sample(0.035, 0.01, 0.0);
        assert!(l[0] > 0.99 && r[0] < 0.01);
    }

    #[test]
    fn noise_is_row_order_independent_and_bounded() {
        let oct = [Octave::iso(0.05, 0.6), Octave::iso(0.01, 0.4)];
        let mut a = Canvas::new([0.3, 0.2], 200.0, [0.0; 3]);
        a.fbm_rows(Rect::new(0.0, 0.0, 0.3, 0.2), 42, &oct, |t, v| t[0] = v);
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap();
        let mut b = Canvas::new([0.3, 0.2], 200.0, [0.0; 3]);
        pool.install(|| b.fbm_rows(Rect::new(0.0, 0.0, 0.3, 0.2), 42, &oct, |t, v| t[0] = v));
        assert_eq!(a.data, b.data);
        let (lo, hi) = a.data.iter().fold((f32::MAX, f32::MIN), |(lo, hi), t| {
            (lo.min(t[0]), hi.max(t[0]))
        });
        assert!(lo >= 0.0 && hi <= 1.0 && hi - lo > 0.3, "{lo} {hi}");
    }
}
