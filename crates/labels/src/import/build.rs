//! The join and the labels, in memory: frames table + COLMAP model + LIMAP folder ->
//! label tables and report, or every problem found.

use super::problems::ImportProblem;
use super::report::ImportReport;
use super::{ImportConfig, ImportError};
use crate::align::{AlignedBy, align_endpoints};
use crate::stats::Spread;
use colmap::Reconstruction;
use geometry::Camera;
use geometry::metrics::pose_error;
use limap::LimapDir;
use std::collections::{BTreeSet, HashMap};
use tables::frames::{Frame, FramesTable, Split};
use tables::labels::{LabelSource, LabelTables, LineRow, PointRow, PoseRow, PoseSource};

/// What went wrong with one source (model or LIMAP) image name.
enum NameProblem {
    Unmappable(String),
    NotInDataset(String),
    TestFrame(u32),
    /// (mapped name, id of the first source image with that name)
    Duplicate(String, u32),
}

/// Maps `(source id, source name)` to frames: frame id -> source id. Problems go
/// through `on`, which names them for its source.
fn join_names(
    entries: impl Iterator<Item = (u32, String)>,
    mapping: &crate::NameMapping,
    by_name: &HashMap<&str, &Frame>,
    allow_test: bool,
    problems: &mut Vec<ImportProblem>,
    test_skipped: &mut usize,
    on: impl Fn(u32, &str, NameProblem) -> ImportProblem,
) -> HashMap<u32, u32> {
    let mut out = HashMap::new();
    let mut seen: HashMap<String, u32> = HashMap::new();
    for (id, name) in entries {
        let mapped = match mapping.apply(&name) {
            Ok(m) => m,
            Err(reason) => {
                problems.push(on(id, &name, NameProblem::Unmappable(reason)));
                continue;
            }
        };
        if let Some(&first) = seen.get(&mapped) {
            problems.push(on(id, &name, NameProblem::Duplicate(mapped, first)));
            continue;
        }
        seen.insert(mapped.clone(), id);
        match by_name.get(mapped.as_str()) {
            None => problems.push(on(id, &name, NameProblem::NotInDataset(mapped))),
            Some(f) if f.split == Split::Test => {
                if allow_test {
                    *test_skipped += 1;
                } else {
                    problems.push(on(id, &name, NameProblem::TestFrame(f.id)));
                }
            }
            Some(f) => {
                out.insert(f.id, id);
            }
        }
    }
    out
}

fn model_problem(image_id: u32, name: &str, p: NameProblem) -> ImportProblem {
    let name = name.to_string();
    match p {
        NameProblem::Unmappable(reason) => ImportProblem::ModelNameUnmappable {
            image_id,
            name,
            reason,
        },
        NameProblem::NotInDataset(mapped) => ImportProblem::ModelImageNotInDataset {
            image_id,
            name,
            mapped,
        },
        NameProblem::TestFrame(frame_id) => ImportProblem::ModelImageIsTestFrame {
            image_id,
            name,
            frame_id,
        },
        NameProblem::Duplicate(mapped, first) => ImportProblem::DuplicateModelName {
            mapped,
            first_image_id: first,
            second_image_id: image_id,
        },
    }
}

fn limap_problem(limap_image_id: u32, name: &str, p: NameProblem) -> ImportProblem {
    let name = name.to_string();
    match p {
        NameProblem::Unmappable(reason) => ImportProblem::LimapNameUnmappable {
            limap_image_id,
            name,
            reason,
        },
        NameProblem::NotInDataset(mapped) => ImportProblem::LimapImageNotInDataset {
            limap_image_id,
            name,
            mapped,
        },
        NameProblem::TestFrame(frame_id) => ImportProblem::LimapImageIsTestFrame {
            limap_image_id,
            name,
            frame_id,
        },
        NameProblem::Duplicate(mapped, first) => ImportProblem::DuplicateLimapName {
            mapped,
            first_limap_image_id: first,
            second_limap_image_id: limap_image_id,
        },
    }
}

fn same_camera(a: &Camera, b: &Camera) -> bool {
    a.model == b.model
        && a.params.len() == b.params.len()
        && a.params
            .iter()
            .zip(&b.params)
            .all(|(x, y)| (x - y).abs() <= 1e-6 * x.abs().max(1.0))
}

fn inside(xy: [f64; 2], size: (u64, u64), tol: f64) -> bool {
    xy[0] >= -tol && xy[1] >= -tol && xy[0] <= size.0 as f64 + tol && xy[1] <= size.1 as f64 + tol
}

/// How far (pixels) `xy` lies outside the image; 0 inside.
fn overshoot(xy: [f64; 2], size: (u64, u64)) -> f64 {
    (-xy[0])
        .max(-xy[1])
        .max(xy[0] - size.0 as f64)
        .max(xy[1] - size.1 as f64)
        .max(0.0)
}

fn degenerate(line: &[[f64; 3]; 2]) -> bool {
    let finite = line.iter().flatten().all(|v| v.is_finite());
    let len2: f64 = (0..3).map(|k| (line[1][k] - line[0][k]).powi(2)).sum();
    !finite || len2 < 1e-18
}

/// The label tables and report of an import, or every problem of its inputs.
pub fn build(
    config: &ImportConfig,
    frames: &FramesTable,
    frames_sha256: &str,
    model: &Reconstruction,
    limap: &LimapDir,
) -> Result<(LabelTables, ImportReport), ImportError> {
    config.validate()?;
    let mut problems = Vec::new();
    let train: Vec<&Frame> = frames
        .frames
        .iter()
        .filter(|f| f.split == Split::Train)
        .collect();
    if train.is_empty() {
        problems.push(ImportProblem::NoTrainingFrames);
    }
    let by_name: HashMap<&str, &Frame> =
        frames.frames.iter().map(|f| (f.name.as_str(), f)).collect();
    let mut report = ImportReport {
        config: config.clone(),
        frames_sha256: frames_sha256.to_string(),
        train_frames: train.len(),
        test_frames: frames.count(Split::Test),
        ..Default::default()
    };
    report.model.cameras = model.cameras.len();
    report.model.images = model.images.len();
    report.model.points3d = model.points3d.len();
    report.limap.images = limap.image_list.len();
    report.limap.tracks = limap.tracks.len();

    let model_of = join_names(
        model.images.iter().map(|im| (im.image_id, im.name.clone())),
        &config.model_names,
        &by_name,
        config.allow_test_images,
        &mut problems,
        &mut report.model.test_images_skipped,
        model_problem,
    );
    let limap_of = join_names(
        limap.image_list.images.iter().cloned(),
        &config.limap_names,
        &by_name,
        config.allow_test_images,
        &mut problems,
        &mut report.limap.test_images_skipped,
        limap_problem,
    );
    for f in &train {
        if !model_of.contains_key(&f.id) {
            problems.push(ImportProblem::TrainFrameNotInModel {
                frame_id: f.id,
                name: f.name.clone(),
            });
        }
        match limap_of.get(&f.id) {
            None => problems.push(ImportProblem::TrainFrameNotInLimap {
                frame_id: f.id,
                name: f.name.clone(),
            }),
            Some(lid) if !limap.segments.contains_key(lid) => {
                problems.push(ImportProblem::TrainFrameWithoutSegments {
                    frame_id: f.id,
                    name: f.name.clone(),
                    limap_image_id: *lid,
                })
            }
            Some(_) => {}
        }
    }
    let check = limap.check();
    let mut unlisted_segments = 0;
    for p in check.results.iter().flat_map(|r| &r.problems) {
        match ImportProblem::from_limap(p) {
            Some(ip) if p.severity() == limap::Severity::Error => problems.push(ip),
            _ => {
                if matches!(p, limap::Problem::SegmentsOfUnlistedImage { .. }) {
                    unlisted_segments += 1;
                }
            }
        }
    }
    if unlisted_segments > 0 {
        report.warnings.push(format!(
            "{unlisted_segments} segments file(s) belong to no image of LIMAP's image_list.txt (ignored)"
        ));
    }

    // (LIMAP image id, line id) -> track; a second claim was reported above.
    let mut supports: HashMap<(u32, u32), usize> = HashMap::new();
    for (t, track) in limap.tracks.iter().enumerate() {
        for s in track.supports() {
            supports.entry(s).or_insert(t);
        }
    }
    let index = model.index();
    let mut tables = LabelTables {
        source: LabelSource::Sfm,
        pose_source: config.pose_source,
        frames_sha256: frames_sha256.to_string(),
        // Recorded only when not the default (the tables' metadata, then the shards'
        // manifest).
        line_tracks: (config.line_tracks != super::LineTrackSet::Finaltracks)
            .then(|| config.line_tracks.as_str().to_string()),
        points: Vec::new(),
        lines: Vec::new(),
        poses: Vec::new(),
    };
    let mut translations = Vec::new();
    let mut rotations = Vec::new();
    let mut worst: Option<(f64, String)> = None;
    let mut points3d_seen = BTreeSet::new();
    let mut tracks_seen = BTreeSet::new();
    let tol = config.bounds_tolerance_px;
    let bar = stage::progress_bar(train.len() as u64, "import");
    for f in &train {
        bar.inc(1);
        let (Some(&image_id), Some(&lid)) = (model_of.get(&f.id), limap_of.get(&f.id)) else {
            continue;
        };
        let Some(image) = index.images.get(&image_id).map(|&i| &model.images[i]) else {
            continue;
        };
        let Some(sfm_camera) = index
            .cameras
            .get(&image.camera_id)
            .map(|&i| &model.cameras[i].camera)
        else {
            problems.push(ImportProblem::UnknownCamera {
                image_id,
                camera_id: image.camera_id,
            });
            continue;
        };
        let size = (sfm_camera.width, sfm_camera.height);
        if size != (u64::from(f.width), u64::from(f.height)) {
            problems.push(ImportProblem::CameraSizeMismatch {
                frame_id: f.id,
                name: f.name.clone(),
                model: size,
                frame: (f.width, f.height),
            });
            continue;
        }
        let sfm_pose = match image.pose() {
            Ok(p) => p,
            Err(e) => {
                problems.push(ImportProblem::InvalidModelPose {
                    image_id,
                    reason: e.to_string(),
                });
                continue;
            }
        };
        let e = pose_error(&f.pose, &sfm_pose);
        translations.push(e.translation_m);
        rotations.push(e.rotation_deg);
        if worst.as_ref().is_none_or(|(w, _)| e.translation_m > *w) {
            worst = Some((
                e.translation_m,
                format!(
                    "{} ({:.2} cm, {:.3} deg)",
                    f.name,
                    e.translation_cm(),
                    e.rotation_deg
                ),
            ));
        }
        if !same_camera(sfm_camera, &f.camera) {
            report.intrinsics_differ += 1;
            if report.intrinsics_example.is_none() {
                report.intrinsics_example = Some(format!(
                    "{}: model {} {:?}, frames table {} {:?}",
                    f.name, sfm_camera.model, sfm_camera.params, f.camera.model, f.camera.params
                ));
            }
        }
        if lid != image_id {
            report.limap.ids_differ_from_model += 1;
        }
        let (camera, pose) = match config.pose_source {
            PoseSource::Sfm => (sfm_camera.clone(), sfm_pose),
            PoseSource::Dataset => (f.camera.clone(), f.pose),
        };

        let mut outside: Vec<usize> = Vec::new();
        for (k, p) in image.points2d.iter().enumerate() {
            if !inside(p.xy, size, tol) {
                outside.push(k);
            }
            report.points.keypoints += 1;
            let (point3d_id, xyz) = if p.has_point3d() {
                match (
                    index.points3d.get(&p.point3d_id),
                    i64::try_from(p.point3d_id),
                ) {
                    (Some(&i), Ok(id)) => {
                        points3d_seen.insert(p.point3d_id);
                        (id, Some(model.points3d[i].xyz))
                    }
                    _ => {
                        problems.push(ImportProblem::UnknownPoint3d {
                            image_id,
                            kp_index: k,
                            point3d_id: p.point3d_id,
                        });
                        (-1, None)
                    }
                }
            } else {
                report.points.without_point3d += 1;
                (-1, None)
            };
            report.points.valid += usize::from(xyz.is_some());
            tables.points.push(PointRow {
                frame_id: f.id,
                kp_index: k as u32,
                xy: p.xy,
                point3d_id,
                xyz,
            });
        }
        if let Some(&first_index) = outside.first() {
            problems.push(ImportProblem::KeypointsOutsideImage {
                frame_id: f.id,
                name: f.name.clone(),
                count: outside.len(),
                first_index,
                first: image.points2d[first_index].xy,
                size,
            });
        }

        if let Some(segs) = limap.segments.get(&lid) {
            let mut outside: Vec<(usize, [f64; 4])> = Vec::new();
            let mut max_overshoot_px = 0.0_f64;
            for (k, s) in segs.lines.iter().enumerate() {
                let seg = s.map(|v| v * config.segment_scale);
                if !(inside([seg[0], seg[1]], size, tol) && inside([seg[2], seg[3]], size, tol)) {
                    outside.push((k, seg));
                    max_overshoot_px = max_overshoot_px
                        .max(overshoot([seg[0], seg[1]], size))
                        .max(overshoot([seg[2], seg[3]], size));
                }
                report.lines.segments += 1;
                let track = supports.get(&(lid, k as u32)).copied();
                let mut row = LineRow {
                    frame_id: f.id,
                    seg_index: k as u32,
                    segment: seg,
                    track_id: track.map_or(-1, |t| t as i64),
                    endpoints: None,
                    swapped: false,
                };
                match track {
                    None => report.lines.in_no_track += 1,
                    Some(t) if degenerate(&limap.tracks[t].line) => {
                        report.lines.degenerate_track += 1
                    }
                    Some(t) => {
                        tracks_seen.insert(t);
                        let (ends, swapped, by) =
                            align_endpoints(&camera, &pose, &seg, &limap.tracks[t].line);
                        row.endpoints = Some(ends);
                        row.swapped = swapped;
                        let l = &mut report.lines;
                        l.valid += 1;
                        l.swapped += usize::from(swapped);
                        match by {
                            AlignedBy::Projection => l.aligned_by_projection += 1,
                            AlignedBy::Rays => l.aligned_by_rays += 1,
                            AlignedBy::Undecided => l.order_undecided += 1,
                        }
                    }
                }
                tables.lines.push(row);
            }
            if let Some(&(first_index, first)) = outside.first() {
                problems.push(ImportProblem::SegmentsOutsideImage {
                    frame_id: f.id,
                    name: f.name.clone(),
                    count: outside.len(),
                    first_index,
                    first,
                    size,
                    max_overshoot_px,
                });
            }
        }
        report.model.images_used += 1;
        tables.poses.push(PoseRow {
            frame_id: f.id,
            name: f.name.clone(),
            sfm_image_id: image_id,
            limap_image_id: lid,
            camera,
            pose,
        });
    }
    bar.finish_and_clear();

    if !problems.is_empty() {
        let mut hints = Vec::new();
        let unmatched = problems.iter().any(|p| {
            matches!(
                p,
                ImportProblem::ModelImageNotInDataset { .. }
                    | ImportProblem::LimapImageNotInDataset { .. }
            )
        });
        if unmatched {
            let examples: Vec<String> = train
                .iter()
                .take(3)
                .map(|f| format!("{:?}", f.name))
                .collect();
            hints.push(format!(
                "frames table names look like {}; model names mapping: {}; LIMAP names mapping: {}",
                examples.join(", "),
                config.model_names,
                config.limap_names
            ));
        }
        return Err(ImportError::Inconsistent { problems, hints });
    }

    report.points.points3d_observed = points3d_seen.len();
    report.limap.tracks_used = tracks_seen.len();
    report.pose_disagreement.translation_m = Spread::of(&translations);
    report.pose_disagreement.rotation_deg = Spread::of(&rotations);
    report.pose_disagreement.worst_frame = worst.map(|(_, s)| s);
    if report.limap.ids_differ_from_model > 0 {
        report.warnings.push(format!(
            "{} training frame(s) have a LIMAP image id different from their COLMAP image id \
             (joined by name; LIMAP built from this model would keep COLMAP's ids)",
            report.limap.ids_differ_from_model
        ));
    }
    tables.sort();
    Ok((tables, report))
}
