//! `pl2map shard`: writes the frames and their labels into MCAP shards
//! (`OUT/train-*.mcap`, `OUT/test-*.mcap`, `OUT/manifest.json`, `OUT/stage.json`; a work
//! unit `--shards a..b` writes `OUT/manifest.a-b.json`, and the unit that completes the
//! plan writes `manifest.json`).

use anyhow::Context;
use labels::shard::{self, ShardStageConfig};
use std::ops::Range;
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
pub struct Args {
    /// The frames table.
    #[arg(long)]
    pub frames: PathBuf,
    /// Label folder (import or refine stage).
    #[arg(long)]
    pub labels: PathBuf,
    /// Stage folder to write.
    #[arg(long)]
    pub out: PathBuf,
    /// Frames per shard file.
    #[arg(long, default_value_t = 500)]
    pub frames_per_shard: usize,
    /// Write only shards a..b of the run's plan (training shards first, then test).
    #[arg(long, value_parser = parse_range)]
    pub shards: Option<Range<usize>>,
    /// Leave the test frames out.
    #[arg(long)]
    pub no_test: bool,
    /// zstd level of the chunks (1-22).
    #[arg(long, default_value_t = 3)]
    pub zstd_level: u32,
}

fn parse_range(s: &str) -> Result<Range<usize>, String> {
    let (a, b) = s
        .split_once("..")
        .ok_or_else(|| format!("expected a..b, got {s:?}"))?;
    let a: usize = a.parse().map_err(|_| format!("bad start {a:?} in {s:?}"))?;
    let b: usize = b.parse().map_err(|_| format!("bad end {b:?} in {s:?}"))?;
    if a > b {
        return Err(format!("empty range {s:?}"));
    }
    Ok(a..b)
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let mut config = ShardStageConfig {
        include_test: !args.no_test,
        ..ShardStageConfig::default()
    };
    config.shards.frames_per_shard = args.frames_per_shard;
    config.shards.zstd_level = args.zstd_level;
    let output = shard::run(
        &config,
        &args.frames,
        &args.labels,
        &args.out,
        args.shards.clone(),
    )
    .with_context(|| {
        format!(
            "sharding {} with labels {}",
            args.frames.display(),
            args.labels.display()
        )
    })?;
    let m = &output.manifest;
    let written = m.shards.len() - output.reused.len();
    let state = if output.skipped {
        "up to date, skipped".to_string()
    } else if output.reused.is_empty() {
        "written".to_string()
    } else {
        format!(
            "{written} written, {} kept: their frames did not change",
            output.reused.len()
        )
    };
    println!(
        "{}: {} shard(s), {} frame(s) ({state}); plan: {} shards, {} frames{}",
        args.out.display(),
        m.shards.len(),
        m.shards.iter().map(|s| s.frame_count).sum::<u64>(),
        m.planned_shards,
        m.planned_frames,
        if output.complete {
            "; manifest.json complete"
        } else {
            "; other units pending"
        }
    );
    for s in &m.shards {
        let kept = if output.reused.contains(&s.index) {
            "  (kept)"
        } else {
            ""
        };
        println!(
            "  {}  frames {}..={}  {} frames  {} bytes  {}{kept}",
            s.file,
            s.first_frame,
            s.last_frame,
            s.frame_count,
            s.bytes,
            &s.sha256[..16.min(s.sha256.len())],
        );
    }
    Ok(())
}
