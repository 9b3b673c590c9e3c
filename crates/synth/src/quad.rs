//! Planar rectangles, the only primitive of the synthetic scene, and a bounding volume
//! hierarchy over them for exact nearest-hit ray casts.

use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

/// What a quad belongs to; decides nothing in the renderer, but lets callers filter.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Surface {
    Wall,
    Floor,
    Ceiling,
    Rug,
    Poster,
    Picture,
    Furniture,
    Book,
    Carton,
    Door,
}

/// A one-sided rectangle: `origin + a u + b v` for `a in [0, size[0]]`, `b in [0, size[1]]`.
/// `u` and `v` are orthonormal and `normal = u x v` points to the side it is seen from;
/// rays arriving from behind pass through it (closed objects hide their back faces).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Quad {
    pub origin: Vector3<f64>,
    pub u: Vector3<f64>,
    pub v: Vector3<f64>,
    pub normal: Vector3<f64>,
    /// Lengths along `u` and `v` in metres.
    pub size: [f64; 2],
    /// Index into [`crate::Scene::objects`].
    pub object: u32,
    pub surface: Surface,
    /// Index of the quad's own texture (texture coordinates are `(a, b)` in metres).
    pub texture: u32,
    /// Flat shading factor applied to the texture colour (fixed lights, per face).
    pub shade: f32,
}

/// Rays must travel at least this far (in units of the direction) before they can hit.
pub const RAY_EPS: f64 = 1e-9;

impl Quad {
    /// The four corners in order origin, +u, +u+v, +v.
    pub fn corners(&self) -> [Vector3<f64>; 4] {
        let du = self.u * self.size[0];
        let dv = self.v * self.size[1];
        [
            self.origin,
            self.origin + du,
            self.origin + du + dv,
            self.origin + dv,
        ]
    }

    /// World point of local coordinates `(a, b)` (metres along `u`, `v`).
    pub fn point_at(&self, a: f64, b: f64) -> Vector3<f64> {
        self.origin + self.u * a + self.v * b
    }

    /// Local coordinates of a world point (its projection onto the quad's plane).
    pub fn local_of(&self, p: &Vector3<f64>) -> [f64; 2] {
        let d = p - self.origin;
        [self.u.dot(&d), self.v.dot(&d)]
    }

    /// Signed distance of `p` from the quad's plane (positive on the visible side).
    pub fn plane_distance(&self, p: &Vector3<f64>) -> f64 {
        self.normal.dot(&(p - self.origin))
    }

    /// Front-side intersection: `(t, a, b)` with `origin + t dir` on the quad.
    pub fn intersect(&self, origin: &Vector3<f64>, dir: &Vector3<f64>) -> Option<(f64, f64, f64)> {
        let denom = self.normal.dot(dir);
        if denom >= 0.0 {
            return None;
        }
        let t = self.normal.dot(&(self.origin - origin)) / denom;
        if t.is_nan() || t <= RAY_EPS {
            return None;
        }
        let p = origin + dir * t - self.origin;
        let a = self.u.dot(&p);
        let b = self.v.dot(&p);
        if a >= 0.0 && a <= self.size[0] && b >= 0.0 && b <= self.size[1] {
            Some((t, a, b))
        } else {
            None
        }
    }

    pub(crate) fn aabb(&self) -> Aabb {
        let mut b = Aabb::empty();
        for c in self.corners() {
            b.grow(&c);
        }
        b
    }
}

/// Axis-aligned box.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Aabb {
    pub min: Vector3<f64>,
    pub max: Vector3<f64>,
}

impl Aabb {
    pub fn empty() -> Self {
        Aabb {
            min: Vector3::repeat(f64::INFINITY),
            max: Vector3::repeat(f64::NEG_INFINITY),
        }
    }

    pub fn grow(&mut self, p: &Vector3<f64>) {
        self.min = self.min.inf(p);
        self.max = self.max.sup(p);
    }

    pub fn merge(&mut self, o: &Aabb) {
        self.min = self.min.inf(&o.min);
        self.max = self.max.sup(&o.max);
    }

    /// Euclidean distance from `p` to the box (0 inside).
    pub fn distance(&self, p: &Vector3<f64>) -> f64 {
        let d = (self.min - p).sup(&(p - self.max)).sup(&Vector3::zeros());
        d.norm()
    }

    /// Entry parameter of the ray into the (slightly padded) box, if it enters before `t_max`.
    fn ray_entry(&self, origin: &Vector3<f64>, inv_dir: &Vector3<f64>, t_max: f64) -> Option<f64> {
        // Flat boxes (a quad parallel to an axis plane) get a hair of thickness so that
        // the slab test cannot miss them through rounding.
        const PAD: f64 = 1e-7;
        let mut t0 = 0.0f64;
        let mut t1 = t_max;
        for k in 0..3 {
            let lo = (self.min[k] - PAD - origin[k]) * inv_dir[k];
            let hi = (self.max[k] + PAD - origin[k]) * inv_dir[k];
            let (lo, hi) = if lo <= hi { (lo, hi) } else { (hi, lo) };
            // NaN (0 * inf when the origin lies on a slab plane) must not shrink the range.
            if lo > t0 {
                t0 = lo;
            }
            if hi < t1 {
                t1 = hi;
            }
        }
        (t0 <= t1).then_some(t0)
    }
}

#[derive(Clone, Debug)]
enum Node {
    Leaf {
        bounds: Aabb,
        first: u32,
        count: u32,
    },
    Inner {
        bounds: Aabb,
        left: u32,
        right: u32,
    },
}

impl Node {
    fn bounds(&self) -> &Aabb {
        match self {
            Node::Leaf { bounds, .. } | Node::Inner { bounds, .. } => bounds,
        }
    }
}

/// Median-split BVH over quads; leaves hold at most `LEAF` quads.
#[derive(Clone, Debug)]
pub(crate) struct Bvh {
    nodes: Vec<Node>,
    order: Vec<u32>,
}

const LEAF: usize = 4;

impl Bvh {
    pub(crate) fn build(quads: &[Quad]) -> Self {
        let boxes: Vec<Aabb> = quads.iter().map(Quad::aabb).collect();
        let mut order: Vec<u32> = (0..quads.len() as u32).collect();
        let mut nodes = Vec::new();
        if !quads.is_empty() {
            Self::build_node(&boxes, &mut order, 0, quads.len(), &mut nodes);
        }
        Bvh { nodes, order }
    }

    fn build_node(
        boxes: &[Aabb],
        order: &mut [u32],
        start: usize,
        end: usize,
        nodes: &mut Vec<Node>,
    ) -> u32 {
        let mut bounds = Aabb::empty();
        let mut centroids = Aabb::empty();
        for &i in &order[start..end] {
            let b = &boxes[i as usize];
            bounds.merge(b);
            centroids.grow(&((b.min + b.max) * 0.5));
        }
        let id = nodes.len() as u32;
        if end - start <= LEAF {
            nodes.push(Node::Leaf {
                bounds,
                first: start as u32,
                count: (end - start) as u32,
            });
            return id;
        }
        let ext = centroids.max - centroids.min;
        let axis = ext.imax();
        let mid = (start + end) / 2;
        // Ties broken by index so the tree (and so the traversal order) is deterministic.
        order[start..end].sort_by(|&a, &b| {
            let ca = boxes[a as usize].min[axis] + boxes[a as usize].max[axis];
            let cb = boxes[b as usize].min[axis] + boxes[b as usize].max[axis];
            ca.total_cmp(&cb).then(a.cmp(&b))
        });
        nodes.push(Node::Leaf {
            bounds,
            first: 0,
            count: 0,
        });
        let left = Self::build_node(boxes, order, start, mid, nodes);
        let right = Self::build_node(boxes, order, mid, end, nodes);
        nodes[id as usize] = Node::Inner {
            bounds,
            left,
            right,
        };
        id
    }

    /// Nearest front-side hit: `(quad index, t, a, b)`. Equal `t` resolves to the lower
    /// quad index, like the renderer's z-buffer.
    pub(crate) fn nearest(
        &self,
        quads: &[Quad],
        origin: &Vector3<f64>,
        dir: &Vector3<f64>,
    ) -> Option<(u32, f64, f64, f64)> {
        if self.nodes.is_empty() {
            return None;
        }
        let inv = Vector3::new(1.0 / dir.x, 1.0 / dir.y, 1.0 / dir.z);
        let mut best: Option<(u32, f64, f64, f64)> = None;
        let mut stack: Vec<u32> = Vec::with_capacity(64);
        stack.push(0);
        while let Some(n) = stack.pop() {
            let node = &self.nodes[n as usize];
            let t_max = best.map_or(f64::INFINITY, |b| b.1);
            // `<=` on ties: a farther-right subtree may hold an equal-t, lower-index quad.
            if node
                .bounds()
                .ray_entry(origin, &inv, t_max * (1.0 + 1e-12) + 1e-12)
                .is_none()
            {
                continue;
            }
            match node {
                Node::Leaf { first, count, .. } => {
                    for &qi in &self.order[*first as usize..(*first + *count) as usize] {
                        if let Some((t, a, b)) = quads[qi as usize].intersect(origin, dir) {
                            let better = match best {
                                None => true,
                                Some((bi, bt, _, _)) => t < bt || (t == bt && qi < bi),
                            };
                            if better {
                                best = Some((qi, t, a, b));
                            }
                        }
                    }
                }
                Node::Inner { left, right, .. } => {
                    stack.push(*right);
                    stack.push(*left);
                }
            }
        }
        best
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn quad(origin: [f64; 3], u: [f64; 3], v: [f64; 3], size: [f64; 2]) -> Quad {
        let u = Vector3::from(u);
        let v = Vector3::from(v);
        Quad {
            origin: Vector3::from(origin),
            u,
            v,
            normal: u.cross(&v),
            size,
            object: 0,
            surface: Surface::Wall,
            texture: 0,
            shade: 1.0,
        }
    }

    #[test]
    fn intersect_front_and_back() {
        // Unit square in the plane z = 1 facing -z (u = y, v = x gives y x x = -z).
        let q = quad(
            [0.0, 0.0, 1.0],
            [0.0, 1.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0],
        );
        let o = Vector3::new(0.25, 0.5, 0.0);
        let (t, a, b) = q.intersect(&o, &Vector3::new(0.0, 0.0, 2.0)).unwrap();
        assert!((t - 0.5).abs() < 1e-15);
        assert!((a - 0.5).abs() < 1e-15 && (b - 0.25).abs() < 1e-15);
        // From behind: invisible.
        let o2 = Vector3::new(0.25, 0.5, 2.0);
        assert!(q.intersect(&o2, &Vector3::new(0.0, 0.0, -1.0)).is_none());
        // Outside the extent.
        let o3 = Vector3::new(1.5, 0.5, 0.0);
        assert!(q.intersect(&o3, &Vector3::z()).is_none());
    }

    #[test]
    fn bvh_matches_brute_force() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let mut quads = Vec::new();
        for _ in 0..200 {
            let u = Vector3::new(
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
            )
            .normalize();
            let w = Vector3::new(
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
            );
            let v = (w - u * u.dot(&w)).normalize();
            let o = [
                rng.random_range(-3.0..3.0),
                rng.random_range(-3.0..3.0),
                rng.random_range(-3.0..3.0),
            ];
            quads.push(quad(
                o,
                u.into(),
                v.into(),
                [rng.random_range(0.1..1.0), rng.random_range(0.1..1.0)],
            ));
        }
        let bvh = Bvh::build(&quads);
        let mut hits = 0;
        for _ in 0..5000 {
            let o = Vector3::new(
                rng.random_range(-4.0..4.0),
                rng.random_range(-4.0..4.0),
                rng.random_range(-4.0..4.0),
            );
            let d = Vector3::new(
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
            );
            let brute = quads
                .iter()
                .enumerate()
                .filter_map(|(i, q)| q.intersect(&o, &d).map(|h| (i as u32, h.0)))
                .min_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)));
            let fast = bvh.nearest(&quads, &o, &d).map(|h| (h.0, h.1));
            assert_eq!(brute, fast);
            hits += brute.is_some() as usize;
        }
        assert!(hits > 500, "test rays should hit something ({hits})");
    }

    #[test]
    fn aabb_distance() {
        let b = Aabb {
            min: Vector3::new(0.0, 0.0, 0.0),
            max: Vector3::new(1.0, 1.0, 1.0),
        };
        assert_eq!(b.distance(&Vector3::new(0.5, 0.5, 0.5)), 0.0);
        assert!((b.distance(&Vector3::new(2.0, 0.5, 0.5)) - 1.0).abs() < 1e-15);
        assert!((b.distance(&Vector3::new(4.0, 5.0, 0.5)) - 5.0).abs() < 1e-15);
    }
}
