//! The plots' drawing surface, shared by the score stage (`cdf.png`) and the trainer
//! (`losses.png`): plotters draws axes, ticks, grids and curves into an RGB buffer;
//! [`Canvas`] lays out and rasterises text itself with a font embedded in the binary
//! (`assets/DejaVuSans-plot.ttf`, a DejaVu Sans subset, licence next to it), so the same
//! inputs give the same PNG bytes on every machine and no system font is looked up;
//! [`legend`] draws a legend strip; [`png`] encodes the buffer.
//!
//! A crate of the foundation layer (ARCHITECTURE.md): the two plotting crates share it
//! without depending on each other.

mod canvas;
mod legend;

pub use canvas::Canvas;
pub use legend::{LegendStyle, legend};
/// The plotters this canvas implements, for the crates that draw on it.
pub use plotters;

/// The font family named in text styles (the canvas has one font: any name draws it).
pub const FONT: &str = "DejaVu Sans";

/// A drawing error as text.
pub fn draw_err<E: std::fmt::Display>(e: E) -> String {
    format!("drawing the plot: {e}")
}

/// A white RGB buffer of `width` x `height` pixels to draw on.
pub fn white_buffer(width: u32, height: u32) -> Vec<u8> {
    vec![255u8; width as usize * height as usize * 3]
}

/// The PNG bytes of an RGB buffer (deterministic: no time stamp, fixed settings).
pub fn png(buf: Vec<u8>, width: u32, height: u32) -> Result<Vec<u8>, String> {
    let img = image::RgbImage::from_raw(width, height, buf)
        .ok_or_else(|| "plot buffer of the wrong size".to_string())?;
    let mut out = std::io::Cursor::new(Vec::new());
    img.write_to(&mut out, image::ImageFormat::Png)
        .map_err(|e| format!("encoding the plot: {e}"))?;
    Ok(out.into_inner())
}

#[cfg(test)]
mod tests {
    use super::*;
    use plotters::prelude::*;

    fn draw(text: &str) -> Vec<u8> {
        let (w, h) = (240, 60);
        let mut buf = white_buffer(w, h);
        {
            let root = Canvas::new(&mut buf, (w, h)).unwrap().into_drawing_area();
            root.fill(&WHITE).unwrap();
            legend(
                &root,
                &[(text, RGBColor(200, 0, 0))],
                &LegendStyle {
                    font_px: 18,
                    sample: 30,
                    gap: 8,
                    spacing: 30,
                    text: BLACK,
                },
            )
            .unwrap();
            root.present().unwrap();
        }
        png(buf, w, h).unwrap()
    }

    #[test]
    fn text_is_drawn_and_deterministic() {
        let a = draw("points + lines");
        assert_eq!(a, draw("points + lines"));
        assert_ne!(a, draw("points"));
        let img = image::load_from_memory(&a).unwrap().to_rgb8();
        assert_eq!(img.dimensions(), (240, 60));
        // Dark text pixels right of the red line sample.
        let dark = img
            .enumerate_pixels()
            .filter(|(x, _, p)| *x > 100 && p.0.iter().all(|&c| c < 100))
            .count();
        assert!(dark > 20, "{dark} dark pixels");
    }
}
