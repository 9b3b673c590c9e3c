//! Recipes of the room's own surfaces: wallpaper, ceiling, floor tiles and the rug.

use super::LocalEdge;
use super::painter::{Painter, contrasting, random_colour};
use crate::texture::{Ellipse, Octave, Rect, Rgb, hsv, luma, mix, scale};
use rand::Rng;
use rand_chacha::ChaCha8Rng;

impl Painter {
    pub(super) fn wallpaper(&mut self, rng: &mut ChaCha8Rng, palette: u8) {
        // Each wall its own light base and its own set of blob colours.
        let hue = (palette as f32 * 0.27 + rng.random_range(0.0..0.1)) % 1.0;
        let c0 = hsv(
            hue,
            rng.random_range(0.08..0.2),
            rng.random_range(0.78..0.88),
        );
        let c1 = hsv(
            hue + 0.08,
            rng.random_range(0.15..0.3),
            rng.random_range(0.62..0.75),
        );
        let full = self.full();
        self.noise_fill(
            full,
            c0,
            c1,
            &[
                Octave::iso(0.45, 0.4),
                Octave::iso(0.12, 0.3),
                Octave::iso(0.03, 0.2),
                Octave::iso(0.008, 0.1),
            ],
            1,
        );
        // Blob colours near the wall's hue, darker or lighter: a terrazzo-like wallpaper.
        let pal: Vec<Rgb> = (0..5)
            .map(|k| {
                let h = hue + (k as f32 - 2.0) * 0.06 + rng.random_range(-0.03..0.03);
                let v = if k % 2 == 0 {
                    rng.random_range(0.35..0.55)
                } else {
                    rng.random_range(0.88..1.0)
                };
                hsv(h, rng.random_range(0.15..0.45), v)
            })
            .collect();
        // Large faint patches first, then the small flecks SIFT locks on to.
        self.blobs(rng, full, 0.0, (0.03, 0.09), 0.12, &pal, 0.15, (0.25, 0.5));
        self.blobs(
            rng,
            full,
            0.0,
            (0.004, 0.025),
            0.35,
            &pal,
            0.15,
            (0.55, 0.95),
        );
        self.modulate(
            full,
            0.08,
            &[Octave::iso(0.02, 0.5), Octave::iso(0.006, 0.5)],
            2,
        );
    }

    pub(super) fn ceiling(&mut self, rng: &mut ChaCha8Rng) {
        let full = self.full();
        let c0 = [0.9, 0.89, 0.86];
        let c1 = [0.78, 0.77, 0.76];
        self.noise_fill(
            full,
            c0,
            c1,
            &[
                Octave::iso(0.3, 0.5),
                Octave::iso(0.05, 0.3),
                Octave::iso(0.01, 0.2),
            ],
            1,
        );
        let pal = [[0.6, 0.6, 0.62], [0.7, 0.66, 0.6], [0.55, 0.58, 0.6]];
        self.blobs(rng, full, 0.0, (0.006, 0.04), 0.3, &pal, 0.2, (0.7, 1.0));
    }

    pub(super) fn floor_tiles(&mut self, rng: &mut ChaCha8Rng) {
        let full = self.full();
        let grout: Rgb = [0.22, 0.21, 0.2];
        self.canvas.rect(full, grout);
        let tile = rng.random_range(0.45..0.6);
        let gap = 0.008;
        let base = random_colour(rng, (0.15, 0.4), (0.55, 0.7));
        // Grid phase keeps every grout line >= 8 cm from the walls (partial tiles at the border).
        let ox = rng.random_range(0.08..tile - 0.08);
        let oy = rng.random_range(0.08..tile - 0.08);
        let mut k = 10;
        let mut x = ox - tile;
        while x < self.size[0] {
            let mut y = oy - tile;
            while y < self.size[1] {
                let r = Rect::new(
                    (x + gap * 0.5).max(0.0),
                    (y + gap * 0.5).max(0.0),
                    (x + tile - gap * 0.5).min(self.size[0]),
                    (y + tile - gap * 0.5).min(self.size[1]),
                );
                if r.width() > 0.02 && r.height() > 0.02 {
                    let c = scale(base, rng.random_range(0.85..1.12));
                    let c2 = mix(c, random_colour(rng, (0.1, 0.3), (0.4, 0.7)), 0.35);
                    self.canvas.rect(r, c);
                    // Mottling, then stone speckles inside the tile, clear of the grout.
                    let inner = r.inset(0.004);
                    self.noise_fill(
                        inner,
                        c,
                        c2,
                        &[
                            Octave::iso(0.12, 0.5),
                            Octave::iso(0.03, 0.3),
                            Octave::iso(0.007, 0.2),
                        ],
                        k,
                    );
                    let pal = [scale(c, 0.55), scale(c, 1.3), c2, [0.3, 0.28, 0.25]];
                    self.blobs(rng, r, 0.012, (0.002, 0.02), 0.35, &pal, 0.15, (0.7, 1.0));
                    let contrast = luma(c) - luma(grout);
                    for s in r.sides() {
                        let on_border = |v: f64, lim: f64| v <= 0.0 || v >= lim;
                        let vertical = s[0] == s[2];
                        let skip = if vertical {
                            on_border(s[0], self.size[0])
                        } else {
                            on_border(s[1], self.size[1])
                        };
                        if !skip {
                            self.edges.push(LocalEdge {
                                a: [s[0], s[1]],
                                b: [s[2], s[3]],
                                contrast,
                            });
                        }
                    }
                    k += 1;
                }
                y += tile;
            }
            x += tile;
        }
    }

    pub(super) fn rug(&mut self, rng: &mut ChaCha8Rng) {
        let full = self.full();
        let band_c = random_colour(rng, (0.4, 0.8), (0.2, 0.4));
        let field_c = contrasting(rng, band_c, 0.25, (0.2, 0.6));
        self.canvas.rect(full, band_c);
        let band = rng.random_range(0.08..0.14);
        let field = full.inset(band);
        self.canvas.rect(field, field_c);
        let field_c2 = mix(field_c, band_c, 0.3);
        self.noise_fill(
            field.inset(0.004),
            field_c,
            field_c2,
            &[
                Octave::iso(0.2, 0.5),
                Octave::iso(0.04, 0.3),
                Octave::iso(0.01, 0.2),
            ],
            1,
        );
        let pal = [
            band_c,
            scale(field_c, 1.3),
            random_colour(rng, (0.5, 0.9), (0.3, 0.9)),
        ];
        self.blobs(
            rng,
            field,
            0.015,
            (0.005, 0.05),
            0.5,
            &pal,
            0.35,
            (0.7, 1.0),
        );
        self.rect_edges(field, (luma(field_c) - luma(band_c)).abs());
        // Dots along the band, away from both steps.
        let dot_c = contrasting(rng, band_c, 0.3, (0.0, 0.5));
        let mid = full.inset(band * 0.5);
        let mut t = 0.0;
        let per = mid.width() * 2.0 + mid.height() * 2.0;
        while t < per {
            let (x, y) = perimeter_point(&mid, t);
            self.canvas.ellipse(&Ellipse {
                cx: x,
                cy: y,
                rx: band * 0.2,
                ry: band * 0.2,
                angle: 0.0,
                ring: None,
                colour: dot_c,
                opacity: 1.0,
            });
            t += band * rng.random_range(0.8..1.6);
        }
    }
}

/// Point at arc length `t` along the rectangle's perimeter (counter-clockwise from (x0, y0)).
fn perimeter_point(r: &Rect, t: f64) -> (f64, f64) {
    let (w, h) = (r.width(), r.height());
    if t < w {
        (r.x0 + t, r.y0)
    } else if t < w + h {
        (r.x1, r.y0 + t - w)
    } else if t < 2.0 * w + h {
        (r.x1 - (t - w - h), r.y1)
    } else {
        (r.x0, r.y1 - (t - 2.0 * w - h))
    }
}
