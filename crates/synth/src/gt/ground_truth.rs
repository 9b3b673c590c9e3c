//! The exact labels of the training frames ([`GroundTruth`]) that the merge
//! (`mod.rs`, `build`) makes and the writer (`write.rs`) writes, and the counts the CLI
//! prints.

use super::lines::LineTrackGt;
use super::observations::FrameObservations;
use super::points::PointTrack;

/// One training image of the model: COLMAP/LIMAP image id (1-based, training order),
/// its frame and name.
#[derive(Clone, Debug, PartialEq)]
pub struct GtImage {
    pub image_id: u32,
    /// Index into [`crate::SynthDataset::frames`].
    pub frame: usize,
    pub name: String,
}

/// The exact labels of the training frames, before noise and writing.
#[derive(Clone, Debug)]
pub struct GroundTruth {
    pub images: Vec<GtImage>,
    /// Per image (parallel to `images`): its keypoints and segments.
    pub observations: Vec<FrameObservations>,
    /// 3D point tracks; point3D id = position + 1.
    pub points: Vec<PointTrack>,
    /// Line tracks in edge order; track file index = position.
    pub lines: Vec<LineTrackGt>,
}

/// Counts printed by the CLI.
#[derive(Clone, Debug, PartialEq)]
pub struct GtSummary {
    pub images: usize,
    pub keypoints: usize,
    pub points3d: usize,
    pub observations: usize,
    pub mean_track_length: f64,
    pub segments: usize,
    pub line_tracks: usize,
    pub line_supports: usize,
}

impl GroundTruth {
    pub fn summary(&self) -> GtSummary {
        let observations: usize = self.points.iter().map(|p| p.track.len()).sum();
        GtSummary {
            images: self.images.len(),
            keypoints: self.observations.iter().map(|o| o.keypoints.len()).sum(),
            points3d: self.points.len(),
            observations,
            mean_track_length: if self.points.is_empty() {
                0.0
            } else {
                observations as f64 / self.points.len() as f64
            },
            segments: self.observations.iter().map(|o| o.segments.len()).sum(),
            line_tracks: self.lines.len(),
            line_supports: self.lines.iter().map(|l| l.supports.len()).sum(),
        }
    }
}
