//! `pl2map colmap info|convert` end to end, through the built binary.

use std::path::Path;
use std::process::{Command, Output};

fn pl2map(args: &[&std::ffi::OsStr]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_pl2map"))
        .arg("--quiet")
        .args(args)
        .output()
        .expect("running pl2map")
}

fn ok(out: &Output) -> String {
    assert!(
        out.status.success(),
        "pl2map failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout.clone()).unwrap()
}

fn same_files(a: &Path, b: &Path, ext: &str) {
    for t in ["cameras", "images", "points3D", "rigs", "frames"] {
        let name = format!("{t}.{ext}");
        assert!(
            std::fs::read(a.join(&name)).unwrap() == std::fs::read(b.join(&name)).unwrap(),
            "{name} differs"
        );
    }
}

#[test]
fn info_and_convert_on_a_generated_model() {
    let spec = colmap::synthetic::SyntheticSpec {
        num_points3d: 200,
        num_images: 6,
        num_observations: 700,
        unmatched_per_image: 3,
        images_per_camera: 2,
        seed: 1,
    };
    let rec = colmap::synthetic::large_model(&spec);
    let tmp = tempfile::tempdir().unwrap();
    let bin = tmp.path().join("bin");
    rec.write_binary(&bin).unwrap();

    let text = ok(&pl2map(&[
        "colmap".as_ref(),
        "info".as_ref(),
        bin.as_os_str(),
    ]));
    for line in [
        "num_cameras = 3",
        "num_images = 6",
        "num_points3D = 200",
        "num_observations = 700",
        "num_points2D = 718",
        "mean_track_length = 3.5",
        "SIMPLE_RADIAL 1600x1200",
    ] {
        assert!(text.contains(line), "{line:?} missing in:\n{text}");
    }

    let json = ok(&pl2map(&[
        "colmap".as_ref(),
        "info".as_ref(),
        bin.as_os_str(),
        "--json".as_ref(),
    ]));
    let v: serde_json::Value = serde_json::from_str(&json).unwrap();
    assert_eq!(v["num_points3D"], 200);
    assert_eq!(v["format"], "bin");
    assert_eq!(v["cameras"].as_array().unwrap().len(), 3);
    let expected = rec.mean_reprojection_error();
    assert!((v["mean_reprojection_error"].as_f64().unwrap() - expected).abs() < 1e-12);

    let txt = tmp.path().join("txt");
    let back = tmp.path().join("back");
    ok(&pl2map(&[
        "colmap".as_ref(),
        "convert".as_ref(),
        bin.as_os_str(),
        txt.as_os_str(),
        "--format".as_ref(),
        "txt".as_ref(),
    ]));
    assert_eq!(colmap::read_text(&txt).unwrap(), rec);
    ok(&pl2map(&[
        "colmap".as_ref(),
        "convert".as_ref(),
        txt.as_os_str(),
        back.as_os_str(),
        "--format".as_ref(),
        "bin".as_ref(),
    ]));
    same_files(&bin, &back, "bin");
}

#[test]
fn info_and_convert_on_real_models() {
    let Some(scene) = testkit::sample::sample_data("colmap-maupertuis") else {
        return;
    };
    let summary: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(scene.join("pycolmap-summary.json")).unwrap(),
    )
    .unwrap();
    for model in ["model-bin", "model-txt", "model-original-txt"] {
        let dir = scene.join(model);
        let json = ok(&pl2map(&[
            "colmap".as_ref(),
            "info".as_ref(),
            dir.as_os_str(),
            "--json".as_ref(),
        ]));
        let v: serde_json::Value = serde_json::from_str(&json).unwrap();
        for key in [
            "num_cameras",
            "num_images",
            "num_points3D",
            "num_observations",
        ] {
            assert_eq!(v[key], summary[key], "{model}: {key}");
        }
        let (a, b) = (
            v["mean_reprojection_error"].as_f64().unwrap(),
            summary["mean_reprojection_error"].as_f64().unwrap(),
        );
        assert!((a - b).abs() < 1e-6 * b, "{model}: {a} vs {b}");
    }
    // The summary text is laid out like pycolmap's.
    let text = ok(&pl2map(&[
        "colmap".as_ref(),
        "info".as_ref(),
        scene.join("model-bin").as_os_str(),
    ]));
    assert!(text.contains("\tmean_track_length = 3.22907\n"), "{text}");
    assert!(
        text.contains("\tmean_observations_per_image = 838.75\n"),
        "{text}"
    );
    assert!(
        text.contains("\tmean_reprojection_error = 0.3426\n"),
        "{text}"
    );
    assert!(
        text.contains("1 SIMPLE_PINHOLE 1919x1079 f=1847.53 cx=959.5 cy=539.5 (4 images)"),
        "{text}"
    );

    // bin -> txt gives exactly the text files pycolmap wrote.
    let tmp = tempfile::tempdir().unwrap();
    ok(&pl2map(&[
        "colmap".as_ref(),
        "convert".as_ref(),
        scene.join("model-bin").as_os_str(),
        tmp.path().as_os_str(),
        "--format".as_ref(),
        "txt".as_ref(),
    ]));
    same_files(tmp.path(), &scene.join("model-txt"), "txt");
}

#[test]
fn errors_name_the_file_and_place() {
    let tmp = tempfile::tempdir().unwrap();
    let out = pl2map(&["colmap".as_ref(), "info".as_ref(), tmp.path().as_os_str()]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("no COLMAP model"), "{err}");

    std::fs::write(tmp.path().join("cameras.bin"), 5u64.to_le_bytes()).unwrap();
    std::fs::write(tmp.path().join("images.bin"), 0u64.to_le_bytes()).unwrap();
    std::fs::write(tmp.path().join("points3D.bin"), 0u64.to_le_bytes()).unwrap();
    let out = pl2map(&["colmap".as_ref(), "info".as_ref(), tmp.path().as_os_str()]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("cameras.bin: byte 0") && err.contains("cameras count 5"),
        "{err}"
    );
}

/// A model whose camera cannot exist (a focal length of 0 or below) is refused by
/// `colmap info` and `colmap convert`, naming the file and the camera id, instead of
/// passing on to the import and refine; `convert` writes nothing (docs/errors.md).
#[test]
fn a_camera_that_cannot_exist_is_refused_naming_the_file_and_camera() {
    let spec = colmap::synthetic::SyntheticSpec {
        num_points3d: 50,
        num_images: 4,
        num_observations: 150,
        unmatched_per_image: 1,
        images_per_camera: 2,
        seed: 2,
    };
    let tmp = tempfile::tempdir().unwrap();
    for (focal, expect) in [(0.0, "f = 0 must be positive"), (-1200.0, "f = -1200 must")] {
        let mut rec = colmap::synthetic::large_model(&spec);
        rec.cameras[1].camera.params[0] = focal;
        for (sub, ext) in [("bin", "bin"), ("txt", "txt")] {
            let model = tmp.path().join(format!("{sub}{focal}"));
            if ext == "bin" {
                rec.write_binary(&model).unwrap();
            } else {
                rec.write_text(&model).unwrap();
            }
            let out = pl2map(&["colmap".as_ref(), "info".as_ref(), model.as_os_str()]);
            assert!(!out.status.success(), "info must refuse focal {focal}");
            let err = String::from_utf8_lossy(&out.stderr);
            assert!(
                err.contains(&format!("cameras.{ext}"))
                    && err.contains("camera #1 (id 2)")
                    && err.contains(expect),
                "{err}"
            );
            let converted = tmp.path().join(format!("out-{sub}{focal}"));
            let out = pl2map(&[
                "colmap".as_ref(),
                "convert".as_ref(),
                model.as_os_str(),
                converted.as_os_str(),
                "--format".as_ref(),
                "txt".as_ref(),
            ]);
            assert!(!out.status.success(), "convert must refuse focal {focal}");
            assert!(!converted.exists(), "nothing may be written");
        }
    }
}

/// `pl2map colmap info MODEL | true`: the reader is gone before the first line.
#[test]
fn info_with_a_closed_stdout_is_a_quiet_exit() {
    let Some(scene) = testkit::sample::sample_data("colmap-maupertuis") else {
        return;
    };
    for json in [false, true] {
        let mut c = Command::new(env!("CARGO_BIN_EXE_pl2map"));
        c.args(["colmap", "info"]).arg(scene.join("model-bin"));
        if json {
            c.arg("--json");
        }
        testkit::process::assert_quiet_exit_on_closed_stdout(&mut c);
    }
}
