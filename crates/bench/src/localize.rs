//! `pl2map bench localize`: where a query's time goes, and queries per second
//! (docs/performance.md, "Localisation").
//!
//! - Phases, one image after the other on one thread: decode, SIFT detect, describe
//!   points, LSD, describe lines (each public call on its own, as training calls them),
//!   describe points + lines in one pass (the query path), network, RANSAC with points,
//!   RANSAC with points + lines.
//! - One query alone through [`score::localize::localize_batch`] (what `pl2map localize` runs) on
//!   pools of 1 and 2 threads: the latency.
//! - Every query through `localize_batch` in rounds, as `pl2map localize` does, on 1 and
//!   2 threads: queries per second.
//! - The poses from the query path's features against the poses from the per-call
//!   features: they must be identical.

use score::localize::{Query, load_query, localize_batch};
use score::network::correspondences;
use score::{
    Correspondences, NetworkLocaliser, ScoreConfig, ScoreError, TestFrame, Timing, Variant,
    localize_frame,
};
use std::path::Path;
use std::time::Instant;

/// Median milliseconds of each phase, and the rest of the table.
#[derive(Clone, Debug)]
pub struct LocalizeBench {
    pub images: usize,
    pub mean_keypoints: f64,
    pub mean_segments: f64,
    /// (phase, median ms), in table order.
    pub phases: Vec<(&'static str, f64)>,
    /// (threads, median ms per query alone).
    pub latency_ms: Vec<(usize, f64)>,
    /// (threads, queries per second).
    pub throughput: Vec<(usize, f64)>,
    /// Queries whose poses (both variants) are the same from both front-end paths.
    pub identical_poses: usize,
    /// Queries with a pose from points + lines.
    pub localised: usize,
}

fn median(mut v: Vec<f64>) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn ms(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}

fn pool(threads: usize) -> Result<rayon::ThreadPool, ScoreError> {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| ScoreError::Config(format!("thread pool: {e}")))
}

fn frame_err(f: &TestFrame, e: impl std::fmt::Display) -> ScoreError {
    ScoreError::Frame {
        frame_id: f.frame_id(),
        name: f.name().to_string(),
        reason: e.to_string(),
    }
}

/// Runs the benchmark over `queries` (images under `images`).
pub fn run(
    localiser: &mut NetworkLocaliser,
    queries: &[Query],
    images: &Path,
    config: &ScoreConfig,
    threads: &[usize],
) -> Result<LocalizeBench, ScoreError> {
    let frames: Vec<TestFrame> = queries
        .iter()
        .map(|q| {
            load_query(images, q).map_err(|reason| ScoreError::Frame {
                frame_id: q.id,
                name: q.name.clone(),
                reason,
            })
        })
        .collect::<Result<_, _>>()?;
    // The phases are SIFT's and LSD's (this bench measures the SIFT query path).
    let front_end = localiser.predictor().front_end();
    if !front_end.kind().is_sift() {
        return Err(ScoreError::Config(format!(
            "bench localize measures the SIFT front-end's phases; this model uses {}",
            front_end.kind()
        )));
    }
    let fe = front_end.config().clone();
    let names = [
        "decode",
        "SIFT detect",
        "describe points",
        "LSD detect lines",
        "describe lines",
        "describe points, then lines (the two calls above)",
        "describe points + lines, one pass",
        "network",
        "RANSAC points",
        "RANSAC points + lines",
    ];
    let mut times: Vec<Vec<f64>> = vec![Vec::new(); names.len()];
    let (mut nk, mut ns) = (0usize, 0usize);
    let (mut identical, mut localised) = (0usize, 0usize);
    let one = pool(1)?;
    one.install(|| -> Result<(), ScoreError> {
        for f in &frames {
            let t = Instant::now();
            let gray = f.gray_image()?;
            times[0].push(ms(t));
            let t = Instant::now();
            let kps: Vec<[f64; 2]> = features::detect_keypoints(&gray, &fe.sift)
                .map_err(|e| frame_err(f, e))?
                .into_iter()
                .map(|k| k.xy)
                .collect();
            times[1].push(ms(t));
            let t = Instant::now();
            let desc = features::describe_points(&gray, &kps, &fe.sift, &fe.descriptor)
                .map_err(|e| frame_err(f, e))?;
            times[2].push(ms(t));
            let t = Instant::now();
            let segs = features::detect_segments(&gray, &fe.lsd).map_err(|e| frame_err(f, e))?;
            times[3].push(ms(t));
            let t = Instant::now();
            let line_desc = features::describe_lines(
                &gray,
                &segs,
                fe.samples_per_line,
                &fe.sift,
                &fe.descriptor,
            )
            .map_err(|e| frame_err(f, e))?;
            times[4].push(ms(t));
            let t = Instant::now();
            let (fast_desc, fast_line_desc) =
                features::describe_points_and_lines(&gray, &kps, &segs, &fe)
                    .map_err(|e| frame_err(f, e))?;
            times[6].push(ms(t));
            let per_call_ms = times[2].last().unwrap() + times[4].last().unwrap();
            times[5].push(per_call_ms);
            let fast = features::extract(&gray, &fe).map_err(|e| frame_err(f, e))?;
            let same_descriptors = fast_desc == desc && fast_line_desc == line_desc;
            nk += kps.len();
            ns += segs.len();
            let per_call = features::ImageFeatures {
                keypoints: kps,
                descriptors: desc,
                segments: segs,
                line_descriptors: line_desc,
                samples_per_line: fe.samples_per_line,
                dim: features::SIFT_DIM,
            };
            let t = Instant::now();
            let pred = localiser
                .predictor()
                .predict_features(&fast)
                .map_err(|e| frame_err(f, e))?;
            times[7].push(ms(t));
            let (points, lines) = correspondences(&pred);
            let corr = Correspondences {
                points,
                lines,
                timings: vec![],
            };
            let r = localize_frame(f.frame_id(), f.name(), f.camera(), &corr, config, vec![]);
            times[8].push(r.variant(Variant::Points).ms);
            times[9].push(r.variant(Variant::PointsLines).ms);
            localised += usize::from(r.variant(Variant::PointsLines).pose.is_some());
            // The same query from the per-call features.
            let pred_ref = localiser
                .predictor()
                .predict_features(&per_call)
                .map_err(|e| frame_err(f, e))?;
            let (points, lines) = correspondences(&pred_ref);
            let corr_ref = Correspondences {
                points,
                lines,
                timings: vec![],
            };
            let r_ref = localize_frame(
                f.frame_id(),
                f.name(),
                f.camera(),
                &corr_ref,
                config,
                vec![],
            );
            let same = per_call == fast
                && same_descriptors
                && Variant::ALL
                    .iter()
                    .all(|&v| r.variant(v).pose == r_ref.variant(v).pose);
            identical += usize::from(same);
        }
        Ok(())
    })?;
    let mut latency_ms = Vec::new();
    let mut throughput = Vec::new();
    for &n in threads {
        let p = pool(n)?;
        let mut lat = Vec::new();
        for f in &frames {
            let t = Instant::now();
            let r = p.install(|| {
                localize_batch(localiser, std::slice::from_ref(f), vec![vec![]], config)
            });
            lat.push(ms(t));
            r.into_iter().next().expect("one frame")?;
        }
        latency_ms.push((n, median(lat)));
        let round = 2 * n;
        let t = Instant::now();
        for chunk in frames.chunks(round) {
            let before = vec![Vec::<Timing>::new(); chunk.len()];
            for r in p.install(|| localize_batch(localiser, chunk, before, config)) {
                r?;
            }
        }
        throughput.push((n, frames.len() as f64 / t.elapsed().as_secs_f64()));
    }
    let n = frames.len().max(1) as f64;
    Ok(LocalizeBench {
        images: frames.len(),
        mean_keypoints: nk as f64 / n,
        mean_segments: ns as f64 / n,
        phases: names
            .iter()
            .zip(times)
            .map(|(name, t)| (*name, median(t)))
            .collect(),
        latency_ms,
        throughput,
        identical_poses: identical,
        localised,
    })
}

impl LocalizeBench {
    /// The summary line a script reads (the last line of `pl2map bench localize`): the
    /// median milliseconds of one query alone on the most threads measured, e.g.
    /// `median ms per query (2 threads): 87.3`.
    pub fn median_line(&self) -> Option<String> {
        let (n, ms) = self.latency_ms.iter().max_by_key(|(n, _)| *n)?;
        Some(format!("median ms per query ({n} threads): {ms:.1}"))
    }

    /// The table, markdown.
    pub fn table(&self) -> String {
        let mut s = String::from("| phase (1 thread) | median ms |\n|---|---:|\n");
        for (name, ms) in &self.phases {
            s.push_str(&format!("| {name} | {ms:.1} |\n"));
        }
        s.push_str("\n| threads | median ms per query alone | queries/s (many queries) |\n|---:|---:|---:|\n");
        for ((n, lat), (_, qps)) in self.latency_ms.iter().zip(&self.throughput) {
            s.push_str(&format!("| {n} | {lat:.1} | {qps:.2} |\n"));
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_median_line_is_the_most_threads_latency() {
        let mut b = LocalizeBench {
            images: 3,
            mean_keypoints: 10.0,
            mean_segments: 5.0,
            phases: vec![("decode", 1.0)],
            latency_ms: vec![(1, 150.25), (2, 87.34)],
            throughput: vec![(1, 6.0), (2, 11.0)],
            identical_poses: 3,
            localised: 3,
        };
        assert_eq!(
            b.median_line().unwrap(),
            "median ms per query (2 threads): 87.3"
        );
        assert!(b.table().contains("| 2 | 87.3 | 11.00 |"));
        b.latency_ms.clear();
        assert_eq!(b.median_line(), None);
    }
}
