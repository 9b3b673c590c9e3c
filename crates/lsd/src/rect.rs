//! The rectangle a segment stands for (IPOL paper, section "Rectangular approximation")
//! and the pixels it covers.
//!
//! The pixel walk (the reference's `ri_*` iterator) decides which pixels the NFA counts,
//! so its rounding (ceil of the lower side, columns from the leftmost corner) is kept.

use crate::nfa::double_equal;

/// A line segment with a width: the candidate whose NFA is tested.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Rect {
    /// First endpoint (the axis runs from it to the second).
    pub(crate) x1: f64,
    pub(crate) y1: f64,
    /// Second endpoint.
    pub(crate) x2: f64,
    pub(crate) y2: f64,
    /// Full width across the axis.
    pub(crate) width: f64,
    /// The region's gradient-weighted centre.
    pub(crate) x: f64,
    pub(crate) y: f64,
    /// Axis angle and its unit vector (`dx`, `dy`) = (cos, sin).
    pub(crate) theta: f64,
    pub(crate) dx: f64,
    pub(crate) dy: f64,
    /// Angle tolerance (radians) and the matching probability `prec / pi`.
    pub(crate) prec: f64,
    pub(crate) p: f64,
}

/// `y` on the segment (x1, y1)-(x2, y2) at `x`, with `x1 <= x <= x2`; for a vertical
/// side (x1 ~ x2) the smaller y (`low`) or the larger.
#[inline]
fn interpolate(x: f64, x1: f64, y1: f64, x2: f64, y2: f64, low: bool) -> f64 {
    if double_equal(x1, x2) {
        if y1 < y2 {
            return if low { y1 } else { y2 };
        }
        if y1 > y2 {
            return if low { y2 } else { y1 };
        }
    }
    y1 + (x - x1) * (y2 - y1) / (x2 - x1)
}

/// The integer pixels inside a rectangle, column by column (increasing x), each column
/// from its lowest y up. The corners are kept in circular order starting with the
/// leftmost one.
pub(crate) struct RectPixels {
    vx: [f64; 4],
    vy: [f64; 4],
    /// Lower and upper y limits of the current column.
    ys: f64,
    ye: f64,
    x: i64,
    y: i64,
}

impl RectPixels {
    pub(crate) fn new(r: &Rect) -> Self {
        let half_w = |d: f64| d * r.width / 2.0;
        let vx = [
            r.x1 - half_w(r.dy),
            r.x2 - half_w(r.dy),
            r.x2 + half_w(r.dy),
            r.x1 + half_w(r.dy),
        ];
        let vy = [
            r.y1 + half_w(r.dx),
            r.y2 + half_w(r.dx),
            r.y2 - half_w(r.dx),
            r.y1 - half_w(r.dx),
        ];
        // Rotate so that corner 0 has the smallest x (for a vertical side, the one with
        // the larger y).
        let offset = if r.x1 < r.x2 && r.y1 <= r.y2 {
            0
        } else if r.x1 >= r.x2 && r.y1 < r.y2 {
            1
        } else if r.x1 > r.x2 && r.y1 >= r.y2 {
            2
        } else {
            3
        };
        let mut it = Self {
            vx: std::array::from_fn(|n| vx[(offset + n) % 4]),
            vy: std::array::from_fn(|n| vy[(offset + n) % 4]),
            ys: -f64::MAX,
            ye: -f64::MAX,
            x: 0,
            y: 0,
        };
        // One column before the first, with limits that force `advance` to start a new
        // column at once.
        it.x = it.vx[0].ceil() as i64 - 1;
        it.y = it.vy[0].ceil() as i64;
        it.advance();
        it
    }

    #[inline]
    fn done(&self) -> bool {
        self.x as f64 > self.vx[2]
    }

    /// Moves to the next pixel, starting new columns as needed.
    fn advance(&mut self) {
        if !self.done() {
            self.y += 1;
        }
        while self.y as f64 > self.ye && !self.done() {
            self.x += 1;
            if self.done() {
                return;
            }
            let x = self.x as f64;
            let (vx, vy) = (&self.vx, &self.vy);
            // Lower side: corner 0 -> 3 -> 2; upper side: corner 0 -> 1 -> 2.
            self.ys = if x < vx[3] {
                interpolate(x, vx[0], vy[0], vx[3], vy[3], true)
            } else {
                interpolate(x, vx[3], vy[3], vx[2], vy[2], true)
            };
            self.ye = if x < vx[1] {
                interpolate(x, vx[0], vy[0], vx[1], vy[1], false)
            } else {
                interpolate(x, vx[1], vy[1], vx[2], vy[2], false)
            };
            self.y = self.ys.ceil() as i64;
        }
    }
}

impl Iterator for RectPixels {
    type Item = (i64, i64);

    fn next(&mut self) -> Option<(i64, i64)> {
        if self.done() {
            return None;
        }
        let here = (self.x, self.y);
        self.advance();
        Some(here)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rect(x1: f64, y1: f64, x2: f64, y2: f64, width: f64) -> Rect {
        let theta = (y2 - y1).atan2(x2 - x1);
        Rect {
            x1,
            y1,
            x2,
            y2,
            width,
            x: (x1 + x2) / 2.0,
            y: (y1 + y2) / 2.0,
            theta,
            dx: theta.cos(),
            dy: theta.sin(),
            prec: 0.39,
            p: 0.125,
        }
    }

    #[test]
    fn an_axis_aligned_rectangle_covers_its_grid_points() {
        // From (1, 2) to (5, 2), 2 wide: x in [1, 5], y in [1, 3] -> 5 x 3 pixels.
        let px: Vec<_> = RectPixels::new(&rect(1.0, 2.0, 5.0, 2.0, 2.0)).collect();
        assert_eq!(px.len(), 15, "{px:?}");
        assert_eq!(px[0], (1, 1));
        assert_eq!(px[1], (1, 2));
        assert_eq!(*px.last().unwrap(), (5, 3));
        // The reversed direction (exactly along -x) visits the same pixels in the same
        // order: the walk always starts at the leftmost corner.
        let mut r = rect(5.0, 2.0, 1.0, 2.0, 2.0);
        (r.dx, r.dy) = (-1.0, 0.0);
        let back: Vec<_> = RectPixels::new(&r).collect();
        assert_eq!(px, back);
    }

    #[test]
    fn a_diagonal_rectangle_covers_about_its_area() {
        let r = rect(10.0, 10.0, 40.0, 30.0, 3.0);
        let n = RectPixels::new(&r).count() as f64;
        let area = (30f64.hypot(20.0)) * 3.0;
        assert!((n - area).abs() < 0.2 * area, "{n} vs {area}");
        for (x, y) in RectPixels::new(&r) {
            // Every pixel lies within the rectangle (distance to the axis <= width / 2).
            let d = (-(x as f64 - r.x1) * r.dy + (y as f64 - r.y1) * r.dx).abs();
            assert!(d <= 1.5 + 1e-9, "({x}, {y}) at {d}");
        }
    }
}
