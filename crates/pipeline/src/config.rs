//! The pipeline file (`pipeline/*.toml`): a work folder and one section per stage. Each
//! section deserialises straight into its stage's own configuration struct (the only
//! place a setting and its default live): `[synth]` `synth::SynthConfig`, `[ingest]`
//! `datasets::ingest::IngestConfig`, `[import]` `labels::import::ImportConfig`,
//! `[refine]` `labels::refine::RefineConfig`, `[shard]`
//! `shards::shard_stage::ShardStageConfig`, `[train]` `train::TrainConfig`, `[score]`
//! `score::ScoreStageConfig`. Unknown keys are refused; errors name the file, line and
//! column.
//!
//! Paths are relative to the pipeline file and may use `${NAME}` environment
//! variables (the dataset, hloc and LIMAP folders of the templates). With `[synth]` the
//! inputs are the synthetic scene the pipeline renders first into `<work>/synth/`: the
//! dataset root, depth, COLMAP model and LIMAP folder then come from it and may not be
//! given.

use crate::error::{PipelineError, Result};
use crate::resolver::Resolver;
use crate::stages::StageName;
use datasets::ingest::{DatasetKind, DepthOption, IngestConfig};
use fileio::io_err;
use labels::import::ImportConfig;
use labels::refine::RefineConfig;
use score::ScoreStageConfig;
use serde::{Deserialize, Serialize};
use shards::shard_stage::ShardStageConfig;
use std::path::{Path, PathBuf};
use synth::SynthConfig;

/// The file as written (paths unexpanded). Serialisable: a lock file embeds the
/// pipeline it was made from.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PipelineFile {
    /// Work folder: each stage writes `<work>/<stage>/`.
    pub work: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub synth: Option<SynthConfig>,
    #[serde(default)]
    pub ingest: IngestConfig,
    #[serde(default)]
    pub import: ImportConfig,
    /// Absent: the shards take the imported labels as they are.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub refine: Option<RefineConfig>,
    #[serde(default)]
    pub shard: ShardStageConfig,
    /// Absent: the pipeline ends with the shards.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub train: Option<train::TrainConfig>,
    /// Scores the trained model on the test shards; needs `[train]`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub score: Option<ScoreStageConfig>,
    /// How `pl2map run --warm-start CKPT` continues training (defaults without it).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub warm_start: Option<WarmStartSection>,
    /// The front-end of `[train]` (and, through its checkpoint, of `[score]`). Absent:
    /// `[train]`'s own `front_end` (SIFT by default).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub features: Option<FeaturesSection>,
}

/// `[features]`: which front-end describes the training images and the queries, and
/// which detector the import's check compares the SfM keypoints with.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FeaturesSection {
    /// `sift` or `superpoint`; the network's descriptor width follows it (128 / 256).
    pub kind: features::FrontEndKind,
    /// The SuperPoint weights file (`superpoint_v1.pth`, supplied by the user; README.md,
    /// "SuperPoint weights"), relative to this file; absent: `PL2MAP_SUPERPOINT_WEIGHTS`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub superpoint_weights: Option<String>,
}

/// Nightly retraining: with `--warm-start CKPT` the train stage starts from that model's
/// weights (fresh optimiser, the model's coordinate centre) and trains this many
/// iterations on the current shards, with `[train]`'s learning-rate schedule.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct WarmStartSection {
    /// None: `[train] iterations`. Shorter warm starts lost accuracy on the frames the
    /// previous model had learned (docs/operations.md, "How long a warm start trains").
    #[serde(skip_serializing_if = "Option::is_none")]
    pub iterations: Option<u64>,
    /// None: `[train] learning_rate`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub learning_rate: Option<f64>,
}

impl WarmStartSection {
    /// Refuses what `[train]`'s own check would only refuse when the stage starts.
    pub fn validate(&self) -> std::result::Result<(), String> {
        if self.iterations == Some(0) {
            return Err("iterations must be at least 1".into());
        }
        Ok(())
    }

    /// The trainer's configuration of a warm-started run.
    pub fn train_config(&self, train: &train::TrainConfig) -> train::TrainConfig {
        let mut c = train.clone();
        c.iterations = self.iterations.unwrap_or(train.iterations);
        if let Some(lr) = self.learning_rate {
            c.learning_rate = lr;
        }
        c
    }
}

/// A pipeline with every path expanded and made absolute: what [`crate::run()`] runs.
/// The sections that need no resolving are read from `file` ([`Pipeline::synth`],
/// [`Pipeline::refine`], [`Pipeline::shard`]): one copy of each, so that a variant such
/// as [`Pipeline::without_refine`] changes it in one place.
#[derive(Clone, Debug)]
pub struct Pipeline {
    /// The file it was read from (pipeline or lock file).
    pub origin: PathBuf,
    pub file: PipelineFile,
    pub work: PathBuf,
    /// With `root` (and a rendered `depth`) absolute.
    pub ingest: IngestConfig,
    /// With `model` and `limap` absolute.
    pub import: ImportConfig,
    /// A variant of the pipeline sharing the data stages (synth, ingest, import, refine):
    /// its shard, train and score folders are under `<work>/<branch>/`.
    pub branch: Option<String>,
}

/// The label variant [`Pipeline::without_refine`] makes.
pub const WITHOUT_REFINE: &str = "without-refine";

impl Pipeline {
    /// Runs the network of `[train]` and `[score]` on `device` (`pl2map run --device`),
    /// whatever their sections say. A device this build has no backend for, or this
    /// machine cannot run (no driver, no such GPU), is refused before any stage runs.
    pub fn set_device(&mut self, device: train::Device) -> Result<()> {
        device.check_usable().map_err(|e| PipelineError::Config {
            path: self.origin.clone(),
            message: format!("--device: {e}"),
        })?;
        if let Some(t) = self.file.train.as_mut() {
            t.device = device;
        }
        if let Some(s) = self.file.score.as_mut() {
            s.device = device;
        }
        Ok(())
    }

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
            if work.is_none() && !file.work.contains("${SCENE}") {
                let r = Resolver::new(&text, path, base, &[], None);
                work = Some(r.path(&["work"], &file.work)?.join(scene));
            }
        }
        Pipeline::resolve(file, &text, path, base, work, &[])
    }

    /// Resolves `file` (parsed from `text`, read from `origin`, for error positions;
    /// `prefix` is where the pipeline's tables sit in `text`: `["pipeline"]` in a lock
    /// file). `work` replaces the file's work folder (a lock file is rebuilt elsewhere).
    pub fn resolve(
        file: PipelineFile,
        text: &str,
        origin: &Path,
        base: &Path,
        work: Option<PathBuf>,
        prefix: &[&str],
    ) -> Result<Pipeline> {
        let r = Resolver::new(text, origin, base, prefix, file.ingest.scene.clone());
        let work = work_folder(&r, &file, work)?;
        let (ingest, mut import) = match &file.synth {
            Some(s) => synth_inputs(&r, s, &work, &file)?,
            None => dataset_inputs(&r, &file)?,
        };
        let mut file = file;
        apply_features(&r, &mut file, &mut import)?;
        check_sections(&r, &mut file)?;
        Ok(Pipeline {
            origin: origin.to_path_buf(),
            work,
            ingest,
            import,
            file,
            branch: None,
        })
    }

    /// `[synth]`: the scene the pipeline renders first, if any.
    pub fn synth(&self) -> Option<&SynthConfig> {
        self.file.synth.as_ref()
    }

    /// `[refine]`: absent, the shards take the imported labels as they are.
    pub fn refine(&self) -> Option<&RefineConfig> {
        self.file.refine.as_ref()
    }

    pub fn shard(&self) -> &ShardStageConfig {
        &self.file.shard
    }

    /// `<work>/<stage>`, or `<work>/<branch>/<stage>` for a branch's own stages.
    pub fn stage_dir(&self, stage: StageName) -> PathBuf {
        match &self.branch {
            Some(b) if stage.per_branch() => self.work.join(b).join(stage.dir()),
            _ => self.work.join(stage.dir()),
        }
    }

    /// The same pipeline on the imported labels as they are: no `[refine]`, its shards,
    /// model and score in `<work>/without-refine/` (the data stages are shared).
    pub fn without_refine(&self) -> Pipeline {
        let mut p = self.clone();
        p.file.refine = None;
        p.branch = Some(WITHOUT_REFINE.to_string());
        p
    }

    /// The label folder the shards are made from: refine's, or import's without it.
    pub fn labels_dir(&self) -> PathBuf {
        self.stage_dir(if self.refine().is_some() {
            StageName::Refine
        } else {
            StageName::Import
        })
    }

    pub fn frames_path(&self) -> PathBuf {
        self.stage_dir(StageName::Ingest)
            .join(datasets::ingest_stage::FRAMES_FILE)
    }
}

/// The work folder: `work` when given, else the file's; absolute, valid UTF-8, and not
/// a file (nor under one).
fn work_folder(r: &Resolver, file: &PipelineFile, work: Option<PathBuf>) -> Result<PathBuf> {
    let given = work.is_some();
    let work = match work {
        Some(w) => w,
        None => r.path(&["work"], &file.work)?,
    };
    let work = absolute(&work)?;
    if let Err(stage::StageError::NotAFolder { path, .. }) = stage::require_folder(&work) {
        let within = if path == work {
            String::new()
        } else {
            format!(" (in {})", work.display())
        };
        let message = format!(
            "{} is a file, not a folder{within}: choose another work folder",
            path.display()
        );
        return Err(if given {
            r.config(message)
        } else {
            r.value(&["work"], message)
        });
    }
    // Stage records, frames tables and manifests hold paths as text.
    if work.to_str().is_none() {
        return Err(r.config(format!(
            "the work folder {} is not valid UTF-8; choose another",
            work.display()
        )));
    }
    Ok(work)
}

/// With `[synth]`: the dataset, depth, model and LIMAP folder of the rendered scene in
/// `<work>/synth/` (and none of them may be given).
fn synth_inputs(
    r: &Resolver,
    s: &SynthConfig,
    work: &Path,
    file: &PipelineFile,
) -> Result<(IngestConfig, ImportConfig)> {
    let given: Vec<String> = [
        ["ingest", "dataset"],
        ["ingest", "root"],
        ["ingest", "scene"],
        ["ingest", "depth"],
        ["import", "model"],
        ["import", "limap"],
    ]
    .iter()
    .filter(|k| r.given(&k[..]))
    .map(|k| k.join("."))
    .collect();
    if !given.is_empty() {
        return Err(r.config(format!(
            "{} come(s) from the synthetic scene of [synth]; remove them",
            given.join(", ")
        )));
    }
    s.validate()
        .map_err(|e| r.section("synth", e.to_string()))?;
    let (mut ingest, mut import) = (file.ingest.clone(), file.import.clone());
    let root = work.join(StageName::Synth.dir()).join(&s.name);
    let gt = root.join(synth::gt::GT_DIR);
    ingest.dataset = Some(match s.layout {
        synth::Layout::SevenScenes => DatasetKind::SevenScenes,
        synth::Layout::Cambridge => DatasetKind::Cambridge,
    });
    // The renderer writes depth in the colour camera next to 7-Scenes frames; the
    // Cambridge layout has none.
    if s.layout == synth::Layout::SevenScenes {
        ingest.depth = DepthOption::Rendered(root.clone());
    }
    ingest.root = Some(root);
    import.model = Some(gt.join("colmap"));
    import.limap = Some(gt.join("limap"));
    Ok((ingest, import))
}

/// Without `[synth]`: the dataset folder, depth, descriptor, model and LIMAP folder as
/// the file gives them, placed.
fn dataset_inputs(r: &Resolver, file: &PipelineFile) -> Result<(IngestConfig, ImportConfig)> {
    let (mut ingest, mut import) = (file.ingest.clone(), file.import.clone());
    if ingest.dataset.is_none() {
        return Err(r.config("ingest.dataset is required without [synth]".into()));
    }
    let need = |key: [&str; 2], v: &Option<PathBuf>| -> Result<PathBuf> {
        match v.as_deref().and_then(Path::to_str) {
            Some(v) => r.path(&key, v),
            None if v.is_some() => Err(r.value(&key, "path is not valid UTF-8".into())),
            None => Err(r.config(format!("{} is required without [synth]", key.join(".")))),
        }
    };
    ingest.root = Some(need(["ingest", "root"], &ingest.root)?);
    if let DepthOption::Rendered(dir) = &ingest.depth {
        let dir = dir
            .to_str()
            .ok_or_else(|| r.value(&["ingest", "depth"], "path is not valid UTF-8".into()))?;
        ingest.depth = DepthOption::Rendered(r.path(&["ingest", "depth"], dir)?);
    }
    // A descriptor of the user's own (a .toml file) is relative to this file; a built-in
    // one is a name.
    if let Some(d) = &ingest.descriptor
        && d.ends_with(".toml")
    {
        let path = r.path(&["ingest", "descriptor"], d)?;
        ingest.descriptor =
            Some(path.to_str().map(str::to_string).ok_or_else(|| {
                r.value(&["ingest", "descriptor"], "path is not valid UTF-8".into())
            })?);
    }
    import.model = Some(need(["import", "model"], &import.model)?);
    import.limap = Some(need(["import", "limap"], &import.limap)?);
    Ok((ingest, import))
}

/// `[features]`: the front-end of `[train]` and of the import's detector check.
fn apply_features(r: &Resolver, file: &mut PipelineFile, import: &mut ImportConfig) -> Result<()> {
    let Some(f) = file.features.clone() else {
        return Ok(());
    };
    // The import's detector check compares the inputs with this front-end.
    import.front_end.kind = f.kind;
    if let Some(w) = &f.superpoint_weights {
        import.front_end.superpoint.weights = Some(r.path(&["features", "superpoint_weights"], w)?);
    }
    let Some(t) = file.train.as_mut() else {
        return Err(r.config("[features] chooses the front-end of [train]: add [train]".into()));
    };
    t.front_end.kind = f.kind;
    t.model.descriptor_dim = f.kind.dim();
    if let Some(w) = &f.superpoint_weights {
        t.front_end.superpoint.weights = Some(r.path(&["features", "superpoint_weights"], w)?);
    }
    Ok(())
}

/// Every section is checked now, not when its stage starts minutes later; `[score]`'s
/// query segments are placed.
fn check_sections(r: &Resolver, file: &mut PipelineFile) -> Result<()> {
    if file.score.is_some() && file.train.is_none() {
        return Err(r.config("[score] scores the model of [train]: add [train]".into()));
    }
    file.import
        .validate()
        .map_err(|e| r.section("import", e.to_string()))?;
    if let Some(refine) = &file.refine {
        refine
            .validate()
            .map_err(|e| r.section("refine", e.to_string()))?;
    }
    file.shard
        .validate()
        .map_err(|e| r.section("shard", e.to_string()))?;
    if let Some(t) = &file.train {
        t.validate()
            .map_err(|e| r.section("train", e.to_string()))?;
    }
    if let Some(w) = &file.warm_start {
        w.validate().map_err(|e| r.section("warm_start", e))?;
    }
    if let Some(score) = &mut file.score {
        score
            .resolve()
            .validate()
            .map_err(|e| r.section("score", e.to_string()))?;
        if let Some(q) = &score.query_segments {
            let key = ["score", "query_segments"];
            let q = q
                .to_str()
                .ok_or_else(|| r.value(&key, "path is not valid UTF-8".into()))?;
            score.query_segments = Some(r.path(&key, q)?);
        }
    }
    Ok(())
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

#[cfg(test)]
mod tests {
    use super::*;

    fn resolve(text: &str) -> Result<Pipeline> {
        let f = parse::<PipelineFile>(text, Path::new("/p/x.toml"))?;
        Pipeline::resolve(f, text, Path::new("/p/x.toml"), Path::new("/p"), None, &[])
    }

    #[test]
    fn features_section_sets_the_train_front_end_and_width() {
        let text = "work = \"w\"\n[synth]\ntiny = true\n[train]\n[features]\n\
                    kind = \"superpoint\"\nsuperpoint_weights = \"weights/sp.pth\"\n";
        let p = resolve(text).unwrap();
        let t = p.file.train.as_ref().unwrap();
        assert_eq!(t.front_end.kind, features::FrontEndKind::Superpoint);
        assert_eq!(t.model.descriptor_dim, 256);
        assert_eq!(
            t.front_end.superpoint.weights,
            Some(PathBuf::from("/p/weights/sp.pth"))
        );
        // The import's detector check compares with the same front-end.
        assert_eq!(p.import.front_end.kind, features::FrontEndKind::Superpoint);
        assert_eq!(
            p.import.front_end.superpoint.weights,
            Some(PathBuf::from("/p/weights/sp.pth"))
        );
        assert_eq!(
            p.import.detector_check,
            labels::import::DetectorCheck::Refuse
        );
        let e = resolve("work = \"w\"\n[synth]\n[features]\nkind = \"superpoint\"\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("add [train]"), "{e}");
        let e = resolve("work = \"w\"\n[synth]\n[train]\n[features]\nkind = \"surf\"\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("x.toml") && e.contains("surf"), "{e}");
    }

    #[test]
    fn synthetic_defaults() {
        let p = resolve("work = \"./x/../w\"\n[synth]\ntiny = true\n[refine]\n").unwrap();
        assert_eq!(p.work, PathBuf::from("/p/w"));
        assert_eq!(p.ingest.root, Some(PathBuf::from("/p/w/synth/synthroom")));
        assert_eq!(p.ingest.dataset, Some(DatasetKind::SevenScenes));
        assert_eq!(
            p.ingest.depth,
            DepthOption::Rendered("/p/w/synth/synthroom".into())
        );
        assert_eq!(
            p.import.model,
            Some(PathBuf::from("/p/w/synth/synthroom/sfm_gt/colmap"))
        );
        assert_eq!(p.refine(), Some(&RefineConfig::default()));
        assert_eq!(p.shard(), &ShardStageConfig::default());
        assert_eq!(p.import.settings(), ImportConfig::default());
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
        assert_eq!(p.ingest.root, Some(PathBuf::from("/data/7scenes")));
        assert_eq!(p.ingest.scene_dir(), PathBuf::from("/data/7scenes/stairs"));
        assert_eq!(
            p.ingest.depth,
            DepthOption::Rendered("/p/depth/stairs".into())
        );
        assert_eq!(p.import.model, Some(PathBuf::from("/p/hloc/stairs")));
        assert_eq!(p.import.limap, Some(PathBuf::from("/p/limap/stairs")));
        assert!(p.refine().is_none());
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
        // Nothing that comes from [synth] is written back (it would conflict).
        for key in [
            "\nroot =",
            "\ndepth =",
            "\ndataset =",
            "\nmodel =",
            "\nlimap =",
        ] {
            assert!(!again.contains(key), "{key} in {again}");
        }
    }

    #[test]
    fn invalid_values_are_refused_when_the_file_loads() {
        let e = resolve("work = \"w\"\n[synth]\ntiny = true\n[shard]\nframes_per_shard = 0\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("frames_per_shard"), "{e}");
        let e = resolve("work = \"w\"\n[synth]\nlabel_noise_cm = -1.0\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("label_noise_cm"), "{e}");
    }

    #[test]
    fn every_section_is_checked_at_load_with_the_line_of_its_key() {
        let base = "work = \"w\"\n[synth]\ntiny = true\n[train]\n";
        for (section, text, key) in [
            (
                "shard",
                "[shard]\nframes_per_shard = 0\n",
                "shard.frames_per_shard",
            ),
            (
                "refine",
                "[refine]\nmax_depth_m = -3.0\n",
                "refine.max_depth_m",
            ),
            (
                "refine",
                "[refine]\nline_max_samples = 0\n",
                "refine.line_max_samples",
            ),
            (
                "import",
                "[import]\nsegment_scale = 0.0\n",
                "import.segment_scale",
            ),
            (
                "score",
                "[score]\npoint_threshold_px = -1.0\n",
                "score.point_threshold_px",
            ),
            (
                "score",
                "[score]\nmin_point_reliability = 2.0\n",
                "score.min_point_reliability",
            ),
        ] {
            let e = resolve(&format!("{base}{text}")).unwrap_err();
            match &e {
                PipelineError::Value { line, key: k, .. } => {
                    assert_eq!((*line, k.as_str()), (6, key), "{section}: {e}");
                }
                _ => panic!("{section}: not at its key: {e}"),
            }
        }
    }

    /// A work folder that is a file (or under one) is named as such when the file
    /// loads, at the line of `work`, not reported later as "File exists (os error 17)".
    #[test]
    fn a_work_folder_that_is_a_file_is_named() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("w");
        std::fs::write(&file, b"x").unwrap();
        let text = format!("work = \"{}\"\n[synth]\ntiny = true\n", file.display());
        let e = resolve(&text).unwrap_err().to_string();
        assert_eq!(
            e,
            format!(
                "/p/x.toml:1:8: work: {} is a file, not a folder: choose another work folder",
                file.display()
            )
        );
        let below = file.join("sub");
        let e = resolve(&format!(
            "work = \"{}\"\n[synth]\ntiny = true\n",
            below.display()
        ))
        .unwrap_err()
        .to_string();
        assert!(
            e.contains(&format!(
                "{} is a file, not a folder (in {}): choose another work folder",
                file.display(),
                below.display()
            )),
            "{e}"
        );
        // `--work` names the file too.
        let f = parse::<PipelineFile>(&text, Path::new("/p/x.toml")).unwrap();
        let e = Pipeline::resolve(
            f,
            &text,
            Path::new("/p/x.toml"),
            Path::new("/p"),
            Some(file.clone()),
            &[],
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("is a file, not a folder"), "{e}");
        assert_eq!(std::fs::read(&file).unwrap(), b"x");
    }

    /// `work = "${VAR}/w"` with VAR set to "" is refused, not written to `/w`.
    #[test]
    fn an_empty_variable_in_the_work_folder_is_refused() {
        // SAFETY: this test is the only one reading this variable.
        unsafe { std::env::set_var("PL2MAP_TEST_CONFIG_EMPTY", "") };
        let e = resolve("work = \"${PL2MAP_TEST_CONFIG_EMPTY}/w\"\n[synth]\ntiny = true\n")
            .unwrap_err()
            .to_string();
        assert_eq!(
            e,
            "/p/x.toml:1:8: work: environment variable PL2MAP_TEST_CONFIG_EMPTY is set but \
             empty (used in \"${PL2MAP_TEST_CONFIG_EMPTY}/w\")"
        );
    }

    #[test]
    fn a_work_folder_that_is_not_utf8_is_named() {
        use std::os::unix::ffi::OsStrExt as _;
        let text = "work = \"w\"\n[synth]\ntiny = true\n";
        let f = parse::<PipelineFile>(text, Path::new("/p/x.toml")).unwrap();
        let work = PathBuf::from(std::ffi::OsStr::from_bytes(b"/tmp/w\xff"));
        let e = Pipeline::resolve(
            f,
            text,
            Path::new("/p/x.toml"),
            Path::new("/p"),
            Some(work),
            &[],
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("/tmp/w") && e.contains("not valid UTF-8"), "{e}");
    }

    fn warm(text: &str) -> (train::TrainConfig, train::TrainConfig) {
        let p = resolve(text).unwrap();
        let t = p.file.train.clone().unwrap();
        let w = p
            .file
            .warm_start
            .clone()
            .unwrap_or_default()
            .train_config(&t);
        (t, w)
    }

    #[test]
    fn a_warm_start_runs_the_whole_schedule_unless_told_otherwise() {
        let (t, w) = warm(
            "work = \"w\"\n[synth]\ntiny = true\n[train]\niterations = 1200\n\
             learning_rate = 1e-3\nlr_schedule = \"cosine\"\nlr_halvings = 5\n",
        );
        assert_eq!(w, t);
        let (t, w) = warm(
            "work = \"w\"\n[synth]\ntiny = true\n[train]\niterations = 1200\n\
             [warm_start]\niterations = 600\nlearning_rate = 2e-4\n",
        );
        assert_eq!((w.iterations, w.learning_rate), (600, 2e-4));
        assert_eq!(w.lr_halvings, t.lr_halvings);
    }

    #[test]
    fn bad_warm_start_keys_are_refused_by_name() {
        let e =
            resolve("work = \"w\"\n[synth]\ntiny = true\n[train]\n[warm_start]\niterations = 0\n")
                .unwrap_err()
                .to_string();
        assert!(
            e.contains("/p/x.toml") && e.contains("iterations must be at least 1"),
            "{e}"
        );
        let e = resolve(
            "work = \"w\"\n[synth]\ntiny = true\n[train]\n[warm_start]\nschedule = \"tail\"\n",
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("schedule"), "{e}");
    }
}
