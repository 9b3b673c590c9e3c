//! A summary of a LIMAP folder for people (`Display`) and scripts (`Serialize`).

use std::fmt;

use serde::Serialize;

use crate::alltracks::ALLTRACKS_MIN_IMAGES;
use crate::check::{Check, CheckReport};
use crate::dir::{Layout, LimapDir, SegmentsOrigin};

/// How many problems of each check are spelled out.
pub const EXAMPLES_PER_CHECK: usize = 5;

#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Distribution {
    pub min: f64,
    pub mean: f64,
    /// The middle value; the mean of the two middle values for an even count.
    pub median: f64,
    pub max: f64,
}

impl Distribution {
    /// `None` for no values.
    pub fn of(values: impl IntoIterator<Item = f64>) -> Option<Self> {
        let mut v: Vec<f64> = values.into_iter().collect();
        if v.is_empty() {
            return None;
        }
        v.sort_by(f64::total_cmp);
        let n = v.len();
        let median = if n % 2 == 1 {
            v[n / 2]
        } else {
            0.5 * (v[n / 2 - 1] + v[n / 2])
        };
        Some(Distribution {
            min: v[0],
            mean: v.iter().sum::<f64>() / n as f64,
            median,
            max: v[n - 1],
        })
    }
}

#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum CheckStatus {
    Ok,
    Warning,
    Failed,
    Skipped,
}

#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CheckSummary {
    pub name: &'static str,
    pub description: &'static str,
    pub status: CheckStatus,
    pub errors: usize,
    pub warnings: usize,
    pub skipped: Option<&'static str>,
    /// The first few problems, as sentences.
    pub examples: Vec<String>,
}

#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Summary {
    pub root: String,
    pub layout: Layout,
    pub segments_dir: String,
    pub segments_origin: SegmentsOrigin,
    pub images: usize,
    pub segment_files: usize,
    pub segments: usize,
    pub finaltracks: usize,
    pub alltracks: Option<usize>,
    pub tracks_with_4_images: usize,
    pub supports_per_track: Option<Distribution>,
    pub images_per_track: Option<Distribution>,
    pub length_3d: Option<Distribution>,
    pub checks: Vec<CheckSummary>,
}

impl Summary {
    pub fn new(dir: &LimapDir, report: &CheckReport) -> Self {
        let tracks = &dir.tracks;
        let checks = Check::ALL
            .iter()
            .filter_map(|c| report.get(*c))
            .map(|r| CheckSummary {
                name: r.check.name(),
                description: r.check.description(),
                status: if r.skipped.is_some() {
                    CheckStatus::Skipped
                } else if r.errors() > 0 {
                    CheckStatus::Failed
                } else if r.warnings() > 0 {
                    CheckStatus::Warning
                } else {
                    CheckStatus::Ok
                },
                errors: r.errors(),
                warnings: r.warnings(),
                skipped: r.skipped,
                examples: r
                    .problems
                    .iter()
                    .take(EXAMPLES_PER_CHECK)
                    .map(|p| p.to_string())
                    .collect(),
            })
            .collect();
        Summary {
            root: dir.root.display().to_string(),
            layout: dir.layout,
            segments_dir: dir.segments_dir.display().to_string(),
            segments_origin: dir.segments_origin,
            images: dir.image_list.len(),
            segment_files: dir.segments.len(),
            segments: dir.segments.values().map(|s| s.len()).sum(),
            finaltracks: tracks.len(),
            alltracks: dir.alltracks.as_ref().map(Vec::len),
            tracks_with_4_images: tracks
                .iter()
                .filter(|t| t.n_images() >= ALLTRACKS_MIN_IMAGES)
                .count(),
            supports_per_track: Distribution::of(tracks.iter().map(|t| t.n_lines() as f64)),
            images_per_track: Distribution::of(tracks.iter().map(|t| t.n_images() as f64)),
            length_3d: Distribution::of(tracks.iter().map(|t| t.length())),
            checks,
        }
    }

    /// True when no check failed (warnings allowed).
    pub fn is_ok(&self) -> bool {
        self.checks.iter().all(|c| c.status != CheckStatus::Failed)
    }
}

fn dist(f: &mut fmt::Formatter<'_>, label: &str, d: &Option<Distribution>) -> fmt::Result {
    match d {
        Some(d) => writeln!(
            f,
            "  {label:<22} min {:.3}  mean {:.3}  median {:.3}  max {:.3}",
            d.min, d.mean, d.median, d.max
        ),
        None => writeln!(f, "  {label:<22} -"),
    }
}

impl fmt::Display for Summary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "LIMAP folder {} ({})", self.root, self.layout.name())?;
        let origin = match self.segments_origin {
            SegmentsOrigin::Given => "given",
            SegmentsOrigin::Detected => "auto-detected, the only candidate",
            SegmentsOrigin::Structures => "the 2D lines of structures2d.bin",
        };
        writeln!(
            f,
            "  segments folder        {} ({origin})",
            self.segments_dir
        )?;
        writeln!(f, "  images                 {}", self.images)?;
        writeln!(
            f,
            "  segment files          {} ({} segments)",
            self.segment_files, self.segments
        )?;
        match self.layout {
            Layout::Limap1 => writeln!(f, "  finaltracks            {}", self.finaltracks)?,
            Layout::Limap2 => writeln!(f, "  lines3D.bin            {}", self.finaltracks)?,
        }
        match self.alltracks {
            Some(n) if self.layout == Layout::Limap2 => {
                writeln!(f, "  alltracks (derived)    {n}")?
            }
            Some(n) => writeln!(f, "  alltracks.txt          {n}")?,
            None => writeln!(f, "  alltracks.txt          absent")?,
        }
        writeln!(f, "  tracks in >= 4 images  {}", self.tracks_with_4_images)?;
        dist(f, "supports per track", &self.supports_per_track)?;
        dist(f, "images per track", &self.images_per_track)?;
        dist(f, "3D length", &self.length_3d)?;
        writeln!(f, "checks")?;
        for c in &self.checks {
            let status = match c.status {
                CheckStatus::Ok => "ok".to_string(),
                CheckStatus::Warning => format!("warning ({})", c.warnings),
                CheckStatus::Failed => format!("FAILED ({} errors)", c.errors),
                CheckStatus::Skipped => {
                    format!("skipped: {}", c.skipped.unwrap_or_default())
                }
            };
            writeln!(f, "  {:<28} {status}", c.name)?;
            writeln!(f, "    {}", c.description)?;
            for e in &c.examples {
                writeln!(f, "    - {e}")?;
            }
            let total = c.errors + c.warnings;
            if total > c.examples.len() {
                writeln!(f, "    ... and {} more", total - c.examples.len())?;
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn distribution_by_hand() {
        let d = Distribution::of([4.0, 1.0, 3.0, 2.0]).unwrap();
        assert_eq!((d.min, d.mean, d.median, d.max), (1.0, 2.5, 2.5, 4.0));
        let d = Distribution::of([5.0, 1.0, 9.0]).unwrap();
        assert_eq!(d.median, 5.0);
        assert!(Distribution::of([]).is_none());
    }
}
