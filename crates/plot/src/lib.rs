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
///
/// The one PNG encoder of the plotting crates: the PNG encoder itself, with the settings
/// `write_to(.., ImageFormat::Png)` uses (same bytes), because `write_to` is generic
/// over its writer and compiles every enabled encoder (PNG, JPEG, TIFF) again in each
/// crate that calls it.
pub fn png(buf: Vec<u8>, width: u32, height: u32) -> Result<Vec<u8>, String> {
    use image::ImageEncoder as _;
    let expected = width as usize * height as usize * 3;
    if buf.len() != expected {
        return Err(format!(
            "plot buffer of the wrong size: {} bytes for {width} x {height} RGB",
            buf.len()
        ));
    }
    let mut out = Vec::new();
    image::codecs::png::PngEncoder::new(&mut out)
        .write_image(&buf, width, height, image::ExtendedColorType::Rgb8)
        .map_err(|e| format!("encoding the plot: {e}"))?;
    Ok(out)
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
