//! The pipeline file (`pipeline/*.toml`): a work folder and one section per stage,
//! mirroring each stage's own configuration. Unknown keys are refused; errors name the
//! file, line and column.
//!
//! Paths are relative to the pipeline file and may use `${NAME}` environment
//! variables (the dataset, hloc and LIMAP folders of the templates). With `[synth]` the
//! inputs are the synthetic scene the pipeline renders first into `<work>/synth/`: the
//! dataset root, depth, COLMAP model and LIMAP folder then come from it and may not be
//! given.

use crate::error::{PipelineError, Result, io_err};
use crate::expand::{expand, line_column};
use crate::train_stage::ScoreSection;
use datasets::ingest::{DatasetKind, DepthOption, IngestConfig, PoseOption};
use labels::import::ImportConfig;
use labels::refine::RefineConfig;
use labels::shard::ShardStageConfig;
use labels::{NameMapping, PoseSource};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use toml::Spanned;

/// The file as written (paths unexpanded). Serialisable: a lock file embeds the
/// pipeline it was made from.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PipelineFile {
    /// Work folder: each stage writes `<work>/<stage>/`.
    pub work: Spanned<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub synth: Option<SynthSection>,
    #[serde(default)]
    pub ingest: IngestSection,
    #[serde(default)]
    pub import: ImportSection,
    /// Absent: the shards take the imported labels as they are.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub refine: Option<RefineSection>,
    #[serde(default)]
    pub shard: ShardSection,
    /// The trainer's configuration (`pl2map train --config`; missing keys take their
    /// defaults). Absent: the pipeline ends with the shards.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub train: Option<train::TrainConfig>,
    /// Scores the trained model on the test shards; needs `[train]`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub score: Option<ScoreSection>,
    /// How `pl2map run --warm-start CKPT` continues training (defaults without it).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub warm_start: Option<WarmStartSection>,
}

/// Nightly retraining: with `--warm-start CKPT` the train stage starts from that model's
/// weights (fresh optimiser, the model's coordinate centre) and trains this many
/// iterations on the current shards, with its own learning-rate schedule.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct WarmStartSection {
    /// None: a fifth of `[train] iterations` (at least 1).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub iterations: Option<u64>,
    /// None: `[train] learning_rate`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub learning_rate: Option<f64>,
}

impl WarmStartSection {
    /// The trainer's configuration of a warm-started run.
    pub fn train_config(&self, train: &train::TrainConfig) -> train::TrainConfig {
        let mut c = train.clone();
        c.iterations = self.iterations.unwrap_or((train.iterations / 5).max(1));
        if let Some(lr) = self.learning_rate {
            c.learning_rate = lr;
        }
        c
    }
}

/// `pl2map synth` options.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SynthSection {
    /// The test-sized scene (24 training + 8 test frames); `frames` is then ignored.
    pub tiny: bool,
    pub frames: usize,
    pub seed: u64,
    /// RMS 3D error (cm) added to the ground-truth labels, for `[refine]` to remove.
    pub label_noise_cm: f64,
    pub layout: DatasetKind,
    pub name: String,
    /// Only the first N training sequences (the dataset as recorded so far); raising it
    /// later adds frames and leaves the others as they were.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub train_sequences: Option<usize>,
}

impl Default for SynthSection {
    fn default() -> Self {
        SynthSection {
            tiny: false,
            frames: datasets::synth::trajectory::DEFAULT_FRAMES,
            seed: 0,
            label_noise_cm: 0.0,
            layout: DatasetKind::SevenScenes,
            name: datasets::synth::generate::DEFAULT_SCENE_NAME.into(),
            train_sequences: None,
        }
    }
}

/// `pl2map ingest` options. `depth` is `none`, `raw` or `rendered:DIR`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct IngestSection {
    #[serde(skip_serializing_if = "Option::is_none")]
    pub dataset: Option<DatasetKind>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub root: Option<Spanned<String>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub scene: Option<String>,
    pub poses: PoseOption,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub depth: Option<Spanned<String>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub camera: Option<String>,
}

/// Image name rules (see `labels::NameMapping`); `replace_extension = [".jpg", ".png"]`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct NamesSection {
    #[serde(skip_serializing_if = "Option::is_none")]
    pub strip_prefix: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub add_prefix: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub replace_extension: Option<(String, String)>,
}

impl From<&NamesSection> for NameMapping {
    fn from(n: &NamesSection) -> Self {
        NameMapping {
            strip_prefix: n.strip_prefix.clone(),
            add_prefix: n.add_prefix.clone(),
            replace_extension: n.replace_extension.clone(),
        }
    }
}

/// `pl2map import` options: the COLMAP model (hloc) and LIMAP folders, and the
/// stage's `ImportConfig`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ImportSection {
    #[serde(skip_serializing_if = "Option::is_none")]
    pub model: Option<Spanned<String>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub limap: Option<Spanned<String>>,
    pub model_names: NamesSection,
    pub limap_names: NamesSection,
    pub pose_source: PoseSource,
    pub allow_test_images: bool,
    pub segment_scale: f64,
    pub bounds_tolerance_px: f64,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub limap_segments: Option<PathBuf>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub limap_tracks: Option<PathBuf>,
}

impl Default for ImportSection {
    fn default() -> Self {
        let c = ImportConfig::default();
        ImportSection {
            model: None,
            limap: None,
            model_names: NamesSection::default(),
            limap_names: NamesSection::default(),
            pose_source: c.pose_source,
            allow_test_images: c.allow_test_images,
            segment_scale: c.segment_scale,
            bounds_tolerance_px: c.bounds_tolerance_px,
            limap_segments: c.limap_segments,
            limap_tracks: c.limap_tracks,
        }
    }
}

impl ImportSection {
    pub fn config(&self) -> ImportConfig {
        ImportConfig {
            model_names: (&self.model_names).into(),
            limap_names: (&self.limap_names).into(),
            pose_source: self.pose_source,
            allow_test_images: self.allow_test_images,
            segment_scale: self.segment_scale,
            bounds_tolerance_px: self.bounds_tolerance_px,
            limap_segments: self.limap_segments.clone(),
            limap_tracks: self.limap_tracks.clone(),
        }
    }
}

/// The `[refine]` section is `labels::refine::RefineConfig` itself (metres), with its
/// defaults for missing keys.
pub use labels::refine::RefineConfig as RefineSection;

/// `labels::shard::ShardStageConfig`, flattened.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ShardSection {
    pub frames_per_shard: usize,
    pub chunk_size: u64,
    pub zstd_level: u32,
    pub include_test: bool,
}

impl Default for ShardSection {
    fn default() -> Self {
        let c = ShardStageConfig::default();
        ShardSection {
            frames_per_shard: c.shards.frames_per_shard,
            chunk_size: c.shards.chunk_size,
            zstd_level: c.shards.zstd_level,
            include_test: c.include_test,
        }
    }
}

impl ShardSection {
    pub fn config(&self) -> ShardStageConfig {
        let mut c = ShardStageConfig {
            include_test: self.include_test,
            ..ShardStageConfig::default()
        };
        c.shards.frames_per_shard = self.frames_per_shard;
        c.shards.chunk_size = self.chunk_size;
        c.shards.zstd_level = self.zstd_level;
        c
    }
}

/// A pipeline with every path expanded and made absolute: what [`crate::run`] runs.
#[derive(Clone, Debug)]
pub struct Pipeline {
    /// The file it was read from (pipeline or lock file).
    pub origin: PathBuf,
    pub file: PipelineFile,
    pub work: PathBuf,
    pub synth: Option<SynthSection>,
    pub ingest: IngestConfig,
    pub model: PathBuf,
    pub limap: PathBuf,
    pub import: ImportConfig,
    pub refine: Option<RefineConfig>,
    pub shard: ShardStageConfig,
    /// A variant of the pipeline sharing the data stages (synth, ingest, import, refine):
    /// its shard, train and score folders are under `<work>/<branch>/`.
    pub branch: Option<String>,
}

/// The label variant [`Pipeline::without_refine`] makes.
pub const WITHOUT_REFINE: &str = "without-refine";

/// Stages a branch keeps in its own folder.
const BRANCH_STAGES: [&str; 3] = ["shard", "train", "score"];

/// Stage folder names under the work folder, in run order.
pub const STAGES: [&str; 7] = [
    "synth", "ingest", "import", "refine", "shard", "train", "score",
];

impl Pipeline {
    /// Reads and resolves a pipeline file; relative paths are relative to its folder.
    pub fn load(path: &Path) -> Result<Pipeline> {
        Pipeline::load_with_work(path, None)
    }

    /// As [`Pipeline::load`], with `work` (when given) replacing the file's work folder.
    pub fn load_with_work(path: &Path, work: Option<PathBuf>) -> Result<Pipeline> {
        Pipeline::load_unit(path, work, None)
    }

    /// As [`Pipeline::load_with_work`] for one scene of a multi-scene dataset (a work
    /// unit): `scene` replaces `ingest.scene` and `${SCENE}` in paths. When the file's
    /// `work` does not use `${SCENE}` (and no `work` is given) the scene's work folder is
    /// `<work>/<scene>`, so units of different scenes never share a folder.
    pub fn load_unit(path: &Path, work: Option<PathBuf>, scene: Option<&str>) -> Result<Pipeline> {
        let text = std::fs::read_to_string(path).map_err(io_err(path))?;
        let mut file = parse::<PipelineFile>(&text, path)?;
        let base = path.parent().unwrap_or(Path::new("."));
        let mut work = work;
        if let Some(scene) = scene {
            if file.synth.is_some() {
                return Err(PipelineError::Config {
                    path: path.to_path_buf(),
                    message: "--scene selects a scene of a dataset; this pipeline renders \
                              its own scene ([synth])"
                        .into(),
                });
            }
            if scene.is_empty() || scene.contains(['/', '\\']) || scene.starts_with('.') {
                return Err(PipelineError::Config {
                    path: path.to_path_buf(),
                    message: format!("--scene {scene:?} must be a plain folder name"),
                });
            }
            file.ingest.scene = Some(scene.to_string());
            if work.is_none() && !file.work.get_ref().contains("${SCENE}") {
                let r = Resolver {
                    text: &text,
                    origin: path,
                    base,
                    scene: None,
                };
                work = Some(r.path("work", &file.work)?.join(scene));
            }
        }
        Pipeline::resolve(file, &text, path, base, work)
    }

    /// Resolves `file` (parsed from `text`, read from `origin`, for error positions).
    /// `work` replaces the file's work folder (a lock file is rebuilt elsewhere).
    pub fn resolve(
        file: PipelineFile,
        text: &str,
        origin: &Path,
        base: &Path,
        work: Option<PathBuf>,
    ) -> Result<Pipeline> {
        let r = Resolver {
            text,
            origin,
            base,
            scene: file.ingest.scene.clone(),
        };
        let work = match work {
            Some(w) => w,
            None => r.path("work", &file.work)?,
        };
        let work = absolute(&work)?;
        let ing = &file.ingest;
        let imp = &file.import;
        let (ingest, model, limap) = match &file.synth {
            Some(s) => {
                let given: Vec<&str> = [
                    ("ingest.dataset", ing.dataset.is_some()),
                    ("ingest.root", ing.root.is_some()),
                    ("ingest.scene", ing.scene.is_some()),
                    ("ingest.depth", ing.depth.is_some()),
                    ("import.model", imp.model.is_some()),
                    ("import.limap", imp.limap.is_some()),
                ]
                .into_iter()
                .filter(|(_, g)| *g)
                .map(|(k, _)| k)
                .collect();
                if !given.is_empty() {
                    return Err(r.config(format!(
                        "{} come(s) from the synthetic scene of [synth]; remove them",
                        given.join(", ")
                    )));
                }
                if s.name.is_empty() || s.name.contains(['/', '\\']) || s.name.starts_with('.') {
                    return Err(r.config(format!(
                        "synth.name {:?} must be a plain folder name",
                        s.name
                    )));
                }
                if !(s.label_noise_cm.is_finite() && s.label_noise_cm >= 0.0) {
                    return Err(r.config("synth.label_noise_cm must be finite and >= 0".into()));
                }
                let root = work.join("synth").join(&s.name);
                let gt = root.join(datasets::synth::gt::GT_DIR);
                let mut c = IngestConfig::new(s.layout, &root);
                c.poses = ing.poses;
                c.camera = ing.camera.clone();
                // The renderer writes depth in the colour camera next to 7-Scenes
                // frames; the Cambridge layout has none.
                if s.layout == DatasetKind::SevenScenes {
                    c.depth = DepthOption::Rendered(root.clone());
                }
                (c, gt.join("colmap"), gt.join("limap"))
            }
            None => {
                let need = |key: &str, v: &Option<Spanned<String>>| -> Result<PathBuf> {
                    match v {
                        Some(v) => r.path(key, v),
                        None => Err(r.config(format!("{key} is required without [synth]"))),
                    }
                };
                let dataset = ing
                    .dataset
                    .ok_or_else(|| r.config("ingest.dataset is required without [synth]".into()))?;
                let mut c = IngestConfig::new(dataset, need("ingest.root", &ing.root)?);
                c.scene = ing.scene.clone();
                c.poses = ing.poses;
                c.camera = ing.camera.clone();
                if let Some(d) = &ing.depth {
                    let text = r.expand("ingest.depth", d)?;
                    c.depth = match text.parse::<DepthOption>() {
                        Ok(DepthOption::Rendered(dir)) => DepthOption::Rendered(base.join(dir)),
                        Ok(other) => other,
                        Err(e) => return Err(r.value("ingest.depth", d.span(), e)),
                    };
                }
                let model = need("import.model", &imp.model)?;
                let limap = need("import.limap", &imp.limap)?;
                (c, model, limap)
            }
        };
        if file.score.is_some() && file.train.is_none() {
            return Err(r.config("[score] scores the model of [train]: add [train]".into()));
        }
        Ok(Pipeline {
            origin: origin.to_path_buf(),
            work,
            synth: file.synth.clone(),
            ingest,
            model,
            limap,
            import: imp.config(),
            refine: file.refine.clone(),
            shard: file.shard.config(),
            file,
            branch: None,
        })
    }

    /// `<work>/<stage>`, or `<work>/<branch>/<stage>` for a branch's own stages.
    pub fn stage_dir(&self, stage: &str) -> PathBuf {
        match &self.branch {
            Some(b) if BRANCH_STAGES.contains(&stage) => self.work.join(b).join(stage),
            _ => self.work.join(stage),
        }
    }

    /// The same pipeline on the imported labels as they are: no `[refine]`, its shards,
    /// model and score in `<work>/without-refine/` (the data stages are shared).
    pub fn without_refine(&self) -> Pipeline {
        let mut p = self.clone();
        p.refine = None;
        p.file.refine = None;
        p.branch = Some(WITHOUT_REFINE.to_string());
        p
    }

    /// The label folder the shards are made from: refine's, or import's without it.
    pub fn labels_dir(&self) -> PathBuf {
        self.stage_dir(if self.refine.is_some() {
            "refine"
        } else {
            "import"
        })
    }

    pub fn frames_path(&self) -> PathBuf {
        self.stage_dir("ingest").join(datasets::ingest::FRAMES_FILE)
    }
}

/// Parses TOML into `T`, errors prefixed with the file (toml's message has the line,
/// column and the offending text).
pub fn parse<T: serde::de::DeserializeOwned>(text: &str, path: &Path) -> Result<T> {
    toml::from_str(text).map_err(|e| PipelineError::Toml {
        path: path.to_path_buf(),
        message: e.to_string().trim_end().to_string(),
    })
}

/// Absolute, with `.` and `a/..` removed lexically (so `pipeline/../work` prints as
/// `work`; the work folder is ours, not a symlink farm).
fn absolute(p: &Path) -> Result<PathBuf> {
    use std::path::Component;
    let abs = std::path::absolute(p).map_err(io_err(p))?;
    let mut out = PathBuf::new();
    for c in abs.components() {
        match c {
            Component::CurDir => {}
            Component::ParentDir => {
                out.pop();
            }
            other => out.push(other),
        }
    }
    Ok(out)
}

struct Resolver<'a> {
    text: &'a str,
    origin: &'a Path,
    base: &'a Path,
    /// `${SCENE}`: `ingest.scene` (after `--scene`); other names come from the environment.
    scene: Option<String>,
}

impl Resolver<'_> {
    fn value(&self, key: &str, span: std::ops::Range<usize>, message: String) -> PipelineError {
        let (line, column) = line_column(self.text, span.start);
        PipelineError::Value {
            path: self.origin.to_path_buf(),
            line,
            column,
            key: key.to_string(),
            message,
        }
    }

    fn config(&self, message: String) -> PipelineError {
        PipelineError::Config {
            path: self.origin.to_path_buf(),
            message,
        }
    }

    fn expand(&self, key: &str, v: &Spanned<String>) -> Result<String> {
        let lookup = |n: &str| match n {
            "SCENE" => self.scene.clone(),
            _ => std::env::var(n).ok(),
        };
        expand(v.get_ref(), lookup).map_err(|m| self.value(key, v.span(), m))
    }

    /// Expanded, then relative to the pipeline file's folder.
    fn path(&self, key: &str, v: &Spanned<String>) -> Result<PathBuf> {
        let s = self.expand(key, v)?;
        if s.is_empty() {
            return Err(self.value(key, v.span(), "empty path".into()));
        }
        Ok(self.base.join(s))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn resolve(text: &str) -> Result<Pipeline> {
        let f = parse::<PipelineFile>(text, Path::new("/p/x.toml"))?;
        Pipeline::resolve(f, text, Path::new("/p/x.toml"), Path::new("/p"), None)
    }

    #[test]
    fn synthetic_defaults() {
        let p = resolve("work = \"./x/../w\"\n[synth]\ntiny = true\n[refine]\n").unwrap();
        assert_eq!(p.work, PathBuf::from("/p/w"));
        assert_eq!(p.ingest.root, PathBuf::from("/p/w/synth/synthroom"));
        assert_eq!(
            p.ingest.depth,
            DepthOption::Rendered("/p/w/synth/synthroom".into())
        );
        assert_eq!(p.model, PathBuf::from("/p/w/synth/synthroom/sfm_gt/colmap"));
        assert_eq!(p.refine, Some(RefineConfig::default()));
        assert_eq!(p.shard, ShardStageConfig::default());
        assert_eq!(p.import, ImportConfig::default());
        assert_eq!(p.labels_dir(), PathBuf::from("/p/w/refine"));
    }

    #[test]
    fn unknown_keys_name_the_position() {
        let e = resolve("work = \"w\"\n[refine]\npoint_treshold = 1\n")
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("/p/x.toml: "), "{e}");
        assert!(e.contains("line 3"), "{e}");
        assert!(e.contains("point_treshold"), "{e}");
    }

    #[test]
    fn dataset_paths_from_the_environment() {
        // SAFETY: this test is the only one reading this variable.
        unsafe { std::env::set_var("PL2MAP_TEST_CONFIG_DATA", "/data") };
        let text = "work = \"/w\"\n[ingest]\ndataset = \"7scenes\"\nroot = \"${PL2MAP_TEST_CONFIG_DATA}/7scenes\"\n\
                    scene = \"stairs\"\ndepth = \"rendered:depth/stairs\"\n\
                    [import]\nmodel = \"hloc/stairs\"\nlimap = \"${PL2MAP_TEST_CONFIG_UNSET}/stairs\"\n";
        let e = resolve(text).unwrap_err().to_string();
        assert!(e.starts_with("/p/x.toml:9:9: import.limap:"), "{e}");
        assert!(e.contains("PL2MAP_TEST_CONFIG_UNSET is not set"), "{e}");
        let p = resolve(&text.replace("${PL2MAP_TEST_CONFIG_UNSET}", "limap")).unwrap();
        assert_eq!(p.ingest.root, PathBuf::from("/data/7scenes"));
        assert_eq!(p.ingest.scene_dir(), PathBuf::from("/data/7scenes/stairs"));
        assert_eq!(
            p.ingest.depth,
            DepthOption::Rendered("/p/depth/stairs".into())
        );
        assert_eq!(p.model, PathBuf::from("/p/hloc/stairs"));
        assert_eq!(p.limap, PathBuf::from("/p/limap/stairs"));
        assert!(p.refine.is_none());
        assert_eq!(p.labels_dir(), PathBuf::from("/w/import"));
    }

    #[test]
    fn synth_and_dataset_paths_conflict() {
        let e = resolve("work = \"w\"\n[synth]\n[import]\nmodel = \"m\"\n")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("import.model come(s) from the synthetic scene"),
            "{e}"
        );
        let e = resolve("work = \"w\"\n[ingest]\ndataset = \"7scenes\"\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("ingest.root is required"), "{e}");
    }

    #[test]
    fn file_round_trips_through_toml() {
        let text = "work = \"w\"\n[synth]\ntiny = true\nlabel_noise_cm = 5.0\n[refine]\nseed = 3\n";
        let f = parse::<PipelineFile>(text, Path::new("x")).unwrap();
        let again = toml::to_string(&f).unwrap();
        let back = parse::<PipelineFile>(&again, Path::new("x")).unwrap();
        assert_eq!(
            toml::to_string(&back).unwrap(),
            again,
            "serialised pipeline is stable"
        );
        assert_eq!(back.refine.unwrap().seed, 3);
    }
}
