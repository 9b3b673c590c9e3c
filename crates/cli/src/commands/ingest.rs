//! `pl2map ingest`: reads a dataset in its published layout and writes the frames table
//! (`OUT/frames.parquet`, registered depth under `OUT/depth/`, `OUT/stage.json`).

use anyhow::Context;
use datasets::frames::{FramesTable, Split};
use datasets::ingest::{self, DatasetKind, DepthOption, IngestConfig, PoseOption};
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
pub struct Args {
    /// Dataset layout: 7scenes or cambridge.
    #[arg(long)]
    pub dataset: DatasetKind,
    /// The scene folder (holding the split files), or the dataset folder with --scene.
    #[arg(long)]
    pub root: PathBuf,
    /// Scene folder inside --root (e.g. stairs, KingsCollege).
    #[arg(long)]
    pub scene: Option<String>,
    /// Stage folder to write.
    #[arg(long)]
    pub out: PathBuf,
    /// Colour camera poses (7-Scenes): published (pose.txt as is) or calibrated (moved to
    /// the colour camera with the Kinect depth-to-RGB extrinsic).
    #[arg(long, default_value = "published")]
    pub poses: PoseOption,
    /// Depth maps: none, raw (7-Scenes depth.png registered into the colour camera) or
    /// rendered:DIR (rendered depth maps found by frame name).
    #[arg(long, default_value = "none")]
    pub depth: DepthOption,
    /// Camera for every frame instead of the dataset's: "MODEL WIDTH HEIGHT PARAMS..."
    /// (COLMAP order), e.g. "SIMPLE_PINHOLE 640 480 525 320 240".
    #[arg(long)]
    pub camera: Option<String>,
    /// Dataset descriptor: a built-in name (7scenes, cambridge, synthetic) or a .toml
    /// file of your own (datasets/*.toml show the format); default: --dataset's.
    #[arg(long)]
    pub descriptor: Option<String>,
    /// Read a scene whose frame counts differ from its descriptor's (a subset such as
    /// the sample data); by default such a scene is refused as a truncated download.
    #[arg(long)]
    pub no_count_check: bool,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let config = IngestConfig {
        dataset: args.dataset,
        root: args.root,
        scene: args.scene,
        poses: args.poses,
        depth: args.depth,
        camera: args.camera,
        descriptor: args.descriptor,
        count_check: !args.no_count_check,
    };
    let output = ingest::run(&config, &args.out).with_context(|| {
        format!(
            "ingesting {} ({})",
            config.scene_dir().display(),
            config.dataset.name()
        )
    })?;
    let state = if output.skipped {
        "up to date, skipped"
    } else {
        "written"
    };
    println!("{} ({state})", output.frames_path.display());
    print!("{}", summary(&output.table));
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
