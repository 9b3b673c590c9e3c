//! The import stage's configuration (`[import]`, `pl2map import`).

use super::detected::PointLabels;
use super::detectors::DetectorCheck;
use super::error::ImportError;
use super::problems::LSD_OVERSHOOT_PX;
use crate::names::NameMapping;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use tables::labels::PoseSource;

/// The import stage's configuration: `[import]` of a pipeline file and the flags of
/// `pl2map import`, the only place its settings and defaults live. The two input
/// folders are part of it; the record hashes their content, not their paths.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, clap::Args)]
#[serde(default, deny_unknown_fields)]
pub struct ImportConfig {
    /// COLMAP model folder (cameras/images/points3D, .bin or .txt), e.g. hloc's
    /// `sfm_superpoint+superglue/` (a pipeline with [synth] takes its scene's).
    #[arg(long, required = true)]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub model: Option<PathBuf>,
    /// LIMAP output folder (image_list.txt, finaltracks/, line_detections/*/segments/).
    #[arg(long, required = true)]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub limap: Option<PathBuf>,
    /// COLMAP image name -> frames table name: `identity` or rules
    /// `strip_prefix=P,add_prefix=P,replace_extension=.jpg:.png`.
    #[arg(long, default_value = "identity", value_parser = NameMapping::parse_rules)]
    pub model_names: NameMapping,
    /// LIMAP image_list.txt name -> frames table name (same rules).
    #[arg(long, default_value = "identity", value_parser = NameMapping::parse_rules)]
    pub limap_names: NameMapping,
    /// Camera and pose of the labels: sfm (the model's, as the reference implementation)
    /// or dataset (the frames table's).
    #[arg(long, default_value_t = ImportConfig::default().pose_source)]
    pub pose_source: PoseSource,
    /// Test frames found in the model or in LIMAP are skipped (true) or refused (false,
    /// the default: labels made with test images leak them into training).
    #[arg(long, default_value_t = ImportConfig::default().allow_test_images, action = clap::ArgAction::Set)]
    pub allow_test_images: bool,
    /// LIMAP segment coordinates times this are pixels of the image (LIMAP detects on
    /// images resized to `max_image_dim`, 1600 by default: for a 1920-wide image the
    /// scale is 1920 / 1600 = 1.2).
    #[arg(long, default_value_t = ImportConfig::default().segment_scale)]
    pub segment_scale: f64,
    /// How far outside the image (pixels) a keypoint or segment endpoint may lie before
    /// the input is refused (it would mean another resolution or camera). 3 px by
    /// default: LSD extrapolates segments past the border (LIMAP's pytlsd output of the
    /// synthetic room reaches 2.7 px, docs/formats.md section 2).
    #[arg(long, default_value_t = ImportConfig::default().bounds_tolerance_px)]
    pub bounds_tolerance_px: f64,
    /// The LIMAP segments folder, relative to the LIMAP folder; default: the only one of
    /// `line_detections/*/segments` and `segments`.
    #[arg(long)]
    pub limap_segments: Option<PathBuf>,
    /// The LIMAP track folder, relative to the LIMAP folder; default: `finaltracks`.
    #[arg(long)]
    pub limap_tracks: Option<PathBuf>,
    /// Which line tracks label the lines: `finaltracks` (every track of the track folder)
    /// or `alltracks` (LIMAP's alltracks.txt: the tracks seen in at least 4 images, what
    /// the reference implementation trains on).
    #[serde(skip_serializing_if = "LineTrackSet::is_default")]
    #[arg(long, value_enum, default_value_t = LineTrackSet::default())]
    pub line_tracks: LineTrackSet,
    /// The detector check (docs/method.md section 3): on a sample of training images,
    /// compare the model's keypoints and LIMAP's segments with the front-end's
    /// detections; `refuse` (default) when they say another detector made them, `accept`
    /// (import anyway, the report keeps the rates) or `off`.
    #[serde(skip_serializing_if = "DetectorCheck::is_default")]
    #[arg(long, value_enum, default_value_t = DetectorCheck::default())]
    pub detector_check: DetectorCheck,
    /// Which model keypoints enter the labels: `all` (default) or `detected`, only those
    /// the front-end detects itself within 1 px (docs/method.md section 3). For a model whose detector is another
    /// implementation of the front-end's (COLMAP's or hloc's SIFT under OpenCV's SIFT),
    /// so that training describes the positions the query detects.
    #[serde(skip_serializing_if = "PointLabels::is_default")]
    #[arg(long, value_enum, default_value_t = PointLabels::default())]
    pub point_labels: PointLabels,
    /// The front-end the check compares with (`pl2map import --front-end`; a pipeline's
    /// `[features]` sets its kind and SuperPoint weights). Left out of the serialised
    /// form when the default (SIFT), and its weights file is hashed by content.
    #[serde(skip_serializing_if = "is_default_front_end")]
    #[arg(skip)]
    pub front_end: features::FrontEndConfig,
}

fn is_default_front_end(c: &features::FrontEndConfig) -> bool {
    *c == features::FrontEndConfig::default()
}

/// The LIMAP tracks the line labels come from (`[import] line_tracks`).
#[derive(
    Clone,
    Copy,
    Debug,
    Default,
    PartialEq,
    Eq,
    Serialize,
    Deserialize,
    clap::ValueEnum,
    strum::Display,
    strum::IntoStaticStr,
)]
#[serde(rename_all = "lowercase")]
#[strum(serialize_all = "lowercase")]
pub enum LineTrackSet {
    /// Every track of the track folder (`finaltracks/`).
    #[default]
    Finaltracks,
    /// `alltracks.txt`: the tracks seen in at least 4 images.
    Alltracks,
}

impl LineTrackSet {
    /// Serialised only when not the default, so that configurations (and the records
    /// and reports that hash them) written before the option existed keep their bytes.
    fn is_default(&self) -> bool {
        *self == LineTrackSet::default()
    }

    pub fn as_str(self) -> &'static str {
        self.into()
    }
}

impl Default for ImportConfig {
    fn default() -> Self {
        ImportConfig {
            model: None,
            limap: None,
            model_names: NameMapping::identity(),
            limap_names: NameMapping::identity(),
            pose_source: PoseSource::Sfm,
            allow_test_images: false,
            segment_scale: 1.0,
            bounds_tolerance_px: LSD_OVERSHOOT_PX,
            limap_segments: None,
            limap_tracks: None,
            line_tracks: LineTrackSet::Finaltracks,
            detector_check: DetectorCheck::Refuse,
            point_labels: PointLabels::All,
            front_end: features::FrontEndConfig::default(),
        }
    }
}

impl ImportConfig {
    /// The settings without the input folders: what the record and the report hash
    /// (the inputs are hashed by content).
    pub fn settings(&self) -> ImportConfig {
        let mut front_end = self.front_end.clone();
        front_end.superpoint.weights = None;
        ImportConfig {
            model: None,
            limap: None,
            front_end,
            ..self.clone()
        }
    }

    /// The COLMAP model and LIMAP folders, or the error naming the missing one.
    pub fn inputs(&self) -> Result<(&Path, &Path), ImportError> {
        let model = self.model.as_deref().ok_or_else(|| {
            ImportError::Config("no COLMAP model: give --model DIR ([import] model)".into())
        })?;
        let limap = self.limap.as_deref().ok_or_else(|| {
            ImportError::Config("no LIMAP folder: give --limap DIR ([import] limap)".into())
        })?;
        Ok((model, limap))
    }

    pub fn validate(&self) -> Result<(), ImportError> {
        if !(self.segment_scale.is_finite() && self.segment_scale > 0.0) {
            return Err(ImportError::Config(format!(
                "segment_scale must be positive and finite, got {}",
                self.segment_scale
            )));
        }
        if !(self.bounds_tolerance_px.is_finite() && self.bounds_tolerance_px >= 0.0) {
            return Err(ImportError::Config(format!(
                "bounds_tolerance_px must be >= 0 and finite, got {}",
                self.bounds_tolerance_px
            )));
        }
        self.front_end
            .validate()
            .map_err(|e| ImportError::Config(format!("front_end: {e}")))?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn line_track_set_serde_and_strum_names_agree() {
        for set in [LineTrackSet::Finaltracks, LineTrackSet::Alltracks] {
            assert_eq!(
                serde_json::to_string(&set).unwrap(),
                format!("\"{}\"", set.as_str())
            );
            assert_eq!(set.to_string(), set.as_str());
            let clap_name = clap::ValueEnum::to_possible_value(&set).unwrap();
            assert_eq!(clap_name.get_name(), set.as_str());
        }
    }
}
