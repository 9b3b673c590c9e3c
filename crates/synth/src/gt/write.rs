//! Writes `<scene>/sfm_gt/`: the COLMAP model (binary, as hloc writes it), the LIMAP
//! folder and `exact.json`.

use super::config::GtConfig;
use super::error::GtError;
use super::ground_truth::GroundTruth;
use super::noise::{LabelNoise, noise_seed, sigma_per_coordinate_m};
use super::points::reprojection_error;
use crate::dataset::SynthDataset;
use colmap::{CameraRecord, INVALID_POINT3D_ID, Point2D, Point3D, Reconstruction, TrackElement};
use fileio::IoResultExt;
use geometry::Vector3;
use limap::{ImageList, LineTrack, Segments};
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::Path;

/// Folder of the ground truth inside the scene folder.
pub const GT_DIR: &str = "sfm_gt";
/// The noise-free labels, inside [`GT_DIR`].
pub const EXACT_FILE: &str = "exact.json";
/// LIMAP detector folder name of the segments.
const DETECTOR: &str = "lsd";

/// `exact.json`.
#[derive(Serialize)]
struct Exact {
    label_noise_cm: f64,
    sigma_per_coordinate_m: f64,
    noise_seed: u64,
    /// point3D id -> exact position.
    points3d: BTreeMap<u64, [f64; 3]>,
    /// finaltracks index -> exact endpoints (same order as the track file).
    line_tracks: BTreeMap<usize, ExactLine>,
}

#[derive(Serialize)]
struct ExactLine {
    edge: u32,
    endpoints: [[f64; 3]; 2],
}

/// Writes the labels under `scene_dir/sfm_gt/` (labels perturbed by
/// `cfg.label_noise_cm`, the exact ones to `exact.json`).
pub fn write(
    scene_dir: &Path,
    dataset: &SynthDataset,
    gt: &GroundTruth,
    cfg: &GtConfig,
) -> Result<(), GtError> {
    let root = scene_dir.join(GT_DIR);
    std::fs::create_dir_all(&root).at(&root)?;
    let mut noise = LabelNoise::new(cfg.label_noise_cm, dataset.seed);
    let noisy_points: Vec<[f64; 3]> = gt.points.iter().map(|p| noise.perturb(p.xyz)).collect();
    let noisy_lines: Vec<[[f64; 3]; 2]> = gt
        .lines
        .iter()
        .map(|l| [noise.perturb(l.line[0]), noise.perturb(l.line[1])])
        .collect();
    write_colmap(&root.join("colmap"), dataset, gt, &noisy_points)?;
    write_limap(&root.join("limap"), gt, &noisy_lines)?;

    let exact = Exact {
        label_noise_cm: cfg.label_noise_cm,
        sigma_per_coordinate_m: sigma_per_coordinate_m(cfg.label_noise_cm),
        noise_seed: noise_seed(dataset.seed),
        points3d: gt
            .points
            .iter()
            .enumerate()
            .map(|(i, p)| (i as u64 + 1, p.xyz))
            .collect(),
        line_tracks: gt
            .lines
            .iter()
            .enumerate()
            .map(|(i, l)| {
                (
                    i,
                    ExactLine {
                        edge: l.edge,
                        endpoints: l.line,
                    },
                )
            })
            .collect(),
    };
    let path = root.join(EXACT_FILE);
    let bytes = serde_json::to_vec(&exact).map_err(|source| GtError::Json {
        path: path.clone(),
        source,
    })?;
    let tmp = root.join(format!(".{EXACT_FILE}.tmp"));
    std::fs::write(&tmp, bytes).at(&tmp)?;
    Ok(std::fs::rename(&tmp, &path).at(&path)?)
}

fn write_colmap(
    dir: &Path,
    dataset: &SynthDataset,
    gt: &GroundTruth,
    xyz: &[[f64; 3]],
) -> Result<(), GtError> {
    let err = |source| GtError::Colmap {
        path: dir.to_path_buf(),
        source,
    };
    let mut images: Vec<colmap::Image> = gt
        .images
        .iter()
        .zip(&gt.observations)
        .map(|(im, o)| {
            let pose = dataset.frames[im.frame].pose;
            colmap::Image {
                image_id: im.image_id,
                qvec: pose.qvec(),
                tvec: pose.tvec(),
                camera_id: 1,
                name: im.name.clone(),
                points2d: o
                    .keypoints
                    .iter()
                    .map(|k| Point2D {
                        xy: k.xy,
                        point3d_id: INVALID_POINT3D_ID,
                    })
                    .collect(),
            }
        })
        .collect();
    let mut points3d = Vec::with_capacity(gt.points.len());
    for ((i, p), x) in gt.points.iter().enumerate().zip(xyz) {
        let id = i as u64 + 1;
        let xv = Vector3::from(*x);
        let mut sum = 0.0;
        let mut track = Vec::with_capacity(p.track.len());
        for &(k, kp) in &p.track {
            let im = &mut images[k];
            im.points2d[kp as usize].point3d_id = id;
            let pose = dataset.frames[gt.images[k].frame].pose;
            // Behind the camera only with absurd noise; count it as a large error.
            sum += reprojection_error(&dataset.camera, &pose, &xv, im.points2d[kp as usize].xy)
                .unwrap_or(1e6);
            track.push(TrackElement {
                image_id: im.image_id,
                point2d_idx: kp,
            });
        }
        points3d.push(Point3D {
            id,
            xyz: *x,
            rgb: p.rgb,
            error: sum / p.track.len().max(1) as f64,
            track,
        });
    }
    let rec = Reconstruction::new(
        vec![CameraRecord {
            camera_id: 1,
            camera: dataset.camera.clone(),
        }],
        images,
        points3d,
        vec![],
        vec![],
    )
    .map_err(err)?;
    colmap::write_binary(&rec, dir).map_err(err)
}

fn write_limap(dir: &Path, gt: &GroundTruth, lines: &[[[f64; 3]; 2]]) -> Result<(), GtError> {
    let image_list = ImageList {
        images: gt
            .images
            .iter()
            .map(|im| (im.image_id, im.name.clone()))
            .collect(),
    };
    let segments: BTreeMap<u32, Segments> = gt
        .images
        .iter()
        .zip(&gt.observations)
        .map(|(im, o)| {
            (
                im.image_id,
                Segments::new(o.segments.iter().map(|s| s.xy).collect()),
            )
        })
        .collect();
    let tracks: Vec<LineTrack> = gt
        .lines
        .iter()
        .zip(lines)
        .map(|(l, line)| LineTrack {
            line: *line,
            image_ids: l.supports.iter().map(|s| gt.images[s.0].image_id).collect(),
            line_ids: l.supports.iter().map(|s| s.1).collect(),
            lines2d: Some(
                l.supports
                    .iter()
                    .map(|s| gt.observations[s.0].segments[s.1 as usize].xy)
                    .collect(),
            ),
            extras: None,
        })
        .collect();
    limap::write_limap_dir(dir, DETECTOR, &image_list, &segments, &tracks).map_err(|source| {
        GtError::Limap {
            path: dir.to_path_buf(),
            source,
        }
    })
}
