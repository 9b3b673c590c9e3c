//! Prints what a shard holds: per-channel message counts (from the summary's
//! statistics) and, decoding every frame through the index, the label counts.
//!
//! cargo run -p shards --example inspect -- SHARD.mcap [...]

use shards::{ShardFile, ShardReader};
use std::process::ExitCode;

fn inspect(path: &str) -> Result<(), shards::ShardError> {
    let shard = ShardFile::open(path)?;
    let bytes = std::fs::metadata(path).map(|m| m.len()).unwrap_or(0);
    let ids: Vec<u64> = shard.frame_ids().collect();
    println!(
        "{path}: {bytes} bytes, {} chunks, {} frames",
        shard.chunk_count(),
        ids.len()
    );
    if let (Some(first), Some(last)) = (ids.first(), ids.last()) {
        println!("  frames {first}..={last}");
    }
    println!("  {:<22} {:>8}", "channel", "messages");
    for (topic, n) in shard.channel_message_counts() {
        println!("  {topic:<22} {n:>8}");
    }
    let (mut kp, mut vp, mut seg, mut vl, mut img) = (0usize, 0usize, 0usize, 0usize, 0usize);
    for frame in ShardReader::open([path])? {
        let f = frame?;
        kp += f.keypoints.len();
        vp += f.valid_points();
        seg += f.segments.len();
        vl += f.valid_lines();
        img += f.image_bytes.len();
    }
    println!("  keypoints {kp} (valid 3D {vp}), segments {seg} (valid 3D {vl}), image bytes {img}");
    Ok(())
}

fn main() -> ExitCode {
    let paths: Vec<String> = std::env::args().skip(1).collect();
    if paths.is_empty() {
        eprintln!("usage: inspect SHARD.mcap [...]");
        return ExitCode::from(2);
    }
    let mut status = ExitCode::SUCCESS;
    for p in &paths {
        if let Err(e) = inspect(p) {
            eprintln!("error: {e}");
            status = ExitCode::FAILURE;
        }
    }
    status
}
