//! Level-line field and pseudo-ordering (IPOL paper, sections "Gradient computation" and
//! "Pseudo-ordering").
//!
//! The gradient comes from a 2x2 window. Here it follows pytlsd, which differs from the
//! IPOL code in two ways (both matter for bit-equality):
//! - the window of pixel (x, y) is (x-1..=x, y-1..=y), so the first row and column have no
//!   gradient (IPOL: (x..=x+1, y..=y+1), the last row and column have none);
//! - the level-line angle is `atan2(-gx, gy)` (IPOL: `atan2(gx, -gy)`), the opposite
//!   direction, which swaps the two endpoints of every segment.
//!
//! Seeds are visited by decreasing gradient norm, up to `n_bins` bins: a stable bucket
//! sort of the pixels taken column by column, like the reference's linked lists.

use crate::grid::Grid;

/// The angle of pixels without a defined level line (norm at or below the threshold, or
/// on the first row or column).
pub(crate) const NOTDEF: f64 = -1024.0;

/// The level-line field of an image.
pub(crate) struct LevelLines {
    /// Level-line angle in (-pi, pi], or [`NOTDEF`].
    pub(crate) angles: Grid<f64>,
    /// Gradient norm (0 where the window does not fit).
    pub(crate) modgrad: Grid<f64>,
    /// Seed candidates `(x, y)`, strongest bin first.
    pub(crate) order: Vec<(u32, u32)>,
}

/// Computes angles, norms and the seed order of `img`; pixels with a norm `<= threshold`
/// get [`NOTDEF`].
pub(crate) fn level_lines(img: &Grid<f64>, threshold: f64, n_bins: usize) -> LevelLines {
    let (w, h) = (img.width, img.height);
    let mut angles = Grid::filled(w, h, NOTDEF);
    let mut modgrad = Grid::filled(w, h, 0.0);
    for y in 1..h {
        for x in 1..w {
            let adr = x + y * w;
            // Window   A B     com1 = D - A, com2 = B - C,
            //          C D     gx = B + D - (A + C), gy = C + D - (A + B).
            let com1 = img.data[adr] - img.data[adr - w - 1];
            let com2 = img.data[adr - w] - img.data[adr - 1];
            let gx = com1 + com2;
            let gy = com1 - com2;
            let norm = ((gx * gx + gy * gy) / 4.0).sqrt();
            modgrad.data[adr] = norm;
            if norm > threshold {
                angles.data[adr] = (-gx).atan2(gy);
            }
        }
    }
    let order = pseudo_order(&modgrad, n_bins);
    LevelLines {
        angles,
        modgrad,
        order,
    }
}

/// The pixels of `modgrad` in bins of width `max / n_bins`, from the highest bin down;
/// within a bin in the order visited: x outer, y inner.
///
/// As in the reference, the maximum is taken over the whole image but the last column
/// and the last row are left out of the list (the reference's loops stop at `size - 1`,
/// a leftover of the IPOL window whose last row and column are undefined): pixels there
/// can join a region but never seed one.
fn pseudo_order(modgrad: &Grid<f64>, n_bins: usize) -> Vec<(u32, u32)> {
    let (w, h) = (modgrad.width, modgrad.height);
    let mut max_grad = 0.0;
    for &v in &modgrad.data {
        if v > max_grad {
            max_grad = v;
        }
    }
    let cols = w.saturating_sub(1);
    let rows = h.saturating_sub(1);
    let bin_of = |x: usize, y: usize| -> usize {
        let norm = modgrad.get(x, y);
        // `as` saturates and maps NaN (a flat image: 0 / 0) to bin 0; there every angle is
        // NOTDEF, so the order does not matter.
        let i = (norm * n_bins as f64 / max_grad) as usize;
        i.min(n_bins - 1)
    };
    // Counting sort, stable, descending bins.
    let mut counts = vec![0usize; n_bins];
    for x in 0..cols {
        for y in 0..rows {
            counts[bin_of(x, y)] += 1;
        }
    }
    let mut start = vec![0usize; n_bins];
    let mut acc = 0;
    for b in (0..n_bins).rev() {
        start[b] = acc;
        acc += counts[b];
    }
    let mut order = vec![(0u32, 0u32); acc];
    for x in 0..cols {
        for y in 0..rows {
            let b = bin_of(x, y);
            order[start[b]] = (x as u32, y as u32);
            start[b] += 1;
        }
    }
    order
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_vertical_step_has_horizontal_gradient_and_vertical_level_line() {
        // Dark left half, bright right half: gx > 0, gy = 0 at the step.
        let mut img = Grid::filled(6, 4, 0.0);
        for y in 0..4 {
            for x in 3..6 {
                img.set(x, y, 100.0);
            }
        }
        let ll = level_lines(&img, 5.0, 1024);
        // The window of x = 3 spans columns 2 and 3: norm = sqrt((2 * 100)^2 / 4).
        assert_eq!(ll.modgrad.get(3, 1), 100.0);
        assert_eq!(ll.angles.get(3, 1), (-200f64).atan2(0.0));
        assert_eq!(ll.angles.get(3, 1), -std::f64::consts::FRAC_PI_2);
        assert_eq!(ll.angles.get(2, 1), NOTDEF, "flat: below the threshold");
        assert_eq!(ll.angles.get(3, 0), NOTDEF, "first row: no window");
        assert_eq!(ll.modgrad.get(3, 0), 0.0);
    }

    #[test]
    fn the_order_is_by_decreasing_bin_and_stable_within_a_bin() {
        let mut m = Grid::filled(4, 3, 0.0);
        m.set(2, 1, 10.0);
        m.set(0, 1, 5.0);
        m.set(1, 0, 5.0);
        m.set(3, 2, 20.0); // max, but in the last column and row: not listed
        let order = pseudo_order(&m, 4);
        // 6 pixels listed (3 x 2); bin = floor(v * 4 / 20).
        assert_eq!(order.len(), 6);
        assert_eq!(order[0], (2, 1)); // bin 2
        assert_eq!(&order[1..3], &[(0, 1), (1, 0)]); // bin 1, x-major order
        assert_eq!(&order[3..], &[(0, 0), (1, 1), (2, 0)]); // bin 0
    }
}
