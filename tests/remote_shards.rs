//! End to end: `pl2map train --shards` and `pl2map score --shards` from the tiny
//! synthetic scene's shards served by a real S3 server (s3s-fs, scripts/setup-s3.sh) and
//! by Python's http.server, both started here on 127.0.0.1, give the same bytes as from
//! the local folder: model.ckpt for train, summary.json for score. Each server that
//! cannot be started is skipped, saying why. (An integration test of the `cli` package,
//! which builds the binary.)

#[path = "../crates/remote/tests/support/mod.rs"]
mod support;

use std::path::{Path, PathBuf};
use std::process::Command;
use testkit::process::ok;

fn pl2map() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_pl2map"));
    c.arg("--quiet");
    c
}

/// A short training run: the comparison needs the same bytes, not a good model.
const TRAIN: &str = "iterations = 4\ncheckpoint_every = 2\nseed = 0\n";

fn train(shards: &str, out: &Path, config: &Path, env: &[(String, String)]) -> Vec<u8> {
    let stdout = ok(
        pl2map()
            .args(["train", "--shards", shards, "--out"])
            .arg(out)
            .arg("--config")
            .arg(config)
            .envs(env.iter().map(|(k, v)| (k, v)))
            .output()
            .unwrap(),
        &format!("train --shards {shards}"),
    );
    if shards.contains("://") {
        assert!(
            stdout.contains(&format!("shards: {shards} -> ")),
            "{stdout}"
        );
    }
    std::fs::read(out.join("model.ckpt")).unwrap()
}

fn score_oracle(shards: &str, out: &Path, env: &[(String, String)]) -> Vec<u8> {
    ok(
        pl2map()
            .args(["score", "--oracle", "--shards", shards, "--out"])
            .arg(out)
            .envs(env.iter().map(|(k, v)| (k, v)))
            .output()
            .unwrap(),
        &format!("score --shards {shards}"),
    );
    std::fs::read(out.join("summary.json")).unwrap()
}

#[test]
fn training_from_s3_and_http_gives_the_local_model() {
    let tmp = tempfile::tempdir().unwrap();
    let root = tmp.path();
    let pipeline =
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../pipeline/synthetic-tiny.toml");
    let work = root.join("work");
    ok(
        pl2map()
            .arg("run")
            .arg(&pipeline)
            .arg("--work")
            .arg(&work)
            .args(["--until", "shard"])
            .output()
            .unwrap(),
        "run --until shard",
    );
    let local = work.join("shard");
    assert!(
        local.join("manifest.json").is_file(),
        "no shards in {}",
        local.display()
    );
    let config = root.join("train.toml");
    std::fs::write(&config, TRAIN).unwrap();
    let local_model = train(
        local.to_str().unwrap(),
        &root.join("train-local"),
        &config,
        &[],
    );
    let local_summary = score_oracle(local.to_str().unwrap(), &root.join("score-local"), &[]);
    let cache = root.join("cache");
    let cache_env = vec![
        (
            "PL2MAP_SHARD_CACHE".to_string(),
            cache.display().to_string(),
        ),
        ("PL2MAP_SHARD_RETRIES".to_string(), "2".to_string()),
    ];
    let mut served = 0;

    match support::start_s3(root, "sets") {
        Err(why) => eprintln!("skipping the S3 half: {why}"),
        Ok(s3) => {
            support::upload_s3(&s3, "sets", "synthetic-tiny", &local);
            let env: Vec<(String, String)> = support::s3_env(&s3)
                .into_iter()
                .chain(cache_env.clone())
                .collect();
            let url = "s3://sets/synthetic-tiny";
            let model = train(url, &root.join("train-s3"), &config, &env);
            assert!(
                model == local_model,
                "model.ckpt from {url} differs from the local one"
            );
            let summary = score_oracle(url, &root.join("score-s3"), &env);
            assert!(summary == local_summary, "summary.json from {url} differs");
            served += 1;
        }
    }

    match support::start_http(root) {
        Err(why) => eprintln!("skipping the HTTP half: {why}"),
        Ok(http) => {
            support::publish_http(&http, "sets/synthetic-tiny", &local);
            let url = format!("http://127.0.0.1:{}/sets/synthetic-tiny", http.port);
            let model = train(&url, &root.join("train-http"), &config, &cache_env);
            assert!(
                model == local_model,
                "model.ckpt from {url} differs from the local one"
            );
            // The second command reads the cache: only manifest.json and stage.json again.
            score_oracle(&url, &root.join("score-http"), &cache_env);
            let manifest = shards::Manifest::load(local.join("manifest.json")).unwrap();
            let files = manifest.shards.iter().map(|s| (s.file.as_str(), 1));
            for (f, expected) in files.chain([("manifest.json", 2), ("stage.json", 2)]) {
                let gets = support::http_gets(&http, &format!("/sets/synthetic-tiny/{f}"));
                assert_eq!(gets, expected, "{f}: {}", http.log_text());
            }
            served += 1;
        }
    }
    eprintln!("{served} of 2 servers compared with the local folder");
}
