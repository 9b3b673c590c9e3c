//! A bitmap canvas: plotters' `BitMapBackend` draws the lines and areas, text is laid
//! out and rasterised here with the embedded font (`assets/`, a DejaVu Sans subset):
//! kerning, side bearings and sub-pixel pen positions kept, no system font looked up.
//! The same text gives the same pixels on every machine.

use ab_glyph::{Font, FontRef, Glyph, PxScale, ScaleFont, point};
use plotters::backend::BitMapBackend;
use plotters::prelude::DrawingBackend;
use plotters::style::text_anchor::{HPos, VPos};
use plotters_backend::{
    BackendColor, BackendCoord, BackendStyle, BackendTextStyle, DrawingErrorKind,
};

/// The font family named in text styles (the canvas has one font: any name draws it).
pub const FONT: &str = "DejaVu Sans";

static FONT_BYTES: &[u8] = include_bytes!("../assets/DejaVuSans-plot.ttf");

type Error = DrawingErrorKind<<BitMapBackend<'static> as DrawingBackend>::ErrorType>;

pub struct Canvas<'a> {
    bitmap: BitMapBackend<'a>,
    font: FontRef<'static>,
}

impl<'a> Canvas<'a> {
    /// A canvas over an RGB buffer of `size.0 * size.1 * 3` bytes.
    pub fn new(buf: &'a mut [u8], size: (u32, u32)) -> Result<Self, String> {
        let font = FontRef::try_from_slice(FONT_BYTES).map_err(|e| {
            format!("the embedded plot font (crates/plot/assets/DejaVuSans-plot.ttf): {e}")
        })?;
        Ok(Self {
            bitmap: BitMapBackend::with_buffer(buf, size),
            font,
        })
    }

    /// The glyphs of `text` with the pen starting at (0, 0) on the baseline, and
    /// the advance width, in pixels.
    fn layout(&self, text: &str, size: f64) -> (Vec<Glyph>, f32) {
        let font = self.font.as_scaled(PxScale::from(size as f32));
        let (mut x, mut prev, mut glyphs) = (0f32, None, Vec::new());
        for c in text.chars() {
            let id = font.glyph_id(c);
            if let Some(p) = prev {
                x += font.kern(p, id);
            }
            glyphs.push(id.with_scale_and_position(font.scale(), point(x, 0.0)));
            x += font.h_advance(id);
            prev = Some(id);
        }
        (glyphs, x)
    }

    /// Ascent, descent (negative) and capital height in pixels.
    fn metrics(&self, size: f64) -> (f32, f32, f32) {
        let font = self.font.as_scaled(PxScale::from(size as f32));
        let cap = self
            .font
            .outline(self.font.glyph_id('H'))
            // ab_glyph keeps the y-up top of the box in `min.y`.
            .map(|o| o.bounds.min.y * font.v_scale_factor())
            .unwrap_or(0.7 * font.ascent());
        (font.ascent(), font.descent(), cap)
    }
}

impl DrawingBackend for Canvas<'_> {
    type ErrorType = <BitMapBackend<'static> as DrawingBackend>::ErrorType;

    fn get_size(&self) -> (u32, u32) {
        self.bitmap.get_size()
    }
    fn ensure_prepared(&mut self) -> Result<(), Error> {
        self.bitmap.ensure_prepared()
    }
    fn present(&mut self) -> Result<(), Error> {
        self.bitmap.present()
    }
    fn draw_pixel(&mut self, p: BackendCoord, color: BackendColor) -> Result<(), Error> {
        self.bitmap.draw_pixel(p, color)
    }
    fn draw_line<S: BackendStyle>(
        &mut self,
        from: BackendCoord,
        to: BackendCoord,
        style: &S,
    ) -> Result<(), Error> {
        self.bitmap.draw_line(from, to, style)
    }
    fn draw_rect<S: BackendStyle>(
        &mut self,
        upper_left: BackendCoord,
        bottom_right: BackendCoord,
        style: &S,
        fill: bool,
    ) -> Result<(), Error> {
        self.bitmap.draw_rect(upper_left, bottom_right, style, fill)
    }
    /// Thick paths with a square brush of `width` x `width` pixels: no spikes where
    /// the polygon joins of plotters meet the sharp turns of noisy or stepped curves.
    fn draw_path<S: BackendStyle, I: IntoIterator<Item = BackendCoord>>(
        &mut self,
        path: I,
        style: &S,
    ) -> Result<(), Error> {
        let width = style.stroke_width() as i32;
        if width <= 1 {
            return self.bitmap.draw_path(path, style);
        }
        let points: Vec<BackendCoord> = path.into_iter().collect();
        let color = style.color();
        let lo = -(width - 1) / 2;
        for dy in lo..lo + width {
            for dx in lo..lo + width {
                let shifted = points.iter().map(|&(x, y)| (x + dx, y + dy));
                self.bitmap.draw_path(shifted, &color)?;
            }
        }
        Ok(())
    }
    fn draw_circle<S: BackendStyle>(
        &mut self,
        center: BackendCoord,
        radius: u32,
        style: &S,
        fill: bool,
    ) -> Result<(), Error> {
        self.bitmap.draw_circle(center, radius, style, fill)
    }
    fn fill_polygon<S: BackendStyle, I: IntoIterator<Item = BackendCoord>>(
        &mut self,
        vert: I,
        style: &S,
    ) -> Result<(), Error> {
        self.bitmap.fill_polygon(vert, style)
    }
    fn blit_bitmap(
        &mut self,
        pos: BackendCoord,
        size: (u32, u32),
        src: &[u8],
    ) -> Result<(), Error> {
        self.bitmap.blit_bitmap(pos, size, src)
    }

    /// The box of the unrotated text: advance width by line height.
    fn estimate_text_size<S: BackendTextStyle>(
        &self,
        text: &str,
        style: &S,
    ) -> Result<(u32, u32), Error> {
        let (_, width) = self.layout(text, style.size());
        let (ascent, descent, _) = self.metrics(style.size());
        Ok((width.ceil() as u32, (ascent - descent).ceil() as u32))
    }

    /// Horizontal anchors at the pen's start, middle or end; vertical ones at the
    /// ascent, the middle of the capitals (so labels centre on their tick) or the
    /// descent. Rotation turns the laid-out pixels about the anchor.
    fn draw_text<S: BackendTextStyle>(
        &mut self,
        text: &str,
        style: &S,
        pos: BackendCoord,
    ) -> Result<(), Error> {
        let color = style.color();
        if color.alpha == 0.0 {
            return Ok(());
        }
        let (glyphs, width) = self.layout(text, style.size());
        let (ascent, descent, cap) = self.metrics(style.size());
        let anchor = style.anchor();
        let dx = match anchor.h_pos {
            HPos::Left => 0.0,
            HPos::Center => -width / 2.0,
            HPos::Right => -width,
        };
        let baseline = match anchor.v_pos {
            VPos::Top => ascent,
            VPos::Center => cap / 2.0,
            VPos::Bottom => descent,
        };
        let transform = style.transform();
        let mut coverage = Vec::new();
        for mut glyph in glyphs {
            glyph.position.x += dx;
            glyph.position.y += baseline;
            let Some(outline) = self.font.outline_glyph(glyph) else {
                continue;
            };
            let min = outline.px_bounds().min;
            outline.draw(|x, y, c| {
                coverage.push((min.x as i32 + x as i32, min.y as i32 + y as i32, c))
            });
        }
        for (x, y, c) in coverage {
            if c > 0.0 {
                let (x, y) = transform.transform(x, y);
                let c = f64::from(c.min(1.0));
                self.bitmap
                    .draw_pixel((pos.0 + x, pos.1 + y), color.mix(c))?;
            }
        }
        Ok(())
    }
}
