//! 7-Scenes ingest: the real sample against kapture's own import of it, and every bad
//! input on small fixtures.

use datasets::descriptor::{Descriptor, SevenScenesLayout};
use datasets::ingest::{
    self, DatasetKind, DepthOption, IngestConfig, IngestError, PoseOption, depth,
};
use datasets::ingest_stage;
use geometry::{GeometryError, Pose};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use tables::frames::{FramesTable, Split};
use testkit::images::{write_depth, write_rgb};
use testkit::layouts::{fixture_pose, seven_scenes};

// ---------------------------------------------------------------------------------------
// The real sample against kapture-reference/.
//
// kapture's conventions (naver/kapture, kapture/core/Trajectories.py, `rigs_remove_inplace`):
// trajectories.txt holds `pose_rig_from_world` (world-to-device) for the rig `kinect`, and
// rigs.txt holds, for each sensor of a rig, `pose_device_from_rig` (sensor_from_rig); a
// sensor's world-to-camera pose is `sensor_from_rig * rig_from_world`. kapture's 7-Scenes
// importer makes the rig frame the depth camera (the `kinect_depth` row is the identity)
// and writes the inverse of pose.txt as the rig's trajectory. So:
// - published (pose.txt as the colour camera's pose) = trajectory;
// - calibrated = rigs[kinect, kinect_rgb] * trajectory, i.e. rgb_from_depth * depth_from_world,
//   which is ACE's `pose_rgb = pose @ inv(d_to_rgb)` inverted.

fn sample_scene() -> Option<(PathBuf, PathBuf)> {
    let base = testkit::sample::sample_data("7scenes-stairs-mini")?;
    Some((base.join("stairs"), base.join("kapture-reference")))
}

/// The sample is 12 of the 3000 frames of stairs: read without the count check
/// (ingest_descriptors.rs checks that it is refused with it).
fn sample_config(scene: &Path) -> IngestConfig {
    let mut c = IngestConfig::new(DatasetKind::SevenScenes, scene);
    c.count_check = false;
    c
}

/// The built-in 7-Scenes descriptor's cameras and extrinsic.
fn seven_scenes_layout() -> SevenScenesLayout {
    Descriptor::builtin("7scenes")
        .unwrap()
        .seven_scenes()
        .unwrap()
        .clone()
}

/// Comma-separated kapture rows (comments and blank lines skipped).
fn kapture_rows(path: &Path) -> Vec<Vec<String>> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .filter(|l| !l.trim().is_empty() && !l.trim_start().starts_with('#'))
        .map(|l| l.split(',').map(|t| t.trim().to_string()).collect())
        .collect()
}

fn pose_from(fields: &[String]) -> Pose {
    let v: Vec<f64> = fields.iter().map(|t| t.parse().unwrap()).collect();
    Pose::from_qvec_tvec([v[0], v[1], v[2], v[3]], [v[4], v[5], v[6]]).unwrap()
}

/// kapture's sensor_from_rig of `sensor` in rigs.txt.
fn kapture_rig(reference: &Path, part: &str, sensor: &str) -> Pose {
    let rows = kapture_rows(&reference.join(part).join("sensors/rigs.txt"));
    let row = rows
        .iter()
        .find(|r| r[0] == "kinect" && r[1] == sensor)
        .unwrap();
    pose_from(&row[2..9])
}

/// image path -> (split, kapture's rig_from_world) for both kapture parts.
fn kapture_trajectories(reference: &Path) -> BTreeMap<String, (Split, Pose)> {
    let mut out = BTreeMap::new();
    for (part, split) in [("mapping", Split::Train), ("query", Split::Test)] {
        let dir = reference.join(part).join("sensors");
        let poses: BTreeMap<String, Pose> = kapture_rows(&dir.join("trajectories.txt"))
            .into_iter()
            .map(|r| {
                assert_eq!(r[1], "kinect");
                (r[0].clone(), pose_from(&r[2..9]))
            })
            .collect();
        for r in kapture_rows(&dir.join("records_camera.txt")) {
            assert_eq!(r[1], "kinect_rgb");
            out.insert(r[2].clone(), (split, poses[&r[0]]));
        }
    }
    out
}

/// Max absolute differences over all frames: (rotation matrix entries, translation,
/// camera centre).
fn max_differences(table: &FramesTable, expected: &BTreeMap<String, (Split, Pose)>) -> [f64; 3] {
    assert_eq!(table.frames.len(), expected.len());
    let mut worst = [0.0f64; 3];
    for f in &table.frames {
        let (split, want) = expected
            .get(&f.name)
            .unwrap_or_else(|| panic!("{} not in kapture's records", f.name));
        assert_eq!(f.split, *split, "{}", f.name);
        let dr = (f.pose.rotation_matrix() - want.rotation_matrix())
            .abs()
            .max();
        let dt = (f.pose.translation - want.translation).abs().max();
        let dc = (f.pose.centre() - want.centre()).abs().max();
        worst = [worst[0].max(dr), worst[1].max(dt), worst[2].max(dc)];
    }
    worst
}

#[test]
fn kapture_rig_matches_our_extrinsic() {
    let Some((_, reference)) = sample_scene() else {
        return;
    };
    for part in ["mapping", "query"] {
        // The rig frame is the depth camera.
        let depth = kapture_rig(&reference, part, "kinect_depth");
        assert_eq!(depth.qvec(), [1.0, 0.0, 0.0, 0.0]);
        assert_eq!(depth.tvec(), [0.0; 3]);
        let rgb = kapture_rig(&reference, part, "kinect_rgb");
        let ours = seven_scenes_layout().rgb_from_depth.unwrap().pose;
        let dr = (rgb.rotation_matrix() - ours.rotation_matrix()).abs().max();
        let dt = (rgb.translation - ours.translation).abs().max();
        eprintln!(
            "{part}: rig kinect_rgb vs our extrinsic: rotation {dr:.3e}, translation {dt:.3e}"
        );
        assert!(dr < 1e-12 && dt < 1e-15, "{dr} {dt}");
    }
}

/// The sample's table, kapture's trajectories by image name, kapture's folder.
type SampleIngest = (FramesTable, BTreeMap<String, (Split, Pose)>, PathBuf);

fn ingest_sample(poses: PoseOption) -> Option<SampleIngest> {
    let (scene, reference) = sample_scene()?;
    let mut config = sample_config(&scene);
    config.poses = poses;
    let table = ingest::read_dataset(&config, None).unwrap();
    Some((table, kapture_trajectories(&reference), reference))
}

#[test]
fn published_poses_equal_kapture_trajectories() {
    let Some((table, expected, _)) = ingest_sample(PoseOption::Published) else {
        return;
    };
    let [dr, dt, dc] = max_differences(&table, &expected);
    eprintln!(
        "published vs kapture (12 frames): max |dR| {dr:.3e}, |dt| {dt:.3e} m, |dC| {dc:.3e} m"
    );
    assert!(dr < 1e-9 && dt < 1e-9 && dc < 1e-9);
    assert!(table.meta.pose_source.starts_with("published"));
}

#[test]
fn calibrated_poses_equal_kapture_rgb_sensor_poses() {
    let Some((table, trajectories, reference)) = ingest_sample(PoseOption::Calibrated) else {
        return;
    };
    let mut expected = BTreeMap::new();
    for (name, (split, rig_from_world)) in trajectories {
        let part = if split == Split::Train {
            "mapping"
        } else {
            "query"
        };
        let rgb_from_rig = kapture_rig(&reference, part, "kinect_rgb");
        expected.insert(name, (split, rgb_from_rig.compose(&rig_from_world)));
    }
    let [dr, dt, dc] = max_differences(&table, &expected);
    eprintln!(
        "calibrated vs kapture (12 frames): max |dR| {dr:.3e}, |dt| {dt:.3e} m, |dC| {dc:.3e} m"
    );
    assert!(dr < 1e-9 && dt < 1e-9 && dc < 1e-9);
    assert!(table.meta.pose_source.starts_with("calibrated"));
    // The calibration moves the camera by the extrinsic's 2.6 cm, not more.
    let published = ingest_sample(PoseOption::Published).unwrap().0;
    for (a, b) in table.frames.iter().zip(&published.frames) {
        let d = (a.pose.centre() - b.pose.centre()).norm();
        assert!((d - 0.02564).abs() < 1e-4, "{}: {d}", a.name);
    }
}

#[test]
fn sample_table_rows_and_registered_depth() {
    let Some((scene, _)) = sample_scene() else {
        return;
    };
    let out = tempfile::tempdir().unwrap();
    let mut config = sample_config(&scene);
    config.depth = DepthOption::Raw;
    let result = ingest_stage::run(&config, out.path()).unwrap();
    assert!(!result.skipped);
    let t = &result.output.table;
    assert_eq!((t.count(Split::Train), t.count(Split::Test)), (6, 6));
    let names: Vec<&str> = t.frames.iter().map(|f| f.name.as_str()).collect();
    assert_eq!(names[0], "seq-02/frame-000000.color.jpg");
    assert_eq!(names[6], "seq-01/frame-000000.color.jpg");
    assert_eq!(names[11], "seq-04/frame-000002.color.jpg");
    for (i, f) in t.frames.iter().enumerate() {
        assert_eq!(f.id as usize, i);
        assert_eq!((f.width, f.height), (640, 480));
        assert_eq!(f.camera, seven_scenes_layout().colour_camera.model);
        assert_eq!(f.path, scene.canonicalize().unwrap().join(&f.name));
        assert_eq!(f.content_hash, stage::sha256_file(&f.path).unwrap());
        // Registered depth: in the colour camera, mm, 65535 where nothing landed.
        let dp = f.depth_path.as_ref().unwrap();
        assert!(dp.starts_with(out.path().canonicalize().unwrap().join("depth")));
        let reg = depth::read_depth_png(dp).unwrap();
        assert_eq!(reg.dimensions(), (640, 480));
        let raw_path = f.path.to_str().unwrap().replace(".color.jpg", ".depth.png");
        let raw = depth::read_depth_png(Path::new(&raw_path)).unwrap();
        let valid = |img: &depth::DepthImage| {
            let mut v: Vec<u16> = img
                .pixels()
                .map(|p| p.0[0])
                .filter(|&d| d != 0 && d != 65535)
                .collect();
            v.sort_unstable();
            v
        };
        let (r, g) = (valid(&raw), valid(&reg));
        // 585/525: ~1.24 depth pixels per colour pixel, so collisions merge some points.
        let ratio = g.len() as f64 / r.len() as f64;
        assert!((0.6..=1.0).contains(&ratio), "{}: {ratio}", f.name);
        let (mr, mg) = (r[r.len() / 2] as f64, g[g.len() / 2] as f64);
        assert!(
            (mr - mg).abs() < 0.03 * mr,
            "{}: median {mr} vs {mg}",
            f.name
        );
    }
    assert!(t.meta.depth_source.starts_with("raw"));
    assert_eq!(t.meta.depth_units_per_metre, Some(1000.0));
    assert_eq!(t.meta.dataset, "7scenes");
    assert_eq!(t.meta.scene, "stairs");
    // The table on disk is the one returned.
    let back = FramesTable::read_parquet(&result.output.frames_path).unwrap();
    assert_eq!(&back, t);
}

// ---------------------------------------------------------------------------------------
// Fixtures: bad inputs.

/// Small fixture images need a camera of their size.
fn fixture_config(scene: &Path) -> IngestConfig {
    let mut c = IngestConfig::new(DatasetKind::SevenScenes, scene);
    c.camera = Some("SIMPLE_PINHOLE 16 12 10 8 6".into());
    c
}

fn fixture() -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let scene = seven_scenes(dir.path(), 16, 12);
    (dir, scene)
}

fn err(config: &IngestConfig) -> IngestError {
    ingest::read_dataset(config, None).unwrap_err()
}

#[test]
fn fixture_reads_with_expected_poses() {
    let (_d, scene) = fixture();
    let t = ingest::read_dataset(&fixture_config(&scene), None).unwrap();
    let names: Vec<&str> = t.frames.iter().map(|f| f.name.as_str()).collect();
    assert_eq!(
        names,
        [
            "seq-01/frame-000000.color.png",
            "seq-01/frame-000001.color.png",
            "seq-02/frame-000000.color.jpg"
        ]
    );
    assert_eq!(t.frames[2].split, Split::Test);
    for (k, f) in t.frames.iter().enumerate() {
        // pose.txt holds 7 significant digits of the camera-to-world matrix.
        let want = fixture_pose(k);
        assert!(
            (f.pose.rotation_matrix() - want.rotation_matrix())
                .abs()
                .max()
                < 1e-6
        );
        assert!((f.pose.translation - want.translation).abs().max() < 1e-6);
    }
    assert!(t.meta.intrinsics.starts_with("given: SIMPLE_PINHOLE 16 12"));
}

#[test]
fn missing_split_file() {
    let (_d, scene) = fixture();
    std::fs::remove_file(scene.join("TestSplit.txt")).unwrap();
    match err(&fixture_config(&scene)) {
        IngestError::Missing { path, .. } => assert!(path.ends_with("TestSplit.txt")),
        e => panic!("{e}"),
    }
}

#[test]
fn malformed_split_line() {
    let (_d, scene) = fixture();
    for (text, line) in [
        ("sequence1\r\nseq2\r\n", 2),
        ("\nsequenceX\n", 2),
        ("sequence 1\n", 1),
    ] {
        std::fs::write(scene.join("TrainSplit.txt"), text).unwrap();
        match err(&fixture_config(&scene)) {
            IngestError::Parse {
                path,
                line: l,
                message,
            } => {
                assert!(path.ends_with("TrainSplit.txt"));
                assert_eq!(l, line, "{text:?}");
                assert!(message.contains("sequenceN"), "{message}");
            }
            e => panic!("{text:?}: {e}"),
        }
    }
    std::fs::write(scene.join("TrainSplit.txt"), "\r\n").unwrap();
    assert!(matches!(
        err(&fixture_config(&scene)),
        IngestError::Parse { .. }
    ));
}

#[test]
fn sequence_in_both_splits_or_missing_folder() {
    let (_d, scene) = fixture();
    std::fs::write(scene.join("TestSplit.txt"), "sequence2\nsequence1\n").unwrap();
    match err(&fixture_config(&scene)) {
        IngestError::Duplicate { line, name, .. } => {
            assert_eq!((line, name.as_str()), (2, "seq-01"))
        }
        e => panic!("{e}"),
    }
    std::fs::write(scene.join("TestSplit.txt"), "sequence3\n").unwrap();
    match err(&fixture_config(&scene)) {
        IngestError::Missing { path, what } => {
            assert!(path.ends_with("seq-03"));
            assert!(what.contains("TestSplit.txt:1"), "{what}");
        }
        e => panic!("{e}"),
    }
}

#[test]
fn missing_colour_frame() {
    let (_d, scene) = fixture();
    std::fs::remove_file(scene.join("seq-01/frame-000001.color.png")).unwrap();
    match err(&fixture_config(&scene)) {
        IngestError::MissingColour { stem, .. } => assert_eq!(stem, "frame-000001"),
        e => panic!("{e}"),
    }
    // Both encodings at once is ambiguous.
    let (_d, scene) = fixture();
    write_rgb(&scene.join("seq-01/frame-000001.color.jpg"), 16, 12, 0);
    assert!(matches!(
        err(&fixture_config(&scene)),
        IngestError::Ambiguous { .. }
    ));
}

#[test]
fn missing_pose_file() {
    let (_d, scene) = fixture();
    std::fs::remove_file(scene.join("seq-02/frame-000000.pose.txt")).unwrap();
    match err(&fixture_config(&scene)) {
        IngestError::Missing { path, .. } => {
            assert!(path.ends_with("seq-02/frame-000000.pose.txt"))
        }
        e => panic!("{e}"),
    }
}

/// Replaces one row of a frame's pose.txt and returns the error.
fn with_pose_rows(rows: &str) -> IngestError {
    let (_d, scene) = fixture();
    let p = scene.join("seq-01/frame-000001.pose.txt");
    std::fs::write(&p, rows).unwrap();
    let e = err(&fixture_config(&scene));
    match &e {
        IngestError::Pose { path, .. } | IngestError::Parse { path, .. } => assert_eq!(path, &p),
        _ => panic!("{e}"),
    }
    e
}

const R1: &str = "1 0 0 0.5\r\n";
const R2: &str = "0 1 0 0.25\r\n";
const R3: &str = "0 0 1 -1\r\n";
const R4: &str = "0 0 0 1\r\n";

#[test]
fn nan_in_pose() {
    let e = with_pose_rows(&format!("{R1}0 NaN 0 0.25\r\n{R3}{R4}"));
    assert!(
        matches!(
            e,
            IngestError::Pose {
                line: 2,
                source: GeometryError::NonFinite { .. },
                ..
            }
        ),
        "{e}"
    );
    let e = with_pose_rows(&format!("{R1}{R2}{R3}0 0 0 inf\r\n"));
    assert!(matches!(e, IngestError::Pose { line: 4, .. }), "{e}");
}

#[test]
fn non_orthonormal_rotation() {
    let e = with_pose_rows(&format!("{R1}{R2}0 0 1.01 -1\r\n{R4}"));
    assert!(
        matches!(
            e,
            IngestError::Pose {
                line: 3,
                source: GeometryError::NotOrthonormal { .. },
                ..
            }
        ),
        "{e}"
    );
    // A reflection: orthonormal, determinant -1.
    let e = with_pose_rows(&format!("-1 0 0 0.5\r\n{R2}{R3}{R4}"));
    assert!(
        matches!(
            e,
            IngestError::Pose {
                source: GeometryError::NotOrthonormal { .. },
                ..
            }
        ),
        "{e}"
    );
}

#[test]
fn pose_with_bad_fourth_row() {
    let e = with_pose_rows(&format!("{R1}{R2}{R3}0 0 0.5 1\r\n"));
    assert!(
        matches!(
            e,
            IngestError::Pose {
                line: 4,
                source: GeometryError::NotRigid(_),
                ..
            }
        ),
        "{e}"
    );
}

#[test]
fn pose_with_wrong_shape() {
    let e = with_pose_rows(&format!("{R1}{R2}{R3}"));
    assert!(
        matches!(&e, IngestError::Parse { message, .. } if message.contains("found 3")),
        "{e}"
    );
    let e = with_pose_rows(&format!("{R1}0 1 0\r\n{R3}{R4}"));
    assert!(matches!(e, IngestError::Parse { line: 2, .. }), "{e}");
    let e = with_pose_rows(&format!("{R1}{R2}{R3}{R4}{R4}"));
    assert!(matches!(e, IngestError::Parse { line: 5, .. }), "{e}");
    let e = with_pose_rows(&format!("{R1}{R2}0 0 one -1\r\n{R4}"));
    assert!(matches!(e, IngestError::Parse { line: 3, .. }), "{e}");
}

#[test]
fn image_size_must_match_the_camera() {
    let (_d, scene) = fixture();
    // The default camera is 640x480; the fixture images are 16x12.
    let config = IngestConfig::new(DatasetKind::SevenScenes, &scene);
    match err(&config) {
        IngestError::Camera { message, .. } => assert!(message.contains("16x12"), "{message}"),
        e => panic!("{e}"),
    }
}

#[test]
fn raw_depth_of_the_wrong_size() {
    let (dir, scene) = fixture();
    write_depth(
        &scene.join("seq-01/frame-000001.depth.png"),
        320,
        240,
        |_, _| 1000,
    );
    let mut config = fixture_config(&scene);
    config.depth = DepthOption::Raw;
    match ingest::read_dataset(&config, Some(&dir.path().join("out"))).unwrap_err() {
        IngestError::ImageContent { path, message } => {
            assert!(path.ends_with("seq-01/frame-000001.depth.png"));
            assert!(message.contains("320x240"), "{message}");
        }
        e => panic!("{e}"),
    }
    // Raw depth needs a folder to write to.
    assert!(matches!(
        ingest::read_dataset(&config, None),
        Err(IngestError::Config(_))
    ));
    // And a depth.png for every frame.
    std::fs::remove_file(scene.join("seq-02/frame-000000.depth.png")).unwrap();
    assert!(matches!(
        ingest::read_dataset(&config, Some(&dir.path().join("out"))),
        Err(IngestError::Missing { .. })
    ));
}

#[test]
fn rendered_depth_is_found_by_name_and_checked_for_size() {
    let (dir, scene) = fixture();
    let rendered = dir.path().join("rendered");
    // hloc's flat names, DSAC*'s per-sequence names: both accepted.
    write_depth(
        &rendered.join("seq01_frame-000000.pose.depth.png"),
        16,
        12,
        |_, _| 900,
    );
    write_depth(
        &rendered.join("seq-01/frame-000001.depth.png"),
        16,
        12,
        |_, _| 900,
    );
    write_depth(
        &rendered.join("seq-02-frame-000000.depth.png"),
        16,
        12,
        |_, _| 900,
    );
    let mut config = fixture_config(&scene);
    config.depth = DepthOption::Rendered(rendered.clone());
    let t = ingest::read_dataset(&config, None).unwrap();
    let r = rendered.canonicalize().unwrap();
    assert_eq!(
        t.frames[1].depth_path.as_deref(),
        Some(r.join("seq-01/frame-000001.depth.png").as_path())
    );
    assert!(t.meta.depth_source.starts_with("rendered"));
    // Wrong size.
    write_depth(
        &rendered.join("seq-01/frame-000001.depth.png"),
        8,
        6,
        |_, _| 900,
    );
    match ingest::read_dataset(&config, None).unwrap_err() {
        IngestError::DepthSize {
            got_w, w, image, ..
        } => {
            assert_eq!((got_w, w), (8, 16));
            assert_eq!(image, "seq-01/frame-000001.color.png");
        }
        e => panic!("{e}"),
    }
    // Missing.
    std::fs::remove_file(rendered.join("seq-01/frame-000001.depth.png")).unwrap();
    assert!(matches!(
        ingest::read_dataset(&config, None),
        Err(IngestError::Missing { .. })
    ));
}

#[test]
fn sample_calibrated_depth_points_land_consistently() {
    // Registered depth + calibrated pose put a depth point at the same world position as
    // the raw depth + the depth camera's pose (published) do.
    let Some((scene, _)) = sample_scene() else {
        return;
    };
    let out = tempfile::tempdir().unwrap();
    let mut config = sample_config(&scene);
    config.depth = DepthOption::Raw;
    config.poses = PoseOption::Calibrated;
    let t = ingest_stage::run(&config, out.path()).unwrap().output.table;
    let published = ingest::read_dataset(&sample_config(&scene), None).unwrap();
    let f = &t.frames[0];
    let reg = depth::read_depth_png(f.depth_path.as_ref().unwrap()).unwrap();
    let raw_path = f.path.to_str().unwrap().replace(".color.jpg", ".depth.png");
    let raw = depth::read_depth_png(Path::new(&raw_path)).unwrap();
    let dcam = seven_scenes_layout().depth_camera.unwrap().model;
    let mut checked = 0;
    for (x, y) in [(200u32, 150u32), (320, 240), (400, 300), (250, 350)] {
        let d = raw.get_pixel(x, y).0[0];
        if d == 0 || d == 65535 {
            continue;
        }
        let ray = dcam
            .unproject(&geometry::Vector2::new(x as f64 + 0.5, y as f64 + 0.5))
            .unwrap();
        let world = published.frames[0]
            .pose
            .inverse()
            .transform_point(&(ray * (d as f64 / 1000.0)));
        let cam = f.pose.transform_point(&world);
        let px = f.camera.project(&cam).unwrap();
        let got = reg.get_pixel(px.x as u32, px.y as u32).0[0] as f64;
        // Nearest-wins may keep a neighbouring depth pixel's point: a few mm.
        assert!(
            (got - cam.z * 1000.0).abs() < 15.0,
            "({x},{y}): {got} vs {}",
            cam.z * 1000.0
        );
        checked += 1;
    }
    assert!(checked >= 3);
}
