//! Items hung on the walls: posters, framed pictures and small wall shelves with books
//! and a carton, in free wall areas (clear of each other and of tall furniture).

use super::{BoxSpec, Builder, FRONT, LEFT, RHO_OBJECT, RIGHT, WALL_NAMES, Wall, walls};
use crate::elements::{ObjectKind, ROOM};
use crate::patterns::Material;
use crate::quad::Surface;
use crate::texture::hsv;
use nalgebra::Vector3;
use rand::Rng;

/// Offset of a poster in front of its wall (a flat quad lies a little in front of the
/// surface under it: no depth ties).
const POSTER_OFFSET: f64 = 0.003;

impl Builder {
    /// Posters and pictures on free wall areas.
    pub(super) fn wall_decor(&mut self, wall_quads: &[u32; 6]) {
        let ws = walls();
        // Posters, framed pictures and small wall shelves with books and a carton.
        let mut counts = [0usize; 3];
        let targets = [
            self.rng.random_range(7..=9),
            self.rng.random_range(4..=6),
            self.rng.random_range(2..=3),
        ];
        for _ in 0..2000 {
            let open: Vec<usize> = (0..3).filter(|&k| counts[k] < targets[k]).collect();
            if open.is_empty() {
                break;
            }
            let kind = open[self.rng.random_range(0..open.len())];
            let wi = self.rng.random_range(0..4usize);
            let w = ws[wi];
            let (width, height) = match kind {
                0 => (
                    self.rng.random_range(0.35..0.7),
                    self.rng.random_range(0.45..0.9),
                ),
                1 => (
                    self.rng.random_range(0.3..0.6),
                    self.rng.random_range(0.25..0.5),
                ),
                _ => (self.rng.random_range(0.6..1.0), 0.36),
            };
            let s0 = self.rng.random_range(0.15..w.len - width - 0.15);
            let (zlo, zhi) = if kind == 2 {
                (1.0, 1.75)
            } else {
                (0.75, ROOM[2] - 0.15 - height)
            };
            if zhi <= zlo {
                continue;
            }
            let z0 = self.rng.random_range(zlo..zhi);
            if z0 + height > ROOM[2] - 0.12
                || !self.wall_free(wi, s0, s0 + width, z0, z0 + height, 0.1)
            {
                continue;
            }
            self.wall_taken.push((wi, s0, s0 + width, z0, z0 + height));
            counts[kind] += 1;
            let n = counts[kind];
            match kind {
                0 => {
                    let obj = self.object(
                        format!("poster {n} ({} wall)", WALL_NAMES[wi]),
                        ObjectKind::Poster,
                    );
                    let material = if self.rng.random_bool(0.5) {
                        Material::PosterMondrian
                    } else {
                        Material::PosterStripes
                    };
                    let q = self.quad(
                        w.at(s0, POSTER_OFFSET, z0),
                        w.e,
                        Vector3::z(),
                        [width, height],
                        material,
                        obj,
                        Surface::Poster,
                        RHO_OBJECT,
                    );
                    self.decal_edges(q, wall_quads[wi]);
                }
                1 => self.picture(&w, wi, n, s0, z0, width, height),
                _ => self.wall_shelf(&w, wi, n, s0, z0, width),
            }
        }
    }

    #[allow(clippy::too_many_arguments)]
    fn picture(
        &mut self,
        w: &Wall,
        wi: usize,
        n: usize,
        s0: f64,
        z0: f64,
        width: f64,
        height: f64,
    ) {
        let obj = self.object(
            format!("picture {n} ({} wall)", WALL_NAMES[wi]),
            ObjectKind::Picture,
        );
        let moulding = self.rng.random_range(0.03..0.055);
        let depth = 0.025;
        let tone = self.wood_tone();
        self.add_box(
            &BoxSpec {
                corner: w.at(s0, depth, z0),
                e1: w.e,
                e2: -w.n,
                size: [width, depth, height],
                omit: [false, false, true, false, false, false],
                surface: Surface::Picture,
            },
            obj,
            &move |face, size| match face {
                FRONT => Material::Picture { moulding },
                _ => Material::Wood {
                    tone,
                    grain_along_a: size[0] >= size[1],
                },
            },
        );
    }

    /// A board on the wall with a row of books and a small carton on it.
    fn wall_shelf(&mut self, w: &Wall, wi: usize, n: usize, s0: f64, z0: f64, width: f64) {
        let obj = self.object(
            format!("wall shelf {n} ({} wall)", WALL_NAMES[wi]),
            ObjectKind::Shelf,
        );
        let tone = self.wood_tone();
        let depth = 0.2;
        let th = 0.025;
        let e2 = -w.n;
        self.add_box(
            &BoxSpec {
                corner: w.at(s0, depth, z0),
                e1: w.e,
                e2,
                size: [width, depth, th],
                omit: [false, false, true, false, false, false],
                surface: Surface::Furniture,
            },
            obj,
            &move |face, size| Material::Wood {
                tone,
                grain_along_a: face != LEFT && face != RIGHT && size[0] >= size[1],
            },
        );
        let top = z0 + th;
        let mut s = s0 + self.rng.random_range(0.02..0.08);
        let books_end = s0 + width * self.rng.random_range(0.45..0.7);
        while s < books_end {
            let bw = self.rng.random_range(0.02..0.045);
            let bh = self.rng.random_range(0.18..0.3);
            let recess = self.rng.random_range(0.005..0.02);
            let bd = self.rng.random_range(0.12..depth - recess - 0.01);
            let colour = hsv(
                self.rng.random_range(0.0..1.0),
                self.rng.random_range(0.35..0.85),
                self.rng.random_range(0.3..0.85),
            );
            let bobj = self.object(format!("book {}", self.objects.len()), ObjectKind::Book);
            self.book(
                bobj,
                w.at(s, depth - recess, top),
                w.e,
                e2,
                [bw, bd, bh],
                colour,
            );
            s += bw + self.rng.random_range(0.003..0.015);
        }
        let cw = self.rng.random_range(0.12..0.2);
        let cs = s + self.rng.random_range(0.04..0.1);
        if cs + cw < s0 + width - 0.03 {
            let ch = self.rng.random_range(0.1..0.2);
            let cd = self.rng.random_range(0.1..0.16);
            let cobj = self.object(format!("carton on wall shelf {n}"), ObjectKind::Carton);
            self.carton(cobj, w.at(cs, depth - 0.02, top), w.e, e2, [cw, cd, ch]);
        }
    }
}
