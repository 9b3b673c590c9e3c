//! The burn SuperPoint against an independent PyTorch one (`superpoint_torch.py`, written
//! from the paper) with the same random weights, saved by PyTorch in the released
//! file's key layout, on real images of the sample data. Needs `PL2MAP_PYTHON` with
//! torch and cv2 (scripts/setup-python.sh) and the sample data; skips otherwise.

use features::{FrontEnd, FrontEndConfig, FrontEndKind};
use std::path::{Path, PathBuf};
use std::process::Command;
use superpoint::{SuperPointFrontEnd, Weights};

const SCRIPT: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/superpoint_torch.py");

fn make_weights(python: &Path, out: &Path, seed: u64, option: &str) {
    let mut cmd = Command::new(python);
    cmd.arg(SCRIPT)
        .arg("weights")
        .arg(out)
        .arg(seed.to_string());
    if !option.is_empty() {
        cmd.arg(option);
    }
    testkit::python::run(&mut cmd);
}

fn read_f32(path: &Path) -> Vec<f32> {
    std::fs::read(path)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
        .chunks_exact(4)
        .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .collect()
}

fn max_abs(a: &[f32], b: &[f32]) -> f32 {
    assert_eq!(a.len(), b.len(), "lengths differ");
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f32::max)
}

fn images(root: &Path) -> Vec<PathBuf> {
    vec![
        root.join("7scenes-stairs-mini/stairs/seq-02/frame-000000.color.jpg"),
        root.join("7scenes-stairs-mini/stairs/seq-03/frame-000002.color.jpg"),
        // 780 x 1063: resized to 751 x 1024 before the network.
        root.join("colmap-sacre-coeur/images/02928139_3448003521.jpg"),
    ]
}

fn config() -> FrontEndConfig {
    FrontEndConfig {
        kind: FrontEndKind::Superpoint,
        ..FrontEndConfig::default()
    }
}

#[test]
fn burn_superpoint_matches_pytorch_on_real_images() {
    let Some(python) = testkit::python::python(&["torch", "cv2", "numpy"]) else {
        return;
    };
    let Some(root) = testkit::sample::sample_data("") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let zip = dir.path().join("superpoint_zip.pth");
    let legacy = dir.path().join("superpoint_legacy.pth");
    make_weights(&python, &zip, 7, "");
    make_weights(&python, &legacy, 7, "legacy");
    let w = Weights::read(&zip).unwrap();
    let w_legacy = Weights::read(&legacy).unwrap();
    assert_eq!(
        w.layers, w_legacy.layers,
        "both PyTorch formats give the same tensors"
    );
    let fe = SuperPointFrontEnd::from_weights(config(), &w).unwrap();
    let t = fe.config().samples_per_line;

    for (k, path) in images(&root).iter().enumerate() {
        let gray = features::load_gray(path).unwrap();
        let png = dir.path().join(format!("gray{k}.png"));
        gray.save(&png).unwrap();

        let det = fe.detect(&gray).unwrap();
        // Given positions: some detections, positions off the grid, LSD segments and
        // segments reaching the border.
        let (w_img, h_img) = (gray.width() as f64, gray.height() as f64);
        let mut given: Vec<[f64; 2]> = det.keypoints.iter().take(300).copied().collect();
        for i in 0..50 {
            let f = i as f64 / 50.0;
            given.push([0.3 + f * (w_img - 0.6), 0.7 + (1.0 - f) * (h_img - 1.4)]);
        }
        let mut segments: Vec<[f64; 4]> = fe.segments(&gray).unwrap();
        segments.truncate(80);
        segments.push([0.5, 0.5, w_img - 0.5, h_img - 0.5]);
        segments.push([w_img - 2.0, 3.0, 10.0, h_img - 1.0]);
        let (at_points, at_lines) = fe.describe(&gray, &given, &segments).unwrap();

        let job = serde_json::json!({
            "image": png, "resize_max": 1024, "nms_radius": 3, "threshold": 0.005,
            "border": 4, "max_keypoints": 2048, "keypoints": given, "segments": segments,
            "samples_per_line": t,
        });
        let job_path = dir.path().join(format!("job{k}.json"));
        std::fs::write(&job_path, job.to_string()).unwrap();
        let out = dir.path().join(format!("out{k}"));
        std::fs::create_dir_all(&out).unwrap();
        testkit::python::run(
            Command::new(&python)
                .arg(SCRIPT)
                .arg("run")
                .arg(&zip)
                .arg(&job_path)
                .arg(&out),
        );

        let (maps, _) = fe.dense(&gray).unwrap();
        let d_scores = max_abs(&maps.scores, &read_f32(&out.join("scores.f32")));
        let d_dense = max_abs(&maps.descriptors, &read_f32(&out.join("dense.f32")));
        let d_points = max_abs(&at_points, &read_f32(&out.join("at_points.f32")));
        let d_lines = max_abs(&at_lines, &read_f32(&out.join("at_lines.f32")));
        let theirs = read_f32(&out.join("keypoints.f32"));
        let theirs: std::collections::HashSet<(u64, u64)> = theirs
            .chunks_exact(2)
            .map(|p| {
                (
                    (p[0] as f64 * 64.0).round() as u64,
                    (p[1] as f64 * 64.0).round() as u64,
                )
            })
            .collect();
        let shared = det
            .keypoints
            .iter()
            .filter(|p| {
                theirs.contains(&((p[0] * 64.0).round() as u64, (p[1] * 64.0).round() as u64))
            })
            .count();
        let denom = det.keypoints.len().max(theirs.len()).max(1);
        let share = shared as f64 / denom as f64;
        println!(
            "{}: {}x{}, maps {}x{}, keypoints burn {} torch {} shared {:.4}; max abs: scores \
             {d_scores:.2e} dense {d_dense:.2e} at points {d_points:.2e} along lines \
             {d_lines:.2e}",
            path.file_name().unwrap().to_string_lossy(),
            gray.width(),
            gray.height(),
            maps.score_width,
            maps.score_height,
            det.keypoints.len(),
            theirs.len(),
            share
        );
        assert!(det.keypoints.len() > 50, "too few keypoints to compare");
        assert!(d_scores <= 1e-4, "score maps differ by {d_scores}");
        assert!(d_dense <= 1e-4, "descriptor maps differ by {d_dense}");
        assert!(share >= 0.99, "only {share} of the keypoints are shared");
        assert!(
            d_points <= 1e-4,
            "descriptors at keypoints differ by {d_points}"
        );
        assert!(
            d_lines <= 1e-4,
            "descriptors along lines differ by {d_lines}"
        );
    }
}

#[test]
fn a_bad_weights_file_is_refused_naming_the_file_and_the_key() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("nope.pth");
    let e = Weights::read(&missing).unwrap_err().to_string();
    assert!(e.contains("nope.pth") && e.contains("no such file"), "{e}");
    let garbage = dir.path().join("garbage.pth");
    std::fs::write(&garbage, b"not a pytorch file").unwrap();
    let e = Weights::read(&garbage).unwrap_err().to_string();
    assert!(e.contains("garbage.pth"), "{e}");

    let Some(python) = testkit::python::python(&["torch"]) else {
        return;
    };
    let dropped = dir.path().join("dropped.pth");
    make_weights(&python, &dropped, 1, "drop:convDa.bias");
    let e = Weights::read(&dropped).unwrap_err().to_string();
    assert!(
        e.contains("dropped.pth") && e.contains("key convDa.bias") && e.contains("missing"),
        "{e}"
    );
    let cut = dir.path().join("cut.pth");
    make_weights(&python, &cut, 1, "shape:conv3b.weight");
    let e = Weights::read(&cut).unwrap_err().to_string();
    assert!(
        e.contains("cut.pth") && e.contains("key conv3b.weight") && e.contains("[127, 128, 3, 3]"),
        "{e}"
    );
}

#[test]
fn a_checkpoint_s_weights_hash_is_enforced() {
    let Some(python) = testkit::python::python(&["torch"]) else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let a = dir.path().join("a.pth");
    make_weights(&python, &a, 3, "");
    let mut cfg = config();
    cfg.superpoint.weights = Some(a.clone());
    let fe = SuperPointFrontEnd::from_config(&cfg).unwrap();
    let recorded = fe.config().superpoint.weights_sha256.clone().unwrap();
    assert_eq!(recorded, superpoint::file_sha256(&a).unwrap());
    let b = dir.path().join("b.pth");
    make_weights(&python, &b, 4, "");
    let mut other = fe.config().clone();
    other.superpoint.weights = Some(b);
    let e = SuperPointFrontEnd::from_config(&other)
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("b.pth") && e.contains(&recorded), "{e}");
    // No file anywhere: the error says where to name one.
    let mut none = config();
    none.superpoint.weights = None;
    if std::env::var_os(features::SUPERPOINT_WEIGHTS_ENV).is_none() {
        let e = SuperPointFrontEnd::from_config(&none)
            .err()
            .unwrap()
            .to_string();
        assert!(
            e.contains("superpoint_weights") && e.contains("--weights"),
            "{e}"
        );
    }
}
