//! Accuracy of a trained network's 3D points on held-out frames of a synthetic scene
//! (a measurement, not a test).
//!
//! Ground truth: each detected keypoint is back-projected with the scene's rendered depth
//! (camera-frame z in mm, inverse depth interpolated bilinearly, which is exact on planes;
//! keypoints whose 2x2 depth neighbourhood spans more than 1 % are skipped as depth edges)
//! and the true pose from the shard.
//!
//! cargo run -p train --example eval_synth -- MODEL.ckpt SHARD_DIR SCENE_ROOT [test|train] [MAX_FRAMES]

mod common;

use common::{depth_at, load_depth};
use geometry::{Vector2, Vector3};
use shards::{Manifest, ShardReader, Split};
use std::path::{Path, PathBuf};
use train::Predictor;

fn median(v: &mut [f64]) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
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
        let gray = image::load_from_memory(&frame.image_bytes)?.to_luma8();
        let depth = load_depth(root, &frame.name)?;
        let pred = predictor.predict(&gray, &frame.camera)?;
        let inv = frame.pose.inverse();
        for p in &pred.points {
            let Some(z) = depth_at(&depth, p.xy) else {
                continue;
            };
            let Some(ray) = frame.camera.unproject(&Vector2::new(p.xy[0], p.xy[1])) else {
                continue;
            };
            let gt = inv.transform_point(&(ray * z));
            let err = (Vector3::new(p.xyz[0], p.xyz[1], p.xyz[2]) - gt).norm();
            all.push((err, p.reliability));
        }
    }
    println!(
        "{frames} {split} frame(s), {} keypoints with depth ground truth, {:.1} s",
        all.len(),
        t0.elapsed().as_secs_f64()
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
