//! Our minimal solvers against poselib 2.0.5's (an independent implementation) on the
//! same random problems: every solution of ours must be one of poselib's, and every
//! poselib solution that keeps the sample's points in front of the camera must be one
//! of ours. Needs PL2MAP_PYTHON (a Python with poselib, see scripts/setup-python.sh);
//! skips with a printed reason otherwise.

mod common;

use common::Scene;
use geometry::{Pose, Vector3};
use pose::solvers::{Line3D, p1p2ll, p2p1ll, p3ll, p3p};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde_json::{Value, json};
use std::process::Command;

const SCRIPT: &str = r#"
import json, sys
import numpy as np
import poselib
out = []
for pb in json.load(open(sys.argv[1])):
    a = lambda k: np.array(pb[k], dtype=np.float64).reshape(-1, 3)
    kind = pb["kind"]
    if kind == "p3p":
        sols = poselib.p3p(a("x"), a("X"))
    elif kind == "p2p1ll":
        sols = poselib.p2p1ll(a("x"), a("X"), a("l"), a("C"), a("V"))
    elif kind == "p1p2ll":
        sols = poselib.p1p2ll(a("x"), a("X"), a("l"), a("C"), a("V"))
    else:
        sols = poselib.p3ll(a("l"), a("C"), a("V"))
    out.append([list(map(float, s.q)) + list(map(float, s.t)) for s in sols])
json.dump(out, open(sys.argv[2], "w"))
"#;

struct Case {
    kind: &'static str,
    x: Vec<Vector3<f64>>,
    pts: Vec<Vector3<f64>>,
    l: Vec<Vector3<f64>>,
    lines: Vec<Line3D>,
    ours: Vec<Pose>,
}

fn v3(v: &[Vector3<f64>]) -> Value {
    json!(v.iter().map(|p| [p.x, p.y, p.z]).collect::<Vec<_>>())
}

fn same(a: &Pose, b: &Pose) -> bool {
    let scale = a.translation.norm().max(1.0);
    a.rotation.angle_to(&b.rotation) < 1e-6 && (a.translation - b.translation).norm() < 1e-6 * scale
}

#[test]
fn solution_sets_match_poselib() {
    let Some(py) = testkit::python::python(&["poselib", "numpy"]) else {
        return;
    };
    let mut rng = ChaCha8Rng::seed_from_u64(42);
    let mut cases = Vec::new();
    for i in 0..800 {
        let mut s = Scene::new(&mut rng);
        let case = match i % 4 {
            0 => {
                let p: Vec<_> = (0..3).map(|_| s.point()).collect();
                let (x, pts): (Vec<_>, Vec<_>) = p.into_iter().unzip();
                let ours = p3p(&[x[0], x[1], x[2]], &[pts[0], pts[1], pts[2]]);
                Case {
                    kind: "p3p",
                    x,
                    pts,
                    l: vec![],
                    lines: vec![],
                    ours,
                }
            }
            1 => {
                let (a, b, (n, line)) = (s.point(), s.point(), s.line());
                let ours = p2p1ll(&[a.0, b.0], &[a.1, b.1], &n, &line);
                Case {
                    kind: "p2p1ll",
                    x: vec![a.0, b.0],
                    pts: vec![a.1, b.1],
                    l: vec![n],
                    lines: vec![line],
                    ours,
                }
            }
            2 => {
                let (a, (n1, l1), (n2, l2)) = (s.point(), s.line(), s.line());
                let ours = p1p2ll(&a.0, &a.1, &[n1, n2], &[l1, l2]);
                Case {
                    kind: "p1p2ll",
                    x: vec![a.0],
                    pts: vec![a.1],
                    l: vec![n1, n2],
                    lines: vec![l1, l2],
                    ours,
                }
            }
            _ => {
                let ls: Vec<_> = (0..3).map(|_| s.line()).collect();
                let (l, lines): (Vec<_>, Vec<_>) = ls.into_iter().unzip();
                let ours = p3ll(&[l[0], l[1], l[2]], &[lines[0], lines[1], lines[2]]);
                Case {
                    kind: "p3ll",
                    x: vec![],
                    pts: vec![],
                    l,
                    lines,
                    ours,
                }
            }
        };
        cases.push(case);
    }
    let dir = tempfile::tempdir().unwrap();
    let (input, output, script) = (
        dir.path().join("in.json"),
        dir.path().join("out.json"),
        dir.path().join("s.py"),
    );
    let doc: Vec<Value> = cases
        .iter()
        .map(|c| {
            let unit: Vec<_> = c.lines.iter().map(|l| l.normalized().unwrap()).collect();
            json!({
                "kind": c.kind,
                "x": v3(&c.x.iter().map(|x| x.normalize()).collect::<Vec<_>>()),
                "X": v3(&c.pts),
                "l": v3(&c.l),
                "C": v3(&unit.iter().map(|l| l.point).collect::<Vec<_>>()),
                "V": v3(&unit.iter().map(|l| l.direction).collect::<Vec<_>>()),
            })
        })
        .collect();
    std::fs::write(&input, serde_json::to_vec(&doc).unwrap()).unwrap();
    std::fs::write(&script, SCRIPT).unwrap();
    testkit::python::run(Command::new(&py).arg(&script).arg(&input).arg(&output));
    let theirs: Vec<Vec<Vec<f64>>> =
        serde_json::from_slice(&std::fs::read(&output).unwrap()).unwrap();
    assert_eq!(theirs.len(), cases.len());
    let mut mismatches = Vec::new();
    let mut total = [0usize; 2];
    for (k, (c, t)) in cases.iter().zip(&theirs).enumerate() {
        let theirs: Vec<Pose> = t
            .iter()
            .filter_map(|v| Pose::from_qvec_tvec([v[0], v[1], v[2], v[3]], [v[4], v[5], v[6]]).ok())
            // Solutions with a sample point behind the camera are not poses.
            .filter(|p| {
                c.pts
                    .iter()
                    .zip(&c.x)
                    .all(|(w, x)| p.transform_point(w).dot(x) > 0.0)
            })
            .collect();
        total[0] += c.ours.len();
        total[1] += theirs.len();
        let ours_in_theirs = c.ours.iter().all(|o| theirs.iter().any(|p| same(o, p)));
        let theirs_in_ours = theirs.iter().all(|p| c.ours.iter().any(|o| same(o, p)));
        if !(ours_in_theirs && theirs_in_ours) {
            mismatches.push(format!(
                "case {k} {}: ours {} theirs {}",
                c.kind,
                c.ours.len(),
                theirs.len()
            ));
        }
    }
    println!(
        "{} problems: {} solutions ours, {} poselib; {} mismatched: {:?}",
        cases.len(),
        total[0],
        total[1],
        mismatches.len(),
        mismatches
    );
    assert!(mismatches.len() * 200 <= cases.len(), "{mismatches:?}");
}

const RANSAC_SCRIPT: &str = r#"
import json, sys
import numpy as np
import poselib
out = []
for pb in json.load(open(sys.argv[1])):
    p2 = np.array(pb["p2"], dtype=np.float64).reshape(-1, 2)
    p3 = np.array(pb["p3"], dtype=np.float64).reshape(-1, 3)
    l2 = np.array(pb["l2"], dtype=np.float64).reshape(-1, 4)
    l3 = np.array(pb["l3"], dtype=np.float64).reshape(-1, 6)
    ransac = {"max_reproj_error": 12.0, "max_epipolar_error": 10.0, "min_iterations": 1000,
              "max_iterations": 100000, "success_prob": 0.9999, "seed": pb["seed"]}
    bundle = {"loss_type": "CAUCHY", "loss_scale": 6.0}
    if len(l2) == 0:
        pose, _ = poselib.estimate_absolute_pose(p2, p3, pb["camera"], ransac, bundle)
    else:
        pose, _ = poselib.estimate_absolute_pose_pnpl(
            p2, p3, np.ascontiguousarray(l2[:, :2]), np.ascontiguousarray(l2[:, 2:]),
            np.ascontiguousarray(l3[:, :3]), np.ascontiguousarray(l3[:, 3:]), pb["camera"], ransac, bundle)
    out.append(list(map(float, pose.q)) + list(map(float, pose.t)))
json.dump(out, open(sys.argv[2], "w"))
"#;

/// With the same options, our RANSAC and poselib's end at the same optimum of the same
/// robust cost (the minimal samples differ, the inlier sets and the refinement agree).
#[test]
fn ransac_agrees_with_poselib() {
    use geometry::metrics::pose_error;
    use pose::synthetic::{SyntheticConfig, generate_seeded};
    use pose::{RansacOptions, estimate_pose};
    let Some(py) = testkit::python::python(&["poselib", "numpy"]) else {
        return;
    };
    let mut problems = Vec::new();
    for seed in 0..12 {
        let cfg = if seed % 2 == 0 {
            SyntheticConfig::bench_points()
        } else {
            SyntheticConfig::bench_points_lines()
        };
        problems.push((generate_seeded(&cfg, 500 + seed), seed));
    }
    let doc: Vec<Value> = problems
        .iter()
        .map(|(pb, seed)| {
            let c = &pb.camera;
            json!({
                "camera": {"model": c.model.name(), "width": c.width, "height": c.height, "params": c.params},
                "p2": pb.points.iter().map(|p| [p.pixel.x, p.pixel.y]).collect::<Vec<_>>(),
                "p3": pb.points.iter().map(|p| [p.world.x, p.world.y, p.world.z]).collect::<Vec<_>>(),
                "l2": pb.lines.iter().map(|l| l.segment.to_array()).collect::<Vec<_>>(),
                "l3": pb.lines.iter().map(|l| [l.world.start.x, l.world.start.y, l.world.start.z, l.world.end.x, l.world.end.y, l.world.end.z]).collect::<Vec<_>>(),
                "seed": seed,
            })
        })
        .collect();
    let dir = tempfile::tempdir().unwrap();
    let (input, output, script) = (
        dir.path().join("in.json"),
        dir.path().join("out.json"),
        dir.path().join("s.py"),
    );
    std::fs::write(&input, serde_json::to_vec(&doc).unwrap()).unwrap();
    std::fs::write(&script, RANSAC_SCRIPT).unwrap();
    testkit::python::run(Command::new(&py).arg(&script).arg(&input).arg(&output));
    let theirs: Vec<Vec<f64>> = serde_json::from_slice(&std::fs::read(&output).unwrap()).unwrap();
    for ((pb, seed), v) in problems.iter().zip(&theirs) {
        let opt = RansacOptions {
            seed: *seed,
            ..RansacOptions::default()
        };
        let ours = estimate_pose(&pb.camera, &pb.points, &pb.lines, &opt).unwrap();
        let theirs = Pose::from_qvec_tvec([v[0], v[1], v[2], v[3]], [v[4], v[5], v[6]]).unwrap();
        let d = pose_error(&theirs, &ours.pose);
        let g = pose_error(&pb.gt, &ours.pose);
        println!(
            "seed {seed}: ours vs poselib {:.2e} cm {:.2e} deg; ours vs truth {:.3} cm {:.4} deg",
            d.translation_cm(),
            d.rotation_deg,
            g.translation_cm(),
            g.rotation_deg
        );
        assert!(
            d.translation_cm() < 0.01 && d.rotation_deg < 1e-3,
            "seed {seed}: {d:?}"
        );
    }
}
