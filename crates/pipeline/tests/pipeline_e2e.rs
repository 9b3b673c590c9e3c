//! The tiny synthetic pipeline end to end through the library: a second run skips every
//! stage, a changed `[refine]` reruns refine and shard only, the committed lock file
//! `manifests/synthetic-tiny.toml` verifies (the CI check of issue 7) and a tampered one
//! fails naming the shard.

use pipeline::{Lock, Pipeline, RunOptions, Status, lock, run};
use std::path::{Path, PathBuf};

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn tiny_pipeline() -> PathBuf {
    repo().join("pipeline/synthetic-tiny.toml")
}

fn committed_manifest() -> PathBuf {
    repo().join("manifests/synthetic-tiny.toml")
}

fn quiet() -> RunOptions {
    RunOptions {
        until: Some("shard".into()),
        progress: false,
    }
}

fn statuses(report: &pipeline::RunReport) -> Vec<(&'static str, Status)> {
    report
        .stages
        .iter()
        .take(5)
        .map(|s| (s.stage, s.status.clone()))
        .collect()
}

#[test]
fn reruns_only_what_a_change_affects_and_tampering_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let work = dir.path().join("work");
    let p = Pipeline::load_with_work(&tiny_pipeline(), Some(work.clone())).unwrap();
    let stages = ["synth", "ingest", "import", "refine", "shard"];

    let first = run(&p, &quiet()).unwrap();
    assert_eq!(
        statuses(&first),
        stages.map(|s| (s, Status::Ran)).to_vec(),
        "{}",
        first.table()
    );
    let second = run(&p, &quiet()).unwrap();
    assert_eq!(
        statuses(&second),
        stages.map(|s| (s, Status::Skipped)).to_vec(),
        "{}",
        second.table()
    );

    // This folder's shards are the committed lock's: same inputs, config and hashes.
    let (committed, _) = Lock::read(&committed_manifest()).unwrap();
    let built = Lock::collect(&p).unwrap();
    // The lock was made from this recipe (it has not drifted from pipeline/).
    assert_eq!(committed.pipeline, built.pipeline);
    let report = lock::compare(&committed_manifest(), &committed, &built);
    report
        .check()
        .unwrap_or_else(|e| panic!("{e}\n{}", report.table()));

    // A tampered lock, verified against this (up-to-date) folder: every stage skips
    // and the difference names the shard.
    let mut text = std::fs::read_to_string(committed_manifest()).unwrap();
    let sha = &committed.shards[0].sha256;
    assert_eq!(committed.shards[0].file, "train-00000.mcap");
    text = text.replace(sha.as_str(), &"0".repeat(64));
    let tampered = dir.path().join("tampered.toml");
    std::fs::write(&tampered, text).unwrap();
    let report = pipeline::verify(&tampered, Some(&work), false).unwrap();
    let err = report.check().unwrap_err().to_string();
    assert!(err.contains("1 difference(s)"), "{err}");
    assert!(
        err.contains("shard train-00000.mcap: expected 0000"),
        "{err}"
    );
    assert!(err.contains(&format!("got {sha}")), "{err}");
    assert!(report.table().contains("DIFFERS"));

    // Stages skip by content: a refine section that yields the same labels (the
    // points are all within 1 cm of their median here) reruns refine only ...
    let text = std::fs::read_to_string(tiny_pipeline()).unwrap();
    assert!(text.contains("[refine]\n"));
    let with_threshold = |m: f64| {
        let path = dir.path().join(format!("changed-{m}.toml"));
        let t = text.replace(
            "[refine]\n",
            &format!("[refine]\npoint_inlier_threshold_m = {m}\n"),
        );
        std::fs::write(&path, t).unwrap();
        Pipeline::load_with_work(&path, Some(work.clone())).unwrap()
    };
    let same_labels = run(&with_threshold(0.01), &quiet()).unwrap();
    let expect = |refine, shard| {
        vec![
            ("synth", Status::Skipped),
            ("ingest", Status::Skipped),
            ("import", Status::Skipped),
            ("refine", refine),
            ("shard", shard),
        ]
    };
    assert_eq!(
        statuses(&same_labels),
        expect(Status::Ran, Status::Skipped),
        "{}",
        same_labels.table()
    );
    // ... while a 1 mm threshold drops point labels: refine and shard rerun; the scene,
    // the frames table and the imported labels are kept.
    let p2 = with_threshold(0.001);
    let third = run(&p2, &quiet()).unwrap();
    assert_eq!(
        statuses(&third),
        expect(Status::Ran, Status::Ran),
        "{}",
        third.table()
    );
    let rebuilt = Lock::collect(&p2).unwrap();
    assert_ne!(rebuilt.shards[0].sha256, built.shards[0].sha256);
    assert_eq!(rebuilt.inputs, built.inputs);
}

#[test]
fn committed_tiny_manifest_verifies() {
    let report = pipeline::verify(&committed_manifest(), None, false).unwrap();
    report
        .check()
        .unwrap_or_else(|e| panic!("{e}\n{}", report.table()));
    assert!(report.rows.iter().any(|r| r.kind == "shard"));
    assert!(report.rows.iter().any(|r| r.kind == "input"));
}

#[test]
fn train_and_score_run_once_then_skip() {
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(tiny_pipeline()).unwrap();
    // A few iterations: this checks the stage records, not the model.
    let recipe = "iterations = 100\ncheckpoint_every = 50\n";
    assert!(text.contains(recipe));
    let text = text.replace(recipe, "iterations = 4\ncheckpoint_every = 2\n");
    let path = dir.path().join("p.toml");
    std::fs::write(&path, text).unwrap();
    let p = Pipeline::load_with_work(&path, Some(dir.path().join("w"))).unwrap();
    let all = RunOptions {
        until: None,
        progress: false,
    };
    let first = run(&p, &all).unwrap();
    assert!(
        first.stages.iter().all(|s| s.status == Status::Ran),
        "{}",
        first.table()
    );
    assert!(p.work.join("train/model.ckpt").is_file());
    assert!(p.work.join("score/summary.md").is_file());
    let second = run(&p, &all).unwrap();
    assert!(
        second.stages.iter().all(|s| s.status == Status::Skipped),
        "{}",
        second.table()
    );
    let bad = run(
        &p,
        &RunOptions {
            until: Some("nope".into()),
            progress: false,
        },
    );
    assert!(
        bad.unwrap_err()
            .to_string()
            .contains("unknown stage \"nope\"")
    );
}

#[test]
fn committed_pipeline_files_resolve() {
    // SAFETY: no other test of this binary reads these variables.
    unsafe {
        for (k, v) in [
            ("PL2MAP_WORK", "/w"),
            ("PL2MAP_7SCENES", "/data/7scenes"),
            ("PL2MAP_7SCENES_DEPTH", "/data/depth"),
            ("PL2MAP_CAMBRIDGE", "/data/cambridge"),
            ("PL2MAP_HLOC", "/out/hloc"),
            ("PL2MAP_LIMAP", "/out/limap"),
        ] {
            std::env::set_var(k, v);
        }
    }
    let dir = repo().join("pipeline");
    let s = Pipeline::load(&dir.join("7scenes.toml")).unwrap();
    assert_eq!(s.ingest.scene_dir(), PathBuf::from("/data/7scenes/stairs"));
    assert_eq!(s.work, PathBuf::from("/w/7scenes-stairs"));
    assert_eq!(s.limap, PathBuf::from("/out/limap/stairs"));
    assert!(s.refine.is_some() && s.synth.is_none());
    let c = Pipeline::load(&dir.join("cambridge.toml")).unwrap();
    assert_eq!(c.ingest.dataset, datasets::ingest::DatasetKind::Cambridge);
    assert_eq!(c.import.segment_scale, 1.2);
    assert!(c.refine.is_none());
    let d = Pipeline::load(&dir.join("synthetic.toml")).unwrap();
    let synth = d.synth.as_ref().unwrap();
    assert!(!synth.tiny && synth.frames == 300 && d.refine.is_some());
    assert!(d.file.train.is_some() && d.file.score.is_some());
    let t = Pipeline::load(&tiny_pipeline()).unwrap();
    assert!(t.synth.as_ref().unwrap().tiny);
}
