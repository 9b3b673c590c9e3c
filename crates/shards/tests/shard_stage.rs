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

/// Records hand-written label tables in `dir` as an import run would (the shard stage
/// reads label tables only with their record).
fn record_labels(dir: &std::path::Path) {
    let mut rec = stage::StageRecord::new("import", String::new(), Default::default());
    for f in tables::labels::LABEL_FILES {
        rec.add_output(dir, f).unwrap();
    }
    rec.save(dir).unwrap();
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
    record_labels(&labels2);
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
    record_labels(&scene.out("labels"));
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

/// Nothing of a refused shard run is left under a final name.
fn assert_nothing_written(out: &std::path::Path) {
    assert!(!out.join(shard_stage::MANIFEST_FILE).exists());
    assert!(!out.join("stage.json").exists());
    let mcap = std::fs::read_dir(out)
        .map(|d| {
            d.filter(|e| {
                e.as_ref()
                    .is_ok_and(|e| e.path().extension().is_some_and(|x| x == "mcap"))
            })
            .count()
        })
        .unwrap_or(0);
    assert_eq!(mcap, 0, "shards written into {}", out.display());
}

/// The shard stage reads the label tables and the frames table only as their stages
/// recorded them: the tables a refused import left behind (its record removed), a table
/// changed after its stage ran, a frames table without its record, another stage's
/// folder given as the labels are each refused naming the file and the stage to run,
/// and nothing is written.
#[test]
fn refuses_tables_their_stage_did_not_record() {
    let scene = scene_with_labels();
    let labels = scene.out("labels");
    let out = scene.out("shards");
    let shard = |labels: &std::path::Path| {
        shard_stage::run(&config(3), &scene.frames_path, labels, &out, None)
            .unwrap_err()
            .to_string()
    };

    let record = std::fs::read(labels.join("stage.json")).unwrap();
    std::fs::remove_file(labels.join("stage.json")).unwrap();
    let e = shard(&labels);
    assert_eq!(
        e,
        format!(
            "{}: missing: points.parquet, lines.parquet, poses.parquet in {} are not the \
             outputs of a finished import or refine run (a refused or killed run leaves no \
             record): run the import or refine stage again",
            labels.join("stage.json").display(),
            labels.display()
        )
    );
    assert_nothing_written(&out);

    std::fs::write(labels.join("stage.json"), &record).unwrap();
    let mut t = LabelTables::read(&labels).unwrap();
    t.poses[0].pose = geometry::Pose::identity();
    t.write(&labels).unwrap();
    let e = shard(&labels);
    assert!(
        e.starts_with(&format!(
            "{}: changed after the import stage recorded it",
            labels.join("poses.parquet").display()
        )) && e.ends_with("run the import stage again"),
        "{e}"
    );
    assert_nothing_written(&out);

    let ingest = scene.frames_path.parent().unwrap();
    let e = shard(ingest);
    assert!(
        e.contains("the record of the ingest stage, expected the import or refine stage's"),
        "{e}"
    );
    assert_nothing_written(&out);

    // The frames table: changed after ingest, then without its record.
    let mut other = scene.table.clone();
    other.meta.scene = "other".into();
    other.write_parquet(&scene.frames_path).unwrap();
    let e = shard(&scene.out("labels"));
    assert!(
        e.starts_with(&format!(
            "{}: changed after the ingest stage recorded it",
            scene.frames_path.display()
        )),
        "{e}"
    );
    std::fs::remove_file(ingest.join("stage.json")).unwrap();
    let e = shard(&scene.out("labels"));
    assert!(
        e.contains("frames.parquet in") && e.ends_with("run the ingest stage again"),
        "{e}"
    );
    assert_nothing_written(&out);
}

/// The one manifest check of every reader (train, score, lock): a manifest edited to drop
/// a shard, a shard replaced after the stage ran, a folder without the stage's record,
/// and an incomplete manifest are refused, naming the file and what to run.
#[test]
fn readers_check_the_manifest_against_the_record() {
    let scene = scene_with_labels();
    let out = scene.out("shards");
    let done = run_all(&scene, 2, &out);
    assert_eq!(
        shards::checked_manifest(&out).unwrap(),
        done.output.manifest
    );
    let manifest_path = out.join(shard_stage::MANIFEST_FILE);
    let original = std::fs::read(&manifest_path).unwrap();
    let record = std::fs::read(out.join("stage.json")).unwrap();

    // One training shard dropped from the list, the plan edited to match.
    let mut edited = done.output.manifest.clone();
    let dropped = edited.shards.remove(1);
    edited.planned_shards -= 1;
    edited.planned_frames -= dropped.frame_count;
    edited.save(&manifest_path).unwrap();
    let e = shards::checked_manifest(&out).unwrap_err().to_string();
    assert!(
        e.starts_with(&format!(
            "{}: changed after the shard stage recorded it",
            manifest_path.display()
        )) && e.ends_with("run the shard stage again"),
        "{e}"
    );

    // Dropped from the list only, with a record to match: still incomplete.
    let mut edited = done.output.manifest.clone();
    edited.shards.remove(1);
    edited.save(&manifest_path).unwrap();
    let mut rec = stage::StageRecord::load(&out).unwrap().unwrap();
    rec.add_output(&out, shard_stage::MANIFEST_FILE).unwrap();
    rec.save(&out).unwrap();
    let e = shards::checked_manifest(&out).unwrap_err().to_string();
    assert_eq!(
        e,
        format!(
            "{}: the manifest is incomplete (missing shard(s) [1], {} of {} planned frames \
             listed): run the shard stage to the end",
            manifest_path.display(),
            done.output.manifest.planned_frames - dropped.frame_count,
            done.output.manifest.planned_frames
        )
    );
    std::fs::write(&manifest_path, &original).unwrap();
    std::fs::write(out.join("stage.json"), &record).unwrap();

    // A shard replaced by another (valid) shard after the stage ran.
    let (a, b) = (
        &done.output.manifest.shards[0],
        &done.output.manifest.shards[1],
    );
    let keep = std::fs::read(out.join(&a.file)).unwrap();
    std::fs::copy(out.join(&b.file), out.join(&a.file)).unwrap();
    let e = shards::checked_manifest(&out).unwrap_err().to_string();
    assert!(
        e.contains(&format!(
            "{}: changed after the shard stage recorded it (sha256 {}",
            a.file, b.sha256
        )) && e.ends_with("run the shard stage again"),
        "{e}"
    );
    std::fs::write(out.join(&a.file), keep).unwrap();
    assert!(shards::checked_manifest(&out).is_ok());

    // No record: the manifest a refused or killed run left is not read.
    std::fs::remove_file(out.join("stage.json")).unwrap();
    let e = shards::checked_manifest(&out).unwrap_err().to_string();
    assert!(
        e.starts_with(&out.join("stage.json").display().to_string())
            && e.contains("manifest.json in")
            && e.ends_with("run the shard stage again"),
        "{e}"
    );
}
