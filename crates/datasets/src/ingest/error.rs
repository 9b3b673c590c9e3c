use crate::descriptor::{CountMismatch, DescriptorError, SplitCounts};
use geometry::GeometryError;
use std::path::PathBuf;
use tables::TableError;
use thiserror::Error;

/// Everything that can go wrong while ingesting a dataset. Each variant about an input
/// names the file and, where the file is text, the 1-based line.
#[derive(Debug, Error)]
pub enum IngestError {
    #[error(transparent)]
    Io(#[from] fileio::IoError),
    /// A file or folder the layout requires does not exist.
    #[error("{path}: missing {what}")]
    Missing { path: PathBuf, what: String },
    /// A text file does not have the expected layout.
    #[error("{path}:{line}: {message}")]
    Parse {
        path: PathBuf,
        line: usize,
        message: String,
    },
    /// Values that parse but do not form a valid pose (NaN, not a rotation, last row of a
    /// 4x4 not [0 0 0 1], quaternion far from unit norm).
    #[error("{path}:{line}: invalid pose: {source}")]
    Pose {
        path: PathBuf,
        line: usize,
        #[source]
        source: GeometryError,
    },
    /// A colour frame of 7-Scenes exists in neither of the accepted encodings.
    #[error("{dir}: no colour image for {stem} (expected {stem}.color.png or {stem}.color.jpg)")]
    MissingColour { dir: PathBuf, stem: String },
    /// Two files claim the same role (e.g. both .color.png and .color.jpg).
    #[error("{path}: ambiguous {what}: {candidates:?}")]
    Ambiguous {
        path: PathBuf,
        what: String,
        candidates: Vec<String>,
    },
    #[error("{path}: cannot read the image: {source}")]
    Image {
        path: PathBuf,
        #[source]
        source: image::ImageError,
    },
    /// An image that is truncated or does not decode (one frame; ingest reports every
    /// damaged frame of a scene together as [`IngestError::DamagedImages`]).
    #[error("{path}: damaged image: {reason}")]
    DamagedImage { path: PathBuf, reason: String },
    /// Every damaged image of the scene.
    #[error(transparent)]
    DamagedImages(Box<DamagedImagesError>),
    /// An image or depth map whose size or pixel type is not the expected one.
    #[error("{path}: {message}")]
    ImageContent { path: PathBuf, message: String },
    /// A depth map whose size differs from its colour image.
    #[error("{path}: depth map is {got_w}x{got_h}, its colour image {image} is {w}x{h}")]
    DepthSize {
        path: PathBuf,
        image: String,
        got_w: u32,
        got_h: u32,
        w: u32,
        h: u32,
    },
    /// A Cambridge frame the NVM reconstruction has no camera for.
    #[error("{nvm}: no camera for frame {name} (looked up NVM names {nvm_stem}.*)")]
    NvmMissingCamera {
        nvm: PathBuf,
        name: String,
        nvm_stem: String,
    },
    /// The same frame listed twice (same split file, or both splits).
    #[error("{path}:{line}: {name} is listed twice ({first})")]
    Duplicate {
        path: PathBuf,
        line: usize,
        name: String,
        first: String,
    },
    /// A camera that does not fit its images.
    #[error("{path}: {message}")]
    Camera { path: PathBuf, message: String },
    /// An invalid configuration (not about a file).
    #[error("invalid ingest configuration: {0}")]
    Config(String),
    /// The dataset descriptor cannot be read or lacks what the configuration needs.
    #[error(transparent)]
    Descriptor(#[from] DescriptorError),
    /// A scene whose frames per split differ from its dataset descriptor's counts.
    #[error(transparent)]
    FrameCounts(Box<FrameCountError>),
    #[error(transparent)]
    Table(#[from] TableError),
    #[error(transparent)]
    Stage(#[from] stage::StageError),
}

/// A scene whose frames per split differ from its dataset descriptor's counts: a
/// truncated or partial download, or a subset read without turning the check off.
#[derive(Debug, Error)]
#[error(
    "{scene_dir}: scene {scene} does not have the frames the {descriptor} dataset \
     descriptor ({origin}) lists: {} ({counted}). A truncated or partial download? \
     Download the scene again, or turn the check off (`pl2map ingest --no-count-check`, \
     `count_check = false` in [ingest]) to read a subset such as the sample data",
    list_mismatches(.mismatches)
)]
pub struct FrameCountError {
    pub scene_dir: PathBuf,
    pub scene: String,
    /// The descriptor's name.
    pub descriptor: String,
    /// Where the descriptor was read from.
    pub origin: String,
    pub expected: SplitCounts,
    /// Every split whose count differs, train first.
    pub mismatches: Vec<CountMismatch>,
    /// What was counted, e.g. `frames of the sequences TrainSplit.txt / TestSplit.txt
    /// list`.
    pub counted: String,
}

/// The images of a scene that are truncated or do not decode, all of them.
#[derive(Debug, Error)]
#[error(
    "{scene_dir}: {} of {total} images are damaged (truncated or corrupt); a partial \
     download? Download them again:\n{}",
    damaged.len(),
    list_damaged(.damaged)
)]
pub struct DamagedImagesError {
    pub scene_dir: PathBuf,
    /// Frames of the scene (both splits).
    pub total: usize,
    /// Each damaged image with what is wrong, in frame order.
    pub damaged: Vec<(PathBuf, String)>,
}

fn list_damaged(damaged: &[(PathBuf, String)]) -> String {
    let lines: Vec<String> = damaged
        .iter()
        .map(|(p, why)| format!("  {}: {why}", p.display()))
        .collect();
    lines.join("\n")
}

pub type Result<T, E = IngestError> = std::result::Result<T, E>;

/// `train: expected 2000, found 6; test: expected 1000, found 6`.
fn list_mismatches(mismatches: &[CountMismatch]) -> String {
    let list: Vec<String> = mismatches
        .iter()
        .map(|m| format!("{}: expected {}, found {}", m.split, m.expected, m.found))
        .collect();
    list.join("; ")
}
