//! Planning: lists every frame of a dataset and every file the stage will read, and
//! reads the small text files (split files, NVM). Per-frame files are read by
//! [`super::build`].

use super::config::{DatasetKind, DepthOption, IngestConfig, PoseOption};
use super::error::{IngestError, Result, io_err};
use super::{cambridge, depth, nvm, sevenscenes};
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
    std::fs::canonicalize(path).map_err(io_err(path))
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
    let mut plan = Plan {
        kind: config.dataset()?,
        scene,
        scene_dir,
        depth: normalised_config.depth.clone(),
        poses: config.poses,
        camera,
        frames: Vec::new(),
        excluded: Vec::new(),
        scene_inputs: Vec::new(),
        normalised_config,
    };
    match plan.kind {
        DatasetKind::SevenScenes => plan_seven_scenes(&mut plan, rendered.as_deref())?,
        DatasetKind::Cambridge => plan_cambridge(&mut plan, rendered.as_deref())?,
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

fn plan_seven_scenes(plan: &mut Plan, rendered: Option<&Path>) -> Result<()> {
    let mut seen: BTreeMap<String, (PathBuf, usize)> = BTreeMap::new();
    for (split, file) in [
        (Split::Train, sevenscenes::TRAIN_SPLIT_FILE),
        (Split::Test, sevenscenes::TEST_SPLIT_FILE),
    ] {
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
    Ok(())
}

fn plan_cambridge(plan: &mut Plan, rendered: Option<&Path>) -> Result<()> {
    let nvm = match plan.camera {
        Some(_) => None,
        None => {
            let p = plan.scene_dir.join(cambridge::NVM_FILE);
            let cams = nvm::NvmCameras::read(&p)?;
            plan.scene_inputs
                .push(("nvm", cambridge::NVM_FILE.to_string(), p.clone()));
            Some((p, cams))
        }
    };
    let mut seen: BTreeMap<String, (PathBuf, usize)> = BTreeMap::new();
    for (split, file) in [
        (Split::Train, cambridge::TRAIN_FILE),
        (Split::Test, cambridge::TEST_FILE),
    ] {
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
            if let Some(reason) = cambridge::outlier_reason(&row.pose) {
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
    Ok(())
}
