//! Consistency checks across the files of a LIMAP output folder.
//!
//! Every check runs and reports all its problems; [`CheckReport::is_ok`] is false when any
//! problem is an error. Warnings are kept for things LIMAP would not produce but that do
//! not make labels wrong (a listed image without a segments file, segments of an image that
//! is not listed).

use std::collections::{BTreeMap, HashMap, HashSet};

use serde::Serialize;

use crate::alltracks::ALLTRACKS_MIN_IMAGES;
use crate::image_list::ImageList;
pub use crate::problem::{Problem, Severity};
use crate::segments::Segments;
use crate::track::LineTrack;

/// Largest coordinate difference (pixels) between a track's stored 2D segment and the row
/// of the segments file it points to. LIMAP copies the detection into the track and writes
/// it with 10 decimals, so a correct pair differs by about 1e-10; a larger difference means
/// the segments are not the ones the tracks were triangulated from.
pub const LINE2D_TOLERANCE_PX: f64 = 1e-4;

/// Tolerance on endpoint coordinates between `alltracks.txt` and `finaltracks`; both are
/// written with 10 decimals from the same doubles.
pub const ALLTRACKS_TOLERANCE: f64 = 1e-9;

/// The checks, in the order they are reported.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Check {
    KnownImages,
    LineIdsInRange,
    UniqueSupports,
    Lines2dMatchSegments,
    AlltracksMatchFinaltracks,
    SegmentsMatchImageList,
}

impl Check {
    pub const ALL: [Check; 6] = [
        Check::KnownImages,
        Check::LineIdsInRange,
        Check::UniqueSupports,
        Check::Lines2dMatchSegments,
        Check::AlltracksMatchFinaltracks,
        Check::SegmentsMatchImageList,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Check::KnownImages => "known_images",
            Check::LineIdsInRange => "line_ids_in_range",
            Check::UniqueSupports => "unique_supports",
            Check::Lines2dMatchSegments => "lines2d_match_segments",
            Check::AlltracksMatchFinaltracks => "alltracks_match_finaltracks",
            Check::SegmentsMatchImageList => "segments_match_image_list",
        }
    }

    pub fn description(self) -> &'static str {
        match self {
            Check::KnownImages => "every image id of a track is in image_list.txt",
            Check::LineIdsInRange => {
                "every line id is a row of its image's segments file (which exists)"
            }
            Check::UniqueSupports => "no (image, line) support is claimed twice",
            Check::Lines2dMatchSegments => {
                "each track's 2D segments equal the rows of the segments files they point to"
            }
            Check::AlltracksMatchFinaltracks => {
                "alltracks.txt holds exactly the finaltracks seen in >= 4 images, in order"
            }
            Check::SegmentsMatchImageList => {
                "every listed image has a segments file and every segments file a listed image"
            }
        }
    }
}

/// Outcome of one check.
#[derive(Debug, Clone, PartialEq)]
pub struct CheckResult {
    pub check: Check,
    /// Why the check could not run (e.g. no alltracks.txt); `problems` is then empty.
    pub skipped: Option<&'static str>,
    pub problems: Vec<Problem>,
}

impl CheckResult {
    pub fn errors(&self) -> usize {
        self.problems
            .iter()
            .filter(|p| p.severity() == Severity::Error)
            .count()
    }

    pub fn warnings(&self) -> usize {
        self.problems.len() - self.errors()
    }
}

/// The result of every check, in [`Check::ALL`] order.
#[derive(Debug, Clone, PartialEq)]
pub struct CheckReport {
    pub results: Vec<CheckResult>,
}

impl CheckReport {
    /// True when no check found an error (warnings allowed).
    pub fn is_ok(&self) -> bool {
        self.results.iter().all(|r| r.errors() == 0)
    }

    pub fn errors(&self) -> impl Iterator<Item = &Problem> {
        self.results
            .iter()
            .flat_map(|r| &r.problems)
            .filter(|p| p.severity() == Severity::Error)
    }

    pub fn get(&self, check: Check) -> Option<&CheckResult> {
        self.results.iter().find(|r| r.check == check)
    }
}

/// Runs every check on a set of LIMAP outputs. `alltracks` is `None` when the folder has no
/// `alltracks.txt`.
pub fn check(
    image_list: &ImageList,
    segments: &BTreeMap<u32, Segments>,
    tracks: &[LineTrack],
    alltracks: Option<&[LineTrack]>,
) -> CheckReport {
    let listed: HashSet<u32> = image_list.ids().collect();
    let mut known = Vec::new();
    let mut in_range = Vec::new();
    let mut unique = Vec::new();
    let mut lines2d = Vec::new();
    let mut claimed: HashMap<(u32, u32), usize> = HashMap::new();

    for (t, track) in tracks.iter().enumerate() {
        for (s, (image_id, line_id)) in track.supports().enumerate() {
            if !listed.contains(&image_id) {
                known.push(Problem::UnknownImage {
                    track: t,
                    support: s,
                    image_id,
                });
            }
            if let Some(&first) = claimed.get(&(image_id, line_id)) {
                unique.push(Problem::DuplicateSupport {
                    image_id,
                    line_id,
                    first,
                    second: t,
                });
            } else {
                claimed.insert((image_id, line_id), t);
            }
            let Some(segs) = segments.get(&image_id) else {
                in_range.push(Problem::NoSegmentsFile {
                    track: t,
                    support: s,
                    image_id,
                });
                continue;
            };
            let Some(row) = segs.lines.get(line_id as usize) else {
                in_range.push(Problem::LineIdOutOfRange {
                    track: t,
                    support: s,
                    image_id,
                    line_id,
                    n_segments: segs.len(),
                });
                continue;
            };
            if let Some(stored) = track.lines2d.as_ref().and_then(|l| l.get(s)) {
                let diff = stored
                    .iter()
                    .zip(row)
                    .map(|(a, b)| (a - b).abs())
                    .fold(0.0, f64::max);
                if diff > LINE2D_TOLERANCE_PX {
                    lines2d.push(Problem::Line2dMismatch {
                        track: t,
                        support: s,
                        image_id,
                        line_id,
                        max_difference: diff,
                    });
                }
            }
        }
    }

    let lines2d_skipped = tracks
        .iter()
        .all(|t| t.lines2d.is_none())
        .then_some("no track stores its 2D segments (old LIMAP format)");
    let (alltracks_problems, alltracks_skipped) = match alltracks {
        Some(all) => (compare_alltracks(tracks, all), None),
        None => (Vec::new(), Some("no alltracks.txt")),
    };

    let mut coverage = Vec::new();
    for id in image_list.ids() {
        if !segments.contains_key(&id) {
            coverage.push(Problem::ImageWithoutSegments { image_id: id });
        }
    }
    for id in segments.keys() {
        if !listed.contains(id) {
            coverage.push(Problem::SegmentsOfUnlistedImage { image_id: *id });
        }
    }

    let result = |check, skipped, problems| CheckResult {
        check,
        skipped,
        problems,
    };
    CheckReport {
        results: vec![
            result(Check::KnownImages, None, known),
            result(Check::LineIdsInRange, None, in_range),
            result(Check::UniqueSupports, None, unique),
            result(Check::Lines2dMatchSegments, lines2d_skipped, lines2d),
            result(
                Check::AlltracksMatchFinaltracks,
                alltracks_skipped,
                alltracks_problems,
            ),
            result(Check::SegmentsMatchImageList, None, coverage),
        ],
    }
}

fn compare_alltracks(tracks: &[LineTrack], alltracks: &[LineTrack]) -> Vec<Problem> {
    let selected: Vec<(usize, &LineTrack)> = tracks
        .iter()
        .enumerate()
        .filter(|(_, t)| t.n_images() >= ALLTRACKS_MIN_IMAGES)
        .collect();
    let mut problems = Vec::new();
    if selected.len() != alltracks.len() {
        problems.push(Problem::AlltracksCount {
            alltracks: alltracks.len(),
            expected: selected.len(),
        });
    }
    for (k, (a, (t, f))) in alltracks.iter().zip(selected).enumerate() {
        let what = if a.image_ids != f.image_ids {
            Some("image ids differ".to_string())
        } else if a.line_ids != f.line_ids {
            Some("line ids differ".to_string())
        } else {
            let diff = a
                .line
                .iter()
                .flatten()
                .zip(f.line.iter().flatten())
                .map(|(x, y)| (x - y).abs())
                .fold(0.0, f64::max);
            (diff > ALLTRACKS_TOLERANCE).then(|| format!("endpoints differ by up to {diff:.3e}"))
        };
        if let Some(what) = what {
            problems.push(Problem::AlltracksMismatch {
                alltracks_id: k,
                track: t,
                what,
            });
        }
    }
    problems
}
