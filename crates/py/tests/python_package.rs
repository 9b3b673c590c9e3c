//! The Python package against the Rust reader, run through the interpreter
//! `PL2MAP_PYTHON` names (scripts/setup-python.sh installs the package into its venv):
//! each test builds a shard folder from the analytic scene, runs one script of
//! tests/python/ on it and fails when the script fails (a Python assertion exits
//! non-zero). Skipped with a printed reason when PL2MAP_PYTHON is unset, or when
//! `pl2map_shards` (or, for the PyTorch tests, `torch`) does not import there.

use labels::import::{self, ImportConfig};
use labels::import_stage;
use pl2map_shards::order::Plan;
use serde_json::{Value, json};
use sha2::{Digest, Sha256};
use shards::shard_stage::{self, ShardStageConfig};
use shards::{FrameRecord, Manifest, ShardReader, Split};
use std::path::{Path, PathBuf};
use std::process::Command;
use testkit::scene::{Scene, SceneOptions};

/// Frames per shard: the 13 training frames make 4 shards (4, 4, 4, 1), an odd count so
/// that two ranks need padding.
const FRAMES_PER_SHARD: usize = 4;
const SEED: u64 = 7;
const EPOCH: u64 = 3;

/// The scene's shards (13 training, 3 test frames) in `<scene>/shards`, as the shard
/// stage writes them (with its stage.json).
fn shard_folder() -> (Scene, PathBuf) {
    let scene = Scene::build(&SceneOptions {
        n_train: 13,
        n_test: 3,
        noise_sigma_m: 0.01,
        seed: 11,
        ..Default::default()
    });
    import_stage::run(
        &scene.with_inputs(&ImportConfig::default()),
        &scene.frames_path,
        &scene.out("labels"),
        &import::sift_only,
    )
    .unwrap();
    let out = scene.out("shards");
    let config = ShardStageConfig {
        frames_per_shard: FRAMES_PER_SHARD,
        ..Default::default()
    };
    let done = shard_stage::run(
        &config,
        &scene.frames_path,
        &scene.out("labels"),
        &out,
        None,
    )
    .unwrap();
    assert!(done.output.complete);
    (scene, out)
}

fn script(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/python")
        .join(name)
}

/// Runs `tests/python/<name>` with `args`; panics with its output when it fails.
fn run_script(python: &Path, name: &str, args: &[&Path]) -> String {
    let out = testkit::python::run(Command::new(python).arg(script(name)).args(args));
    String::from_utf8(out).unwrap()
}

fn bits<const N: usize>(rows: &[[f64; N]]) -> Vec<u64> {
    rows.as_flattened().iter().map(|v| v.to_bits()).collect()
}

/// Everything of a frame, with every double as its bit pattern (NaN and -0.0 survive).
fn frame_json(f: &FrameRecord) -> Value {
    json!({
        "frame_id": f.frame_id,
        "name": f.name,
        "split": f.split.as_str(),
        "image_sha256": hex::encode(Sha256::digest(&f.image_bytes)),
        "image_format": f.image_format.as_str(),
        "camera_model": f.camera.model.name(),
        "width": f.camera.width,
        "height": f.camera.height,
        "params": f.camera.params.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
        "qvec": bits(&[f.pose.qvec()]),
        "tvec": bits(&[f.pose.tvec()]),
        "keypoints": bits(&f.keypoints),
        "point3d_ids": f.point3d_ids,
        "points3d": bits(&f.points3d),
        "point_valid": f.point_valid,
        "segments": bits(&f.segments),
        "track_ids": f.track_ids,
        "lines3d": bits(&f.lines3d),
        "line_valid": f.line_valid,
        "label_source": f.label_source.as_str(),
        "endpoints_aligned": f.endpoints_aligned,
    })
}

/// The Rust reader's frames of `split` in reading order.
fn rust_frames(dir: &Path, split: Split) -> Vec<FrameRecord> {
    let manifest = shards::checked_manifest(dir).unwrap();
    let paths: Vec<PathBuf> = shard_stage::shards_of_split(&manifest, split)
        .iter()
        .map(|s| dir.join(&s.file))
        .collect();
    ShardReader::open(&paths)
        .unwrap()
        .map(|f| f.unwrap())
        .collect()
}

#[test]
fn python_yields_the_records_of_the_rust_reader_in_the_same_order() {
    let Some(python) = testkit::python::python(&["pl2map_shards", "numpy"]) else {
        return;
    };
    let (scene, dir) = shard_folder();
    let mut expected = serde_json::Map::new();
    for split in [Split::Train, Split::Test] {
        let frames = rust_frames(&dir, split);
        let plan = Plan {
            frames: frames.len(),
            seed: SEED,
            epoch: EPOCH,
            world: 1,
            drop_last: false,
            shuffle: true,
        };
        let shuffled: Vec<Value> = plan
            .global_order()
            .into_iter()
            .map(|i| frame_json(&frames[i]))
            .collect();
        expected.insert(
            split.as_str().into(),
            json!({
                "reading_order": frames.iter().map(frame_json).collect::<Vec<_>>(),
                "shuffled": shuffled,
            }),
        );
    }
    expected.insert("seed".into(), json!(SEED));
    expected.insert("epoch".into(), json!(EPOCH));
    let path = scene.out("expected.json");
    std::fs::write(&path, serde_json::to_vec(&Value::Object(expected)).unwrap()).unwrap();
    let out = run_script(&python, "same_records.py", &[&dir, &path]);
    eprint!("{out}");
    assert!(out.contains("same records: 13 train, 3 test"), "{out}");
}

#[test]
fn any_number_of_workers_and_ranks_yields_the_global_order_once() {
    let Some(python) = testkit::python::python(&["pl2map_shards", "torch"]) else {
        return;
    };
    let (_scene, dir) = shard_folder();
    let out = run_script(&python, "workers_and_ranks.py", &[&dir]);
    eprint!("{out}");
    assert!(out.contains("checked 24 loaders"), "{out}");
}

#[test]
fn a_resumed_epoch_yields_the_rest_of_the_order() {
    let Some(python) = testkit::python::python(&["pl2map_shards", "torch"]) else {
        return;
    };
    let (_scene, dir) = shard_folder();
    let out = run_script(&python, "resume.py", &[&dir]);
    eprint!("{out}");
    assert!(out.contains("resume checked"), "{out}");
}

#[test]
fn a_set_served_over_http_reads_as_the_local_folder() {
    let Some(python) = testkit::python::python(&["pl2map_shards", "numpy"]) else {
        return;
    };
    let (scene, dir) = shard_folder();
    let cache = scene.out("cache");
    let out = run_script(&python, "over_http.py", &[&dir, &cache]);
    eprint!("{out}");
    assert!(out.contains("over http: 13 frames"), "{out}");
}

/// Flips one byte in the middle of the first training shard of a copy of `dir`.
fn damaged_copy(dir: &Path, to: &Path, keep_record: bool) -> PathBuf {
    testkit::files::copy_dir(dir, to);
    if !keep_record {
        std::fs::remove_file(to.join(stage::RECORD_FILE)).unwrap();
    }
    let manifest = Manifest::load(to.join(shards::MANIFEST_FILE)).unwrap();
    let shard = to.join(&manifest.shards[0].file);
    let mut bytes = std::fs::read(&shard).unwrap();
    let middle = bytes.len() / 2;
    bytes[middle] ^= 0x40;
    std::fs::write(&shard, bytes).unwrap();
    shard
}

#[test]
fn a_damaged_shard_raises_an_error_naming_the_shard_and_the_frame() {
    let Some(python) = testkit::python::python(&["pl2map_shards"]) else {
        return;
    };
    let (scene, dir) = shard_folder();
    // With the shard stage's record (checked as the trainer checks it) and without it
    // (the manifest's hashes alone, as in a copied folder).
    let recorded = scene.out("recorded");
    let shard = damaged_copy(&dir, &recorded, true);
    let bare = scene.out("bare");
    damaged_copy(&dir, &bare, false);
    let out = run_script(&python, "damaged.py", &[&recorded, &bare, &shard]);
    eprint!("{out}");
    assert!(out.contains("damaged checked"), "{out}");
}

#[test]
fn the_example_trains_a_point_regression() {
    let Some(python) = testkit::python::python(&["pl2map_shards", "torch"]) else {
        return;
    };
    let (_scene, dir) = shard_folder();
    let example =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../python/examples/train_points.py");
    let out = testkit::python::run(Command::new(&python).arg(&example).arg(&dir).args([
        "--steps",
        "300",
        "--workers",
        "2",
        "--seed",
        "1",
    ]));
    let out = String::from_utf8(out).unwrap();
    eprint!("{out}");
    // The last line is the summary: the loss must have fallen well below its start.
    let summary: Value = serde_json::from_str(out.lines().last().unwrap_or("")).unwrap();
    let (first, last) = (
        summary["first_loss"].as_f64().unwrap(),
        summary["last_loss"].as_f64().unwrap(),
    );
    assert_eq!(summary["steps"], 300, "{summary}");
    assert!(last < 0.5 * first, "loss {first} -> {last}");
}
