//! `pl2map synth OUT`: renders the built-in synthetic room into OUT/<scene> in the
//! 7-Scenes or Cambridge layout, with its SfM and LIMAP ground truth in OUT/<scene>/sfm_gt
//! (unless --no-gt) and an optional contact sheet OUT/<scene>/preview.png.

use anyhow::Context;
use datasets::synth::{Layout, Split, SynthConfig, SynthOutput, contact_sheet, generate};
use std::path::{Path, PathBuf};
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
    /// RMS 3D error (cm) added to the written ground-truth points and line endpoints
    /// (Gaussian, sigma = X / sqrt(3) per coordinate); the exact values go to
    /// sfm_gt/exact.json.
    #[arg(long, default_value_t = 0.0)]
    pub label_noise_cm: f64,
    /// Skip the ground truth (COLMAP model and LIMAP folder under sfm_gt/).
    #[arg(long)]
    pub no_gt: bool,
    /// Write OUT/<name>/preview.png: a few training frames with their SIFT keypoints and
    /// LSD segments drawn.
    #[arg(long)]
    pub preview: bool,
    /// Only the first N training sequences (the dataset as recorded so far); the frames
    /// are those of the full scene, so a later run with more adds frames only.
    #[arg(long)]
    pub train_sequences: Option<usize>,
}

/// Frames shown on the contact sheet.
const PREVIEW_FRAMES: usize = 6;

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
        ground_truth: !args.no_gt,
        label_noise_cm: args.label_noise_cm,
        train_sequences: args.train_sequences,
    };
    if !(args.label_noise_cm >= 0.0 && args.label_noise_cm.is_finite()) {
        anyhow::bail!("--label-noise-cm must be a finite number >= 0");
    }
    let t = Instant::now();
    let out = generate(&cfg)
        .with_context(|| format!("writing the synthetic scene to {}", cfg.out.display()))?;
    println!(
        "{} frames written to {} in {:.1} s",
        out.frames.len(),
        out.root.display(),
        t.elapsed().as_secs_f64()
    );
    if let Some(g) = &out.ground_truth {
        println!(
            "ground truth ({} training images): {} points3D, mean track length {:.2}, \
             {} of {} keypoints labelled; {} line tracks with {} supports of {} segments",
            g.images,
            g.points3d,
            g.mean_track_length,
            g.observations,
            g.keypoints,
            g.line_tracks,
            g.line_supports,
            g.segments
        );
        if args.label_noise_cm > 0.0 {
            println!(
                "labels perturbed by {} cm RMS; exact values in {}",
                args.label_noise_cm,
                out.root
                    .join(datasets::synth::gt::GT_DIR)
                    .join(datasets::synth::gt::EXACT_FILE)
                    .display()
            );
        }
    }
    if args.preview {
        let path = out.root.join("preview.png");
        write_preview(&out, &path)?;
        println!("preview written to {}", path.display());
    }
    Ok(())
}

/// A contact sheet of a few training frames (evenly spaced) with the keypoints and
/// segments the front-end detects on the written images.
fn write_preview(out: &SynthOutput, path: &Path) -> anyhow::Result<()> {
    let train: Vec<_> = out
        .frames
        .iter()
        .filter(|f| f.split == Split::Train)
        .collect();
    let n = train.len().min(PREVIEW_FRAMES);
    let fe = features::FrontEndConfig::default();
    let mut sheet = Vec::with_capacity(n);
    for k in 0..n {
        let f = train[k * train.len() / n];
        let rgb = image::open(&f.color_path)
            .with_context(|| format!("reading {}", f.color_path.display()))?
            .to_rgb8();
        let gray = features::gray_from_rgb(&rgb);
        let kps = features::detect_keypoints(&gray, &fe.sift)
            .with_context(|| format!("SIFT on {}", f.color_path.display()))?;
        let segs = features::detect_segments(&gray, &fe.lsd)
            .with_context(|| format!("LSD on {}", f.color_path.display()))?;
        sheet.push((rgb, kps.into_iter().map(|k| k.xy).collect(), segs));
    }
    let img = contact_sheet(&sheet, 3);
    let tmp = path.with_file_name(".preview.png.tmp");
    img.save_with_format(&tmp, image::ImageFormat::Png)
        .with_context(|| format!("writing {}", tmp.display()))?;
    std::fs::rename(&tmp, path).with_context(|| format!("renaming to {}", path.display()))?;
    Ok(())
}
