//! Floor-standing items placed against a wall: the door, bookcases, the cabinet, the
//! table and carton stacks, with the books and cartons on them (also used by the wall
//! shelves of `wall_decor.rs`).

use super::{BOTTOM, BoxSpec, Builder, FRONT, LEFT, RHO_OBJECT, RIGHT, TOP, WALL_NAMES, Wall};
use crate::elements::ObjectKind;
use crate::patterns::Material;
use crate::quad::Surface;
use crate::texture::{Rgb, hsv};
use nalgebra::Vector3;
use rand::Rng;

impl Builder {
    pub(super) fn door(&mut self, _wi: usize, w: &Wall, wall_quad: u32) -> bool {
        let width = 0.85;
        let height = 2.05;
        let jamb = 0.07;
        let Some(s) = self.place_on_wall(w, width + 2.0 * jamb, 0.05, height + jamb) else {
            return false;
        };
        let obj = self.object("door".into(), ObjectKind::Door);
        let colour = hsv(self.rng.random_range(0.0..1.0), 0.12, 0.82);
        let leaf_s = s + jamb;
        let leaf = self.quad(
            w.at(leaf_s, 0.012, 0.0),
            w.e,
            Vector3::z(),
            [width, height],
            Material::Door { colour },
            obj,
            Surface::Door,
            RHO_OBJECT,
        );
        self.decal_edges(leaf, wall_quad);
        let wood = [0.9, 0.88, 0.84];
        let e2 = -w.n;
        let trim = |corner: Vector3<f64>, size: [f64; 3]| BoxSpec {
            corner,
            e1: w.e,
            e2,
            size,
            omit: [false, false, true, false, false, true],
            surface: Surface::Door,
        };
        let depth = 0.025;
        let parts = [
            trim(w.at(s, depth, 0.0), [jamb, depth, height + jamb]),
            trim(
                w.at(s + jamb + width, depth, 0.0),
                [jamb, depth, height + jamb],
            ),
            trim(w.at(s + jamb, depth, height), [width, depth, jamb]),
        ];
        for (k, p) in parts.iter().enumerate() {
            let mut p = BoxSpec { ..*p };
            if k == 2 {
                // The head rests between the jambs: its ends are hidden.
                p.omit[LEFT] = true;
                p.omit[RIGHT] = true;
            }
            self.add_box(&p, obj, &|face, _| Material::Wood {
                tone: wood,
                grain_along_a: face == TOP || face == BOTTOM,
            });
        }
        // Handle.
        let hs = leaf_s + width - 0.16;
        let handle = BoxSpec {
            corner: w.at(hs, 0.07, 1.0),
            e1: w.e,
            e2,
            size: [0.12, 0.07 - 0.012, 0.025],
            omit: [false, false, true, false, false, false],
            surface: Surface::Door,
        };
        self.add_box(&handle, obj, &|_, _| Material::Plain {
            colour: [0.35, 0.35, 0.37],
        });
        true
    }

    /// A bookcase: two sides, a top that overhangs, recessed boards, a back panel, books.
    pub(super) fn bookcase(&mut self, wi: usize, w: &Wall) -> bool {
        let width = self.rng.random_range(0.8..1.2);
        let depth = (0.3f64).min(w.max_depth - 0.03);
        let height = self.rng.random_range(1.6..1.95);
        let gap = 0.01;
        let Some(s0) = self.place_on_wall(w, width + 0.02, depth + gap + 0.015, height + 0.03)
        else {
            return false;
        };
        let s0 = s0 + 0.01;
        let obj = self.object("bookcase".into(), ObjectKind::Shelf);
        let tone = self.wood_tone();
        let th = 0.02;
        let e2 = -w.n;
        let front = gap + depth;
        let wood = move |face: usize, size: [f64; 2]| Material::Wood {
            tone,
            grain_along_a: face != LEFT && face != RIGHT && size[0] >= size[1],
        };
        for s in [s0, s0 + width - th] {
            self.add_box(
                &BoxSpec {
                    corner: w.at(s, front, 0.0),
                    e1: w.e,
                    e2,
                    size: [th, depth, height],
                    omit: [false, false, true, false, true, true],
                    surface: Surface::Furniture,
                },
                obj,
                &wood,
            );
        }
        self.add_box(
            &BoxSpec {
                corner: w.at(s0 - 0.01, front + 0.015, height),
                e1: w.e,
                e2,
                size: [width + 0.02, depth + 0.015, th],
                omit: [false, false, true, false, false, false],
                surface: Surface::Furniture,
            },
            obj,
            &wood,
        );
        let back_d = gap + 0.008;
        let inner = width - 2.0 * th;
        self.add_box(
            &BoxSpec {
                corner: w.at(s0 + th, back_d, 0.0),
                e1: w.e,
                e2,
                size: [inner, 0.008, height],
                omit: [true, true, true, false, true, true],
                surface: Surface::Furniture,
            },
            obj,
            &move |_, _| Material::Plain {
                colour: [tone[0] * 0.8, tone[1] * 0.8, tone[2] * 0.8],
            },
        );
        // Boards at random heights, the lowest a little above the floor.
        let levels = self.rng.random_range(3..=4usize);
        let mut zs = vec![0.06];
        let span = height - 0.06 - th;
        for k in 1..levels {
            zs.push(0.06 + span * k as f64 / levels as f64 + self.rng.random_range(-0.03..0.03));
        }
        let board_depth = depth - 0.008 - 0.015;
        for &z in &zs {
            self.add_box(
                &BoxSpec {
                    corner: w.at(s0 + th, gap + 0.008 + board_depth, z),
                    e1: w.e,
                    e2,
                    size: [inner, board_depth, th],
                    omit: [true, true, true, false, false, false],
                    surface: Surface::Furniture,
                },
                obj,
                &wood,
            );
        }
        // Books on every level but (sometimes) one, which holds a carton instead.
        let mut tops: Vec<(f64, f64)> = Vec::new();
        for (k, &z) in zs.iter().enumerate() {
            let top = zs.get(k + 1).copied().unwrap_or(height);
            tops.push((z + th, top));
        }
        let carton_level = self.rng.random_range(0..tops.len());
        for (k, &(z0, z1)) in tops.iter().enumerate() {
            let clear = z1 - z0;
            if k == carton_level {
                let cw = self.rng.random_range(0.2..(inner * 0.6).min(0.35));
                let ch = (clear * self.rng.random_range(0.5..0.8)).min(0.3);
                let cd = board_depth - 0.04;
                let cs = s0 + th + self.rng.random_range(0.03..inner - cw - 0.03);
                let cobj = self.object(
                    format!("carton on {} bookcase", WALL_NAMES[wi]),
                    ObjectKind::Carton,
                );
                self.carton(
                    cobj,
                    w.at(cs, gap + 0.008 + cd + 0.01, z0),
                    w.e,
                    e2,
                    [cw, cd, ch],
                );
                continue;
            }
            let mut s = s0 + th + self.rng.random_range(0.005..0.05);
            let end = s0 + width - th - 0.005;
            loop {
                let bw = self.rng.random_range(0.02..0.05);
                if s + bw > end {
                    break;
                }
                let bh = (clear * self.rng.random_range(0.6..0.92))
                    .max(0.1)
                    .min(clear - 0.01);
                let bd = self.rng.random_range(0.14..board_depth - 0.02);
                let recess = self.rng.random_range(0.005..0.02);
                let colour = hsv(
                    self.rng.random_range(0.0..1.0),
                    self.rng.random_range(0.35..0.85),
                    self.rng.random_range(0.3..0.85),
                );
                let bobj = self.object(format!("book {}", self.objects.len()), ObjectKind::Book);
                self.book(
                    bobj,
                    w.at(s, gap + 0.008 + board_depth - recess, z0),
                    w.e,
                    e2,
                    [bw, bd, bh],
                    colour,
                );
                s += bw + self.rng.random_range(0.003..0.02);
                if self.rng.random_bool(0.08) {
                    s += self.rng.random_range(0.05..0.12);
                }
            }
        }
        true
    }

    pub(super) fn book(
        &mut self,
        obj: u32,
        corner: Vector3<f64>,
        e1: Vector3<f64>,
        e2: Vector3<f64>,
        size: [f64; 3],
        colour: Rgb,
    ) {
        self.add_box(
            &BoxSpec {
                corner,
                e1,
                e2,
                size,
                omit: [false, false, true, false, false, true],
                surface: Surface::Book,
            },
            obj,
            &move |face, _| match face {
                FRONT => Material::BookSpine { colour },
                TOP => Material::Pages,
                _ => Material::BookCover { colour },
            },
        );
    }

    pub(super) fn carton(
        &mut self,
        obj: u32,
        corner: Vector3<f64>,
        e1: Vector3<f64>,
        e2: Vector3<f64>,
        size: [f64; 3],
    ) {
        let tone = self.carton_tone();
        let label_face = if self.rng.random_bool(0.5) {
            FRONT
        } else {
            LEFT
        };
        let mut omit = [false; 6];
        omit[BOTTOM] = true;
        self.add_box(
            &BoxSpec {
                corner,
                e1,
                e2,
                size,
                omit,
                surface: Surface::Carton,
            },
            obj,
            &move |face, _| Material::Cardboard {
                tone,
                label: face == label_face || face == TOP,
            },
        );
    }

    pub(super) fn wood_tone(&mut self) -> Rgb {
        let tones = [
            [0.62, 0.45, 0.3],
            [0.78, 0.64, 0.45],
            [0.45, 0.3, 0.2],
            [0.85, 0.83, 0.8],
            [0.3, 0.3, 0.32],
        ];
        tones[self.rng.random_range(0..tones.len())]
    }

    fn carton_tone(&mut self) -> Rgb {
        let v = self.rng.random_range(0.85..1.1);
        [0.66 * v, 0.5 * v, 0.33 * v]
    }

    /// A closed cabinet (front with door panels) with cartons on top.
    pub(super) fn cabinet(&mut self, _wi: usize, w: &Wall) -> bool {
        let width = self.rng.random_range(0.9..1.3);
        let depth = (w.max_depth - 0.03).min(0.4);
        let height = self.rng.random_range(0.7..0.95);
        let Some(s0) = self.place_on_wall(w, width, depth + 0.01, height + 0.4) else {
            return false;
        };
        let obj = self.object("cabinet".into(), ObjectKind::Cabinet);
        let tone = self.wood_tone();
        let e2 = -w.n;
        let front_colour = hsv(self.rng.random_range(0.0..1.0), 0.25, 0.75);
        self.add_box(
            &BoxSpec {
                corner: w.at(s0, depth + 0.01, 0.0),
                e1: w.e,
                e2,
                size: [width, depth, height],
                omit: [false, false, true, false, false, true],
                surface: Surface::Furniture,
            },
            obj,
            &move |face, size| match face {
                FRONT => Material::Door {
                    colour: front_colour,
                },
                _ => Material::Wood {
                    tone,
                    grain_along_a: size[0] >= size[1],
                },
            },
        );
        // One or two cartons on top, the second one turned a little.
        let n = self.rng.random_range(1..=2usize);
        let mut s = s0 + self.rng.random_range(0.03..0.15);
        for k in 0..n {
            let cw = self.rng.random_range(0.2..0.35);
            if s + cw > s0 + width - 0.03 {
                break;
            }
            let cd = self.rng.random_range(0.18..depth - 0.05);
            let ch = self.rng.random_range(0.12..0.3);
            let cobj = self.object(format!("carton on cabinet {k}"), ObjectKind::Carton);
            let yaw = if k == 1 {
                self.rng.random_range(-0.35..0.35)
            } else {
                0.0
            };
            let (e1r, e2r) = rotate_frame(w.e, e2, yaw);
            let centre = w.at(s + cw * 0.5, 0.01 + depth * 0.5 + 0.01, height);
            let corner = centre - e1r * (cw * 0.5) - e2r * (cd * 0.5);
            self.carton(cobj, corner, e1r, e2r, [cw, cd, ch]);
            s += cw + self.rng.random_range(0.05..0.15);
        }
        true
    }

    /// A table with four legs against a wall, a carton and a lying book on it.
    pub(super) fn table(&mut self, _wi: usize, w: &Wall) -> bool {
        let width = self.rng.random_range(1.0..1.4);
        let depth = (w.max_depth - 0.02).min(0.5);
        let height = 0.74;
        let Some(s0) = self.place_on_wall(w, width, depth + 0.03, height + 0.45) else {
            return false;
        };
        let obj = self.object("table".into(), ObjectKind::Table);
        let tone = self.wood_tone();
        let e2 = -w.n;
        let front = 0.03 + depth;
        let wood = move |_: usize, size: [f64; 2]| Material::Wood {
            tone,
            grain_along_a: size[0] >= size[1],
        };
        let top_th = 0.03;
        self.add_box(
            &BoxSpec {
                corner: w.at(s0, front, height - top_th),
                e1: w.e,
                e2,
                size: [width, depth, top_th],
                omit: [false; 6],
                surface: Surface::Furniture,
            },
            obj,
            &wood,
        );
        let leg = 0.05;
        let inset = 0.04;
        for (ls, ld) in [
            (s0 + inset, front - inset),
            (s0 + width - inset - leg, front - inset),
            (s0 + inset, front - depth + inset + leg),
            (s0 + width - inset - leg, front - depth + inset + leg),
        ] {
            self.add_box(
                &BoxSpec {
                    corner: w.at(ls, ld, 0.0),
                    e1: w.e,
                    e2,
                    size: [leg, leg, height - top_th],
                    omit: [false, false, false, false, true, true],
                    surface: Surface::Furniture,
                },
                obj,
                &wood,
            );
        }
        // A carton and a lying book on the table top.
        let cw = self.rng.random_range(0.22..0.35);
        let cd = self.rng.random_range(0.18..depth - 0.08);
        let ch = self.rng.random_range(0.12..0.25);
        let cs = s0 + self.rng.random_range(0.05..width * 0.45 - cw).max(0.05);
        let cobj = self.object("carton on table".into(), ObjectKind::Carton);
        self.carton(cobj, w.at(cs, front - 0.05, height), w.e, e2, [cw, cd, ch]);
        let bw = self.rng.random_range(0.18..0.26);
        let bd = self.rng.random_range(0.13..0.2);
        let bh = self.rng.random_range(0.025..0.05);
        let bs = s0
            + width * 0.55
            + self
                .rng
                .random_range(0.0..(width * 0.45 - bw - 0.05).max(0.01));
        let yaw = self.rng.random_range(-0.5..0.5);
        let (e1r, e2r) = rotate_frame(w.e, e2, yaw);
        let centre = w.at(bs + bw * 0.5, front - 0.05 - bd * 0.5 - 0.03, height);
        let colour = hsv(self.rng.random_range(0.0..1.0), 0.7, 0.6);
        let bobj = self.object("book on table".into(), ObjectKind::Book);
        self.add_box(
            &BoxSpec {
                corner: centre - e1r * (bw * 0.5) - e2r * (bd * 0.5),
                e1: e1r,
                e2: e2r,
                size: [bw, bd, bh],
                omit: [false, false, false, false, false, true],
                surface: Surface::Book,
            },
            bobj,
            &move |face, _| match face {
                TOP => Material::BookCover { colour },
                LEFT => Material::BookSpine { colour },
                _ => Material::Pages,
            },
        );
        true
    }

    /// A stack of 1-3 cartons on the floor against a wall, upper ones smaller and turned.
    pub(super) fn carton_stack(&mut self, _wi: usize, w: &Wall, k: usize) -> bool {
        let depth = self.rng.random_range(0.28..(w.max_depth - 0.04).max(0.3));
        let width = self.rng.random_range(0.35..0.55);
        let h0 = self.rng.random_range(0.25..0.42);
        let Some(s0) = self.place_on_wall(w, width, depth + 0.04, h0 + 0.7) else {
            return false;
        };
        let e2 = -w.n;
        let obj = self.object(format!("carton stack {k} bottom"), ObjectKind::Carton);
        self.carton(
            obj,
            w.at(s0, depth + 0.04, 0.0),
            w.e,
            e2,
            [width, depth, h0],
        );
        let mut base = (w.at(s0 + width * 0.5, 0.04 + depth * 0.5, h0), width, depth);
        let levels = self.rng.random_range(0..=2usize);
        let mut z = h0;
        for l in 0..levels {
            let (centre, bw, bd) = base;
            let cw = bw * self.rng.random_range(0.55..0.75);
            let cd = bd * self.rng.random_range(0.55..0.75);
            let ch = self.rng.random_range(0.15..0.3);
            let yaw = self.rng.random_range(-0.3..0.3);
            let (e1r, e2r) = rotate_frame(w.e, e2, yaw);
            let c = centre + w.e * self.rng.random_range(-0.03..0.03);
            let corner = c - e1r * (cw * 0.5) - e2r * (cd * 0.5);
            let o = self.object(
                format!("carton stack {k} level {}", l + 1),
                ObjectKind::Carton,
            );
            self.carton(o, corner, e1r, e2r, [cw, cd, ch]);
            z += ch;
            base = (Vector3::new(c.x, c.y, z), cw, cd);
        }
        true
    }
}

/// The frame (e1, e2) turned by `yaw` about z.
fn rotate_frame(e1: Vector3<f64>, e2: Vector3<f64>, yaw: f64) -> (Vector3<f64>, Vector3<f64>) {
    let (s, c) = yaw.sin_cos();
    (e1 * c + e2 * s, e2 * c - e1 * s)
}
