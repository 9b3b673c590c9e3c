//! `pl2map synth OUT`: the synth stage alone. Renders the built-in synthetic room into
//! OUT/<scene> in the 7-Scenes or Cambridge layout, with its SfM and LIMAP ground truth in
//! OUT/<scene>/sfm_gt (unless --no-gt), recorded in OUT/stage.json, and an optional
//! contact sheet OUT/<scene>/preview.png. The flags are those of `synth::SynthConfig`.

use anyhow::Context;
use image::ImageEncoder as _;
use std::path::{Path, PathBuf};
use synth::{Split, SynthConfig, color_name, contact_sheet};

#[derive(clap::Args, Debug)]
pub struct Args {
    /// Output folder; the scene is written to OUT/<--name>.
    pub out: PathBuf,
    /// Replace OUT/<name> even when it holds files this command did not write (by
    /// default those are refused, naming them; a scene this command recorded in
    /// OUT/stage.json is replaced when the settings change).
    #[arg(long)]
    pub overwrite: bool,
    /// Write OUT/<name>/preview.png: a few training frames with their SIFT keypoints and
    /// LSD segments drawn.
    #[arg(long)]
    pub preview: bool,
    #[command(flatten)]
    pub config: SynthConfig,
}

/// Frames shown on the contact sheet.
const PREVIEW_FRAMES: usize = 6;

pub fn run(args: Args, quiet: bool) -> anyhow::Result<()> {
    let cfg = &args.config;
    let done = synth::synth_stage::run(cfg, &args.out, !quiet, args.overwrite)
        .with_context(|| format!("writing the synthetic scene to {}", args.out.display()))?;
    crate::outln!("{}", done.line("synth"));
    crate::outln!("scene folder: {}", done.output.root.display());
    if cfg.label_noise_cm > 0.0 && cfg.ground_truth {
        crate::outln!(
            "labels perturbed by {} cm RMS; exact values in {}",
            cfg.label_noise_cm,
            done.output
                .root
                .join(synth::gt::GT_DIR)
                .join(synth::gt::EXACT_FILE)
                .display()
        );
    }
    if args.preview {
        let path = done.output.root.join(synth::synth_stage::PREVIEW_FILE);
        write_preview(cfg, &done.output.root, &path)?;
        crate::outln!("preview written to {}", path.display());
    }
    Ok(())
}

/// A contact sheet of a few training frames (evenly spaced) with the keypoints and
/// segments the front-end detects on the written images.
fn write_preview(cfg: &SynthConfig, root: &Path, path: &Path) -> anyhow::Result<()> {
    let dataset = cfg.dataset()?;
    let train: Vec<PathBuf> = dataset
        .frames
        .iter()
        .filter(|f| f.split == Split::Train)
        .map(|f| root.join(color_name(cfg.layout, f)))
        .collect();
    let n = train.len().min(PREVIEW_FRAMES);
    let fe = features::FrontEndConfig::default();
    let mut sheet = Vec::with_capacity(n);
    for k in 0..n {
        let f = &train[k * train.len() / n];
        // `load_from_memory`, not `image::open`: the latter is generic over its reader
        // and would compile every image decoder again in this crate.
        let bytes = std::fs::read(f).with_context(|| format!("reading {}", f.display()))?;
        let rgb = image::load_from_memory(&bytes)
            .with_context(|| format!("decoding {}", f.display()))?
            .to_rgb8();
        let gray = features::gray_from_rgb(&rgb);
        let kps = features::detect_keypoints(&gray, &fe.sift)
            .with_context(|| format!("SIFT on {}", f.display()))?;
        let segs = features::detect_segments(&gray, &fe.lsd)
            .with_context(|| format!("LSD on {}", f.display()))?;
        sheet.push((rgb, kps.into_iter().map(|k| k.xy).collect(), segs));
    }
    let img = contact_sheet(&sheet, 3);
    // The PNG encoder alone (`write_to` would compile every encoder in this crate).
    let mut bytes = Vec::new();
    image::codecs::png::PngEncoder::new(&mut bytes)
        .write_image(
            img.as_raw(),
            img.width(),
            img.height(),
            image::ExtendedColorType::Rgb8,
        )
        .with_context(|| format!("encoding {}", path.display()))?;
    stage::write_atomic(path, &bytes)?;
    Ok(())
}
