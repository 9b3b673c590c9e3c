//! The room's shell: walls, floor and ceiling with the corners between them, and the
//! rug lying on the floor.

use super::{Builder, RHO_CEILING, RHO_ROOM, walls};
use crate::elements::{Edge3, EdgeKind, ObjectKind, ROOM};
use crate::patterns::Material;
use crate::quad::Surface;
use nalgebra::Vector3;
use rand::Rng;

/// Offset of the rug above the floor (a flat quad lies a little in front of the surface
/// under it: no depth ties).
const RUG_OFFSET: f64 = 0.003;

impl Builder {
    pub(super) fn room(&mut self) -> [u32; 6] {
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

    pub(super) fn rug(&mut self, floor: u32) {
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
}
