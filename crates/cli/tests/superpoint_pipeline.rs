//! The tiny synthetic pipeline with the SuperPoint front-end at D = 256, as a user runs
//! it: `pl2map run` killed with SIGKILL during training, run again, gives the model of
//! an uninterrupted run, and the score stage localises with it. The weights are random
//! (seeded) in the released file's layout, written by the PyTorch peer
//! (crates/superpoint/tests/superpoint_torch.py): a weak but legitimate descriptor, so
//! this tests the path, not the accuracy.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};
use testkit::process::ok;

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn weights(dir: &Path) -> Option<PathBuf> {
    let python = testkit::python::python(&["torch"])?;
    let path = dir.join("superpoint-random.pth");
    testkit::python::run(
        Command::new(python)
            .arg(repo().join("crates/superpoint/tests/superpoint_torch.py"))
            .arg("weights")
            .arg(&path)
            .arg("7"),
    );
    Some(path)
}

/// The tiny pipeline on SuperPoint: 6 steps, a checkpoint every 2, a capped RANSAC.
fn pipeline(dir: &Path, weights: &Path) -> PathBuf {
    let text = std::fs::read_to_string(repo().join("pipeline/synthetic-tiny.toml")).unwrap();
    let text = text
        .replace("iterations = 100", "iterations = 6")
        .replace("checkpoint_every = 50", "checkpoint_every = 2")
        .replace("[score]\n", "[score]\nmax_iterations = 200\n")
        // The synthetic scene's keypoints are SIFT detections: the detector check would
        // refuse them under SuperPoint, and this test is about the SuperPoint path.
        .replace("[import]\n", "[import]\ndetector_check = \"accept\"\n");
    let text = text
        .lines()
        .map(|l| {
            if l.starts_with("work = ") {
                format!("work = {:?}", dir.join("work"))
            } else {
                l.to_string()
            }
        })
        .collect::<Vec<_>>()
        .join("\n");
    let text = format!(
        "{text}\n\n[features]\nkind = \"superpoint\"\nsuperpoint_weights = {:?}\n",
        weights
    );
    let path = dir.join("pipeline.toml");
    std::fs::write(&path, text).unwrap();
    path
}

fn run(pipeline: &Path) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_pl2map"))
        .arg("run")
        .arg(pipeline)
        .arg("--quiet")
        .output()
        .unwrap()
}

#[test]
fn a_killed_superpoint_run_resumes_to_the_uninterrupted_model_and_scores() {
    let dir = tempfile::tempdir().unwrap();
    let Some(weights) = weights(dir.path()) else {
        return;
    };
    let pipeline = pipeline(dir.path(), &weights);
    let work = dir.path().join("work");

    // Killed once the first checkpoint is written, then run again.
    let mut child = Command::new(env!("CARGO_BIN_EXE_pl2map"))
        .arg("run")
        .arg(&pipeline)
        .arg("--quiet")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let checkpoint = work.join("train/checkpoint.ckpt");
    let start = Instant::now();
    while !checkpoint.exists() {
        if let Ok(Some(status)) = child.try_wait() {
            panic!("the run ended ({status}) before its first checkpoint");
        }
        assert!(start.elapsed() < Duration::from_secs(600), "no checkpoint");
        std::thread::sleep(Duration::from_millis(20));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    assert!(
        !work.join("train/model.ckpt").exists(),
        "killed after training"
    );
    ok(run(&pipeline), "the run after the kill");
    let resumed = std::fs::read(work.join("train/model.ckpt")).unwrap();
    let resumed_poses = std::fs::read(work.join("score/results_points_lines.txt")).unwrap();
    let summary: serde_json::Value =
        serde_json::from_slice(&std::fs::read(work.join("score/summary.json")).unwrap()).unwrap();
    assert!(summary.to_string().contains("points"), "{summary}");

    // The uninterrupted run, in the same place.
    std::fs::remove_dir_all(&work).unwrap();
    ok(run(&pipeline), "the uninterrupted run");
    assert!(
        std::fs::read(work.join("train/model.ckpt")).unwrap() == resumed,
        "the resumed model differs from the uninterrupted one"
    );
    assert_eq!(
        std::fs::read(work.join("score/results_points_lines.txt")).unwrap(),
        resumed_poses
    );
}
