//! Accuracy of a trained network's 3D points on held-out frames of a synthetic scene
//! (a measurement, not a test).
//!
//! Ground truth: each detected keypoint is back-projected with the scene's rendered depth
//! (camera-frame z in mm, inverse depth interpolated bilinearly, which is exact on planes;
//! keypoints whose 2x2 depth neighbourhood spans more than 1 % are skipped as depth edges)
//! and the true pose from the shard.
//!
//! Besides the table over reliability thresholds it prints where the error of the kept
//! points (reliability >= 0.5) lies, as medians over frames: how much of it is one shift
//! common to the whole frame, how much is along the viewing direction (depth) and how
//! much across it, and the least-squares scale of the predictions about their mean
//! (below 1: the frame's points are pulled together).
//!
//! PL2MAP_EVAL_CHUNK=N predicts each image's keypoints in interleaved groups of N with at
//! most the training limit of lines each, instead of all at once: the network then sees
//! the context size that training gave it.
//!
//! cargo run -p bench --example eval_synth -- MODEL.ckpt SHARD_DIR SCENE_ROOT [test|train] [MAX_FRAMES]

mod common;

use common::{depth_at, load_depth};
use features::ImageFeatures;
use geometry::{Matrix3, Vector2, Vector3};
use shards::{Manifest, ShardReader, Split};
use std::path::{Path, PathBuf};
use train::{ImagePrediction, Predictor};

fn median(v: &mut [f64]) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Predicts the image's keypoints in `groups` interleaved groups of about `chunk`.
fn predict_chunked(
    predictor: &Predictor,
    gray: &image::GrayImage,
    chunk: usize,
) -> Result<ImagePrediction, Box<dyn std::error::Error>> {
    let f = predictor.front_end().extract(gray)?;
    let n = f.num_keypoints();
    let groups = n.div_ceil(chunk.max(1)).max(1);
    let max_lines = predictor.config().limits.max_lines;
    let mut points = Vec::with_capacity(n);
    for g in 0..groups {
        let ki: Vec<usize> = (g..n).step_by(groups).collect();
        let li: Vec<usize> = (g..f.num_segments())
            .step_by(groups)
            .take(max_lines)
            .collect();
        let part = ImageFeatures {
            keypoints: ki.iter().map(|&i| f.keypoints[i]).collect(),
            descriptors: ki
                .iter()
                .flat_map(|&i| f.descriptor(i).iter().copied())
                .collect(),
            segments: li.iter().map(|&i| f.segments[i]).collect(),
            line_descriptors: li
                .iter()
                .flat_map(|&i| f.line_descriptor(i).iter().copied())
                .collect(),
            samples_per_line: f.samples_per_line,
            dim: f.dim,
        };
        points.extend(predictor.predict_features(&part)?.points);
    }
    Ok(ImagePrediction {
        points,
        lines: Vec::new(),
    })
}

/// Where one frame's error lies (metres), from its kept points' (prediction, truth).
struct FrameError {
    median: f64,
    /// Norm of the per-axis median of the error vectors.
    common_shift: f64,
    /// Median error once that shift is taken off.
    around_shift: f64,
    /// Median |error| along the camera's z axis, and across it.
    depth: f64,
    lateral: f64,
    /// Least-squares scale of the predictions about their mean against the truth's.
    scale: f64,
}

impl FrameError {
    fn of(pairs: &[(Vector3<f64>, Vector3<f64>)], world_to_camera: &Matrix3<f64>) -> Self {
        let diffs: Vec<Vector3<f64>> = pairs.iter().map(|(p, g)| p - g).collect();
        let med =
            |f: &dyn Fn(&Vector3<f64>) -> f64| median(&mut diffs.iter().map(f).collect::<Vec<_>>());
        let shift = Vector3::new(med(&|d| d[0]), med(&|d| d[1]), med(&|d| d[2]));
        let n = pairs.len() as f64;
        let mp = pairs.iter().map(|p| p.0).sum::<Vector3<f64>>() / n;
        let mg = pairs.iter().map(|p| p.1).sum::<Vector3<f64>>() / n;
        let num: f64 = pairs.iter().map(|(p, g)| (p - mp).dot(&(g - mg))).sum();
        let den: f64 = pairs.iter().map(|(_, g)| (g - mg).norm_squared()).sum();
        FrameError {
            median: med(&|d| d.norm()),
            common_shift: shift.norm(),
            around_shift: med(&|d| (d - shift).norm()),
            depth: med(&|d| (world_to_camera * d)[2].abs()),
            lateral: med(&|d| (world_to_camera * d).xy().norm()),
            scale: num / den,
        }
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    if args.len() < 4 {
        eprintln!("usage: eval_synth MODEL.ckpt SHARD_DIR SCENE_ROOT [test|train] [MAX_FRAMES]");
        std::process::exit(2);
    }
    let (model, shard_dir, root) = (
        Path::new(&args[1]),
        Path::new(&args[2]),
        Path::new(&args[3]),
    );
    let split = args.get(4).map(String::as_str).unwrap_or("test");
    let max_frames: usize = args
        .get(5)
        .map(|s| s.parse())
        .transpose()?
        .unwrap_or(usize::MAX);
    let predictor = Predictor::load(model)?;
    let manifest = Manifest::load(shard_dir.join("manifest.json"))?;
    let paths: Vec<PathBuf> = manifest
        .shards
        .iter()
        .filter(|s| s.file.starts_with(&format!("{split}-")))
        .map(|s| shard_dir.join(&s.file))
        .collect();
    let reader = ShardReader::open(&paths)?;
    let total = reader.frame_count();
    let step = (total / max_frames.min(total).max(1)).max(1);
    // (error in metres, reliability) of every keypoint with ground truth.
    let mut all: Vec<(f64, f64)> = Vec::new();
    let mut frames = 0;
    let mut frame_errors: Vec<FrameError> = Vec::new();
    let chunk: Option<usize> = std::env::var("PL2MAP_EVAL_CHUNK")
        .ok()
        .map(|v| v.parse())
        .transpose()?;
    let t0 = std::time::Instant::now();
    for (k, frame) in reader.enumerate() {
        let frame = frame?;
        if k % step != 0 || frames >= max_frames {
            continue;
        }
        let want = if split == "test" {
            Split::Test
        } else {
            Split::Train
        };
        if frame.split != want {
            continue;
        }
        frames += 1;
        let gray = train::sample::decode_gray(&frame)?;
        let depth = load_depth(root, &frame.name)?;
        let pred = match chunk {
            None => predictor.predict(&gray, &frame.camera)?,
            Some(n) => predict_chunked(&predictor, &gray, n)?,
        };
        let inv = frame.pose.inverse();
        let mut kept: Vec<(Vector3<f64>, Vector3<f64>)> = Vec::new();
        for p in &pred.points {
            let Some(z) = depth_at(&depth, p.xy) else {
                continue;
            };
            let Some(ray) = frame.camera.unproject(&Vector2::new(p.xy[0], p.xy[1])) else {
                continue;
            };
            let gt = inv.transform_point(&(ray * z));
            let xyz = Vector3::new(p.xyz[0], p.xyz[1], p.xyz[2]);
            all.push(((xyz - gt).norm(), p.reliability));
            if p.reliability >= 0.5 {
                kept.push((xyz, gt));
            }
        }
        if !kept.is_empty() {
            frame_errors.push(FrameError::of(&kept, &frame.pose.rotation_matrix()));
        }
    }
    println!(
        "{frames} {split} frame(s), {} keypoints with depth ground truth, {:.1} s",
        all.len(),
        t0.elapsed().as_secs_f64()
    );
    let over_frames =
        |f: fn(&FrameError) -> f64| median(&mut frame_errors.iter().map(f).collect::<Vec<_>>());
    println!(
        "per frame (reliability >= 0.5; medians over frames): error {:.2} cm = common shift \
         {:.2} cm + {:.2} cm around it; along the view {:.2} cm, across {:.2} cm; scale {:.3}",
        100.0 * over_frames(|e| e.median),
        100.0 * over_frames(|e| e.common_shift),
        100.0 * over_frames(|e| e.around_shift),
        100.0 * over_frames(|e| e.depth),
        100.0 * over_frames(|e| e.lateral),
        over_frames(|e| e.scale),
    );
    println!(
        "| reliability >= | kept | fraction kept | median error (cm) | under 5 cm | under 10 cm |"
    );
    println!("|---|---|---|---|---|---|");
    for th in [0.0, 0.1, 0.3, 0.5, 0.7, 0.9] {
        let mut e: Vec<f64> = all
            .iter()
            .filter(|(_, r)| *r >= th)
            .map(|(e, _)| *e)
            .collect();
        let n = e.len();
        let under = |c: f64| e.iter().filter(|x| **x < c).count() as f64 / n.max(1) as f64;
        let (u5, u10) = (under(0.05), under(0.10));
        println!(
            "| {th:.1} | {n} | {:.3} | {:.2} | {:.3} | {:.3} |",
            n as f64 / all.len().max(1) as f64,
            100.0 * median(&mut e),
            u5,
            u10
        );
    }
    Ok(())
}
