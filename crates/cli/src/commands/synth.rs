//! `pl2map synth OUT`: renders the built-in synthetic room into OUT/<scene> in the
//! 7-Scenes or Cambridge layout.

use anyhow::Context;
use datasets::synth::{Layout, SynthConfig, generate};
use std::path::PathBuf;
use std::time::Instant;

#[derive(clap::Args, Debug)]
pub struct Args {
    /// Output folder; the scene is written to OUT/<--name>.
    pub out: PathBuf,
    /// Total number of frames (2/3 training, 1/3 test). Ignored with --tiny.
    #[arg(long, default_value_t = datasets::synth::trajectory::DEFAULT_FRAMES)]
    pub frames: usize,
    /// Seed of the room and the camera paths.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Layout of the written dataset: 7scenes or cambridge.
    #[arg(long, default_value = "7scenes", value_parser = parse_layout)]
    pub layout: Layout,
    /// The small test scene (24 training + 8 test frames).
    #[arg(long)]
    pub tiny: bool,
    /// Scene folder name inside OUT.
    #[arg(long, default_value = datasets::synth::generate::DEFAULT_SCENE_NAME)]
    pub name: String,
    /// Replace an existing OUT/<name>.
    #[arg(long)]
    pub overwrite: bool,
}

fn parse_layout(s: &str) -> Result<Layout, String> {
    match s {
        "7scenes" | "7-scenes" => Ok(Layout::SevenScenes),
        "cambridge" => Ok(Layout::Cambridge),
        _ => Err(format!(
            "unknown layout {s:?}: expected 7scenes or cambridge"
        )),
    }
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let cfg = SynthConfig {
        out: args.out,
        scene_name: args.name,
        frames: args.frames,
        seed: args.seed,
        layout: args.layout,
        tiny: args.tiny,
        overwrite: args.overwrite,
        progress: true,
    };
    let t = Instant::now();
    let out = generate(&cfg)
        .with_context(|| format!("writing the synthetic scene to {}", cfg.out.display()))?;
    println!(
        "{} frames written to {} in {:.1} s",
        out.frames.len(),
        out.root.display(),
        t.elapsed().as_secs_f64()
    );
    Ok(())
}
