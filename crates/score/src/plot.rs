//! `cdf.png`: the cumulative distributions of the translation and rotation errors of
//! both variants (fraction of all frames with an error <= x, x on a log axis from
//! 0.001 to 1000 cm / deg, wide enough for outdoor scenes). Frames without a pose
//! never enter, so a curve tops out at the fraction localised. Drawn with the `image`
//! crate (plotters is not among the packages this project may use); the same errors
//! give the same bytes.

use crate::error::ScoreError;
use crate::evaluate::{FrameResult, Variant};
use crate::font::{GLYPH_H, draw_text, text_width};
use image::{Rgb, RgbImage};
use std::path::Path;

const PANEL_W: u32 = 620;
const HEIGHT: u32 = 480;
const LEFT: u32 = 78;
const RIGHT: u32 = 24;
const TOP: u32 = 48;
const BOTTOM: u32 = 92;
/// log10 of the x range.
const X_MIN: f64 = -3.0;
const X_MAX: f64 = 3.0;
const TEXT_SCALE: u32 = 2;

const BACKGROUND: Rgb<u8> = Rgb([255, 255, 255]);
const AXIS: Rgb<u8> = Rgb([40, 40, 40]);
const GRID: Rgb<u8> = Rgb([225, 225, 225]);
const THRESHOLD: Rgb<u8> = Rgb([200, 200, 200]);
/// Colours of [`Variant::ALL`]: blue, orange.
pub const COLORS: [Rgb<u8>; 2] = [Rgb([31, 119, 180]), Rgb([230, 110, 0])];

/// The plot's pixel box for the curves of one panel.
#[derive(Clone, Copy, Debug)]
struct Frame {
    x0: u32,
    y0: u32,
    w: u32,
    h: u32,
}

impl Frame {
    fn px(&self, log_x: f64) -> f64 {
        f64::from(self.x0) + (log_x - X_MIN) / (X_MAX - X_MIN) * f64::from(self.w - 1)
    }
    fn py(&self, fraction: f64) -> f64 {
        f64::from(self.y0) + (1.0 - fraction) * f64::from(self.h - 1)
    }
}

fn put(img: &mut RgbImage, x: i64, y: i64, c: Rgb<u8>) {
    if x >= 0 && y >= 0 && (x as u32) < img.width() && (y as u32) < img.height() {
        img.put_pixel(x as u32, y as u32, c);
    }
}

/// A line of `thick` x `thick` pixel dots (Bresenham).
fn line(img: &mut RgbImage, a: (i64, i64), b: (i64, i64), c: Rgb<u8>, thick: i64) {
    let (mut x, mut y) = a;
    let (dx, dy) = ((b.0 - a.0).abs(), -(b.1 - a.1).abs());
    let (sx, sy) = (
        if a.0 < b.0 { 1 } else { -1 },
        if a.1 < b.1 { 1 } else { -1 },
    );
    let mut err = dx + dy;
    loop {
        for oy in 0..thick {
            for ox in 0..thick {
                put(img, x + ox, y + oy, c);
            }
        }
        if (x, y) == b {
            break;
        }
        let e2 = 2 * err;
        if e2 >= dy {
            err += dy;
            x += sx;
        }
        if e2 <= dx {
            err += dx;
            y += sy;
        }
    }
}

fn text_centered(img: &mut RgbImage, cx: i64, y: i64, text: &str, color: Rgb<u8>) {
    let w = i64::from(text_width(text, TEXT_SCALE));
    draw_text(img, cx - w / 2, y, text, TEXT_SCALE, color);
}

fn tick_label(e: i32) -> String {
    if e >= 0 {
        format!("{}", 10u64.pow(e as u32))
    } else {
        format!("{:.*}", (-e) as usize, 10f64.powi(e))
    }
}

/// Fraction of `n` frames with error <= x, for sorted finite `errors`.
fn cdf(errors: &[f64], n: usize, x: f64) -> f64 {
    if n == 0 {
        return 0.0;
    }
    errors.partition_point(|&e| e <= x) as f64 / n as f64
}

fn panel(img: &mut RgbImage, x_off: u32, title: &str, curves: &[(Vec<f64>, Rgb<u8>)], n: usize) {
    let f = Frame {
        x0: x_off + LEFT,
        y0: TOP,
        w: PANEL_W - LEFT - RIGHT,
        h: HEIGHT - TOP - BOTTOM,
    };
    let (x1, y1) = (i64::from(f.x0 + f.w - 1), i64::from(f.y0 + f.h - 1));
    // Grid: decades and the 1/2/3/5/10 accuracy thresholds, 25 % steps.
    for e in X_MIN as i32..=X_MAX as i32 {
        let x = f.px(f64::from(e)).round() as i64;
        line(img, (x, i64::from(f.y0)), (x, y1), GRID, 1);
        text_centered(img, x, y1 + 10, &tick_label(e), AXIS);
    }
    for t in [2.0f64, 3.0, 5.0] {
        let x = f.px(t.log10()).round() as i64;
        let mut y = i64::from(f.y0);
        // Dashed: the thresholds between the decades.
        while y < y1 {
            line(img, (x, y), (x, (y + 4).min(y1)), THRESHOLD, 1);
            y += 9;
        }
    }
    for k in 0..=4 {
        let frac = f64::from(k) / 4.0;
        let y = f.py(frac).round() as i64;
        line(img, (i64::from(f.x0), y), (x1, y), GRID, 1);
        let label = format!("{}%", k * 25);
        let w = i64::from(text_width(&label, TEXT_SCALE));
        draw_text(
            img,
            i64::from(f.x0) - 8 - w,
            y - i64::from(GLYPH_H * TEXT_SCALE) / 2,
            &label,
            TEXT_SCALE,
            AXIS,
        );
    }
    // Axes box.
    let (l, t) = (i64::from(f.x0), i64::from(f.y0));
    line(img, (l, t), (x1, t), AXIS, 1);
    line(img, (l, y1), (x1, y1), AXIS, 1);
    line(img, (l, t), (l, y1), AXIS, 1);
    line(img, (x1, t), (x1, y1), AXIS, 1);
    text_centered(img, l + i64::from(f.w) / 2, 16, title, AXIS);

    // Curves: one value per pixel column, joined, so jumps are vertical segments.
    for (errors, color) in curves {
        let mut prev: Option<(i64, i64)> = None;
        for col in 0..f.w {
            let lx = X_MIN + f64::from(col) / f64::from(f.w - 1) * (X_MAX - X_MIN);
            let y = f.py(cdf(errors, n, 10f64.powf(lx))).round() as i64;
            let p = (i64::from(f.x0 + col), y);
            if let Some(q) = prev {
                line(img, q, p, *color, 2);
            }
            prev = Some(p);
        }
    }
}

/// Renders the two panels and the legend.
pub fn render(results: &[FrameResult]) -> RgbImage {
    let mut img = RgbImage::from_pixel(2 * PANEL_W, HEIGHT, BACKGROUND);
    let n = results.len();
    let sorted = |f: &dyn Fn(&geometry::metrics::PoseError) -> f64, v: Variant| {
        let mut e: Vec<f64> = results
            .iter()
            .filter_map(|r| r.variant(v).error.as_ref().map(f))
            .filter(|e| e.is_finite())
            .collect();
        e.sort_by(f64::total_cmp);
        e
    };
    let titles = ["translation error (cm)", "rotation error (deg)"];
    for (k, title) in titles.iter().enumerate() {
        let curves: Vec<(Vec<f64>, Rgb<u8>)> = Variant::ALL
            .iter()
            .zip(COLORS)
            .map(|(&v, c)| {
                let e = if k == 0 {
                    sorted(&|e| e.translation_cm(), v)
                } else {
                    sorted(&|e| e.rotation_deg, v)
                };
                (e, c)
            })
            .collect();
        panel(&mut img, k as u32 * PANEL_W, title, &curves, n);
    }
    // Legend under the panels.
    let y = i64::from(HEIGHT) - 30;
    let mut x = i64::from(LEFT);
    for (v, c) in Variant::ALL.iter().zip(COLORS) {
        line(&mut img, (x, y + 6), (x + 36, y + 6), c, 3);
        draw_text(&mut img, x + 46, y, v.label(), TEXT_SCALE, AXIS);
        x += 46 + i64::from(text_width(v.label(), TEXT_SCALE)) + 40;
    }
    let note = format!("{n} frames, fraction with error <= x");
    draw_text(&mut img, x + 20, y, &note, TEXT_SCALE, AXIS);
    img
}

/// Encodes [`render`] as PNG.
pub fn png_bytes(results: &[FrameResult]) -> Result<Vec<u8>, image::ImageError> {
    let mut buf = std::io::Cursor::new(Vec::new());
    render(results).write_to(&mut buf, image::ImageFormat::Png)?;
    Ok(buf.into_inner())
}

/// Writes the plot atomically.
pub fn write_plot(path: &Path, results: &[FrameResult]) -> Result<(), ScoreError> {
    let bytes = png_bytes(results).map_err(|source| ScoreError::Png {
        path: path.to_path_buf(),
        source,
    })?;
    stage::write_atomic(path, &bytes)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::evaluate::VariantResult;
    use geometry::metrics::PoseError;

    fn result(cm: Option<f64>, deg: f64) -> FrameResult {
        let v = VariantResult {
            pose: None,
            error: cm.map(|c| PoseError {
                translation_m: c / 100.0,
                rotation_deg: deg,
            }),
            failure: None,
            point_inliers: 0,
            line_inliers: 0,
            iterations: 0,
            ms: 0.0,
        };
        FrameResult {
            frame_id: 0,
            name: "x".into(),
            points_total: 0,
            lines_total: 0,
            points_kept: 0,
            lines_kept: 0,
            variants: [v.clone(), v],
            timings: vec![],
        }
    }

    #[test]
    fn cdf_counts_all_frames() {
        let e = [0.1, 1.0, 5.0];
        assert_eq!(cdf(&e, 4, 0.05), 0.0);
        assert_eq!(cdf(&e, 4, 1.0), 0.5);
        assert_eq!(cdf(&e, 4, 1000.0), 0.75);
        assert_eq!(cdf(&e, 0, 1.0), 0.0);
        assert_eq!(tick_label(-3), "0.001");
        assert_eq!(tick_label(3), "1000");
    }

    #[test]
    fn curves_reach_the_localised_fraction_and_bytes_repeat() {
        // Half the frames localised to ~1e-6 cm: the curve sits at 50 % from the left.
        let results = vec![result(Some(1e-6), 1e-6), result(None, 0.0)];
        let img = render(&results);
        assert_eq!(img.dimensions(), (2 * PANEL_W, HEIGHT));
        let f = Frame {
            x0: LEFT,
            y0: TOP,
            w: PANEL_W - LEFT - RIGHT,
            h: HEIGHT - TOP - BOTTOM,
        };
        let x = f.x0 + f.w / 2;
        let y_half = f.py(0.5).round() as u32;
        // The variants are drawn in order: the last one's colour is on top.
        let c = *img.get_pixel(x, y_half);
        assert!(COLORS.contains(&c), "{c:?} at ({x}, {y_half})");
        // Nothing drawn at 100 % in the middle of the panel (a grid line only).
        let top = *img.get_pixel(x, f.py(1.0).round() as u32 + 3);
        assert!(!COLORS.contains(&top), "{top:?}");

        let a = png_bytes(&results).unwrap();
        assert_eq!(a, png_bytes(&results).unwrap());
        let back = image::load_from_memory(&a).unwrap();
        assert_eq!(back.width(), 2 * PANEL_W);
    }

    #[test]
    fn empty_and_huge_errors_do_not_panic() {
        let _ = render(&[]);
        let _ = render(&[result(Some(1e9), f64::INFINITY), result(Some(0.0), 0.0)]);
    }
}
