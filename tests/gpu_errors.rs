//! A GPU device that this build or machine cannot run is one line on stderr saying what
//! to do, a non-zero exit and nothing written, never a panic (issue 50, item 3). Runs
//! the built `pl2map` (`train`, `score` and `run --device`):
//!
//! - every build: an engine it was built without (`cuda`, `libtorch:cpu`,
//!   `libtorch:cuda:N`) names the cargo feature and the build command;
//! - builds with a GPU engine (`--features cuda` and/or `--features tch`), for each
//!   engine's GPU device, with a libcuda built here with cc first on LD_LIBRARY_PATH:
//!   the CUDA toolkit's stub (cuInit returns CUDA_ERROR_STUB_LIBRARY), a library of that
//!   name without the driver's entry points, a driver that answers with one GPU asked
//!   for GPU 3, and (on a machine with no NVIDIA driver) no driver at all.
//!
//! GPU memory exhausted cannot be caused on a CPU machine; its line is tested on the
//! engines' panic messages in `crates/model/src/device.rs` (`explain_gpu_panic`).

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn bin() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_pl2map"));
    c.env("RUST_BACKTRACE", "0");
    c
}

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// The refusal's stderr, after checking it is one line, a non-zero exit, no panic.
fn refused(out: Output, what: &str) -> String {
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(!out.status.success(), "{what} succeeded: {stderr}");
    assert!(!stderr.contains("panicked"), "{what} panicked: {stderr}");
    assert_eq!(
        stderr.trim_end().lines().count(),
        1,
        "{what}: not one line: {stderr}"
    );
    stderr
}

/// `pl2map train`, `pl2map score` and `pl2map run` on `device`, each refused with a
/// line containing every one of `says`, writing nothing.
fn refused_everywhere(device: &str, env: &[(&str, String)], says: &[&str]) {
    let dir = tempfile::tempdir().unwrap();
    let with_env = |mut c: Command| {
        for (k, v) in env {
            c.env(k, v);
        }
        c
    };
    let out_dir = dir.path().join("model");
    let mut c = with_env(bin());
    c.args(["train", "--device", device, "--shards"])
        .arg(dir.path())
        .arg("--out")
        .arg(&out_dir);
    let e = refused(c.output().unwrap(), &format!("train --device {device}"));
    for s in says {
        assert!(e.contains(s), "train --device {device}: {e} lacks {s:?}");
    }
    assert!(!out_dir.exists(), "train wrote {}", out_dir.display());

    let score_dir = dir.path().join("score");
    let mut c = with_env(bin());
    c.args(["score", "--device", device, "--shards"])
        .arg(dir.path())
        .arg("--checkpoint")
        .arg(dir.path().join("model.ckpt"))
        .arg("--out")
        .arg(&score_dir);
    let e = refused(c.output().unwrap(), &format!("score --device {device}"));
    for s in says {
        assert!(e.contains(s), "score --device {device}: {e} lacks {s:?}");
    }
    assert!(!score_dir.exists());

    let work = dir.path().join("work");
    let mut c = with_env(bin());
    c.args(["run", "--quiet", "--device", device, "--work"])
        .arg(&work)
        .arg(repo().join("pipeline/synthetic-tiny.toml"));
    let e = refused(c.output().unwrap(), &format!("run --device {device}"));
    for s in says {
        assert!(e.contains(s), "run --device {device}: {e} lacks {s:?}");
    }
    assert!(!work.exists(), "the refused run made {}", work.display());
}

#[test]
fn an_engine_the_build_lacks_says_how_to_build_it() {
    if !cfg!(feature = "tch") {
        for device in ["libtorch:cpu", "libtorch:cuda:1"] {
            refused_everywhere(
                device,
                &[],
                &[
                    &format!("device {device}"),
                    "built without LibTorch",
                    "--features tch",
                    "scripts/libtorch-env.sh",
                ],
            );
        }
    }
    if !cfg!(feature = "cuda") {
        refused_everywhere(
            "cuda:1",
            &[],
            &["device cuda:1", "built without CUDA", "--features cuda"],
        );
    }
    if cfg!(feature = "tch") && cfg!(feature = "cuda") {
        println!("SKIPPED: this build has both engines");
    }
}

/// The GPU devices of the engines this build has.
fn gpu_devices() -> Vec<&'static str> {
    let mut v = Vec::new();
    if cfg!(feature = "cuda") {
        v.push("cuda");
    }
    if cfg!(feature = "tch") {
        v.push("libtorch:cuda");
    }
    v
}

/// Builds `dir/libcuda.so` from C source with cc; false (the caller skips, saying why)
/// without a C compiler.
fn libcuda(dir: &Path, source: &str) -> bool {
    std::fs::create_dir_all(dir).unwrap();
    let c = dir.join("libcuda.c");
    std::fs::write(&c, source).unwrap();
    match Command::new("cc")
        .args(["-shared", "-fPIC", "-o"])
        .arg(dir.join("libcuda.so"))
        .arg(&c)
        .output()
    {
        Ok(o) => {
            assert!(
                o.status.success(),
                "cc: {}",
                String::from_utf8_lossy(&o.stderr)
            );
            true
        }
        Err(e) => {
            eprintln!("skipping: no C compiler to build a libcuda.so (cc: {e})");
            false
        }
    }
}

/// `dir` first on the library path, the rest (LibTorch's torch/lib) kept.
fn library_path(dir: &Path) -> Vec<(&'static str, String)> {
    let rest = std::env::var("LD_LIBRARY_PATH").unwrap_or_default();
    vec![("LD_LIBRARY_PATH", format!("{}:{rest}", dir.display()))]
}

#[test]
fn a_machine_without_a_working_driver_is_one_line() {
    let devices = gpu_devices();
    if devices.is_empty() {
        println!("SKIPPED: this build has no GPU engine (--features cuda or tch)");
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let stub = dir.path().join("stub");
    if !libcuda(
        &stub,
        "int cuInit(unsigned f) { (void)f; return 34; }\n\
         int cuDeviceGetCount(int *n) { *n = 0; return 34; }\n\
         int cuDriverGetVersion(int *v) { *v = 0; return 34; }\n",
    ) {
        return;
    }
    let empty = dir.path().join("empty");
    assert!(libcuda(&empty, "int unrelated(void) { return 0; }\n"));
    let one = dir.path().join("one");
    assert!(libcuda(
        &one,
        "int cuInit(unsigned f) { (void)f; return 0; }\n\
         int cuDeviceGetCount(int *n) { *n = 1; return 0; }\n\
         int cuDriverGetVersion(int *v) { *v = 12040; return 0; }\n",
    ));
    for device in devices {
        let stub_file = stub.join("libcuda.so").display().to_string();
        refused_everywhere(
            device,
            &library_path(&stub),
            &["stub library", &stub_file, "LD_LIBRARY_PATH"],
        );
        refused_everywhere(
            device,
            &library_path(&empty),
            &["is not the NVIDIA driver", "LD_LIBRARY_PATH"],
        );
        let third = format!("{device}:3");
        refused_everywhere(
            &third,
            &library_path(&one),
            &["there is no GPU 3", "sees 1", "use index 0"],
        );
        let has_driver = Path::new("/dev/nvidiactl").exists()
            || Command::new("ldconfig")
                .arg("-p")
                .output()
                .is_ok_and(|o| String::from_utf8_lossy(&o.stdout).contains("libcuda.so"));
        if has_driver {
            println!("SKIPPED (no driver): this machine has an NVIDIA driver");
        } else {
            refused_everywhere(device, &[], &["no NVIDIA driver", "--device cpu"]);
        }
    }
}
