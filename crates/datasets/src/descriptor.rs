//! Dataset descriptors: what pl2map knows about a dataset before reading it, one TOML
//! file per dataset in the repository's top-level `datasets/` folder (the source of
//! truth, compiled into the binary so that it works outside the repository): scene names
//! and their frame counts per split, the file names and cameras of each layout the
//! dataset comes in, where the data comes from and its licence, and what the hloc /
//! LIMAP runs that a pipeline imports write. Each file documents the format in its
//! header; `datasets/7scenes.toml` is the fullest example.
//!
//! A descriptor is chosen by built-in name (`7scenes`, `cambridge`, `synthetic`) or by
//! the path of a file of the user's own (a name ending in `.toml`), for data in a layout
//! the adapters read. Unknown keys are refused and every value is checked while parsing
//! (cameras, the extrinsic's rotation, scene names), so an error names the file, the line
//! and the key.
//!
//! The ingest stage reads its layout's file names and default cameras from the descriptor
//! in use and, unless told not to, compares the frames it found per split with the
//! scene's counts ([`Descriptor::check_counts`]).

use crate::camera_spec;
use crate::dataset_kind::DatasetKind;
use geometry::{Camera, Matrix3, Pose, Vector3};
use serde::{Deserialize, Deserializer, Serialize};
use std::collections::BTreeMap;
use std::fmt;
use std::path::{Path, PathBuf};
use tables::frames::Split;
use thiserror::Error;

/// The built-in descriptors: (name, file text).
const BUILTIN: [(&str, &str); 3] = [
    ("7scenes", include_str!("../../../datasets/7scenes.toml")),
    (
        "cambridge",
        include_str!("../../../datasets/cambridge.toml"),
    ),
    (
        "synthetic",
        include_str!("../../../datasets/synthetic.toml"),
    ),
];

/// Names of the built-in descriptors.
pub const BUILTIN_NAMES: [&str; 3] = [BUILTIN[0].0, BUILTIN[1].0, BUILTIN[2].0];

#[derive(Debug, Error)]
pub enum DescriptorError {
    /// Displays as `dataset descriptor <path>: <error>`.
    #[error("dataset descriptor {0}")]
    Io(#[from] fileio::IoError),
    /// Not TOML, an unknown or missing key, or a value that is not valid (the message
    /// has the line, the column and the key).
    #[error("dataset descriptor {origin}: {message}")]
    Parse { origin: Origin, message: String },
    /// A descriptor name that is neither built in nor a `.toml` path.
    #[error(
        "unknown dataset descriptor {name:?}: expected one of {} or the path of a .toml file",
        BUILTIN_NAMES.join(", ")
    )]
    Unknown { name: String },
    /// The descriptor has no section for the layout being read.
    #[error(
        "dataset descriptor {origin} has no [layouts.{layout}] section: it describes {}",
        .has.join(", ")
    )]
    NoLayout {
        origin: Origin,
        layout: &'static str,
        has: Vec<&'static str>,
    },
    /// A value the configuration needs is not in the descriptor.
    #[error("dataset descriptor {origin}: {what}")]
    Missing { origin: Origin, what: String },
}

pub type Result<T, E = DescriptorError> = std::result::Result<T, E>;

/// Where a descriptor was read from.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub enum Origin {
    /// A built-in descriptor, by name.
    BuiltIn(String),
    /// A file given by path.
    File(PathBuf),
    /// Parsed from text with no file (tests).
    #[default]
    Text,
}

impl fmt::Display for Origin {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Origin::BuiltIn(name) => write!(f, "built-in datasets/{name}.toml"),
            Origin::File(p) => write!(f, "{}", p.display()),
            Origin::Text => f.write_str("(text)"),
        }
    }
}

/// One dataset descriptor file.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Descriptor {
    /// The built-in name (`7scenes`); any short name for a file of the user's own.
    pub name: String,
    /// How messages name the dataset (`7-Scenes`).
    pub title: String,
    pub description: String,
    /// Where the data comes from (documentation).
    pub source: String,
    pub licence: String,
    pub layouts: Layouts,
    /// Scene folder name -> frames per split.
    #[serde(deserialize_with = "scene_map")]
    pub scenes: BTreeMap<String, SceneCounts>,
    /// How a generated dataset is made (the synthetic room).
    #[serde(default)]
    pub generated: Option<Generated>,
    /// What a recipe imports for a scene.
    pub outputs: Outputs,
    #[serde(skip)]
    origin: Origin,
}

/// The layouts a dataset comes in, each read by one ingest adapter.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Layouts {
    #[serde(rename = "7scenes", default)]
    pub seven_scenes: Option<SevenScenesLayout>,
    #[serde(default)]
    pub cambridge: Option<CambridgeLayout>,
}

/// `<scene>/{TrainSplit.txt, TestSplit.txt}` and `seq-XX/frame-XXXXXX.*`.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SevenScenesLayout {
    pub train_split: String,
    pub test_split: String,
    /// Every frame's camera unless the configuration gives one.
    pub colour_camera: NamedCamera,
    /// The sensor depth camera (`depth = raw`).
    #[serde(default)]
    pub depth_camera: Option<NamedCamera>,
    /// Depth-to-colour extrinsic (`depth = raw`, `poses = calibrated`).
    #[serde(default)]
    pub rgb_from_depth: Option<Extrinsic>,
}

/// `<scene>/{dataset_train.txt, dataset_test.txt, reconstruction.nvm, seqN/...}`.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CambridgeLayout {
    pub train_split: String,
    pub test_split: String,
    /// The reconstruction whose cameras give the focal lengths.
    pub nvm: String,
    /// Frames whose world-to-camera translation has a component beyond this (absolute
    /// value, metres) are outliers and excluded; None: no frame is excluded.
    #[serde(default, deserialize_with = "positive_finite_opt")]
    pub outlier_max_abs_translation: Option<f64>,
}

/// A camera and where it comes from.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NamedCamera {
    /// `"MODEL WIDTH HEIGHT PARAMS..."` in the file.
    #[serde(deserialize_with = "camera_from_spec")]
    pub model: Camera,
    /// How the frames table names the camera (`7-Scenes default`).
    #[serde(default)]
    pub label: Option<String>,
    pub source: String,
}

/// A rigid transform between two sensors, `X_to = R X_from + t`.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(try_from = "RawExtrinsic")]
pub struct Extrinsic {
    /// How the frames table names it (`LIRIS`).
    pub label: String,
    pub source: String,
    /// The matrix as written (rows).
    pub rotation: [[f64; 3]; 3],
    /// Metres.
    pub translation: [f64; 3],
    /// The closest rigid transform (the rotation checked orthonormal to 1e-6).
    pub pose: Pose,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawExtrinsic {
    label: String,
    source: String,
    rotation: [[f64; 3]; 3],
    translation: [f64; 3],
}

/// Tolerance of the extrinsic's rotation check (max |R^T R - I|, |det R - 1|).
const EXTRINSIC_ORTHONORMAL_TOLERANCE: f64 = 1e-6;

impl TryFrom<RawExtrinsic> for Extrinsic {
    type Error = String;
    fn try_from(raw: RawExtrinsic) -> Result<Self, String> {
        let r = Matrix3::from_fn(|i, j| raw.rotation[i][j]);
        let t = Vector3::from(raw.translation);
        let pose = Pose::from_rotation_matrix(&r, &t, EXTRINSIC_ORTHONORMAL_TOLERANCE)
            .map_err(|e| format!("extrinsic {:?}: {e}", raw.label))?;
        Ok(Extrinsic {
            label: raw.label,
            source: raw.source,
            rotation: raw.rotation,
            translation: raw.translation,
            pose,
        })
    }
}

/// Frames per split.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SplitCounts {
    pub train: usize,
    pub test: usize,
}

impl SplitCounts {
    pub fn get(&self, split: Split) -> usize {
        match split {
            Split::Train => self.train,
            Split::Test => self.test,
        }
    }
}

/// A scene's frame counts: both splits, or neither (counts not fixed, e.g. set when the
/// scene is generated).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(try_from = "RawSceneCounts")]
pub struct SceneCounts(pub Option<SplitCounts>);

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSceneCounts {
    #[serde(default)]
    train: Option<usize>,
    #[serde(default)]
    test: Option<usize>,
}

impl TryFrom<RawSceneCounts> for SceneCounts {
    type Error = &'static str;
    fn try_from(raw: RawSceneCounts) -> Result<Self, &'static str> {
        match (raw.train, raw.test) {
            (Some(train), Some(test)) => Ok(SceneCounts(Some(SplitCounts { train, test }))),
            (None, None) => Ok(SceneCounts(None)),
            _ => Err("give both train and test frame counts, or neither"),
        }
    }
}

/// How a generated dataset is made.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Generated {
    pub command: String,
    pub default_frames: usize,
    pub default: SplitCounts,
    pub tiny: SplitCounts,
}

/// What a recipe imports for a scene: paths relative to the folder each tool was given,
/// `${SCENE}` standing for the scene name.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Outputs {
    /// The COLMAP SfM model of the training images (`[import] model`).
    pub model: String,
    pub model_by: String,
    /// The LIMAP output folder (`[import] limap`).
    pub limap: String,
    pub limap_by: String,
    /// Depth rendered in the colour camera (`[ingest] depth = "rendered:DIR"`).
    #[serde(default)]
    pub depth: Option<String>,
    #[serde(default)]
    pub depth_by: Option<String>,
    /// Exact labels (a generated dataset).
    #[serde(default)]
    pub ground_truth: Option<String>,
    /// LIMAP's segments times this are pixels of the original images.
    #[serde(deserialize_with = "positive_finite")]
    pub segment_scale: f64,
}

/// A split whose frame count differs from the descriptor's.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CountMismatch {
    pub split: Split,
    pub expected: usize,
    pub found: usize,
}

/// The outcome of [`Descriptor::check_counts`].
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum CountCheck {
    /// Every split has the descriptor's count.
    Agrees(SplitCounts),
    /// The splits whose counts differ (at least one).
    Differs {
        expected: SplitCounts,
        mismatches: Vec<CountMismatch>,
    },
    /// The scene is listed without counts (a generated scene).
    NotFixed,
    /// The scene is not in the descriptor: nothing to check against.
    NotListed,
}

impl Descriptor {
    /// A built-in descriptor by name.
    pub fn builtin(name: &str) -> Result<Descriptor> {
        let (name, text) = BUILTIN
            .iter()
            .find(|(n, _)| *n == name)
            .ok_or_else(|| DescriptorError::Unknown { name: name.into() })?;
        Descriptor::parse(text, Origin::BuiltIn((*name).to_string()))
    }

    /// The default descriptor of a layout: the built-in one of the same name.
    pub fn for_layout(layout: DatasetKind) -> Result<Descriptor> {
        Descriptor::builtin(layout.name())
    }

    /// Reads a descriptor file of the user's own.
    pub fn from_file(path: &Path) -> Result<Descriptor> {
        let text = std::fs::read_to_string(path).map_err(fileio::io_err(path))?;
        Descriptor::parse(&text, Origin::File(path.to_path_buf()))
    }

    /// `choice` as `[ingest] descriptor` holds it: None, the layout's built-in
    /// descriptor; a name ending in `.toml`, a file (relative to the working folder);
    /// otherwise a built-in name.
    pub fn resolve(choice: Option<&str>, layout: DatasetKind) -> Result<Descriptor> {
        match choice {
            None => Descriptor::for_layout(layout),
            Some(c) if is_path(c) => Descriptor::from_file(Path::new(c)),
            Some(c) => Descriptor::builtin(c),
        }
    }

    /// Parses descriptor text; `origin` names it in errors.
    pub fn parse(text: &str, origin: Origin) -> Result<Descriptor> {
        let mut d: Descriptor = toml::from_str(text).map_err(|e| DescriptorError::Parse {
            origin: origin.clone(),
            message: e.to_string().trim_end().to_string(),
        })?;
        d.origin = origin;
        if d.layouts.seven_scenes.is_none() && d.layouts.cambridge.is_none() {
            return Err(DescriptorError::Missing {
                origin: d.origin,
                what: "no [layouts.7scenes] or [layouts.cambridge] section: \
                       say which layout the dataset comes in"
                    .into(),
            });
        }
        Ok(d)
    }

    pub fn origin(&self) -> &Origin {
        &self.origin
    }

    /// The layouts this descriptor has a section for.
    pub fn layout_names(&self) -> Vec<&'static str> {
        let mut v = Vec::new();
        if self.layouts.seven_scenes.is_some() {
            v.push(DatasetKind::SevenScenes.name());
        }
        if self.layouts.cambridge.is_some() {
            v.push(DatasetKind::Cambridge.name());
        }
        v
    }

    fn no_layout(&self, layout: DatasetKind) -> DescriptorError {
        DescriptorError::NoLayout {
            origin: self.origin.clone(),
            layout: layout.name(),
            has: self.layout_names(),
        }
    }

    pub fn seven_scenes(&self) -> Result<&SevenScenesLayout> {
        self.layouts
            .seven_scenes
            .as_ref()
            .ok_or_else(|| self.no_layout(DatasetKind::SevenScenes))
    }

    pub fn cambridge(&self) -> Result<&CambridgeLayout> {
        self.layouts
            .cambridge
            .as_ref()
            .ok_or_else(|| self.no_layout(DatasetKind::Cambridge))
    }

    /// Checks that the descriptor has a section for `layout`.
    pub fn require_layout(&self, layout: DatasetKind) -> Result<()> {
        match layout {
            DatasetKind::SevenScenes => self.seven_scenes().map(drop),
            DatasetKind::Cambridge => self.cambridge().map(drop),
        }
    }

    /// An error naming this descriptor and what it lacks.
    pub fn missing(&self, what: impl Into<String>) -> DescriptorError {
        DescriptorError::Missing {
            origin: self.origin.clone(),
            what: what.into(),
        }
    }

    /// The scene's frame counts: None when it is not listed, Some(None) when listed
    /// without counts.
    pub fn scene_counts(&self, scene: &str) -> Option<Option<SplitCounts>> {
        self.scenes.get(scene).map(|c| c.0)
    }

    /// Compares the frames found per split with the scene's counts.
    pub fn check_counts(&self, scene: &str, found: SplitCounts) -> CountCheck {
        match self.scene_counts(scene) {
            None => CountCheck::NotListed,
            Some(None) => CountCheck::NotFixed,
            Some(Some(expected)) => {
                let mismatches: Vec<CountMismatch> = [Split::Train, Split::Test]
                    .into_iter()
                    .filter(|&s| expected.get(s) != found.get(s))
                    .map(|split| CountMismatch {
                        split,
                        expected: expected.get(split),
                        found: found.get(split),
                    })
                    .collect();
                if mismatches.is_empty() {
                    CountCheck::Agrees(expected)
                } else {
                    CountCheck::Differs {
                        expected,
                        mismatches,
                    }
                }
            }
        }
    }
}

/// A descriptor choice naming a file rather than a built-in descriptor.
pub fn is_path(choice: &str) -> bool {
    choice.ends_with(".toml")
}

fn camera_from_spec<'de, D: Deserializer<'de>>(d: D) -> Result<Camera, D::Error> {
    let spec = String::deserialize(d)?;
    camera_spec::parse_camera(&spec).map_err(serde::de::Error::custom)
}

fn check_positive_finite<E: serde::de::Error>(v: f64) -> Result<f64, E> {
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        Err(E::custom(format!("expected a finite number > 0, got {v}")))
    }
}

fn positive_finite<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    check_positive_finite(f64::deserialize(d)?)
}

fn positive_finite_opt<'de, D: Deserializer<'de>>(d: D) -> Result<Option<f64>, D::Error> {
    check_positive_finite(f64::deserialize(d)?).map(Some)
}

fn scene_map<'de, D: Deserializer<'de>>(d: D) -> Result<BTreeMap<String, SceneCounts>, D::Error> {
    let map = BTreeMap::<String, SceneCounts>::deserialize(d)?;
    if let Some(bad) = map
        .keys()
        .find(|s| s.is_empty() || s.contains(['/', '\\']) || *s == "." || *s == "..")
    {
        return Err(serde::de::Error::custom(format!(
            "scene {bad:?} must be a folder name"
        )));
    }
    Ok(map)
}

#[cfg(test)]
mod tests {
    use super::*;

    const MINIMAL: &str = r#"
name = "mine"
title = "Mine"
description = "d"
source = "s"
licence = "l"
[layouts.7scenes]
train_split = "TrainSplit.txt"
test_split = "TestSplit.txt"
colour_camera = { model = "SIMPLE_PINHOLE 64 48 50 32 24", source = "guess" }
[scenes]
a = { train = 3, test = 2 }
b = {}
[outputs]
model = "m"
model_by = "x"
limap = "l"
limap_by = "y"
segment_scale = 1.0
"#;

    fn parse(text: &str) -> Result<Descriptor> {
        Descriptor::parse(text, Origin::File("mine.toml".into()))
    }

    #[test]
    fn builtins_parse_and_name_themselves() {
        for name in BUILTIN_NAMES {
            let d = Descriptor::builtin(name).unwrap();
            assert_eq!(d.name, name);
            assert_eq!(d.origin(), &Origin::BuiltIn(name.into()));
        }
        assert!(matches!(
            Descriptor::builtin("7Scenes"),
            Err(DescriptorError::Unknown { .. })
        ));
    }

    #[test]
    fn counts_are_checked_per_split() {
        let d = parse(MINIMAL).unwrap();
        let found = |train, test| SplitCounts { train, test };
        assert_eq!(
            d.check_counts("a", found(3, 2)),
            CountCheck::Agrees(found(3, 2))
        );
        assert_eq!(
            d.check_counts("a", found(3, 1)),
            CountCheck::Differs {
                expected: found(3, 2),
                mismatches: vec![CountMismatch {
                    split: Split::Test,
                    expected: 2,
                    found: 1
                }]
            }
        );
        assert_eq!(d.check_counts("b", found(1, 1)), CountCheck::NotFixed);
        assert_eq!(d.check_counts("c", found(1, 1)), CountCheck::NotListed);
    }

    #[test]
    fn errors_name_the_file_line_and_key() {
        let cases = [
            (
                MINIMAL.replace("licence = \"l\"", "licence = \"l\"\nlicense = \"l\""),
                "license",
                7,
            ),
            (
                MINIMAL.replace("a = { train = 3, test = 2 }", "a = { train = 3 }"),
                "both",
                12,
            ),
            (MINIMAL.replace("b = {}", "\"x/y\" = {}"), "folder name", 11),
            (MINIMAL.replace("50 32 24", "50 32"), "SIMPLE_PINHOLE", 10),
            (
                MINIMAL.replace("segment_scale = 1.0", "segment_scale = -1.0"),
                "> 0",
                19,
            ),
        ];
        for (text, want, line) in cases {
            let e = parse(&text).unwrap_err().to_string();
            assert!(e.starts_with("dataset descriptor mine.toml: "), "{e}");
            assert!(e.contains(want), "{want}: {e}");
            assert!(e.contains(&format!("line {line}")), "{line}: {e}");
        }
        let e = parse(&MINIMAL.replace("[layouts.7scenes]", "[layouts.seven]")).unwrap_err();
        assert!(e.to_string().contains("seven"), "{e}");
    }

    #[test]
    fn a_non_rotation_extrinsic_is_refused() {
        // A sub-table of [layouts.7scenes] may come after other tables.
        let text = format!(
            "{MINIMAL}\n[layouts.7scenes.rgb_from_depth]\nlabel = \"k\"\nsource = \"s\"\n\
             rotation = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.01]]\n\
             translation = [0.0, 0.0, 0.0]\n"
        );
        let e = parse(&text).unwrap_err().to_string();
        assert!(e.contains("extrinsic \"k\""), "{e}");
    }

    #[test]
    fn layouts_are_required_and_named() {
        let d = parse(MINIMAL).unwrap();
        assert!(d.seven_scenes().is_ok());
        let e = d.cambridge().unwrap_err().to_string();
        assert!(
            e.contains("mine.toml has no [layouts.cambridge] section: it describes 7scenes"),
            "{e}"
        );
        let start = MINIMAL.find("[layouts.7scenes]").unwrap();
        let end = MINIMAL.find("[scenes]").unwrap();
        let no_layout = format!("{}[layouts]\n{}", &MINIMAL[..start], &MINIMAL[end..]);
        let e = parse(&no_layout).unwrap_err().to_string();
        assert!(e.contains("which layout"), "{e}");
    }

    #[test]
    fn choices() {
        assert!(is_path("my.toml") && is_path("../d/7scenes.toml"));
        assert!(!is_path("7scenes"));
        let d = Descriptor::resolve(None, DatasetKind::Cambridge).unwrap();
        assert_eq!(d.name, "cambridge");
        let e = Descriptor::resolve(Some("nope"), DatasetKind::Cambridge).unwrap_err();
        assert!(
            e.to_string()
                .contains("expected one of 7scenes, cambridge, synthetic"),
            "{e}"
        );
        let e =
            Descriptor::resolve(Some("/nonexistent/x.toml"), DatasetKind::Cambridge).unwrap_err();
        assert!(matches!(e, DescriptorError::Io(_)), "{e}");
        assert!(
            e.to_string()
                .starts_with("dataset descriptor /nonexistent/x.toml: "),
            "{e}"
        );
    }
}
