//! `--device`: in a build without the `cuda` feature, every command that runs the network
//! refuses a CUDA device with one error saying how to build one, before it writes
//! anything; a misspelt device is refused with the spellings that work.

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

fn refused(out: Output, what: &str) -> String {
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(!out.status.success(), "{what} succeeded: {stderr}");
    assert!(!stderr.contains("panicked"), "{what} panicked: {stderr}");
    stderr
}

fn assert_says_how_to_build(stderr: &str, device: &str) {
    assert!(
        stderr.contains(&format!("device {device}"))
            && stderr.contains("built without CUDA")
            && stderr.contains("cargo build --release --locked -p cli --features cuda"),
        "{stderr}"
    );
}

#[test]
fn cuda_in_a_cpu_build_is_one_clear_error() {
    if cfg!(feature = "cuda") {
        println!("SKIPPED: this build has the cuda feature");
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let work = dir.path().join("work");
    let pipeline = repo().join("pipeline/synthetic-tiny.toml");

    // `pl2map run --device`: refused before any stage runs.
    let args = ["run", "--quiet", "--device", "cuda:1", "--work"];
    let out = bin().args(args).arg(&work).arg(&pipeline).output().unwrap();
    assert_says_how_to_build(&refused(out, "run --device cuda:1"), "cuda:1");
    assert!(!work.exists(), "the refused run made {}", work.display());

    // `[train] device` in the file: refused at load, naming the file.
    let text = std::fs::read_to_string(&pipeline)
        .unwrap()
        .replace("[train]\n", "[train]\ndevice = \"cuda\"\n");
    let file = dir.path().join("cuda.toml");
    std::fs::write(&file, text).unwrap();
    let out = bin()
        .args(["run", "--quiet", "--work"])
        .arg(&work)
        .arg(&file)
        .output()
        .unwrap();
    let stderr = refused(out, "[train] device = cuda");
    assert_says_how_to_build(&stderr, "cuda:0");
    assert!(stderr.contains("cuda.toml"), "{stderr}");
    assert!(!work.exists());

    // `pl2map train` and `pl2map score`.
    let out_dir = dir.path().join("model");
    let out = bin()
        .args(["train", "--device", "cuda", "--shards"])
        .arg(dir.path())
        .arg("--out")
        .arg(&out_dir)
        .output()
        .unwrap();
    assert_says_how_to_build(&refused(out, "train --device cuda"), "cuda:0");
    assert!(!out_dir.exists());
    let out = bin()
        .args(["score", "--device", "cuda", "--shards"])
        .arg(dir.path())
        .arg("--checkpoint")
        .arg(dir.path().join("model.ckpt"))
        .arg("--out")
        .arg(dir.path().join("score"))
        .output()
        .unwrap();
    assert_says_how_to_build(&refused(out, "score --device cuda"), "cuda:0");
}

#[test]
fn a_misspelt_device_names_the_spellings() {
    let dir = tempfile::tempdir().unwrap();
    let out = bin()
        .args(["train", "--device", "gpu0", "--shards"])
        .arg(dir.path())
        .arg("--out")
        .arg(dir.path().join("o"))
        .output()
        .unwrap();
    let stderr = refused(out, "--device gpu0");
    assert!(
        stderr.contains("cpu, cuda or cuda:N") && stderr.contains("gpu0"),
        "{stderr}"
    );
}
