//! `pl2map pose`: absolute pose from 2D-3D point (and line) correspondences in text
//! files (formats in pose::io), with the hybrid RANSAC of the pose crate.

use anyhow::Context;
use pose::io::{parse_camera, read_lines, read_points};
use pose::{RansacOptions, estimate_pose};
use serde_json::json;
use std::path::PathBuf;
use std::time::Instant;

#[derive(clap::Args)]
pub struct Args {
    /// Camera as "MODEL WIDTH HEIGHT PARAMS..." (COLMAP model names and parameter
    /// order), e.g. "PINHOLE 640 480 525 525 320 240".
    #[arg(long)]
    camera: String,
    /// Point correspondences: `x y X Y Z` per line (pixels in the COLMAP convention,
    /// `#` comments).
    #[arg(long)]
    points: PathBuf,
    /// Line correspondences: `x1 y1 x2 y2 X1 Y1 Z1 X2 Y2 Z2` per line.
    #[arg(long)]
    lines: Option<PathBuf>,
    /// Inlier threshold on point reprojection errors, pixels.
    #[arg(long, default_value_t = RansacOptions::default().point_threshold_px)]
    point_threshold: f64,
    /// Inlier threshold on line errors (sum of both endpoint distances), pixels.
    #[arg(long, default_value_t = RansacOptions::default().line_threshold_px)]
    line_threshold: f64,
    /// RANSAC seed (same inputs and seed, same result).
    #[arg(long, default_value_t = RansacOptions::default().seed)]
    seed: u64,
    /// Print one JSON object instead of text.
    #[arg(long)]
    json: bool,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let camera = parse_camera(&args.camera)?;
    let points = read_points(&args.points)?;
    let lines = match &args.lines {
        Some(p) => read_lines(p)?,
        None => Vec::new(),
    };
    let opt = RansacOptions {
        seed: args.seed,
        ..RansacOptions::with_thresholds(args.point_threshold, args.line_threshold)
    };
    let t0 = Instant::now();
    let est = estimate_pose(&camera, &points, &lines, &opt).with_context(|| {
        format!(
            "estimating the pose from {} points and {} lines",
            points.len(),
            lines.len()
        )
    })?;
    let ms = t0.elapsed().as_secs_f64() * 1e3;
    let (q, t) = (est.pose.qvec(), est.pose.tvec());
    if args.json {
        let finite = |v: &[f64]| {
            v.iter()
                .map(|&e| e.is_finite().then_some(e))
                .collect::<Vec<_>>()
        };
        let doc = json!({
            "qvec": q,
            "tvec": t,
            "num_points": points.len(),
            "num_lines": lines.len(),
            "point_inliers": est.num_point_inliers,
            "line_inliers": est.num_line_inliers,
            "iterations": est.iterations,
            "milliseconds": ms,
            "point_inlier_mask": est.point_inliers,
            "line_inlier_mask": est.line_inliers,
            "point_errors_px": finite(&est.point_errors_px),
            "line_errors_px": finite(&est.line_errors_px),
            "unusable": est.num_unusable,
        });
        crate::outln!("{doc}");
    } else {
        crate::outln!("pose (world-to-camera, qw qx qy qz tx ty tz):");
        crate::outln!(
            "{} {} {} {} {} {} {}",
            q[0],
            q[1],
            q[2],
            q[3],
            t[0],
            t[1],
            t[2]
        );
        crate::outln!(
            "inliers: {}/{} points, {}/{} lines",
            est.num_point_inliers,
            points.len(),
            est.num_line_inliers,
            lines.len()
        );
        crate::outln!("iterations: {}", est.iterations);
        crate::outln!("time: {ms:.3} ms");
        if est.num_unusable > 0 {
            crate::outln!(
                "note: {} correspondences could not be used (outside the camera model's domain)",
                est.num_unusable
            );
        }
    }
    Ok(())
}
