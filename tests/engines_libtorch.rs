//! The LibTorch engine (`--features tch`) on LibTorch's CPU device, against Flex:
//!
//! - `bench::engines` (crates/bench/src/engines.rs): predictions, the line encoder,
//!   loss terms, every parameter's gradient and five training steps in one and two
//!   gradient groups, for the transformer-only and the graph network, within its
//!   bounds (forward 2e-3, losses and gradients 5e-3, after five steps 3e-2, as
//!   max |a - b| / (1 + |b|); measured: docs/performance.md, "The LibTorch engine and
//!   the GPU check");
//! - the tiny synthetic scene trained for 300 steps with `pl2map run --device
//!   libtorch:cpu`: the map loss falls (by 5 %, as on Flex), and the checkpoint loads on Flex and predicts
//!   what LibTorch predicts, within 1e-4.
//!
//! Build and run: `eval "$(scripts/libtorch-env.sh)" && cargo test -p cli --features tch
//! --release --locked --test engines_libtorch`.

use std::path::{Path, PathBuf};
use std::process::Command;
use testkit::process::ok;

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

#[test]
fn libtorch_cpu_agrees_with_flex() {
    let a = bench::engines::check_agreement(train::Device::LibTorchCpu).unwrap();
    print!("{a}");
    assert!(a.passed(), "{a}");
    assert_eq!(a.comparisons.len(), 12, "{a}");
}

/// Mean of column `name` over `rows` of metrics.csv.
fn mean(rows: &[Vec<String>], header: &[String], name: &str) -> f64 {
    let i = header.iter().position(|h| h == name).unwrap();
    rows.iter()
        .map(|r| r[i].parse::<f64>().unwrap())
        .sum::<f64>()
        / rows.len() as f64
}

#[test]
fn the_tiny_scene_learns_on_libtorch_and_its_checkpoint_predicts_the_same_on_flex() {
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(repo().join("pipeline/synthetic-tiny.toml"))
        .unwrap()
        .replace("iterations = 100", "iterations = 300")
        .replace("checkpoint_every = 50", "checkpoint_every = 300");
    assert!(text.contains("iterations = 300"));
    let file = dir.path().join("tiny.toml");
    std::fs::write(&file, text).unwrap();
    let work = dir.path().join("work");
    let started = std::time::Instant::now();
    ok(
        Command::new(env!("CARGO_BIN_EXE_pl2map"))
            .args([
                "run",
                "--quiet",
                "--until",
                "train",
                "--device",
                "libtorch:cpu",
                "--work",
            ])
            .arg(&work)
            .arg(&file)
            .output()
            .unwrap(),
        "pl2map run --device libtorch:cpu",
    );
    eprintln!(
        "synth, data stages and 300 LibTorch steps: {:.0?}",
        started.elapsed()
    );
    let train_dir = std::fs::read_dir(&work)
        .unwrap()
        .filter_map(|e| e.ok().map(|e| e.path()))
        .find(|p| p.join("model.ckpt").exists())
        .unwrap_or_else(|| panic!("no model.ckpt under {}", work.display()));

    // The loss falls clearly: the last 50 steps' mean well under the first 50's.
    let csv = std::fs::read_to_string(train_dir.join("metrics.csv")).unwrap();
    let mut lines = csv
        .lines()
        .map(|l| l.split(',').map(str::to_string).collect::<Vec<_>>());
    let header = lines.next().unwrap();
    let rows: Vec<Vec<String>> = lines.collect();
    assert_eq!(rows.len(), 300);
    // The map loss (points + lines): the reliability terms start near their floor. The
    // tiny recipe (learning rate 3e-4, decaying) moves slowly: 1535.7 -> 1460.3 here,
    // 1535.7 -> 1462.3 on Flex (`--device cpu`, the same command; 2026-12-06).
    let map = |r: &[Vec<String>]| mean(r, &header, "map_points") + mean(r, &header, "map_lines");
    let (first, last) = (map(&rows[..50]), map(&rows[250..]));
    let (total_first, total_last) = (
        mean(&rows[..50], &header, "total"),
        mean(&rows[250..], &header, "total"),
    );
    eprintln!(
        "mean map loss: steps 1-50 {first:.4}, steps 251-300 {last:.4}; total {total_first:.4} -> {total_last:.4}"
    );
    assert!(last < 0.97 * first, "map loss {first} -> {last}");

    // The checkpoint on both engines: the same predictions within 1e-4.
    let ck = train::checkpoint::CheckpointFile::read(&train_dir.join("model.ckpt")).unwrap();
    let flex = ck.model::<model::CpuBackend>(&Default::default()).unwrap();
    let torch = ck
        .model::<model::LibTorchBackend>(&train::Device::LibTorchCpu.libtorch())
        .unwrap();
    let cfg = &ck.header.config.model;
    let sample = bench::step::synthetic_sample(cfg, 64, 8, 5);
    let predict = |p: model::HostPrediction| model::testing::flat(&p);
    let a = predict(
        flex.predict(&sample.point_descriptors, &sample.line_descriptors)
            .unwrap(),
    );
    let b = predict(
        torch
            .predict(&sample.point_descriptors, &sample.line_descriptors)
            .unwrap(),
    );
    assert_eq!(a.len(), b.len());
    let worst = a
        .iter()
        .zip(&b)
        .map(|(x, y)| (x - y).abs() / (1.0 + x.abs()))
        .fold(0.0f32, f32::max);
    eprintln!(
        "checkpoint on Flex and LibTorch: max rel. difference {worst:.2e} over {} values",
        a.len()
    );
    assert!(worst < 1e-4, "{worst}");
}
