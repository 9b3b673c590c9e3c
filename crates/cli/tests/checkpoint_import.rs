//! `pl2map checkpoint import` against an independent PyTorch peer
//! (crates/cli/tests/pl2map_reference_torch.py): a PL2Map module with the reference
//! implementation's parameter names and shapes, random weights, saved as the reference
//! saves its models. After the import this project's network gives the peer's point and
//! line predictions and reliabilities within 1e-4 (D = 256); a file with a missing or a
//! misshapen key is refused naming the file and that key.

use model::{CpuBackend, Dropout, NetworkInput};
use std::path::{Path, PathBuf};
use std::process::Command;

const N: usize = 40;
const M: usize = 15;
const D: usize = 256;
const T: usize = 12;
const TOLERANCE: f32 = 1e-4;

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// The peer's files in `dir` (`layout`: nested or bare, `edit`: "" or drop:/shape:KEY),
/// and SuperPoint weights (random, seeded); None after a printed skip without torch.
fn peer(dir: &Path, layout: &str, edit: &str) -> Option<PathBuf> {
    let python = testkit::python::python(&["torch"])?;
    testkit::python::run(
        Command::new(&python)
            .arg(repo().join("crates/cli/tests/pl2map_reference_torch.py"))
            .arg(dir)
            .args(["11", &N.to_string(), &M.to_string(), layout, edit]),
    );
    let weights = dir.join("superpoint.pth");
    if !weights.is_file() {
        testkit::python::run(
            Command::new(&python)
                .arg(repo().join("crates/superpoint/tests/superpoint_torch.py"))
                .arg("weights")
                .arg(&weights)
                .arg("5"),
        );
    }
    Some(weights)
}

fn import(dir: &Path, weights: &Path, out: &str) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_pl2map"))
        .args(["checkpoint", "import"])
        .arg(dir.join("reference.pth"))
        .arg("--out")
        .arg(dir.join(out))
        .arg("--superpoint-weights")
        .arg(weights)
        .env_remove("PL2MAP_SUPERPOINT_WEIGHTS")
        .output()
        .unwrap()
}

fn floats(path: &Path) -> Vec<f32> {
    std::fs::read(path)
        .unwrap()
        .chunks_exact(4)
        .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect()
}

fn max_diff(a: &[f32], b: &[f32]) -> f32 {
    assert_eq!(a.len(), b.len());
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f32::max)
}

#[test]
fn imported_reference_model_gives_the_reference_predictions() {
    let dir = tempfile::tempdir().unwrap();
    let Some(weights) = peer(dir.path(), "nested", "") else {
        return;
    };
    let out = import(dir.path(), &weights, "model.ckpt");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains("92 tensors"), "{stdout}");

    let ck = train::checkpoint::CheckpointFile::read(&dir.path().join("model.ckpt")).unwrap();
    let cfg = &ck.header.config;
    assert_eq!(cfg.front_end.kind, features::FrontEndKind::Superpoint);
    assert_eq!(cfg.model.descriptor_dim, D);
    assert_eq!(
        cfg.front_end.superpoint.weights_sha256.as_deref(),
        Some(superpoint::file_sha256(&weights).unwrap().as_str())
    );
    let net = ck.model::<CpuBackend>(&Default::default()).unwrap();

    let (points, lines) = (
        floats(&dir.path().join("points.f32")),
        floats(&dir.path().join("lines.f32")),
    );
    assert_eq!((points.len(), lines.len()), (N * D, M * T * D));
    let input =
        NetworkInput::<CpuBackend>::from_host(&cfg.model, &points, &lines, &Default::default())
            .unwrap();
    assert_eq!((input.num_points(), input.num_lines()), (N, M));
    let got = net.forward(input, &mut Dropout::off()).to_host();
    let want_p = floats(&dir.path().join("points_out.f32"));
    let want_l = floats(&dir.path().join("lines_out.f32"));
    let r = |u: f32| 1.0 / (1.0 + (100.0 * u).abs());

    let xyz: Vec<f32> = got.points.iter().flat_map(|p| p.xyz).collect();
    let want_xyz: Vec<f32> = want_p.chunks(4).flat_map(|c| c[..3].to_vec()).collect();
    let rel: Vec<f32> = got.points.iter().map(|p| p.reliability).collect();
    let want_rel: Vec<f32> = want_p.chunks(4).map(|c| r(c[3])).collect();
    let ends: Vec<f32> = got
        .lines
        .iter()
        .flat_map(|l| l.start.into_iter().chain(l.end))
        .collect();
    let want_ends: Vec<f32> = want_l.chunks(7).flat_map(|c| c[..6].to_vec()).collect();
    let lrel: Vec<f32> = got.lines.iter().map(|l| l.reliability).collect();
    let want_lrel: Vec<f32> = want_l.chunks(7).map(|c| r(c[6])).collect();
    let diffs = [
        ("point coordinates", max_diff(&xyz, &want_xyz)),
        ("point reliabilities", max_diff(&rel, &want_rel)),
        ("line endpoints", max_diff(&ends, &want_ends)),
        ("line reliabilities", max_diff(&lrel, &want_lrel)),
    ];
    println!("max |difference| against the PyTorch peer: {diffs:?}");
    for (what, diff) in diffs {
        assert!(diff <= TOLERANCE, "{what}: max difference {diff}");
    }
    // The outputs are not trivially small, so the tolerance means something.
    assert!(want_xyz.iter().any(|v| v.abs() > 0.5));

    // The predictor of `pl2map score` / `localize` loads it and describes an image with
    // the recorded SuperPoint weights.
    let predictor = train::Predictor::load(&dir.path().join("model.ckpt")).unwrap();
    let img = image::GrayImage::from_fn(160, 120, |x, y| {
        image::Luma([((x * 7 + y * 13 + (x * y) % 31) % 256) as u8])
    });
    let pred = predictor
        .predict_at(
            &img,
            &[[40.0, 30.0], [100.0, 80.0]],
            &[[20.0, 20.0, 120.0, 90.0]],
        )
        .unwrap();
    assert_eq!((pred.points.len(), pred.lines.len()), (2, 1));
    assert!(
        pred.points
            .iter()
            .all(|p| p.xyz.iter().all(|v| v.is_finite()))
    );

    // A bare state dict (no "model_state_dict" around it) gives the same checkpoint.
    let bare = tempfile::tempdir().unwrap();
    std::fs::copy(&weights, bare.path().join("superpoint.pth")).unwrap();
    peer(bare.path(), "bare", "").unwrap();
    let out = import(bare.path(), &weights, "model.ckpt");
    assert!(out.status.success());
    assert_eq!(
        std::fs::read(bare.path().join("model.ckpt")).unwrap(),
        std::fs::read(dir.path().join("model.ckpt")).unwrap()
    );
}

#[test]
fn a_missing_or_misshapen_key_is_refused_naming_it() {
    for (edit, key, want) in [
        (
            "drop:gnn.layers.2.attn.merge.weight",
            "gnn.layers.2.attn.merge.weight",
            "missing",
        ),
        (
            "shape:mapping_l.6.weight",
            "mapping_l.6.weight",
            "shape [6, 512, 1], expected [7, 512, 1]",
        ),
    ] {
        let dir = tempfile::tempdir().unwrap();
        let Some(weights) = peer(dir.path(), "nested", edit) else {
            return;
        };
        let out = import(dir.path(), &weights, "model.ckpt");
        assert!(!out.status.success(), "{edit}: accepted");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            err.contains("reference.pth")
                && err.contains(&format!("key {key}"))
                && err.contains(want),
            "{edit}: {err}"
        );
        if edit.starts_with("drop:") {
            assert!(err.contains("[256, 256, 1]"), "{err}");
        }
        assert!(!dir.path().join("model.ckpt").exists());
    }
}

#[test]
fn an_import_without_superpoint_weights_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    if peer(dir.path(), "bare", "").is_none() {
        return;
    }
    let out = Command::new(env!("CARGO_BIN_EXE_pl2map"))
        .args(["checkpoint", "import"])
        .arg(dir.path().join("reference.pth"))
        .arg("--out")
        .arg(dir.path().join("model.ckpt"))
        .env_remove("PL2MAP_SUPERPOINT_WEIGHTS")
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("--superpoint-weights") && err.contains("PL2MAP_SUPERPOINT_WEIGHTS"),
        "{err}"
    );
    assert!(!dir.path().join("model.ckpt").exists());
}
