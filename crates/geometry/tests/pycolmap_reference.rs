//! The geometry crate's projection and lifting against pycolmap 4.2.1, for every
//! COLMAP camera model: the committed reference file, and a live re-run of the
//! generator when PL2MAP_PYTHON is set.

mod support;

use std::path::{Path, PathBuf};
use std::process::Command;
use support::{Report, compare, parse};

fn manifest_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn check(report: &Report, source: &str) {
    eprintln!(
        "{source}: {} projections and {} liftings compared, {} failing in both; max \
         difference: projection {:.2e} px (pixels within 1e4 px of the origin) and \
         {:.2e} relative, lifting {:.2e} px",
        report.projections,
        report.liftings,
        report.both_fail,
        report.max_project_px,
        report.max_project_rel,
        report.max_lift_px
    );
    // Where we differ because pycolmap answers with a value its own inverse rejects,
    // counted by model and reason.
    let mut kinds: Vec<(String, &str, usize)> = Vec::new();
    for (model, _, why) in &report.justified {
        match kinds
            .iter_mut()
            .find(|(m, w, _)| *m == model.name() && w == why)
        {
            Some(k) => k.2 += 1,
            None => kinds.push((model.name().to_string(), why, 1)),
        }
    }
    for (model, why, n) in kinds {
        eprintln!("  {model}: {n} x {why}");
    }
    assert!(
        report.failures.is_empty(),
        "{source}: {} disagreements with pycolmap:\n{}",
        report.failures.len(),
        report.failures.join("\n")
    );
}

#[test]
fn matches_committed_pycolmap_reference() {
    let path = manifest_dir().join("tests/data/pycolmap_camera_reference.txt");
    let text = std::fs::read_to_string(&path)
        .unwrap_or_else(|e| panic!("cannot read {}: {e}", path.display()));
    let cases = parse(&text).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    // Every model appears, so no model goes untested.
    for model in geometry::CameraModel::ALL {
        assert!(
            cases.iter().any(|c| c.camera.model == model),
            "{model} missing from {}",
            path.display()
        );
    }
    let report = compare(&cases);
    check(&report, "committed reference");
    // The divergences are the documented ones, and only those: pycolmap answers with a
    // value its own inverse rejects (fisheye / FOV / division pixels past their
    // domain, division points behind the camera).
    assert!(!report.justified.is_empty());
}

/// The generator's exit code when numpy or pycolmap cannot be imported.
const EXIT_NO_PYCOLMAP: i32 = 3;

/// Runs the generator: Ok(output), or Err(reason to skip) when the Python cannot run
/// or has no pycolmap. Any other failure of the script is a test failure.
fn run_generator(python: &Path) -> Result<String, String> {
    let script = manifest_dir().join("tests/gen_pycolmap_reference.py");
    let out = Command::new(python)
        .arg(&script)
        .output()
        .map_err(|e| format!("cannot run {}: {e}", python.display()))?;
    let stderr = String::from_utf8_lossy(&out.stderr);
    if out.status.code() == Some(EXIT_NO_PYCOLMAP) {
        return Err(stderr.trim().to_string());
    }
    assert!(
        out.status.success(),
        "{} {} failed ({}): {}",
        python.display(),
        script.display(),
        out.status,
        stderr.trim()
    );
    Ok(String::from_utf8(out.stdout).expect("generator output is not UTF-8"))
}

#[test]
fn matches_live_pycolmap() {
    let Some(python) = testkit::python::python(&[]) else {
        return;
    };
    let text = match run_generator(&python) {
        Ok(text) => text,
        Err(e) => {
            testkit::skip(format_args!("live pycolmap comparison: {e}"));
            return;
        }
    };
    let live = parse(&text).unwrap_or_else(|e| panic!("live generator output: {e}"));
    check(&compare(&live), "live pycolmap");

    // The committed file is what the script produces (same inputs; outputs equal up to
    // the last bits a different pycolmap build may change).
    let path = manifest_dir().join("tests/data/pycolmap_camera_reference.txt");
    let committed = std::fs::read_to_string(&path)
        .unwrap_or_else(|e| panic!("cannot read {}: {e}", path.display()));
    let (a, b): (Vec<&str>, Vec<&str>) = (
        committed.lines().skip(1).collect(),
        text.lines().skip(1).collect(),
    );
    assert_eq!(
        a.len(),
        b.len(),
        "live output has a different number of lines"
    );
    for (i, (x, y)) in a.iter().zip(&b).enumerate() {
        let (tx, ty): (Vec<&str>, Vec<&str>) = (
            x.split_whitespace().collect(),
            y.split_whitespace().collect(),
        );
        let same = tx.len() == ty.len()
            && tx.iter().zip(&ty).all(|(p, q)| {
                p == q
                    || match (p.parse::<f64>(), q.parse::<f64>()) {
                        (Ok(p), Ok(q)) => (p - q).abs() <= 1e-9 * p.abs().max(1.0),
                        _ => false,
                    }
            });
        assert!(same, "line {}: committed `{x}`, live `{y}`", i + 2);
    }
}
