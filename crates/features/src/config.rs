use crate::error::FeatureError;
use crate::kind::FrontEndKind;
use serde::{Deserialize, Serialize};
use std::path::PathBuf;

/// SIFT detection (OpenCV's parameters) and the top-K cut.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SiftConfig {
    /// Keep the K strongest keypoints (4096 for training images, 2048 for queries).
    pub max_keypoints: usize,
    pub n_octave_layers: i32,
    pub contrast_threshold: f64,
    pub edge_threshold: f64,
    pub sigma: f64,
}

impl Default for SiftConfig {
    fn default() -> Self {
        SiftConfig {
            max_keypoints: 4096,
            n_octave_layers: 3,
            contrast_threshold: 0.04,
            edge_threshold: 10.0,
            sigma: 1.6,
        }
    }
}

/// Which SIFT descriptor the SIFT front-end computes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum DescriptorMethod {
    /// Read from one dense map of pooled orientation channels per image (`dense.rs`):
    /// about 1 us per descriptor after a map of a few ms.
    #[default]
    Dense,
    /// OpenCV's SIFT descriptor at each keypoint (about 0.1 ms each at size 12): the
    /// descriptor of checkpoints written before `method` existed (checkpoint format 1).
    Opencv,
}

/// How a descriptor is computed at a given position.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct DescriptorConfig {
    /// `dense` (the default) or `opencv`. A map is queried with the method it was
    /// trained with: the checkpoint records it.
    pub method: DescriptorMethod,
    /// SIFT keypoint "size" (diameter in pixels) used for every descriptor: one fixed
    /// scale, so that training positions (no scale known) and query detections are
    /// described alike.
    pub point_size: f32,
    /// Size of the descriptors sampled along lines.
    pub line_size: f32,
}

impl Default for DescriptorConfig {
    fn default() -> Self {
        DescriptorConfig {
            method: DescriptorMethod::Dense,
            point_size: 12.0,
            line_size: 12.0,
        }
    }
}

/// Which LSD the front-end runs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum LsdImplementation {
    /// The `lsd` crate with pytlsd's settings: the segments LIMAP detects (it calls
    /// `pytlsd.lsd(grey)`), so that a query sees the lines its map was trained on.
    #[default]
    Pytlsd,
    /// OpenCV's `createLineSegmentDetector` with refinement: the detector of
    /// checkpoints written before `implementation` existed (checkpoint format 1).
    Opencv,
}

/// LSD line detection.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LsdConfig {
    /// `pytlsd` (the default, LIMAP's LSD) or `opencv`. A map is queried with the
    /// detector it was trained with: the checkpoint records it.
    pub implementation: LsdImplementation,
    /// Segments shorter than this (pixels) are dropped.
    pub min_length: f64,
    /// Keep the longest N segments.
    pub max_lines: usize,
}

impl Default for LsdConfig {
    fn default() -> Self {
        LsdConfig {
            implementation: LsdImplementation::Pytlsd,
            min_length: 15.0,
            max_lines: 3000,
        }
    }
}

/// The environment variable naming the SuperPoint weights file when neither the
/// configuration nor a flag does.
pub const SUPERPOINT_WEIGHTS_ENV: &str = "PL2MAP_SUPERPOINT_WEIGHTS";

/// SuperPoint's settings (docs/method.md section 2b). Plain data: the network is in the
/// `superpoint` crate.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SuperPointConfig {
    /// The released state-dict file (`superpoint_v1.pth`), supplied by the user. None:
    /// the `PL2MAP_SUPERPOINT_WEIGHTS` environment variable.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub weights: Option<PathBuf>,
    /// sha256 of the weights file the front-end was built with. Filled by the trainer
    /// and stored in every checkpoint; a front-end built from a checkpoint refuses a
    /// weights file with another hash.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub weights_sha256: Option<String>,
    /// Non-maximum suppression radius in pixels (a max-pool of size 2r + 1).
    pub nms_radius: usize,
    /// Scores at or below this are not keypoints.
    pub detection_threshold: f32,
    /// Keypoints closer than this to the image border (pixels) are dropped.
    pub remove_borders: usize,
    /// Keep the K strongest keypoints (the query's top-K).
    pub max_keypoints: usize,
    /// Resize so that the longer side is at most this many pixels (area interpolation)
    /// before the network; 0: never. Keypoints and given positions are mapped between
    /// the original and the resized image.
    pub resize_max: usize,
}

impl Default for SuperPointConfig {
    fn default() -> Self {
        SuperPointConfig {
            weights: None,
            weights_sha256: None,
            nms_radius: 3,
            detection_threshold: 0.005,
            remove_borders: 4,
            max_keypoints: 2048,
            resize_max: 1024,
        }
    }
}

impl SuperPointConfig {
    pub fn is_default(&self) -> bool {
        *self == SuperPointConfig::default()
    }

    /// The weights file: the configured one, else `PL2MAP_SUPERPOINT_WEIGHTS`.
    pub fn weights_path(&self) -> Option<PathBuf> {
        self.weights.clone().or_else(|| {
            std::env::var_os(SUPERPOINT_WEIGHTS_ENV)
                .filter(|v| !v.is_empty())
                .map(PathBuf::from)
        })
    }
}

/// The whole front-end.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FrontEndConfig {
    /// Which front-end (`sift`, the default, or `superpoint`). Left out of the
    /// serialised form when `sift`, so configurations (and the stage records and
    /// checkpoints holding them) of SIFT runs keep their bytes.
    #[serde(skip_serializing_if = "FrontEndKind::is_sift")]
    pub kind: FrontEndKind,
    /// SuperPoint's settings (used when `kind = "superpoint"`).
    #[serde(skip_serializing_if = "SuperPointConfig::is_default")]
    pub superpoint: SuperPointConfig,
    pub sift: SiftConfig,
    pub descriptor: DescriptorConfig,
    pub lsd: LsdConfig,
    /// Points sampled along each segment, endpoints included (T = 12 in PL2Map).
    pub samples_per_line: usize,
}

impl Default for FrontEndConfig {
    fn default() -> Self {
        FrontEndConfig {
            kind: FrontEndKind::Sift,
            superpoint: SuperPointConfig::default(),
            sift: SiftConfig::default(),
            descriptor: DescriptorConfig::default(),
            lsd: LsdConfig::default(),
            samples_per_line: 12,
        }
    }
}

impl FrontEndConfig {
    /// The query-time configuration: 2048 keypoints.
    pub fn query() -> Self {
        let mut c = Self::default();
        c.sift.max_keypoints = 2048;
        c
    }

    /// The descriptor width of the configured kind.
    pub fn dim(&self) -> usize {
        self.kind.dim()
    }

    /// Sets the query's top-K of the configured kind.
    pub fn set_max_keypoints(&mut self, k: usize) {
        match self.kind {
            FrontEndKind::Sift => self.sift.max_keypoints = k,
            FrontEndKind::Superpoint => self.superpoint.max_keypoints = k,
        }
    }

    pub fn validate(&self) -> Result<(), FeatureError> {
        let bad = |m: &str| Err(FeatureError::Config(m.to_string()));
        let sp = &self.superpoint;
        if !(sp.detection_threshold >= 0.0 && sp.detection_threshold < 1.0) {
            return bad("superpoint.detection_threshold must be in [0, 1)");
        }
        if sp.resize_max != 0 && sp.resize_max < 16 {
            return bad("superpoint.resize_max must be 0 (off) or at least 16");
        }
        if self.samples_per_line < 2 {
            return bad("samples_per_line must be >= 2 (both endpoints)");
        }
        if !(self.descriptor.point_size > 0.0 && self.descriptor.line_size > 0.0) {
            return bad("descriptor sizes must be > 0");
        }
        if !(self.sift.sigma > 0.0 && self.sift.n_octave_layers > 0) {
            return bad("sift.sigma and sift.n_octave_layers must be > 0");
        }
        if !(self.lsd.min_length >= 0.0) {
            return bad("lsd.min_length must be >= 0");
        }
        Ok(())
    }
}
