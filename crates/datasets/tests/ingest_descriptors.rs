//! Dataset descriptors (datasets/*.toml): they parse, hold the values the adapters used
//! before (bit for bit), and ingest refuses a scene whose frame counts differ from its
//! descriptor's unless the count check is off.

use datasets::descriptor::{
    BUILTIN_NAMES, CountMismatch, Descriptor, DescriptorError, SplitCounts,
};
use datasets::ingest::{self, DatasetKind, DepthOption, IngestConfig, IngestError, PoseOption};
use datasets::ingest_stage;
use geometry::CameraModel;
use std::path::{Path, PathBuf};
use tables::frames::Split;
use testkit::layouts::{cambridge, seven_scenes};

fn builtin(name: &str) -> Descriptor {
    Descriptor::builtin(name).unwrap()
}

fn counts(train: usize, test: usize) -> SplitCounts {
    SplitCounts { train, test }
}

#[test]
fn every_file_of_the_folder_is_built_in() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../datasets");
    let mut names: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    let mut want: Vec<String> = BUILTIN_NAMES.iter().map(|n| format!("{n}.toml")).collect();
    want.sort();
    assert_eq!(names, want);
    // The files parse as files too, and equal what is compiled in.
    for n in BUILTIN_NAMES {
        let file = Descriptor::from_file(&dir.join(format!("{n}.toml"))).unwrap();
        let built = builtin(n);
        assert_eq!(file.name, built.name);
        assert_eq!(file.scenes, built.scenes);
        assert_eq!(file.layouts, built.layouts);
    }
}

// The extrinsic's literals are written with the source's 17 digits, as the 7-Scenes
// adapter held them before the descriptor did.
#[allow(clippy::excessive_precision)]
#[test]
fn seven_scenes_holds_the_adapters_former_constants() {
    let d = builtin("7scenes");
    assert_eq!(d.layout_names(), ["7scenes"]);
    let l = d.seven_scenes().unwrap();
    assert_eq!(
        (l.train_split.as_str(), l.test_split.as_str()),
        ("TrainSplit.txt", "TestSplit.txt")
    );
    let c = &l.colour_camera.model;
    assert_eq!(c.model, CameraModel::SimplePinhole);
    assert_eq!((c.width, c.height), (640, 480));
    assert_eq!(c.params, [525.0, 320.0, 240.0]);
    assert_eq!(l.colour_camera.label.as_deref(), Some("7-Scenes default"));
    let dc = &l.depth_camera.as_ref().unwrap().model;
    assert_eq!(dc.model, CameraModel::SimplePinhole);
    assert_eq!((dc.width, dc.height), (640, 480));
    assert_eq!(dc.params, [585.0, 320.0, 240.0]);
    // The LIRIS extrinsic, as the 7-Scenes adapter held it: the same f64 bits.
    let ext = l.rgb_from_depth.as_ref().unwrap();
    let rotation: [[f64; 3]; 3] = [
        [
            9.9996518012567637e-01,
            2.6765126468950343e-03,
            -7.9041012313000904e-03,
        ],
        [
            -2.7409311281316700e-03,
            9.9996302803027592e-01,
            -8.1504520778013286e-03,
        ],
        [
            7.8819942130445332e-03,
            8.1718328771890631e-03,
            9.9993554558014031e-01,
        ],
    ];
    let translation: [f64; 3] = [
        -2.5558943178152542e-02,
        1.0109636268061706e-04,
        2.0318321729487039e-03,
    ];
    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<u64>>();
    assert_eq!(
        bits(ext.rotation.as_flattened()),
        bits(rotation.as_flattened())
    );
    assert_eq!(bits(&ext.translation), bits(&translation));
    assert_eq!(ext.pose.tvec(), translation);
    let r = geometry::Matrix3::from_fn(|i, j| rotation[i][j]);
    assert!((ext.pose.rotation_matrix() - r).abs().max() < 1e-7);
    assert_eq!(ext.label, "LIRIS");

    let want = [
        ("chess", 4000, 2000),
        ("fire", 2000, 2000),
        ("heads", 1000, 1000),
        ("office", 6000, 4000),
        ("pumpkin", 4000, 2000),
        ("redkitchen", 7000, 5000),
        ("stairs", 2000, 1000),
    ];
    assert_eq!(d.scenes.len(), want.len());
    for (scene, train, test) in want {
        assert_eq!(
            d.scene_counts(scene),
            Some(Some(counts(train, test))),
            "{scene}"
        );
    }
    assert_eq!(d.outputs.model, "${SCENE}/sfm_superpoint+superglue");
    assert_eq!(d.outputs.segment_scale, 1.0);
}

#[test]
fn cambridge_holds_the_adapters_former_constants() {
    let d = builtin("cambridge");
    assert_eq!(d.layout_names(), ["cambridge"]);
    let l = d.cambridge().unwrap();
    assert_eq!(
        (
            l.train_split.as_str(),
            l.test_split.as_str(),
            l.nvm.as_str()
        ),
        (
            "dataset_train.txt",
            "dataset_test.txt",
            "reconstruction.nvm"
        )
    );
    assert_eq!(l.outlier_max_abs_translation, Some(1e4));
    assert!(d.seven_scenes().is_err());
    let want = [
        ("GreatCourt", 1532, 760),
        ("KingsCollege", 1220, 343),
        ("OldHospital", 895, 182),
        ("ShopFacade", 231, 103),
        ("StMarysChurch", 1487, 530),
        ("Street", 3015, 2923),
    ];
    assert_eq!(d.scenes.len(), want.len());
    for (scene, train, test) in want {
        assert_eq!(
            d.scene_counts(scene),
            Some(Some(counts(train, test))),
            "{scene}"
        );
    }
    assert_eq!(d.outputs.segment_scale, 1.2);
}

#[test]
fn synthetic_scene_has_no_fixed_counts() {
    let d = builtin("synthetic");
    assert_eq!(d.layout_names(), ["7scenes", "cambridge"]);
    assert_eq!(d.scene_counts("synthroom"), Some(None));
    let g = d.generated.as_ref().unwrap();
    assert_eq!(g.command, "pl2map synth");
    // 2/3 of the default frames are training; the tiny scene is 4 x 6 + 2 x 4.
    assert_eq!(g.default.train + g.default.test, g.default_frames);
    assert_eq!(g.default, counts(200, 100));
    assert_eq!(g.tiny, counts(24, 8));
    // Read as 7-Scenes frames with the 7-Scenes default camera: the same frames table.
    assert_eq!(
        d.seven_scenes().unwrap().colour_camera,
        builtin("7scenes").seven_scenes().unwrap().colour_camera
    );
    assert_eq!(d.outputs.model, "${SCENE}/sfm_gt/colmap");
    assert_eq!(d.outputs.limap, "${SCENE}/sfm_gt/limap");
    assert_eq!(
        d.outputs.ground_truth.as_deref(),
        Some("${SCENE}/sfm_gt/exact.json")
    );
}

// ---------------------------------------------------------------------------------------
// The count check.

fn stairs_sample() -> Option<PathBuf> {
    testkit::sample::sample_data("7scenes-stairs-mini/stairs")
}

fn frame_counts(e: IngestError) -> (String, SplitCounts, Vec<CountMismatch>, String) {
    let message = e.to_string();
    match e {
        IngestError::FrameCounts(f) => (f.scene, f.expected, f.mismatches, message),
        e => panic!("expected a frame count error, got {e}"),
    }
}

fn mismatch(split: Split, expected: usize, found: usize) -> CountMismatch {
    CountMismatch {
        split,
        expected,
        found,
    }
}

#[test]
fn sample_stairs_reads_with_the_check_off_and_is_refused_with_it_on() {
    let Some(scene) = stairs_sample() else {
        return;
    };
    let mut config = IngestConfig::new(DatasetKind::SevenScenes, &scene);
    config.count_check = false;
    let t = ingest::read_dataset(&config, None).unwrap();
    assert_eq!((t.count(Split::Train), t.count(Split::Test)), (6, 6));

    // On (the default): the 12 frames are not the 2000 + 1000 of stairs.
    let out = tempfile::tempdir().unwrap();
    let e = ingest_stage::run(
        &IngestConfig::new(DatasetKind::SevenScenes, &scene),
        out.path(),
    )
    .unwrap_err();
    let (name, expected, mismatches, message) = frame_counts(e);
    eprintln!("{message}");
    assert_eq!(name, "stairs");
    assert_eq!(expected, counts(2000, 1000));
    assert_eq!(
        mismatches,
        [
            mismatch(Split::Train, 2000, 6),
            mismatch(Split::Test, 1000, 6)
        ]
    );
    for want in [
        "scene stairs",
        "7scenes dataset descriptor (built-in datasets/7scenes.toml)",
        "train: expected 2000, found 6; test: expected 1000, found 6",
        "TrainSplit.txt / TestSplit.txt",
        "--no-count-check",
        "count_check = false",
    ] {
        assert!(message.contains(want), "{want}: {message}");
    }
    assert!(!out.path().join(ingest_stage::FRAMES_FILE).exists());

    // The same scene named by --scene inside the dataset folder.
    let mut c = IngestConfig::new(DatasetKind::SevenScenes, scene.parent().unwrap());
    c.scene = Some("stairs".into());
    let (name, ..) = frame_counts(ingest::read_dataset(&c, None).unwrap_err());
    assert_eq!(name, "stairs");
}

#[test]
fn cambridge_fixture_is_refused_with_the_named_counts() {
    let dir = tempfile::tempdir().unwrap();
    // Two training rows; one test frame and one outlier row (counted: it is listed).
    let scene = cambridge(dir.path());
    let config = IngestConfig::new(DatasetKind::Cambridge, &scene);
    let (name, expected, mismatches, message) =
        frame_counts(ingest::read_dataset(&config, None).unwrap_err());
    assert_eq!(name, "ShopFacade");
    assert_eq!(expected, counts(231, 103));
    assert_eq!(
        mismatches,
        [
            mismatch(Split::Train, 231, 2),
            mismatch(Split::Test, 103, 2)
        ]
    );
    assert!(
        message.contains(
            "train: expected 231, found 2; test: expected 103, found 2 (rows of \
             dataset_train.txt / dataset_test.txt, outlier poses included)"
        ),
        "{message}"
    );
    let mut off = config.clone();
    off.count_check = false;
    let t = ingest::read_dataset(&off, None).unwrap();
    assert_eq!(t.frames.len() + t.meta.excluded.len(), 4);
}

/// The 7-Scenes fixture (train seq-01: 2 frames; test seq-02: 1 frame) under `name`.
fn seven_scenes_fixture(root: &Path, name: &str) -> PathBuf {
    let scene = seven_scenes(root, 16, 12);
    let renamed = root.join(name);
    std::fs::rename(&scene, &renamed).unwrap();
    renamed
}

fn fixture_config(scene: &Path) -> IngestConfig {
    let mut c = IngestConfig::new(DatasetKind::SevenScenes, scene);
    c.camera = Some("SIMPLE_PINHOLE 16 12 10 8 6".into());
    c
}

/// A descriptor of the user's own: the 7-Scenes one with other scenes.
fn own_descriptor(dir: &Path, scenes: &str) -> PathBuf {
    let text = builtin_text("7scenes");
    let start = text.find("\n[scenes]\n").unwrap();
    let end = text.find("\n[outputs]\n").unwrap();
    let text = format!("{}\n[scenes]\n{scenes}\n{}", &text[..start], &text[end..])
        .replace("name = \"7scenes\"", "name = \"mine\"");
    let path = dir.join("mine.toml");
    std::fs::write(&path, text).unwrap();
    path
}

fn builtin_text(name: &str) -> String {
    std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("../../datasets/{name}.toml")),
    )
    .unwrap()
}

#[test]
fn a_descriptor_of_ones_own_is_checked_and_hashed() {
    let dir = tempfile::tempdir().unwrap();
    let scene = seven_scenes_fixture(dir.path(), "kitchen");
    let good = own_descriptor(dir.path(), "kitchen = { train = 2, test = 1 }");
    let mut c = fixture_config(&scene);
    c.descriptor = Some(good.to_str().unwrap().into());
    let out = dir.path().join("out");
    ingest_stage::run(&c, &out).unwrap();
    // The file is an input of the stage: its content is in the record.
    let rec: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("stage.json")).unwrap()).unwrap();
    assert!(rec["inputs"]["descriptor"].is_string(), "{rec}");

    // Only the split that differs is named.
    own_descriptor(dir.path(), "kitchen = { train = 2, test = 5 }");
    let (name, _, mismatches, message) = frame_counts(ingest::read_dataset(&c, None).unwrap_err());
    assert_eq!(name, "kitchen");
    assert_eq!(mismatches, [mismatch(Split::Test, 5, 1)]);
    assert!(message.contains("mine dataset descriptor"), "{message}");
    assert!(message.contains(good.to_str().unwrap()), "{message}");
    assert!(!message.contains("train: expected"), "{message}");

    // A parse error names the file, the line and the key.
    std::fs::write(&good, builtin_text("7scenes") + "\nlicense = \"x\"\n").unwrap();
    let e = ingest::read_dataset(&c, None).unwrap_err();
    let message = e.to_string();
    assert!(matches!(
        e,
        IngestError::Descriptor(DescriptorError::Parse { .. })
    ));
    assert!(message.contains(good.to_str().unwrap()), "{message}");
    assert!(message.contains("line "), "{message}");
    assert!(message.contains("license"), "{message}");
}

#[test]
fn scenes_without_counts_are_read() {
    let dir = tempfile::tempdir().unwrap();
    // Not listed in the layout's descriptor (the fixture folder is "scene").
    let scene = seven_scenes(dir.path(), 16, 12);
    ingest::read_dataset(&fixture_config(&scene), None).unwrap();
    // Listed without counts: the synthetic scene, read with its descriptor.
    let room = seven_scenes_fixture(&dir.path().join("b"), "synthroom");
    let mut c = fixture_config(&room);
    c.descriptor = Some("synthetic".into());
    ingest::read_dataset(&c, None).unwrap();
    // Its descriptor has no Kinect: raw depth and calibrated poses are refused.
    for (depth, poses) in [
        (DepthOption::Raw, PoseOption::Published),
        (DepthOption::None, PoseOption::Calibrated),
    ] {
        let mut c = c.clone();
        c.depth = depth;
        c.poses = poses;
        let e = ingest_stage::run(&c, &dir.path().join("out")).unwrap_err();
        assert!(
            matches!(e, IngestError::Descriptor(DescriptorError::Missing { .. })),
            "{e}"
        );
        assert!(e.to_string().contains("datasets/synthetic.toml"), "{e}");
    }
    // A descriptor without the layout.
    let mut c = fixture_config(&scene);
    c.descriptor = Some("cambridge".into());
    let e = ingest::read_dataset(&c, None).unwrap_err().to_string();
    assert!(
        e.contains("has no [layouts.7scenes] section: it describes cambridge"),
        "{e}"
    );
}

#[test]
fn neither_key_changes_the_stage_record_or_the_table() {
    let dir = tempfile::tempdir().unwrap();
    let scene = seven_scenes_fixture(dir.path(), "stairs");
    let run = |c: &IngestConfig, name: &str| {
        let out = dir.path().join(name);
        let o = ingest_stage::run(c, &out).unwrap();
        let rec: serde_json::Value =
            serde_json::from_slice(&std::fs::read(out.join("stage.json")).unwrap()).unwrap();
        (
            rec["config_hash"].clone(),
            rec["inputs"].clone(),
            std::fs::read(o.output.frames_path).unwrap(),
        )
    };
    let mut plain = fixture_config(&scene);
    plain.count_check = false;
    let mut named = plain.clone();
    named.descriptor = Some("7scenes".into());
    assert_eq!(run(&plain, "a"), run(&named, "b"));
    // A rerun with the check on (and the counts still wrong) is refused, not skipped.
    let mut on = plain.clone();
    on.count_check = true;
    let e = ingest_stage::run(&on, &dir.path().join("a")).unwrap_err();
    assert!(matches!(e, IngestError::FrameCounts(_)), "{e}");
}
