//! Planning: lists every frame of a dataset and every file the stage will read, and
//! reads the small text files (split files, NVM). Per-frame files are read by
//! [`super::build`].

use super::config::{DepthOption, IngestConfig, PoseOption};
use super::error::{FrameCountError, IngestError, Result};
use super::{cambridge, depth, nvm, sevenscenes};
use crate::dataset_kind::DatasetKind;
use crate::descriptor::{self, CountCheck, Descriptor, Extrinsic, NamedCamera, SplitCounts};
use fileio::io_err;
use geometry::{Camera, Pose};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use tables::frames::{ExcludedFrame, Split};

/// Where a frame's pose comes from.
#[derive(Clone, Debug)]
pub(super) enum PoseSource {
    /// 7-Scenes pose.txt.
    File(PathBuf),
    /// Read with the split file (Cambridge).
    Given(Pose),
}

#[derive(Clone, Debug)]
pub(super) struct PlannedFrame {
    pub(super) name: String,
    /// The name without its colour suffix: names the depth maps.
    pub(super) stem: String,
    pub(super) split: Split,
    pub(super) image: PathBuf,
    pub(super) pose: PoseSource,
    /// Cambridge: the NVM focal length (None with a camera override).
    pub(super) focal: Option<f64>,
    /// Raw depth.png or the rendered depth map.
    pub(super) depth_in: Option<PathBuf>,
    /// (input category, name in that category, path) of every file this frame reads.
    pub(super) inputs: Vec<(&'static str, String, PathBuf)>,
}

pub(super) struct Plan {
    pub(super) kind: DatasetKind,
    pub(super) scene: String,
    pub(super) scene_dir: PathBuf,
    pub(super) depth: DepthOption,
    pub(super) poses: PoseOption,
    pub(super) camera: Option<Camera>,
    /// The dataset descriptor in use.
    pub(super) descriptor: Descriptor,
    /// 7-Scenes layout: the descriptor's colour camera (used without `camera`).
    pub(super) default_camera: Option<NamedCamera>,
    /// 7-Scenes layout: the descriptor's depth camera (`depth = raw`).
    pub(super) depth_camera: Option<Camera>,
    /// 7-Scenes layout: the descriptor's depth-to-RGB extrinsic (`depth = raw`,
    /// `poses = calibrated`).
    pub(super) rgb_from_depth: Option<Extrinsic>,
    pub(super) frames: Vec<PlannedFrame>,
    pub(super) excluded: Vec<ExcludedFrame>,
    /// Files read once for the whole scene: (category, name, path).
    pub(super) scene_inputs: Vec<(&'static str, String, PathBuf)>,
    /// The configuration with absolute paths: what the stage record hashes.
    pub(super) normalised_config: IngestConfig,
}

fn canonical_dir(path: &Path, what: &str) -> Result<PathBuf> {
    if !path.is_dir() {
        return Err(IngestError::Missing {
            path: path.to_path_buf(),
            what: what.to_string(),
        });
    }
    let dir = std::fs::canonicalize(path).map_err(io_err(path))?;
    // The frames table and the stage record hold paths as text.
    if dir.to_str().is_none() {
        return Err(stage::StageError::Path { path: dir }.into());
    }
    Ok(dir)
}

fn rel_name(base: &Path, path: &Path) -> String {
    path.strip_prefix(base)
        .unwrap_or(path)
        .to_string_lossy()
        .replace('\\', "/")
}

/// Lists every frame and every file to read, and reads the small text files (split
/// files, NVM); per-frame files are read by [`super::build`].
pub(super) fn plan(config: &IngestConfig) -> Result<Plan> {
    let camera = config.validate()?;
    let kind = config.dataset()?;
    let descriptor = Descriptor::resolve(config.descriptor.as_deref(), kind)?;
    descriptor.require_layout(kind)?;
    let scene_dir = canonical_dir(&config.scene_dir(), "scene folder")?;
    let scene = match &config.scene {
        Some(s) => s.clone(),
        None => scene_dir
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default(),
    };
    let rendered = match &config.depth {
        DepthOption::Rendered(d) => Some(canonical_dir(d, "rendered depth folder")?),
        _ => None,
    };
    let mut normalised_config = config.clone();
    normalised_config.root = Some(scene_dir.clone());
    normalised_config.scene = None;
    if let Some(d) = &rendered {
        normalised_config.depth = DepthOption::Rendered(d.clone());
    }
    // The count check changes no output (and runs on every plan, skipped or not); the
    // layout's own descriptor is the default. Left at their defaults, both keys are not
    // serialised: the record of a configuration without them is unchanged.
    normalised_config.count_check = true;
    let mut scene_inputs = Vec::new();
    normalised_config.descriptor = match config.descriptor.as_deref() {
        Some(c) if descriptor::is_path(c) => {
            let p = std::fs::canonicalize(c).map_err(io_err(c))?;
            let name = p
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default();
            scene_inputs.push(("descriptor", name, p.clone()));
            Some(p.display().to_string())
        }
        Some(c) if c == kind.name() => None,
        other => other.map(str::to_string),
    };
    let (default_camera, depth_camera, rgb_from_depth) = match kind {
        DatasetKind::SevenScenes => {
            let l = descriptor.seven_scenes()?;
            (
                Some(l.colour_camera.clone()),
                l.depth_camera.as_ref().map(|c| c.model.clone()),
                l.rgb_from_depth.clone(),
            )
        }
        DatasetKind::Cambridge => (None, None, None),
    };
    if config.depth == DepthOption::Raw && depth_camera.is_none() {
        return Err(descriptor
            .missing("depth = raw needs [layouts.7scenes.depth_camera]")
            .into());
    }
    let needs_extrinsic =
        config.depth == DepthOption::Raw || config.poses == PoseOption::Calibrated;
    if needs_extrinsic && rgb_from_depth.is_none() {
        return Err(descriptor
            .missing("depth = raw and poses = calibrated need [layouts.7scenes.rgb_from_depth]")
            .into());
    }
    let mut plan = Plan {
        kind: config.dataset()?,
        scene,
        scene_dir,
        depth: normalised_config.depth.clone(),
        poses: config.poses,
        camera,
        descriptor,
        default_camera,
        depth_camera,
        rgb_from_depth,
        frames: Vec::new(),
        excluded: Vec::new(),
        scene_inputs,
        normalised_config,
    };
    let counted = match plan.kind {
        DatasetKind::SevenScenes => plan_seven_scenes(&mut plan, rendered.as_deref())?,
        DatasetKind::Cambridge => plan_cambridge(&mut plan, rendered.as_deref())?,
    };
    if config.count_check {
        check_counts(&plan, &counted)?;
    } else {
        tracing::info!(
            "ingest: frame counts of {} not checked (count_check = false)",
            plan.scene
        );
    }
    plan.frames
        .sort_by(|a, b| (a.split, &a.name).cmp(&(b.split, &b.name)));
    if plan.frames.is_empty() {
        return Err(IngestError::Missing {
            path: plan.scene_dir.clone(),
            what: "frames: every listed frame was excluded".into(),
        });
    }
    if plan.frames.len() > u32::MAX as usize {
        return Err(IngestError::Config("more than 2^32 frames".into()));
    }
    Ok(plan)
}

/// Compares the frames listed per split (excluded ones included) with the descriptor's
/// counts of the scene. `counted` says what was counted, for the error.
fn check_counts(plan: &Plan, counted: &str) -> Result<()> {
    let listed = |split: Split| {
        plan.frames.iter().filter(|f| f.split == split).count()
            + plan.excluded.iter().filter(|f| f.split == split).count()
    };
    let found = SplitCounts {
        train: listed(Split::Train),
        test: listed(Split::Test),
    };
    let d = &plan.descriptor;
    match d.check_counts(&plan.scene, found) {
        CountCheck::Agrees(c) => tracing::info!(
            "ingest: {} has the {} train and {} test frames of the {} descriptor",
            plan.scene,
            c.train,
            c.test,
            d.name
        ),
        CountCheck::NotFixed => tracing::info!(
            "ingest: the {} descriptor fixes no frame counts for {}: not checked",
            d.name,
            plan.scene
        ),
        CountCheck::NotListed => tracing::info!(
            "ingest: scene {} is not in the {} descriptor ({}; scenes {}): frame counts not \
             checked",
            plan.scene,
            d.name,
            d.origin(),
            d.scenes.keys().cloned().collect::<Vec<_>>().join(", ")
        ),
        CountCheck::Differs {
            expected,
            mismatches,
        } => {
            return Err(IngestError::FrameCounts(Box::new(FrameCountError {
                scene_dir: plan.scene_dir.clone(),
                scene: plan.scene.clone(),
                descriptor: d.name.clone(),
                origin: d.origin().to_string(),
                expected,
                mismatches,
                counted: counted.to_string(),
            })));
        }
    }
    Ok(())
}

fn add_rendered(plan: &Plan, frame: &mut PlannedFrame, rendered: Option<&Path>) -> Result<()> {
    if let Some(dir) = rendered {
        let p = depth::find_rendered(dir, plan.kind, &frame.stem)?;
        frame.inputs.push((
            "depth",
            format!("rendered/{}", rel_name(dir, &p)),
            p.clone(),
        ));
        frame.depth_in = Some(p);
    }
    Ok(())
}

/// Lists the frames of a 7-Scenes scene; returns what the count check counts.
fn plan_seven_scenes(plan: &mut Plan, rendered: Option<&Path>) -> Result<String> {
    let layout = plan.descriptor.seven_scenes()?;
    let (train_file, test_file) = (layout.train_split.clone(), layout.test_split.clone());
    let mut seen: BTreeMap<String, (PathBuf, usize)> = BTreeMap::new();
    for (split, file) in [(Split::Train, &train_file), (Split::Test, &test_file)] {
        let split_path = plan.scene_dir.join(file);
        let seqs = sevenscenes::parse_split_file(&split_path)?;
        plan.scene_inputs
            .push(("splits", file.to_string(), split_path.clone()));
        for (line, seq) in seqs {
            if let Some((first_file, first_line)) = seen.get(&seq) {
                return Err(IngestError::Duplicate {
                    path: split_path,
                    line,
                    name: seq,
                    first: format!("also at {}:{first_line}", first_file.display()),
                });
            }
            seen.insert(seq.clone(), (split_path.clone(), line));
            let files = sevenscenes::list_sequence(&plan.scene_dir, &seq, (&split_path, line))?;
            for f in files {
                let mut inputs = vec![
                    ("images", f.name.clone(), f.colour.clone()),
                    ("poses", format!("{}.pose.txt", f.stem), f.pose.clone()),
                ];
                let depth_in = if plan.depth == DepthOption::Raw {
                    let d = f.depth.clone().ok_or_else(|| IngestError::Missing {
                        path: plan.scene_dir.join(format!("{}.depth.png", f.stem)),
                        what: "depth map of a frame (depth = raw)".into(),
                    })?;
                    inputs.push(("depth", format!("{}.depth.png", f.stem), d.clone()));
                    Some(d)
                } else {
                    None
                };
                let mut frame = PlannedFrame {
                    name: f.name,
                    stem: f.stem,
                    split,
                    image: f.colour,
                    pose: PoseSource::File(f.pose),
                    focal: None,
                    depth_in,
                    inputs,
                };
                add_rendered(plan, &mut frame, rendered)?;
                plan.frames.push(frame);
            }
        }
    }
    Ok(format!(
        "frames of the sequences {train_file} / {test_file} list"
    ))
}

/// Lists the frames of a Cambridge scene; returns what the count check counts.
fn plan_cambridge(plan: &mut Plan, rendered: Option<&Path>) -> Result<String> {
    let layout = plan.descriptor.cambridge()?;
    let (train_file, test_file, nvm_file) = (
        layout.train_split.clone(),
        layout.test_split.clone(),
        layout.nvm.clone(),
    );
    let max_abs_translation = layout.outlier_max_abs_translation;
    let nvm = match plan.camera {
        Some(_) => None,
        None => {
            let p = plan.scene_dir.join(&nvm_file);
            let cams = nvm::NvmCameras::read(&p)?;
            plan.scene_inputs.push(("nvm", nvm_file.clone(), p.clone()));
            Some((p, cams))
        }
    };
    let mut seen: BTreeMap<String, (PathBuf, usize)> = BTreeMap::new();
    for (split, file) in [(Split::Train, &train_file), (Split::Test, &test_file)] {
        let split_path = plan.scene_dir.join(file);
        let rows = cambridge::read_split_file(&split_path)?;
        plan.scene_inputs
            .push(("splits", file.to_string(), split_path.clone()));
        for row in rows {
            if let Some((first_file, first_line)) = seen.get(&row.name) {
                return Err(IngestError::Duplicate {
                    path: split_path,
                    line: row.line,
                    name: row.name,
                    first: format!("first at {}:{first_line}", first_file.display()),
                });
            }
            seen.insert(row.name.clone(), (split_path.clone(), row.line));
            if let Some(reason) =
                max_abs_translation.and_then(|max| cambridge::outlier_reason(&row.pose, max))
            {
                tracing::warn!(
                    "{}:{}: {} excluded: {reason}",
                    split_path.display(),
                    row.line,
                    row.name
                );
                plan.excluded.push(ExcludedFrame {
                    name: row.name,
                    split,
                    reason,
                });
                continue;
            }
            let image = plan.scene_dir.join(&row.name);
            if !image.is_file() {
                return Err(IngestError::Missing {
                    path: image,
                    what: format!("image listed at {}:{}", split_path.display(), row.line),
                });
            }
            let stem = nvm::name_stem(&row.name).to_string();
            let focal = match &nvm {
                Some((nvm_path, cams)) => Some(
                    cams.by_stem(&stem)
                        .ok_or_else(|| IngestError::NvmMissingCamera {
                            nvm: nvm_path.clone(),
                            name: row.name.clone(),
                            nvm_stem: stem.clone(),
                        })?
                        .focal,
                ),
                None => None,
            };
            let mut frame = PlannedFrame {
                inputs: vec![("images", row.name.clone(), image.clone())],
                name: row.name,
                stem,
                split,
                image,
                pose: PoseSource::Given(row.pose),
                focal,
                depth_in: None,
            };
            add_rendered(plan, &mut frame, rendered)?;
            plan.frames.push(frame);
        }
    }
    Ok(format!(
        "rows of {train_file} / {test_file}, outlier poses included"
    ))
}
