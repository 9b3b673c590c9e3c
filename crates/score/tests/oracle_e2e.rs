//! End to end on the tiny synthetic scene, through the stage libraries (the same calls
//! as `pl2map synth --tiny`, `ingest --depth rendered:...`, `import` of the scene's
//! `sfm_gt`, `shard`): the oracle's poses must be accurate (the labels are exact) and a
//! rerun must write the same bytes.

use datasets::ingest::{DatasetKind, DepthOption, IngestConfig};
use datasets::ingest_stage;
use labels::import::{self, ImportConfig};
use labels::import_stage;
use score::scoring::{PER_FRAME_FILE, PLOT_FILE, SUMMARY_JSON_FILE, SUMMARY_MD_FILE, results_file};
use score::{OracleLocaliser, ScoreConfig, ScoreError, Variant};
use shards::shard_stage::{self, ShardStageConfig};
use std::path::{Path, PathBuf};
use synth::generate_tiny;
use tables::parquet::polars::prelude::*;

/// synth -> ingest -> import -> shard; returns the shard folder.
fn prepare(root: &Path) -> PathBuf {
    let synth = generate_tiny(&root.join("data")).expect("synth");
    let scene = synth.root.clone();
    let mut ic = IngestConfig::new(DatasetKind::SevenScenes, &scene);
    ic.depth = DepthOption::Rendered(scene.clone());
    let frames = ingest_stage::run(&ic, &root.join("frames"))
        .expect("ingest")
        .output
        .frames_path;
    let gt = scene.join(synth::gt::GT_DIR);
    let imports = ImportConfig {
        model: Some(gt.join("colmap")),
        limap: Some(gt.join("limap")),
        ..ImportConfig::default()
    };
    import_stage::run(&imports, &frames, &root.join("labels"), &import::sift_only).expect("import");
    let shards = root.join("shards");
    // Several shards per split, so the reader crosses shard boundaries.
    let sc = ShardStageConfig {
        frames_per_shard: 10,
        ..ShardStageConfig::default()
    };
    shard_stage::run(&sc, &frames, &root.join("labels"), &shards, None).expect("shard");
    shards
}

fn read_table(path: &Path) -> DataFrame {
    ParquetReader::new(std::fs::File::open(path).unwrap())
        .finish()
        .unwrap()
}

fn f64s(df: &DataFrame, name: &str) -> Vec<Option<f64>> {
    df.column(name).unwrap().f64().unwrap().iter().collect()
}

#[test]
fn oracle_poses_are_accurate_and_outputs_repeat() {
    let dir = tempfile::tempdir().unwrap();
    let shards = prepare(dir.path());
    let config = ScoreConfig::default();
    let out_a = dir.path().join("score_a");
    let a = score::score_shards(&shards, &out_a, &mut OracleLocaliser, &config).expect("score");

    let s = &a.summary;
    assert_eq!(s.split, "train");
    assert!(s.source.contains("oracle"));
    let (p, pl) = (&s.variants[0], &s.variants[1]);
    assert_eq!(
        (p.variant, pl.variant),
        (Variant::Points, Variant::PointsLines)
    );
    // The tiny scene has 24 training frames, every one labelled.
    assert_eq!(p.frames, 24);
    assert_eq!(a.results.len(), 24);
    let under_1cm_1deg = |v: &score::summary::VariantSummary| v.accuracy[0].fraction;
    println!("{}", s.markdown());
    assert!(
        under_1cm_1deg(p) >= 0.95,
        "points: {:.3} under 1 cm / 1 deg",
        under_1cm_1deg(p)
    );
    assert!(
        under_1cm_1deg(pl) >= under_1cm_1deg(p),
        "points + lines ({:.3}) worse than points ({:.3})",
        under_1cm_1deg(pl),
        under_1cm_1deg(p)
    );
    // Exact labels: the errors are those of the solvers and the refinement.
    assert!(p.median_cm < 0.1 && p.median_deg < 0.1, "{p:?}");
    assert!(pl.median_cm < 0.1 && pl.median_deg < 0.1, "{pl:?}");
    for r in &a.results {
        assert!(r.points_kept > 0 && r.lines_kept > 0, "frame {}", r.name);
        assert!(
            r.variant(Variant::PointsLines).line_inliers > 0,
            "frame {}",
            r.name
        );
    }

    // Outputs: one hloc line per localised frame, a table row per frame.
    for v in Variant::ALL {
        let entries = score::hloc::read_results(&out_a.join(results_file(v))).unwrap();
        let localised = a.results.iter().filter(|r| r.variant(v).pose.is_some());
        assert_eq!(entries.len(), localised.clone().count());
        for (e, r) in entries.iter().zip(localised) {
            assert_eq!(e.name, r.name);
        }
    }
    let df = read_table(&out_a.join(PER_FRAME_FILE));
    assert_eq!(df.height(), 24);
    for col in [
        "time_read_ms",
        "time_labels_ms",
        "time_filter_ms",
        "time_pose_points_ms",
        "time_pose_points_lines_ms",
    ] {
        assert!(df.column(col).is_ok(), "missing {col}");
    }
    let md = std::fs::read_to_string(out_a.join(SUMMARY_MD_FILE)).unwrap();
    assert!(md.contains("| points + lines | 24 |"), "{md}");
    let png = image::open(out_a.join(PLOT_FILE)).unwrap();
    assert!(png.width() > 0);

    // Deterministic: a second run writes the same bytes (the timings aside), with the
    // visual file or without.
    let out_b = dir.path().join("score_b");
    score::scoring::score_shards_with_visual(&shards, &out_b, &mut OracleLocaliser, &config, true)
        .expect("score again");
    let visual = std::fs::read(out_b.join(score::visual::VISUAL_FILE)).unwrap();
    let mut per_topic = std::collections::BTreeMap::<String, usize>::new();
    for m in mcap::MessageStream::new(&visual).unwrap() {
        *per_topic
            .entry(m.unwrap().channel.topic.clone())
            .or_default() += 1;
    }
    // Every frame: image, calibration, predictions, and on /tf the estimate and the
    // ground truth (the oracle localises every frame).
    let expected_topics: Vec<(String, usize)> = [
        ("/camera/calibration", 24),
        ("/camera/image", 24),
        ("/predictions/lines", 24),
        ("/predictions/points", 24),
        ("/tf", 48),
    ]
    .iter()
    .map(|(t, n)| (t.to_string(), *n))
    .collect();
    assert_eq!(per_topic.into_iter().collect::<Vec<_>>(), expected_topics);
    let mut names = vec![
        SUMMARY_MD_FILE.to_string(),
        SUMMARY_JSON_FILE.to_string(),
        PLOT_FILE.to_string(),
    ];
    names.extend(Variant::ALL.iter().map(|&v| results_file(v)));
    for n in &names {
        assert!(
            std::fs::read(out_a.join(n)).unwrap() == std::fs::read(out_b.join(n)).unwrap(),
            "{n} differs between two runs"
        );
    }
    let db = read_table(&out_b.join(PER_FRAME_FILE));
    for c in df.get_column_names() {
        if !c.starts_with("time_") {
            assert!(
                df.column(c).unwrap().equals_missing(db.column(c).unwrap()),
                "column {c} differs"
            );
        }
    }
    // Only the final files are left (no temp files).
    let mut left: Vec<String> = std::fs::read_dir(&out_a)
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    left.sort();
    let mut expected = names.clone();
    expected.push(PER_FRAME_FILE.to_string());
    expected.sort();
    assert_eq!(left, expected);

    // Another seed moves the estimates by rounding at most.
    let other = ScoreConfig {
        ransac: pose::RansacOptions {
            seed: 7,
            ..config.ransac.clone()
        },
        ..config.clone()
    };
    let c = score::score_shards(
        &shards,
        &dir.path().join("score_c"),
        &mut OracleLocaliser,
        &other,
    )
    .expect("other seed");
    assert!(c.summary.variants[0].accuracy[0].fraction >= 0.95);
    let t = f64s(
        &read_table(&dir.path().join("score_c").join(PER_FRAME_FILE)),
        "points_t_cm",
    );
    assert!(t.iter().all(|v| v.is_some_and(|v| v < 1.0)), "{t:?}");

    // The test shards carry no labels: the network path reads them; the oracle refuses
    // a folder without training shards.
    let e = score::score_shards(
        &dir.path().join("nowhere"),
        &dir.path().join("x"),
        &mut OracleLocaliser,
        &config,
    )
    .unwrap_err();
    assert!(matches!(e, ScoreError::Manifest { .. }), "{e}");
    let test_paths = score::scoring::shard_paths(&shards, shards::Split::Test).unwrap();
    assert!(!test_paths.is_empty());
}
