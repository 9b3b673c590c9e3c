//! Typed errors. Every error about input names the file, the place (byte offset and
//! record for binary files, line and column for text files, the record for
//! cross-file checks) and what was expected.

use geometry::GeometryError;
use std::fmt;
use std::path::PathBuf;
use thiserror::Error;

/// The five tables of a model (one file each).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Table {
    Cameras,
    Images,
    Points3D,
    Rigs,
    Frames,
}

impl Table {
    /// File stem as COLMAP names it (`points3D`, not `points3d`).
    pub fn stem(self) -> &'static str {
        match self {
            Table::Cameras => "cameras",
            Table::Images => "images",
            Table::Points3D => "points3D",
            Table::Rigs => "rigs",
            Table::Frames => "frames",
        }
    }

    fn record_name(self) -> &'static str {
        match self {
            Table::Cameras => "camera",
            Table::Images => "image",
            Table::Points3D => "point3D",
            Table::Rigs => "rig",
            Table::Frames => "frame",
        }
    }
}

/// One record of a table: its position in the file (0-based) and, once read, its id.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RecordRef {
    pub table: Table,
    pub index: usize,
    pub id: Option<u64>,
}

impl fmt::Display for RecordRef {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} #{}", self.table.record_name(), self.index)?;
        if let Some(id) = self.id {
            write!(f, " (id {id})")?;
        }
        Ok(())
    }
}

/// Where in a file a problem was found.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Location {
    /// Binary file: byte offset of the value that could not be read.
    Byte {
        offset: usize,
        record: Option<RecordRef>,
    },
    /// Text file: 1-based line and column (byte) of the offending token.
    Line {
        line: usize,
        column: usize,
        record: Option<RecordRef>,
    },
    /// A record as a whole (cross-record and cross-file checks).
    Record(RecordRef),
}

impl fmt::Display for Location {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Location::Byte { offset, record } => {
                write!(f, "byte {offset}")?;
                if let Some(r) = record {
                    write!(f, " ({r})")?;
                }
                Ok(())
            }
            Location::Line {
                line,
                column,
                record,
            } => {
                write!(f, "line {line}, column {column}")?;
                if let Some(r) = record {
                    write!(f, " ({r})")?;
                }
                Ok(())
            }
            Location::Record(r) => write!(f, "{r}"),
        }
    }
}

/// What is wrong.
#[derive(Clone, Debug, PartialEq, Error)]
pub enum Problem {
    #[error("expected {what} ({needed} bytes), but only {remaining} bytes remain")]
    Truncated {
        what: &'static str,
        needed: usize,
        remaining: usize,
    },
    #[error(
        "{what} count {count} needs at least {min_bytes} bytes, but only {remaining} bytes remain"
    )]
    CountTooLarge {
        what: &'static str,
        count: u64,
        min_bytes: u128,
        remaining: usize,
    },
    #[error("{count} unexpected bytes after the last record")]
    TrailingBytes { count: usize },
    #[error("image name is not NUL-terminated before the end of the file")]
    UnterminatedName,
    #[error("text file is not valid UTF-8")]
    NotUtf8,
    #[error("image name is not valid UTF-8")]
    NameNotUtf8,
    #[error("image name {0:?} cannot be stored (empty, or contains whitespace / NUL)")]
    BadName(String),
    #[error("unknown sensor type {0} (expected CAMERA, IMU or INVALID / 0, 1, -1)")]
    UnknownSensorType(String),
    #[error("{what}: {source}")]
    Geometry {
        what: &'static str,
        #[source]
        source: GeometryError,
    },
    #[error("{what} is not finite")]
    NonFinite { what: &'static str },
    #[error("expected {expected}, found end of line")]
    MissingToken { expected: &'static str },
    #[error("expected {expected}, found {token:?}")]
    BadToken {
        expected: &'static str,
        token: String,
    },
    #[error("{count} unexpected tokens at the end of the line, starting with {first:?}")]
    ExtraTokens { count: usize, first: String },
    #[error("expected the POINTS2D line of the image, found end of file")]
    MissingPointsLine,
    #[error("duplicate id {id} (first at record #{first_index})")]
    DuplicateId { id: u64, first_index: usize },
    #[error("duplicate image name {name:?} (first at record #{first_index})")]
    DuplicateName { name: String, first_index: usize },
    #[error("unknown camera id {0}")]
    UnknownCamera(u32),
    #[error("unknown image id {0}")]
    UnknownImage(u32),
    #[error("unknown rig id {0}")]
    UnknownRig(u32),
    #[error("point2D index {idx} is out of range: image {image_id} has {num_points2d} points2D")]
    Point2DOutOfRange {
        image_id: u32,
        idx: u32,
        num_points2d: usize,
    },
    #[error(
        "track element (image {image_id}, point2D {idx}) points at a 2D point whose point3D id is {found}"
    )]
    TrackMismatch {
        image_id: u32,
        idx: u32,
        found: String,
    },
    #[error("track lists (image {image_id}, point2D {idx}) twice (or two tracks list it)")]
    DuplicateObservation { image_id: u32, idx: u32 },
    #[error(
        "point2D {idx} refers to point3D {point3d_id}, which does not exist or whose track does not list it"
    )]
    DanglingObservation { idx: usize, point3d_id: u64 },
    #[error("image is not part of any frame (rigs/frames are present)")]
    ImageWithoutFrame,
    #[error("image is listed by frames {first} and {second}")]
    ImageInTwoFrames { first: u32, second: u32 },
    #[error(
        "frame lists the image with sensor (CAMERA, {sensor_id}) but the image's camera is {camera_id}"
    )]
    FrameSensorMismatch { sensor_id: u32, camera_id: u32 },
    #[error("rig {rig_id} has no sensor (CAMERA, {camera_id})")]
    SensorNotInRig { rig_id: u32, camera_id: u32 },
    #[error("rig {rig_id} has no sensor_from_rig pose for camera {camera_id}")]
    SensorPoseMissing { rig_id: u32, camera_id: u32 },
    #[error("rig has {count} non-reference sensors but no reference sensor")]
    SensorsWithoutReference { count: usize },
    #[error(
        "stored cam_from_world differs from the frame's composed pose by {rotation_rad:.3e} rad / {translation:.3e} (tolerance {tolerance:.0e})"
    )]
    PoseMismatch {
        rotation_rad: f64,
        translation: f64,
        tolerance: f64,
    },
    #[error("point3D id 2^64-1 is reserved for \"no 3D point\"")]
    ReservedPointId,
    #[error("count {count} does not fit in a 32-bit field")]
    CountOverflow { count: usize },
    /// points3D.txt cut short: a cut between two track elements leaves a valid line,
    /// so the only sign in the file is a missing line end or a header that promises
    /// more; `then` is the model check's error that the cut caused.
    #[error("the file is cut short: {evidence}; the model's check then fails: {then}")]
    CutShort { evidence: String, then: String },
}

/// Errors of this crate.
#[derive(Debug, Error)]
pub enum ColmapError {
    #[error(transparent)]
    Io(#[from] fileio::IoError),
    #[error(
        "{}: no COLMAP model (need cameras, images and points3D, all .bin or all .txt)",
        dir.display()
    )]
    MissingModel { dir: PathBuf },
    /// A problem in one file, at a place.
    #[error("{}: {at}: {problem}", path.display())]
    Parse {
        path: PathBuf,
        at: Location,
        problem: Box<Problem>,
    },
    /// An in-memory model that breaks an invariant (no file involved).
    #[error("invalid model: {at}: {problem}")]
    Invalid { at: Location, problem: Box<Problem> },
}

impl ColmapError {
    /// The problem, whatever the variant (None for I/O and missing files).
    pub fn problem(&self) -> Option<&Problem> {
        match self {
            ColmapError::Parse { problem, .. } | ColmapError::Invalid { problem, .. } => {
                Some(problem)
            }
            _ => None,
        }
    }

    pub fn location(&self) -> Option<&Location> {
        match self {
            ColmapError::Parse { at, .. } | ColmapError::Invalid { at, .. } => Some(at),
            _ => None,
        }
    }
}

pub type Result<T, E = ColmapError> = std::result::Result<T, E>;

/// A located problem before the file it belongs to is known (checks of in-memory models
/// report the table; the directory readers turn that into a path).
#[derive(Clone, Debug, PartialEq)]
pub struct Located {
    pub table: Table,
    pub at: Location,
    pub problem: Box<Problem>,
}

impl Located {
    pub(crate) fn record(record: RecordRef, problem: Problem) -> Self {
        Located {
            table: record.table,
            at: Location::Record(record),
            problem: Box::new(problem),
        }
    }

    pub(crate) fn into_invalid(self) -> ColmapError {
        ColmapError::Invalid {
            at: self.at,
            problem: self.problem,
        }
    }

    pub(crate) fn into_parse(self, path: PathBuf) -> ColmapError {
        ColmapError::Parse {
            path,
            at: self.at,
            problem: self.problem,
        }
    }
}
