//! Interop: the frames table read by an independent parquet reader (pyarrow). Needs
//! `PL2MAP_PYTHON` pointing at a python with pyarrow; skipped with a reason otherwise.

use datasets::ingest::{DatasetKind, DepthOption, IngestConfig};
use datasets::ingest_stage;
use std::process::Command;
use tables::frames::{FramesTable, META_KEY};
use testkit::layouts::seven_scenes;

const SCRIPT: &str = r#"
import json, sys
import pyarrow.parquet as pq
path = sys.argv[1]
table = pq.read_table(path)
meta = pq.read_metadata(path).metadata
out = {
    "schema": [[f.name, str(f.type)] for f in table.schema],
    "rows": table.num_rows,
    "meta": json.loads(meta[b"pl2map.frames.meta"].decode()),
    "version": meta[b"pl2map.frames.version"].decode(),
    "columns": {},
}
for name in table.column_names:
    col = table.column(name).to_pylist()
    if name in ("qw", "qx", "qy", "qz", "tx", "ty", "tz"):
        col = [v.hex() for v in col]
    elif name == "camera_params":
        col = [[v.hex() for v in p] for p in col]
    out["columns"][name] = col
print(json.dumps(out))
"#;

fn f64_from_hex(s: &str) -> f64 {
    // Python's float.hex(): [-]0x1.<hex>p<exp> (or 0x0.0p+0).
    let (neg, s) = match s.strip_prefix('-') {
        Some(r) => (true, r),
        None => (false, s),
    };
    let s = s.strip_prefix("0x").unwrap();
    let (mant, exp) = s.split_once('p').unwrap();
    let (int, frac) = mant.split_once('.').unwrap_or((mant, ""));
    let mut v = u64::from_str_radix(int, 16).unwrap() as f64;
    let mut scale = 1.0 / 16.0;
    for ch in frac.chars() {
        v += ch.to_digit(16).unwrap() as f64 * scale;
        scale /= 16.0;
    }
    let v = v * 2f64.powi(exp.parse::<i32>().unwrap());
    if neg { -v } else { v }
}

#[test]
fn pyarrow_reads_the_frames_table() {
    let Some(python) = testkit::python::python(&["pyarrow"]) else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let scene = seven_scenes(dir.path(), 16, 12);
    let mut c = IngestConfig::new(DatasetKind::SevenScenes, &scene);
    c.camera = Some("SIMPLE_RADIAL 16 12 10.25 8 6 -0.0123".into());
    c.depth = DepthOption::Raw;
    let out = ingest_stage::run(&c, &dir.path().join("out"))
        .unwrap()
        .output;
    let stdout = testkit::python::run(
        Command::new(&python)
            .args(["-c", SCRIPT])
            .arg(&out.frames_path),
    );
    let v: serde_json::Value = serde_json::from_slice(&stdout).unwrap();
    let schema: Vec<(String, String)> = serde_json::from_value(v["schema"].clone()).unwrap();
    let names: Vec<&str> = schema.iter().map(|(n, _)| n.as_str()).collect();
    assert_eq!(
        names,
        [
            "id",
            "name",
            "path",
            "split",
            "camera_model",
            "width",
            "height",
            "camera_params",
            "qw",
            "qx",
            "qy",
            "qz",
            "tx",
            "ty",
            "tz",
            "depth_path",
            "content_hash",
            "depth_hash"
        ]
    );
    let ty = |n: &str| schema.iter().find(|(k, _)| k == n).unwrap().1.clone();
    assert_eq!(ty("id"), "uint32");
    let params_type = ty("camera_params");
    assert!(
        params_type.contains("list<") && params_type.contains("double"),
        "{params_type}"
    );
    assert_eq!(v["rows"], 3);
    assert_eq!(v["version"], "1");
    let table: &FramesTable = &out.table;
    assert_eq!(
        serde_json::to_value(&table.meta).unwrap(),
        v["meta"],
        "{META_KEY} as pyarrow sees it"
    );
    let cols = &v["columns"];
    for (row, f) in table.frames.iter().enumerate() {
        assert_eq!(cols["id"][row], f.id);
        assert_eq!(cols["name"][row], f.name.as_str());
        assert_eq!(cols["split"][row], f.split.as_str());
        assert_eq!(cols["camera_model"][row], "SIMPLE_RADIAL");
        assert_eq!(cols["content_hash"][row], f.content_hash.as_str());
        assert_eq!(
            cols["depth_hash"][row],
            f.depth_hash.as_deref().unwrap(),
            "the registered depth map's sha256"
        );
        assert_eq!(
            cols["depth_path"][row],
            f.depth_path.as_ref().unwrap().to_str().unwrap()
        );
        let q = f.pose.qvec();
        let t = f.pose.tvec();
        for (k, name) in ["qw", "qx", "qy", "qz", "tx", "ty", "tz"]
            .iter()
            .enumerate()
        {
            let want = if k < 4 { q[k] } else { t[k - 4] };
            let got = f64_from_hex(cols[*name][row].as_str().unwrap());
            assert_eq!(got.to_bits(), want.to_bits(), "{name} row {row}");
        }
        let params: Vec<f64> = cols["camera_params"][row]
            .as_array()
            .unwrap()
            .iter()
            .map(|h| f64_from_hex(h.as_str().unwrap()))
            .collect();
        assert_eq!(params, f.camera.params);
    }
}
