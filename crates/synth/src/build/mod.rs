//! Construction of the room: walls, floor, ceiling, a rug, posters and pictures on the
//! walls, a bookcase with books, a cabinet, a table, carton stacks and a door; all boxes
//! and rectangles, placed from the seed without overlaps. Textures are painted in
//! parallel, each from its own seed, so the result does not depend on the thread count.
//!
//! This file holds the builder: its quads, boxes and their edges, the free-space
//! bookkeeping that keeps items apart, and `build`, which places everything in a fixed
//! order (the order of the seeded draws, so it fixes the scene) and paints the textures.
//! What is built lives beside it: `shell.rs` (walls, floor, ceiling, rug), `furniture.rs`
//! (floor-standing items against a wall and what stands on them) and `wall_decor.rs`
//! (posters, pictures and wall shelves).

mod furniture;
mod shell;
mod wall_decor;

use super::elements::{Edge3, EdgeKind, Object, ObjectKind, ROOM};
use super::patterns::{LocalEdge, Material, paint};
use super::quad::{Aabb, Quad, Surface};
use super::texture::{Texture, hash64, luma};
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
