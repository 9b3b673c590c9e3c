//! The built-in synthetic scene: a procedural, textured indoor room rendered with exact
//! visibility, with the exact 3D geometry (ray casts, straight edges) that ground-truth
//! labels are built from.
//!
//! World frame: metres, z up, the room is `[0, 4] x [0, 3] x [0, 2.5]` (see [`scene`]).
//! Cameras: COLMAP conventions (world-to-camera poses, x right, y down, z forward, pixel
//! centres at +0.5).
//!
//! - [`Scene::generate`] builds the room from a seed; [`Scene::raycast`], [`Scene::edges`]
//!   and [`Scene::render`] give exact hits, edges and images.
//! - [`SynthDataset`] adds the camera paths; [`generate`] renders them and writes the
//!   7-Scenes or Cambridge layout.
//! - [`preview::contact_sheet`] draws frames with keypoints and segments.

mod build;
pub mod dataset;
pub mod elements;
pub mod error;
pub mod generate;
pub mod gt;
pub mod layout;
pub mod patterns;
pub mod preview;
pub mod quad;
pub mod render;
pub mod scene;
pub mod synth_stage;
pub mod texture;
pub mod trajectory;

pub use dataset::SynthDataset;
pub use elements::{Edge3, EdgeKind, Object, ObjectKind, ROOM};
pub use error::{Result, SynthError};
pub use generate::{
    FrameInfo, SynthConfig, SynthOutput, WriteOptions, color_name, generate, generate_tiny,
};
pub use layout::Layout;
pub use preview::contact_sheet;
pub use quad::{Aabb, Quad, Surface};
pub use render::Rendered;
pub use scene::{Hit, Scene};
pub use trajectory::{FrameSpec, Split, default_camera};
