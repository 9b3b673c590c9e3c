//! Ground truth of the synthetic room (`sfm_gt/`): exactness of the labels, read-back
//! through the colmap and limap crates (and pycolmap where available), determinism and
//! label noise. All on the tiny scene.

use geometry::{Pose, Vector2, Vector3};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;
use synth::gt::{EXACT_FILE, GT_DIR};
use synth::{Split, SynthConfig, SynthOutput, generate};
use testkit::files::files;

const SEED: u64 = 3;

struct Generated {
    _dir: tempfile::TempDir,
    out: SynthOutput,
}

fn generate_tiny(dir: &Path, threads: usize, noise_cm: f64) -> SynthOutput {
    testkit::on_threads(threads, || {
        generate(
            &SynthConfig {
                seed: SEED,
                tiny: true,
                label_noise_cm: noise_cm,
                ..SynthConfig::default()
            },
            &synth::WriteOptions {
                progress: false,
                ..synth::WriteOptions::new(dir)
            },
        )
        .unwrap()
    })
}

/// The noise-free tiny scene, generated once for the tests of this file.
fn exact() -> &'static Generated {
    static G: OnceLock<Generated> = OnceLock::new();
    G.get_or_init(|| {
        let dir = tempfile::tempdir().unwrap();
        let out = generate_tiny(dir.path(), 2, 0.0);
        Generated { _dir: dir, out }
    })
}

fn model_dir(out: &SynthOutput) -> PathBuf {
    out.root.join(GT_DIR).join("colmap")
}

fn limap_dir(out: &SynthOutput) -> PathBuf {
    out.root.join(GT_DIR).join("limap")
}

fn project(cam: &geometry::Camera, pose: &Pose, x: &Vector3<f64>) -> Vector2<f64> {
    let pc = pose.transform_point(x);
    assert!(pc.z > 0.0, "point behind the camera");
    cam.project(&pc).unwrap()
}

#[test]
fn model_holds_every_training_frame_and_every_keypoint() {
    let g = exact();
    let rec = colmap::read_binary(&model_dir(&g.out)).unwrap();
    rec.validate().unwrap();
    let train: Vec<_> = g
        .out
        .frames
        .iter()
        .filter(|f| f.split == Split::Train)
        .collect();
    assert_eq!(rec.images.len(), train.len());
    assert_eq!(rec.cameras.len(), 1);
    let cam = &rec.cameras[0].camera;
    assert_eq!(cam.model, geometry::CameraModel::Pinhole);
    assert_eq!(cam.params, g.out.dataset.camera.params);
    for (im, f) in rec.images.iter().zip(&train) {
        assert_eq!(im.name, f.name);
        let pose = im.pose().unwrap();
        assert!((pose.centre() - f.pose.centre()).norm() < 1e-12);
    }
    // Every SIFT keypoint of the written image is in the model, in detection order.
    let cfg = features::SiftConfig::default();
    for k in [0usize, train.len() - 1] {
        let gray = features::load_gray(&train[k].color_path).unwrap();
        let kps = features::detect_keypoints(&gray, &cfg).unwrap();
        let xy: Vec<[f64; 2]> = rec.images[k].points2d.iter().map(|p| p.xy).collect();
        assert_eq!(xy, kps.iter().map(|k| k.xy).collect::<Vec<_>>());
        assert!(xy.len() > 1000, "only {} keypoints", xy.len());
    }
    let summary = g.out.ground_truth.as_ref().unwrap();
    assert_eq!(summary.points3d, rec.points3d.len());
    assert_eq!(summary.observations, rec.num_observations());
    eprintln!(
        "tiny ground truth: {} images, {} keypoints, {} points3D, mean track length {:.2}, \
         {} line tracks ({} supports of {} segments)",
        summary.images,
        summary.keypoints,
        summary.points3d,
        summary.mean_track_length,
        summary.line_tracks,
        summary.line_supports,
        summary.segments
    );
    assert!(rec.points3d.len() > 500, "{} points", rec.points3d.len());
    assert!(rec.mean_track_length() >= 2.0);
}

#[test]
fn labelled_points_reproject_within_half_a_pixel_and_lie_on_visible_surfaces() {
    let g = exact();
    let rec = colmap::read_binary(&model_dir(&g.out)).unwrap();
    let idx = rec.index();
    let cam = &rec.cameras[0].camera;
    let scene = &g.out.dataset.scene;
    let mut n = 0usize;
    for p in &rec.points3d {
        let x = Vector3::from(p.xyz);
        assert!(p.track.len() >= 2);
        let mut images: Vec<u32> = p.track.iter().map(|t| t.image_id).collect();
        images.sort();
        images.dedup();
        assert_eq!(images.len(), p.track.len(), "one observation per image");
        let mut sum = 0.0;
        for t in &p.track {
            let im = &rec.images[idx.images[&t.image_id]];
            let pose = im.pose().unwrap();
            let kp = im.points2d[t.point2d_idx as usize];
            assert_eq!(kp.point3d_id, p.id);
            let e = (project(cam, &pose, &x) - Vector2::from(kp.xy)).norm();
            assert!(e <= 0.5, "point {} image {}: {e} px", p.id, t.image_id);
            sum += e;
            // The ray from the camera to the point ends on the point: it is the visible
            // surface, not a point behind something.
            let c = pose.centre();
            let hit = scene.raycast(&c, &(x - c)).unwrap();
            assert!((hit.point - x).norm() < 1e-6, "point {} occluded", p.id);
            n += 1;
        }
        assert!((sum / p.track.len() as f64 - p.error).abs() < 1e-9);
    }
    assert!(n > 1000);
}

#[test]
fn line_tracks_lie_on_scene_edges_and_project_onto_their_supports() {
    let g = exact();
    let dir = limap::LimapDir::load(limap_dir(&g.out), &limap::LimapDirOptions::default()).unwrap();
    let report = dir.check();
    assert!(report.is_ok(), "{report:?}");
    let rec = colmap::read_binary(&model_dir(&g.out)).unwrap();
    let idx = rec.index();
    let cam = &rec.cameras[0].camera;
    // image_list.txt names the model's images with the same ids.
    assert_eq!(dir.image_list.len(), rec.images.len());
    for (id, name) in &dir.image_list.images {
        assert_eq!(rec.images[idx.images[id]].name, *name);
    }
    assert_eq!(dir.segments.len(), rec.images.len());
    assert!(dir.alltracks.is_some());
    assert!(!dir.tracks.is_empty());
    let edges = g.out.dataset.scene.edges();
    let mut checked = 0usize;
    for t in &dir.tracks {
        let mut imgs = t.image_ids.clone();
        imgs.sort();
        imgs.dedup();
        assert!(imgs.len() >= 4, "track with {} images", imgs.len());
        let (a, b) = (Vector3::from(t.line[0]), Vector3::from(t.line[1]));
        assert!((b - a).norm() > 1e-6);
        // Both endpoints lie on one edge segment of the scene (within the 1e-10 m of
        // the track file's 10 decimals).
        let on_edge = |x: &Vector3<f64>, e: &synth::Edge3| {
            let u = e.b - e.a;
            let l = (x - e.a).dot(&u) / u.norm_squared();
            let tol = 1e-9 / u.norm();
            (-tol..=1.0 + tol).contains(&l) && (e.a + u * l - x).norm() < 1e-9
        };
        assert!(
            edges.iter().any(|e| on_edge(&a, e) && on_edge(&b, e)),
            "track endpoints {a:?} {b:?} on no edge"
        );
        for (img, line) in t.supports() {
            let im = &rec.images[idx.images[&img]];
            let pose = im.pose().unwrap();
            let s = dir.segments[&img].lines[line as usize];
            let (pa, pb) = (project(cam, &pose, &a), project(cam, &pose, &b));
            let d = (pb - pa).normalize();
            let nrm = Vector2::new(-d.y, d.x);
            for q in [Vector2::new(s[0], s[1]), Vector2::new(s[2], s[3])] {
                let dist = nrm.dot(&(q - pa)).abs();
                assert!(dist <= 1.5, "image {img} line {line}: {dist} px");
            }
            checked += 1;
        }
    }
    assert!(checked >= 4 * dir.tracks.len());
}

#[test]
fn same_seed_gives_identical_bytes_for_any_thread_count() {
    let g = exact();
    let dir = tempfile::tempdir().unwrap();
    let one = generate_tiny(dir.path(), 1, 0.0);
    let a = g.out.root.join(GT_DIR);
    let b = one.root.join(GT_DIR);
    let fa = files(&a);
    assert_eq!(fa, files(&b));
    assert!(fa.len() > 10);
    for f in &fa {
        assert!(
            std::fs::read(a.join(f)).unwrap() == std::fs::read(b.join(f)).unwrap(),
            "{f:?} differs"
        );
    }
}

#[derive(serde::Deserialize)]
struct ExactLine {
    endpoints: [[f64; 3]; 2],
}

#[derive(serde::Deserialize)]
struct Exact {
    label_noise_cm: f64,
    points3d: BTreeMap<u64, [f64; 3]>,
    line_tracks: BTreeMap<usize, ExactLine>,
}

fn read_exact(out: &SynthOutput) -> Exact {
    let text = std::fs::read_to_string(out.root.join(GT_DIR).join(EXACT_FILE)).unwrap();
    serde_json::from_str(&text).unwrap()
}

#[test]
fn label_noise_has_the_requested_rms_and_exact_json_keeps_the_truth() {
    let g = exact();
    let clean = colmap::read_binary(&model_dir(&g.out)).unwrap();
    let clean_exact = read_exact(&g.out);
    assert_eq!(clean_exact.label_noise_cm, 0.0);
    for p in &clean.points3d {
        // serde_json's default float parsing may be off by one ulp.
        let d = Vector3::from(clean_exact.points3d[&p.id]) - Vector3::from(p.xyz);
        assert!(d.norm() < 1e-12);
    }

    let dir = tempfile::tempdir().unwrap();
    let noisy_out = generate_tiny(dir.path(), 2, 2.0);
    let noisy = colmap::read_binary(&model_dir(&noisy_out)).unwrap();
    let ex = read_exact(&noisy_out);
    assert_eq!(ex.label_noise_cm, 2.0);
    // The noise moves labels, never keypoints or tracks.
    assert_eq!(noisy.points3d.len(), clean.points3d.len());
    assert_eq!(noisy.images, clean.images);
    let mut sq = 0.0;
    for (p, q) in noisy.points3d.iter().zip(&clean.points3d) {
        assert_eq!(p.track, q.track);
        assert!((Vector3::from(ex.points3d[&p.id]) - Vector3::from(q.xyz)).norm() < 1e-12);
        sq += (Vector3::from(p.xyz) - Vector3::from(q.xyz)).norm_squared();
    }
    let rms_cm = (sq / noisy.points3d.len() as f64).sqrt() * 100.0;
    assert!((rms_cm - 2.0).abs() < 0.15, "points: RMS {rms_cm} cm");

    let ld =
        limap::LimapDir::load(limap_dir(&noisy_out), &limap::LimapDirOptions::default()).unwrap();
    let mut sq = 0.0;
    let mut n = 0usize;
    for (i, t) in ld.tracks.iter().enumerate() {
        for (x, e) in t.line.iter().zip(ex.line_tracks[&i].endpoints) {
            sq += (Vector3::from(*x) - Vector3::from(e)).norm_squared();
            n += 1;
        }
    }
    let rms_cm = (sq / n as f64).sqrt() * 100.0;
    // Fewer samples: a looser bound (n >= 40 endpoints gives a few % spread).
    assert!(
        (rms_cm - 2.0).abs() < 0.6,
        "lines: RMS {rms_cm} cm over {n} endpoints"
    );
}

#[test]
fn pycolmap_reads_the_model_with_the_same_counts() {
    let Some(python) = testkit::python::python(&["pycolmap"]) else {
        return;
    };
    let g = exact();
    let rec = colmap::read_binary(&model_dir(&g.out)).unwrap();
    let script = "import sys, pycolmap\n\
                  r = pycolmap.Reconstruction(sys.argv[1])\n\
                  print(r.num_images(), r.num_points3D(), r.compute_num_observations())\n";
    let out = testkit::python::run(
        std::process::Command::new(&python)
            .arg("-c")
            .arg(script)
            .arg(model_dir(&g.out)),
    );
    let counts: Vec<usize> = String::from_utf8_lossy(&out)
        .split_whitespace()
        .map(|t| t.parse().unwrap())
        .collect();
    assert_eq!(
        counts,
        vec![rec.images.len(), rec.points3d.len(), rec.num_observations()]
    );
}
