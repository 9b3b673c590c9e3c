//! The frame of a chart, drawn alike by both plots (`cdf.png`, crates/score/src/plot.rs;
//! `losses.png`, crates/train/src/plot.rs): a white picture, the chart's caption,
//! margins and label areas, the styled mesh (tick labels, axis descriptions, a grid of
//! decades with light minor lines, the axes), and the tick positions and labels of a
//! log axis. Each plot keeps its own sizes ([`FrameStyle`]), axes and curves.

use crate::{Canvas, FONT, draw_err, white_buffer};
use image::RgbImage;
use plotters::chart::MeshStyle;
use plotters::coord::Shift;
use plotters::coord::ranged1d::{AsRangedCoord, Ranged, ValueFormatter};
use plotters::prelude::*;

/// The colour of all text and of the axes.
pub const TEXT: RGBColor = RGBColor(30, 30, 30);
/// The light grid lines between the bold ones.
pub const MINOR_GRID: RGBColor = RGBColor(236, 236, 236);

/// A chart on Cartesian axes `X`, `Y`.
pub type Chart<'c, DB, X, Y> = ChartContext<'c, DB, Cartesian2d<X, Y>>;

/// Sizes and colours of a chart's frame, in pixels.
#[derive(Clone, Copy, Debug)]
pub struct FrameStyle {
    /// Font size of the chart's caption.
    pub caption_px: u32,
    pub margin_top: u32,
    pub margin_bottom: u32,
    pub margin_left: u32,
    pub margin_right: u32,
    /// Height of the x tick labels and description under the chart.
    pub x_label_area: u32,
    /// Width of the y tick labels and description left of the chart.
    pub y_label_area: u32,
    /// Font size of the tick labels.
    pub tick_label_px: u32,
    /// Font size of the axis descriptions.
    pub axis_desc_px: u32,
    /// The bold grid lines (the decades of a log axis).
    pub major_grid: RGBColor,
}

impl FrameStyle {
    /// A chart with this frame's caption, margins and label areas in `area`, on the
    /// axes `x` and `y`.
    pub fn chart<'c, DB: DrawingBackend, X: AsRangedCoord, Y: AsRangedCoord>(
        &self,
        area: &DrawingArea<DB, Shift>,
        caption: &str,
        x: X,
        y: Y,
    ) -> Result<Chart<'c, DB, X::CoordDescType, Y::CoordDescType>, String> {
        ChartBuilder::on(area)
            .caption(caption, (FONT, self.caption_px).into_font().color(&TEXT))
            .margin_top(self.margin_top)
            .margin_bottom(self.margin_bottom)
            .margin_left(self.margin_left)
            .margin_right(self.margin_right)
            .x_label_area_size(self.x_label_area)
            .y_label_area_size(self.y_label_area)
            .build_cartesian_2d(x, y)
            .map_err(draw_err)
    }

    /// The chart's mesh with this frame's text, grid and axis styles; the caller adds
    /// its axis descriptions, tick counts and label formats, then draws it.
    pub fn mesh<'a, 'b, DB, X, Y>(
        &self,
        chart: &'b mut ChartContext<'a, DB, Cartesian2d<X, Y>>,
    ) -> MeshStyle<'a, 'b, X, Y, DB>
    where
        DB: DrawingBackend,
        X: Ranged + ValueFormatter<<X as Ranged>::ValueType>,
        Y: Ranged + ValueFormatter<<Y as Ranged>::ValueType>,
    {
        let mut mesh = chart.configure_mesh();
        mesh.label_style((FONT, self.tick_label_px).into_font().color(&TEXT))
            .axis_desc_style((FONT, self.axis_desc_px).into_font().color(&TEXT))
            .bold_line_style(self.major_grid)
            .light_line_style(MINOR_GRID)
            .axis_style(TEXT);
        mesh
    }
}

/// Draws a `width` x `height` picture with `draw` on a white canvas and returns its
/// pixels.
pub fn draw_rgb(
    width: u32,
    height: u32,
    draw: impl FnOnce(&DrawingArea<Canvas<'_>, Shift>) -> Result<(), String>,
) -> Result<RgbImage, String> {
    let mut buf = white_buffer(width, height);
    {
        let root = Canvas::new(&mut buf, (width, height))?.into_drawing_area();
        root.fill(&WHITE).map_err(draw_err)?;
        draw(&root)?;
        root.present().map_err(draw_err)?;
    }
    RgbImage::from_raw(width, height, buf).ok_or_else(|| "plot buffer of the wrong size".into())
}

/// The ticks of a log axis from 10^`lo` to 10^`hi`: the decades (bold grid lines,
/// labelled) and 2..9 times each decade below `hi` (light grid lines).
pub fn log_ticks(lo: i32, hi: i32) -> (Vec<f64>, Vec<f64>) {
    let decades = (lo..=hi).map(|e| 10f64.powi(e)).collect();
    let minors = (lo..hi)
        .flat_map(|e| (2..10).map(move |m| f64::from(m) * 10f64.powi(e)))
        .collect();
    (decades, minors)
}

/// The tick label of the power of ten `v`: whole numbers up to 100000, decimals down
/// to 0.0001, `1e<exponent>` beyond.
pub fn decade_label(v: f64) -> String {
    let e = v.log10().round() as i32;
    match e {
        0..=5 => format!("{}", 10u64.pow(e as u32)),
        -4..=-1 => format!("{:.*}", (-e) as usize, 10f64.powi(e)),
        _ => format!("1e{e}"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use image::Rgb;

    const STYLE: FrameStyle = FrameStyle {
        caption_px: 18,
        margin_top: 6,
        margin_bottom: 4,
        margin_left: 8,
        margin_right: 16,
        x_label_area: 40,
        y_label_area: 56,
        tick_label_px: 14,
        axis_desc_px: 14,
        major_grid: RGBColor(200, 200, 200),
    };

    /// A frame with a linear x axis and a log y axis from 0.1 to 10, as PNG.
    fn frame_png(caption: &str) -> (Vec<u8>, RgbImage) {
        let img = draw_rgb(360, 240, |root| {
            let (decades, minors) = log_ticks(-1, 1);
            let y = (0.1..10.0)
                .log_scale()
                .with_key_points(decades)
                .with_light_points(minors);
            let mut chart = STYLE.chart(root, caption, 0.0..1.0, y)?;
            let label = |v: &f64| decade_label(*v);
            STYLE
                .mesh(&mut chart)
                .x_desc("x")
                .y_desc("y")
                .y_label_formatter(&label)
                .draw()
                .map_err(draw_err)
        })
        .unwrap();
        let (w, h) = img.dimensions();
        (crate::png(img.clone().into_raw(), w, h).unwrap(), img)
    }

    #[test]
    fn frame_is_drawn_and_deterministic() {
        let (a, img) = frame_png("caption");
        assert_eq!(a, frame_png("caption").0);
        assert_ne!(a, frame_png("another caption").0);
        assert_eq!(img.dimensions(), (360, 240));
        let count = |c: RGBColor| img.pixels().filter(|p| **p == Rgb([c.0, c.1, c.2])).count();
        // The axes and text, the decade lines and the minor lines are all there.
        assert!(count(TEXT) > 300, "{}", count(TEXT));
        assert!(count(STYLE.major_grid) > 200, "{}", count(STYLE.major_grid));
        assert!(count(MINOR_GRID) > 1000, "{}", count(MINOR_GRID));
    }

    #[test]
    fn decade_labels() {
        assert_eq!(decade_label(1e-3), "0.001");
        assert_eq!(decade_label(0.01), "0.01");
        assert_eq!(decade_label(1.0), "1");
        assert_eq!(decade_label(100.0), "100");
        assert_eq!(decade_label(1e3), "1000");
        assert_eq!(decade_label(1e-7), "1e-7");
        assert_eq!(decade_label(1e6), "1e6");
    }

    #[test]
    fn log_ticks_are_decades_and_their_multiples() {
        let (decades, minors) = log_ticks(-1, 1);
        assert_eq!(decades, vec![0.1, 1.0, 10.0]);
        assert_eq!(minors.len(), 16);
        assert_eq!(minors[0], 2.0 * 0.1);
        assert_eq!(minors[8], 2.0);
        assert_eq!(log_ticks(0, 0), (vec![1.0], vec![]));
    }
}
