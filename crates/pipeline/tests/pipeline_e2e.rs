//! The tiny synthetic pipeline end to end through the library: a second run skips every
//! stage, a changed `[refine]` reruns refine and shard only, the committed lock file
//! `manifests/synthetic-tiny.toml` verifies (a CI check: README.md, "Pipelines and datasets") and a tampered one
//! fails naming the shard.

use pipeline::{Lock, Pipeline, RunOptions, StageName, Status, lock, run};
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
        until: Some(StageName::Shard),
        progress: false,
        ..Default::default()
    }
}

fn statuses(report: &pipeline::RunReport) -> Vec<(StageName, Status)> {
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
    let stages = [
        StageName::Synth,
        StageName::Ingest,
        StageName::Import,
        StageName::Refine,
        StageName::Shard,
    ];

    let first = run(&p, &quiet()).unwrap();
    assert!(first.score.is_none(), "--until shard has no score");
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
            (StageName::Synth, Status::Skipped),
            (StageName::Ingest, Status::Skipped),
            (StageName::Import, Status::Skipped),
            (StageName::Refine, refine),
            (StageName::Shard, shard),
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
        ..Default::default()
    };
    let first = run(&p, &all).unwrap();
    assert!(
        first.stages.iter().all(|s| s.status == Status::Ran),
        "{}",
        first.table()
    );
    assert!(p.work.join("train/model.ckpt").is_file());
    assert!(p.work.join("score/summary.md").is_file());
    // The report carries the score stage's summary (what `pl2map run` prints): both
    // variants, the rows of the summary file the stage wrote.
    let written = std::fs::read_to_string(p.work.join("score/summary.md")).unwrap();
    let score = first
        .score
        .as_ref()
        .expect("a run through score has its summary");
    let labels: Vec<&str> = score.variants.iter().map(|v| v.variant.label()).collect();
    assert_eq!(labels, ["points", "points + lines"]);
    assert!(written.contains(&score.table()), "{}", score.table());
    let second = run(&p, &all).unwrap();
    assert!(
        second.stages.iter().all(|s| s.status == Status::Skipped),
        "{}",
        second.table()
    );
    // Up to date: the same summary, read back from the stage's record.
    assert_eq!(
        second.score.as_ref().map(|s| s.table()),
        Some(score.table())
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
            ("PL2MAP_SUPERPOINT_WEIGHTS", "/weights/superpoint_v1.pth"),
        ] {
            std::env::set_var(k, v);
        }
    }
    let dir = repo().join("pipeline");
    let s = Pipeline::load(&dir.join("7scenes.toml")).unwrap();
    assert_eq!(s.ingest.scene_dir(), PathBuf::from("/data/7scenes/stairs"));
    assert_eq!(s.work, PathBuf::from("/w/7scenes-stairs"));
    assert_eq!(s.import.limap, Some(PathBuf::from("/out/limap/stairs")));
    assert!(s.refine().is_some() && s.synth().is_none());
    // A work unit of another scene: ${SCENE} follows --scene everywhere.
    let chess = Pipeline::load_unit(&dir.join("7scenes.toml"), None, Some("chess")).unwrap();
    assert_eq!(
        chess.ingest.scene_dir(),
        PathBuf::from("/data/7scenes/chess")
    );
    assert_eq!(chess.work, PathBuf::from("/w/7scenes-chess"));
    assert_eq!(
        chess.import.model,
        Some(PathBuf::from("/out/hloc/chess/sfm_superpoint+superglue"))
    );
    assert_eq!(chess.import.limap, Some(PathBuf::from("/out/limap/chess")));
    assert_eq!(
        chess.ingest.depth,
        datasets::ingest::DepthOption::Rendered(PathBuf::from(
            "/data/depth/7scenes_chess/train/depth"
        ))
    );
    let err = Pipeline::load_unit(&tiny_pipeline(), None, Some("chess")).unwrap_err();
    assert!(err.to_string().contains("[synth]"), "{err}");
    let err = Pipeline::load_unit(&dir.join("7scenes.toml"), None, Some("../x")).unwrap_err();
    assert!(err.to_string().contains("plain folder name"), "{err}");
    let kings = Pipeline::load(&dir.join("cambridge.toml")).unwrap();
    assert_eq!(kings.work, PathBuf::from("/w/cambridge-KingsCollege"));
    let c = Pipeline::load(&dir.join("cambridge.toml")).unwrap();
    assert_eq!(
        c.ingest.dataset,
        Some(datasets::ingest::DatasetKind::Cambridge)
    );
    assert_eq!(c.import.segment_scale, 1.2);
    assert!(c.refine().is_none());
    let d = Pipeline::load(&dir.join("synthetic.toml")).unwrap();
    let synth = d.synth().unwrap();
    assert!(!synth.tiny && synth.frames == 300 && d.refine().is_some());
    assert!(d.file.train.is_some() && d.file.score.is_some());
    // The main job's deep heads start He-initialised (docs/training-notes.md, "Head
    // initialisation"); the paper's recipes below keep the reference's initialisation.
    let main_train = d.file.train.as_ref().unwrap();
    assert!(!main_train.model.head_init.is_reference());
    let t = Pipeline::load(&tiny_pipeline()).unwrap();
    assert!(t.synth().unwrap().tiny);
    // The reference's graph network on the main job's data: the same data sections.
    let g = Pipeline::load(&dir.join("synthetic-paper.toml")).unwrap();
    assert_eq!(g.file.synth, d.file.synth);
    assert_eq!(g.file.refine, d.file.refine);
    assert_eq!(g.file.shard, d.file.shard);
    let gt = g.file.train.as_ref().unwrap();
    assert_eq!(gt.model.layers.len(), 5);
    assert_eq!(gt.model.head_hidden, vec![512, 1024, 512]);
    assert_eq!(gt.iterations, 30_000);
    assert!(gt.model.head_init.is_reference());
    // The paper's recipes: SuperPoint at D = 256, the graph network, alltracks, the
    // reference's schedule and reprojection scale per dataset.
    for (file, tau_max, learning_rate, iterations) in [
        ("7scenes-paper.toml", 50.0, 3e-4, 1_500_000),
        ("cambridge-paper.toml", 100.0, 1e-4, 1_000_000),
    ] {
        let p = Pipeline::load_unit(&dir.join(file), None, Some("chess")).unwrap();
        let train = p.file.train.as_ref().unwrap();
        assert_eq!(
            train.front_end.kind,
            features::FrontEndKind::Superpoint,
            "{file}"
        );
        assert_eq!(
            train.front_end.superpoint.weights,
            Some(PathBuf::from("/weights/superpoint_v1.pth"))
        );
        assert_eq!(train.model.descriptor_dim, 256, "{file}");
        assert_eq!(train.model.layers.len(), 5, "{file}");
        assert!(train.model.head_init.is_reference(), "{file}");
        assert_eq!(train.loss.tau_max, tau_max, "{file}");
        assert_eq!(train.learning_rate, learning_rate, "{file}");
        assert_eq!(train.iterations, iterations, "{file}");
        assert_eq!(train.batch_frames, 1, "{file}");
        assert_eq!(
            p.import.line_tracks,
            labels::import::LineTrackSet::Alltracks,
            "{file}"
        );
        let score = p.file.score.as_ref().unwrap();
        assert_eq!(
            (score.point_threshold_px, score.line_threshold_px),
            (12.0, 10.0)
        );
    }
}

/// `--shards` work units of the shard stage through `pl2map run`: the unit that completes
/// the set writes the manifest a single run writes, and the stages after the shards
/// wait for it.
#[test]
fn shard_work_units_through_run() {
    let dir = tempfile::tempdir().unwrap();
    let units = Pipeline::load_with_work(&tiny_pipeline(), Some(dir.path().join("w"))).unwrap();
    run(
        &units,
        &RunOptions {
            until: Some(StageName::Refine),
            ..RunOptions::default()
        },
    )
    .unwrap();
    let unit = |r: std::ops::Range<usize>| {
        let report = run(
            &units,
            &RunOptions {
                shards: Some(r),
                ..RunOptions::default()
            },
        )
        .unwrap();
        let shard = report
            .stages
            .iter()
            .find(|s| s.stage == StageName::Shard)
            .unwrap();
        assert_eq!(shard.status, Status::Ran, "{}", report.table());
        assert!(matches!(
            report.status(StageName::Train),
            Some(Status::Off(_))
        ));
        shard.note.clone()
    };
    // The tiny scene has one training and one test shard.
    assert!(unit(1..2).contains("other units pending"));
    assert!(
        !units
            .stage_dir(StageName::Shard)
            .join("manifest.json")
            .exists()
    );
    assert!(unit(0..1).contains("the set is complete"));
    let manifest = units.stage_dir(StageName::Shard).join("manifest.json");
    let merged = std::fs::read(&manifest).unwrap();
    // One run over the whole plan, from the same inputs (the frames table holds the
    // work folder's paths, so the comparison stays in one folder).
    std::fs::remove_dir_all(units.stage_dir(StageName::Shard)).unwrap();
    let whole = run(&units, &quiet()).unwrap();
    assert_eq!(whole.status(StageName::Shard), Some(&Status::Ran));
    assert_eq!(std::fs::read(&manifest).unwrap(), merged);
}

/// `--compare-refine`: the pipeline with and without `[refine]` side by side; the data
/// stages are shared, the variant's shards differ (other labels).
#[test]
fn label_ablation_in_one_run() {
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(tiny_pipeline()).unwrap();
    let recipe = "iterations = 100\ncheckpoint_every = 50\n";
    let text = text.replace(recipe, "iterations = 3\ncheckpoint_every = 3\n");
    let path = dir.path().join("p.toml");
    std::fs::write(&path, format!("{text}max_iterations = 300\n")).unwrap();
    let p = Pipeline::load_with_work(&path, Some(dir.path().join("w"))).unwrap();
    let a = pipeline::run_compare_refine(&p, &RunOptions::default()).unwrap();
    assert_eq!(a.imported.status(StageName::Import), Some(&Status::Skipped));
    assert!(matches!(
        a.imported.status(StageName::Refine),
        Some(Status::Off(_))
    ));
    let imported = p.work.join("without-refine");
    for stage in ["shard", "train", "score"] {
        assert!(imported.join(stage).join("stage.json").is_file(), "{stage}");
    }
    let manifest = |d: &Path| std::fs::read(d.join("shard/manifest.json")).unwrap();
    assert_ne!(manifest(&p.work), manifest(&imported));
    let table = a.table();
    assert_eq!(
        table
            .lines()
            .filter(|l| l.starts_with("| refined |"))
            .count(),
        2,
        "{table}"
    );
    assert_eq!(
        table
            .lines()
            .filter(|l| l.starts_with("| as imported |"))
            .count(),
        2,
        "{table}"
    );
    assert!(table.contains("5 cm 5 deg"), "{table}");
    // Without [refine] there is nothing to compare.
    let err =
        pipeline::run_compare_refine(&p.without_refine(), &RunOptions::default()).unwrap_err();
    assert!(err.to_string().contains("needs [refine]"), "{err}");
}
