//! The labels of the joined training frames, frame by frame: the points of the model
//! image, the segments of the LIMAP image with their tracks' endpoints, the camera and
//! pose they go with; the problems each frame shows, and the report's counts.

use super::config::{ImportConfig, LineTrackSet};
use super::problems::ImportProblem;
use super::report::ImportReport;
use crate::align::{AlignedBy, align_endpoints};
use crate::stats::Spread;
use colmap::{Image, ModelIndex, Reconstruction};
use geometry::metrics::pose_error;
use geometry::{Camera, Pose};
use limap::LimapDir;
use std::collections::{BTreeSet, HashMap};
use tables::frames::Frame;
use tables::labels::{LabelSource, LabelTables, LineRow, PointRow, PoseRow, PoseSource};

/// The import's state while it labels the training frames in frame order.
pub(super) struct Labelling<'a> {
    config: &'a ImportConfig,
    model: &'a Reconstruction,
    index: ModelIndex<'a>,
    limap: &'a LimapDir,
    /// (LIMAP image id, line id) -> track; a second claim is a LIMAP problem already.
    supports: HashMap<(u32, u32), usize>,
    pub(super) problems: Vec<ImportProblem>,
    pub(super) report: ImportReport,
    tables: LabelTables,
    /// SfM pose against the frames table's pose, per labelled frame.
    translations: Vec<f64>,
    rotations: Vec<f64>,
    worst: Option<(f64, String)>,
    points3d_seen: BTreeSet<u64>,
    tracks_seen: BTreeSet<usize>,
}

/// A frame's model image with the camera and pose the model gives it.
struct ModelView<'a> {
    image_id: u32,
    image: &'a Image,
    camera: &'a Camera,
    pose: Pose,
}

impl<'a> Labelling<'a> {
    pub(super) fn new(
        config: &'a ImportConfig,
        model: &'a Reconstruction,
        limap: &'a LimapDir,
        frames_sha256: &str,
        problems: Vec<ImportProblem>,
        report: ImportReport,
    ) -> Self {
        let mut supports: HashMap<(u32, u32), usize> = HashMap::new();
        for (t, track) in limap.tracks.iter().enumerate() {
            for s in track.supports() {
                supports.entry(s).or_insert(t);
            }
        }
        let tables = LabelTables {
            source: LabelSource::Sfm,
            pose_source: config.pose_source,
            frames_sha256: frames_sha256.to_string(),
            // Recorded only when not the default (the tables' metadata, then the shards'
            // manifest).
            line_tracks: (config.line_tracks != LineTrackSet::Finaltracks)
                .then(|| config.line_tracks.as_str().to_string()),
            points: Vec::new(),
            lines: Vec::new(),
            poses: Vec::new(),
        };
        Labelling {
            config,
            model,
            index: model.index(),
            limap,
            supports,
            problems,
            report,
            tables,
            translations: Vec::new(),
            rotations: Vec::new(),
            worst: None,
            points3d_seen: BTreeSet::new(),
            tracks_seen: BTreeSet::new(),
        }
    }

    /// Labels training frame `f`, joined to model image `image_id` and LIMAP image `lid`.
    pub(super) fn frame(&mut self, f: &Frame, image_id: u32, lid: u32) {
        let Some(view) = self.model_view(f, image_id) else {
            return;
        };
        let size = (view.camera.width, view.camera.height);
        self.compare_with_model(f, &view);
        if lid != image_id {
            self.report.limap.ids_differ_from_model += 1;
        }
        let (camera, pose) = match self.config.pose_source {
            PoseSource::Sfm => (view.camera.clone(), view.pose),
            PoseSource::Dataset => (f.camera.clone(), f.pose),
        };
        self.points(f, &view, size);
        self.lines(f, lid, size, &camera, &pose);
        self.report.model.images_used += 1;
        self.tables.poses.push(PoseRow {
            frame_id: f.id,
            name: f.name.clone(),
            sfm_image_id: image_id,
            limap_image_id: lid,
            camera,
            pose,
        });
    }

    /// The model's image, camera and pose of `f`, or None with the problem recorded (an
    /// unknown camera, another image size, an invalid pose).
    fn model_view(&mut self, f: &Frame, image_id: u32) -> Option<ModelView<'a>> {
        let model = self.model;
        let image = &model.images[*self.index.images.get(&image_id)?];
        let Some(&camera_index) = self.index.cameras.get(&image.camera_id) else {
            self.problems.push(ImportProblem::UnknownCamera {
                image_id,
                camera_id: image.camera_id,
            });
            return None;
        };
        let camera = &model.cameras[camera_index].camera;
        let size = (camera.width, camera.height);
        if size != (u64::from(f.width), u64::from(f.height)) {
            self.problems.push(ImportProblem::CameraSizeMismatch {
                frame_id: f.id,
                name: f.name.clone(),
                model: size,
                frame: (f.width, f.height),
            });
            return None;
        }
        match image.pose() {
            Ok(pose) => Some(ModelView {
                image_id,
                image,
                camera,
                pose,
            }),
            Err(e) => {
                self.problems.push(ImportProblem::InvalidModelPose {
                    image_id,
                    reason: e.to_string(),
                });
                None
            }
        }
    }

    /// The report's pose disagreement and intrinsics difference of `f` against the model.
    fn compare_with_model(&mut self, f: &Frame, view: &ModelView) {
        let e = pose_error(&f.pose, &view.pose);
        self.translations.push(e.translation_m);
        self.rotations.push(e.rotation_deg);
        if self
            .worst
            .as_ref()
            .is_none_or(|(w, _)| e.translation_m > *w)
        {
            self.worst = Some((
                e.translation_m,
                format!(
                    "{} ({:.2} cm, {:.3} deg)",
                    f.name,
                    e.translation_cm(),
                    e.rotation_deg
                ),
            ));
        }
        let sfm_camera = view.camera;
        if !same_camera(sfm_camera, &f.camera) {
            self.report.intrinsics_differ += 1;
            if self.report.intrinsics_example.is_none() {
                self.report.intrinsics_example = Some(format!(
                    "{}: model {} {:?}, frames table {} {:?}",
                    f.name, sfm_camera.model, sfm_camera.params, f.camera.model, f.camera.params
                ));
            }
        }
    }

    /// A point row per keypoint of the model image: its 3D point, or no label.
    fn points(&mut self, f: &Frame, view: &ModelView, size: (u64, u64)) {
        let model = self.model;
        let tol = self.config.bounds_tolerance_px;
        let mut outside: Vec<usize> = Vec::new();
        for (k, p) in view.image.points2d.iter().enumerate() {
            if !inside(p.xy, size, tol) {
                outside.push(k);
            }
            self.report.points.keypoints += 1;
            let (point3d_id, xyz) = if p.has_point3d() {
                match (
                    self.index.points3d.get(&p.point3d_id),
                    i64::try_from(p.point3d_id),
                ) {
                    (Some(&i), Ok(id)) => {
                        self.points3d_seen.insert(p.point3d_id);
                        (id, Some(model.points3d[i].xyz))
                    }
                    _ => {
                        self.problems.push(ImportProblem::UnknownPoint3d {
                            image_id: view.image_id,
                            kp_index: k,
                            point3d_id: p.point3d_id,
                        });
                        (-1, None)
                    }
                }
            } else {
                self.report.points.without_point3d += 1;
                (-1, None)
            };
            self.report.points.valid += usize::from(xyz.is_some());
            self.tables.points.push(PointRow {
                frame_id: f.id,
                kp_index: k as u32,
                xy: p.xy,
                point3d_id,
                xyz,
            });
        }
        if let Some(&first_index) = outside.first() {
            self.problems.push(ImportProblem::KeypointsOutsideImage {
                frame_id: f.id,
                name: f.name.clone(),
                count: outside.len(),
                first_index,
                first: view.image.points2d[first_index].xy,
                size,
            });
        }
    }

    /// A line row per segment of LIMAP image `lid` (times the segment scale): the
    /// endpoints of the track that lists it, ordered to follow it, or no label.
    fn lines(&mut self, f: &Frame, lid: u32, size: (u64, u64), camera: &Camera, pose: &Pose) {
        let limap = self.limap;
        let Some(segs) = limap.segments.get(&lid) else {
            return;
        };
        let tol = self.config.bounds_tolerance_px;
        let mut outside: Vec<(usize, [f64; 4])> = Vec::new();
        let mut max_overshoot_px = 0.0_f64;
        for (k, s) in segs.lines.iter().enumerate() {
            let seg = s.map(|v| v * self.config.segment_scale);
            if !(inside([seg[0], seg[1]], size, tol) && inside([seg[2], seg[3]], size, tol)) {
                outside.push((k, seg));
                max_overshoot_px = max_overshoot_px
                    .max(overshoot([seg[0], seg[1]], size))
                    .max(overshoot([seg[2], seg[3]], size));
            }
            self.report.lines.segments += 1;
            let track = self.supports.get(&(lid, k as u32)).copied();
            let mut row = LineRow {
                frame_id: f.id,
                seg_index: k as u32,
                segment: seg,
                track_id: track.map_or(-1, |t| t as i64),
                endpoints: None,
                swapped: false,
            };
            match track {
                None => self.report.lines.in_no_track += 1,
                Some(t) if degenerate(&limap.tracks[t].line) => {
                    self.report.lines.degenerate_track += 1
                }
                Some(t) => {
                    self.tracks_seen.insert(t);
                    let (ends, swapped, by) =
                        align_endpoints(camera, pose, &seg, &limap.tracks[t].line);
                    row.endpoints = Some(ends);
                    row.swapped = swapped;
                    let l = &mut self.report.lines;
                    l.valid += 1;
                    l.swapped += usize::from(swapped);
                    match by {
                        AlignedBy::Projection => l.aligned_by_projection += 1,
                        AlignedBy::Rays => l.aligned_by_rays += 1,
                        AlignedBy::Undecided => l.order_undecided += 1,
                    }
                }
            }
            self.tables.lines.push(row);
        }
        if let Some(&(first_index, first)) = outside.first() {
            self.problems.push(ImportProblem::SegmentsOutsideImage {
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

    /// The tables (sorted) and the report with its summaries, or every problem found.
    pub(super) fn finish(self) -> Result<(LabelTables, ImportReport), Vec<ImportProblem>> {
        if !self.problems.is_empty() {
            return Err(self.problems);
        }
        let (mut tables, mut report) = (self.tables, self.report);
        report.points.points3d_observed = self.points3d_seen.len();
        report.limap.tracks_used = self.tracks_seen.len();
        report.pose_disagreement.translation_m = Spread::of(&self.translations);
        report.pose_disagreement.rotation_deg = Spread::of(&self.rotations);
        report.pose_disagreement.worst_frame = self.worst.map(|(_, s)| s);
        if report.limap.ids_differ_from_model > 0 {
            // LIMAP 1.x numbered its images by position (the list form of image_list.txt,
            // crates/limap/src/image_list.rs): its ids differ from COLMAP's by design.
            let by_position = self
                .limap
                .image_list
                .ids()
                .enumerate()
                .all(|(k, id)| id as usize == k);
            report.warnings.push(if by_position {
                format!(
                    "{} training frame(s) have a LIMAP image id different from their COLMAP \
                     image id (joined by name; LIMAP numbers these images by position from \
                     0, as LIMAP 1.x did)",
                    report.limap.ids_differ_from_model
                )
            } else {
                format!(
                    "{} training frame(s) have a LIMAP image id different from their COLMAP \
                     image id (joined by name; LIMAP built from this model would keep \
                     COLMAP's ids)",
                    report.limap.ids_differ_from_model
                )
            });
        }
        tables.sort();
        Ok((tables, report))
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
