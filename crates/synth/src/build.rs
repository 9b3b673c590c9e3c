//! Construction of the room: walls, floor, ceiling, a rug, posters and pictures on the
//! walls, a bookcase with books, a cabinet, a table, carton stacks and a door; all boxes
//! and rectangles, placed from the seed without overlaps. Textures are painted in
//! parallel, each from its own seed, so the result does not depend on the thread count.

use super::patterns::{LocalEdge, Material, hsv, paint};
use super::quad::{Aabb, Quad, Surface};
use super::scene::{Edge3, EdgeKind, Object, ObjectKind, ROOM};
use super::texture::{Rgb, Texture, hash64, luma};
use nalgebra::Vector3;
use rand::Rng;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

/// Texel densities (texels per metre): room surfaces, the ceiling (rarely seen up close)
/// and everything else.
pub const RHO_ROOM: f64 = 512.0;
pub const RHO_CEILING: f64 = 320.0;
pub const RHO_OBJECT: f64 = 512.0;

/// Offsets of flat quads in front of the surface they lie on (no depth ties).
const POSTER_OFFSET: f64 = 0.003;
const RUG_OFFSET: f64 = 0.003;

/// Objects deeper than this from a wall would crowd the camera paths (see trajectory.rs).
const MAX_DEPTH_LONG_WALL: f64 = 0.42;
const MAX_DEPTH_SHORT_WALL: f64 = 0.55;

/// Flat shading: a key light from above, a weaker fill from the other side, ambient.
pub fn shade(n: &Vector3<f64>) -> f32 {
    let key = Vector3::new(0.55, 0.3, 0.78).normalize();
    let fill = Vector3::new(-0.35, -0.75, 0.2).normalize();
    let s = 0.42 + 0.5 * n.dot(&key).max(0.0) + 0.3 * n.dot(&fill).max(0.0);
    (s * 1.1) as f32
}

pub(crate) struct Parts {
    pub quads: Vec<Quad>,
    pub textures: Vec<Texture>,
    pub edges: Vec<Edge3>,
    pub objects: Vec<Object>,
}

struct Job {
    material: Material,
    size: [f64; 2],
    rho: f64,
    seed: u64,
}

/// Collects quads, texture jobs, edges and objects while the room is laid out.
struct Builder {
    rng: ChaCha8Rng,
    seed: u64,
    quads: Vec<Quad>,
    jobs: Vec<Job>,
    edges: Vec<Edge3>,
    objects: Vec<Object>,
    /// Floor footprints (xy) of placed floor-standing items, for overlap tests.
    footprints: Vec<[f64; 4]>,
    /// Wall rectangles (wall, s0, s1, z0, z1) already taken by hung items and tall furniture.
    wall_taken: Vec<(usize, f64, f64, f64, f64)>,
}

/// A wall: origin at floor level, tangent `e` (with `e x z = n`), inward normal `n`.
#[derive(Clone, Copy)]
struct Wall {
    origin: Vector3<f64>,
    e: Vector3<f64>,
    n: Vector3<f64>,
    len: f64,
    max_depth: f64,
}

impl Wall {
    fn at(&self, s: f64, d: f64, z: f64) -> Vector3<f64> {
        self.origin + self.e * s + self.n * d + Vector3::z() * z
    }
}

fn walls() -> [Wall; 4] {
    [
        // west, east, south, north
        Wall {
            origin: Vector3::new(0.0, 0.0, 0.0),
            e: Vector3::y(),
            n: Vector3::x(),
            len: ROOM[1],
            max_depth: MAX_DEPTH_SHORT_WALL,
        },
        Wall {
            origin: Vector3::new(ROOM[0], ROOM[1], 0.0),
            e: -Vector3::y(),
            n: -Vector3::x(),
            len: ROOM[1],
            max_depth: MAX_DEPTH_SHORT_WALL,
        },
        Wall {
            origin: Vector3::new(ROOM[0], 0.0, 0.0),
            e: -Vector3::x(),
            n: Vector3::y(),
            len: ROOM[0],
            max_depth: MAX_DEPTH_LONG_WALL,
        },
        Wall {
            origin: Vector3::new(0.0, ROOM[1], 0.0),
            e: Vector3::x(),
            n: -Vector3::y(),
            len: ROOM[0],
            max_depth: MAX_DEPTH_LONG_WALL,
        },
    ]
}

const WALL_NAMES: [&str; 4] = ["west", "east", "south", "north"];

/// A box: corner, right-handed frame (e1, e2, z) and sizes; faces in the order
/// +e1, -e1, +e2, -e2 (front), +z (top), -z (bottom).
struct BoxSpec {
    corner: Vector3<f64>,
    e1: Vector3<f64>,
    e2: Vector3<f64>,
    size: [f64; 3],
    /// Faces that are never visible (against a wall, resting on something) and are left out.
    omit: [bool; 6],
    surface: Surface,
}

/// A face of a box: origin, u, v, size.
type FaceFrame = (Vector3<f64>, Vector3<f64>, Vector3<f64>, [f64; 2]);

const RIGHT: usize = 0;
const LEFT: usize = 1;
const BACK: usize = 2;
const FRONT: usize = 3;
const TOP: usize = 4;
const BOTTOM: usize = 5;

impl Builder {
    fn new(seed: u64) -> Self {
        Builder {
            rng: ChaCha8Rng::seed_from_u64(seed),
            seed,
            quads: Vec::new(),
            jobs: Vec::new(),
            edges: Vec::new(),
            objects: Vec::new(),
            footprints: Vec::new(),
            wall_taken: Vec::new(),
        }
    }

    fn object(&mut self, name: String, kind: ObjectKind) -> u32 {
        self.objects.push(Object {
            name,
            kind,
            bounds: Aabb::empty(),
        });
        (self.objects.len() - 1) as u32
    }

    #[allow(clippy::too_many_arguments)]
    fn quad(
        &mut self,
        origin: Vector3<f64>,
        u: Vector3<f64>,
        v: Vector3<f64>,
        size: [f64; 2],
        material: Material,
        object: u32,
        surface: Surface,
        rho: f64,
    ) -> u32 {
        let normal = u.cross(&v);
        let id = self.quads.len() as u32;
        let job_seed = hash64(self.seed ^ hash64(0x5EED_0000 + id as u64));
        self.jobs.push(Job {
            material,
            size,
            rho,
            seed: job_seed,
        });
        let q = Quad {
            origin,
            u,
            v,
            normal,
            size,
            object,
            surface,
            texture: id,
            shade: shade(&normal),
        };
        for c in q.corners() {
            self.objects[object as usize].bounds.grow(&c);
        }
        self.quads.push(q);
        id
    }

    /// Adds a box; `material(face, size)` gives each face's recipe. Returns the face quads.
    fn add_box(
        &mut self,
        b: &BoxSpec,
        object: u32,
        material: &dyn Fn(usize, [f64; 2]) -> Material,
    ) -> [Option<u32>; 6] {
        let (e1, e2, e3) = (b.e1, b.e2, Vector3::z());
        let [l1, l2, l3] = b.size;
        let c = b.corner;
        let faces: [FaceFrame; 6] = [
            (c + e1 * l1, e2, e3, [l2, l3]),
            (c + e2 * l2, -e2, e3, [l2, l3]),
            (c + e1 * l1 + e2 * l2, -e1, e3, [l1, l3]),
            (c, e1, e3, [l1, l3]),
            (c + e3 * l3, e1, e2, [l1, l2]),
            (c + e2 * l2, e1, -e2, [l1, l2]),
        ];
        let mut ids = [None; 6];
        for (k, (o, u, v, size)) in faces.into_iter().enumerate() {
            if !b.omit[k] {
                ids[k] = Some(self.quad(
                    o,
                    u,
                    v,
                    size,
                    material(k, size),
                    object,
                    b.surface,
                    RHO_OBJECT,
                ));
            }
        }
        // The solid's bounds (omitted faces included).
        for x in [0.0, l1] {
            for y in [0.0, l2] {
                for z in [0.0, l3] {
                    self.objects[object as usize]
                        .bounds
                        .grow(&(c + e1 * x + e2 * y + e3 * z));
                }
            }
        }
        // 12 edges; an edge is kept when at least one of its two faces exists.
        let p = |x: f64, y: f64, z: f64| c + e1 * x + e2 * y + e3 * z;
        let xf = |x: f64| if x == 0.0 { LEFT } else { RIGHT };
        let yf = |y: f64| if y == 0.0 { FRONT } else { BACK };
        let zf = |z: f64| if z == 0.0 { BOTTOM } else { TOP };
        let mut list = Vec::with_capacity(12);
        for y in [0.0, l2] {
            for z in [0.0, l3] {
                list.push((p(0.0, y, z), p(l1, y, z), yf(y), zf(z)));
            }
        }
        for x in [0.0, l1] {
            for z in [0.0, l3] {
                list.push((p(x, 0.0, z), p(x, l2, z), xf(x), zf(z)));
            }
        }
        for x in [0.0, l1] {
            for y in [0.0, l2] {
                list.push((p(x, y, 0.0), p(x, y, l3), xf(x), yf(y)));
            }
        }
        for (a, bb, f1, f2) in list {
            let faces = [ids[f1], ids[f2]];
            if faces.iter().all(Option::is_none) {
                continue;
            }
            self.edges.push(Edge3 {
                a,
                b: bb,
                kind: EdgeKind::ObjectEdge,
                faces,
                object,
                contrast: None,
            });
        }
        ids
    }

    fn floor_free(&self, fp: [f64; 4], gap: f64) -> bool {
        self.footprints.iter().all(|o| {
            fp[2] + gap <= o[0] || o[2] + gap <= fp[0] || fp[3] + gap <= o[1] || o[3] + gap <= fp[1]
        })
    }

    fn wall_free(&self, wall: usize, s0: f64, s1: f64, z0: f64, z1: f64, gap: f64) -> bool {
        self.wall_taken.iter().all(|&(w, a0, a1, b0, b1)| {
            w != wall || s1 + gap <= a0 || a1 + gap <= s0 || z1 + gap <= b0 || b1 + gap <= z0
        })
    }

    /// Footprint (x0, y0, x1, y1) of a wall-anchored item from s0 to s1, depth d (incl. gap).
    fn footprint(w: &Wall, s0: f64, s1: f64, d: f64) -> [f64; 4] {
        let a = w.at(s0, 0.0, 0.0);
        let b = w.at(s1, d, 0.0);
        [a.x.min(b.x), a.y.min(b.y), a.x.max(b.x), a.y.max(b.y)]
    }

    /// Finds a free position along `wall` for a floor item of `width` and `depth`.
    fn place_on_wall(&mut self, wall: &Wall, width: f64, depth: f64, height: f64) -> Option<f64> {
        if width + 0.1 > wall.len {
            return None;
        }
        for _ in 0..60 {
            let s0 = self.rng.random_range(0.05..wall.len - width - 0.05);
            let fp = Self::footprint(wall, s0, s0 + width, depth + 0.02);
            if self.floor_free(fp, 0.06) {
                self.footprints.push(fp);
                self.reserve_walls(fp, height + 0.12);
                return Some(s0);
            }
        }
        None
    }

    /// Keeps hung items off the wall area behind (or beside, in a corner) a floor item.
    fn reserve_walls(&mut self, fp: [f64; 4], height: f64) {
        for (wi, w) in walls().iter().enumerate() {
            // Distance of the footprint from the wall plane and its extent along the wall.
            let corners = [
                [fp[0], fp[1]],
                [fp[2], fp[1]],
                [fp[2], fp[3]],
                [fp[0], fp[3]],
            ];
            let mut dmin = f64::INFINITY;
            let (mut s0, mut s1) = (f64::INFINITY, f64::NEG_INFINITY);
            for c in corners {
                let p = Vector3::new(c[0], c[1], 0.0) - w.origin;
                dmin = dmin.min(p.dot(&w.n));
                let s = p.dot(&w.e);
                s0 = s0.min(s);
                s1 = s1.max(s);
            }
            if dmin < 0.3 {
                self.wall_taken.push((wi, s0, s1, 0.0, height));
            }
        }
    }

    fn add_texture_edges(&mut self, quad: u32, local: &[LocalEdge]) {
        let q = self.quads[quad as usize].clone();
        for e in local {
            self.edges.push(Edge3 {
                a: q.point_at(e.a[0], e.a[1]),
                b: q.point_at(e.b[0], e.b[1]),
                kind: EdgeKind::TextureEdge,
                faces: [Some(quad), None],
                object: q.object,
                contrast: Some(e.contrast * q.shade),
            });
        }
    }

    /// The four borders of a flat quad lying on `under`.
    fn decal_edges(&mut self, quad: u32, under: u32) {
        let q = self.quads[quad as usize].clone();
        let c = q.corners();
        for k in 0..4 {
            self.edges.push(Edge3 {
                a: c[k],
                b: c[(k + 1) % 4],
                kind: EdgeKind::DecalBorder,
                faces: [Some(quad), Some(under)],
                object: q.object,
                contrast: None,
            });
        }
    }

    fn room(&mut self) -> [u32; 6] {
        let room = self.object("room".into(), ObjectKind::Room);
        let mut ids = [0u32; 6];
        for (k, w) in walls().iter().enumerate() {
            ids[k] = self.quad(
                w.origin,
                w.e,
                Vector3::z(),
                [w.len, ROOM[2]],
                Material::Wallpaper { palette: k as u8 },
                room,
                Surface::Wall,
                RHO_ROOM,
            );
        }
        ids[4] = self.quad(
            Vector3::zeros(),
            Vector3::x(),
            Vector3::y(),
            [ROOM[0], ROOM[1]],
            Material::FloorTiles,
            room,
            Surface::Floor,
            RHO_ROOM,
        );
        ids[5] = self.quad(
            Vector3::new(0.0, 0.0, ROOM[2]),
            Vector3::y(),
            Vector3::x(),
            [ROOM[1], ROOM[0]],
            Material::Ceiling,
            room,
            Surface::Ceiling,
            RHO_CEILING,
        );
        // Corners: vertical ones between adjacent walls, then each wall with floor and ceiling.
        let (x, y, z) = (ROOM[0], ROOM[1], ROOM[2]);
        let v = |a: [f64; 3], b: [f64; 3]| (Vector3::from(a), Vector3::from(b));
        let corners = [
            (v([0.0, 0.0, 0.0], [0.0, 0.0, z]), 0, 2),
            (v([x, 0.0, 0.0], [x, 0.0, z]), 1, 2),
            (v([x, y, 0.0], [x, y, z]), 1, 3),
            (v([0.0, y, 0.0], [0.0, y, z]), 0, 3),
        ];
        for ((a, b), f1, f2) in corners {
            self.edges.push(Edge3 {
                a,
                b,
                kind: EdgeKind::RoomCorner,
                faces: [Some(ids[f1]), Some(ids[f2])],
                object: room,
                contrast: None,
            });
        }
        for (k, w) in walls().iter().enumerate() {
            for (h, f) in [(0.0, 4), (z, 5)] {
                self.edges.push(Edge3 {
                    a: w.at(0.0, 0.0, h),
                    b: w.at(w.len, 0.0, h),
                    kind: EdgeKind::RoomCorner,
                    faces: [Some(ids[k]), Some(ids[f])],
                    object: room,
                    contrast: None,
                });
            }
        }
        ids
    }

    fn rug(&mut self, floor: u32) {
        let obj = self.object("rug".into(), ObjectKind::Rug);
        let w = self.rng.random_range(1.3..1.9);
        let h = self.rng.random_range(0.8..1.2);
        let x0 = ROOM[0] * 0.5 - w * 0.5 + self.rng.random_range(-0.2..0.2);
        let y0 = ROOM[1] * 0.5 - h * 0.5 + self.rng.random_range(-0.15..0.15);
        let q = self.quad(
            Vector3::new(x0, y0, RUG_OFFSET),
            Vector3::x(),
            Vector3::y(),
            [w, h],
            Material::Rug,
            obj,
            Surface::Rug,
            RHO_ROOM,
        );
        self.decal_edges(q, floor);
    }

    fn door(&mut self, _wi: usize, w: &Wall, wall_quad: u32) -> bool {
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
    fn bookcase(&mut self, wi: usize, w: &Wall) -> bool {
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

    fn book(
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

    fn carton(
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

    fn wood_tone(&mut self) -> Rgb {
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
    fn cabinet(&mut self, _wi: usize, w: &Wall) -> bool {
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
    fn table(&mut self, _wi: usize, w: &Wall) -> bool {
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
    fn carton_stack(&mut self, _wi: usize, w: &Wall, k: usize) -> bool {
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

    /// Posters and pictures on free wall areas.
    fn wall_decor(&mut self, wall_quads: &[u32; 6]) {
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

/// The frame (e1, e2) turned by `yaw` about z.
fn rotate_frame(e1: Vector3<f64>, e2: Vector3<f64>, yaw: f64) -> (Vector3<f64>, Vector3<f64>) {
    let (s, c) = yaw.sin_cos();
    (e1 * c + e2 * s, e2 * c - e1 * s)
}

pub(crate) fn build(seed: u64) -> Parts {
    let mut b = Builder::new(seed);
    let ids = b.room();
    let ws = walls();
    // Roles: the door, the bookcase, the cabinet and the table go to walls chosen from
    // the seed; cartons fill in.
    let mut order = [0usize, 1, 2, 3];
    for i in (1..4).rev() {
        let j = b.rng.random_range(0..=i);
        order.swap(i, j);
    }
    b.door(order[0], &ws[order[0]], ids[order[0]]);
    b.bookcase(order[1], &ws[order[1]]);
    b.cabinet(order[2], &ws[order[2]]);
    b.table(order[3], &ws[order[3]]);
    if b.rng.random_bool(0.5) {
        b.bookcase(order[2], &ws[order[2]]);
    }
    let mut stacks = 0;
    for k in 0..12 {
        if stacks >= 3 {
            break;
        }
        let wi = b.rng.random_range(0..4usize);
        if b.carton_stack(wi, &ws[wi], k) {
            stacks += 1;
        }
    }
    b.rug(ids[4]);
    b.wall_decor(&ids);

    let jobs = std::mem::take(&mut b.jobs);
    let painted: Vec<(Texture, Vec<LocalEdge>)> = jobs
        .par_iter()
        .map(|j| paint(&j.material, j.size, j.rho, j.seed))
        .collect();
    let mut textures = Vec::with_capacity(painted.len());
    for (qi, (tex, local)) in painted.into_iter().enumerate() {
        b.add_texture_edges(qi as u32, &local);
        textures.push(tex);
    }
    // Crease contrast from the faces' shaded mean colours (the coarsest mip level).
    let mean_luma: Vec<f32> = b
        .quads
        .iter()
        .zip(&textures)
        .map(|(q, t)| luma(t.sample(0.0, 0.0, f64::INFINITY)) * q.shade)
        .collect();
    for e in &mut b.edges {
        if let (None, [Some(f1), Some(f2)]) = (e.contrast, e.faces) {
            e.contrast = Some((mean_luma[f1 as usize] - mean_luma[f2 as usize]).abs());
        }
    }
    Parts {
        quads: b.quads,
        textures,
        edges: b.edges,
        objects: b.objects,
    }
}
