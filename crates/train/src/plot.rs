//! The loss curves as a PNG (`losses.png`), drawn with the `image` crate (no plotting
//! library in this workspace).
//!
//! x: iteration (linear, first to last); y: log10 of the loss, each curve a moving
//! average over 1/100 of the run. Grid lines mark each power of ten (darker) and each
//! tenth of the run. Colours (no text rendering, so the legend is here and in the
//! trainer's summary): total black, L_m points blue, L_m lines cyan, L_r (points +
//! lines) green, L_pi (points + lines, once on) red.

use crate::checkpoint::write_atomic;
use crate::error::{TrainError, io_err};
use crate::metrics::read_columns;
use image::{Rgb, RgbImage};
use std::path::Path;

pub const PLOT_FILE: &str = "losses.png";
pub const LEGEND: &str = "black: total, blue: L_m points, cyan: L_m lines, green: L_r, red: L_pi";

const W: u32 = 1000;
const H: u32 = 520;
const MARGIN: u32 = 30;

fn moving_average(v: &[f64], window: usize) -> Vec<f64> {
    let mut out = Vec::with_capacity(v.len());
    let (mut sum, mut count) = (0.0, 0usize);
    for i in 0..v.len() {
        if v[i].is_finite() {
            sum += v[i];
            count += 1;
        }
        if i >= window && v[i - window].is_finite() {
            sum -= v[i - window];
            count -= 1;
        }
        out.push(if count > 0 {
            sum / count as f64
        } else {
            f64::NAN
        });
    }
    out
}

fn line(img: &mut RgbImage, (x0, y0): (f64, f64), (x1, y1): (f64, f64), c: Rgb<u8>) {
    let steps = ((x1 - x0).abs().max((y1 - y0).abs()).ceil() as usize).max(1);
    for s in 0..=steps {
        let t = s as f64 / steps as f64;
        let (x, y) = (x0 + (x1 - x0) * t, y0 + (y1 - y0) * t);
        for (dx, dy) in [(0.0, 0.0), (0.0, 1.0)] {
            let (px, py) = ((x + dx).round(), (y + dy).round());
            if px >= 0.0 && py >= 0.0 && px < W as f64 && py < H as f64 {
                img.put_pixel(px as u32, py as u32, c);
            }
        }
    }
}

/// Draws `series` (name-less curves with their colours) against their index.
pub fn render(series: &[(Vec<f64>, Rgb<u8>)]) -> RgbImage {
    let mut img = RgbImage::from_pixel(W, H, Rgb([255, 255, 255]));
    let n = series.iter().map(|(v, _)| v.len()).max().unwrap_or(0);
    let logs: Vec<f64> = series
        .iter()
        .flat_map(|(v, _)| v.iter())
        .filter(|x| x.is_finite() && **x > 0.0)
        .map(|x| x.log10())
        .collect();
    let lo = logs.iter().copied().fold(f64::INFINITY, f64::min).floor();
    let hi = logs
        .iter()
        .copied()
        .fold(f64::NEG_INFINITY, f64::max)
        .ceil();
    let (lo, hi) = if lo.is_finite() && hi > lo {
        (lo, hi)
    } else {
        (0.0, 1.0)
    };
    let (x0, x1) = (MARGIN as f64, (W - MARGIN) as f64);
    let (y0, y1) = ((H - MARGIN) as f64, MARGIN as f64);
    let px = |i: usize| x0 + (x1 - x0) * i as f64 / (n.max(2) - 1) as f64;
    let py = |v: f64| y0 + (y1 - y0) * (v.log10() - lo) / (hi - lo);
    for d in 0..=((hi - lo) as i64) {
        let y = y0 + (y1 - y0) * d as f64 / (hi - lo);
        line(&mut img, (x0, y), (x1, y), Rgb([170, 170, 170]));
        // Minor grid at 2x .. 9x of each decade.
        for m in 2..10 {
            let v = 10f64.powf(lo + d as f64) * m as f64;
            if v.log10() < hi {
                let y = py(v);
                line(&mut img, (x0, y), (x1, y), Rgb([232, 232, 232]));
            }
        }
    }
    for k in 0..=10 {
        let x = x0 + (x1 - x0) * k as f64 / 10.0;
        line(&mut img, (x, y0), (x, y1), Rgb([225, 225, 225]));
    }
    line(&mut img, (x0, y0), (x1, y0), Rgb([0, 0, 0]));
    line(&mut img, (x0, y0), (x0, y1), Rgb([0, 0, 0]));
    let window = (n / 100).max(1);
    for (v, c) in series {
        let avg = moving_average(v, window);
        let mut prev: Option<(f64, f64)> = None;
        for (i, a) in avg.iter().enumerate() {
            if a.is_finite() && *a > 0.0 {
                let p = (px(i), py(*a));
                if let Some(q) = prev {
                    line(&mut img, q, p, *c);
                }
                prev = Some(p);
            } else {
                prev = None;
            }
        }
    }
    img
}

/// Plots the loss columns of a metrics file into `out` (atomically).
pub fn plot_metrics(metrics: &Path, out: &Path) -> Result<(), TrainError> {
    let cols = read_columns(
        metrics,
        &[
            "total",
            "map_points",
            "map_lines",
            "reliability_points",
            "reliability_lines",
            "reprojection_points",
            "reprojection_lines",
            "reprojection_active",
        ],
    )?;
    let sum = |a: &[f64], b: &[f64]| -> Vec<f64> { a.iter().zip(b).map(|(x, y)| x + y).collect() };
    let reprojection: Vec<f64> = sum(&cols[5], &cols[6])
        .into_iter()
        .zip(&cols[7])
        .map(|(v, on)| if *on > 0.5 { v } else { f64::NAN })
        .collect();
    let img = render(&[
        (cols[0].clone(), Rgb([0, 0, 0])),
        (cols[1].clone(), Rgb([30, 80, 220])),
        (cols[2].clone(), Rgb([0, 180, 200])),
        (sum(&cols[3], &cols[4]), Rgb([20, 160, 40])),
        (reprojection, Rgb([220, 30, 30])),
    ]);
    let mut bytes = std::io::Cursor::new(Vec::new());
    img.write_to(&mut bytes, image::ImageFormat::Png)
        .map_err(|e| TrainError::Image(format!("encoding {}: {e}", out.display())))?;
    write_atomic(out, bytes.get_ref()).map_err(|e| match e {
        TrainError::Io { source, .. } => io_err(out)(source),
        other => other,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn curves_are_drawn_in_their_colours() {
        let falling: Vec<f64> = (0..500).map(|i| 100.0 / (1.0 + i as f64)).collect();
        let flat = vec![1.0; 500];
        let img = render(&[(falling, Rgb([255, 0, 0])), (flat, Rgb([0, 0, 255]))]);
        let count = |c: Rgb<u8>| img.pixels().filter(|p| **p == c).count();
        assert!(count(Rgb([255, 0, 0])) > 500);
        assert!(count(Rgb([0, 0, 255])) > 500);
        // The falling curve starts high (top-left) and ends low.
        let red_rows = |x: u32| -> Vec<u32> {
            (0..H)
                .filter(|&y| *img.get_pixel(x, y) == Rgb([255, 0, 0]))
                .collect()
        };
        let start = red_rows(MARGIN + 12);
        let end = red_rows(W - MARGIN - 1);
        assert!(!start.is_empty() && !end.is_empty());
        assert!(start[0] < end[0]);
    }

    #[test]
    fn moving_average_skips_missing_values() {
        let v = [1.0, f64::NAN, 3.0, 5.0];
        let a = moving_average(&v, 2);
        assert_eq!(a[0], 1.0);
        assert_eq!(a[1], 1.0);
        assert_eq!(a[2], 3.0);
        assert_eq!(a[3], 4.0);
    }
}
