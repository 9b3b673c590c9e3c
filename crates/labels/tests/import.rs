//! The import stage on the analytic scene: exact labels, endpoint order, pose report,
//! name mapping, determinism and stage records.

use geometry::{Vector2, Vector3};
use labels::import::{self, ImportConfig, LineTrackSet};
use labels::import_stage;
use labels::{LabelTables, NameMapping, PoseSource};
use std::collections::HashMap;
use tables::frames::Split;
use testkit::files::folder_bytes;
use testkit::scene::{Scene, SceneOptions};

fn import(
    scene: &Scene,
    config: &ImportConfig,
    out: &str,
) -> (stage::Done<import_stage::ImportOutput>, LabelTables) {
    let out = scene.out(out);
    let o = import_stage::run(
        &scene.with_inputs(config),
        &scene.frames_path,
        &out,
        &import::sift_only,
    )
    .unwrap_or_else(|e| panic!("{e}"));
    (o, LabelTables::read(&out).unwrap())
}

#[test]
fn import_recovers_every_label_exactly() {
    let scene = Scene::build(&SceneOptions::default());
    let (out, t) = import(&scene, &ImportConfig::default(), "labels");
    let train = scene.train_frames();
    assert_eq!(t.poses.len(), train.len());
    // Every keypoint of every registered image, in order, with its point's xyz.
    let mut expected_points = 0;
    for (k, f) in train.iter().enumerate() {
        let image = &scene.model.images[k];
        assert_eq!(image.name, f.name);
        let rows: Vec<_> = t.points.iter().filter(|r| r.frame_id == f.id).collect();
        assert_eq!(rows.len(), image.points2d.len());
        for (i, (r, p)) in rows.iter().zip(&image.points2d).enumerate() {
            assert_eq!(r.kp_index as usize, i);
            assert_eq!(r.xy, p.xy);
            if p.has_point3d() {
                assert_eq!(r.point3d_id as u64, p.point3d_id);
                assert_eq!(r.xyz, Some(scene.gt_points[&p.point3d_id]));
                expected_points += 1;
            } else {
                assert_eq!((r.point3d_id, r.xyz), (-1, None));
            }
        }
        // Segments: the file's rows, in order; stray detections have no track.
        let lid = k as u32 + 1;
        let segs = &scene.segments[&lid].lines;
        let rows: Vec<_> = t.lines.iter().filter(|r| r.frame_id == f.id).collect();
        assert_eq!(rows.len(), segs.len());
        for (i, (r, s)) in rows.iter().zip(segs).enumerate() {
            assert_eq!((r.seg_index as usize, r.segment), (i, *s));
            let track = scene
                .tracks
                .iter()
                .position(|t| t.supports().any(|x| x == (lid, i as u32)));
            match track {
                Some(ti) => {
                    assert_eq!(r.track_id, ti as i64);
                    let gt = scene.gt_tracks[ti];
                    let rev = scene.reversed[&(lid, i as u32)];
                    assert_eq!(r.swapped, rev, "frame {} segment {i}", f.id);
                    let want = if rev { [gt[1], gt[0]] } else { gt };
                    // LIMAP track files hold 10 decimals.
                    let got = r.endpoints.unwrap();
                    for (g, w) in got.iter().flatten().zip(want.iter().flatten()) {
                        assert!((g - w).abs() < 1e-9, "{got:?} vs {want:?}");
                    }
                }
                None => assert_eq!((r.track_id, r.endpoints), (-1, None)),
            }
        }
    }
    let rep = &out.output.report;
    assert_eq!(rep.points.valid, expected_points);
    assert_eq!(rep.points.keypoints, t.points.len());
    assert_eq!(rep.points.without_point3d, 3 * train.len());
    assert_eq!(rep.points.points3d_observed, scene.gt_points.len());
    assert_eq!(rep.lines.in_no_track, 2 * train.len());
    assert_eq!(rep.lines.valid, scene.reversed.len());
    assert_eq!(
        rep.lines.swapped,
        scene.reversed.values().filter(|&&r| r).count()
    );
    assert_eq!(rep.lines.aligned_by_projection, rep.lines.valid);
    assert_eq!(rep.limap.tracks_used, scene.tracks.len());
    assert!(rep.warnings.is_empty(), "{:?}", rep.warnings);
    print!("{}", rep.table());
}

#[test]
fn first_endpoint_projects_onto_the_segment_start() {
    // Checked by projection (not through the construction's bookkeeping), with noisy
    // endpoints: the order must still follow each detection.
    let scene = Scene::build(&SceneOptions {
        noise_sigma_m: 0.02,
        ..Default::default()
    });
    let (_, t) = import(&scene, &ImportConfig::default(), "labels");
    let poses: HashMap<u32, _> = t.poses.iter().map(|p| (p.frame_id, p)).collect();
    let mut checked = 0;
    for r in t.lines.iter().filter(|r| r.endpoints.is_some()) {
        let v = poses[&r.frame_id];
        let e = r.endpoints.unwrap();
        let px = |x: [f64; 3]| {
            v.camera
                .project(&v.pose.transform_point(&Vector3::from(x)))
                .unwrap()
        };
        let s = Vector2::new(r.segment[0], r.segment[1]);
        let en = Vector2::new(r.segment[2], r.segment[3]);
        assert!((px(e[0]) - s).norm() < (px(e[1]) - s).norm());
        assert!((px(e[1]) - en).norm() < (px(e[0]) - en).norm());
        checked += 1;
    }
    assert!(checked > 50, "{checked}");
}

#[test]
fn pose_disagreement_is_reported_and_the_pose_source_chosen() {
    let mut scene = Scene::build(&SceneOptions::default());
    // Move the SfM pose of the third training frame by 3 cm and 0.5 degrees.
    let f = scene.train_frames()[2].clone();
    let im = &mut scene.model.images[2];
    let moved = geometry::Pose::new(
        geometry::UnitQuaternion::from_axis_angle(&Vector3::z_axis(), 0.5f64.to_radians())
            * f.pose.rotation,
        Vector3::zeros(),
    );
    // Same centre moved by (0.03, 0, 0).
    let centre = f.pose.centre() + Vector3::new(0.03, 0.0, 0.0);
    let moved = geometry::Pose::new(moved.rotation, -(moved.rotation * centre));
    im.qvec = moved.qvec();
    im.tvec = moved.tvec();
    scene.model.frames.clear();
    scene.model.rigs.clear();
    scene.write_model();

    let (out, t) = import(&scene, &ImportConfig::default(), "sfm");
    let d = &out.output.report.pose_disagreement;
    assert!((d.translation_m.max - 0.03).abs() < 1e-9, "{:?}", d);
    assert!((d.rotation_deg.max - 0.5).abs() < 1e-9, "{:?}", d);
    assert!(d.translation_m.median < 1e-12);
    assert!(d.worst_frame.as_deref().unwrap().starts_with(&f.name));
    assert_eq!(t.pose_source, PoseSource::Sfm);
    let row = t.poses.iter().find(|p| p.frame_id == f.id).unwrap();
    assert!((row.pose.centre() - centre).norm() < 1e-12);

    let config = ImportConfig {
        pose_source: PoseSource::Dataset,
        ..Default::default()
    };
    let (_, t) = import(&scene, &config, "dataset");
    assert_eq!(t.pose_source, PoseSource::Dataset);
    let row = t.poses.iter().find(|p| p.frame_id == f.id).unwrap();
    assert_eq!(row.pose, f.pose);
    assert_eq!(row.camera, f.camera);
}

#[test]
fn explicit_name_mappings_join_renamed_models() {
    let mut scene = Scene::build(&SceneOptions::default());
    // The model says "frame-000000.color.jpg", LIMAP "/data/box/seq-01/frame-000000.color.png".
    for im in &mut scene.model.images {
        im.name = im
            .name
            .trim_start_matches("seq-01/")
            .replace(".png", ".jpg");
    }
    for (_, n) in &mut scene.image_list.images {
        *n = format!("/data/box/{n}");
    }
    scene.write_model();
    scene.write_limap();
    // The identity mapping refuses: no guessing.
    let e = import_stage::run(
        &scene.with_inputs(&ImportConfig::default()),
        &scene.frames_path,
        &scene.out("identity"),
        &import::sift_only,
    )
    .unwrap_err();
    assert!(!e.problems().is_empty());
    let config = ImportConfig {
        model_names: NameMapping {
            strip_prefix: None,
            add_prefix: Some("seq-01/".into()),
            replace_extension: Some((".jpg".into(), ".png".into())),
        },
        limap_names: NameMapping {
            strip_prefix: Some("/data/box/".into()),
            ..Default::default()
        },
        ..Default::default()
    };
    let (out, t) = import(&scene, &config, "mapped");
    assert_eq!(t.poses.len(), scene.train_frames().len());
    assert_eq!(out.output.report.points.valid, {
        let plain = Scene::build(&SceneOptions::default());
        let (o, _) = import(&plain, &ImportConfig::default(), "plain");
        o.output.report.points.valid
    });
}

/// The scene's LIMAP folder as LIMAP 1.x's runners wrote it: image ids from 0 (the
/// positions in LIMAP's image collection) and `image_list.txt` in the list form
/// (`save_txt_imname_list`: the count, then one name per line) with `root` before every
/// name.
fn as_limap_1x_list(scene: &mut Scene, root: impl Fn(usize) -> String) {
    for (id, _) in &mut scene.image_list.images {
        *id -= 1;
    }
    scene.segments = std::mem::take(&mut scene.segments)
        .into_iter()
        .map(|(id, s)| (id - 1, s))
        .collect();
    for t in &mut scene.tracks {
        for id in &mut t.image_ids {
            *id -= 1;
        }
    }
    scene.write_limap();
    let mut text = format!("number of images, {}\n", scene.image_list.len());
    for (k, (_, name)) in scene.image_list.images.iter().enumerate() {
        text.push_str(&format!("{}{name}\n", root(k)));
    }
    std::fs::write(scene.limap_dir.join("image_list.txt"), text).unwrap();
}

/// LIMAP 1.x's absolute image paths in its list-form image_list.txt import without a
/// `limap_names` mapping: the dataset root common to every name is stripped, the report
/// (import_report.json and the printed table) says which, and the labels are those of
/// the same scene with relative names.
#[test]
fn limap_1x_absolute_paths_in_the_list_form_import_with_the_root_stripped() {
    let plain = Scene::build(&SceneOptions::default());
    let (p, plain_tables) = import(&plain, &ImportConfig::default(), "plain");
    assert_eq!(p.output.report.limap.root_prefix_stripped, None);

    let mut scene = Scene::build(&SceneOptions::default());
    let root = format!("{}/", scene.dir.path().join("data/7scenes/box").display());
    as_limap_1x_list(&mut scene, |_| root.clone());
    let (out, t) = import(&scene, &ImportConfig::default(), "labels");
    let rep = &out.output.report;
    assert_eq!(
        rep.limap.root_prefix_stripped.as_deref(),
        Some(root.as_str())
    );
    assert!(
        rep.table()
            .contains(&format!("LIMAP names: the dataset root {root:?} stripped")),
        "{}",
        rep.table()
    );
    let json = std::fs::read_to_string(scene.out("labels").join("import_report.json")).unwrap();
    assert!(
        json.contains(&format!("\"root_prefix_stripped\": {root:?}")),
        "{json}"
    );
    assert_eq!(t.points, plain_tables.points);
    assert_eq!(t.lines, plain_tables.lines);
    assert_eq!(rep.lines.valid, p.output.report.lines.valid);
    // LIMAP's ids are the list's positions: one less than the model's, which the report
    // explains instead of suspecting a model of another run.
    for row in &t.poses {
        assert_eq!(row.limap_image_id + 1, row.sfm_image_id, "{}", row.name);
    }
    assert_eq!(
        rep.warnings,
        [format!(
            "{} training frame(s) have a LIMAP image id different from their COLMAP image id \
             (joined by name; LIMAP numbers these images by position from 0, as LIMAP 1.x did)",
            t.poses.len()
        )]
    );
    // Without the report field when the names join as they are (the synthetic pipeline's
    // report keeps its bytes).
    let plain_json =
        std::fs::read_to_string(plain.out("plain").join("import_report.json")).unwrap();
    assert!(!plain_json.contains("root_prefix_stripped"), "{plain_json}");
}

#[test]
fn same_inputs_give_the_same_bytes_and_reruns_are_skipped() {
    let scene = Scene::build(&SceneOptions {
        noise_sigma_m: 0.01,
        ..Default::default()
    });
    let config = ImportConfig::default();
    let (a, _) = import(&scene, &config, "a");
    let (b, _) = import(&scene, &config, "b");
    assert!(!a.skipped && !b.skipped);
    let (fa, fb) = (folder_bytes(&scene.out("a")), folder_bytes(&scene.out("b")));
    assert_eq!(
        fa.keys().collect::<Vec<_>>(),
        [
            // The folder's guard (stage::FolderGuard), empty once released.
            ".pl2map.lock",
            "import_report.json",
            "lines.parquet",
            "points.parquet",
            "poses.parquet",
            "stage.json"
        ]
    );
    assert_eq!(fa, fb);

    // Rerun: skipped, same report.
    let (again, _) = import(&scene, &config, "a");
    assert!(again.skipped);
    assert_eq!(again.output.report, a.output.report);
    // A changed configuration, a changed input or a damaged output reruns it.
    let other = ImportConfig {
        bounds_tolerance_px: 2.0,
        ..config.clone()
    };
    assert!(!import(&scene, &other, "a").0.skipped);
    assert!(import(&scene, &other, "a").0.skipped);
    std::fs::write(scene.out("a").join("lines.parquet"), b"damaged").unwrap();
    assert!(!import(&scene, &other, "a").0.skipped);
    let mut scene = scene;
    scene.tracks[0].line[0][0] += 0.1;
    scene.write_limap();
    let (o, t) = import(&scene, &other, "a");
    assert!(!o.skipped);
    assert!(t.lines.iter().any(|r| r.track_id == 0));
    // Frames of the test split never get labels.
    let test_ids: Vec<u32> = scene
        .table
        .frames
        .iter()
        .filter(|f| f.split == Split::Test)
        .map(|f| f.id)
        .collect();
    assert!(t.points.iter().all(|r| !test_ids.contains(&r.frame_id)));
}

#[test]
fn text_models_import_like_binary_ones() {
    let scene = Scene::build(&SceneOptions::default());
    let (_, bin) = import(&scene, &ImportConfig::default(), "bin");
    std::fs::remove_dir_all(&scene.model_dir).unwrap();
    colmap::write_text(&scene.model, &scene.model_dir).unwrap();
    let (_, txt) = import(&scene, &ImportConfig::default(), "txt");
    assert_eq!(bin, txt);
}

/// (frame id, segment index) -> (track id, endpoints) of the labelled lines.
type LineLabels = HashMap<(u32, u32), (i64, [[f64; 3]; 2])>;

/// LIMAP's alltracks.txt holds the tracks seen in at least 4 distinct images: the labels
/// from it are the finaltracks labels of exactly those tracks (counted here from the
/// scene's own tracks, not by the limap crate), with the same segments and endpoints.
#[test]
fn alltracks_labels_are_the_finaltracks_labels_of_tracks_seen_in_four_images() {
    let scene = Scene::build(&SceneOptions::default());
    let (_, fin) = import(&scene, &ImportConfig::default(), "final");
    let config = ImportConfig {
        line_tracks: LineTrackSet::Alltracks,
        ..Default::default()
    };
    let (out, all) = import(&scene, &config, "all");
    let kept: Vec<i64> = scene
        .tracks
        .iter()
        .enumerate()
        .filter(|(_, t)| {
            let mut ids = t.image_ids.clone();
            ids.sort_unstable();
            ids.dedup();
            ids.len() >= 4
        })
        .map(|(i, _)| i as i64)
        .collect();
    assert!(
        !kept.is_empty() && kept.len() < scene.tracks.len(),
        "the scene needs tracks on both sides of 4 images: {} of {}",
        kept.len(),
        scene.tracks.len()
    );
    let labelled = |t: &LabelTables| -> LineLabels {
        t.lines
            .iter()
            .filter_map(|r| {
                r.endpoints
                    .map(|e| ((r.frame_id, r.seg_index), (r.track_id, e)))
            })
            .collect()
    };
    let (fin, all) = (labelled(&fin), labelled(&all));
    let expected: LineLabels = fin
        .iter()
        .filter_map(|(k, (t, e))| {
            // alltracks numbers its tracks 0, 1, ... in finaltracks order.
            kept.iter()
                .position(|x| x == t)
                .map(|rank| (*k, (rank as i64, *e)))
        })
        .collect();
    assert!(!expected.is_empty() && expected.len() < fin.len());
    assert_eq!(all, expected);
    assert_eq!(
        out.output.report.config.line_tracks,
        LineTrackSet::Alltracks
    );
    assert_eq!(out.output.report.limap.tracks, kept.len());
}

#[test]
fn alltracks_without_the_file_is_refused_naming_it() {
    let scene = Scene::build(&SceneOptions::default());
    std::fs::remove_file(scene.limap_dir.join("alltracks.txt")).unwrap();
    let config = ImportConfig {
        line_tracks: LineTrackSet::Alltracks,
        ..Default::default()
    };
    let e = import_stage::run(
        &scene.with_inputs(&config),
        &scene.frames_path,
        &scene.out("x"),
        &import::sift_only,
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("alltracks.txt does not exist"), "{e}");
}
