//! A legend strip under a chart: one line sample and label per curve, centred.

use crate::Canvas;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

/// Sizes of a legend strip, in pixels.
#[derive(Clone, Copy, Debug)]
pub struct LegendStyle {
    pub font_px: u32,
    /// Length of the line sample.
    pub sample: i32,
    /// Between a sample and its label.
    pub gap: i32,
    /// Between two entries.
    pub spacing: i32,
    pub text: RGBColor,
}

/// Draws `entries` (label, colour) centred in `area`.
pub fn legend(
    area: &DrawingArea<Canvas, Shift>,
    entries: &[(&str, RGBColor)],
    s: &LegendStyle,
) -> Result<(), String> {
    let style = TextStyle::from((crate::FONT, s.font_px).into_font())
        .color(&s.text)
        .pos(Pos::new(HPos::Left, VPos::Center));
    let widths: Vec<i32> = entries
        .iter()
        .map(|(l, _)| {
            area.estimate_text_size(l, &style)
                .map(|(w, _)| w as i32)
                .map_err(crate::draw_err)
        })
        .collect::<Result<_, _>>()?;
    let total: i32 = widths.iter().map(|w| s.sample + s.gap + w).sum::<i32>()
        + s.spacing * (entries.len() as i32 - 1).max(0);
    let (w, h) = area.dim_in_pixel();
    let y = h as i32 / 2;
    let mut x = (w as i32 - total) / 2;
    for ((label, color), width) in entries.iter().zip(widths) {
        area.draw(&PathElement::new(
            vec![(x, y), (x + s.sample, y)],
            color.stroke_width(3),
        ))
        .map_err(crate::draw_err)?;
        area.draw(&Text::new(
            label.to_string(),
            (x + s.sample + s.gap, y),
            style.clone(),
        ))
        .map_err(crate::draw_err)?;
        x += s.sample + s.gap + width + s.spacing;
    }
    Ok(())
}
