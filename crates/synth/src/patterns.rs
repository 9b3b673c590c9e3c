//! Texture recipes. Each paints one quad's texture from its own seed and returns the
//! straight intensity steps it drew, as segments in the quad's local metres, so that
//! the scene can list them as exact 3D edges.
//!
//! Design rules that keep those edge lists honest:
//! - straight steps come only from flat-coloured rectangles and stripes whose colours
//!   differ in luma by at least [`MIN_CONTRAST`]; they never overlap one another;
//! - everything SIFT is meant to find (value noise, ellipses, rings, dots) is curved and
//!   kept a margin away from the listed steps, so it never breaks an edge;
//! - a final low-amplitude noise modulates every texel multiplicatively, which changes
//!   no edge position.

use super::texture::{Canvas, Ellipse, Octave, Rect, Rgb, Texture, hash64, luma, mix, scale};
use rand::Rng;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

/// Minimum luma difference (of the flat colours, before shading) of a listed texture edge.
pub const MIN_CONTRAST: f32 = 0.12;

/// A straight intensity step inside a texture, in local metres.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LocalEdge {
    pub a: [f64; 2],
    pub b: [f64; 2],
    /// Luma difference of the flat colours on both sides (0..1).
    pub contrast: f32,
}

/// Which recipe paints a quad.
#[derive(Clone, Debug, PartialEq)]
pub enum Material {
    Wallpaper {
        palette: u8,
    },
    Ceiling,
    FloorTiles,
    Rug,
    PosterMondrian,
    PosterStripes,
    /// Front of a picture frame: moulding of the given width, a mat, a photo.
    Picture {
        moulding: f64,
    },
    /// Wood; `grain_along_a` orients the streaks along the quad's `u` axis.
    Wood {
        tone: Rgb,
        grain_along_a: bool,
    },
    Cardboard {
        tone: Rgb,
        label: bool,
    },
    BookSpine {
        colour: Rgb,
    },
    BookCover {
        colour: Rgb,
    },
    Pages,
    Door {
        colour: Rgb,
    },
    Plain {
        colour: Rgb,
    },
}

/// Paints `material` on a quad of `size` metres at `rho` texels per metre.
pub fn paint(
    material: &Material,
    size: [f64; 2],
    rho: f64,
    seed: u64,
) -> (Texture, Vec<LocalEdge>) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut p = Painter {
        canvas: Canvas::new(size, rho, [0.5; 3]),
        size,
        edges: Vec::new(),
        seed,
    };
    match material {
        Material::Wallpaper { palette } => p.wallpaper(&mut rng, *palette),
        Material::Ceiling => p.ceiling(&mut rng),
        Material::FloorTiles => p.floor_tiles(&mut rng),
        Material::Rug => p.rug(&mut rng),
        Material::PosterMondrian => p.mondrian(&mut rng),
        Material::PosterStripes => p.stripes(&mut rng),
        Material::Picture { moulding } => p.picture(&mut rng, *moulding),
        Material::Wood {
            tone,
            grain_along_a,
        } => p.wood(
            &mut rng,
            *tone,
            *grain_along_a,
            Rect::new(0.0, 0.0, size[0], size[1]),
        ),
        Material::Cardboard { tone, label } => p.cardboard(&mut rng, *tone, *label),
        Material::BookSpine { colour } => p.book_spine(&mut rng, *colour),
        Material::BookCover { colour } => p.plain(&mut rng, *colour, 0.12),
        Material::Pages => p.plain(&mut rng, [0.93, 0.9, 0.82], 0.06),
        Material::Door { colour } => p.door(&mut rng, *colour),
        Material::Plain { colour } => p.plain(&mut rng, *colour, 0.1),
    }
    p.grain();
    let edges = p
        .edges
        .into_iter()
        .filter(|e| {
            let l = ((e.b[0] - e.a[0]).powi(2) + (e.b[1] - e.a[1]).powi(2)).sqrt();
            l >= 0.01 && e.contrast >= MIN_CONTRAST
        })
        .collect();
    (p.canvas.finish(), edges)
}

/// A colour from hue (0..1), saturation and value.
pub fn hsv(h: f32, s: f32, v: f32) -> Rgb {
    let h = (h.rem_euclid(1.0)) * 6.0;
    let i = h.floor();
    let f = h - i;
    let p = v * (1.0 - s);
    let q = v * (1.0 - s * f);
    let t = v * (1.0 - s * (1.0 - f));
    match i as i32 {
        0 => [v, t, p],
        1 => [q, v, p],
        2 => [p, v, t],
        3 => [p, q, v],
        4 => [t, p, v],
        _ => [v, p, q],
    }
}

fn random_colour(rng: &mut ChaCha8Rng, s: (f32, f32), v: (f32, f32)) -> Rgb {
    hsv(
        rng.random::<f32>(),
        rng.random_range(s.0..s.1),
        rng.random_range(v.0..v.1),
    )
}

/// A colour whose luma differs from `from` by at least `min` (tries, then falls back to
/// black or white, whichever is farther).
fn contrasting(rng: &mut ChaCha8Rng, from: Rgb, min: f32, s: (f32, f32)) -> Rgb {
    for _ in 0..32 {
        let c = random_colour(rng, s, (0.15, 1.0));
        if (luma(c) - luma(from)).abs() >= min {
            return c;
        }
    }
    if luma(from) > 0.5 {
        [0.08; 3]
    } else {
        [0.95; 3]
    }
}

struct Painter {
    canvas: Canvas,
    size: [f64; 2],
    edges: Vec<LocalEdge>,
    seed: u64,
}

impl Painter {
    fn full(&self) -> Rect {
        Rect::new(0.0, 0.0, self.size[0], self.size[1])
    }

    fn sub_seed(&self, k: u64) -> u64 {
        hash64(self.seed ^ k.wrapping_mul(0xD6E8_FEB8_6659_FD93))
    }

    fn rect_edges(&mut self, r: Rect, contrast: f32) {
        for s in r.sides() {
            self.edges.push(LocalEdge {
                a: [s[0], s[1]],
                b: [s[2], s[3]],
                contrast,
            });
        }
    }

    /// Per-texel multiplicative grain on everything (+-3 %): fine texture at close range
    /// that moves no edge.
    fn grain(&mut self) {
        let seed = self.sub_seed(999);
        self.canvas.white_noise(seed, 0.03);
    }

    /// Two-colour value-noise background over `region`.
    fn noise_fill(&mut self, region: Rect, c0: Rgb, c1: Rgb, octaves: &[Octave], k: u64) {
        let seed = self.sub_seed(k);
        let total: f32 = octaves.iter().map(|o| o.amp).sum();
        self.canvas.fbm_rows(region, seed, octaves, |t, v| {
            let x = (v / total - 0.5) * 2.2 + 0.5;
            *t = mix(c0, c1, x.clamp(0.0, 1.0));
        });
    }

    /// Luminance modulation by value noise inside `region` (factor in [1-amp, 1+amp]).
    fn modulate(&mut self, region: Rect, amp: f32, octaves: &[Octave], k: u64) {
        let seed = self.sub_seed(k);
        let total: f32 = octaves.iter().map(|o| o.amp).sum();
        self.canvas.fbm_rows(region, seed, octaves, |t, v| {
            *t = scale(*t, 1.0 + amp * ((v / total) * 2.0 - 1.0));
        });
    }

    /// Scatters ellipses, rings and dots inside `region` (kept `margin` inside it):
    /// `coverage` is the expected fraction of area covered, radii log-uniform.
    #[allow(clippy::too_many_arguments)]
    fn blobs(
        &mut self,
        rng: &mut ChaCha8Rng,
        region: Rect,
        margin: f64,
        radii: (f64, f64),
        coverage: f64,
        palette: &[Rgb],
        ring_prob: f64,
        opacity: (f32, f32),
    ) {
        let inner = region.inset(margin);
        if inner.width() <= 2.0 * radii.0 || inner.height() <= 2.0 * radii.0 || palette.is_empty() {
            return;
        }
        let (l0, l1) = (radii.0.ln(), radii.1.ln());
        // Mean of r^2 under a log-uniform law.
        let mean_r2 = if (l1 - l0).abs() < 1e-9 {
            radii.0 * radii.0
        } else {
            (radii.1 * radii.1 - radii.0 * radii.0) / (2.0 * (l1 - l0))
        };
        let area = inner.width() * inner.height();
        let n = (coverage * area / (std::f64::consts::PI * mean_r2 * 0.75)).round() as usize;
        let n = n.min(200_000);
        for _ in 0..n {
            let r = rng.random_range(l0..=l1).exp();
            let aspect = rng.random_range(0.45..1.0);
            let rmax = r.min(inner.width() * 0.5).min(inner.height() * 0.5);
            let cx = uniform(rng, inner.x0 + rmax, inner.x1 - rmax);
            let cy = uniform(rng, inner.y0 + rmax, inner.y1 - rmax);
            let colour = palette[rng.random_range(0..palette.len())];
            let colour = scale(colour, rng.random_range(0.8..1.15));
            let ring = if rng.random_bool(ring_prob) {
                Some(rmax * rng.random_range(0.15..0.4))
            } else {
                None
            };
            let ring_pad = ring.unwrap_or(0.0) * 0.5;
            let rx = (rmax - ring_pad).max(1e-4);
            self.canvas.ellipse(&Ellipse {
                cx,
                cy,
                rx,
                ry: rx * aspect,
                angle: rng.random_range(0.0..std::f64::consts::PI),
                ring,
                colour,
                opacity: rng.random_range(opacity.0..=opacity.1),
            });
        }
    }

    fn wallpaper(&mut self, rng: &mut ChaCha8Rng, palette: u8) {
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

    fn ceiling(&mut self, rng: &mut ChaCha8Rng) {
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

    fn floor_tiles(&mut self, rng: &mut ChaCha8Rng) {
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

    fn rug(&mut self, rng: &mut ChaCha8Rng) {
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

    /// Paper margin, black ground, coloured cells separated by black lines (recursive
    /// splits); dots inside the cells.
    fn mondrian(&mut self, rng: &mut ChaCha8Rng) {
        let full = self.full();
        let paper: Rgb = [0.92, 0.91, 0.87];
        let black: Rgb = [0.06, 0.06, 0.07];
        self.canvas.rect(full, paper);
        let margin = rng.random_range(0.03..0.05);
        let ground = full.inset(margin);
        self.canvas.rect(ground, black);
        self.rect_edges(ground, luma(paper) - luma(black));
        let line = rng.random_range(0.01..0.018);
        let mut cells = Vec::new();
        split_cells(rng, ground.inset(line), line, 0, &mut cells);
        let palette: [Rgb; 7] = [
            [0.85, 0.12, 0.1],
            [0.95, 0.8, 0.1],
            [0.25, 0.4, 0.8],
            [0.93, 0.93, 0.9],
            [0.75, 0.75, 0.75],
            [0.3, 0.65, 0.35],
            [0.95, 0.55, 0.15],
        ];
        for (k, cell) in cells.iter().enumerate() {
            let c = palette[rng.random_range(0..palette.len())];
            self.canvas.rect(*cell, c);
            self.modulate(
                cell.inset(0.003),
                0.06,
                &[Octave::iso(0.05, 0.6), Octave::iso(0.01, 0.4)],
                100 + k as u64,
            );
            let dot = contrasting(rng, c, 0.3, (0.3, 0.9));
            let pal = [dot, scale(dot, 0.7), contrasting(rng, c, 0.25, (0.0, 0.8))];
            self.blobs(
                rng,
                *cell,
                0.012,
                (0.003, 0.02),
                0.25,
                &pal,
                0.3,
                (0.7, 1.0),
            );
            self.rect_edges(*cell, luma(c) - luma(black));
        }
    }

    /// Paper margin, black outline, straight stripes at one angle with dots between.
    fn stripes(&mut self, rng: &mut ChaCha8Rng) {
        let full = self.full();
        let paper: Rgb = [0.9, 0.9, 0.86];
        let black: Rgb = [0.07, 0.07, 0.08];
        self.canvas.rect(full, paper);
        let outer = full.inset(rng.random_range(0.03..0.05));
        let line = rng.random_range(0.01..0.015);
        let inner = outer.inset(line);
        self.canvas.rect(outer, black);
        self.rect_edges(outer, luma(paper) - luma(black));
        // Two alternating colours of clearly different luma, both far from black.
        let light = random_colour(rng, (0.2, 0.7), (0.85, 1.0));
        let mut dark = random_colour(rng, (0.5, 0.9), (0.55, 0.8));
        for _ in 0..16 {
            if luma(light) - luma(dark) >= 0.25 && luma(dark) >= 0.3 {
                break;
            }
            dark = random_colour(rng, (0.5, 0.9), (0.55, 0.8));
        }
        if !(luma(light) - luma(dark) >= 0.25 && luma(dark) >= 0.3) {
            dark = [0.75, 0.25, 0.2];
        }
        let colours = [light, dark];
        let angles = [0.0f64, 90.0, 30.0, -30.0, 45.0, -45.0, 60.0, -60.0];
        let theta = angles[rng.random_range(0..angles.len())].to_radians();
        let (s, c) = theta.sin_cos();
        // Stripe boundaries are lines n . p = d with n the unit normal of the stripes.
        let n = [-s, c];
        let corners = [
            [inner.x0, inner.y0],
            [inner.x1, inner.y0],
            [inner.x1, inner.y1],
            [inner.x0, inner.y1],
        ];
        let ds: Vec<f64> = corners.iter().map(|p| n[0] * p[0] + n[1] * p[1]).collect();
        let dmin = ds.iter().cloned().fold(f64::INFINITY, f64::min);
        let dmax = ds.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
        let mut bounds = vec![dmin];
        let mut d = dmin + rng.random_range(0.015..0.06);
        while d < dmax - 0.015 {
            bounds.push(d);
            d += rng.random_range(0.015..0.06);
        }
        bounds.push(dmax);
        self.canvas.stripes(inner, n, &bounds, &colours);
        let contrast = luma(light) - luma(dark);
        for &b in &bounds[1..bounds.len() - 1] {
            if let Some(seg) = clip_line_to_rect(n, b, &inner) {
                self.edges.push(LocalEdge {
                    a: [seg[0], seg[1]],
                    b: [seg[2], seg[3]],
                    contrast,
                });
            }
        }
        self.rect_edges(inner, luma(dark).min(luma(light)) - luma(black));
        self.modulate(
            inner.inset(0.002),
            0.05,
            &[Octave::iso(0.05, 0.6), Octave::iso(0.01, 0.4)],
            3,
        );
        // Dots wholly inside single stripes, >= 4 mm from every boundary.
        let dots = (inner.width() * inner.height() * 900.0) as usize;
        for _ in 0..dots {
            let r = rng.random_range(0.003f64..0.012);
            let x = rng.random_range(inner.x0 + r + 0.006..inner.x1 - r - 0.006);
            let y = rng.random_range(inner.y0 + r + 0.006..inner.y1 - r - 0.006);
            let dd = n[0] * x + n[1] * y;
            let k = bounds.partition_point(|&b| b <= dd).saturating_sub(1);
            if k + 1 >= bounds.len() || dd - bounds[k] < r + 0.004 || bounds[k + 1] - dd < r + 0.004
            {
                continue;
            }
            let under = colours[k % 2];
            let colour = contrasting(rng, under, 0.2, (0.3, 1.0));
            let ring = rng.random_bool(0.3).then_some(r * 0.35);
            self.canvas.ellipse(&Ellipse {
                cx: x,
                cy: y,
                rx: r,
                ry: r * rng.random_range(0.6..1.0),
                angle: rng.random_range(0.0..3.2),
                ring,
                colour,
                opacity: 1.0,
            });
        }
    }

    fn picture(&mut self, rng: &mut ChaCha8Rng, moulding: f64) {
        let full = self.full();
        let tone = [0.45, 0.3, 0.18];
        let tone = scale(tone, rng.random_range(0.6..1.3));
        self.wood(rng, tone, true, full);
        let mat_rect = full.inset(moulding);
        let mat: Rgb = [0.93, 0.92, 0.88];
        self.canvas.rect(mat_rect, mat);
        self.rect_edges(mat_rect, luma(mat) - luma(tone).min(0.9));
        let mat_w = rng
            .random_range(0.025f64..0.05)
            .min(mat_rect.width() * 0.2)
            .min(mat_rect.height() * 0.2);
        let photo = mat_rect.inset(mat_w);
        // A "photo": three-colour noise landscape with large and small blobs; kept darker
        // than the mat so its border is a clear step.
        let a = random_colour(rng, (0.3, 0.8), (0.25, 0.6));
        let b = random_colour(rng, (0.3, 0.8), (0.2, 0.6));
        self.canvas.rect(photo, a);
        self.noise_fill(
            photo.inset(0.003),
            a,
            b,
            &[
                Octave::iso(0.15, 0.5),
                Octave::iso(0.04, 0.3),
                Octave::iso(0.01, 0.2),
            ],
            7,
        );
        let pal: Vec<Rgb> = (0..5)
            .map(|_| random_colour(rng, (0.3, 1.0), (0.1, 0.95)))
            .collect();
        self.blobs(rng, photo, 0.01, (0.02, 0.06), 0.3, &pal, 0.2, (0.7, 1.0));
        self.blobs(
            rng,
            photo,
            0.008,
            (0.003, 0.02),
            0.5,
            &pal,
            0.25,
            (0.7, 1.0),
        );
        let photo_luma = 0.5 * (luma(a) + luma(b));
        self.rect_edges(photo, luma(mat) - photo_luma);
    }

    fn wood(&mut self, rng: &mut ChaCha8Rng, tone: Rgb, grain_along_a: bool, region: Rect) {
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

    fn cardboard(&mut self, rng: &mut ChaCha8Rng, tone: Rgb, label: bool) {
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

    fn book_spine(&mut self, rng: &mut ChaCha8Rng, colour: Rgb) {
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

    fn plain(&mut self, rng: &mut ChaCha8Rng, colour: Rgb, amp: f32) {
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

    fn door(&mut self, rng: &mut ChaCha8Rng, colour: Rgb) {
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

/// Uniform in `[lo, hi]`, or `lo` when rounding made the range empty.
fn uniform(rng: &mut ChaCha8Rng, lo: f64, hi: f64) -> f64 {
    if hi > lo {
        rng.random_range(lo..=hi)
    } else {
        lo
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

/// Recursive split into cells separated by gaps of `line`.
fn split_cells(rng: &mut ChaCha8Rng, r: Rect, line: f64, depth: u32, out: &mut Vec<Rect>) {
    const MIN: f64 = 0.07;
    let can_x = r.width() > 2.0 * MIN + line;
    let can_y = r.height() > 2.0 * MIN + line;
    let stop = depth >= 4 || (!can_x && !can_y) || (depth >= 2 && rng.random_bool(0.3));
    if stop {
        out.push(r);
        return;
    }
    let along_x = if can_x && can_y {
        rng.random_bool((r.width() / (r.width() + r.height())).clamp(0.2, 0.8))
    } else {
        can_x
    };
    if along_x {
        let p = rng.random_range(r.x0 + MIN..r.x1 - MIN - line);
        split_cells(rng, Rect::new(r.x0, r.y0, p, r.y1), line, depth + 1, out);
        split_cells(
            rng,
            Rect::new(p + line, r.y0, r.x1, r.y1),
            line,
            depth + 1,
            out,
        );
    } else {
        let p = rng.random_range(r.y0 + MIN..r.y1 - MIN - line);
        split_cells(rng, Rect::new(r.x0, r.y0, r.x1, p), line, depth + 1, out);
        split_cells(
            rng,
            Rect::new(r.x0, p + line, r.x1, r.y1),
            line,
            depth + 1,
            out,
        );
    }
}

/// The segment of the line `n . p = d` (n unit) inside `r`, if any.
fn clip_line_to_rect(n: [f64; 2], d: f64, r: &Rect) -> Option<[f64; 4]> {
    // Parametrise p = n d + s t with t the direction (-n1, n0); clip s to the slabs.
    let t = [-n[1], n[0]];
    let p0 = [n[0] * d, n[1] * d];
    let mut lo = f64::NEG_INFINITY;
    let mut hi = f64::INFINITY;
    for k in 0..2 {
        let (min, max) = if k == 0 { (r.x0, r.x1) } else { (r.y0, r.y1) };
        if t[k].abs() < 1e-12 {
            if p0[k] < min || p0[k] > max {
                return None;
            }
        } else {
            let a = (min - p0[k]) / t[k];
            let b = (max - p0[k]) / t[k];
            lo = lo.max(a.min(b));
            hi = hi.min(a.max(b));
        }
    }
    (hi - lo > 1e-6).then(|| {
        [
            p0[0] + t[0] * lo,
            p0[1] + t[1] * lo,
            p0[0] + t[0] * hi,
            p0[1] + t[1] * hi,
        ]
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clip_line() {
        let r = Rect::new(0.0, 0.0, 2.0, 1.0);
        // Vertical line x = 0.5 (normal (1, 0)).
        let s = clip_line_to_rect([1.0, 0.0], 0.5, &r).unwrap();
        let (ys, ye) = (s[1].min(s[3]), s[1].max(s[3]));
        assert!((s[0] - 0.5).abs() < 1e-12 && (s[2] - 0.5).abs() < 1e-12);
        assert!(ys.abs() < 1e-12 && (ye - 1.0).abs() < 1e-12);
        // Diagonal x + y = 1 (normal (1,1)/sqrt2, d = 1/sqrt2): from (0,1) to (1,0).
        let h = std::f64::consts::FRAC_1_SQRT_2;
        let s = clip_line_to_rect([h, h], h, &r).unwrap();
        let mut pts = [[s[0], s[1]], [s[2], s[3]]];
        pts.sort_by(|a, b| a[0].total_cmp(&b[0]));
        assert!((pts[0][0]).abs() < 1e-12 && (pts[0][1] - 1.0).abs() < 1e-12);
        assert!((pts[1][0] - 1.0).abs() < 1e-12 && pts[1][1].abs() < 1e-12);
        assert!(clip_line_to_rect([1.0, 0.0], 3.0, &r).is_none());
    }

    #[test]
    fn paint_is_deterministic_and_edges_are_steps() {
        for m in [
            Material::PosterMondrian,
            Material::PosterStripes,
            Material::FloorTiles,
            Material::Picture { moulding: 0.04 },
        ] {
            let (t1, e1) = paint(&m, [0.6, 0.8], 400.0, 5);
            let (t2, e2) = paint(&m, [0.6, 0.8], 400.0, 5);
            assert_eq!(e1, e2);
            assert_eq!(t1.texel(100, 100), t2.texel(100, 100));
            assert!(!e1.is_empty(), "{m:?} drew no edges");
        }
    }
}
