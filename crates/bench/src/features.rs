//! Front-end benchmark: per-step milliseconds per image and images/s for a thread
//! count, printed as a table by `pl2map bench features`.

use features::{
    FeatureError, FrontEndConfig, describe_lines, describe_points, detect_keypoints,
    detect_segments, extract,
};
use image::GrayImage;
use std::time::Instant;

/// Median milliseconds per image of each step, single-threaded.
#[derive(Clone, Debug)]
pub struct StepTimes {
    pub sift_detect_ms: f64,
    pub sift_describe_ms: f64,
    pub lsd_ms: f64,
    pub line_sampling_ms: f64,
    pub mean_keypoints: f64,
    pub mean_segments: f64,
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(|a, b| a.total_cmp(b));
    if v.is_empty() {
        f64::NAN
    } else {
        v[v.len() / 2]
    }
}

/// Times each step on every image (in the calling thread).
pub fn step_times(images: &[GrayImage], cfg: &FrontEndConfig) -> Result<StepTimes, FeatureError> {
    let (mut det, mut desc, mut lsd, mut lines) = (vec![], vec![], vec![], vec![]);
    let (mut nk, mut ns) = (0usize, 0usize);
    for img in images {
        let t = Instant::now();
        let kps: Vec<[f64; 2]> = detect_keypoints(img, &cfg.sift)?
            .into_iter()
            .map(|k| k.xy)
            .collect();
        det.push(t.elapsed().as_secs_f64() * 1e3);
        let t = Instant::now();
        describe_points(img, &kps, &cfg.sift, &cfg.descriptor)?;
        desc.push(t.elapsed().as_secs_f64() * 1e3);
        let t = Instant::now();
        let segs = detect_segments(img, &cfg.lsd)?;
        lsd.push(t.elapsed().as_secs_f64() * 1e3);
        let t = Instant::now();
        describe_lines(img, &segs, cfg.samples_per_line, &cfg.sift, &cfg.descriptor)?;
        lines.push(t.elapsed().as_secs_f64() * 1e3);
        nk += kps.len();
        ns += segs.len();
    }
    let n = images.len().max(1) as f64;
    Ok(StepTimes {
        sift_detect_ms: median(det),
        sift_describe_ms: median(desc),
        lsd_ms: median(lsd),
        line_sampling_ms: median(lines),
        mean_keypoints: nk as f64 / n,
        mean_segments: ns as f64 / n,
    })
}

/// Whole-front-end throughput (images/s) with a rayon pool of `threads` threads.
pub fn throughput(
    images: &[GrayImage],
    cfg: &FrontEndConfig,
    threads: usize,
) -> Result<f64, FeatureError> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| FeatureError::Config(format!("thread pool: {e}")))?;
    let t = Instant::now();
    let results = pool.install(|| {
        features::extract_batch(images, &indicatif::ProgressBar::hidden(), |img| {
            extract(img, cfg)
        })
    });
    let secs = t.elapsed().as_secs_f64();
    for r in results {
        r?;
    }
    Ok(images.len() as f64 / secs)
}
