//! Recipes of what hangs on the walls: the two posters (coloured cells, stripes at an
//! angle) and the framed picture, with the geometry they need (recursive cell splits, a
//! line clipped to a rectangle).

use super::LocalEdge;
use super::painter::{Painter, contrasting, random_colour};
use crate::texture::{Ellipse, Octave, Rect, Rgb, luma, scale};
use rand::Rng;
use rand_chacha::ChaCha8Rng;

impl Painter {
    /// Paper margin, black ground, coloured cells separated by black lines (recursive
    /// splits); dots inside the cells.
    pub(super) fn mondrian(&mut self, rng: &mut ChaCha8Rng) {
        let full = self.full();
        let paper: Rgb = [0.92, 0.91, 0.87];
        let black: Rgb = [0.06, 0.06, 0.07];
        self.canvas.rect(full, paper);
        let margin = rng.random_range(0.03..0.05);
        let ground = full.inset(margin);
        self.canvas.rect(ground, black);
        self.rect_edges(ground, luma(paper) - luma(black));
        let line = rng.random_range(0.01..0.018);
        let mut cells = Vec::new();
        split_cells(rng, ground.inset(line), line, 0, &mut cells);
        let palette: [Rgb; 7] = [
            [0.85, 0.12, 0.1],
            [0.95, 0.8, 0.1],
            [0.25, 0.4, 0.8],
            [0.93, 0.93, 0.9],
            [0.75, 0.75, 0.75],
            [0.3, 0.65, 0.35],
            [0.95, 0.55, 0.15],
        ];
        for (k, cell) in cells.iter().enumerate() {
            let c = palette[rng.random_range(0..palette.len())];
            self.canvas.rect(*cell, c);
            self.modulate(
                cell.inset(0.003),
                0.06,
                &[Octave::iso(0.05, 0.6), Octave::iso(0.01, 0.4)],
                100 + k as u64,
            );
            let dot = contrasting(rng, c, 0.3, (0.3, 0.9));
            let pal = [dot, scale(dot, 0.7), contrasting(rng, c, 0.25, (0.0, 0.8))];
            self.blobs(
                rng,
                *cell,
                0.012,
                (0.003, 0.02),
                0.25,
                &pal,
                0.3,
                (0.7, 1.0),
            );
            self.rect_edges(*cell, luma(c) - luma(black));
        }
    }

    /// Paper margin, black outline, straight stripes at one angle with dots between.
    pub(super) fn stripes(&mut self, rng: &mut ChaCha8Rng) {
        let full = self.full();
        let paper: Rgb = [0.9, 0.9, 0.86];
        let black: Rgb = [0.07, 0.07, 0.08];
        self.canvas.rect(full, paper);
        let outer = full.inset(rng.random_range(0.03..0.05));
        let line = rng.random_range(0.01..0.015);
        let inner = outer.inset(line);
        self.canvas.rect(outer, black);
        self.rect_edges(outer, luma(paper) - luma(black));
        // Two alternating colours of clearly different luma, both far from black.
        let light = random_colour(rng, (0.2, 0.7), (0.85, 1.0));
        let mut dark = random_colour(rng, (0.5, 0.9), (0.55, 0.8));
        for _ in 0..16 {
            if luma(light) - luma(dark) >= 0.25 && luma(dark) >= 0.3 {
                break;
            }
            dark = random_colour(rng, (0.5, 0.9), (0.55, 0.8));
        }
        if !(luma(light) - luma(dark) >= 0.25 && luma(dark) >= 0.3) {
            dark = [0.75, 0.25, 0.2];
        }
        let colours = [light, dark];
        let angles = [0.0f64, 90.0, 30.0, -30.0, 45.0, -45.0, 60.0, -60.0];
        let theta = angles[rng.random_range(0..angles.len())].to_radians();
        let (s, c) = theta.sin_cos();
        // Stripe boundaries are lines n . p = d with n the unit normal of the stripes.
        let n = [-s, c];
        let corners = [
            [inner.x0, inner.y0],
            [inner.x1, inner.y0],
            [inner.x1, inner.y1],
            [inner.x0, inner.y1],
        ];
        let ds: Vec<f64> = corners.iter().map(|p| n[0] * p[0] + n[1] * p[1]).collect();
        let dmin = ds.iter().cloned().fold(f64::INFINITY, f64::min);
        let dmax = ds.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
        let mut bounds = vec![dmin];
        let mut d = dmin + rng.random_range(0.015..0.06);
        while d < dmax - 0.015 {
            bounds.push(d);
            d += rng.random_range(0.015..0.06);
        }
        bounds.push(dmax);
        self.canvas.stripes(inner, n, &bounds, &colours);
        let contrast = luma(light) - luma(dark);
        for &b in &bounds[1..bounds.len() - 1] {
            if let Some(seg) = clip_line_to_rect(n, b, &inner) {
                self.edges.push(LocalEdge {
                    a: [seg[0], seg[1]],
                    b: [seg[2], seg[3]],
                    contrast,
                });
            }
        }
        self.rect_edges(inner, luma(dark).min(luma(light)) - luma(black));
        self.modulate(
            inner.inset(0.002),
            0.05,
            &[Octave::iso(0.05, 0.6), Octave::iso(0.01, 0.4)],
            3,
        );
        // Dots wholly inside single stripes, >= 4 mm from every boundary.
        let dots = (inner.width() * inner.height() * 900.0) as usize;
        for _ in 0..dots {
            let r = rng.random_range(0.003f64..0.012);
            let x = rng.random_range(inner.x0 + r + 0.006..inner.x1 - r - 0.006);
            let y = rng.random_range(inner.y0 + r + 0.006..inner.y1 - r - 0.006);
            let dd = n[0] * x + n[1] * y;
            let k = bounds.partition_point(|&b| b <= dd).saturating_sub(1);
            if k + 1 >= bounds.len() || dd - bounds[k] < r + 0.004 || bounds[k + 1] - dd < r + 0.004
            {
                continue;
            }
            let under = colours[k % 2];
            let colour = contrasting(rng, under, 0.2, (0.3, 1.0));
            let ring = rng.random_bool(0.3).then_some(r * 0.35);
            self.canvas.ellipse(&Ellipse {
                cx: x,
                cy: y,
                rx: r,
                ry: r * rng.random_range(0.6..1.0),
                angle: rng.random_range(0.0..3.2),
                ring,
                colour,
                opacity: 1.0,
            });
        }
    }

    pub(super) fn picture(&mut self, rng: &mut ChaCha8Rng, moulding: f64) {
        let full = self.full();
        let tone = [0.45, 0.3, 0.18];
        let tone = scale(tone, rng.random_range(0.6..1.3));
        self.wood(rng, tone, true, full);
        let mat_rect = full.inset(moulding);
        let mat: Rgb = [0.93, 0.92, 0.88];
        self.canvas.rect(mat_rect, mat);
        self.rect_edges(mat_rect, luma(mat) - luma(tone).min(0.9));
        let mat_w = rng
            .random_range(0.025f64..0.05)
            .min(mat_rect.width() * 0.2)
            .min(mat_rect.height() * 0.2);
        let photo = mat_rect.inset(mat_w);
        // A "photo": three-colour noise landscape with large and small blobs; kept darker
        // than the mat so its border is a clear step.
        let a = random_colour(rng, (0.3, 0.8), (0.25, 0.6));
        let b = random_colour(rng, (0.3, 0.8), (0.2, 0.6));
        self.canvas.rect(photo, a);
        self.noise_fill(
            photo.inset(0.003),
            a,
            b,
            &[
                Octave::iso(0.15, 0.5),
                Octave::iso(0.04, 0.3),
                Octave::iso(0.01, 0.2),
            ],
            7,
        );
        let pal: Vec<Rgb> = (0..5)
            .map(|_| random_colour(rng, (0.3, 1.0), (0.1, 0.95)))
            .collect();
        self.blobs(rng, photo, 0.01, (0.02, 0.06), 0.3, &pal, 0.2, (0.7, 1.0));
        self.blobs(
            rng,
            photo,
            0.008,
            (0.003, 0.02),
            0.5,
            &pal,
            0.25,
            (0.7, 1.0),
        );
        let photo_luma = 0.5 * (luma(a) + luma(b));
        self.rect_edges(photo, luma(mat) - photo_luma);
    }
}

/// Recursive split into cells separated by gaps of `line`.
fn split_cells(rng: &mut ChaCha8Rng, r: Rect, line: f64, depth: u32, out: &mut Vec<Rect>) {
    const MIN: f64 = 0.07;
    let can_x = r.width() > 2.0 * MIN + line;
    let can_y = r.height() > 2.0 * MIN + line;
    let stop = depth >= 4 || (!can_x && !can_y) || (depth >= 2 && rng.random_bool(0.3));
    if stop {
        out.push(r);
        return;
    }
    let along_x = if can_x && can_y {
        rng.random_bool((r.width() / (r.width() + r.height())).clamp(0.2, 0.8))
    } else {
        can_x
    };
    if along_x {
        let p = rng.random_range(r.x0 + MIN..r.x1 - MIN - line);
        split_cells(rng, Rect::new(r.x0, r.y0, p, r.y1), line, depth + 1, out);
        split_cells(
            rng,
            Rect::new(p + line, r.y0, r.x1, r.y1),
            line,
            depth + 1,
            out,
        );
    } else {
        let p = rng.random_range(r.y0 + MIN..r.y1 - MIN - line);
        split_cells(rng, Rect::new(r.x0, r.y0, r.x1, p), line, depth + 1, out);
        split_cells(
            rng,
            Rect::new(r.x0, p + line, r.x1, r.y1),
            line,
            depth + 1,
            out,
        );
    }
}

/// The segment of the line `n . p = d` (n unit) inside `r`, if any.
fn clip_line_to_rect(n: [f64; 2], d: f64, r: &Rect) -> Option<[f64; 4]> {
    // Parametrise p = n d + s t with t the direction (-n1, n0); clip s to the slabs.
    let t = [-n[1], n[0]];
    let p0 = [n[0] * d, n[1] * d];
    let mut lo = f64::NEG_INFINITY;
    let mut hi = f64::INFINITY;
    for k in 0..2 {
        let (min, max) = if k == 0 { (r.x0, r.x1) } else { (r.y0, r.y1) };
        if t[k].abs() < 1e-12 {
            if p0[k] < min || p0[k] > max {
                return None;
            }
        } else {
            let a = (min - p0[k]) / t[k];
            let b = (max - p0[k]) / t[k];
            lo = lo.max(a.min(b));
            hi = hi.min(a.max(b));
        }
    }
    (hi - lo > 1e-6).then(|| {
        [
            p0[0] + t[0] * lo,
            p0[1] + t[1] * lo,
            p0[0] + t[0] * hi,
            p0[1] + t[1] * hi,
        ]
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clip_line() {
        let r = Rect::new(0.0, 0.0, 2.0, 1.0);
        // Vertical line x = 0.5 (normal (1, 0)).
        let s = clip_line_to_rect([1.0, 0.0], 0.5, &r).unwrap();
        let (ys, ye) = (s[1].min(s[3]), s[1].max(s[3]));
        assert!((s[0] - 0.5).abs() < 1e-12 && (s[2] - 0.5).abs() < 1e-12);
        assert!(ys.abs() < 1e-12 && (ye - 1.0).abs() < 1e-12);
        // Diagonal x + y = 1 (normal (1,1)/sqrt2, d = 1/sqrt2): from (0,1) to (1,0).
        let h = std::f64::consts::FRAC_1_SQRT_2;
        let s = clip_line_to_rect([h, h], h, &r).unwrap();
        let mut pts = [[s[0], s[1]], [s[2], s[3]]];
        pts.sort_by(|a, b| a[0].total_cmp(&b[0]));
        assert!((pts[0][0]).abs() < 1e-12 && (pts[0][1] - 1.0).abs() < 1e-12);
        assert!((pts[1][0] - 1.0).abs() < 1e-12 && pts[1][1].abs() < 1e-12);
        assert!(clip_line_to_rect([1.0, 0.0], 3.0, &r).is_none());
    }
}
