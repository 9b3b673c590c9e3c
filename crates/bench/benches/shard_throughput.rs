//! Shard write and read throughput on synthetic frames: N frames (default 200) with
//! 4096 keypoints, 500 segments and a 640x480 PNG each.
//!
//! cargo bench -p bench --bench shard_throughput [-- FRAMES] [--keep DIR]
//!
//! `--keep DIR` leaves the single-shard run's file in DIR (e.g. for the inspect
//! example or Foxglove).

use shards::{FrameRecord, ShardConfig, ShardJob, ShardReader, plan_shards, write_shards};
use std::collections::BTreeMap;
use std::time::Instant;
use testkit::shard_frames::{frame_with_image, image_bytes};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let n: u64 = args.iter().find_map(|a| a.parse().ok()).unwrap_or(200);
    let keep = args
        .iter()
        .position(|a| a == "--keep")
        .and_then(|i| args.get(i + 1))
        .map(std::path::PathBuf::from);
    stage::set_quiet(true);
    let t = Instant::now();
    let frames: Vec<FrameRecord> = (0..n)
        .map(|id| {
            let png = image_bytes(640, 480, id, shards::ImageFormat::Png);
            frame_with_image(id, 4096, 500, png, shards::ImageFormat::Png, 640, 480)
        })
        .collect();
    let image_bytes: usize = frames.iter().map(|f| f.image_bytes.len()).sum();
    println!(
        "{n} frames, 4096 keypoints + 500 segments each, PNG 640x480 {:.0} KiB on average (made in {:.1} s)",
        image_bytes as f64 / n as f64 / 1024.0,
        t.elapsed().as_secs_f64()
    );
    let ids: Vec<u64> = frames.iter().map(|f| f.frame_id).collect();
    let load = |id: u64| -> Result<FrameRecord, Box<dyn std::error::Error + Send + Sync>> {
        Ok(frames[id as usize].clone())
    };
    let mb = |b: u64| b as f64 / 1e6;

    println!(
        "{:<34} {:>9} {:>10} {:>9} {:>9}",
        "", "seconds", "frames/s", "MB/s", "MB"
    );
    for (frames_per_shard, threads) in [(n as usize, 1), (50, 1), (50, 2)] {
        let tmp = tempfile::tempdir().unwrap();
        let dir = match &keep {
            Some(k) if frames_per_shard == n as usize => k.as_path(),
            _ => tmp.path(),
        };
        let config = ShardConfig {
            frames_per_shard,
            ..ShardConfig::default()
        };
        let plans = plan_shards(&ids, frames_per_shard).unwrap();
        let job = ShardJob {
            out_dir: dir,
            plans: &plans,
            config: &config,
            config_hash: String::new(),
            inputs: BTreeMap::new(),
            digests: None,
        };
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        let t = Instant::now();
        let m = pool.install(|| write_shards(&job, 0..plans.len(), &load).unwrap().manifest);
        let dt = t.elapsed().as_secs_f64();
        let bytes: u64 = m.shards.iter().map(|s| s.bytes).sum();
        println!(
            "{:<34} {dt:>9.2} {:>10.1} {:>9.1} {:>9.1}",
            format!("write {} shard(s), {threads} thread(s)", plans.len()),
            n as f64 / dt,
            mb(bytes) / dt,
            mb(bytes)
        );

        let paths = m.shard_paths(dir);
        let t = Instant::now();
        let mut reader = ShardReader::open(&paths).unwrap();
        let mut read = 0u64;
        for f in reader.by_ref() {
            read += f.unwrap().keypoints.len() as u64;
        }
        let dt = t.elapsed().as_secs_f64();
        assert_eq!(read, 4096 * n);
        println!(
            "{:<34} {dt:>9.2} {:>10.1} {:>9.1} {:>9.1}",
            format!("read {} shard(s) in order", plans.len()),
            n as f64 / dt,
            mb(bytes) / dt,
            mb(bytes)
        );
        if frames_per_shard == n as usize {
            // Random access: every frame once, in a scrambled order.
            let t = Instant::now();
            for i in 0..n {
                let id = (i * 7919) % n;
                reader.read_frame(id).unwrap();
            }
            let dt = t.elapsed().as_secs_f64();
            println!(
                "{:<34} {dt:>9.2} {:>10.1} {:>9} {:>9}",
                "read every frame in random order",
                n as f64 / dt,
                "",
                ""
            );
        }
    }
}
