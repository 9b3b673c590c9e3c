//! SIFT-style descriptors sampled from one dense map per image ("dense SIFT").
//!
//! OpenCV's SIFT descriptor at the front-end's fixed size of 12 px loops over a
//! 129 x 129 px window for every keypoint (about 0.1 ms each); a query has 3,000-4,000
//! of them, most of them line samples (docs/performance.md, "Localisation"). Here the
//! work that does not depend on the keypoint is done once per image, as the paper does
//! with SuperPoint's dense descriptor map (docs/method.md section 2b):
//!
//! 1. the grey image blurred to the scale of SIFT's first pyramid level (sigma 1.6,
//!    the camera's blur taken as 0.5, as OpenCV's SIFT does);
//! 2. the gradient at every pixel (central differences, y up as in SIFT) split over 8
//!    orientation channels, each gradient's magnitude shared linearly between the two channels
//!    nearest its angle (SIFT's orientation interpolation);
//! 3. each channel pooled with SIFT's spatial kernel, a separable triangle as wide as
//!    two histogram cells (SIFT's bilinear spatial interpolation), as two box filters
//!    per axis (running sums, O(1) per pixel whatever the cell width).
//!
//! A descriptor is then 4 x 4 cells x 8 orientations read from the pooled channels at
//! the cell centres (bilinear), each cell weighted by SIFT's Gaussian window taken at
//! its centre (sigma = 2 cells), normalised, clipped at 0.2 and normalised again
//! (Lowe 2004). Rotated descriptors (line samples, oriented along their segment) place
//! the cell centres on the rotated grid and shift the orientation channels by the angle,
//! interpolating between the two nearest (the pooling kernel is not rotated, an
//! approximation that keeps the cost per descriptor at 16 bilinear reads).
//!
//! The values differ from OpenCV's (the Gaussian window per cell instead of per pixel,
//! the unrotated pooling kernel, zero gradient at the image border); a map trained on
//! one kind of descriptor cannot be queried with the other, which is why the method is
//! part of the front-end's configuration and of every checkpoint
//! (`DescriptorConfig::method`). Arithmetic is plain f32/f64 in a fixed order with no
//! library transcendental on the per-pixel path, so a descriptor is the same bytes on
//! every machine and for any thread count.

use crate::SIFT_DIM;
use image::GrayImage;

/// Cells per side of the descriptor grid (SIFT's d).
const GRID: usize = 4;
/// Orientation channels (SIFT's n).
const ORIENTATIONS: usize = 8;
/// SIFT's histogram cell width in units of the keypoint's scale (size / 2).
const CELL_PER_SCALE: f64 = 3.0;
/// The blur of SIFT's first pyramid level and the blur assumed of the camera.
const BASE_SIGMA: f64 = 1.6;
const CAMERA_SIGMA: f64 = 0.5;
/// Lowe's clip of the normalised descriptor.
const CLIP: f32 = 0.2;

/// The grey image at the blur of SIFT's first pyramid level: what every pooled map of
/// an image starts from (built once per image, beside the detectors).
#[derive(Clone, Debug)]
pub struct OrientedGradients {
    width: usize,
    height: usize,
    blurred: Vec<f32>,
}

/// The channels pooled for one descriptor size: what descriptors are read from.
#[derive(Clone, Debug)]
pub struct DenseMap {
    /// The pooled grid: every `STEP`-th pixel of every `STEP`-th row.
    width: usize,
    height: usize,
    /// Histogram cell width in pixels.
    cell: f64,
    /// width x height x 8, interleaved.
    pooled: Vec<f32>,
}

/// The pooled map keeps every second pixel of every second row: the pooling kernel is
/// 2 x 18 px wide at the default size, so bilinear reads between grid points lose
/// nothing measurable (median cosine to OpenCV's SIFT unchanged, the test
/// `dense_descriptors_approximate_opencv_sift`) and the map costs a quarter.
const STEP: usize = 2;

type Px = [f32; ORIENTATIONS];
const ZERO: Px = [0.0; ORIENTATIONS];

impl OrientedGradients {
    /// The blurred image of a grey image.
    pub fn new(img: &GrayImage) -> Self {
        let (width, height) = (img.width() as usize, img.height() as usize);
        let pixels: Vec<f32> = img.as_raw().iter().map(|&v| f32::from(v)).collect();
        let sigma = (BASE_SIGMA * BASE_SIGMA - CAMERA_SIGMA * CAMERA_SIGMA).sqrt();
        let blurred = gaussian_blur(&pixels, width, height, sigma);
        OrientedGradients {
            width,
            height,
            blurred,
        }
    }

    /// Row `y`'s gradients split over the 8 orientation channels (`out`: width x 8).
    /// The border rows and columns have no central difference: zero gradient there, as
    /// OpenCV's SIFT skips them.
    fn channel_row(&self, y: usize, out: &mut [f32]) {
        out.iter_mut().for_each(|v| *v = 0.0);
        let w = self.width;
        if y == 0 || y + 1 >= self.height || w < 3 {
            return;
        }
        let b = &self.blurred;
        let (up, row, down) = (
            &b[(y - 1) * w..y * w],
            &b[y * w..(y + 1) * w],
            &b[(y + 1) * w..(y + 2) * w],
        );
        for x in 1..w - 1 {
            // SIFT's convention (Lowe's and OpenCV's): y up, so that orientation o is
            // o * 45 deg counter-clockwise on the screen.
            let dx = row[x + 1] - row[x - 1];
            let dy = up[x] - down[x];
            let mag = (dx * dx + dy * dy).sqrt();
            if mag == 0.0 {
                continue;
            }
            let bin = orientation_bins(dx, dy);
            let lo = bin as usize;
            let f = bin - lo as f32;
            let px = &mut out[x * ORIENTATIONS..(x + 1) * ORIENTATIONS];
            px[lo & 7] = mag * (1.0 - f);
            px[(lo + 1) & 7] = mag * f;
        }
    }

    /// The channels pooled for descriptors of keypoint size `size` (OpenCV's keypoint
    /// "size", a diameter in pixels; the cell is 3 * size / 2 px wide): the separable
    /// triangle (half - |k|, |k| < half, half = the cell width) along each row, then
    /// down the columns, streamed row by row through a ring of 2 half + 2 rows.
    pub fn pool(&self, size: f32) -> DenseMap {
        let cell = CELL_PER_SCALE * f64::from(size) * 0.5;
        let half = (cell.round() as usize).max(1);
        let (w, h) = (self.width, self.height);
        let (mw, mh) = (w.div_ceil(STEP), h.div_ceil(STEP));
        let row_len = mw * ORIENTATIONS;
        let ring = 2 * half + 2;
        let mut rows = vec![0f32; ring * row_len];
        let mut channels = vec![0f32; w * ORIENTATIONS];
        let mut made = 0usize;
        // Makes the row-pooled rows up to `y` (those past the image stay zero).
        let mut make_until = |y: usize, rows: &mut [f32]| {
            while made <= y {
                let slot = &mut rows[(made % ring) * row_len..][..row_len];
                if made < h {
                    self.channel_row(made, &mut channels);
                    triangle_stream(&channels, w, half, slot);
                } else {
                    slot.iter_mut().for_each(|v| *v = 0.0);
                }
                made += 1;
            }
        };
        let get = |y: isize| -> Option<std::ops::Range<usize>> {
            (y >= 0 && (y as usize) < h)
                .then(|| (y as usize % ring) * row_len..(y as usize % ring + 1) * row_len)
        };
        // T(y) = sum_k (half - |k|) g(y + k); T(y + 1) = T(y) + R(y) - L(y) with
        // R(y) = g(y + 1) + .. + g(y + half), L(y) = g(y - half + 1) + .. + g(y).
        let mut t = vec![0f32; row_len];
        let mut r = vec![0f32; row_len];
        let mut l = vec![0f32; row_len];
        make_until(half + 1, &mut rows);
        for k in 0..half as isize {
            if let Some(g) = get(k) {
                add_rows(&mut t, &rows[g.clone()], (half as isize - k) as f32);
                if k == 0 {
                    add_rows(&mut l, &rows[g], 1.0);
                }
            }
        }
        for m in 1..=half as isize {
            if let Some(g) = get(m) {
                add_rows(&mut r, &rows[g], 1.0);
            }
        }
        let mut pooled = vec![0f32; mh * row_len];
        for y in 0..h {
            if y.is_multiple_of(STEP) {
                pooled[(y / STEP) * row_len..][..row_len].copy_from_slice(&t);
            }
            if y + 1 == h {
                break;
            }
            for ((tv, rv), lv) in t.iter_mut().zip(&r).zip(&l) {
                *tv += rv - lv;
            }
            make_until(y + 1 + half, &mut rows);
            let y = y as isize;
            let half = half as isize;
            if let Some(g) = get(y + 1 + half) {
                add_rows(&mut r, &rows[g], 1.0);
            }
            if let Some(g) = get(y + 1) {
                add_rows(&mut r, &rows[g.clone()], -1.0);
                add_rows(&mut l, &rows[g], 1.0);
            }
            if let Some(g) = get(y + 1 - half) {
                add_rows(&mut l, &rows[g], -1.0);
            }
        }
        DenseMap {
            width: mw,
            height: mh,
            cell,
            pooled,
        }
    }
}

/// The triangle filter (half - |k|, |k| < half, zero outside) along one row of `n`
/// pixels of 8 channels, written at every `STEP`-th pixel into `out`: the same
/// running-sum recurrence as the columns of [`OrientedGradients::pool`].
fn triangle_stream(src: &[f32], n: usize, half: usize, out: &mut [f32]) {
    let g = |i: isize| -> Px {
        if i < 0 || i as usize >= n {
            ZERO
        } else {
            let i = i as usize;
            src[i * ORIENTATIONS..(i + 1) * ORIENTATIONS]
                .try_into()
                .expect("8 channels")
        }
    };
    let (mut t, mut r, mut l) = (ZERO, ZERO, ZERO);
    for k in 0..half as isize {
        add_rows(&mut t, &g(k), (half as isize - k) as f32);
    }
    add_rows(&mut l, &g(0), 1.0);
    for m in 1..=half as isize {
        add_rows(&mut r, &g(m), 1.0);
    }
    let half = half as isize;
    for i in 0..n as isize {
        if (i as usize).is_multiple_of(STEP) {
            out[(i as usize / STEP) * ORIENTATIONS..][..ORIENTATIONS].copy_from_slice(&t);
        }
        for c in 0..ORIENTATIONS {
            t[c] += r[c] - l[c];
        }
        let next = g(i + 1);
        add_rows(&mut r, &g(i + 1 + half), 1.0);
        add_rows(&mut r, &next, -1.0);
        add_rows(&mut l, &next, 1.0);
        add_rows(&mut l, &g(i + 1 - half), -1.0);
    }
}

impl DenseMap {
    /// The 128-d descriptor at `xy` (COLMAP pixels) with its x axis along the image
    /// angle `angle_deg` (OpenCV's keypoint angle: degrees from +x towards +y). Row
    /// layout as SIFT's: (cell row, cell column, orientation). L2-normalised (zero when
    /// the window holds no gradient).
    pub fn describe(&self, xy: [f64; 2], angle_deg: f32, out: &mut [f32]) {
        debug_assert_eq!(out.len(), SIFT_DIM);
        // Pixel-index coordinates (centre of the top-left pixel at 0).
        let (cx, cy) = (xy[0] - 0.5, xy[1] - 0.5);
        let step = STEP as f64;
        let theta = f64::from(angle_deg).to_radians();
        let (s, c) = (theta.sin(), theta.cos());
        // Orientation shift: descriptor bin o holds the channel o + shift. The keypoint
        // angle turns clockwise on the screen (y down), the channels counter-clockwise,
        // so a keypoint at angle A sees the channels turned by -A (OpenCV's
        // `ori = 360 - angle`).
        let shift = ((360.0 - f64::from(angle_deg)).rem_euclid(360.0) / 45.0) as f32;
        let k = shift.floor();
        let f = shift - k;
        let k = k as usize % ORIENTATIONS;
        let mut norm2 = 0f32;
        for i in 0..GRID {
            for j in 0..GRID {
                let ox = (j as f64 - 1.5) * self.cell;
                let oy = (i as f64 - 1.5) * self.cell;
                let px = cx + c * ox - s * oy;
                let py = cy + s * ox + c * oy;
                let mut cellv = [0f32; ORIENTATIONS];
                self.sample(px / step, py / step, &mut cellv);
                let g = CELL_WEIGHTS[i * GRID + j];
                let dst = &mut out[(i * GRID + j) * ORIENTATIONS..][..ORIENTATIONS];
                for (o, d) in dst.iter_mut().enumerate() {
                    let a = cellv[(o + k) % ORIENTATIONS];
                    let b = cellv[(o + k + 1) % ORIENTATIONS];
                    let v = g * ((1.0 - f) * a + f * b);
                    *d = v;
                    norm2 += v * v;
                }
            }
        }
        normalise_clip(out, norm2);
    }

    /// Bilinear read of the 8 pooled channels at grid position (x, y) (pixel index /
    /// `STEP`); zero outside the image.
    fn sample(&self, x: f64, y: f64, out: &mut [f32; ORIENTATIONS]) {
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = ((x - x0) as f32, (y - y0) as f32);
        let (x0, y0) = (x0 as i64, y0 as i64);
        let corners = [
            (x0, y0, (1.0 - fx) * (1.0 - fy)),
            (x0 + 1, y0, fx * (1.0 - fy)),
            (x0, y0 + 1, (1.0 - fx) * fy),
            (x0 + 1, y0 + 1, fx * fy),
        ];
        for (xx, yy, wgt) in corners {
            if xx < 0 || yy < 0 || xx >= self.width as i64 || yy >= self.height as i64 {
                continue;
            }
            let at = (yy as usize * self.width + xx as usize) * ORIENTATIONS;
            for (o, v) in out.iter_mut().zip(&self.pooled[at..at + ORIENTATIONS]) {
                *o += wgt * v;
            }
        }
    }
}

/// SIFT's Gaussian window (sigma = d / 2 cells) at the 16 cell centres.
const CELL_WEIGHTS: [f32; GRID * GRID] = {
    // exp(-(a^2 + b^2) / 8) for cell-centre offsets a, b in {±0.5, ±1.5} cells:
    // e^{-0.0625} (both inner), e^{-0.3125} (one outer), e^{-0.5625} (both outer).
    const IN: f32 = 0.939_413_1;
    const MID: f32 = 0.731_615_6;
    const OUT: f32 = 0.569_782_8;
    [
        OUT, MID, MID, OUT, //
        MID, IN, IN, MID, //
        MID, IN, IN, MID, //
        OUT, MID, MID, OUT,
    ]
};

/// L2-normalise, clip every value at 0.2, normalise again.
fn normalise_clip(v: &mut [f32], norm2: f32) {
    if norm2 <= 0.0 {
        return;
    }
    let inv = 1.0 / norm2.sqrt();
    let mut n2 = 0f32;
    for x in v.iter_mut() {
        *x = (*x * inv).min(CLIP);
        n2 += *x * *x;
    }
    let inv = 1.0 / n2.sqrt();
    v.iter_mut().for_each(|x| *x *= inv);
}

/// The gradient's angle in units of 45 deg, in [0, 8): atan2 by octant reduction and a
/// polynomial on [0, 1] (max error about 1e-5 rad), pure arithmetic so that it is the
/// same on every machine.
fn orientation_bins(dx: f32, dy: f32) -> f32 {
    let (ax, ay) = (dx.abs(), dy.abs());
    let (lo, hi) = if ax >= ay { (ay, ax) } else { (ax, ay) };
    let z = lo / hi;
    // atan(z) / (pi / 4) on [0, 1]: Abramowitz and Stegun 4.4.49 (error <= 1e-5 rad)
    // divided by pi / 4.
    let z2 = z * z;
    let mut t = z
        * (1.273_069
            + z2 * (-0.420_550_4 + z2 * (0.229_362_6 + z2 * (-0.108_394_7 + z2 * 0.026_528_07))));
    if ay > ax {
        t = 2.0 - t;
    }
    if dx < 0.0 {
        t = 4.0 - t;
    }
    if dy < 0.0 {
        t = 8.0 - t;
    }
    if t >= 8.0 { 0.0 } else { t }
}

/// Separable Gaussian blur (kernel radius ceil(3 sigma), borders mirrored without
/// repeating the edge pixel, OpenCV's default `BORDER_REFLECT_101`).
fn gaussian_blur(src: &[f32], w: usize, h: usize, sigma: f64) -> Vec<f32> {
    let r = (3.0 * sigma).ceil() as isize;
    let mut k: Vec<f64> = (-r..=r)
        .map(|i| (-(i * i) as f64 / (2.0 * sigma * sigma)).exp())
        .collect();
    let sum: f64 = k.iter().sum();
    k.iter_mut().for_each(|v| *v /= sum);
    let k: Vec<f32> = k.into_iter().map(|v| v as f32).collect();
    let reflect = |i: isize, n: usize| -> usize {
        let n = n as isize;
        if n == 1 {
            return 0;
        }
        let mut i = i;
        while i < 0 || i >= n {
            i = if i < 0 { -i } else { 2 * (n - 1) - i };
        }
        i as usize
    };
    let mut tmp = vec![0f32; w * h];
    let mut padded = vec![0f32; w + 2 * r as usize];
    for y in 0..h {
        let row = &src[y * w..(y + 1) * w];
        for (i, p) in padded.iter_mut().enumerate() {
            *p = row[reflect(i as isize - r, w)];
        }
        for (x, out) in tmp[y * w..(y + 1) * w].iter_mut().enumerate() {
            *out = padded[x..x + k.len()]
                .iter()
                .zip(&k)
                .fold(0f32, |acc, (p, kv)| acc + kv * p);
        }
    }
    let mut out = vec![0f32; w * h];
    for y in 0..h {
        for (t, kv) in k.iter().enumerate() {
            let sy = reflect(y as isize + t as isize - r, h);
            let (src_row, dst_row) = (&tmp[sy * w..(sy + 1) * w], &mut out[y * w..(y + 1) * w]);
            for (d, s) in dst_row.iter_mut().zip(src_row) {
                *d += kv * s;
            }
        }
    }
    out
}

/// `acc += sign * row`, element by element.
fn add_rows(acc: &mut [f32], row: &[f32], sign: f32) {
    for (a, r) in acc.iter_mut().zip(row) {
        *a += sign * r;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn orientation_bins_match_atan2() {
        let mut worst = 0f64;
        for i in 0..3600 {
            let a = (i as f64 / 10.0 + 0.05).to_radians();
            let (dx, dy) = (a.cos() as f32 * 3.0, a.sin() as f32 * 3.0);
            let got = f64::from(orientation_bins(dx, dy));
            let want = (f64::from(dy).atan2(f64::from(dx))).rem_euclid(std::f64::consts::TAU)
                / std::f64::consts::FRAC_PI_4;
            let mut d = (got - want).abs();
            d = d.min(8.0 - d);
            worst = worst.max(d);
        }
        // 1e-4 of a 45 deg bin.
        assert!(worst < 1e-4, "worst error {worst} bins");
        assert!((0.0..8.0).contains(&orientation_bins(1.0, -1e-30)));
    }

    #[test]
    fn cell_weights_are_the_gaussian_window() {
        for i in 0..GRID {
            for j in 0..GRID {
                let (a, b) = (i as f64 - 1.5, j as f64 - 1.5);
                let want = (-(a * a + b * b) / 8.0).exp() as f32;
                assert!((CELL_WEIGHTS[i * GRID + j] - want).abs() < 1e-6);
            }
        }
    }

    #[test]
    fn triangle_filter_has_triangle_weights() {
        let n = 21;
        let mut src = vec![0f32; n * ORIENTATIONS];
        src[10 * ORIENTATIONS + 3] = 1.0;
        src[ORIENTATIONS + 5] = 2.0;
        let mut out = vec![0f32; n.div_ceil(STEP) * ORIENTATIONS];
        triangle_stream(&src, n, 4, &mut out);
        for i in (0..n).step_by(STEP) {
            let tri = |c: usize| (4 - (i as i64 - c as i64).abs()).max(0) as f32;
            let got = &out[(i / STEP) * ORIENTATIONS..][..ORIENTATIONS];
            assert_eq!(got[3], tri(10), "x {i}");
            assert_eq!(got[5], 2.0 * tri(1), "x {i}");
            assert!(
                got.iter()
                    .enumerate()
                    .all(|(c, v)| c == 3 || c == 5 || *v == 0.0)
            );
        }
    }

    /// The streamed 2-D pooling equals the separable triangle summed directly.
    #[test]
    fn pooling_is_the_separable_triangle() {
        let img = GrayImage::from_fn(37, 29, |x, y| {
            image::Luma([((x * 37 + y * y * 11) % 256) as u8])
        });
        let g = OrientedGradients::new(&img);
        let half = 6usize;
        let map = g.pool((2.0 * half as f64 / CELL_PER_SCALE) as f32);
        let mut ch = vec![vec![0f32; 37 * ORIENTATIONS]; 29];
        for (y, row) in ch.iter_mut().enumerate() {
            g.channel_row(y, row);
        }
        let scale = map
            .pooled
            .iter()
            .fold(0f64, |m, v| m.max(f64::from(v.abs())));
        for my in 0..map.height {
            for mx in 0..map.width {
                let (x0, y0) = (mx * STEP, my * STEP);
                let mut want = [0f64; ORIENTATIONS];
                for (y, row) in ch.iter().enumerate() {
                    for x in 0..37 {
                        let wy = (half as f64 - (y as f64 - y0 as f64).abs()).max(0.0);
                        let wx = (half as f64 - (x as f64 - x0 as f64).abs()).max(0.0);
                        for c in 0..ORIENTATIONS {
                            want[c] += wx * wy * f64::from(row[x * ORIENTATIONS + c]);
                        }
                    }
                }
                let got = &map.pooled[(my * map.width + mx) * ORIENTATIONS..][..ORIENTATIONS];
                // f32 running sums drift by a few ulps of the map's largest values.
                for c in 0..ORIENTATIONS {
                    assert!(
                        (f64::from(got[c]) - want[c]).abs() <= 1e-5 * scale,
                        "({mx},{my}) ch {c}: {} vs {}",
                        got[c],
                        want[c]
                    );
                }
            }
        }
    }

    #[test]
    fn blur_keeps_a_constant_image() {
        let src = vec![7f32; 30 * 20];
        let out = gaussian_blur(&src, 30, 20, 1.52);
        assert!(out.iter().all(|v| (v - 7.0).abs() < 1e-4));
    }
}
