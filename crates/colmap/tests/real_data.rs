//! Real COLMAP models of the sample data (README.md, "Tests") against what pycolmap 4.2.1 reads from them
//! (pycolmap-summary.json, written by pycolmap, not by this project).

use colmap::Reconstruction;
use serde_json::Value;
use std::path::Path;

fn summary(scene: &Path) -> Value {
    let text = std::fs::read_to_string(scene.join("pycolmap-summary.json")).unwrap();
    serde_json::from_str(&text).unwrap()
}

fn f(v: &Value) -> f64 {
    v.as_f64().unwrap()
}

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs().max(1e-300)
}

/// Everything the summary holds, compared with the model we read.
fn check_against_summary(rec: &Reconstruction, s: &Value, what: &str) {
    assert_eq!(
        rec.cameras.len() as u64,
        s["num_cameras"].as_u64().unwrap(),
        "{what}"
    );
    assert_eq!(
        rec.images.len() as u64,
        s["num_images"].as_u64().unwrap(),
        "{what}"
    );
    assert_eq!(
        rec.images.len() as u64,
        s["num_reg_images"].as_u64().unwrap(),
        "{what}"
    );
    assert_eq!(
        rec.points3d.len() as u64,
        s["num_points3D"].as_u64().unwrap(),
        "{what}"
    );
    assert_eq!(
        rec.num_observations() as u64,
        s["num_observations"].as_u64().unwrap(),
        "{what}"
    );
    // COLMAP's definition: mean of the stored per-point errors.
    let expected = f(&s["mean_reprojection_error"]);
    let got = rec.mean_reprojection_error();
    assert!(
        rel(got, expected) < 1e-6,
        "{what}: mean reprojection error {got} vs {expected}"
    );

    let cams = s["cameras"].as_object().unwrap();
    assert_eq!(cams.len(), rec.cameras.len());
    for (id, c) in cams {
        let cam = rec
            .camera(id.parse().unwrap())
            .unwrap_or_else(|| panic!("{what}: camera {id}"));
        assert_eq!(cam.camera.model.name(), c["model"].as_str().unwrap());
        assert_eq!(cam.camera.width, c["width"].as_u64().unwrap());
        assert_eq!(cam.camera.height, c["height"].as_u64().unwrap());
        let params: Vec<f64> = c["params"].as_array().unwrap().iter().map(f).collect();
        assert_eq!(cam.camera.params.len(), params.len());
        for (a, b) in cam.camera.params.iter().zip(&params) {
            assert!(
                (a - b).abs() <= 1e-12 * b.abs().max(1.0),
                "{what}: camera {id}: {a} vs {b}"
            );
        }
    }

    let index = rec.index();
    let images = s["images"].as_object().unwrap();
    assert_eq!(images.len(), rec.images.len());
    for (id, e) in images {
        let im = &rec.images[index.images[&id.parse::<u32>().unwrap()]];
        let name = e["name"].as_str().unwrap();
        assert_eq!(im.name, name);
        assert_eq!(rec.image_by_name(name).unwrap().image_id, im.image_id);
        assert_eq!(u64::from(im.camera_id), e["camera_id"].as_u64().unwrap());
        let q: Vec<f64> = e["qvec_wxyz"].as_array().unwrap().iter().map(f).collect();
        let t: Vec<f64> = e["tvec"].as_array().unwrap().iter().map(f).collect();
        // pycolmap reports the quaternion as stored (not normalised), like `qvec`.
        for (a, b) in im.qvec.iter().zip(&q) {
            assert!(
                (a - b).abs() <= 1e-9,
                "{what}: image {id} qvec {:?} vs {q:?}",
                im.qvec
            );
        }
        for (a, b) in im.tvec.iter().zip(&t) {
            assert!(
                (a - b).abs() <= 1e-9,
                "{what}: image {id} tvec {:?} vs {t:?}",
                im.tvec
            );
        }
        // The checked pose is the same rotation, normalised.
        let pose = im.pose().unwrap();
        let expected =
            geometry::Pose::from_qvec_tvec([q[0], q[1], q[2], q[3]], [t[0], t[1], t[2]]).unwrap();
        assert!(
            pose.rotation.angle_to(&expected.rotation) <= 1e-9,
            "{what}: image {id}"
        );
        assert!(
            (pose.translation - expected.translation).norm() <= 1e-9,
            "{what}: image {id}"
        );
        assert_eq!(
            im.num_points2d() as u64,
            e["num_points2D"].as_u64().unwrap(),
            "{what}"
        );
        assert_eq!(
            im.num_points3d() as u64,
            e["num_points3D"].as_u64().unwrap(),
            "{what}"
        );
    }
}

#[test]
fn maupertuis_every_variant_matches_pycolmap() {
    let Some(scene) = testkit::sample::sample_data("colmap-maupertuis") else {
        return;
    };
    let s = summary(&scene);
    let original = colmap::read_text(&scene.join("model-original-txt")).unwrap();
    check_against_summary(&original, &s, "model-original-txt");
    let bin = colmap::read_binary(&scene.join("model-bin")).unwrap();
    check_against_summary(&bin, &s, "model-bin");
    let txt = colmap::read_text(&scene.join("model-txt")).unwrap();
    check_against_summary(&txt, &s, "model-txt");
    // read() prefers the binary files, falls back to text.
    assert_eq!(colmap::read(&scene.join("model-bin")).unwrap(), bin);
    assert_eq!(colmap::read(&scene.join("model-txt")).unwrap(), txt);
    // The bin and txt written by pycolmap hold the same model.
    assert_eq!(bin, txt);

    // The legacy model gets COLMAP's trivial rigs and frames, which are exactly what
    // pycolmap wrote for it.
    assert_eq!(original.rigs, bin.rigs);
    assert_eq!(original.frames.len(), bin.frames.len());
    for (a, b) in original.frames.iter().zip(&bin.frames) {
        assert_eq!(
            (a.frame_id, a.rig_id, &a.data_ids),
            (b.frame_id, b.rig_id, &b.data_ids)
        );
    }
}

#[test]
fn sacre_coeur_matches_pycolmap() {
    let Some(scene) = testkit::sample::sample_data("colmap-sacre-coeur") else {
        return;
    };
    let s = summary(&scene);
    let bin = colmap::read_binary(&scene.join("model-bin")).unwrap();
    check_against_summary(&bin, &s, "model-bin");
    let txt = colmap::read_text(&scene.join("model-txt")).unwrap();
    check_against_summary(&txt, &s, "model-txt");
    assert_eq!(bin, txt);
}

/// Reprojection errors recomputed with geometry::Camera::project (COLMAP's
/// UpdatePoint3DErrors) against pycolmap's mean.
#[test]
fn recomputed_reprojection_error_matches_pycolmap() {
    let Some(scene) = testkit::sample::sample_data("colmap-sacre-coeur") else {
        return;
    };
    let s = summary(&scene);
    let rec = colmap::read_binary(&scene.join("model-bin")).unwrap();
    let expected = f(&s["mean_reprojection_error"]);
    let got = rec.recomputed_mean_reprojection_error().unwrap();
    assert!(
        rel(got, expected) < 1e-6,
        "sacre-coeur: recomputed {got} vs {expected}"
    );
    // Per point, too: the stored errors are what COLMAP computed after its last bundle
    // adjustment on this very model.
    let errors = rec.reprojection_errors().unwrap();
    for (p, e) in rec.points3d.iter().zip(&errors) {
        assert!(
            (p.error - e).abs() <= 1e-6 * p.error.max(1.0),
            "point {}: {} vs {e}",
            p.id,
            p.error
        );
    }

    // Maupertuis's poses were published with 6 significant digits while its stored
    // errors come from the full-precision poses, so recomputing moves the mean by
    // ~8e-5 (pycolmap itself gives 0.34262688 here); it must still be that close.
    let Some(scene) = testkit::sample::sample_data("colmap-maupertuis") else {
        return;
    };
    let s = summary(&scene);
    let rec = colmap::read_binary(&scene.join("model-bin")).unwrap();
    let expected = f(&s["mean_reprojection_error"]);
    let got = rec.recomputed_mean_reprojection_error().unwrap();
    assert!(
        rel(got, expected) < 2e-4,
        "maupertuis: recomputed {got} vs {expected}"
    );
}
