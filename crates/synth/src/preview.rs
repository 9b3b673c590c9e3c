//! Contact sheets: a few frames side by side, downscaled, with keypoints and line
//! segments drawn on them, so that a person can see what the data looks like.
//!
//! Coordinates are in the COLMAP pixel convention (the top-left pixel's centre is
//! (0.5, 0.5)): a point `(x, y)` of a frame lands at `(x * s, y * s)` on a tile drawn at
//! scale `s`, in the same convention.

use image::{Rgb, RgbImage};

/// Width of one tile in the sheet; frames are downscaled (box filter) to it.
pub const TILE_WIDTH: u32 = 320;
const PAD: u32 = 4;

/// A frame with its keypoints `[x, y]` and segments `[x1, y1, x2, y2]`.
pub type SheetFrame = (RgbImage, Vec<[f64; 2]>, Vec<[f64; 4]>);

/// Tiles `frames` in rows of `cols` (at least 1) on a dark background; keypoints are small
/// yellow circles, segments lines in a cycle of distinct colours.
pub fn contact_sheet(frames: &[SheetFrame], cols: usize) -> RgbImage {
    let cols = cols.max(1).min(frames.len().max(1));
    let rows = frames.len().div_ceil(cols).max(1);
    let tiles: Vec<(RgbImage, f64)> = frames
        .iter()
        .map(|(img, _, _)| {
            let s = if img.width() > TILE_WIDTH {
                TILE_WIDTH as f64 / img.width() as f64
            } else {
                1.0
            };
            (downscale(img, s), s)
        })
        .collect();
    let tw = tiles.iter().map(|t| t.0.width()).max().unwrap_or(1);
    let th = tiles.iter().map(|t| t.0.height()).max().unwrap_or(1);
    let mut sheet = RgbImage::from_pixel(
        cols as u32 * (tw + PAD) + PAD,
        rows as u32 * (th + PAD) + PAD,
        Rgb([24, 24, 28]),
    );
    for (k, ((tile, s), (_, kps, segs))) in tiles.iter().zip(frames).enumerate() {
        let ox = PAD + (k % cols) as u32 * (tw + PAD);
        let oy = PAD + (k / cols) as u32 * (th + PAD);
        for (x, y, p) in tile.enumerate_pixels() {
            sheet.put_pixel(ox + x, oy + y, *p);
        }
        let clip = (
            ox as f64,
            oy as f64,
            (ox + tile.width()) as f64,
            (oy + tile.height()) as f64,
        );
        for (n, seg) in segs.iter().enumerate() {
            let c = SEGMENT_COLOURS[n % SEGMENT_COLOURS.len()];
            draw_line(
                &mut sheet,
                (ox as f64 + seg[0] * s, oy as f64 + seg[1] * s),
                (ox as f64 + seg[2] * s, oy as f64 + seg[3] * s),
                c,
                clip,
            );
        }
        for kp in kps {
            draw_circle(
                &mut sheet,
                (ox as f64 + kp[0] * s, oy as f64 + kp[1] * s),
                2.0,
                [255, 230, 40],
                clip,
            );
        }
    }
    sheet
}

const SEGMENT_COLOURS: [[u8; 3]; 6] = [
    [255, 60, 60],
    [60, 220, 255],
    [80, 255, 80],
    [255, 120, 255],
    [255, 160, 40],
    [120, 140, 255],
];

/// Box-filter downscale by `s` <= 1 (each output pixel averages the input pixels it covers).
pub fn downscale(img: &RgbImage, s: f64) -> RgbImage {
    if s >= 1.0 {
        return img.clone();
    }
    let w = ((img.width() as f64 * s).round() as u32).max(1);
    let h = ((img.height() as f64 * s).round() as u32).max(1);
    let mut out = RgbImage::new(w, h);
    for y in 0..h {
        let y0 = (y as f64 / s).floor() as u32;
        let y1 = (((y + 1) as f64 / s).ceil() as u32)
            .min(img.height())
            .max(y0 + 1);
        for x in 0..w {
            let x0 = (x as f64 / s).floor() as u32;
            let x1 = (((x + 1) as f64 / s).ceil() as u32)
                .min(img.width())
                .max(x0 + 1);
            let mut acc = [0u32; 3];
            let mut n = 0u32;
            for yy in y0..y1.min(img.height()) {
                for xx in x0..x1 {
                    let p = img.get_pixel(xx, yy);
                    for c in 0..3 {
                        acc[c] += p[c] as u32;
                    }
                    n += 1;
                }
            }
            let n = n.max(1);
            out.put_pixel(
                x,
                y,
                Rgb([(acc[0] / n) as u8, (acc[1] / n) as u8, (acc[2] / n) as u8]),
            );
        }
    }
    out
}

/// Blends `c` into the pixel containing the point `(x, y)` (corner-origin coordinates).
fn plot(img: &mut RgbImage, x: f64, y: f64, c: [u8; 3], alpha: f64, clip: (f64, f64, f64, f64)) {
    if !(x >= clip.0 && y >= clip.1 && x < clip.2 && y < clip.3) {
        return;
    }
    let (xi, yi) = (x.floor() as u32, y.floor() as u32);
    if xi >= img.width() || yi >= img.height() {
        return;
    }
    let p = img.get_pixel_mut(xi, yi);
    for k in 0..3 {
        p[k] = (p[k] as f64 * (1.0 - alpha) + c[k] as f64 * alpha).round() as u8;
    }
}

/// A line sampled every half pixel (1 px wide).
fn draw_line(
    img: &mut RgbImage,
    a: (f64, f64),
    b: (f64, f64),
    c: [u8; 3],
    clip: (f64, f64, f64, f64),
) {
    let len = ((b.0 - a.0).powi(2) + (b.1 - a.1).powi(2)).sqrt();
    if !len.is_finite() {
        return;
    }
    let n = (len * 2.0).ceil().clamp(1.0, 1e5) as usize;
    for k in 0..=n {
        let t = k as f64 / n as f64;
        plot(
            img,
            a.0 + (b.0 - a.0) * t,
            a.1 + (b.1 - a.1) * t,
            c,
            0.9,
            clip,
        );
    }
}

fn draw_circle(
    img: &mut RgbImage,
    c: (f64, f64),
    r: f64,
    col: [u8; 3],
    clip: (f64, f64, f64, f64),
) {
    if !(c.0.is_finite() && c.1.is_finite()) {
        return;
    }
    let n = 16;
    for k in 0..n {
        let a = k as f64 * std::f64::consts::TAU / n as f64;
        plot(img, c.0 + r * a.cos(), c.1 + r * a.sin(), col, 1.0, clip);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sheet_layout_and_drawing() {
        let img = RgbImage::from_pixel(640, 480, Rgb([100, 100, 100]));
        let frames: Vec<SheetFrame> = (0..3)
            .map(|_| {
                (
                    img.clone(),
                    vec![[320.0, 240.0]],
                    vec![[0.5, 100.5, 639.5, 100.5]],
                )
            })
            .collect();
        let sheet = contact_sheet(&frames, 2);
        assert_eq!(sheet.width(), 2 * (320 + PAD) + PAD);
        assert_eq!(sheet.height(), 2 * (240 + PAD) + PAD);
        // The horizontal segment at y = 100.5 lands on tile row 50 of the first tile.
        let p = sheet.get_pixel(PAD + 100, PAD + 50);
        assert!(p[0] > 200 && p[1] < 100, "{p:?}");
        // The keypoint circle (radius 2 around (160, 120)) touches (162, 120).
        let p = sheet.get_pixel(PAD + 162, PAD + 120);
        assert_eq!(*p, Rgb([255, 230, 40]));
        // Empty fourth slot stays background.
        let p = sheet.get_pixel(PAD + 324 + 100, PAD + 244 + 100);
        assert_eq!(*p, Rgb([24, 24, 28]));
    }

    #[test]
    fn downscale_averages() {
        let mut img = RgbImage::new(4, 2);
        img.put_pixel(0, 0, Rgb([200, 0, 0]));
        let d = downscale(&img, 0.5);
        assert_eq!(d.dimensions(), (2, 1));
        assert_eq!(d.get_pixel(0, 0)[0], 50);
    }
}
