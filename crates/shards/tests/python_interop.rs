//! Interop proof: Python's `mcap` + `mcap-protobuf-support` decode every message of
//! our shards from the schemas embedded in them (tests/decode_shard.py), and agree
//! with the Rust reader on the counts and, bit for bit, on sums of the 3D labels.
//! Skipped with a printed reason when PL2MAP_PYTHON is unset or its imports fail
//! (scripts/setup-python.sh prints a suitable python).

use shards::{FrameRecord, ShardJob, ShardReader, plan_shards, write_shards};
use std::collections::BTreeMap;
use std::process::Command;
use testkit::shard_frames::{frame, small_chunks};

#[test]
fn python_decodes_labels_from_the_embedded_schema() {
    let Some(py) = testkit::python::python(&["mcap.reader", "mcap_protobuf.decoder"]) else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let all: Vec<FrameRecord> = (0..23).map(|i| frame(100 + i, 250, 35, 40, 30)).collect();
    let ids: Vec<u64> = all.iter().map(|f| f.frame_id).collect();
    let plans = plan_shards(&ids, 10).unwrap();
    let job = ShardJob {
        out_dir: dir.path(),
        plans: &plans,
        config: &small_chunks(),
        config_hash: "interop".into(),
        inputs: BTreeMap::new(),
        digests: None,
    };
    let load = |id: u64| -> Result<FrameRecord, Box<dyn std::error::Error + Send + Sync>> {
        Ok(all[(id - 100) as usize].clone())
    };
    let manifest = write_shards(&job, 0..plans.len(), &load).unwrap().manifest;
    let paths = manifest.shard_paths(dir.path());

    let script = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/decode_shard.py");
    let out = testkit::python::run(Command::new(&py).arg(script).args(&paths));
    let py_json: serde_json::Value = serde_json::from_slice(&out).unwrap();

    // The same numbers from the Rust reader, summing in the same order.
    let (mut frames, mut kp, mut vp, mut seg, mut vl) = (0u64, 0u64, 0u64, 0u64, 0u64);
    let (mut psum, mut lsum) = (0.0f64, 0.0f64);
    let mut frame_ids = Vec::new();
    for f in ShardReader::open(&paths).unwrap() {
        let f = f.unwrap();
        frames += 1;
        frame_ids.push(f.frame_id);
        kp += f.keypoints.len() as u64;
        seg += f.segments.len() as u64;
        for (p, _) in f.points3d.iter().zip(&f.point_valid).filter(|x| *x.1) {
            vp += 1;
            p.iter().for_each(|v| psum += v);
        }
        for (l, _) in f.lines3d.iter().zip(&f.line_valid).filter(|x| *x.1) {
            vl += 1;
            l.iter().for_each(|v| lsum += v);
        }
    }
    eprintln!("python: {py_json}");
    assert_eq!(py_json["frames"], frames);
    assert_eq!(py_json["frame_ids"], serde_json::json!(frame_ids));
    assert_eq!(py_json["keypoints"], kp);
    assert_eq!(py_json["valid_points"], vp);
    assert_eq!(py_json["segments"], seg);
    assert_eq!(py_json["valid_lines"], vl);
    assert_eq!(py_json["point_sum_bits"], psum.to_bits());
    assert_eq!(py_json["line_sum_bits"], lsum.to_bits());
    assert!(vp > 0 && vl > 0);

    // Every channel decoded from its embedded schema, one message per frame each.
    let want_schemas = serde_json::json!({
        "/camera/calibration": "foxglove.CameraCalibration",
        "/camera/image": "foxglove.CompressedImage",
        "/labels": "pl2map.FrameLabels",
        "/labels/lines": "foxglove.SceneUpdate",
        "/labels/points": "foxglove.PointCloud",
        "/tf": "foxglove.FrameTransform",
    });
    assert_eq!(py_json["schemas"], want_schemas);
    for topic in want_schemas.as_object().unwrap().keys() {
        assert_eq!(py_json["topics"][topic], frames, "{topic}");
    }
}
