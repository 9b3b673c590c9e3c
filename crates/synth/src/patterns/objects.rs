//! Recipes of the objects' surfaces: wood (also the picture frame's moulding),
//! cardboard with an optional label, book spines, door panels and plain colours.

use super::LocalEdge;
use super::painter::{Painter, contrasting, random_colour};
use crate::texture::{Ellipse, Octave, Rect, Rgb, luma, scale};
use rand::Rng;
use rand_chacha::ChaCha8Rng;

impl Painter {
    pub(super) fn wood(
        &mut self,
        rng: &mut ChaCha8Rng,
        tone: Rgb,
        grain_along_a: bool,
        region: Rect,
    ) {
        let dark = scale(tone, 0.7);
        let light = scale(tone, 1.2);
        let (long, short) = (0.25, 0.004);
        let oct = |l: f64, s: f64, amp: f32| {
            if grain_along_a {
                Octave {
                    scale_x: l,
                    scale_y: s,
                    amp,
                }
            } else {
                Octave {
                    scale_x: s,
                    scale_y: l,
                    amp,
                }
            }
        };
        self.noise_fill(
            region,
            dark,
            light,
            &[
                oct(0.6, 0.05, 0.4),
                oct(long, short * 3.0, 0.35),
                oct(long * 0.4, short, 0.25),
            ],
            20,
        );
        // Knots and pores: curved, SIFT-friendly, low contrast.
        let pal = [scale(tone, 0.5), scale(tone, 0.65), scale(tone, 1.3)];
        self.blobs(
            rng,
            region,
            0.004,
            (0.002, 0.012),
            0.12,
            &pal,
            0.4,
            (0.7, 1.0),
        );
    }

    pub(super) fn cardboard(&mut self, rng: &mut ChaCha8Rng, tone: Rgb, label: bool) {
        let full = self.full();
        self.noise_fill(
            full,
            scale(tone, 0.9),
            scale(tone, 1.1),
            &[
                Octave::iso(0.2, 0.5),
                Octave::iso(0.03, 0.3),
                Octave::iso(0.006, 0.2),
            ],
            1,
        );
        let ink: Rgb = random_colour(rng, (0.3, 0.8), (0.15, 0.4));
        let pal = [ink, scale(tone, 0.7), scale(tone, 1.2)];
        self.blobs(rng, full, 0.01, (0.003, 0.02), 0.25, &pal, 0.2, (0.5, 0.9));
        if label && self.size[0] > 0.2 && self.size[1] > 0.15 {
            let w = rng.random_range(0.08..(self.size[0] * 0.5).min(0.2));
            let h = rng.random_range(0.05..(self.size[1] * 0.45).min(0.14));
            let x0 = rng.random_range(0.04..self.size[0] - w - 0.04);
            let y0 = rng.random_range(0.04..self.size[1] - h - 0.04);
            let r = Rect::new(x0, y0, x0 + w, y0 + h);
            let paper: Rgb = [0.94, 0.94, 0.92];
            self.canvas.rect(r, paper);
            // Rows of "text" dots.
            let mut y = r.y1 - 0.015;
            while y > r.y0 + 0.012 {
                let mut x = r.x0 + 0.012;
                while x < r.x1 - 0.012 {
                    if rng.random_bool(0.8) {
                        self.canvas.ellipse(&Ellipse {
                            cx: x,
                            cy: y,
                            rx: 0.0035,
                            ry: rng.random_range(0.002..0.0045),
                            angle: 0.0,
                            ring: rng.random_bool(0.3).then_some(0.0015),
                            colour: [0.1, 0.1, 0.12],
                            opacity: 1.0,
                        });
                    }
                    x += rng.random_range(0.007..0.012);
                }
                y -= 0.013;
            }
            self.rect_edges(r, luma(paper) - luma(tone) * 1.1);
        }
    }

    pub(super) fn book_spine(&mut self, rng: &mut ChaCha8Rng, colour: Rgb) {
        let full = self.full();
        self.noise_fill(
            full,
            scale(colour, 0.92),
            scale(colour, 1.08),
            &[Octave::iso(0.05, 0.6), Octave::iso(0.008, 0.4)],
            1,
        );
        let band_c = contrasting(rng, colour, 0.25, (0.0, 0.6));
        let (w, h) = (self.size[0], self.size[1]);
        // Bands across the full width near the top and bottom: their horizontal borders
        // are straight steps (their ends lie on the spine's own edges).
        let bands = [
            (rng.random_range(0.02..0.04), rng.random_range(0.006..0.015)),
            (
                h - rng.random_range(0.03..0.06),
                rng.random_range(0.006..0.02),
            ),
        ];
        for (y, bh) in bands {
            if y > 0.01 && y + bh < h - 0.01 {
                let r = Rect::new(0.0, y, w, y + bh);
                self.canvas.rect(r, band_c);
                let contrast = (luma(band_c) - luma(colour)).abs();
                self.edges.push(LocalEdge {
                    a: [0.0, y],
                    b: [w, y],
                    contrast,
                });
                self.edges.push(LocalEdge {
                    a: [0.0, y + bh],
                    b: [w, y + bh],
                    contrast,
                });
            }
        }
        // Title: a column of dots between the bands.
        let title_c = contrasting(rng, colour, 0.3, (0.0, 0.5));
        let mut y = 0.08;
        let r = (w * 0.18).min(0.006);
        while y < h - 0.09 {
            if rng.random_bool(0.75) {
                self.canvas.ellipse(&Ellipse {
                    cx: w * 0.5,
                    cy: y,
                    rx: r,
                    ry: r * rng.random_range(0.5..1.0),
                    angle: 0.0,
                    ring: rng.random_bool(0.3).then_some(r * 0.4),
                    colour: title_c,
                    opacity: 1.0,
                });
            }
            y += r * 2.6;
        }
    }

    pub(super) fn plain(&mut self, rng: &mut ChaCha8Rng, colour: Rgb, amp: f32) {
        let full = self.full();
        self.noise_fill(
            full,
            scale(colour, 1.0 - amp),
            scale(colour, 1.0 + amp),
            &[
                Octave::iso(0.1, 0.5),
                Octave::iso(0.02, 0.3),
                Octave::iso(0.005, 0.2),
            ],
            1,
        );
        let pal = [scale(colour, 0.6), scale(colour, 1.3)];
        self.blobs(rng, full, 0.003, (0.002, 0.01), 0.15, &pal, 0.3, (0.7, 1.0));
    }

    pub(super) fn door(&mut self, rng: &mut ChaCha8Rng, colour: Rgb) {
        let full = self.full();
        self.noise_fill(
            full,
            scale(colour, 0.95),
            scale(colour, 1.04),
            &[
                Octave::iso(0.3, 0.5),
                Octave::iso(0.05, 0.3),
                Octave::iso(0.01, 0.2),
            ],
            1,
        );
        let groove = scale(colour, 0.6);
        let (w, h) = (self.size[0], self.size[1]);
        let side = 0.12;
        let g = 0.012;
        let panels = [
            Rect::new(side, 0.12, w - side, h * 0.45),
            Rect::new(side, h * 0.45 + 0.12, w - side, h - 0.14),
        ];
        for p in panels {
            if p.width() < 0.1 || p.height() < 0.1 {
                continue;
            }
            // A groove: dark ring between two steps.
            let inner = p.inset(g);
            self.canvas.rect(p, groove);
            self.canvas.rect(inner, colour);
            self.modulate(
                inner.inset(0.003),
                0.04,
                &[Octave::iso(0.1, 0.6), Octave::iso(0.02, 0.4)],
                5,
            );
            let contrast = luma(colour) - luma(groove);
            self.rect_edges(p, contrast);
            self.rect_edges(inner, contrast);
            let pal = [scale(colour, 0.75), scale(colour, 0.85), [0.5, 0.45, 0.4]];
            self.blobs(
                rng,
                inner,
                0.01,
                (0.003, 0.015),
                0.08,
                &pal,
                0.4,
                (0.7, 1.0),
            );
        }
    }
}
