//! The ingest configuration: a serde struct embedded in pipeline TOML files, and the
//! option types the command line parses.

use super::error::{IngestError, Result};
use crate::camera_spec;
use crate::dataset_kind::DatasetKind;
use geometry::Camera;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::str::FromStr;

/// Which pose the colour camera gets (7-Scenes; Cambridge has only `published`).
#[derive(
    Clone,
    Copy,
    Debug,
    Default,
    PartialEq,
    Eq,
    Serialize,
    Deserialize,
    strum::Display,
    strum::EnumString,
    strum::VariantNames,
)]
#[serde(rename_all = "lowercase")]
#[strum(
    serialize_all = "lowercase",
    parse_err_ty = String,
    parse_err_fn = unknown_pose_option
)]
pub enum PoseOption {
    /// The dataset's pose as published (7-Scenes: the depth camera's, from pose.txt).
    #[default]
    Published,
    /// 7-Scenes: moved to the colour camera with the Kinect depth-to-RGB extrinsic.
    Calibrated,
}

/// The parse error, naming the accepted options.
fn unknown_pose_option(s: &str) -> String {
    use strum::VariantNames;
    format!(
        "unknown pose option {s:?} (expected {})",
        PoseOption::VARIANTS.join(" or ")
    )
}

/// Which depth maps the table points to. Written as `none`, `raw` or `rendered:DIR`.
///
/// Its names are written here by hand, once (`DepthOption::NONE`, `RAW`, `RENDERED`):
/// `Rendered` carries a folder, which strum's derives can neither print nor parse;
/// serde goes through `Display` and `FromStr`.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub enum DepthOption {
    #[default]
    None,
    /// 7-Scenes: each depth.png registered into the colour camera, written to `depth/`.
    Raw,
    /// A folder of depth maps rendered in the colour camera, found by frame name
    /// ([`depth::rendered_candidates`] lists the accepted names).
    Rendered(PathBuf),
}

impl FromStr for DepthOption {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        match s {
            DepthOption::NONE => Ok(DepthOption::None),
            DepthOption::RAW => Ok(DepthOption::Raw),
            _ => match s.strip_prefix(DepthOption::RENDERED) {
                Some(dir) if !dir.is_empty() => Ok(DepthOption::Rendered(PathBuf::from(dir))),
                _ => Err(format!(
                    "unknown depth option {s:?} (expected none, raw or rendered:DIR)"
                )),
            },
        }
    }
}

impl DepthOption {
    const NONE: &str = "none";
    const RAW: &str = "raw";
    /// Followed by the folder.
    const RENDERED: &str = "rendered:";

    pub fn is_none(&self) -> bool {
        *self == DepthOption::None
    }
}

impl std::fmt::Display for DepthOption {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            DepthOption::None => f.write_str(DepthOption::NONE),
            DepthOption::Raw => f.write_str(DepthOption::RAW),
            DepthOption::Rendered(d) => write!(f, "{}{}", DepthOption::RENDERED, d.display()),
        }
    }
}

impl Serialize for DepthOption {
    fn serialize<S: serde::Serializer>(&self, s: S) -> std::result::Result<S::Ok, S::Error> {
        s.collect_str(self)
    }
}

impl<'de> Deserialize<'de> for DepthOption {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        let text = String::deserialize(d)?;
        text.parse().map_err(serde::de::Error::custom)
    }
}

/// The ingest stage's configuration: `[ingest]` of a pipeline file and the flags of
/// `pl2map ingest`, the only place its settings and defaults live.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, clap::Args)]
#[serde(default, deny_unknown_fields)]
pub struct IngestConfig {
    /// Dataset layout: 7scenes or cambridge (a pipeline with [synth] takes its scene's).
    #[arg(long, required = true)]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub dataset: Option<DatasetKind>,
    /// The dataset folder. With `scene`, the scene is `root/scene`; without, `root` is
    /// the scene folder itself (the one holding the split files).
    #[arg(long, required = true)]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub root: Option<PathBuf>,
    /// Scene folder inside the root (chess, KingsCollege ...).
    #[arg(long)]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub scene: Option<String>,
    /// Which pose the colour camera gets: published (the dataset's) or calibrated
    /// (7-Scenes: moved to the colour camera with the Kinect extrinsic).
    #[arg(long, default_value_t = PoseOption::default())]
    pub poses: PoseOption,
    /// Depth maps of the frames: none, raw (7-Scenes: registered into the colour
    /// camera) or rendered:DIR (maps rendered in the colour camera, found by name).
    #[arg(long, default_value_t = DepthOption::default())]
    #[serde(skip_serializing_if = "DepthOption::is_none")]
    pub depth: DepthOption,
    /// A camera for every frame, `MODEL WIDTH HEIGHT PARAMS...` (COLMAP order), instead
    /// of the dataset's default intrinsics.
    #[arg(long)]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub camera: Option<String>,
    /// The dataset descriptor (see [`crate::descriptor`]): a built-in name (`7scenes`,
    /// `cambridge`, `synthetic`) or the path of a `.toml` file; None, the built-in one
    /// of `dataset`. It gives the layout's file names and default cameras and the
    /// scenes' frame counts.
    #[arg(long)]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub descriptor: Option<String>,
    /// Refuse a scene the descriptor lists whose frame counts per split differ from the
    /// descriptor's (a truncated download). Off for subsets such as the sample data.
    #[arg(
        long = "no-count-check",
        action = clap::ArgAction::SetFalse,
        help = "Read a scene whose frame counts differ from its descriptor's (a subset such \
                as the sample data); by default such a scene is refused as a truncated download"
    )]
    #[serde(skip_serializing_if = "is_true")]
    pub count_check: bool,
}

fn is_true(b: &bool) -> bool {
    *b
}

impl Default for IngestConfig {
    fn default() -> Self {
        IngestConfig {
            dataset: None,
            root: None,
            scene: None,
            poses: PoseOption::default(),
            depth: DepthOption::default(),
            camera: None,
            descriptor: None,
            count_check: true,
        }
    }
}

impl IngestConfig {
    pub fn new(dataset: DatasetKind, root: impl Into<PathBuf>) -> Self {
        IngestConfig {
            dataset: Some(dataset),
            root: Some(root.into()),
            ..IngestConfig::default()
        }
    }

    /// The dataset layout, or the error that names the missing setting.
    pub fn dataset(&self) -> Result<DatasetKind> {
        self.dataset.ok_or_else(|| {
            IngestError::Config(
                "no dataset: give --dataset 7scenes|cambridge ([ingest] dataset)".into(),
            )
        })
    }

    /// The dataset folder, or the error that names the missing setting.
    pub fn root(&self) -> Result<&Path> {
        self.root.as_deref().ok_or_else(|| {
            IngestError::Config("no dataset folder: give --root DIR ([ingest] root)".into())
        })
    }

    pub fn scene_dir(&self) -> PathBuf {
        let root = self.root.clone().unwrap_or_default();
        match &self.scene {
            Some(s) => root.join(s),
            None => root,
        }
    }

    /// Checks option combinations; returns the camera override, parsed.
    pub(super) fn validate(&self) -> Result<Option<Camera>> {
        let cambridge = self.dataset()? == DatasetKind::Cambridge;
        self.root()?;
        if cambridge && self.poses == PoseOption::Calibrated {
            return Err(IngestError::Config(
                "poses = calibrated applies to 7-Scenes only (Cambridge has one pose source)"
                    .into(),
            ));
        }
        if cambridge && self.depth == DepthOption::Raw {
            return Err(IngestError::Config(
                "depth = raw applies to 7-Scenes only (Cambridge has no sensor depth)".into(),
            ));
        }
        if let Some(s) = &self.scene
            && (s.is_empty() || s.contains(['/', '\\']) || s == "." || s == "..")
        {
            return Err(IngestError::Config(format!(
                "scene {s:?} must be a folder name inside root"
            )));
        }
        self.camera
            .as_deref()
            .map(camera_spec::parse_camera)
            .transpose()
            .map_err(IngestError::Config)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn options_parse_and_serialise_for_toml() {
        assert_eq!("7scenes".parse(), Ok(DatasetKind::SevenScenes));
        assert!("7Scenes".parse::<DatasetKind>().is_err());
        assert_eq!("calibrated".parse(), Ok(PoseOption::Calibrated));
        assert_eq!(
            "rendered:/a/b".parse(),
            Ok(DepthOption::Rendered(PathBuf::from("/a/b")))
        );
        assert!("rendered:".parse::<DepthOption>().is_err());
        assert_eq!(
            "none".parse::<DepthOption>().map(|d| d.to_string()),
            Ok("none".to_string())
        );
        assert_eq!(
            "raw".parse::<DepthOption>().map(|d| d.to_string()),
            Ok("raw".to_string())
        );
        let mut c = IngestConfig::new(DatasetKind::SevenScenes, "/data/7scenes");
        c.scene = Some("stairs".into());
        c.depth = DepthOption::Rendered("/r".into());
        let json = serde_json::to_string(&c).unwrap();
        assert!(json.contains(r#""dataset":"7scenes""#), "{json}");
        assert!(json.contains(r#""depth":"rendered:/r""#), "{json}");
        let back: IngestConfig = serde_json::from_str(&json).unwrap();
        assert_eq!(back, c);
        let minimal: IngestConfig =
            serde_json::from_str(r#"{"dataset":"cambridge","root":"/x","depth":"none"}"#).unwrap();
        assert_eq!(minimal.poses, PoseOption::Published);
        assert!(
            serde_json::from_str::<IngestConfig>(r#"{"dataset":"cambridge","root":"/x","typo":1}"#)
                .is_err()
        );
        // The new keys default to the old behaviour and are left out when at their
        // defaults, so configurations written before them hash the same.
        assert!(minimal.count_check && minimal.descriptor.is_none());
        let json = serde_json::to_string(&minimal).unwrap();
        assert!(
            !json.contains("count_check") && !json.contains("descriptor"),
            "{json}"
        );
        let off: IngestConfig = serde_json::from_str(
            r#"{"dataset":"7scenes","root":"/x","descriptor":"my.toml","count_check":false}"#,
        )
        .unwrap();
        assert_eq!(
            (off.descriptor.as_deref(), off.count_check),
            (Some("my.toml"), false)
        );
        assert!(
            serde_json::to_string(&off)
                .unwrap()
                .contains(r#""count_check":false"#)
        );
    }

    #[test]
    fn pose_option_serde_and_strum_names_agree() {
        for p in [PoseOption::Published, PoseOption::Calibrated] {
            assert_eq!(serde_json::to_string(&p).unwrap(), format!("\"{p}\""));
            assert_eq!(p.to_string().parse::<PoseOption>(), Ok(p));
        }
        assert_eq!(
            "Published".parse::<PoseOption>(),
            Err("unknown pose option \"Published\" (expected published or calibrated)".to_string())
        );
    }

    #[test]
    fn invalid_combinations_are_refused() {
        let mut c = IngestConfig::new(DatasetKind::Cambridge, "/x");
        c.poses = PoseOption::Calibrated;
        assert!(matches!(c.validate(), Err(IngestError::Config(_))));
        let mut c = IngestConfig::new(DatasetKind::Cambridge, "/x");
        c.depth = DepthOption::Raw;
        assert!(matches!(c.validate(), Err(IngestError::Config(_))));
        let mut c = IngestConfig::new(DatasetKind::SevenScenes, "/x");
        c.scene = Some("../etc".into());
        assert!(matches!(c.validate(), Err(IngestError::Config(_))));
        c.scene = None;
        c.camera = Some("PINHOLE 640 480 1".into());
        assert!(matches!(c.validate(), Err(IngestError::Config(_))));
    }
}
