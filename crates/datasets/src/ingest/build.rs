//! Hashing every input once and reading each frame (pose, image size, depth) into the
//! table, in parallel and in frame order.

use super::config::{DatasetKind, DepthOption, PoseOption};
use super::error::{IngestError, Result};
use super::plan::{Plan, PlannedFrame, PoseSource};
use super::{camera_spec, depth, sevenscenes};
use geometry::{Camera, CameraModel};
use rayon::prelude::*;
use std::collections::BTreeMap;
use std::path::Path;
use tables::frames::{Frame, FramesTable, IngestMeta};

pub(super) struct InputHashes {
    /// Category -> hash over (name, content hash) of its files, sorted by name.
    pub(super) inputs: BTreeMap<String, String>,
    /// Content hash of each planned frame's image, in plan order.
    pub(super) images: Vec<String>,
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
    let mut by_category: BTreeMap<&str, Vec<(&str, &str)>> = BTreeMap::new();
    for ((frame, category, name, _), hash) in files.iter().zip(&hashes) {
        if *category == "images" && *frame != usize::MAX {
            images[*frame] = hash.clone();
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
    Ok(InputHashes { inputs, images })
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
        .enumerate()
        .map(|(id, (pf, hash))| {
            let r = build_frame(plan, pf, id as u32, hash, depth_out);
            bar.inc(1);
            r
        })
        .collect();
    bar.finish_and_clear();
    // The first error in frame order: the same one for any thread count.
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
    depth_out: Option<&Path>,
) -> Result<Frame> {
    let (w, h) = image::image_dimensions(&pf.image).map_err(|source| IngestError::Image {
        path: pf.image.clone(),
        source,
    })?;
    let camera = match (&plan.camera, plan.kind) {
        (Some(c), _) => check_camera_size(c, &pf.image, w, h, "the given camera")?,
        (None, DatasetKind::SevenScenes) => check_camera_size(
            &sevenscenes::default_rgb_camera(),
            &pf.image,
            w,
            h,
            "the 7-Scenes default camera",
        )?,
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
    let pose = match &pf.pose {
        PoseSource::File(p) => {
            let depth_from_world = sevenscenes::read_pose_file(p)?;
            match plan.poses {
                PoseOption::Published => depth_from_world,
                PoseOption::Calibrated => sevenscenes::rgb_from_depth().compose(&depth_from_world),
            }
        }
        PoseSource::Given(p) => *p,
    };
    let depth_path = match (&plan.depth, &pf.depth_in, depth_out) {
        (DepthOption::Raw, Some(input), Some(out)) => {
            let raw = depth::read_depth_png(input)?;
            let dcam = sevenscenes::depth_camera();
            if (raw.width() as u64, raw.height() as u64) != (dcam.width, dcam.height) {
                return Err(IngestError::ImageContent {
                    path: input.clone(),
                    message: format!(
                        "raw depth map is {}x{}, the Kinect depth camera (f=585, centre \
                         (320, 240)) is {}x{}",
                        raw.width(),
                        raw.height(),
                        dcam.width,
                        dcam.height
                    ),
                });
            }
            let reg = depth::register_depth(&raw, &dcam, &sevenscenes::rgb_from_depth(), &camera);
            let dest = out.join(format!("{}.depth.png", pf.stem));
            depth::write_depth_png(&dest, &reg)?;
            Some(dest)
        }
        (DepthOption::Rendered(_), Some(input), _) => {
            depth::check_depth_size(input, &pf.name, w, h)?;
            Some(input.clone())
        }
        _ => None,
    };
    Ok(Frame {
        id,
        name: pf.name.clone(),
        path: pf.image.clone(),
        split: pf.split,
        camera,
        pose,
        depth_path,
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

fn meta(plan: &Plan, depth_out: Option<&Path>) -> IngestMeta {
    let pose_source = match (plan.kind, plan.poses) {
        (DatasetKind::SevenScenes, PoseOption::Published) => {
            "published: pose.txt (camera-to-world of the Kinect depth camera) inverted, \
             used as the colour camera's pose"
        }
        (DatasetKind::SevenScenes, PoseOption::Calibrated) => {
            "calibrated: pose.txt moved to the colour camera with the LIRIS Kinect \
             depth-to-RGB extrinsic (rgb_from_world = rgb_from_depth * depth_from_world, \
             as ACE/DSAC* and kapture's kinect rig)"
        }
        (DatasetKind::Cambridge, _) => {
            "published: dataset_train.txt / dataset_test.txt (camera centre and w-first \
             world-to-camera quaternion)"
        }
    }
    .to_string();
    let depth_source = match &plan.depth {
        DepthOption::None => "none".to_string(),
        DepthOption::Raw => format!(
            "raw: frame-XXXXXX.depth.png registered into the colour camera (depth camera \
             SIMPLE_PINHOLE 585 320 240, LIRIS depth-to-RGB extrinsic, nearest point wins), \
             written under {}",
            depth_out.map_or_else(String::new, |d| d.display().to_string())
        ),
        DepthOption::Rendered(d) => format!("rendered: {}", d.display()),
    };
    let intrinsics = match (&plan.camera, plan.kind) {
        (Some(c), _) => format!("given: {}", camera_spec::format_camera(c)),
        (None, DatasetKind::SevenScenes) => format!(
            "7-Scenes default: {} (DSAC*/ACE, kapture)",
            camera_spec::format_camera(&sevenscenes::default_rgb_camera())
        ),
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
