//! The shard stage: shards hold the label tables exactly, test frames go into their own
//! shards, work units add up to a single run, bad inputs are refused.

use labels::LabelTables;
use labels::import::{self, ImportConfig};
use labels::import_stage;
use shards::shard_stage::{self, ShardStageConfig, ShardStageError};
use shards::{Manifest, ShardReader};
use std::collections::HashMap;
use tables::frames::Split;
use testkit::files::folder_bytes;
use testkit::scene::{Scene, SceneOptions};

fn scene_with_labels() -> Scene {
    let scene = Scene::build(&SceneOptions {
        n_train: 7,
        n_test: 3,
        noise_sigma_m: 0.01,
        seed: 3,
        ..Default::default()
    });
    import_stage::run(
        &scene.with_inputs(&ImportConfig::default()),
        &scene.frames_path,
        &scene.out("labels"),
        &import::sift_only,
    )
    .unwrap();
    scene
}

fn config(frames_per_shard: usize) -> ShardStageConfig {
    ShardStageConfig {
        frames_per_shard,
        ..Default::default()
    }
}

/// The whole shard stage over the scene's imported labels into `out`.
fn run_all(
    scene: &Scene,
    frames_per_shard: usize,
    out: &std::path::Path,
) -> stage::Done<shard_stage::ShardOutput> {
    shard_stage::run(
        &config(frames_per_shard),
        &scene.frames_path,
        &scene.out("labels"),
        out,
        None,
    )
    .unwrap()
}

#[test]
fn shards_hold_the_label_tables_and_the_test_frames() {
    let scene = scene_with_labels();
    let out = scene.out("shards");
    let o = run_all(&scene, 3, &out);
    assert!(o.output.complete && !o.skipped);
    let m = Manifest::load(out.join(shard_stage::MANIFEST_FILE)).unwrap();
    assert_eq!(m, o.output.manifest);
    // 7 training frames in 3 shards, 3 test frames in 1.
    let files: Vec<&str> = m.shards.iter().map(|s| s.file.as_str()).collect();
    assert_eq!(
        files,
        [
            "train-00000.mcap",
            "train-00001.mcap",
            "train-00002.mcap",
            "test-00000.mcap"
        ]
    );
    assert_eq!(shard_stage::shards_of_split(&m, Split::Test).len(), 1);
    assert!(m.is_complete());
    assert_eq!(m.planned_frames, 10);
    assert_eq!(m.inputs.len(), 4);

    let t = LabelTables::read(&scene.out("labels")).unwrap();
    let poses: HashMap<u32, _> = t.poses.iter().map(|p| (p.frame_id, p)).collect();
    let mut reader = ShardReader::open(m.shard_paths(&out)).unwrap();
    let mut seen = 0;
    for rec in &mut reader {
        let rec = rec.unwrap();
        let f = scene
            .table
            .frames
            .iter()
            .find(|f| u64::from(f.id) == rec.frame_id)
            .unwrap();
        assert_eq!(rec.name, f.name);
        // Original bytes, untouched.
        assert_eq!(rec.image_bytes, std::fs::read(&f.path).unwrap());
        assert_eq!(rec.image_format, shards::ImageFormat::Png);
        match f.split {
            Split::Train => {
                assert_eq!(rec.split, Split::Train);
                let p = poses[&f.id];
                assert_eq!(rec.camera, p.camera);
                assert_eq!(rec.pose.qvec(), p.pose.qvec());
                assert_eq!(rec.pose.tvec(), p.pose.tvec());
                let rows: Vec<_> = t.points.iter().filter(|r| r.frame_id == f.id).collect();
                assert_eq!(rec.keypoints.len(), rows.len());
                for (i, r) in rows.iter().enumerate() {
                    assert_eq!(rec.keypoints[i], r.xy);
                    assert_eq!(rec.point3d_ids[i], r.point3d_id);
                    assert_eq!(rec.point_valid[i], r.xyz.is_some());
                    if let Some(x) = r.xyz {
                        assert_eq!(rec.points3d[i], x);
                    }
                }
                let rows: Vec<_> = t.lines.iter().filter(|r| r.frame_id == f.id).collect();
                assert_eq!(rec.segments.len(), rows.len());
                for (i, r) in rows.iter().enumerate() {
                    assert_eq!(rec.segments[i], r.segment);
                    assert_eq!(rec.track_ids[i], r.track_id);
                    assert_eq!(rec.line_valid[i], r.endpoints.is_some());
                    if let Some([a, b]) = r.endpoints {
                        assert_eq!(rec.lines3d[i], [a[0], a[1], a[2], b[0], b[1], b[2]]);
                    }
                }
                assert_eq!(rec.label_source, shards::LabelSource::Sfm);
                assert!(rec.endpoints_aligned);
            }
            Split::Test => {
                assert_eq!(rec.split, Split::Test);
                assert_eq!(rec.camera, f.camera);
                assert_eq!(rec.pose.qvec(), f.pose.qvec());
                assert!(rec.keypoints.is_empty() && rec.segments.is_empty());
            }
        }
        seen += 1;
    }
    assert_eq!(seen, 10);

    // Rerun: skipped. Different frames per shard: a new plan, rewritten.
    let again = run_all(&scene, 3, &out);
    assert!(again.skipped);
    assert_eq!(again.output.manifest, m);
    let other = run_all(&scene, 4, &out);
    assert!(!other.skipped);
    assert_eq!(other.output.manifest.planned_shards, 3);
}

#[test]
fn work_units_add_up_to_a_single_run() {
    let scene = scene_with_labels();
    let labels = scene.out("labels");
    let whole = scene.out("whole");
    let units = scene.out("units");
    let full = shard_stage::run(&config(2), &scene.frames_path, &labels, &whole, None).unwrap();
    assert_eq!(full.output.manifest.planned_shards, 6);
    let a = shard_stage::run(&config(2), &scene.frames_path, &labels, &units, Some(3..6)).unwrap();
    assert!(!a.output.complete);
    assert!(!units.join(shard_stage::MANIFEST_FILE).exists());
    let b = shard_stage::run(&config(2), &scene.frames_path, &labels, &units, Some(0..3)).unwrap();
    assert!(b.output.complete);
    // Same shard bytes, same manifest bytes, same stage record.
    let (w, u) = (folder_bytes(&whole), folder_bytes(&units));
    for (name, bytes) in &w {
        assert_eq!(Some(bytes), u.get(name), "{name}");
    }
    assert!(u.contains_key("manifest.0-3.json") && u.contains_key("manifest.3-6.json"));
    // A unit rerun is skipped.
    let again =
        shard_stage::run(&config(2), &scene.frames_path, &labels, &units, Some(0..3)).unwrap();
    assert!(again.skipped && again.output.complete);
    // A range past the plan is refused.
    let e =
        shard_stage::run(&config(2), &scene.frames_path, &labels, &units, Some(5..9)).unwrap_err();
    assert_eq!(
        e.to_string(),
        "shard range 5..9 is outside the plan's 6 shards"
    );
}

/// New labels for one frame (as a nightly run brings new frames or labels): only the
/// shard holding it is rewritten, a tampered shard is rewritten too, every other shard
/// is kept, and the folder ends up byte for byte what a fresh run writes.
#[test]
fn only_shards_whose_frames_changed_are_rewritten() {
    let scene = scene_with_labels();
    let out = scene.out("shards");
    let first = run_all(&scene, 2, &out);
    assert!(first.output.reused.is_empty());
    let m = &first.output.manifest;
    assert_eq!(m.planned_shards, 6);
    for s in &m.shards {
        assert!(
            out.join(format!("{}{}", s.file, shards::SOURCE_SUFFIX))
                .is_file()
        );
    }

    // Move the labelled points of the last training frame by 1 cm.
    let mut tables = LabelTables::read(&scene.out("labels")).unwrap();
    let changed = tables.poses.iter().map(|p| p.frame_id).max().unwrap();
    for p in tables.points.iter_mut().filter(|p| p.frame_id == changed) {
        if let Some(x) = &mut p.xyz {
            x[0] += 0.01;
        }
    }
    let labels2 = scene.out("labels2");
    std::fs::create_dir_all(&labels2).unwrap();
    tables.write(&labels2).unwrap();
    let holder = m
        .shards
        .iter()
        .find(|s| (s.first_frame..=s.last_frame).contains(&u64::from(changed)))
        .unwrap()
        .index;
    // And damage another training shard (one byte appended).
    let damaged = (holder + 1) % 4;
    let damaged_file = out.join(&m.shards[damaged].file);
    let mut bytes = std::fs::read(&damaged_file).unwrap();
    bytes.push(0);
    std::fs::write(&damaged_file, bytes).unwrap();

    let second = shard_stage::run(&config(2), &scene.frames_path, &labels2, &out, None).unwrap();
    assert!(!second.skipped && second.output.complete);
    let expected: Vec<usize> = (0..6).filter(|&i| i != holder && i != damaged).collect();
    assert_eq!(second.output.reused, expected);
    assert_ne!(
        second.output.manifest.shards[holder].sha256,
        m.shards[holder].sha256
    );
    assert_eq!(second.output.manifest.shards[damaged], m.shards[damaged]);

    let fresh = scene.out("fresh");
    let third = shard_stage::run(&config(2), &scene.frames_path, &labels2, &fresh, None).unwrap();
    assert!(third.output.reused.is_empty());
    assert_eq!(third.output.manifest, second.output.manifest);
    assert_eq!(folder_bytes(&out), folder_bytes(&fresh));
    // Another layout gives other digests: nothing is kept.
    let other = shard_stage::run(
        &ShardStageConfig {
            zstd_level: 4,
            ..config(2)
        },
        &scene.frames_path,
        &labels2,
        &out,
        None,
    )
    .unwrap();
    assert!(other.output.reused.is_empty());
}

#[test]
fn same_bytes_for_any_thread_count() {
    let scene = scene_with_labels();
    let run_with = |threads: usize, out: &str| {
        testkit::on_threads(threads, || {
            shard_stage::run(
                &config(2),
                &scene.frames_path,
                &scene.out("labels"),
                &scene.out(out),
                None,
            )
            .unwrap()
        })
    };
    run_with(1, "one");
    run_with(2, "two");
    assert_eq!(
        folder_bytes(&scene.out("one")),
        folder_bytes(&scene.out("two"))
    );
}

#[test]
fn refuses_an_image_that_changed_since_ingest() {
    let scene = scene_with_labels();
    let f = &scene.train_frames()[4];
    let mut bytes = std::fs::read(&f.path).unwrap();
    let n = bytes.len();
    bytes[n - 20] ^= 1;
    std::fs::write(&f.path, &bytes).unwrap();
    let out = scene.out("shards");
    let e = shard_stage::run(
        &config(3),
        &scene.frames_path,
        &scene.out("labels"),
        &out,
        None,
    )
    .unwrap_err();
    let msg = format!(
        "{e}: {}",
        std::error::Error::source(&e)
            .map(|s| s.to_string())
            .unwrap_or_default()
    );
    assert!(
        msg.contains("frame 4") && msg.contains("the file changed since ingest"),
        "{msg}"
    );
    assert!(!out.join(shard_stage::MANIFEST_FILE).exists());
    assert!(!out.join("stage.json").exists());
}

#[test]
fn refuses_labels_of_another_frames_table() {
    let mut scene = scene_with_labels();
    scene.table.meta.scene = "other".into();
    scene.write_frames();
    let e = shard_stage::run(
        &config(3),
        &scene.frames_path,
        &scene.out("labels"),
        &scene.out("shards"),
        None,
    )
    .unwrap_err();
    assert!(
        matches!(
            e,
            ShardStageError::Table(tables::TableError::OtherFrames { .. })
        ),
        "{e:?}"
    );
}

#[test]
fn refuses_labels_that_miss_training_frames() {
    let scene = scene_with_labels();
    let mut t = LabelTables::read(&scene.out("labels")).unwrap();
    t.poses.retain(|p| p.frame_id != 2);
    t.points.retain(|p| p.frame_id != 2);
    t.lines.retain(|p| p.frame_id != 2);
    t.write(&scene.out("labels")).unwrap();
    let e = shard_stage::run(
        &config(3),
        &scene.frames_path,
        &scene.out("labels"),
        &scene.out("shards"),
        None,
    )
    .unwrap_err();
    assert_eq!(
        e.to_string(),
        "the label tables do not cover the training frames: 1 training frame(s) without labels \
         (first Some(2)), 0 labelled frame(s) that are not training frames (first None)"
    );
}

/// The label tables' track set reaches the manifest: named for alltracks, absent (and
/// the manifest's bytes as before) for the default finaltracks.
#[test]
fn the_manifest_records_the_line_track_set() {
    let scene = scene_with_labels();
    let alltracks = ImportConfig {
        line_tracks: import::LineTrackSet::Alltracks,
        ..Default::default()
    };
    import_stage::run(
        &scene.with_inputs(&alltracks),
        &scene.frames_path,
        &scene.out("labels-all"),
        &import::sift_only,
    )
    .unwrap();
    let tables = LabelTables::read(&scene.out("labels-all")).unwrap();
    assert_eq!(tables.line_tracks.as_deref(), Some("alltracks"));
    let run = |labels: &str, out: &str| {
        shard_stage::run(
            &config(4),
            &scene.frames_path,
            &scene.out(labels),
            &scene.out(out),
            None,
        )
        .unwrap()
        .output
        .manifest
    };
    let all = run("labels-all", "shards-all");
    assert_eq!(all.line_tracks.as_deref(), Some("alltracks"));
    let on_disk = Manifest::load(scene.out("shards-all").join(shard_stage::MANIFEST_FILE)).unwrap();
    assert_eq!(on_disk.line_tracks.as_deref(), Some("alltracks"));
    let fin = run("labels", "shards-final");
    assert_eq!(fin.line_tracks, None);
    let text = std::fs::read_to_string(scene.out("shards-final").join(shard_stage::MANIFEST_FILE))
        .unwrap();
    assert!(!text.contains("line_tracks"), "{text}");
}
