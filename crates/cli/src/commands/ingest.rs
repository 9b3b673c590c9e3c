//! `pl2map ingest`: reads a dataset in its published layout and writes the frames table
//! (`OUT/frames.parquet`, registered depth under `OUT/depth/`, `OUT/stage.json`).

use anyhow::Context;
use datasets::ingest::IngestConfig;
use datasets::ingest_stage;
use std::path::PathBuf;
use tables::frames::{FramesTable, Split};

#[derive(clap::Args, Debug)]
pub struct Args {
    /// Stage folder to write.
    #[arg(long)]
    pub out: PathBuf,
    #[command(flatten)]
    pub config: IngestConfig,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let config = args.config;
    let done = ingest_stage::run(&config, &args.out).with_context(|| {
        format!(
            "ingesting {} ({})",
            config.scene_dir().display(),
            config.dataset.map_or("no dataset", |d| d.name())
        )
    })?;
    crate::outln!("{}", done.line("ingest"));
    crate::outln!("{}", done.output.frames_path.display());
    crate::out!("{}", summary(&done.output.table));
    Ok(())
}

/// A short table a person reads: frames per split, excluded frames, sources.
fn summary(t: &FramesTable) -> String {
    let m = &t.meta;
    let mut s = format!("{} / {}\n", m.dataset, m.scene);
    let rows = [
        ("train frames", t.count(Split::Train).to_string()),
        ("test frames", t.count(Split::Test).to_string()),
        ("excluded", m.excluded.len().to_string()),
        ("poses", m.pose_source.clone()),
        ("depth", m.depth_source.clone()),
        ("cameras", m.intrinsics.clone()),
    ];
    for (k, v) in rows {
        s.push_str(&format!("  {k:<13} {v}\n"));
    }
    for e in &m.excluded {
        s.push_str(&format!(
            "  excluded {} ({}): {}\n",
            e.name, e.split, e.reason
        ));
    }
    s
}
