//! Diagnostic (not a test): how far a plain nearest-neighbour descriptor lookup gets.
//! Training side: every labelled keypoint of the training shards, described with the
//! checkpoint's front-end on the original image. Query side: test frames, detected and
//! described as the predictor does, ground truth from rendered depth (as eval_synth).
//!
//! cargo run --release -p bench --example nn_baseline -- MODEL.ckpt SHARD_DIR SCENE_ROOT [TEST_FRAMES] [PER_FRAME]

mod common;

use common::{depth_at, load_depth};
use geometry::{Vector2, Vector3};
use shards::{Manifest, ShardReader, Split};
use std::path::{Path, PathBuf};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let a: Vec<String> = std::env::args().collect();
    let predictor = train::Predictor::load(Path::new(&a[1]))?;
    let (dir, root) = (Path::new(&a[2]), Path::new(&a[3]));
    let test_frames: usize = a.get(4).map(|s| s.parse()).transpose()?.unwrap_or(8);
    let per_frame: usize = a.get(5).map(|s| s.parse()).transpose()?.unwrap_or(400);
    let fe = predictor.front_end();
    let manifest = Manifest::load(dir.join("manifest.json"))?;
    let files = |p: &str| -> Vec<PathBuf> {
        manifest
            .shards
            .iter()
            .filter(|s| s.file.starts_with(p))
            .map(|s| dir.join(&s.file))
            .collect()
    };
    let mut descs: Vec<f32> = Vec::new();
    let mut xyz: Vec<[f64; 3]> = Vec::new();
    for f in ShardReader::open(files("train-"))? {
        let f = f?;
        let gray = train::sample::decode_gray(&f)?;
        let pos: Vec<[f64; 2]> = (0..f.keypoints.len())
            .filter(|&i| f.point_valid[i])
            .map(|i| f.keypoints[i])
            .collect();
        let d = fe.describe_points(&gray, &pos)?;
        descs.extend_from_slice(&d);
        for i in (0..f.keypoints.len()).filter(|&i| f.point_valid[i]) {
            xyz.push(f.points3d[i]);
        }
    }
    println!("{} training descriptors", xyz.len());
    // PL2MAP_NN_DUMP=DIR writes the raw arrays (little-endian f32) for offline study.
    let dump = std::env::var_os("PL2MAP_NN_DUMP").map(PathBuf::from);
    let write = |name: &str, v: &[f32]| -> std::io::Result<()> {
        if let Some(d) = &dump {
            let bytes: Vec<u8> = v.iter().flat_map(|x| x.to_le_bytes()).collect();
            std::fs::write(d.join(name), bytes)?;
        }
        Ok(())
    };
    write("train_desc.f32", &descs)?;
    write(
        "train_xyz.f32",
        &xyz.iter()
            .flat_map(|p| p.map(|x| x as f32))
            .collect::<Vec<_>>(),
    )?;
    let (mut qd, mut qg) = (Vec::<f32>::new(), Vec::<f32>::new());
    let mut errs = Vec::new();
    let frames: Vec<_> = ShardReader::open(files("test-"))?.collect::<Result<Vec<_>, _>>()?;
    let step = (frames.len() / test_frames).max(1);
    for f in frames.iter().step_by(step).take(test_frames) {
        assert_eq!(f.split, Split::Test);
        let gray = train::sample::decode_gray(f)?;
        let feats = fe.extract(&gray)?;
        let inv = f.pose.inverse();
        let depth = load_depth(root, &f.name)?;
        for (k, xy) in feats.keypoints.iter().enumerate().take(per_frame) {
            let Some(z) = depth_at(&depth, *xy) else {
                continue;
            };
            let Some(ray) = f.camera.unproject(&Vector2::new(xy[0], xy[1])) else {
                continue;
            };
            let gt = inv.transform_point(&(ray * z));
            let q = feats.descriptor(k);
            qd.extend_from_slice(q);
            qg.extend(gt.iter().map(|x| *x as f32));
            if dump.is_some() {
                continue;
            }
            let (mut best, mut bi) = (f32::MIN, 0);
            for (j, d) in descs.chunks_exact(128).enumerate() {
                let s: f32 = q.iter().zip(d).map(|(a, b)| a * b).sum();
                if s > best {
                    best = s;
                    bi = j;
                }
            }
            let p = xyz[bi];
            errs.push((Vector3::new(p[0], p[1], p[2]) - gt).norm());
        }
    }
    write("test_desc.f32", &qd)?;
    write("test_gt.f32", &qg)?;
    if dump.is_some() {
        return Ok(());
    }
    errs.sort_by(f64::total_cmp);
    let n = errs.len();
    let under = |c: f64| errs.iter().filter(|e| **e < c).count() as f64 / n as f64;
    println!(
        "{n} queries: median {:.1} cm, under 5 cm {:.3}, under 10 cm {:.3}, under 50 cm {:.3}",
        100.0 * errs[n / 2],
        under(0.05),
        under(0.10),
        under(0.5)
    );
    Ok(())
}
