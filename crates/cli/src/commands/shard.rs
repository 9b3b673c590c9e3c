//! `pl2map shard`: writes the frames and their labels into MCAP shards
//! (`OUT/train-*.mcap`, `OUT/test-*.mcap`, `OUT/manifest.json`, `OUT/stage.json`; a work
//! unit `--shards a..b` writes `OUT/manifest.a-b.json`, and the unit that completes the
//! plan writes `manifest.json`).

use anyhow::Context;
use shards::shard_stage::{self, ShardStageConfig};
use std::ops::Range;
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
pub struct Args {
    /// The frames table, with the ingest stage's stage.json beside it.
    #[arg(long)]
    pub frames: PathBuf,
    /// Label folder (import or refine stage; its tables are read only as its
    /// stage.json records them).
    #[arg(long)]
    pub labels: PathBuf,
    /// Stage folder to write.
    #[arg(long)]
    pub out: PathBuf,
    /// Write only shards a..b of the run's plan (training shards first, then test).
    #[arg(long, value_parser = parse_range)]
    pub shards: Option<Range<usize>>,
    #[command(flatten)]
    pub config: ShardStageConfig,
}

/// `a..b` (end exclusive, not empty): a range of shard indexes.
pub fn parse_range(s: &str) -> Result<Range<usize>, String> {
    let (a, b) = s
        .split_once("..")
        .ok_or_else(|| format!("{s:?}: expected a..b (e.g. 0..4)"))?;
    let num = |x: &str| {
        x.trim()
            .parse::<usize>()
            .map_err(|e| format!("{s:?}: {x:?} is not a shard index: {e}"))
    };
    let r = num(a)?..num(b)?;
    if r.start >= r.end {
        return Err(format!("{s:?}: the range is empty"));
    }
    Ok(r)
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let done = shard_stage::run(
        &args.config,
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
    let output = &done.output;
    let m = &output.manifest;
    crate::outln!("{}", done.line("shard"));
    crate::outln!(
        "{}: plan: {} shards, {} frames{}",
        args.out.display(),
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
        crate::outln!(
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

#[cfg(test)]
mod tests {
    use super::parse_range;

    #[test]
    fn shard_ranges() {
        assert_eq!(parse_range("0..4").unwrap(), 0..4);
        assert_eq!(parse_range(" 2 .. 3").unwrap(), 2..3);
        assert!(parse_range("3..3").unwrap_err().contains("empty"));
        assert!(parse_range("4").unwrap_err().contains("expected a..b"));
        assert!(
            parse_range("a..2")
                .unwrap_err()
                .contains("not a shard index")
        );
    }
}
