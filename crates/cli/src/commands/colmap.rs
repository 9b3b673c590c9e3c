//! `pl2map colmap info|convert`: summary of a COLMAP model, bin <-> txt conversion.
use anyhow::Context;
use clap::{Subcommand, ValueEnum};
use colmap::{Format, Reconstruction};
use std::path::{Path, PathBuf};

#[derive(Subcommand)]
pub enum Command {
    /// Print a summary (like pycolmap's `Reconstruction.summary()`) and the cameras.
    Info {
        /// Model directory (binary files if cameras/images/points3D.bin exist, else text).
        dir: PathBuf,
        /// Print JSON instead of text.
        #[arg(long)]
        json: bool,
    },
    /// Read a model and write it in the given format (all five files).
    Convert {
        input: PathBuf,
        output: PathBuf,
        #[arg(long, value_enum)]
        format: OutFormat,
    },
}

#[derive(Clone, Copy, ValueEnum)]
pub enum OutFormat {
    Bin,
    Txt,
}

pub fn run(cmd: Command) -> anyhow::Result<()> {
    match cmd {
        Command::Info { dir, json } => info(&dir, json),
        Command::Convert {
            input,
            output,
            format,
        } => convert(&input, &output, format),
    }
}

fn g6(x: f64) -> String {
    let mut s = String::new();
    colmap::text::push_g(&mut s, x, 6);
    s
}

fn format_name(f: Format) -> &'static str {
    match f {
        Format::Binary => "bin",
        Format::Text => "txt",
    }
}

fn info(dir: &Path, json: bool) -> anyhow::Result<()> {
    let format = colmap::detect_format(dir)?;
    let rec = colmap::read(dir).with_context(|| format!("reading {}", dir.display()))?;
    let mut images_per_camera = std::collections::BTreeMap::<u32, usize>::new();
    for im in &rec.images {
        *images_per_camera.entry(im.camera_id).or_default() += 1;
    }
    if json {
        let cameras: Vec<_> = rec
            .cameras
            .iter()
            .map(|c| {
                serde_json::json!({
                    "camera_id": c.camera_id,
                    "model": c.camera.model.name(),
                    "width": c.camera.width,
                    "height": c.camera.height,
                    "params": c.camera.params,
                    "num_images": images_per_camera.get(&c.camera_id).copied().unwrap_or(0),
                })
            })
            .collect();
        let v = serde_json::json!({
            "dir": dir.display().to_string(),
            "format": format_name(format),
            "num_rigs": rec.rigs.len(),
            "num_cameras": rec.cameras.len(),
            "num_frames": rec.frames.len(),
            "num_images": rec.images.len(),
            "num_reg_images": rec.images.len(),
            "num_points2D": rec.num_points2d(),
            "num_points3D": rec.points3d.len(),
            "num_observations": rec.num_observations(),
            "mean_track_length": rec.mean_track_length(),
            "mean_observations_per_image": rec.mean_observations_per_image(),
            "mean_reprojection_error": rec.mean_reprojection_error(),
            "cameras": cameras,
        });
        crate::outln!("{}", serde_json::to_string_pretty(&v)?);
        return Ok(());
    }
    crate::outln!(
        "Reconstruction: {} ({})",
        dir.display(),
        format_name(format)
    );
    for (k, v) in [
        ("num_rigs", rec.rigs.len().to_string()),
        ("num_cameras", rec.cameras.len().to_string()),
        ("num_frames", rec.frames.len().to_string()),
        ("num_reg_frames", rec.frames.len().to_string()),
        ("num_images", rec.images.len().to_string()),
        ("num_reg_images", rec.images.len().to_string()),
        ("num_points2D", rec.num_points2d().to_string()),
        ("num_points3D", rec.points3d.len().to_string()),
        ("num_observations", rec.num_observations().to_string()),
        ("mean_track_length", g6(rec.mean_track_length())),
        (
            "mean_observations_per_image",
            g6(rec.mean_observations_per_image()),
        ),
        ("mean_reprojection_error", g6(rec.mean_reprojection_error())),
    ] {
        crate::outln!("\t{k} = {v}");
    }
    crate::outln!("Cameras:");
    for c in &rec.cameras {
        let params: Vec<String> = c
            .camera
            .model
            .param_names()
            .iter()
            .zip(&c.camera.params)
            .map(|(n, v)| format!("{n}={}", g6(*v)))
            .collect();
        crate::outln!(
            "\t{} {} {}x{} {} ({} images)",
            c.camera_id,
            c.camera.model.name(),
            c.camera.width,
            c.camera.height,
            params.join(" "),
            images_per_camera.get(&c.camera_id).copied().unwrap_or(0)
        );
    }
    Ok(())
}

fn convert(input: &Path, output: &Path, format: OutFormat) -> anyhow::Result<()> {
    let rec: Reconstruction =
        colmap::read(input).with_context(|| format!("reading {}", input.display()))?;
    let format = match format {
        OutFormat::Bin => Format::Binary,
        OutFormat::Txt => Format::Text,
    };
    colmap::write(&rec, output, format).with_context(|| format!("writing {}", output.display()))?;
    tracing::info!(
        "wrote {} cameras, {} images, {} points3D to {} ({})",
        rec.cameras.len(),
        rec.images.len(),
        rec.points3d.len(),
        output.display(),
        format_name(format)
    );
    Ok(())
}
