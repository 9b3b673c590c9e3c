//! Cambridge Landmarks ingest on small fixtures written in the published layout.

use datasets::ingest::{self, DatasetKind, DepthOption, IngestConfig, IngestError};
use geometry::{CameraModel, Pose, UnitQuaternion, Vector3};
use std::path::{Path, PathBuf};
use tables::frames::Split;
use testkit::images::write_depth;
use testkit::layouts::{CAMBRIDGE_HEADER, cambridge, cambridge_row, fixture_pose};

fn fixture() -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let scene = cambridge(dir.path());
    (dir, scene)
}

/// The fixture is a four-row ShopFacade: a subset, not checked against the descriptor's
/// counts (ingest_descriptors.rs checks that it is refused with them).
fn config(scene: &Path) -> IngestConfig {
    let mut c = IngestConfig::new(DatasetKind::Cambridge, scene);
    c.count_check = false;
    c
}

fn err(config: &IngestConfig) -> IngestError {
    ingest::read_dataset(config, None).unwrap_err()
}

#[test]
fn frames_cameras_and_poses() {
    let (_d, scene) = fixture();
    let t = ingest::read_dataset(&config(&scene), None).unwrap();
    let names: Vec<&str> = t.frames.iter().map(|f| f.name.as_str()).collect();
    assert_eq!(
        names,
        [
            "seq1/frame00001.png",
            "seq1/frame00002.png",
            "seq2/frame00001.png"
        ]
    );
    assert_eq!((t.count(Split::Train), t.count(Split::Test)), (2, 1));
    // Focal length from the NVM (.jpg names), principal point at the centre, size from
    // the file (the third image is portrait).
    let f2 = &t.frames[2];
    assert_eq!((f2.width, f2.height), (24, 32));
    assert_eq!(f2.camera.model, CameraModel::SimplePinhole);
    assert_eq!(f2.camera.params, vec![1400.25, 12.0, 16.0]);
    assert_eq!(t.frames[1].camera.params, vec![1671.5, 16.0, 12.0]);
    for (k, f) in t.frames.iter().enumerate() {
        let want = fixture_pose(k);
        assert!(
            (f.pose.rotation_matrix() - want.rotation_matrix())
                .abs()
                .max()
                < 1e-12
        );
        assert!((f.pose.translation - want.translation).abs().max() < 1e-12);
        assert_eq!(f.id as usize, k);
        assert!(f.depth_path.is_none());
    }
    // The outlier is reported and left out.
    assert_eq!(t.meta.excluded.len(), 1);
    let ex = &t.meta.excluded[0];
    assert_eq!(
        (ex.name.as_str(), ex.split),
        ("seq2/frame00002.png", Split::Test)
    );
    assert!(ex.reason.contains("> 10000"), "{}", ex.reason);
    assert_eq!(t.meta.dataset, "cambridge");
    assert_eq!(t.meta.scene, "ShopFacade");
}

#[test]
fn hand_computed_pose() {
    // Centre (1, 2, 3), 90 degrees about z (x -> y): t = -R c = (2, -1, -3).
    let (_d, scene) = fixture();
    let h = std::f64::consts::FRAC_1_SQRT_2;
    std::fs::write(
        scene.join("dataset_train.txt"),
        format!("{CAMBRIDGE_HEADER}seq1/frame00001.png 1 2 3 {h} 0 0 {h}\n"),
    )
    .unwrap();
    let t = ingest::read_dataset(&config(&scene), None).unwrap();
    let p = t.frames[0].pose;
    let want = Vector3::new(2.0, -1.0, -3.0);
    assert!((p.translation - want).norm() < 1e-12, "{:?}", p.translation);
    assert!((p.rotation * Vector3::x() - Vector3::y()).norm() < 1e-12);
}

#[test]
fn header_missing() {
    let (_d, scene) = fixture();
    let p = scene.join("dataset_test.txt");
    let body = std::fs::read_to_string(&p).unwrap();
    std::fs::write(&p, body.lines().skip(3).collect::<Vec<_>>().join("\n")).unwrap();
    match err(&config(&scene)) {
        IngestError::Parse {
            path,
            line,
            message,
        } => {
            assert!(path.ends_with("dataset_test.txt"));
            assert_eq!(line, 1);
            assert!(message.contains("Visual Landmark Dataset"), "{message}");
        }
        e => panic!("{e}"),
    }
}

#[test]
fn malformed_row() {
    let (_d, scene) = fixture();
    std::fs::write(
        scene.join("dataset_train.txt"),
        format!("{CAMBRIDGE_HEADER}seq1/frame00001.png 1 2 3 1 0 0\n"),
    )
    .unwrap();
    assert!(matches!(
        err(&config(&scene)),
        IngestError::Parse { line: 4, .. }
    ));
}

#[test]
fn outlier_threshold_is_exclusive_at_1e4() {
    let (_d, scene) = fixture();
    // t = -R c with R = I: |t_y| = 1e4 exactly is kept, 1e4 + 1 is excluded.
    let keep = Pose::new(UnitQuaternion::identity(), Vector3::new(0.0, 1e4, 0.0));
    let drop = Pose::new(UnitQuaternion::identity(), Vector3::new(0.0, 0.0, -10001.0));
    std::fs::write(
        scene.join("dataset_train.txt"),
        format!(
            "{CAMBRIDGE_HEADER}{}{}",
            cambridge_row("seq1/frame00001.png", &keep),
            cambridge_row("seq1/frame00002.png", &drop)
        ),
    )
    .unwrap();
    let t = ingest::read_dataset(&config(&scene), None).unwrap();
    let excluded: Vec<&str> = t.meta.excluded.iter().map(|e| e.name.as_str()).collect();
    assert_eq!(excluded, ["seq1/frame00002.png", "seq2/frame00002.png"]);
    assert_eq!(t.frames[0].name, "seq1/frame00001.png");
}

#[test]
fn nvm_missing_a_camera() {
    let (_d, scene) = fixture();
    let p = scene.join("reconstruction.nvm");
    let text = std::fs::read_to_string(&p).unwrap();
    let text = text
        .replace("NVM_V3\n\n4\n", "NVM_V3\n\n3\n")
        .lines()
        .filter(|l| !l.starts_with("seq1/frame00002.jpg"))
        .collect::<Vec<_>>()
        .join("\n");
    std::fs::write(&p, text).unwrap();
    match err(&config(&scene)) {
        IngestError::NvmMissingCamera { name, nvm_stem, .. } => {
            assert_eq!(name, "seq1/frame00002.png");
            assert_eq!(nvm_stem, "seq1/frame00002");
        }
        e => panic!("{e}"),
    }
    // A camera override needs no NVM at all.
    std::fs::remove_file(&p).unwrap();
    let mut c = config(&scene);
    assert!(matches!(err(&c), IngestError::Missing { .. }));
    c.camera = Some("SIMPLE_RADIAL 32 24 30 16 12 0.01".into());
    // The portrait image does not fit a 32x24 camera.
    match err(&c) {
        IngestError::Camera { path, .. } => assert!(path.ends_with("seq2/frame00001.png")),
        e => panic!("{e}"),
    }
}

#[test]
fn malformed_nvm() {
    let (_d, scene) = fixture();
    let p = scene.join("reconstruction.nvm");
    let good = std::fs::read_to_string(&p).unwrap();
    for (bad, line) in [
        (good.replacen("NVM_V3", "NVM_V4", 1), 1),
        (good.replacen("\n4\n", "\nfour\n", 1), 3),
        (good.replacen(" 1670 ", " 1670 extra ", 1), 4),
        (good.replacen(" 1671.5 ", " -1671.5 ", 1), 5),
        ("NVM_V3\n\n4\n".to_string(), 4),
    ] {
        std::fs::write(&p, &bad).unwrap();
        match err(&config(&scene)) {
            IngestError::Parse { path, line: l, .. } => {
                assert!(path.ends_with("reconstruction.nvm"));
                assert_eq!(l, line, "{bad:?}");
            }
            e => panic!("{bad:?}: {e}"),
        }
    }
}

#[test]
fn missing_image_and_duplicates() {
    let (_d, scene) = fixture();
    std::fs::remove_file(scene.join("seq1/frame00002.png")).unwrap();
    match err(&config(&scene)) {
        IngestError::Missing { path, what } => {
            assert!(path.ends_with("seq1/frame00002.png"));
            assert!(what.contains("dataset_train.txt:5"), "{what}");
        }
        e => panic!("{e}"),
    }
    let (_d, scene) = fixture();
    let train = std::fs::read_to_string(scene.join("dataset_train.txt")).unwrap();
    let first_row = train.lines().nth(3).unwrap().to_string();
    let test = std::fs::read_to_string(scene.join("dataset_test.txt")).unwrap();
    std::fs::write(
        scene.join("dataset_test.txt"),
        format!("{test}{first_row}\n"),
    )
    .unwrap();
    match err(&config(&scene)) {
        IngestError::Duplicate { name, line, .. } => {
            assert_eq!(name, "seq1/frame00001.png");
            assert_eq!(line, 6);
        }
        e => panic!("{e}"),
    }
}

#[test]
fn rendered_depth_and_invalid_options() {
    let (dir, scene) = fixture();
    let rendered = dir.path().join("depth");
    write_depth(
        &rendered.join("seq1/frame00001.depth.png"),
        32,
        24,
        |_, _| 5000,
    );
    write_depth(
        &rendered.join("seq1/frame00002.depth.png"),
        32,
        24,
        |_, _| 5000,
    );
    write_depth(
        &rendered.join("seq2/frame00001.depth.png"),
        32,
        24,
        |_, _| 5000,
    );
    let mut c = config(&scene);
    c.depth = DepthOption::Rendered(rendered);
    // seq2/frame00001 is portrait (24x32).
    match err(&c) {
        IngestError::DepthSize {
            image,
            got_w,
            got_h,
            w,
            h,
            ..
        } => {
            assert_eq!(image, "seq2/frame00001.png");
            assert_eq!((got_w, got_h, w, h), (32, 24, 24, 32));
        }
        e => panic!("{e}"),
    }
    c.depth = DepthOption::Raw;
    assert!(matches!(err(&c), IngestError::Config(_)));
    c.depth = DepthOption::None;
    c.poses = ingest::PoseOption::Calibrated;
    assert!(matches!(err(&c), IngestError::Config(_)));
}
