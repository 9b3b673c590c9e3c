//! `cdf.png`: the cumulative distributions of the translation and rotation errors of
//! both variants: for each error x on a log axis from 0.001 to 1000 cm / deg (wide
//! enough for outdoor scenes), the fraction of all test frames whose error is <= x.
//! Frames without a pose never enter, so a curve tops out at the fraction localised.
//! One panel per error, a title naming the frame count, axis labels with units, and a
//! legend with each variant's localised count.
//!
//! Drawn by plotters into an RGB buffer, text with the plot crate's embedded font (no
//! system font is looked up), the frame of each panel as the loss plot's
//! (crates/plot/src/frame.rs), encoded by `image`: the same errors give the same bytes.

use crate::error::ScoreError;
use crate::evaluate::{FrameResult, Variant};
use image::RgbImage;
use plot::plotters::coord::Shift;
use plot::plotters::prelude::*;
use plot::plotters::style::text_anchor::{HPos, Pos, VPos};
use plot::{Canvas, FONT, FrameStyle, TEXT, draw_err};
use std::path::Path;

/// The image size in pixels.
pub const WIDTH: u32 = 1400;
pub const HEIGHT: u32 = 600;
/// Height of the title strip and of the legend strip under the panels.
const TITLE_H: u32 = 48;
const LEGEND_H: u32 = 44;
/// The x range (cm or deg).
const X_LO: f64 = 1e-3;
const X_HI: f64 = 1e3;

/// Colours of [`Variant::ALL`]: blue, orange.
pub const COLORS: [RGBColor; 2] = [RGBColor(31, 119, 180), RGBColor(230, 110, 0)];

/// The frame of each panel.
const PANEL: FrameStyle = FrameStyle {
    caption_px: 21,
    margin_top: 6,
    margin_bottom: 4,
    margin_left: 10,
    margin_right: 28,
    x_label_area: 56,
    y_label_area: 78,
    tick_label_px: 16,
    axis_desc_px: 17,
    major_grid: RGBColor(205, 205, 205),
};

/// Fraction of `n` frames with error <= x, for sorted finite `errors`.
fn cdf(errors: &[f64], n: usize, x: f64) -> f64 {
    if n == 0 {
        return 0.0;
    }
    errors.partition_point(|&e| e <= x) as f64 / n as f64
}

/// The CDF of sorted finite `errors` out of `n` frames as a staircase on [X_LO, X_HI]:
/// errors below the axis count from its left end, errors past it never show.
fn staircase(errors: &[f64], n: usize) -> Vec<(f64, f64)> {
    if n == 0 {
        return vec![];
    }
    let n_f = n as f64;
    let mut pts = vec![(X_LO, cdf(errors, n, X_LO))];
    for (i, &e) in errors.iter().enumerate() {
        if e > X_LO && e <= X_HI {
            pts.push((e, i as f64 / n_f));
            pts.push((e, (i + 1) as f64 / n_f));
        }
    }
    pts.push((X_HI, cdf(errors, n, X_HI)));
    pts
}

type DrawResult<T> = Result<T, String>;

/// One panel: the CDFs of one error (`curves` in the order of [`Variant::ALL`]).
fn panel(
    area: &DrawingArea<Canvas, Shift>,
    title: &str,
    x_desc: &str,
    curves: &[Vec<f64>],
    n: usize,
) -> DrawResult<()> {
    let (decades, minors) =
        plot::log_ticks(X_LO.log10().round() as i32, X_HI.log10().round() as i32);
    let mut chart = PANEL.chart(
        area,
        title,
        (X_LO..X_HI)
            .log_scale()
            .with_key_points(decades)
            .with_light_points(minors),
        0.0..1.0,
    )?;
    let x_label = |v: &f64| plot::decade_label(*v);
    let y_label = |v: &f64| format!("{v:.1}");
    PANEL
        .mesh(&mut chart)
        .x_desc(x_desc)
        .y_desc("fraction of test frames with error ≤ x")
        .x_label_formatter(&x_label)
        .y_labels(11)
        .y_max_light_lines(1)
        .y_label_formatter(&y_label)
        .draw()
        .map_err(draw_err)?;
    for (errors, color) in curves.iter().zip(COLORS) {
        chart
            .draw_series(LineSeries::new(staircase(errors, n), color.stroke_width(3)))
            .map_err(draw_err)?;
    }
    Ok(())
}

/// Renders the title, the two panels and the legend.
pub fn render(results: &[FrameResult]) -> Result<RgbImage, String> {
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
    let translation: Vec<Vec<f64>> = Variant::ALL
        .iter()
        .map(|&v| sorted(&|e| e.translation_cm(), v))
        .collect();
    let rotation: Vec<Vec<f64>> = Variant::ALL
        .iter()
        .map(|&v| sorted(&|e| e.rotation_deg, v))
        .collect();
    let labels: Vec<String> = Variant::ALL
        .iter()
        .map(|&v| {
            let localised = results
                .iter()
                .filter(|r| r.variant(v).error.is_some())
                .count();
            format!("{} ({localised} of {n} frames localised)", v.label())
        })
        .collect();

    plot::draw_rgb(WIDTH, HEIGHT, |root| {
        let (title, rest) = root.split_vertically(TITLE_H);
        let (panels, bottom) = rest.split_vertically(HEIGHT - TITLE_H - LEGEND_H);
        let frames = if n == 1 { "frame" } else { "frames" };
        title
            .draw(&Text::new(
                format!("Cumulative distribution of pose errors over {n} test {frames}"),
                (WIDTH as i32 / 2, TITLE_H as i32 / 2 + 4),
                TextStyle::from((FONT, 24).into_font())
                    .color(&TEXT)
                    .pos(Pos::new(HPos::Center, VPos::Center)),
            ))
            .map_err(draw_err)?;
        let (left, right) = panels.split_horizontally(WIDTH / 2);
        panel(
            &left,
            "Translation error",
            "translation error (cm, log scale)",
            &translation,
            n,
        )?;
        panel(
            &right,
            "Rotation error",
            "rotation error (deg, log scale)",
            &rotation,
            n,
        )?;
        let entries: Vec<(&str, RGBColor)> =
            labels.iter().map(String::as_str).zip(COLORS).collect();
        let style = plot::LegendStyle {
            font_px: 18,
            sample: 36,
            gap: 10,
            spacing: 48,
            text: TEXT,
        };
        plot::legend(&bottom, &entries, &style)
    })
}

fn png_error(reason: String) -> image::ImageError {
    image::ImageError::Parameter(image::error::ParameterError::from_kind(
        image::error::ParameterErrorKind::Generic(reason),
    ))
}

/// Encodes [`render`] as PNG.
pub fn png_bytes(results: &[FrameResult]) -> Result<Vec<u8>, image::ImageError> {
    let img = render(results).map_err(png_error)?;
    let (w, h) = img.dimensions();
    plot::png(img.into_raw(), w, h).map_err(png_error)
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
    use image::Rgb;

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
            point_inlier_mask: vec![],
            line_inlier_mask: vec![],
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

    fn rgb(c: RGBColor) -> Rgb<u8> {
        Rgb([c.0, c.1, c.2])
    }

    /// Pixels of `img` in the box that differ from white.
    fn ink(img: &RgbImage, x: std::ops::Range<u32>, y: std::ops::Range<u32>) -> usize {
        y.flat_map(|y| x.clone().map(move |x| (x, y)))
            .filter(|&(x, y)| *img.get_pixel(x, y) != Rgb([255, 255, 255]))
            .count()
    }

    #[test]
    fn cdf_counts_all_frames() {
        let e = [0.1, 1.0, 5.0];
        assert_eq!(cdf(&e, 4, 0.05), 0.0);
        assert_eq!(cdf(&e, 4, 1.0), 0.5);
        assert_eq!(cdf(&e, 4, 1000.0), 0.75);
        assert_eq!(cdf(&e, 0, 1.0), 0.0);
        // The decades of the axis (the labels of crates/plot/src/frame.rs).
        assert_eq!(plot::decade_label(1e-3), "0.001");
        assert_eq!(plot::decade_label(1.0), "1");
        assert_eq!(plot::decade_label(1e3), "1000");
    }

    #[test]
    fn staircase_steps_at_each_error_within_the_axis() {
        // 1e-6 is left of the axis (counted from its start), 1e9 right of it (never shown).
        let e = [1e-6, 0.5, 2.0, 1e9];
        assert_eq!(
            staircase(&e, 5),
            vec![
                (X_LO, 0.2),
                (0.5, 0.2),
                (0.5, 0.4),
                (2.0, 0.4),
                (2.0, 0.6),
                (X_HI, 0.6)
            ]
        );
        assert!(staircase(&[], 0).is_empty());
    }

    #[test]
    fn png_has_its_size_a_title_and_curves() {
        // Half the frames localised to ~1e-6 cm: the curves sit at 50 % from the left.
        let results = vec![result(Some(1e-6), 1e-6), result(None, 0.0)];
        let bytes = png_bytes(&results).unwrap();
        let img = image::load_from_memory(&bytes).unwrap().to_rgb8();
        assert_eq!(img.dimensions(), (WIDTH, HEIGHT));
        // The title strip has text in its middle, and nothing at its far left.
        let mid = WIDTH / 2;
        assert!(ink(&img, mid - 150..mid + 150, 8..TITLE_H) > 300);
        assert_eq!(ink(&img, 0..40, 0..TITLE_H), 0);
        // Both curve colours appear (the second variant is drawn over the first, but
        // the legend shows both), and the legend strip has text.
        let count = |c: Rgb<u8>| img.pixels().filter(|p| **p == c).count();
        assert!(count(rgb(COLORS[0])) > 100, "{}", count(rgb(COLORS[0])));
        assert!(count(rgb(COLORS[1])) > 500, "{}", count(rgb(COLORS[1])));
        assert!(ink(&img, mid - 200..mid + 200, HEIGHT - LEGEND_H..HEIGHT) > 300);
    }

    #[test]
    fn same_results_same_bytes() {
        let results: Vec<FrameResult> = (0..40)
            .map(|i| {
                let e = 0.01 * 1.3f64.powi(i);
                result((i % 7 != 0).then_some(e), e / 3.0)
            })
            .collect();
        let a = png_bytes(&results).unwrap();
        let b = png_bytes(&results).unwrap();
        assert!(a == b, "two renders of the same results differ");
        // And a different input gives a different picture.
        assert!(a != png_bytes(&results[..20]).unwrap());
    }

    #[test]
    fn empty_and_huge_errors_do_not_panic() {
        render(&[]).unwrap();
        render(&[result(Some(1e9), f64::INFINITY), result(Some(0.0), 0.0)]).unwrap();
        render(&[result(Some(f64::NAN), f64::NAN)]).unwrap();
    }

    /// Writes a sample plot for a person to look at:
    /// `PL2MAP_PLOT_SAMPLE=/tmp/cdf.png cargo test -p score plot::tests::sample -- --ignored`.
    #[test]
    #[ignore]
    fn sample() {
        let Ok(path) = std::env::var("PL2MAP_PLOT_SAMPLE") else {
            println!("SKIPPED PL2MAP_PLOT_SAMPLE is not set");
            return;
        };
        // A plausible indoor scene: log-normal-ish errors, a few frames unlocalised.
        let mut results = Vec::new();
        for i in 0..200u32 {
            let u = (f64::from(i) + 0.5) / 200.0;
            let z = (u - 0.5) * 5.0;
            let mut r = result(
                (i % 23 != 0).then_some(3.0 * (z * 0.9).exp()),
                1.1 * z.exp(),
            );
            if let Some(e) = r.variants[1].error.as_mut() {
                e.translation_m *= 0.7;
                e.rotation_deg *= 0.75;
            }
            if i % 29 == 0 {
                r.variants[0].error = None;
            }
            results.push(r);
        }
        write_plot(Path::new(&path), &results).unwrap();
    }
}
