//! Hashing every input once and reading each frame (pose, image size, depth) into the
//! table, in parallel and in frame order.

use super::config::{DepthOption, PoseOption};
use super::error::{DamagedImagesError, IngestError, Result};
use super::plan::{Plan, PlannedFrame, PoseSource};
use super::{depth, sevenscenes, whole};
use crate::camera_spec;
use crate::dataset_kind::DatasetKind;
use geometry::{Camera, CameraModel};
use rayon::prelude::*;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use tables::frames::{Frame, FramesTable, IngestMeta};

pub(super) struct InputHashes {
    /// Category -> hash over (name, content hash) of its files, sorted by name.
    pub(super) inputs: BTreeMap<String, String>,
    /// Content hash of each planned frame's image, in plan order.
    pub(super) images: Vec<String>,
    /// Content hash of each planned frame's depth input (raw or rendered), in plan
    /// order: a rendered map is the table's depth map, so this is its depth hash.
    pub(super) depths: Vec<Option<String>>,
}

/// Hashes every file the plan reads (in parallel), once.
pub(super) fn hash_inputs(plan: &Plan) -> Result<InputHashes> {
    let files: Vec<(usize, &'static str, &str, &Path)> = plan
        .scene_inputs
        .iter()
        .map(|(c, n, p)| (usize::MAX, *c, n.as_str(), p.as_path()))
        .chain(plan.frames.iter().enumerate().flat_map(|(i, f)| {
            f.inputs
                .iter()
                .map(move |(c, n, p)| (i, *c, n.as_str(), p.as_path()))
        }))
        .collect();
    let bar = stage::progress_bar(files.len() as u64, "hashing");
    let hashes: Vec<String> = files
        .par_iter()
        .map(|(_, _, _, p)| {
            let h = stage::sha256_file(p);
            bar.inc(1);
            h
        })
        .collect::<std::result::Result<_, _>>()?;
    bar.finish_and_clear();
    let mut images = vec![String::new(); plan.frames.len()];
    let mut depths = vec![None; plan.frames.len()];
    let mut by_category: BTreeMap<&str, Vec<(&str, &str)>> = BTreeMap::new();
    for ((frame, category, name, _), hash) in files.iter().zip(&hashes) {
        if *category == "images" && *frame != usize::MAX {
            images[*frame] = hash.clone();
        }
        if *category == "depth" && *frame != usize::MAX {
            depths[*frame] = Some(hash.clone());
        }
        by_category
            .entry(category)
            .or_default()
            .push((name, hash.as_str()));
    }
    let inputs = by_category
        .into_iter()
        .map(|(category, mut entries)| {
            entries.sort_unstable();
            let mut text = String::new();
            for (name, hash) in entries {
                text.push_str(name);
                text.push('\0');
                text.push_str(hash);
                text.push('\n');
            }
            (category.to_string(), stage::sha256_bytes(text.as_bytes()))
        })
        .collect();
    Ok(InputHashes {
        inputs,
        images,
        depths,
    })
}

/// Reads every frame's pose, image size and depth (in parallel, ordered) into the table.
pub(super) fn build(
    plan: &Plan,
    hashes: &InputHashes,
    depth_out: Option<&Path>,
) -> Result<FramesTable> {
    if plan.depth == DepthOption::Raw && depth_out.is_none() {
        return Err(IngestError::Config(
            "depth = raw needs an output folder for the registered depth maps".into(),
        ));
    }
    let bar = stage::progress_bar(plan.frames.len() as u64, "ingest");
    let results: Vec<Result<Frame>> = plan
        .frames
        .par_iter()
        .zip(hashes.images.par_iter())
        .zip(hashes.depths.par_iter())
        .enumerate()
        .map(|(id, ((pf, hash), depth_hash))| {
            let r = build_frame(plan, pf, id as u32, hash, depth_hash.as_deref(), depth_out);
            bar.inc(1);
            r
        })
        .collect();
    bar.finish_and_clear();
    // Damaged images are reported together (a damaged download rarely has just one);
    // otherwise the first error in frame order: the same one for any thread count.
    let damaged: Vec<(PathBuf, String)> = results
        .iter()
        .filter_map(|r| match r {
            Err(IngestError::DamagedImage { path, reason }) => Some((path.clone(), reason.clone())),
            _ => None,
        })
        .collect();
    if !damaged.is_empty() {
        return Err(IngestError::DamagedImages(Box::new(DamagedImagesError {
            scene_dir: plan.scene_dir.clone(),
            total: plan.frames.len(),
            damaged,
        })));
    }
    let frames = results.into_iter().collect::<Result<Vec<Frame>>>()?;
    Ok(FramesTable {
        frames,
        meta: meta(plan, depth_out),
    })
}

fn build_frame(
    plan: &Plan,
    pf: &PlannedFrame,
    id: u32,
    hash: &str,
    depth_input_hash: Option<&str>,
    depth_out: Option<&Path>,
) -> Result<Frame> {
    let (w, h) = {
        let image = whole::decode_whole(&pf.image)?;
        (image.width(), image.height())
    };
    let camera = match (&plan.camera, plan.kind) {
        (Some(c), _) => check_camera_size(c, &pf.image, w, h, "the given camera")?,
        (None, DatasetKind::SevenScenes) => {
            let Some(dc) = &plan.default_camera else {
                return Err(IngestError::Config(
                    "the 7-Scenes layout needs the descriptor's colour camera".into(),
                ));
            };
            let what = match &dc.label {
                Some(label) => format!("the {label} camera"),
                None => format!("the {} descriptor's camera", plan.descriptor.name),
            };
            check_camera_size(&dc.model, &pf.image, w, h, &what)?
        }
        (None, DatasetKind::Cambridge) => {
            let f = pf.focal.unwrap_or(f64::NAN);
            Camera::new(
                CameraModel::SimplePinhole,
                w as u64,
                h as u64,
                vec![f, w as f64 / 2.0, h as f64 / 2.0],
            )
            .map_err(|e| IngestError::Camera {
                path: pf.image.clone(),
                message: e.to_string(),
            })?
        }
    };
    // Both are in the plan whenever the options need them (checked while planning).
    let sensor_missing =
        || IngestError::Config("the descriptor's depth camera and extrinsic are missing".into());
    let pose = match &pf.pose {
        PoseSource::File(p) => {
            let depth_from_world = sevenscenes::read_pose_file(p)?;
            match plan.poses {
                PoseOption::Published => depth_from_world,
                PoseOption::Calibrated => {
                    let ext = plan.rgb_from_depth.as_ref().ok_or_else(sensor_missing)?;
                    ext.pose.compose(&depth_from_world)
                }
            }
        }
        PoseSource::Given(p) => *p,
    };
    // Each depth map with its content hash, which the refine stage checks it against
    // (crates/labels/src/refine/inputs.rs): the registered map as written, a rendered
    // map as hashed with the inputs.
    let depth = match (&plan.depth, &pf.depth_in, depth_out) {
        (DepthOption::Raw, Some(input), Some(out)) => {
            let raw = depth::read_depth_png(input)?;
            let (Some(dcam), Some(ext)) = (&plan.depth_camera, &plan.rgb_from_depth) else {
                return Err(sensor_missing());
            };
            if (raw.width() as u64, raw.height() as u64) != (dcam.width, dcam.height) {
                return Err(IngestError::ImageContent {
                    path: input.clone(),
                    message: format!(
                        "raw depth map is {}x{}, the depth camera ({}) is {}x{}",
                        raw.width(),
                        raw.height(),
                        camera_spec::format_camera(dcam),
                        dcam.width,
                        dcam.height
                    ),
                });
            }
            let reg = depth::register_depth(&raw, dcam, &ext.pose, &camera);
            let dest = out.join(format!("{}.depth.png", pf.stem));
            let sha256 = depth::write_depth_png(&dest, &reg)?;
            Some((dest, sha256))
        }
        (DepthOption::Rendered(_), Some(input), _) => {
            depth::check_depth_size(input, &pf.name, w, h)?;
            let sha256 = depth_input_hash.ok_or_else(|| {
                IngestError::Config(format!(
                    "the depth map {} of {} was not hashed with the inputs",
                    input.display(),
                    pf.name
                ))
            })?;
            Some((input.clone(), sha256.to_string()))
        }
        _ => None,
    };
    let (depth_path, depth_hash) = depth.unzip();
    Ok(Frame {
        id,
        name: pf.name.clone(),
        path: pf.image.clone(),
        split: pf.split,
        camera,
        pose,
        depth_path,
        depth_hash,
        width: w,
        height: h,
        content_hash: hash.to_string(),
    })
}

fn check_camera_size(c: &Camera, image: &Path, w: u32, h: u32, what: &str) -> Result<Camera> {
    if (c.width, c.height) != (w as u64, h as u64) {
        return Err(IngestError::Camera {
            path: image.to_path_buf(),
            message: format!(
                "image is {w}x{h}, {what} ({}) is {}x{}; give a camera for this size",
                camera_spec::format_camera(c),
                c.width,
                c.height
            ),
        });
    }
    Ok(c.clone())
}

/// The table's description of its sources. The wording of every note is fixed (the
/// bytes of frames.parquet depend on it); only the descriptor's values and labels fill
/// it in.
fn meta(plan: &Plan, depth_out: Option<&Path>) -> IngestMeta {
    let extrinsic = plan
        .rgb_from_depth
        .as_ref()
        .map_or("(none)", |e| e.label.as_str());
    let pose_source = match (plan.kind, plan.poses) {
        (DatasetKind::SevenScenes, PoseOption::Published) => {
            "published: pose.txt (camera-to-world of the Kinect depth camera) inverted, \
             used as the colour camera's pose"
                .to_string()
        }
        (DatasetKind::SevenScenes, PoseOption::Calibrated) => format!(
            "calibrated: pose.txt moved to the colour camera with the {extrinsic} Kinect \
             depth-to-RGB extrinsic (rgb_from_world = rgb_from_depth * depth_from_world, \
             as ACE/DSAC* and kapture's kinect rig)"
        ),
        (DatasetKind::Cambridge, _) => {
            let (train, test) = plan
                .descriptor
                .layouts
                .cambridge
                .as_ref()
                .map_or(("", ""), |l| {
                    (l.train_split.as_str(), l.test_split.as_str())
                });
            format!(
                "published: {train} / {test} (camera centre and w-first world-to-camera \
                 quaternion)"
            )
        }
    };
    let depth_source = match &plan.depth {
        DepthOption::None => "none".to_string(),
        DepthOption::Raw => format!(
            "raw: frame-XXXXXX.depth.png registered into the colour camera (depth camera \
             {}, {extrinsic} depth-to-RGB extrinsic, nearest point wins), written under {}",
            plan.depth_camera
                .as_ref()
                .map_or_else(String::new, camera_spec::format_model_and_params),
            depth_out.map_or_else(String::new, |d| d.display().to_string())
        ),
        DepthOption::Rendered(d) => format!("rendered: {}", d.display()),
    };
    let intrinsics = match (&plan.camera, plan.kind) {
        (Some(c), _) => format!("given: {}", camera_spec::format_camera(c)),
        (None, DatasetKind::SevenScenes) => match &plan.default_camera {
            Some(dc) => format!(
                "{}: {} ({})",
                dc.label
                    .clone()
                    .unwrap_or_else(|| format!("{} default", plan.descriptor.title)),
                camera_spec::format_camera(&dc.model),
                dc.source
            ),
            None => String::new(),
        },
        (None, DatasetKind::Cambridge) => "SIMPLE_PINHOLE: focal length of the image's \
             reconstruction.nvm camera, principal point at the image centre, size from the \
             image file"
            .to_string(),
    };
    IngestMeta {
        dataset: plan.kind.name().to_string(),
        scene: plan.scene.clone(),
        root: plan.scene_dir.display().to_string(),
        pose_source,
        depth_units_per_metre: (plan.depth != DepthOption::None).then_some(1000.0),
        depth_source,
        intrinsics,
        excluded: plan.excluded.clone(),
    }
}
