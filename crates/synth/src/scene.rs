//! The synthetic room: planar quads with their textures, the exact straight 3D edges
//! across which the rendered intensity steps, and exact ray casts.
//!
//! World frame: metres, z up, the room is the box `[0, 4] x [0, 3] x [0, 2.5]` (floor at
//! z = 0). Walls are named by their outward direction: west (x = 0), east (x = 4),
//! south (y = 0), north (y = 3). Every quad is one-sided and faces the free space, so a
//! camera inside the room sees exactly what a solid model would show.

use super::build;
use super::elements::{Edge3, Object, ObjectKind, ROOM};
use super::quad::{Bvh, Quad};
use super::texture::Texture;
use nalgebra::Vector3;
use std::collections::HashMap;
use std::sync::{Arc, Mutex, OnceLock, Weak};

/// Nearest ray hit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Ray parameter: `point = origin + t dir` (in units of `dir`, which need not be unit).
    pub t: f64,
    pub point: Vector3<f64>,
    pub quad_id: u32,
    /// The quad's normal (facing the ray origin).
    pub normal: Vector3<f64>,
    /// Local coordinates on the quad in metres (texture coordinates).
    pub local: [f64; 2],
}

/// A procedural room. Immutable once built; share it between threads freely.
#[derive(Clone, Debug)]
pub struct Scene {
    pub(crate) quads: Vec<Quad>,
    pub(crate) textures: Vec<Texture>,
    pub(crate) edges: Vec<Edge3>,
    pub(crate) objects: Vec<Object>,
    bvh: Bvh,
    seed: u64,
}

impl Scene {
    /// Builds the room for `seed` (deterministic: same seed, same scene, whatever the
    /// number of threads).
    pub fn generate(seed: u64) -> Scene {
        let parts = build::build(seed);
        let bvh = Bvh::build(&parts.quads);
        Scene {
            quads: parts.quads,
            textures: parts.textures,
            edges: parts.edges,
            objects: parts.objects,
            bvh,
            seed,
        }
    }

    /// The scene for `seed`, shared with every other caller in this process that still
    /// holds it (building one takes about 1.5 s of CPU and 100 MB).
    pub fn shared(seed: u64) -> Arc<Scene> {
        static CACHE: OnceLock<Mutex<HashMap<u64, Weak<Scene>>>> = OnceLock::new();
        let cache = CACHE.get_or_init(|| Mutex::new(HashMap::new()));
        // A poisoned lock only means another thread panicked while building; the map
        // itself is still valid.
        let mut map = cache.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(s) = map.get(&seed).and_then(Weak::upgrade) {
            return s;
        }
        let s = Arc::new(Scene::generate(seed));
        map.retain(|_, w| w.strong_count() > 0);
        map.insert(seed, Arc::downgrade(&s));
        s
    }

    pub fn seed(&self) -> u64 {
        self.seed
    }

    pub fn quads(&self) -> &[Quad] {
        &self.quads
    }

    pub fn objects(&self) -> &[Object] {
        &self.objects
    }

    /// Every straight 3D step of the scene (see [`crate::EdgeKind`]). Visibility from a given
    /// viewpoint is not considered: test it with [`Scene::is_visible`].
    pub fn edges(&self) -> &[Edge3] {
        &self.edges
    }

    /// The texture of quad `quad_id`.
    pub fn texture(&self, quad_id: u32) -> Option<&Texture> {
        let q = self.quads.get(quad_id as usize)?;
        self.textures.get(q.texture as usize)
    }

    /// Nearest front-facing surface along `origin + t dir`, `t > 0`.
    pub fn raycast(&self, origin: &Vector3<f64>, dir: &Vector3<f64>) -> Option<Hit> {
        let (qi, t, a, b) = self.bvh.nearest(&self.quads, origin, dir)?;
        let q = &self.quads[qi as usize];
        Some(Hit {
            t,
            point: origin + dir * t,
            quad_id: qi,
            normal: q.normal,
            local: [a, b],
        })
    }

    /// Whether `point` is seen from `from`: nothing lies on the segment between them
    /// closer than `tol` metres before the point.
    pub fn is_visible(&self, from: &Vector3<f64>, point: &Vector3<f64>, tol: f64) -> bool {
        let d = point - from;
        let dist = d.norm();
        if dist <= tol {
            return true;
        }
        match self.raycast(from, &d) {
            None => true,
            Some(h) => h.t * dist >= dist - tol,
        }
    }

    /// Free distance from `p` to the room's walls, floor and ceiling and to the solid
    /// objects (rugs, posters and pictures excluded: they lie on walls and floor).
    pub fn clearance(&self, p: &Vector3<f64>) -> f64 {
        let mut d =
            p.x.min(ROOM[0] - p.x)
                .min(p.y)
                .min(ROOM[1] - p.y)
                .min(p.z)
                .min(ROOM[2] - p.z);
        for o in &self.objects {
            if matches!(
                o.kind,
                ObjectKind::Room | ObjectKind::Rug | ObjectKind::Poster | ObjectKind::Picture
            ) {
                continue;
            }
            d = d.min(o.bounds.distance(p));
        }
        d
    }
}
