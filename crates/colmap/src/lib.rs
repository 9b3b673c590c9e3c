//! COLMAP sparse models: cameras, images, points3D, rigs and frames, read from and
//! written to COLMAP's binary (`.bin`) and text (`.txt`) files.
//!
//! - [`read`] picks the format like COLMAP (binary when cameras, images and points3D all
//!   exist as `.bin`); [`write_binary`] / [`write_text`] write all five files through
//!   temporary files and renames.
//! - Records keep their file order, so writing a model read from COLMAP's files gives
//!   the same bytes (binary; text too, for files COLMAP >= 3.12 wrote).
//! - Models without rigs/frames (COLMAP < 3.12) load: as COLMAP does, one rig per camera
//!   and one frame per image are added. With rigs/frames, each image's stored pose must
//!   equal `sensor_from_rig * rig_from_world` (COLMAP silently replaces it; we refuse a
//!   model where they disagree, see [`check::POSE_TOLERANCE`]).
//! - Parsers never panic and never allocate from an unchecked count; errors name the
//!   file, the place (byte offset + record, or line + column) and what was expected.
//!   `binary::parse_*` and `text::parse_*` work on bytes / strings without files.
//! - [`Reconstruction::mean_reprojection_error`] is COLMAP's (and pycolmap's summary):
//!   the mean of the stored per-point errors; `recomputed_mean_reprojection_error`
//!   recomputes them with `geometry::Camera::project` (COLMAP `UpdatePoint3DErrors`).

pub mod binary;
pub mod check;
pub mod error;
pub mod io;
pub mod model;
pub mod rig;
mod stats;
pub mod synthetic;
pub mod text;

pub use error::{ColmapError, Location, Problem, RecordRef, Result, Table};
pub use io::{
    Format, detect_format, read, read_binary, read_text, write, write_binary, write_text,
};
pub use model::{
    CameraRecord, INVALID_POINT3D_ID, Image, ModelIndex, Point2D, Point3D, Reconstruction,
    TrackElement,
};
pub use rig::{DataId, Frame, Rig, RigSensor, RigidTransform, SensorId, SensorType};
