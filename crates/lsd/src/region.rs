//! Line-support regions (IPOL paper, sections "Region growing" and "Rectangular
//! approximation"): pixels connected to a seed whose level-line angles agree within the
//! tolerance, and the rectangle that covers them.

use crate::angle::{angle_diff, is_aligned};
use crate::grid::Grid;
use crate::rect::Rect;
use std::f64::consts::PI;

/// A region: its pixels, the seed first, in the order they joined.
pub(crate) struct Region {
    pub(crate) points: Vec<(usize, usize)>,
    /// The mean level-line angle (of the unit vectors) of the pixels.
    pub(crate) angle: f64,
}

/// Grows the region of seed (`x`, `y`): the 8-neighbours of every member, in member order
/// and within each by increasing x then y, join when unused and aligned with the region's
/// current angle, which is updated after each join. Members are marked in `used`.
pub(crate) fn region_grow(
    x: usize,
    y: usize,
    angles: &Grid<f64>,
    used: &mut Grid<bool>,
    prec: f64,
    region: &mut Region,
) {
    region.points.clear();
    region.points.push((x, y));
    region.angle = angles.get(x, y);
    let mut sumdx = region.angle.cos();
    let mut sumdy = region.angle.sin();
    used.set(x, y, true);
    let mut i = 0;
    while i < region.points.len() {
        let (px, py) = region.points[i];
        for xx in px as i64 - 1..=px as i64 + 1 {
            for yy in py as i64 - 1..=py as i64 + 1 {
                if !used.contains(xx, yy) {
                    continue;
                }
                let (xx, yy) = (xx as usize, yy as usize);
                if !used.get(xx, yy) && is_aligned(xx, yy, angles, region.angle, prec) {
                    used.set(xx, yy, true);
                    region.points.push((xx, yy));
                    let a = angles.get(xx, yy);
                    sumdx += a.cos();
                    sumdy += a.sin();
                    region.angle = sumdy.atan2(sumdx);
                }
            }
        }
        i += 1;
    }
}

/// The axis angle of the region: the principal inertia axis of its pixels weighted by
/// gradient norm about (`cx`, `cy`), turned by pi when that points against the region's
/// mean level-line angle.
fn principal_angle(
    points: &[(usize, usize)],
    cx: f64,
    cy: f64,
    modgrad: &Grid<f64>,
    reg_angle: f64,
    prec: f64,
) -> f64 {
    let (mut ixx, mut iyy, mut ixy) = (0.0, 0.0, 0.0);
    for &(x, y) in points {
        let weight = modgrad.get(x, y);
        let (dx, dy) = (x as f64 - cx, y as f64 - cy);
        ixx += dy * dy * weight;
        iyy += dx * dx * weight;
        ixy -= dx * dy * weight;
    }
    // Smallest eigenvalue; its eigenvector is the axis. Of the two equivalent formulas the
    // better conditioned one is used.
    let lambda = 0.5 * (ixx + iyy - ((ixx - iyy) * (ixx - iyy) + 4.0 * ixy * ixy).sqrt());
    let mut theta = if ixx.abs() > iyy.abs() {
        (lambda - ixx).atan2(ixy)
    } else {
        ixy.atan2(lambda - iyy)
    };
    if angle_diff(theta, reg_angle) > prec {
        theta += PI;
    }
    theta
}

/// The smallest rectangle along the region's principal axis that holds all its pixel
/// centres, at least one pixel wide (a sharp axis-parallel step gives a zero-width
/// region, yet is a one-pixel transition).
pub(crate) fn region_to_rect(region: &Region, modgrad: &Grid<f64>, prec: f64, p: f64) -> Rect {
    let points = &region.points;
    // Centre: gradient-weighted mean of the pixel coordinates.
    let (mut x, mut y, mut sum) = (0.0, 0.0, 0.0);
    for &(px, py) in points {
        let weight = modgrad.get(px, py);
        x += px as f64 * weight;
        y += py as f64 * weight;
        sum += weight;
    }
    x /= sum;
    y /= sum;
    let theta = principal_angle(points, x, y, modgrad, region.angle, prec);
    let (dx, dy) = (theta.cos(), theta.sin());
    // Extent along the axis (l) and across it (w), from the centre.
    let (mut l_min, mut l_max, mut w_min, mut w_max) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
    for &(px, py) in points {
        let (ox, oy) = (px as f64 - x, py as f64 - y);
        let l = ox * dx + oy * dy;
        let w = -ox * dy + oy * dx;
        if l > l_max {
            l_max = l;
        }
        if l < l_min {
            l_min = l;
        }
        if w > w_max {
            w_max = w;
        }
        if w < w_min {
            w_min = w;
        }
    }
    let width = w_max - w_min;
    Rect {
        x1: x + l_min * dx,
        y1: y + l_min * dy,
        x2: x + l_max * dx,
        y2: y + l_max * dy,
        width: if width < 1.0 { 1.0 } else { width },
        x,
        y,
        theta,
        dx,
        dy,
        prec,
        p,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gradient::NOTDEF;

    #[test]
    fn a_region_takes_the_aligned_connected_pixels_only() {
        let mut angles = Grid::filled(6, 5, NOTDEF);
        for y in 1..4 {
            angles.set(2, y, 0.1);
        }
        angles.set(3, 2, 0.15); // aligned neighbour
        angles.set(4, 2, 2.0); // connected but not aligned
        angles.set(5, 4, 0.1); // aligned but not connected
        let mut used = Grid::filled(6, 5, false);
        let mut region = Region {
            points: Vec::new(),
            angle: 0.0,
        };
        region_grow(2, 2, &angles, &mut used, 0.39, &mut region);
        let mut pts = region.points.clone();
        pts.sort();
        assert_eq!(pts, vec![(2, 1), (2, 2), (2, 3), (3, 2)]);
        assert_eq!(region.points[0], (2, 2), "the seed comes first");
        assert!(used.get(3, 2) && !used.get(4, 2) && !used.get(5, 4));
        assert!(region.angle > 0.1 && region.angle < 0.15);
    }

    #[test]
    fn a_horizontal_run_gives_a_horizontal_unit_width_rectangle() {
        let modgrad = Grid::filled(20, 5, 10.0);
        let region = Region {
            points: (3..13).map(|x| (x, 2)).collect(),
            // Level lines pointing along +x.
            angle: 0.0,
        };
        let r = region_to_rect(&region, &modgrad, 0.39, 0.125);
        assert!(
            (r.x1 - 3.0).abs() < 1e-12 && (r.x2 - 12.0).abs() < 1e-12,
            "{r:?}"
        );
        assert!((r.y1 - 2.0).abs() < 1e-12 && (r.y2 - 2.0).abs() < 1e-12);
        assert_eq!(r.width, 1.0);
        // The inertia axis comes out as pi and is turned to agree with the level lines:
        // theta = 2 pi, i.e. along +x.
        assert!((r.dx - 1.0).abs() < 1e-12 && r.dy.abs() < 1e-12, "{r:?}");
        // Level lines along -x: the axis turns round and the endpoints swap.
        let region = Region {
            angle: PI,
            ..region
        };
        let r = region_to_rect(&region, &modgrad, 0.39, 0.125);
        assert!(
            (r.x1 - 12.0).abs() < 1e-12 && (r.x2 - 3.0).abs() < 1e-12,
            "{r:?}"
        );
    }
}
