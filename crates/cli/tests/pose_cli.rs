//! `pl2map pose` end to end: correspondence files written from synthetic problems with
//! known ground truth (pose::synthetic), the binary's text and JSON outputs, and its
//! errors on malformed input.

use geometry::metrics::pose_error;
use geometry::{Camera, CameraModel, Pose};
use pose::synthetic::{SyntheticConfig, SyntheticProblem, generate_seeded};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_pl2map"))
}

fn camera_arg(c: &Camera) -> String {
    let params: Vec<String> = c.params.iter().map(|p| p.to_string()).collect();
    format!(
        "{} {} {} {}",
        c.model.name(),
        c.width,
        c.height,
        params.join(" ")
    )
}

/// Writes the problem's points and lines files (with comments) into `dir`.
fn write_problem(pb: &SyntheticProblem, dir: &Path) -> (PathBuf, PathBuf) {
    let mut pts = String::from("# x y X Y Z\n\n");
    for p in &pb.points {
        writeln!(
            pts,
            "{} {} {} {} {}",
            p.pixel.x, p.pixel.y, p.world.x, p.world.y, p.world.z
        )
        .unwrap();
    }
    let mut lns = String::from("# x1 y1 x2 y2 X1 Y1 Z1 X2 Y2 Z2\n");
    for l in &pb.lines {
        let (s, w) = (&l.segment, &l.world);
        writeln!(
            lns,
            "{} {} {} {}  {} {} {}  {} {} {} # segment",
            s.start.x,
            s.start.y,
            s.end.x,
            s.end.y,
            w.start.x,
            w.start.y,
            w.start.z,
            w.end.x,
            w.end.y,
            w.end.z
        )
        .unwrap();
    }
    let (pp, lp) = (dir.join("points.txt"), dir.join("lines.txt"));
    std::fs::write(&pp, pts).unwrap();
    std::fs::write(&lp, lns).unwrap();
    (pp, lp)
}

fn run_ok(cmd: &mut Command) -> String {
    let out: Output = cmd.output().unwrap();
    assert!(
        out.status.success(),
        "failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).unwrap()
}

fn json_pose(v: &serde_json::Value) -> Pose {
    let f = |key: &str, i: usize| v[key][i].as_f64().unwrap();
    Pose::from_qvec_tvec(
        [f("qvec", 0), f("qvec", 1), f("qvec", 2), f("qvec", 3)],
        [f("tvec", 0), f("tvec", 1), f("tvec", 2)],
    )
    .unwrap()
}

#[test]
fn points_and_lines_json_recovers_the_pose_deterministically() {
    let pb = generate_seeded(&SyntheticConfig::bench_points_lines(), 11);
    let dir = tempfile::tempdir().unwrap();
    let (pp, lp) = write_problem(&pb, dir.path());
    let args = |seed: &str| {
        let mut c = bin();
        c.args(["pose", "--camera", &camera_arg(&pb.camera), "--points"])
            .arg(&pp)
            .arg("--lines")
            .arg(&lp)
            .args(["--seed", seed, "--json"]);
        c
    };
    let out = run_ok(&mut args("3"));
    let v: serde_json::Value = serde_json::from_str(out.trim()).unwrap();
    let e = pose_error(&pb.gt, &json_pose(&v));
    assert!(e.translation_cm() < 1.0 && e.rotation_deg < 0.2, "{e:?}");
    assert_eq!(v["num_points"], 8);
    assert_eq!(v["num_lines"], 60);
    // All 8 points and the 42 good lines are correct; bad lines may pass by chance.
    assert_eq!(v["point_inliers"], 8);
    let li = v["line_inliers"].as_u64().unwrap();
    assert!((42..=46).contains(&li), "{li}");
    assert!(v["iterations"].as_u64().unwrap() >= 1000);
    assert_eq!(v["line_inlier_mask"].as_array().unwrap().len(), 60);
    // Same seed: same pose and masks (only the time differs).
    let again: serde_json::Value = serde_json::from_str(run_ok(&mut args("3")).trim()).unwrap();
    for key in [
        "qvec",
        "tvec",
        "point_inlier_mask",
        "line_inlier_mask",
        "iterations",
    ] {
        assert_eq!(v[key], again[key], "{key}");
    }
}

#[test]
fn points_only_text_output_with_a_distorted_camera() {
    let camera = Camera::new(
        CameraModel::OpenCv,
        640,
        480,
        vec![520.0, 515.0, 322.0, 238.0, -0.12, 0.03, 0.001, -0.0005],
    )
    .unwrap();
    let cfg = SyntheticConfig {
        num_points: 150,
        point_outlier_ratio: 0.4,
        ..SyntheticConfig::indoor(camera.clone())
    };
    let pb = generate_seeded(&cfg, 4);
    let dir = tempfile::tempdir().unwrap();
    let (pp, _) = write_problem(&pb, dir.path());
    let out = run_ok(
        bin()
            .args(["pose", "--camera", &camera_arg(&camera), "--points"])
            .arg(&pp),
    );
    let lines: Vec<&str> = out.lines().collect();
    assert_eq!(lines[0], "pose (world-to-camera, qw qx qy qz tx ty tz):");
    let v: Vec<f64> = lines[1]
        .split_whitespace()
        .map(|s| s.parse().unwrap())
        .collect();
    assert_eq!(v.len(), 7);
    let est = Pose::from_qvec_tvec([v[0], v[1], v[2], v[3]], [v[4], v[5], v[6]]).unwrap();
    let e = pose_error(&pb.gt, &est);
    assert!(e.translation_cm() < 1.0 && e.rotation_deg < 0.1, "{e:?}");
    assert!(lines[2].starts_with("inliers: ") && lines[2].contains("/150 points, 0/0 lines"));
    assert!(lines[3].starts_with("iterations: "));
    assert!(lines[4].starts_with("time: ") && lines[4].ends_with(" ms"));
}

fn run_err(cmd: &mut Command) -> String {
    let out = cmd.output().unwrap();
    assert!(!out.status.success());
    String::from_utf8(out.stderr).unwrap()
}

#[test]
fn malformed_inputs_are_reported_with_file_and_line() {
    let dir = tempfile::tempdir().unwrap();
    let pp = dir.path().join("pts.txt");
    std::fs::write(&pp, "# ok\n1 2 3 4 5\n1 2 3 4\n").unwrap();
    let cam = "PINHOLE 640 480 500 500 320 240";
    let err = run_err(bin().args(["pose", "--camera", cam, "--points"]).arg(&pp));
    assert!(
        err.contains(&format!(
            "{}:3: expected 5 numbers (x y X Y Z), found 4",
            pp.display()
        )),
        "{err}"
    );
    let lp = dir.path().join("lines.txt");
    std::fs::write(&lp, "1 2 3 4 0 0 1 1 0 x\n").unwrap();
    std::fs::write(&pp, "1 2 3 4 5\n").unwrap();
    let err = run_err(
        bin()
            .args(["pose", "--camera", cam, "--points"])
            .arg(&pp)
            .arg("--lines")
            .arg(&lp),
    );
    assert!(
        err.contains(&format!(
            "{}:1: field 10 (Z2) is not a finite number: \"x\"",
            lp.display()
        )),
        "{err}"
    );
    let err = run_err(
        bin()
            .args(["pose", "--camera", "PINHOLE 640 480 500", "--points"])
            .arg(&pp),
    );
    assert!(
        err.contains("camera model PINHOLE takes 4 parameters, got 1"),
        "{err}"
    );
    let missing = dir.path().join("missing.txt");
    let err = run_err(
        bin()
            .args(["pose", "--camera", cam, "--points"])
            .arg(&missing),
    );
    assert!(err.contains("missing.txt: cannot read"), "{err}");
    // Two correspondences are not enough for any solver.
    std::fs::write(&pp, "1 2 3 4 5\n6 7 8 9 10\n").unwrap();
    let err = run_err(bin().args(["pose", "--camera", cam, "--points"]).arg(&pp));
    assert!(err.contains("not enough usable correspondences"), "{err}");
}

#[test]
fn a_closed_stdout_is_a_quiet_exit() {
    let pb = generate_seeded(&SyntheticConfig::bench_points_lines(), 11);
    let dir = tempfile::tempdir().unwrap();
    let (pp, lp) = write_problem(&pb, dir.path());
    for json in [false, true] {
        let mut c = bin();
        c.args(["pose", "--camera", &camera_arg(&pb.camera), "--points"])
            .arg(&pp)
            .arg("--lines")
            .arg(&lp);
        if json {
            c.arg("--json");
        }
        testkit::process::assert_quiet_exit_on_closed_stdout(&mut c);
    }
}
