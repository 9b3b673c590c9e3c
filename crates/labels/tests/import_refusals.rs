//! Every inconsistency the import refuses, one test each, with the message it gives.

use labels::NameMapping;
use labels::import::{self, ImportConfig, ImportError, ImportProblem};
use labels::import_stage;
use tables::frames::{Frame, Split};
use testkit::scene::{Scene, SceneOptions};

fn scene() -> Scene {
    Scene::build(&SceneOptions::default())
}

fn refuse(scene: &Scene, config: &ImportConfig) -> ImportError {
    let out = scene.out("labels");
    let e = import_stage::run(
        &scene.with_inputs(config),
        &scene.frames_path,
        &out,
        &import::sift_only,
    )
    .expect_err("the import must refuse this input");
    // Nothing is written for refused input.
    assert!(!out.join("stage.json").exists());
    assert!(!out.join("points.parquet").exists());
    e
}

fn has(e: &ImportError, kind: &str, text: &str) {
    assert!(
        e.problems().iter().any(|p| p.kind() == kind),
        "no {kind} in {:?}",
        e.problems()
    );
    let msg = e.to_string();
    assert!(msg.contains(kind) && msg.contains(text), "{msg}");
}

#[test]
fn refuses_model_images_missing_from_the_dataset() {
    let mut s = scene();
    let mut extra = s.model.images[0].clone();
    extra.image_id = 99;
    extra.name = "seq-07/frame-000123.color.png".into();
    extra.points2d.retain(|p| !p.has_point3d());
    s.model.images.push(extra);
    s.model.frames.clear();
    s.model.rigs.clear();
    s.write_model();
    let e = refuse(&s, &ImportConfig::default());
    has(
        &e,
        "model_image_not_in_dataset",
        "model image 99 \"seq-07/frame-000123.color.png\" (as dataset name \
         \"seq-07/frame-000123.color.png\") is not in the frames table",
    );
    // The hint shows what the frames table's names look like.
    assert!(
        e.to_string()
            .contains("hint: frames table names look like \"seq-01/frame-000000.color.png\""),
        "{e}"
    );
}

#[test]
fn refuses_training_frames_missing_from_the_model() {
    let mut s = scene();
    // A new training frame that neither the model nor LIMAP knows.
    let mut f: Frame = s.train_frames()[0].clone();
    f.name = "seq-01/frame-000999.color.png".into();
    f.id = 1000;
    s.table.frames.push(f);
    s.write_frames();
    let e = refuse(&s, &ImportConfig::default());
    has(
        &e,
        "train_frame_not_in_model",
        "training frame 1000 \"seq-01/frame-000999.color.png\" is not registered in the model",
    );
    // All problems are listed, not only the first.
    has(
        &e,
        "train_frame_not_in_limap",
        "training frame 1000 \"seq-01/frame-000999.color.png\" is not in LIMAP's image_list.txt",
    );
}

#[test]
fn refuses_a_segment_in_two_tracks() {
    let mut s = scene();
    let (img, line) = s.tracks[0].supports().next().unwrap();
    let seg = s.tracks[0].lines2d.as_ref().unwrap()[0];
    let t = &mut s.tracks[1];
    t.image_ids.push(img);
    t.line_ids.push(line);
    t.lines2d.as_mut().unwrap().push(seg);
    s.write_limap();
    let e = refuse(&s, &ImportConfig::default());
    has(
        &e,
        "segment_in_two_tracks",
        &format!(
            "segment {line} of LIMAP image {img} is in two tracks: track_0.txt and track_1.txt"
        ),
    );
}

#[test]
fn refuses_unknown_point3d_ids() {
    // COLMAP's reader already refuses such a model; the import's own check covers
    // models built in memory.
    let s = scene();
    let mut model = s.model.clone();
    let k = model.images[1]
        .points2d
        .iter()
        .position(|p| p.has_point3d())
        .unwrap();
    model.images[1].points2d[k].point3d_id = 777_777;
    let limap = limap::LimapDir::load(&s.limap_dir, &Default::default()).unwrap();
    let e = import::build(&ImportConfig::default(), &s.table, "hash", &model, &limap).unwrap_err();
    has(
        &e,
        "unknown_point3d",
        &format!("model image 2, keypoint {k}: point3D id 777777 is not in points3D"),
    );
}

#[test]
fn refuses_a_model_file_with_unknown_point3d_ids() {
    let mut s = scene();
    let k = s.model.images[1]
        .points2d
        .iter()
        .position(|p| p.has_point3d())
        .unwrap();
    s.model.images[1].points2d[k].point3d_id = 777_777;
    s.write_model();
    let e = refuse(&s, &ImportConfig::default());
    assert!(matches!(e, ImportError::Colmap { .. }), "{e:?}");
    let msg = e.to_string();
    assert!(
        msg.contains("COLMAP model") && msg.contains("777777"),
        "{msg}"
    );
}

#[test]
fn refuses_unknown_line_ids() {
    let mut s = scene();
    s.tracks[2].line_ids[0] = 500;
    s.write_limap();
    let e = refuse(&s, &ImportConfig::default());
    let img = s.tracks[2].image_ids[0];
    has(
        &e,
        "unknown_line_id",
        &format!("track_2.txt support 0: line id 500 is not a row of segments_{img}.txt"),
    );
}

#[test]
fn refuses_unknown_limap_image_ids() {
    let mut s = scene();
    s.tracks[0].image_ids[0] = 4242;
    s.write_limap();
    let e = refuse(&s, &ImportConfig::default());
    has(
        &e,
        "unknown_limap_image",
        "track_0.txt support 0: LIMAP image id 4242 is not in image_list.txt",
    );
    has(
        &e,
        "missing_segments_file",
        "LIMAP image 4242 has no segments_4242.txt",
    );
}

#[test]
fn refuses_limap_names_that_match_no_frame() {
    let mut s = scene();
    s.image_list.images[3].1 = "images/frame-000003.png".into();
    s.write_limap();
    let e = refuse(&s, &ImportConfig::default());
    has(
        &e,
        "limap_image_not_in_dataset",
        "LIMAP image 4 \"images/frame-000003.png\" (as dataset name \"images/frame-000003.png\") \
         is not in the frames table",
    );
    // ... so that training frame has no LIMAP image either.
    has(&e, "train_frame_not_in_limap", "training frame 3");
}

/// Absolute LIMAP names under two different roots: no single prefix explains every
/// name, so none is stripped (never a guess per name) and the names are refused as
/// they are, with nothing written.
#[test]
fn limap_names_under_two_roots_are_refused_as_they_are() {
    let mut s = scene();
    for (k, (_, n)) in s.image_list.images.iter_mut().enumerate() {
        let root = if k == 0 { "/data/a/" } else { "/data/b/" };
        *n = format!("{root}{n}");
    }
    s.write_limap();
    let e = refuse(&s, &ImportConfig::default());
    has(
        &e,
        "limap_image_not_in_dataset",
        "LIMAP image 1 \"/data/a/seq-01/frame-000000.color.png\" (as dataset name \
         \"/data/a/seq-01/frame-000000.color.png\") is not in the frames table",
    );
}

#[test]
fn refuses_names_the_mapping_does_not_apply_to() {
    let s = scene();
    let config = ImportConfig {
        model_names: NameMapping {
            strip_prefix: Some("/data/".into()),
            ..Default::default()
        },
        ..Default::default()
    };
    let e = refuse(&s, &config);
    has(
        &e,
        "model_name_unmappable",
        "model image 1 \"seq-01/frame-000000.color.png\": the model name mapping does not apply: \
         it does not start with the prefix \"/data/\" to strip",
    );
}

#[test]
fn refuses_test_images_in_the_model_unless_allowed() {
    let mut s = scene();
    let test: Frame = s
        .table
        .frames
        .iter()
        .find(|f| f.split == Split::Test)
        .unwrap()
        .clone();
    let mut extra = s.model.images[0].clone();
    extra.image_id = 50;
    extra.name = test.name.clone();
    extra.points2d.retain(|p| !p.has_point3d());
    s.model.images.push(extra);
    s.model.frames.clear();
    s.model.rigs.clear();
    s.write_model();
    let e = refuse(&s, &ImportConfig::default());
    has(
        &e,
        "model_image_is_test_frame",
        &format!(
            "model image 50 {:?} is test frame {}: a model built with test images leaks them",
            test.name, test.id
        ),
    );
    let allowed = ImportConfig {
        allow_test_images: true,
        ..Default::default()
    };
    let out = import_stage::run(
        &s.with_inputs(&allowed),
        &s.frames_path,
        &s.out("allowed"),
        &import::sift_only,
    )
    .unwrap();
    assert_eq!(out.output.report.model.test_images_skipped, 1);
}

#[test]
fn refuses_two_model_images_with_one_dataset_name() {
    let mut s = scene();
    // "frame-000001.color.jpg" and the existing ".png" both become ".png".
    let mut extra = s.model.images[1].clone();
    extra.image_id = 60;
    extra.name = extra.name.replace(".png", ".jpg");
    extra.points2d.retain(|p| !p.has_point3d());
    s.model.images.push(extra);
    s.model.frames.clear();
    s.model.rigs.clear();
    s.write_model();
    let config = ImportConfig {
        model_names: NameMapping {
            replace_extension: Some((".jpg".into(), ".png".into())),
            ..Default::default()
        },
        ..Default::default()
    };
    let e = refuse(&s, &config);
    // The .png names do not end with .jpg: unmappable; the .jpg one maps onto frame 1.
    has(
        &e,
        "model_name_unmappable",
        "does not end with the extension \".jpg\" to replace",
    );
    let config = ImportConfig {
        model_names: NameMapping::identity(),
        ..Default::default()
    };
    let mut s2 = s;
    let taken = s2.model.images[1].name.clone();
    s2.model.images.last_mut().unwrap().name = taken;
    // colmap refuses duplicate names itself; in memory the import reports them.
    let limap = limap::LimapDir::load(&s2.limap_dir, &Default::default()).unwrap();
    let e = import::build(&config, &s2.table, "h", &s2.model, &limap).unwrap_err();
    has(
        &e,
        "duplicate_model_name",
        "model images 2 and 60 both map to the dataset name \"seq-01/frame-000001.color.png\"",
    );
}

#[test]
fn refuses_a_camera_of_another_size() {
    let mut s = scene();
    s.model.cameras[0].camera.width = 1280;
    s.model.cameras[0].camera.height = 960;
    s.write_model();
    let e = refuse(&s, &ImportConfig::default());
    has(
        &e,
        "camera_size_mismatch",
        "training frame 0 \"seq-01/frame-000000.color.png\": the model's camera is 1280x960 but \
         the image is 640x480",
    );
}

#[test]
fn refuses_segments_outside_the_image() {
    let s = scene();
    let config = ImportConfig {
        segment_scale: 2.5,
        ..Default::default()
    };
    let e = refuse(&s, &config);
    has(&e, "segments_outside_image", "outside the 640x480 image");
    assert!(e.to_string().contains("set the segment scale"), "{e}");
}

#[test]
fn segments_just_past_the_border_import_by_default_and_name_lsds_overshoot_when_refused() {
    // LSD's endpoints overshoot the border by up to about 3 px (docs/formats.md): the
    // default tolerance imports them; a tighter one refuses them naming that tolerance,
    // not the segment scale.
    let mut s = scene();
    let image = *s.segments.keys().next().unwrap();
    s.segments.get_mut(&image).unwrap().lines[0][0] = -2.5;
    // The tracks keep a copy of their segments (checked against the segments files).
    for t in &mut s.tracks {
        let supports: Vec<(u32, u32)> = t.supports().collect();
        for (k, support) in supports.into_iter().enumerate() {
            if support == (image, 0) {
                t.lines2d.as_mut().unwrap()[k][0] = -2.5;
            }
        }
    }
    s.write_limap();
    assert_eq!(ImportConfig::default().bounds_tolerance_px, 3.0);
    import_stage::run(
        &s.with_inputs(&ImportConfig::default()),
        &s.frames_path,
        &s.out("tolerated"),
        &import::sift_only,
    )
    .unwrap();
    let tight = ImportConfig {
        bounds_tolerance_px: 1.0,
        ..Default::default()
    };
    let e = refuse(&s, &tight);
    has(
        &e,
        "segments_outside_image",
        "the farthest endpoint 2.50 px past the border (LSD puts endpoints up to about 3 px \
         past the border: import with bounds_tolerance_px = 3 (--bounds-tolerance-px 3))",
    );
}

#[test]
fn refuses_keypoints_outside_the_image() {
    let mut s = scene();
    s.model.images[0].points2d[0].xy = [700.0, 10.0];
    s.write_model();
    let e = refuse(&s, &ImportConfig::default());
    has(
        &e,
        "keypoints_outside_image",
        "training frame 0 \"seq-01/frame-000000.color.png\": 1 keypoint(s) outside the 640x480 \
         image, first #0 at (700, 10)",
    );
}

#[test]
fn refuses_a_training_frame_without_segments() {
    let mut s = scene();
    // Remove the segments of image 5 and every track support in it.
    s.segments.remove(&5);
    for t in &mut s.tracks {
        let keep: Vec<bool> = t.image_ids.iter().map(|&i| i != 5).collect();
        let filt = |v: &mut Vec<u32>| {
            let mut k = keep.iter();
            v.retain(|_| *k.next().unwrap());
        };
        filt(&mut t.image_ids);
        filt(&mut t.line_ids);
        let mut k = keep.iter();
        t.lines2d.as_mut().unwrap().retain(|_| *k.next().unwrap());
    }
    s.write_limap();
    let e = refuse(&s, &ImportConfig::default());
    has(
        &e,
        "train_frame_without_segments",
        "training frame 4 \"seq-01/frame-000004.color.png\" (LIMAP image 5) has no segments_5.txt",
    );
}

#[test]
fn refuses_tracks_whose_segments_differ_from_the_detections() {
    let mut s = scene();
    s.tracks[1].lines2d.as_mut().unwrap()[0][0] += 3.0;
    s.write_limap();
    let e = refuse(&s, &ImportConfig::default());
    has(
        &e,
        "track_segment_mismatch",
        "track_1.txt support 0: its 2D segment differs from row",
    );
}

#[test]
fn refuses_a_frames_table_without_training_frames() {
    let mut s = scene();
    for f in &mut s.table.frames {
        f.split = Split::Test;
    }
    s.write_frames();
    let e = refuse(&s, &ImportConfig::default());
    has(
        &e,
        "no_training_frames",
        "the frames table has no training frames",
    );
}

#[test]
fn refuses_an_invalid_configuration() {
    let s = scene();
    let e = refuse(
        &s,
        &ImportConfig {
            segment_scale: 0.0,
            ..Default::default()
        },
    );
    assert!(matches!(e, ImportError::Config(_)), "{e}");
    assert!(
        e.to_string().contains("segment_scale must be positive"),
        "{e}"
    );
}

#[test]
fn lists_every_problem_with_counts_and_examples() {
    let mut s = scene();
    for (k, (_, n)) in s.image_list.images.iter_mut().enumerate() {
        *n = format!("elsewhere/{k}.png");
    }
    s.write_limap();
    let e = refuse(&s, &ImportConfig::default());
    let n = s.train_frames().len();
    let count = |kind: &str| e.problems().iter().filter(|p| p.kind() == kind).count();
    assert_eq!(count("limap_image_not_in_dataset"), n);
    assert_eq!(count("train_frame_not_in_limap"), n);
    let msg = e.to_string();
    assert!(
        msg.starts_with(&format!(
            "{} problem(s) in the import inputs, of 2 kind(s):",
            2 * n
        )),
        "{msg}"
    );
    assert!(
        msg.contains(&format!("limap_image_not_in_dataset: {n}")),
        "{msg}"
    );
    assert!(msg.contains(&format!("... and {} more", n - 5)), "{msg}");
    // Problems serialise with their kind, for machine-readable reports.
    let json = serde_json::to_string(&e.problems()[0]).unwrap();
    assert!(
        json.starts_with(r#"{"kind":"limap_image_not_in_dataset""#),
        "{json}"
    );
    assert!(matches!(
        e.problems()[0],
        ImportProblem::LimapImageNotInDataset { .. }
    ));
}
