//! An analytic scene for the label and shard stages' tests: a box-shaped room seen by
//! pinhole cameras from inside, points and line segments painted on its walls and floor,
//! exact depth maps rendered by ray casting, and the inputs the stages read written from
//! it with the project's own writers (COLMAP model, LIMAP folder, frames table, images,
//! 16-bit depth PNGs). Every label is known exactly, so every check is exact.

use colmap::{CameraRecord, Point2D, Point3D, Reconstruction, TrackElement};
use geometry::{Camera, CameraModel, Pose, UnitQuaternion, Vector2, Vector3};
use limap::{ImageList, LineTrack, Segments};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use tables::frames::{Frame, FramesTable, IngestMeta, Split};

/// Half extents of the room: x in [-2, 2], y in [-1.5, 1.5] (y down, floor at +1.5),
/// z in [-2, 2].
pub const ROOM: [f64; 3] = [2.0, 1.5, 2.0];
pub const WIDTH: u32 = 640;
pub const HEIGHT: u32 = 480;
pub const F: f64 = 525.0;
/// Keypoints and segment endpoints are kept this far inside the image.
const MARGIN: f64 = 4.0;

#[derive(Clone, Debug)]
pub struct SceneOptions {
    pub n_train: usize,
    pub n_test: usize,
    /// Standard deviation (metres) of the Gaussian noise added to each coordinate of
    /// the SfM points and LIMAP endpoints (the ground truth stays exact).
    pub noise_sigma_m: f64,
    /// Standard deviation (millimetres) of Gaussian noise on every depth pixel.
    pub depth_noise_mm: f64,
    /// Standard deviation (pixels) of Gaussian noise on the COLMAP keypoints and the
    /// LIMAP segment endpoints (the detections; the 3D truth stays exact).
    pub detection_noise_px: f64,
    pub seed: u64,
}

impl Default for SceneOptions {
    fn default() -> Self {
        SceneOptions {
            n_train: 8,
            n_test: 3,
            noise_sigma_m: 0.0,
            depth_noise_mm: 0.0,
            detection_noise_px: 0.0,
            seed: 1,
        }
    }
}

pub fn camera() -> Camera {
    Camera::new(
        CameraModel::SimplePinhole,
        u64::from(WIDTH),
        u64::from(HEIGHT),
        vec![F, WIDTH as f64 / 2.0, HEIGHT as f64 / 2.0],
    )
    .unwrap()
}

/// World-to-camera pose of a camera at `c` turned by `yaw` about the world y axis and
/// `pitch` about its own x axis (looking along +z at yaw 0).
pub fn pose_at(c: Vector3<f64>, yaw: f64, pitch: f64) -> Pose {
    let c2w = UnitQuaternion::from_axis_angle(&Vector3::y_axis(), yaw)
        * UnitQuaternion::from_axis_angle(&Vector3::x_axis(), pitch);
    let r = c2w.inverse();
    Pose::new(r, -(r * c))
}

/// Distance along a ray (unit z in the camera frame, so also the z-depth) from the
/// camera centre to the room's walls.
pub fn depth_at(pose: &Pose, cam: &Camera, px: Vector2<f64>) -> f64 {
    let ray_cam = cam.unproject(&px).unwrap();
    let ray_cam = ray_cam / ray_cam.z;
    let c = pose.centre();
    let d = pose.rotation.inverse() * ray_cam;
    (0..3)
        .filter(|&k| d[k] != 0.0)
        .map(|k| {
            let bound = if d[k] > 0.0 { ROOM[k] } else { -ROOM[k] };
            (bound - c[k]) / d[k]
        })
        .fold(f64::INFINITY, f64::min)
}

/// The exact 3D points of the scene: a grid on the far wall (z = 2), on the floor and on
/// the right wall.
fn scene_points() -> Vec<[f64; 3]> {
    let mut p = Vec::new();
    for i in 0..11 {
        for j in 0..7 {
            p.push([
                -1.5 + 0.3 * i as f64 + 0.01 * j as f64,
                -0.9 + 0.3 * j as f64,
                ROOM[2],
            ]);
        }
    }
    for i in 0..8 {
        for k in 0..4 {
            p.push([-1.2 + 0.33 * i as f64, ROOM[1], 1.0 + 0.3 * k as f64]);
        }
    }
    for j in 0..5 {
        for k in 0..4 {
            p.push([ROOM[0], -0.8 + 0.35 * j as f64, 0.4 + 0.4 * k as f64]);
        }
    }
    p
}

/// The exact 3D segments: on the far wall and the floor.
fn scene_segments() -> Vec<[[f64; 3]; 2]> {
    let mut s = Vec::new();
    for i in 0..5 {
        for j in 0..3 {
            let x = -1.3 + 0.6 * i as f64;
            let y = -0.8 + 0.6 * j as f64;
            s.push([[x, y, ROOM[2]], [x + 0.4, y + 0.05, ROOM[2]]]);
            s.push([[x + 0.05, y + 0.1, ROOM[2]], [x + 0.02, y + 0.45, ROOM[2]]]);
        }
    }
    for i in 0..4 {
        let x = -0.9 + 0.5 * i as f64;
        s.push([[x, ROOM[1], 1.3], [x + 0.2, ROOM[1], 1.85]]);
    }
    s
}

pub struct Scene {
    pub dir: tempfile::TempDir,
    pub frames_path: PathBuf,
    pub model_dir: PathBuf,
    pub limap_dir: PathBuf,
    pub table: FramesTable,
    pub model: Reconstruction,
    pub image_list: ImageList,
    pub segments: BTreeMap<u32, Segments>,
    pub tracks: Vec<LineTrack>,
    /// point3D id -> exact position.
    pub gt_points: BTreeMap<u64, [f64; 3]>,
    /// Track index -> exact endpoints, in the track file's order.
    pub gt_tracks: Vec<[[f64; 3]; 2]>,
    /// (LIMAP image id, line id) -> whether the 2D segment runs from the track's second
    /// endpoint to its first.
    pub reversed: BTreeMap<(u32, u32), bool>,
}

fn gauss(rng: &mut ChaCha8Rng) -> f64 {
    // Box-Muller.
    let u1: f64 = rng.random::<f64>().max(1e-300);
    let u2: f64 = rng.random();
    (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
}

fn inside(px: &Vector2<f64>) -> bool {
    px.x >= MARGIN
        && px.y >= MARGIN
        && px.x <= WIDTH as f64 - MARGIN
        && px.y <= HEIGHT as f64 - MARGIN
}

fn project(pose: &Pose, cam: &Camera, x: &[f64; 3]) -> Option<Vector2<f64>> {
    let pc = pose.transform_point(&Vector3::from(*x));
    if pc.z <= 0.1 {
        return None;
    }
    cam.project(&pc).filter(inside)
}

pub fn frame_name(split: Split, i: usize) -> String {
    match split {
        Split::Train => format!("seq-01/frame-{i:06}.color.png"),
        Split::Test => format!("seq-02/frame-{i:06}.color.png"),
    }
}

/// A smooth colour image of the scene's size (its pixels are never read, only its bytes
/// and size).
fn write_png_rgb(path: &Path, seed: u32) {
    let img = image::RgbImage::from_fn(WIDTH, HEIGHT, |x, y| {
        image::Rgb([(x / 8) as u8, (y / 8) as u8, (seed * 40) as u8])
    });
    crate::images::save(path, &img);
}

/// The exact depth map (millimetres, 16-bit PNG) of the camera at `pose`, with
/// `noise_mm` Gaussian noise per pixel.
pub fn write_depth(path: &Path, pose: &Pose, cam: &Camera, noise_mm: f64, seed: u64) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    crate::images::write_depth(path, WIDTH, HEIGHT, |x, y| {
        let d = depth_at(pose, cam, Vector2::new(x as f64 + 0.5, y as f64 + 0.5));
        let noise = if noise_mm > 0.0 {
            noise_mm * gauss(&mut rng)
        } else {
            0.0
        };
        (d * 1000.0 + noise).round() as u16
    });
}

impl Scene {
    /// `config` reading this scene's COLMAP model and LIMAP folder.
    pub fn with_inputs(
        &self,
        config: &labels::import::ImportConfig,
    ) -> labels::import::ImportConfig {
        // The scene's keypoints and segments are drawn, not detected in its images (smooth
        // gradients): the detector check would refuse them, so it is off here (its tests
        // use the synthetic scene, crates/labels/tests/detector_check.rs).
        labels::import::ImportConfig {
            model: Some(self.model_dir.clone()),
            limap: Some(self.limap_dir.clone()),
            detector_check: labels::import::DetectorCheck::Off,
            ..config.clone()
        }
    }

    pub fn build(opts: &SceneOptions) -> Scene {
        let dir = tempfile::tempdir().unwrap();
        let root = dir.path().to_path_buf();
        let cam = camera();
        let mut rng = ChaCha8Rng::seed_from_u64(opts.seed);

        // Frames: training cameras spread in front of the far wall, test ones in between.
        let mut frames = Vec::new();
        let mut id = 0u32;
        for (split, n) in [(Split::Train, opts.n_train), (Split::Test, opts.n_test)] {
            for i in 0..n {
                let s = (i as f64 + if split == Split::Test { 0.5 } else { 0.0 }) / n.max(1) as f64;
                let c = Vector3::new(-0.6 + 1.2 * s, 0.15 * (3.0 * s).sin(), -0.9 + 0.4 * s);
                let yaw = (-18.0 + 36.0 * s).to_radians();
                let pitch = (8.0 * (5.0 * s).cos()).to_radians();
                let pose = pose_at(c, yaw, pitch);
                let name = frame_name(split, i);
                let path = root.join("dataset").join(&name);
                write_png_rgb(&path, id);
                let depth_path = root.join("depth").join(format!("{id:05}.depth.png"));
                write_depth(
                    &depth_path,
                    &pose,
                    &cam,
                    opts.depth_noise_mm,
                    opts.seed ^ u64::from(id),
                );
                frames.push(Frame {
                    id,
                    name,
                    content_hash: stage::sha256_file(&path).unwrap(),
                    path,
                    split,
                    camera: cam.clone(),
                    pose,
                    depth_hash: Some(stage::sha256_file(&depth_path).unwrap()),
                    depth_path: Some(depth_path),
                    width: WIDTH,
                    height: HEIGHT,
                });
                id += 1;
            }
        }
        let table = FramesTable {
            frames,
            meta: IngestMeta {
                dataset: "analytic".into(),
                scene: "box".into(),
                root: root.join("dataset").display().to_string(),
                pose_source: "analytic".into(),
                depth_source: "rendered: analytic ray casting".into(),
                depth_units_per_metre: Some(1000.0),
                intrinsics: "SIMPLE_PINHOLE 640 480 525 320 240".into(),
                excluded: Vec::new(),
            },
        };
        let train: Vec<&Frame> = table
            .frames
            .iter()
            .filter(|f| f.split == Split::Train)
            .collect();

        // COLMAP model: image id = position + 1; a few keypoints without a 3D point.
        let mut points2d: Vec<Vec<Point2D>> = vec![Vec::new(); train.len()];
        let mut points3d = Vec::new();
        let mut gt_points = BTreeMap::new();
        for x in scene_points() {
            let obs: Vec<(usize, Vector2<f64>)> = train
                .iter()
                .enumerate()
                .filter_map(|(k, f)| project(&f.pose, &cam, &x).map(|px| (k, px)))
                .collect();
            if obs.len() < 2 {
                continue;
            }
            let pid = points3d.len() as u64 + 1;
            let mut track = Vec::new();
            for (k, px) in obs {
                track.push(TrackElement {
                    image_id: k as u32 + 1,
                    point2d_idx: points2d[k].len() as u32,
                });
                let n = opts.detection_noise_px;
                points2d[k].push(Point2D {
                    xy: [px.x + n * gauss(&mut rng), px.y + n * gauss(&mut rng)],
                    point3d_id: pid,
                });
            }
            let noisy = x.map(|v| v + opts.noise_sigma_m * gauss(&mut rng));
            gt_points.insert(pid, x);
            points3d.push(Point3D {
                id: pid,
                xyz: noisy,
                rgb: [128, 128, 128],
                error: 0.5,
                track,
            });
        }
        for p in points2d.iter_mut() {
            for _ in 0..3 {
                p.push(Point2D {
                    xy: [
                        rng.random_range(10.0..WIDTH as f64 - 10.0),
                        rng.random_range(10.0..HEIGHT as f64 - 10.0),
                    ],
                    point3d_id: colmap::INVALID_POINT3D_ID,
                });
            }
        }
        let images = train
            .iter()
            .enumerate()
            .map(|(k, f)| colmap::Image {
                image_id: k as u32 + 1,
                qvec: f.pose.qvec(),
                tvec: f.pose.tvec(),
                camera_id: 1,
                name: f.name.clone(),
                points2d: std::mem::take(&mut points2d[k]),
            })
            .collect();
        let model = Reconstruction::new(
            vec![CameraRecord {
                camera_id: 1,
                camera: cam.clone(),
            }],
            images,
            points3d,
            vec![],
            vec![],
        )
        .unwrap();

        // LIMAP: one segments file per training image (supports + 2 stray detections).
        let mut segs: Vec<Vec<[f64; 4]>> = vec![Vec::new(); train.len()];
        let mut tracks = Vec::new();
        let mut gt_tracks = Vec::new();
        let mut reversed = BTreeMap::new();
        for (si, seg) in scene_segments().into_iter().enumerate() {
            let obs: Vec<(usize, Vector2<f64>, Vector2<f64>)> = train
                .iter()
                .enumerate()
                .filter_map(|(k, f)| {
                    Some((
                        k,
                        project(&f.pose, &cam, &seg[0])?,
                        project(&f.pose, &cam, &seg[1])?,
                    ))
                })
                .collect();
            if obs.len() < 2 {
                continue;
            }
            // Odd tracks store their endpoints the other way round.
            let stored = if si % 2 == 1 { [seg[1], seg[0]] } else { seg };
            let mut t = LineTrack {
                line: stored.map(|e| e.map(|v| v + opts.noise_sigma_m * gauss(&mut rng))),
                image_ids: Vec::new(),
                line_ids: Vec::new(),
                lines2d: Some(Vec::new()),
                extras: None,
            };
            for (k, a, b) in obs {
                let image_id = k as u32 + 1;
                let line_id = segs[k].len() as u32;
                // Some detections run from the segment's end to its start.
                let flip = (k + si) % 3 == 0;
                let n = opts.detection_noise_px;
                let mut jitter = || n * gauss(&mut rng);
                let (a, b) = (
                    Vector2::new(a.x + jitter(), a.y + jitter()),
                    Vector2::new(b.x + jitter(), b.y + jitter()),
                );
                let s2 = if flip {
                    [b.x, b.y, a.x, a.y]
                } else {
                    [a.x, a.y, b.x, b.y]
                };
                // The 2D segment runs from stored[1] to stored[0] when exactly one of
                // (track stored reversed, detection flipped) holds.
                reversed.insert((image_id, line_id), flip != (si % 2 == 1));
                segs[k].push(s2);
                t.image_ids.push(image_id);
                t.line_ids.push(line_id);
                t.lines2d.as_mut().unwrap().push(s2);
            }
            gt_tracks.push(stored);
            tracks.push(t);
        }
        for s in segs.iter_mut() {
            s.push([20.0, 30.0, 60.0, 35.0]);
            s.push([600.0, 400.0, 560.0, 300.0]);
        }
        let segments: BTreeMap<u32, Segments> = segs
            .into_iter()
            .enumerate()
            .map(|(k, v)| (k as u32 + 1, Segments::new(v)))
            .collect();
        let image_list = ImageList {
            images: train
                .iter()
                .enumerate()
                .map(|(k, f)| (k as u32 + 1, f.name.clone()))
                .collect(),
        };
        let scene = Scene {
            frames_path: root.join("ingest").join("frames.parquet"),
            model_dir: root.join("model"),
            limap_dir: root.join("limap"),
            dir,
            table,
            model,
            image_list,
            segments,
            tracks,
            gt_points,
            gt_tracks,
            reversed,
        };
        scene.write_all();
        scene
    }

    /// Writes the frames table and, as the ingest stage does, its record: the label and
    /// shard stages read a frames table only with it (`stage::recorded_outputs`).
    pub fn write_frames(&self) {
        self.table.write_parquet(&self.frames_path).unwrap();
        let dir = self.frames_path.parent().unwrap();
        let name = self.frames_path.file_name().unwrap().to_str().unwrap();
        let mut record = stage::StageRecord::new(
            tables::frames::FRAMES_STAGE,
            String::new(),
            Default::default(),
        );
        record.add_output(dir, name).unwrap();
        record.save(dir).unwrap();
    }

    /// After a test changed depth maps on disk: their hashes in the frames table, as a
    /// new ingest would write them (the table, and so its hash, changes with them).
    pub fn rehash_depth(&mut self) {
        for f in &mut self.table.frames {
            f.depth_hash = f
                .depth_path
                .as_ref()
                .map(|p| stage::sha256_file(p).unwrap());
        }
        self.write_frames();
    }

    /// Writes the model as is (no validation: tests write broken models on purpose).
    pub fn write_model(&self) {
        colmap::write_binary(&self.model, &self.model_dir).unwrap();
    }

    pub fn write_limap(&self) {
        if self.limap_dir.exists() {
            std::fs::remove_dir_all(&self.limap_dir).unwrap();
        }
        limap::write_limap_dir(
            &self.limap_dir,
            "lsd",
            &self.image_list,
            &self.segments,
            &self.tracks,
        )
        .unwrap();
    }

    pub fn write_all(&self) {
        self.write_frames();
        self.write_model();
        self.write_limap();
    }

    pub fn out(&self, name: &str) -> PathBuf {
        self.dir.path().join(name)
    }

    pub fn train_frames(&self) -> Vec<&Frame> {
        self.table
            .frames
            .iter()
            .filter(|f| f.split == Split::Train)
            .collect()
    }
}
