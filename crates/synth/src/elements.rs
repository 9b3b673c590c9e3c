//! What the room is made of, apart from its quads: its size, its objects and the exact 3D
//! edges across which the rendered intensity steps. Their own file because the builder
//! (`build/`) makes them and the scene (`scene.rs`, which calls the builder) holds them.

use super::quad::Aabb;
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

/// Room size along x, y, z in metres.
pub const ROOM: [f64; 3] = [4.0, 3.0, 2.5];

/// What kind of thing an object is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum ObjectKind {
    /// Walls, floor and ceiling.
    Room,
    Rug,
    Poster,
    Picture,
    Shelf,
    Cabinet,
    Table,
    Book,
    Carton,
    Door,
}

/// A named group of quads (a wall, a book, a shelf unit...).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Object {
    pub name: String,
    pub kind: ObjectKind,
    /// Bounds of the object's solid (boxes) or quads.
    pub bounds: Aabb,
}

/// Why an edge is an intensity step.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum EdgeKind {
    /// Wall-wall, wall-floor and wall-ceiling corners.
    RoomCorner,
    /// An edge of a solid box (furniture, book, carton, frame, door frame): a crease
    /// between two differently shaded faces or a silhouette against what lies behind.
    ObjectEdge,
    /// The border of a flat quad lying on another surface (poster, rug, door leaf).
    DecalBorder,
    /// A straight step drawn inside a texture (poster cells and stripes, tile grout,
    /// picture mats, labels, book bands, door panels).
    TextureEdge,
}

/// A straight 3D segment across which the rendered intensity steps.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Edge3 {
    pub a: Vector3<f64>,
    pub b: Vector3<f64>,
    pub kind: EdgeKind,
    /// The quads the edge bounds (creases: both faces; silhouettes with an omitted face,
    /// decals and texture edges: the quad(s) it lies on).
    pub faces: [Option<u32>; 2],
    pub object: u32,
    /// Expected luma step of the flat colours (texture edges) or of the shaded mean
    /// colours of the two faces (creases), in 0..1; None for silhouettes whose other side
    /// depends on the viewpoint.
    pub contrast: Option<f32>,
}

impl Edge3 {
    pub fn length(&self) -> f64 {
        (self.b - self.a).norm()
    }
}
