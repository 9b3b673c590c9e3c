//! End to end over the synthetic scene, through the built `pl2map` binary:
//! synth -> ingest -> import -> (refine) -> shard, and a shard run killed with SIGKILL
//! mid-way then rerun, which must end with the same manifest and shard bytes as a clean
//! run. (Compiled as an integration test of the `cli` package, which builds the binary.)

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};
use testkit::files::folder_bytes;
use testkit::process::ok;

fn pl2map() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_pl2map"));
    c.arg("--quiet");
    c
}

/// A tiny synthetic scene, its frames table (with the rendered depth) and label tables.
struct Prepared {
    _dir: tempfile::TempDir,
    root: PathBuf,
    frames: PathBuf,
    labels: PathBuf,
}

fn prepare() -> Prepared {
    prepare_with_noise(0.0)
}

/// As [`prepare`], with the SfM labels perturbed by `--label-noise-cm`.
fn prepare_with_noise(noise_cm: f64) -> Prepared {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path().to_path_buf();
    ok(
        pl2map()
            .arg("synth")
            .arg(root.join("data"))
            .arg("--tiny")
            .arg("--label-noise-cm")
            .arg(noise_cm.to_string())
            .output()
            .unwrap(),
        "synth",
    );
    let scene = root.join("data/synthroom");
    ok(
        pl2map()
            .args(["ingest", "--dataset", "7scenes", "--root"])
            .arg(&scene)
            // The synthetic depth is rendered in the colour camera: found by frame name.
            .arg("--depth")
            .arg(format!("rendered:{}", scene.display()))
            .arg("--out")
            .arg(root.join("frames"))
            .output()
            .unwrap(),
        "ingest",
    );
    ok(
        pl2map()
            .arg("import")
            .arg("--frames")
            .arg(root.join("frames/frames.parquet"))
            .arg("--model")
            .arg(scene.join("sfm_gt/colmap"))
            .arg("--limap")
            .arg(scene.join("sfm_gt/limap"))
            .arg("--out")
            .arg(root.join("labels"))
            .output()
            .unwrap(),
        "import",
    );
    Prepared {
        frames: root.join("frames/frames.parquet"),
        labels: root.join("labels"),
        root,
        _dir: dir,
    }
}

/// `pl2map STAGE --frames FRAMES --labels LABELS --out OUT` (refine and shard).
fn labels_stage(stage: &str, p: &Prepared, labels: &Path, out: &Path) -> Command {
    let mut c = pl2map();
    c.arg(stage)
        .arg("--frames")
        .arg(&p.frames)
        .arg("--labels")
        .arg(labels)
        .arg("--out")
        .arg(out);
    c
}

/// One frame per shard: many shards, so that a kill lands mid-run.
fn shard_cmd(p: &Prepared, out: &Path) -> Command {
    let mut c = labels_stage("shard", p, &p.labels, out);
    c.args(["--frames-per-shard", "1"]);
    c
}

fn refine_cmd(p: &Prepared, out: &Path) -> Command {
    labels_stage("refine", p, &p.labels, out)
}

fn mcap_files(dir: &Path) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
        .map(|r| r.filter_map(|e| e.ok().map(|e| e.path())).collect())
        .unwrap_or_default();
    v.retain(|p| p.extension().is_some_and(|e| e == "mcap"));
    v.sort();
    v
}

#[test]
fn killed_shard_run_reruns_to_the_same_manifest() {
    let p = prepare();
    let clean = p.root.join("clean");
    ok(shard_cmd(&p, &clean).output().unwrap(), "clean shard run");
    let n_clean = mcap_files(&clean).len();
    assert!(n_clean > 4, "expected one shard per frame, got {n_clean}");

    // Kill the second run as soon as it has written its first shard file, while the
    // manifest does not exist yet.
    let killed = p.root.join("killed");
    let mut child = shard_cmd(&p, &killed)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let start = Instant::now();
    loop {
        if !mcap_files(&killed).is_empty() {
            break;
        }
        if let Ok(Some(status)) = child.try_wait() {
            panic!("the shard run ended ({status}) before it could be killed");
        }
        assert!(
            start.elapsed() < Duration::from_secs(120),
            "no shard appeared"
        );
        std::thread::sleep(Duration::from_millis(1));
    }
    child.kill().unwrap(); // SIGKILL on Unix
    let status = child.wait().unwrap();
    assert!(!status.success(), "the run was not killed: {status}");
    let written = mcap_files(&killed).len();
    assert!(
        written < n_clean,
        "the killed run wrote all {written} shards; the test needs a bigger scene"
    );
    // What a killed run leaves is never mistaken for complete.
    assert!(!killed.join("manifest.json").exists());
    assert!(!killed.join("stage.json").exists());

    ok(
        shard_cmd(&p, &killed).output().unwrap(),
        "rerun after the kill",
    );
    let (a, b) = (folder_bytes(&clean), folder_bytes(&killed));
    assert_eq!(
        a.keys().collect::<Vec<_>>(),
        b.keys().collect::<Vec<_>>(),
        "different files after the rerun"
    );
    // Manifest, stage record and every shard: the same bytes.
    for ((name, x), y) in a.iter().zip(b.values()) {
        assert!(
            x == y,
            "{name} differs between the clean and the resumed run"
        );
    }
}

#[test]
fn refine_then_shard_on_the_synthetic_scene() {
    let p = prepare();
    let refined = p.root.join("refined");
    let out = ok(refine_cmd(&p, &refined).output().unwrap(), "refine");
    assert!(out.contains("points") && out.contains("lines"), "{out}");
    let shards = p.root.join("shards");
    ok(
        labels_stage("shard", &p, &refined, &shards)
            .output()
            .unwrap(),
        "shard",
    );
    assert!(shards.join("manifest.json").is_file());
    assert!(!mcap_files(&shards).is_empty());
}

/// The label ablation (docs/training-notes.md, "Label ablation") on the tiny synthetic scene: with `--label-noise-cm 5`, depth
/// refinement cuts the median 3D error of point AND line labels (against the exact
/// labels the generator keeps in `sfm_gt/exact.json`) by >= 80 % and drops < 5 %.
#[test]
fn refinement_removes_label_noise_on_the_tiny_scene() {
    let p = prepare_with_noise(5.0);
    let refined = p.root.join("refined");
    let exact = p.root.join("data/synthroom/sfm_gt/exact.json");
    let printed = ok(
        refine_cmd(&p, &refined)
            .arg("--exact")
            .arg(&exact)
            .output()
            .unwrap(),
        "refine --exact",
    );
    assert!(printed.contains("reduction"), "{printed}");
    // The numbers, recomputed here from the written tables.
    let exact = labels::label_error::ExactLabels::read(&exact).unwrap();
    let before = labels::LabelTables::read(&p.labels).unwrap();
    let after = labels::LabelTables::read(&refined).unwrap();
    let rows = labels::label_error::compare(&exact, &before, &after).unwrap();
    print!("{}", labels::label_error::table(&rows));
    for r in &rows {
        // The noise is really there before refinement (5 cm RMS in 3D: median ~4.4 cm).
        assert!(
            r.before.median > 0.02,
            "{}: median before {}",
            r.kind,
            r.before.median
        );
        assert!(
            r.labels_before > 100,
            "{}: only {} labels",
            r.kind,
            r.labels_before
        );
        assert!(
            r.reduction() >= 0.8,
            "{}: median error down by only {:.1} %",
            r.kind,
            100.0 * r.reduction()
        );
        assert!(
            r.dropped_fraction() < 0.05,
            "{}: {:.1} % dropped",
            r.kind,
            100.0 * r.dropped_fraction()
        );
    }
}

/// The score command end to end on the tiny scene: the oracle (labels of the training
/// shards) localises every frame, the iteration cap is passed through, and a cap of 0
/// is refused with a message rather than a panic.
#[test]
fn score_oracle_through_the_command() {
    let p = prepare();
    let shards = p.root.join("shards");
    ok(
        labels_stage("shard", &p, &p.labels, &shards)
            .output()
            .unwrap(),
        "shard",
    );
    let out = p.root.join("score");
    let printed = ok(
        pl2map()
            .arg("score")
            .arg("--shards")
            .arg(&shards)
            .arg("--out")
            .arg(&out)
            .args(["--oracle", "--max-iterations", "2000"])
            .output()
            .unwrap(),
        "score --oracle",
    );
    assert!(printed.contains("points + lines"), "{printed}");
    for f in ["summary.md", "summary.json", "per_frame.parquet", "cdf.png"] {
        assert!(out.join(f).is_file(), "{f} missing");
    }
    let results = std::fs::read_to_string(out.join("results_points.txt")).unwrap();
    assert_eq!(results.lines().count(), 24, "one pose per training frame");
    let bad = pl2map()
        .arg("score")
        .arg("--shards")
        .arg(&shards)
        .arg("--out")
        .arg(p.root.join("score0"))
        .args(["--oracle", "--max-iterations", "0"])
        .output()
        .unwrap();
    assert!(!bad.status.success());
    let err = String::from_utf8_lossy(&bad.stderr);
    assert!(
        err.contains("max_iterations") && !err.contains("panicked"),
        "{err}"
    );
}

/// The stderr of a command that must fail (not a panic).
fn refused(out: std::process::Output, what: &str) -> String {
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(!out.status.success(), "{what} succeeded: {err}");
    assert!(!err.contains("panicked"), "{what}: {err}");
    err
}

/// No silent wrong result (issue 48) through the binary: a stage reads another stage's
/// outputs only while that stage's record vouches for them, checks each depth map
/// against the frames table, reads a shard folder through the one manifest check, and
/// never writes into another stage's folder. Each refusal leaves no record behind.
#[test]
fn stages_read_only_recorded_outputs_and_write_only_their_own_folder() {
    let p = prepare();
    let shards = p.root.join("shards");
    ok(
        labels_stage("shard", &p, &p.labels, &shards)
            .output()
            .unwrap(),
        "shard",
    );

    // `pl2map score --out <the import's folder>`: refused, the import's record kept.
    let import_record = std::fs::read(p.labels.join("stage.json")).unwrap();
    let err = refused(
        pl2map()
            .arg("score")
            .arg("--shards")
            .arg(&shards)
            .arg("--out")
            .arg(&p.labels)
            .arg("--oracle")
            .output()
            .unwrap(),
        "score into the import's folder",
    );
    assert!(
        err.contains(&format!(
            "{} belongs to the import stage (its stage.json says so)",
            p.labels.display()
        )),
        "{err}"
    );
    assert_eq!(
        std::fs::read(p.labels.join("stage.json")).unwrap(),
        import_record
    );

    // A manifest edited to drop a shard: score and train both refuse it.
    let manifest_path = shards.join("manifest.json");
    let original = std::fs::read(&manifest_path).unwrap();
    let mut m = shards::Manifest::load(&manifest_path).unwrap();
    m.shards.remove(0);
    m.save(&manifest_path).unwrap();
    let stale = format!(
        "{}: changed after the shard stage recorded it",
        manifest_path.display()
    );
    let score_out = p.root.join("score");
    let err = refused(
        pl2map()
            .arg("score")
            .arg("--shards")
            .arg(&shards)
            .arg("--out")
            .arg(&score_out)
            .arg("--oracle")
            .output()
            .unwrap(),
        "score of an edited manifest",
    );
    assert!(err.contains(&stale), "{err}");
    assert!(!score_out.join("stage.json").exists());
    let train_out = p.root.join("train");
    let err = refused(
        pl2map()
            .arg("train")
            .arg("--shards")
            .arg(&shards)
            .arg("--out")
            .arg(&train_out)
            .args(["--iterations", "1"])
            .output()
            .unwrap(),
        "train on an edited manifest",
    );
    assert!(err.contains(&stale), "{err}");
    assert!(!train_out.join("stage.json").exists() && !train_out.join("model.ckpt").exists());
    std::fs::write(&manifest_path, original).unwrap();

    // Frame 1's depth map copied over frame 0's after ingest: refine refuses it.
    let table = tables::FramesTable::read_parquet(&p.frames).unwrap();
    let (d0, d1) = (
        table.frames[0].depth_path.clone().unwrap(),
        table.frames[1].depth_path.clone().unwrap(),
    );
    let depth0 = std::fs::read(&d0).unwrap();
    std::fs::copy(&d1, &d0).unwrap();
    let refined = p.root.join("refined");
    let err = refused(
        refine_cmd(&p, &refined).output().unwrap(),
        "refine with a changed depth map",
    );
    assert!(
        err.contains(&format!(
            "{}: the depth map of frame 0 ({}) changed since ingest",
            d0.display(),
            table.frames[0].name
        )),
        "{err}"
    );
    assert!(!refined.join("stage.json").exists());
    std::fs::write(&d0, depth0).unwrap();

    // The tables a refused import leaves without its record: refine and shard refuse
    // them (they used to take them, exit 0).
    std::fs::remove_file(p.labels.join("stage.json")).unwrap();
    let missing = format!(
        "{}: missing: points.parquet, lines.parquet, poses.parquet",
        p.labels.join("stage.json").display()
    );
    let err = refused(
        refine_cmd(&p, &refined).output().unwrap(),
        "refine of unrecorded tables",
    );
    assert!(err.contains(&missing), "{err}");
    let shards2 = p.root.join("shards2");
    let err = refused(
        labels_stage("shard", &p, &p.labels, &shards2)
            .output()
            .unwrap(),
        "shard of unrecorded tables",
    );
    assert!(err.contains(&missing), "{err}");
    assert!(!refined.join("stage.json").exists() && !shards2.join("manifest.json").exists());
}
