//! The plots' drawing surface, shared by the score stage (`cdf.png`) and the trainer
//! (`losses.png`): plotters draws axes, ticks, grids and curves into an RGB buffer;
//! [`Canvas`] lays out and rasterises text itself with a font embedded in the binary
//! (`assets/DejaVuSans-plot.ttf`, a DejaVu Sans subset, licence next to it), so the same
//! inputs give the same PNG bytes on every machine and no system font is looked up;
//! [`draw_rgb`] gives a white picture to draw on, [`FrameStyle`] draws a chart's frame
//! (caption, margins, tick labels, axis descriptions, grid, axes) alike in both plots,
//! [`log_ticks`] and [`decade_label`] are a log axis's ticks; [`legend`] draws a legend
//! strip; [`png`] encodes the buffer.
//!
//! A crate of the foundation layer (ARCHITECTURE.md): the two plotting crates share it
//! without depending on each other.

mod buffer;
mod canvas;
mod frame;
mod legend;

pub use buffer::{draw_err, png, white_buffer};
pub use canvas::{Canvas, FONT};
pub use frame::{FrameStyle, MINOR_GRID, TEXT, decade_label, draw_rgb, log_ticks};
pub use legend::{LegendStyle, legend};
/// The plotters this canvas implements, for the crates that draw on it.
pub use plotters;

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

    /// `png` writes the bytes the image crate's generic `write_to` writes (the plots'
    /// files did not change when it replaced it), and refuses a buffer of the wrong size.
    #[test]
    fn png_is_the_image_crates_png() {
        let drawn = image::load_from_memory(&draw("cdf")).unwrap().to_rgb8();
        let (w, h) = drawn.dimensions();
        let mut generic = std::io::Cursor::new(Vec::new());
        drawn
            .write_to(&mut generic, image::ImageFormat::Png)
            .unwrap();
        assert_eq!(png(drawn.into_raw(), w, h).unwrap(), generic.into_inner());
        let err = png(vec![0; 10], 2, 2).unwrap_err();
        assert!(err.contains("10 bytes for 2 x 2"), "{err}");
    }
}
