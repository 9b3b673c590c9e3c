//! The loss curves as a PNG (`losses.png`).
//!
//! x: iteration (linear, first to last row of `metrics.csv`); y: the loss on a log axis
//! spanning whole decades, each curve a moving average over 1/100 of the run (missing
//! values skipped, non-positive ones left out). A title naming the window, axis labels,
//! tick labels, a decade grid with 2..9 minor lines, and a legend under the chart: total
//! (black), L_m points (blue), L_m lines (cyan), L_r for points + lines (green), L_pi for
//! points + lines once it is on (red). Drawn by plotters into an RGB buffer, text with
//! the plot crate's embedded font, the chart's frame as the CDF plot's
//! (crates/plot/src/frame.rs), encoded by `image`: the same metrics give the same bytes.

use crate::checkpoint::write_atomic;
use crate::error::{TrainError, io_err};
use crate::metrics::read_columns;
use image::RgbImage;
use plot::plotters::prelude::*;
use plot::{FrameStyle, TEXT, draw_err};
use std::path::Path;

pub const PLOT_FILE: &str = "losses.png";
/// The curves and their colours (also in the PNG's legend).
pub const LEGEND: &str = "black: total, blue: L_m points, cyan: L_m lines, green: L_r, red: L_pi";

/// The image size in pixels.
pub const WIDTH: u32 = 1200;
pub const HEIGHT: u32 = 660;
/// Height of the legend strip under the chart.
const LEGEND_H: u32 = 48;

/// The chart's frame.
const FRAME: FrameStyle = FrameStyle {
    caption_px: 24,
    margin_top: 12,
    margin_bottom: 0,
    margin_left: 14,
    margin_right: 36,
    x_label_area: 58,
    y_label_area: 84,
    tick_label_px: 16,
    axis_desc_px: 18,
    major_grid: RGBColor(200, 200, 200),
};

/// The curves of [`plot_metrics`], in legend order.
pub const CURVES: [(&str, RGBColor); 5] = [
    ("total", RGBColor(20, 20, 20)),
    ("L_m points", RGBColor(31, 90, 200)),
    ("L_m lines", RGBColor(0, 170, 200)),
    ("L_r (points + lines)", RGBColor(40, 160, 50)),
    ("L_pi (points + lines)", RGBColor(215, 40, 40)),
];

/// One curve: a value per row of the metrics (NaN where missing).
pub struct Series {
    pub name: String,
    pub values: Vec<f64>,
    pub color: RGBColor,
}

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

/// The moving-average window of a run of `rows` rows.
fn window(rows: usize) -> usize {
    (rows / 100).max(1)
}

/// The runs of drawable points of one curve: (iteration, value) with a finite, positive
/// value; a missing or non-positive value breaks the curve.
fn runs(iterations: &[u64], values: &[f64]) -> Vec<Vec<(u64, f64)>> {
    let mut out = vec![];
    let mut run = vec![];
    for (&it, &v) in iterations.iter().zip(values) {
        if v.is_finite() && v > 0.0 {
            run.push((it, v));
        } else if !run.is_empty() {
            out.push(std::mem::take(&mut run));
        }
    }
    if !run.is_empty() {
        out.push(run);
    }
    out
}

/// Draws the moving averages of `series` against `iterations` (one per row).
pub fn render(iterations: &[u64], series: &[Series]) -> Result<RgbImage, String> {
    let rows = iterations.len();
    let w = window(rows);
    let averaged: Vec<Vec<Vec<(u64, f64)>>> = series
        .iter()
        .map(|s| runs(iterations, &moving_average(&s.values, w)))
        .collect();
    let values = || averaged.iter().flatten().flatten().map(|&(_, v)| v.log10());
    let lo = values().fold(f64::INFINITY, f64::min).floor();
    let hi = values().fold(f64::NEG_INFINITY, f64::max).ceil();
    let (lo, hi) = match (lo.is_finite(), hi.is_finite()) {
        (true, true) if hi > lo => (lo as i32, hi as i32),
        (true, true) => (lo as i32, lo as i32 + 1),
        _ => (0, 1),
    };
    let (decades, minors) = plot::log_ticks(lo, hi);
    // Iteration i is the state after i steps: the axis starts at the one before the first row.
    let first = iterations
        .iter()
        .copied()
        .min()
        .unwrap_or(1)
        .saturating_sub(1);
    let last = iterations.iter().copied().max().unwrap_or(1).max(first + 1);

    plot::draw_rgb(WIDTH, HEIGHT, |root| {
        let (top, bottom) = root.split_vertically(HEIGHT - LEGEND_H);
        let title = if w > 1 {
            format!("Training losses (moving averages over {w} iterations)")
        } else {
            "Training losses".to_string()
        };
        let mut chart = FRAME.chart(
            &top,
            &title,
            first..last,
            (10f64.powi(lo)..10f64.powi(hi))
                .log_scale()
                .with_key_points(decades)
                .with_light_points(minors),
        )?;
        let y_label = |v: &f64| plot::decade_label(*v);
        FRAME
            .mesh(&mut chart)
            .x_desc("iteration")
            .y_desc("loss (log scale)")
            .x_labels(11)
            .x_max_light_lines(1)
            .y_label_formatter(&y_label)
            .draw()
            .map_err(draw_err)?;
        // The first series (the total) thicker and last, on top of its parts.
        for (k, (runs, s)) in averaged.iter().zip(series).enumerate().rev() {
            let width = if k == 0 { 3 } else { 2 };
            for run in runs {
                chart
                    .draw_series(LineSeries::new(
                        run.iter().copied(),
                        s.color.stroke_width(width),
                    ))
                    .map_err(draw_err)?;
            }
        }
        let entries: Vec<(&str, RGBColor)> =
            series.iter().map(|s| (s.name.as_str(), s.color)).collect();
        let style = plot::LegendStyle {
            font_px: 17,
            sample: 32,
            gap: 8,
            spacing: 36,
            text: TEXT,
        };
        plot::legend(&bottom, &entries, &style)
    })
}

/// The PNG of the loss columns of a metrics file.
fn png_bytes(metrics: &Path) -> Result<Vec<u8>, TrainError> {
    let cols = read_columns(
        metrics,
        &[
            "iteration",
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
    // Rows without an iteration number (a damaged line) are left out.
    let keep: Vec<usize> = (0..cols[0].len())
        .filter(|&i| cols[0][i].is_finite() && cols[0][i] >= 0.0)
        .collect();
    let col = |k: usize| -> Vec<f64> { keep.iter().map(|&i| cols[k][i]).collect() };
    let iterations: Vec<u64> = keep.iter().map(|&i| cols[0][i] as u64).collect();
    let sum = |a: &[f64], b: &[f64]| -> Vec<f64> { a.iter().zip(b).map(|(x, y)| x + y).collect() };
    let reprojection: Vec<f64> = sum(&col(6), &col(7))
        .into_iter()
        .zip(col(8))
        .map(|(v, on)| if on > 0.5 { v } else { f64::NAN })
        .collect();
    let values = [col(1), col(2), col(3), sum(&col(4), &col(5)), reprojection];
    let series: Vec<Series> = CURVES
        .iter()
        .zip(values)
        .map(|(&(name, color), values)| Series {
            name: name.to_string(),
            values,
            color,
        })
        .collect();
    let img = render(&iterations, &series)
        .map_err(|e| TrainError::Image(format!("{}: {e}", metrics.display())))?;
    let (w, h) = img.dimensions();
    plot::png(img.into_raw(), w, h)
        .map_err(|e| TrainError::Image(format!("{}: {e}", metrics.display())))
}

/// Plots the loss columns of a metrics file into `out` (atomically).
pub fn plot_metrics(metrics: &Path, out: &Path) -> Result<(), TrainError> {
    let bytes = png_bytes(metrics)?;
    write_atomic(out, &bytes).map_err(|e| match e {
        TrainError::Io(e) => TrainError::Io(io_err(out)(e.source)),
        other => other,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use image::Rgb;

    fn rgb(c: RGBColor) -> Rgb<u8> {
        Rgb([c.0, c.1, c.2])
    }

    /// Pixels of `img` in the box that differ from white.
    fn ink(img: &RgbImage, x: std::ops::Range<u32>, y: std::ops::Range<u32>) -> usize {
        y.flat_map(|y| x.clone().map(move |x| (x, y)))
            .filter(|&(x, y)| *img.get_pixel(x, y) != Rgb([255, 255, 255]))
            .count()
    }

    /// A metrics.csv of `rows` iterations with falling losses, L_pi on from the middle.
    fn write_metrics(path: &Path, rows: usize) {
        let mut text = crate::metrics::COLUMNS.join(",") + "\n";
        for i in 1..=rows {
            let t = i as f64;
            let wobble = 1.0 + 0.3 * ((i * 7919) % 13) as f64 / 13.0;
            let (mp, ml) = (20.0 / t.sqrt() * wobble, 8.0 / t.sqrt());
            let (rp, rl) = (0.6 * wobble, 0.4);
            let on = i > rows / 2;
            let (pp, pl) = if on {
                (30.0 / t * wobble, 10.0 / t)
            } else {
                (0.0, 0.0)
            };
            let total = mp + ml + rp + rl + if on { pp + pl } else { 0.0 };
            let mut cells = vec![
                i.to_string(),
                (i % 17).to_string(),
                total.to_string(),
                mp.to_string(),
                ml.to_string(),
                rp.to_string(),
                rl.to_string(),
                pp.to_string(),
                pl.to_string(),
                u8::from(on).to_string(),
            ];
            cells.resize(crate::metrics::COLUMNS.len(), "0".to_string());
            text += &(cells.join(",") + "\n");
        }
        std::fs::write(path, text).unwrap();
    }

    #[test]
    fn plot_has_its_size_a_title_curves_and_legend() {
        let dir = tempfile::tempdir().unwrap();
        let (csv, png) = (dir.path().join("metrics.csv"), dir.path().join(PLOT_FILE));
        write_metrics(&csv, 600);
        plot_metrics(&csv, &png).unwrap();
        let img = image::open(&png).unwrap().to_rgb8();
        assert_eq!(img.dimensions(), (WIDTH, HEIGHT));
        // The title (top middle) and the legend strip have text.
        let mid = WIDTH / 2;
        assert!(ink(&img, mid - 150..mid + 150, 8..40) > 300);
        assert!(ink(&img, mid - 300..mid + 300, HEIGHT - LEGEND_H..HEIGHT) > 500);
        // Every curve's colour is drawn, well beyond its legend sample.
        for (name, color) in CURVES {
            let n = img.pixels().filter(|p| **p == rgb(color)).count();
            assert!(n > 1000, "{name}: {n} pixels");
        }
    }

    #[test]
    fn same_metrics_same_bytes() {
        let dir = tempfile::tempdir().unwrap();
        let csv = dir.path().join("metrics.csv");
        write_metrics(&csv, 300);
        let a = png_bytes(&csv).unwrap();
        assert!(a == png_bytes(&csv).unwrap(), "two renders differ");
        write_metrics(&csv, 301);
        assert!(a != png_bytes(&csv).unwrap());
    }

    #[test]
    fn falling_curve_is_drawn_from_high_to_low() {
        let red = RGBColor(255, 0, 0);
        let values: Vec<f64> = (0..500).map(|i| 100.0 / (1.0 + i as f64)).collect();
        let iterations: Vec<u64> = (1..=500).collect();
        let series = [Series {
            name: "falling".into(),
            values,
            color: red,
        }];
        let img = render(&iterations, &series).unwrap();
        let rows_at = |x: u32| -> Vec<u32> {
            (0..HEIGHT)
                .filter(|&y| *img.get_pixel(x, y) == rgb(red))
                .collect()
        };
        // Columns a tenth and nine tenths of the way across the picture.
        let (start, end) = (rows_at(WIDTH / 5), rows_at(WIDTH * 9 / 10));
        assert!(!start.is_empty() && !end.is_empty());
        assert!(start[0] < end[0], "{start:?} {end:?}");
    }

    #[test]
    fn empty_and_odd_inputs_do_not_panic() {
        render(&[], &[]).unwrap();
        let s = |values: Vec<f64>| Series {
            name: "x".into(),
            values,
            color: RGBColor(0, 0, 0),
        };
        render(&[7], &[s(vec![1.0])]).unwrap();
        render(&[1, 2, 3], &[s(vec![0.0, -1.0, f64::NAN])]).unwrap();
        render(&[1, 2], &[s(vec![1e-30, 1e30])]).unwrap();
    }

    #[test]
    fn moving_average_skips_missing_values() {
        let v = [1.0, f64::NAN, 3.0, 5.0];
        let a = moving_average(&v, 2);
        assert_eq!(a[0], 1.0);
        assert_eq!(a[1], 1.0);
        assert_eq!(a[2], 3.0);
        assert_eq!(a[3], 4.0);
        // The loss axis's labels (crates/plot/src/frame.rs).
        assert_eq!(plot::decade_label(0.01), "0.01");
        assert_eq!(plot::decade_label(100.0), "100");
        assert_eq!(plot::decade_label(1e-7), "1e-7");
    }

    /// Writes a sample plot for a person to look at:
    /// `PL2MAP_PLOT_SAMPLE=/tmp/losses.png cargo test -p train plot::tests::sample -- --ignored`.
    #[test]
    #[ignore]
    fn sample() {
        let Ok(path) = std::env::var("PL2MAP_PLOT_SAMPLE") else {
            println!("SKIPPED PL2MAP_PLOT_SAMPLE is not set");
            return;
        };
        let dir = tempfile::tempdir().unwrap();
        let csv = dir.path().join("metrics.csv");
        write_metrics(&csv, 3000);
        plot_metrics(&csv, Path::new(&path)).unwrap();
    }
}
