//! `pl2map features` writes hloc's feature-file layout, read back by h5py (an
//! independent HDF5 reader). Needs `PL2MAP_PYTHON` with h5py and numpy; skips otherwise.

use std::process::Command;

#[test]
fn h5py_reads_the_feature_file_in_hloc_layout() {
    let Some(python) = testkit::python::python(&["h5py", "numpy"]) else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let images = dir.path().join("images");
    std::fs::create_dir_all(images.join("seq-01")).unwrap();
    testkit::images::write_rgb(&images.join("seq-01/a.png"), 160, 120, 1);
    testkit::images::write_rgb(&images.join("b.png"), 200, 150, 2);
    let out = dir.path().join("feats.h5");
    let status = Command::new(env!("CARGO_BIN_EXE_pl2map"))
        .args(["--quiet", "features", "--front-end", "sift", "--images"])
        .arg(&images)
        .arg("--out")
        .arg(&out)
        .status()
        .unwrap();
    assert!(status.success());
    let script = r#"
import sys, json, h5py
out = {}
with h5py.File(sys.argv[1], "r") as f:
    def visit(name, obj):
        if isinstance(obj, h5py.Group) and "keypoints" in obj:
            out[name] = {k: list(obj[k].shape) for k in obj}
            out[name]["image_size"] = obj["image_size"][()].tolist()
            out[name]["kp_min"] = float(obj["keypoints"][()].min()) if obj["keypoints"].shape[0] else 0.0
            out[name]["norm"] = float((obj["descriptors"][()] ** 2).sum(0).mean()) if obj["keypoints"].shape[0] else 1.0
    f.visititems(visit)
print(json.dumps(out))
"#;
    let stdout = testkit::python::run(Command::new(&python).args(["-c", script]).arg(&out));
    let v: serde_json::Value = serde_json::from_slice(&stdout).unwrap();
    let a = &v["seq-01/a.png"];
    assert_eq!(a["image_size"], serde_json::json!([160, 120]), "{v}");
    let n = a["keypoints"][0].as_u64().unwrap();
    assert!(n > 0, "{v}");
    assert_eq!(a["keypoints"], serde_json::json!([n, 2]));
    assert_eq!(a["scores"], serde_json::json!([n]));
    assert_eq!(a["descriptors"], serde_json::json!([128, n]));
    // hloc's pixel-index convention: the first pixel centre is 0, never below -0.5.
    assert!(a["kp_min"].as_f64().unwrap() >= -0.5);
    assert!((a["norm"].as_f64().unwrap() - 1.0).abs() < 1e-4, "{v}");
    assert_eq!(v["b.png"]["image_size"], serde_json::json!([200, 150]));
}
