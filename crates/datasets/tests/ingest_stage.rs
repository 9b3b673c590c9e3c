//! The ingest stage folder: skipped reruns, reruns on any change, identical bytes for any
//! thread count.

use datasets::ingest::{DatasetKind, DepthOption, IngestConfig, PoseOption};
use datasets::ingest_stage;
use std::path::Path;
use tables::frames::FramesTable;
use testkit::layouts::{fixture_pose, pose_txt, seven_scenes};

fn config(scene: &Path) -> IngestConfig {
    let mut c = IngestConfig::new(DatasetKind::SevenScenes, scene);
    c.camera = Some("SIMPLE_PINHOLE 16 12 10 8 6".into());
    c.depth = DepthOption::Raw;
    c
}

fn record(out: &Path) -> serde_json::Value {
    serde_json::from_slice(&std::fs::read(out.join("stage.json")).unwrap()).unwrap()
}

#[test]
fn rerun_is_skipped_until_something_changes() {
    let dir = tempfile::tempdir().unwrap();
    let scene = seven_scenes(dir.path(), 16, 12);
    let out = dir.path().join("work/ingest");
    let c = config(&scene);

    let first = ingest_stage::run(&c, &out).unwrap();
    assert!(!first.skipped);
    let rec = record(&out);
    assert_eq!(rec["stage"], "ingest");
    let outputs = rec["outputs"].as_object().unwrap();
    // frames.parquet and one registered depth map per frame.
    assert_eq!(outputs.len(), 4, "{outputs:?}");
    assert!(outputs.contains_key("depth/seq-02/frame-000000.depth.png"));
    let inputs = rec["inputs"].as_object().unwrap();
    let mut keys: Vec<&str> = inputs.keys().map(String::as_str).collect();
    keys.sort_unstable();
    assert_eq!(keys, ["depth", "images", "poses", "splits"]);

    let second = ingest_stage::run(&c, &out).unwrap();
    assert!(second.skipped);
    assert_eq!(second.output.table, first.output.table);

    // Another configuration reruns.
    let mut c2 = c.clone();
    c2.poses = PoseOption::Calibrated;
    assert!(!ingest_stage::run(&c2, &out).unwrap().skipped);
    assert!(ingest_stage::run(&c2, &out).unwrap().skipped);

    // Changed input content (same size, same name) reruns.
    let pose = scene.join("seq-01/frame-000000.pose.txt");
    std::fs::write(&pose, pose_txt(&fixture_pose(7).inverse().to_matrix())).unwrap();
    let third = ingest_stage::run(&c2, &out).unwrap();
    assert!(!third.skipped);
    assert_ne!(
        third.output.table.frames[0].pose,
        first.output.table.frames[0].pose
    );

    // A modified or deleted output reruns, and restores it.
    let parquet = out.join("frames.parquet");
    std::fs::write(&parquet, b"tampered").unwrap();
    assert!(!ingest_stage::run(&c2, &out).unwrap().skipped);
    assert!(FramesTable::read_parquet(&parquet).is_ok());
    std::fs::remove_file(out.join("depth/seq-01/frame-000001.depth.png")).unwrap();
    assert!(!ingest_stage::run(&c2, &out).unwrap().skipped);
    assert!(out.join("depth/seq-01/frame-000001.depth.png").is_file());

    // Without depth, the registered depth of the earlier run is removed.
    let mut c3 = c2.clone();
    c3.depth = DepthOption::None;
    let t = ingest_stage::run(&c3, &out).unwrap().output.table;
    assert!(t.frames.iter().all(|f| f.depth_path.is_none()));
    assert!(!out.join("depth").exists());
    assert_eq!(record(&out)["outputs"].as_object().unwrap().len(), 1);

    // A run that fails while listing the inputs leaves the folder as it was.
    std::fs::remove_file(scene.join("TestSplit.txt")).unwrap();
    assert!(ingest_stage::run(&c3, &out).is_err());
    std::fs::write(scene.join("TestSplit.txt"), "sequence2\r\n\r\n").unwrap();
    assert!(
        ingest_stage::run(&c3, &out).unwrap().skipped,
        "inputs unchanged: still up to date"
    );

    // A run that fails while reading a frame leaves no record: the next run cannot skip.
    let good = std::fs::read(&pose).unwrap();
    std::fs::write(&pose, "1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 2\n").unwrap();
    assert!(ingest_stage::run(&c3, &out).is_err());
    assert!(!out.join("stage.json").exists());
    std::fs::write(&pose, good).unwrap();
    assert!(!ingest_stage::run(&c3, &out).unwrap().skipped);
}

#[test]
fn same_bytes_for_any_thread_count() {
    let dir = tempfile::tempdir().unwrap();
    let scene = seven_scenes(dir.path(), 16, 12);
    let c = config(&scene);
    let out = dir.path().join("out");
    let files = [
        "frames.parquet",
        "stage.json",
        "depth/seq-01/frame-000000.depth.png",
        "depth/seq-01/frame-000001.depth.png",
        "depth/seq-02/frame-000000.depth.png",
    ];
    let run_with = |threads: usize| -> Vec<Vec<u8>> {
        if out.exists() {
            std::fs::remove_dir_all(&out).unwrap();
        }
        testkit::on_threads(threads, || {
            assert!(!ingest_stage::run(&c, &out).unwrap().skipped)
        });
        files
            .iter()
            .map(|f| std::fs::read(out.join(f)).unwrap())
            .collect()
    };
    let one = run_with(1);
    let three = run_with(3);
    for (f, (a, b)) in files.iter().zip(one.iter().zip(&three)) {
        assert!(a == b, "{f} differs between 1 and 3 threads");
    }
}

/// Every depth map goes into the frames table with its content hash (the refine stage
/// checks the file against it): the registered map as written, a rendered map as found.
/// A table written before the hashes existed (no `depth_hash` column) is written again
/// by the next run, even though its record is intact.
#[test]
fn depth_maps_are_hashed_and_a_table_without_the_hashes_is_written_again() {
    let dir = tempfile::tempdir().unwrap();
    let scene = seven_scenes(dir.path(), 16, 12);
    let out = dir.path().join("raw");
    let raw = ingest_stage::run(&config(&scene), &out)
        .unwrap()
        .output
        .table;
    for f in &raw.frames {
        let p = f.depth_path.as_ref().unwrap();
        assert_eq!(f.depth_hash, Some(stage::sha256_file(p).unwrap()), "{p:?}");
    }

    let rendered = dir.path().join("rendered");
    for name in [
        "seq-01/frame-000000.depth.png",
        "seq-01/frame-000001.depth.png",
        "seq-02/frame-000000.depth.png",
    ] {
        testkit::images::write_depth(&rendered.join(name), 16, 12, |x, y| {
            900 + (x + 3 * y) as u16
        });
    }
    let mut c = config(&scene);
    c.depth = DepthOption::Rendered(rendered.clone());
    let out = dir.path().join("rendered-out");
    let first = ingest_stage::run(&c, &out).unwrap().output.table;
    for f in &first.frames {
        let p = f.depth_path.as_ref().unwrap();
        assert!(p.starts_with(rendered.canonicalize().unwrap()), "{p:?}");
        assert_eq!(f.depth_hash, Some(stage::sha256_file(p).unwrap()), "{p:?}");
    }

    // The table as an earlier pl2map wrote it: no depth_hash column, and a record that
    // matches it (so nothing but the missing hashes makes the stage rerun).
    let parquet = out.join("frames.parquet");
    let (mut df, kv) = tables::parquet::read_parquet(&parquet).unwrap();
    df.drop_in_place("depth_hash").unwrap();
    let ours = kv.into_iter().filter(|(k, _)| k.starts_with("pl2map."));
    tables::parquet::write_parquet(&parquet, &mut df, ours.collect()).unwrap();
    let old = FramesTable::read_parquet(&parquet).unwrap();
    assert!(old.frames.iter().all(|f| f.depth_hash.is_none()));
    let mut rec = stage::StageRecord::load(&out).unwrap().unwrap();
    rec.add_output(&out, "frames.parquet").unwrap();
    rec.save(&out).unwrap();

    let again = ingest_stage::run(&c, &out).unwrap();
    assert!(
        !again.skipped,
        "a table without depth hashes is not up to date"
    );
    assert_eq!(again.output.table, first);
    assert_eq!(FramesTable::read_parquet(&parquet).unwrap(), first);
    assert!(ingest_stage::run(&c, &out).unwrap().skipped);
}

/// An output folder that is a file is named as such (not "File exists (os error 17)").
#[test]
fn an_output_folder_that_is_a_file_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let scene = seven_scenes(dir.path(), 16, 12);
    let out = dir.path().join("out");
    std::fs::write(&out, b"a file").unwrap();
    let e = ingest_stage::run(&config(&scene), &out).unwrap_err();
    assert_eq!(
        e.to_string(),
        format!(
            "{} is a file, not a folder: choose another folder",
            out.display()
        )
    );
    assert_eq!(std::fs::read(&out).unwrap(), b"a file");
}
