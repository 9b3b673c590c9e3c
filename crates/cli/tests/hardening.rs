//! The `pl2map` binary as a nightly job meets it: output piped into a reader that goes
//! away, two runs started on one work folder, files of the user's inside stage folders,
//! a run killed in the middle. Each test runs real processes on the tiny synthetic
//! pipeline (pipeline/synthetic-tiny.toml, trained for a few steps only).

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};
use testkit::process::{assert_quiet_exit_on_closed_stdout, ok};

fn bin() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_pl2map"));
    c.env("RUST_BACKTRACE", "0");
    c
}

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// The tiny synthetic pipeline with its work folder in `dir`, 4 training steps and a
/// RANSAC cap that keeps the weak model's score quick. Returns the file's path.
fn tiny_pipeline(dir: &Path, synth_seed: u64) -> PathBuf {
    let text = std::fs::read_to_string(repo().join("pipeline/synthetic-tiny.toml")).unwrap();
    let mut out = String::new();
    for line in text.lines() {
        let line = match line {
            l if l.starts_with("work = ") => format!("work = {:?}", dir.join("work")),
            "iterations = 100" => "iterations = 4".into(),
            "checkpoint_every = 50" => "checkpoint_every = 2".into(),
            l => l.to_string(),
        };
        out.push_str(&line);
        out.push('\n');
        if line == "[score]" {
            out.push_str("max_iterations = 200\n");
        }
        if line == "[synth]" {
            out.push_str(&format!("seed = {synth_seed}\n"));
        }
    }
    // The template's own seed line under [synth] is replaced by the one added above.
    let out = out.replacen("seed = 0\nlabel_noise_cm", "label_noise_cm", 1);
    let path = dir.join("pipeline.toml");
    std::fs::write(&path, out).unwrap();
    path
}

fn run(pipeline: &Path, extra: &[&str]) -> Output {
    bin()
        .arg("run")
        .arg(pipeline)
        .arg("--quiet")
        .args(extra)
        .output()
        .unwrap()
}

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

/// Each stage folder's recorded outputs (name -> sha256), from its stage.json.
fn recorded_outputs(work: &Path) -> Vec<(String, Vec<(String, String)>)> {
    [
        "synth", "ingest", "import", "refine", "shard", "train", "score",
    ]
    .iter()
    .map(|stage| {
        let record = work.join(stage).join("stage.json");
        let json: serde_json::Value =
            serde_json::from_slice(&std::fs::read(&record).unwrap()).unwrap();
        let outputs: Vec<(String, String)> = json["outputs"]
            .as_object()
            .unwrap()
            .iter()
            // metrics.csv is compared without its timing columns
            // (metrics_without_times); per_frame.parquet holds each frame's time
            // too, its poses are in the results files compared here.
            .filter(|(k, _)| *k != "metrics.csv" && *k != "per_frame.parquet")
            .map(|(k, v)| (k.clone(), v.as_str().unwrap().to_string()))
            .collect();
        (stage.to_string(), outputs)
    })
    .collect()
}

/// train/metrics.csv without the `seconds` and `data_seconds` columns (wall time).
fn metrics_without_times(work: &Path) -> Vec<String> {
    let text = std::fs::read_to_string(work.join("train/metrics.csv")).unwrap();
    let header: Vec<&str> = text.lines().next().unwrap().split(',').collect();
    let keep: Vec<usize> = (0..header.len())
        .filter(|&i| !header[i].ends_with("seconds"))
        .collect();
    assert!(keep.len() + 2 == header.len(), "{header:?}");
    text.lines()
        .map(|l| {
            let cells: Vec<&str> = l.split(',').collect();
            let kept: Vec<&str> = keep.iter().map(|&i| cells[i]).collect();
            kept.join(",")
        })
        .collect()
}

fn wait_for(what: &str, mut done: impl FnMut() -> bool) {
    let start = Instant::now();
    while !done() {
        assert!(
            start.elapsed() < Duration::from_secs(300),
            "waited 300 s for {what}"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
}

#[test]
fn a_closed_stdout_is_a_quiet_exit_and_the_work_is_done() {
    // A pipeline whose reader went away still does all its work.
    let dir = tempfile::tempdir().unwrap();
    let pipeline = tiny_pipeline(dir.path(), 0);
    assert_quiet_exit_on_closed_stdout(bin().arg("run").arg(&pipeline).args(["--until", "shard"]));
    assert!(dir.path().join("work/shard/stage.json").is_file());

    // The info commands on the scene's COLMAP model and LIMAP folder.
    let gt = dir.path().join("work/synth/synthroom/sfm_gt");
    for (kind, folder) in [("colmap", "colmap"), ("limap", "limap")] {
        assert_quiet_exit_on_closed_stdout(bin().args([kind, "info"]).arg(gt.join(folder)));
    }
}

#[test]
fn a_second_run_on_the_folder_refuses_or_waits_and_the_outputs_are_one_runs() {
    let dir = tempfile::tempdir().unwrap();
    let pipeline = tiny_pipeline(dir.path(), 0);
    let work = dir.path().join("work");
    let first = bin()
        .arg("run")
        .arg(&pipeline)
        .arg("--quiet")
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let pid = first.id();
    // The holder writes its pid into the work folder's lock file once it holds it.
    let lock = work.join(".pl2map.lock");
    wait_for("the first run's lock", || {
        std::fs::read_to_string(&lock).is_ok_and(|t| t.contains(&format!("pid {pid}")))
    });

    let refused = run(&pipeline, &[]);
    let stderr = text(&refused.stderr);
    assert!(
        !refused.status.success(),
        "the second run was not refused: {stderr}"
    );
    assert!(stderr.contains(&format!("process {pid}")), "{stderr}");
    assert!(
        stderr.contains("started") && stderr.contains("--wait"),
        "{stderr}"
    );

    let waiting = bin()
        .arg("run")
        .arg(&pipeline)
        .args(["--quiet", "--wait"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    ok(first.wait_with_output().unwrap(), "the first run");
    let table = ok(waiting.wait_with_output().unwrap(), "the waiting run");
    for stage in [
        "synth", "ingest", "import", "refine", "shard", "train", "score",
    ] {
        let row = table
            .lines()
            .find(|l| l.starts_with(stage))
            .unwrap_or_else(|| panic!("no {stage} row in\n{table}"));
        assert!(row.contains("up to date"), "{row}");
    }

    // The same outputs as one run alone in the same place (the frames table holds
    // absolute paths).
    let ours = recorded_outputs(&work);
    let our_metrics = metrics_without_times(&work);
    std::fs::remove_dir_all(&work).unwrap();
    ok(run(&pipeline, &[]), "the run alone");
    let one = recorded_outputs(&work);
    assert_eq!(our_metrics, metrics_without_times(&work));
    for ((stage, a), (_, b)) in ours.iter().zip(&one) {
        let differ: Vec<&String> = a
            .iter()
            .zip(b)
            .filter(|(x, y)| x != y)
            .map(|(x, _)| &x.0)
            .collect();
        assert!(
            a.len() == b.len() && differ.is_empty(),
            "{stage}: {differ:?}"
        );
    }
}

#[test]
fn files_the_stages_did_not_write_are_left_or_named() {
    let dir = tempfile::tempdir().unwrap();
    let work = dir.path().join("work");
    ok(run(&tiny_pipeline(dir.path(), 0), &[]), "first run");
    let folders = [
        "", "synth", "ingest", "import", "refine", "shard", "train", "score",
    ];
    for f in folders {
        std::fs::write(work.join(f).join("notes.txt"), format!("mine: {f}")).unwrap();
    }
    let in_scene = work.join("synth/synthroom/notes.txt");
    std::fs::write(&in_scene, "mine: scene").unwrap();

    // Another seed: every stage runs again. The scene folder is rendered anew, so a
    // file of the user's in it is refused by name rather than deleted.
    let reseeded = tiny_pipeline(dir.path(), 1);
    let out = run(&reseeded, &[]);
    let stderr = text(&out.stderr);
    assert!(!out.status.success(), "{stderr}");
    assert!(stderr.contains("synthroom/notes.txt"), "{stderr}");
    assert_eq!(std::fs::read_to_string(&in_scene).unwrap(), "mine: scene");

    std::fs::rename(&in_scene, dir.path().join("kept.txt")).unwrap();
    let table = ok(run(&reseeded, &[]), "the reseeded run");
    assert!(
        table.lines().filter(|l| l.contains(" ran ")).count() == 7,
        "{table}"
    );
    for f in folders {
        let kept = std::fs::read_to_string(work.join(f).join("notes.txt")).unwrap();
        assert_eq!(kept, format!("mine: {f}"));
    }

    // A model the train folder's record does not account for is named, not deleted.
    std::fs::remove_file(work.join("train/stage.json")).unwrap();
    let model = std::fs::read(work.join("train/model.ckpt")).unwrap();
    let out = run(&reseeded, &[]);
    let stderr = text(&out.stderr);
    assert!(!out.status.success(), "{stderr}");
    assert!(stderr.contains(".ckpt"), "{stderr}");
    assert_eq!(std::fs::read(work.join("train/model.ckpt")).unwrap(), model);
}

#[test]
fn a_killed_run_leaves_nothing_the_next_run_keeps() {
    let dir = tempfile::tempdir().unwrap();
    let pipeline = tiny_pipeline(dir.path(), 0);
    let synth = dir.path().join("work/synth");
    let staging = |synth: &Path| -> Vec<PathBuf> {
        std::fs::read_dir(synth)
            .map(|d| {
                d.map(|e| e.unwrap().path())
                    .filter(|p| p.to_string_lossy().contains(".synthroom.partial-"))
                    .collect()
            })
            .unwrap_or_default()
    };
    let mut child = bin()
        .arg("run")
        .arg(&pipeline)
        .args(["--quiet", "--until", "synth"])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    wait_for("the synth stage's staging folder", || {
        staging(&synth)
            .iter()
            .any(|p| std::fs::read_dir(p).is_ok_and(|mut d| d.next().is_some()))
    });
    child.kill().unwrap(); // SIGKILL: nothing of the process runs after it.
    child.wait().unwrap();
    assert!(!staging(&synth).is_empty());
    // A temp file a full disk left in another stage folder.
    let ingest = dir.path().join("work/ingest");
    std::fs::create_dir_all(&ingest).unwrap();
    let temp = ingest.join(".frames.parquet.x1y2.tmp");
    std::fs::write(&temp, b"half a table").unwrap();

    // No stale lock: the next run starts at once, and removes the leftovers.
    ok(
        run(&pipeline, &["--until", "ingest"]),
        "the run after the kill",
    );
    assert!(staging(&synth).is_empty(), "{:?}", staging(&synth));
    assert!(!temp.exists());
    assert!(synth.join("stage.json").is_file());
}

#[test]
fn an_unreadable_record_counts_as_none_in_every_stage() {
    let dir = tempfile::tempdir().unwrap();
    let pipeline = tiny_pipeline(dir.path(), 0);
    let work = dir.path().join("work");
    ok(run(&pipeline, &["--until", "shard"]), "first run");
    for stage in ["ingest", "import", "refine", "shard"] {
        std::fs::write(work.join(stage).join("stage.json"), b"{ garbage").unwrap();
    }
    let table = ok(
        run(&pipeline, &["--until", "shard"]),
        "the run over unreadable records",
    );
    for stage in ["ingest", "import", "refine", "shard"] {
        let row = table.lines().find(|l| l.starts_with(stage)).unwrap();
        assert!(row.contains(" ran "), "{row}");
    }
    // Without a record the synth stage cannot tell its scene from files of the user's
    // in the scene folder: it names them instead of deleting them.
    std::fs::write(work.join("synth/stage.json"), b"{ garbage").unwrap();
    let out = run(&pipeline, &["--until", "synth"]);
    let stderr = text(&out.stderr);
    assert!(!out.status.success(), "{stderr}");
    assert!(
        stderr.contains("synthroom") && stderr.contains("TestSplit.txt"),
        "{stderr}"
    );
}

#[test]
fn a_warm_start_from_a_missing_file_is_refused_before_any_stage() {
    let dir = tempfile::tempdir().unwrap();
    let pipeline = tiny_pipeline(dir.path(), 0);
    let missing = dir.path().join("nonexistent.ckpt");
    let out = run(&pipeline, &["--warm-start", missing.to_str().unwrap()]);
    let stderr = text(&out.stderr);
    assert!(!out.status.success(), "{stderr}");
    assert!(
        stderr.contains("nonexistent.ckpt: no such file"),
        "{stderr}"
    );
    assert!(!dir.path().join("work/synth").exists(), "a stage ran");
}

/// `pl2map train --resume` continues the checkpoint's run to a new iteration count and
/// records what it did; a resume asking another setting is refused naming it, and the
/// finished run keeps its record and model (issue: a resume that trained with the
/// checkpoint's settings and recorded the ones asked for).
#[test]
fn train_resume_continues_to_a_new_count_or_refuses_naming_the_setting() {
    let dir = tempfile::tempdir().unwrap();
    let pipeline = tiny_pipeline(dir.path(), 0);
    let out = run(&pipeline, &["--until", "train"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let work = dir.path().join("work");
    let train_dir = work.join("train");
    let train = |extra: &[&str]| {
        bin()
            .args(["train", "--quiet", "--shards"])
            .arg(work.join("shard"))
            .arg("--out")
            .arg(&train_dir)
            .args(extra)
            .output()
            .unwrap()
    };
    let model_before = std::fs::read(train_dir.join("model.ckpt")).unwrap();
    let record_before = std::fs::read(train_dir.join("stage.json")).unwrap();
    let refused = train(&["--resume", "--iterations", "6", "--learning-rate", "0.01"]);
    let stderr = text(&refused.stderr);
    assert!(!refused.status.success(), "{stderr}");
    assert!(
        stderr.contains("learning_rate (checkpoint") && stderr.contains("checkpoint.ckpt"),
        "{stderr}"
    );
    assert_eq!(
        std::fs::read(train_dir.join("model.ckpt")).unwrap(),
        model_before
    );
    assert_eq!(
        std::fs::read(train_dir.join("stage.json")).unwrap(),
        record_before
    );

    let resumed = train(&["--resume", "--iterations", "6"]);
    let stdout = text(&resumed.stdout);
    assert!(resumed.status.success(), "{}", text(&resumed.stderr));
    assert!(stdout.contains("6 iterations"), "{stdout}");
    assert!(stdout.contains("(resumed at 4)"), "{stdout}");
    assert_ne!(
        std::fs::read(train_dir.join("model.ckpt")).unwrap(),
        model_before
    );
    let record = std::fs::read_to_string(train_dir.join("stage.json")).unwrap();
    // Asked again for what was done: up to date.
    let again = train(&["--resume", "--iterations", "6"]);
    assert!(again.status.success(), "{}", text(&again.stderr));
    assert_eq!(
        std::fs::read_to_string(train_dir.join("stage.json")).unwrap(),
        record
    );
    assert!(
        text(&again.stdout).contains("up to date"),
        "{}",
        text(&again.stdout)
    );
}

/// `pl2map train --init` with a file that is not a checkpoint of the configured network
/// names that file (not the stage's copy of it) and writes nothing; `--config` takes a
/// pipeline's `[train]` section as it is, with a partial `[train.model]` table.
#[test]
fn train_init_and_config_files_are_checked_before_anything_is_written() {
    let dir = tempfile::tempdir().unwrap();
    let pipeline = tiny_pipeline(dir.path(), 0);
    let out = run(&pipeline, &["--until", "shard"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let work = dir.path().join("work");
    let bad = dir.path().join("not-a-model.ckpt");
    std::fs::write(&bad, b"hello").unwrap();
    let out_dir = dir.path().join("warm");
    let refused = bin()
        .args(["train", "--quiet", "--iterations", "2", "--shards"])
        .arg(work.join("shard"))
        .arg("--out")
        .arg(&out_dir)
        .arg("--init")
        .arg(&bad)
        .output()
        .unwrap();
    let stderr = text(&refused.stderr);
    assert!(!refused.status.success(), "{stderr}");
    assert!(
        stderr.contains("not-a-model.ckpt") && !stderr.contains("warm-start.ckpt"),
        "{stderr}"
    );
    assert!(!out_dir.join("warm-start.ckpt").exists());
    assert!(!out_dir.join("stage.json").exists());

    // The pipeline's [train] section, as the tiny pipeline writes it, with the network
    // narrowed in a partial [train.model] table.
    let config = dir.path().join("train.toml");
    std::fs::write(
        &config,
        "[train]\niterations = 2\nseed = 0\n[train.model]\nhead_hidden = [16]\n",
    )
    .unwrap();
    let trained = bin()
        .args(["train", "--quiet", "--shards"])
        .arg(work.join("shard"))
        .arg("--out")
        .arg(dir.path().join("from-section"))
        .arg("--config")
        .arg(&config)
        .output()
        .unwrap();
    let stdout = text(&trained.stdout);
    assert!(trained.status.success(), "{}", text(&trained.stderr));
    assert!(stdout.contains("head widths [16]"), "{stdout}");
}
