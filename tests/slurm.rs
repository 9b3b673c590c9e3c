//! The work units on a real scheduler (docs/operations.md, "Past one machine"): a one-node
//! Slurm on 127.0.0.1 (`slurm/cluster.rs`) runs deploy/slurm/submit.sh on the tiny
//! synthetic scene: the shard stage as a job array, then training and scoring as a job
//! that depends on it. The work folder must be byte for byte what one `pl2map run` of the
//! same pipeline writes, and the lock file of it must verify; also after one array task
//! was cancelled part way and resubmitted alone. `k8s.rs` checks the Kubernetes manifests
//! of the same units (no cluster here). Without Slurm (or not as root) the Slurm tests
//! skip, saying why.

#[path = "slurm/cluster.rs"]
mod cluster;
#[path = "slurm/k8s.rs"]
mod k8s;

use cluster::{Cluster, JobState};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::Mutex;
use std::time::{Duration, Instant};
use testkit::process::ok;

/// One Slurm at a time: the machine has 2 CPUs, and one node is enough.
static ONE_CLUSTER: Mutex<()> = Mutex::new(());

/// How long the jobs of one submission may take (they take seconds to a minute).
const JOB_TIMEOUT: Duration = Duration::from_secs(600);

fn pl2map() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_pl2map"));
    c.arg("--quiet");
    c
}

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../..")
        .canonicalize()
        .unwrap()
}

/// A temporary folder with a copy of pipeline/synthetic-tiny.toml whose work folder is
/// `work` beside it (synth's paths resolve from the work folder, so the whole scene is
/// in there) and `frames_per_shard` frames per shard, for several shards; training
/// shortened. The plain run and the Slurm run write the same folder (the frames table
/// holds the work folder's paths), one after the other.
struct Scene {
    dir: tempfile::TempDir,
    pipeline: PathBuf,
    work: PathBuf,
    plain: PathBuf,
    logs: PathBuf,
}

impl Scene {
    fn new(frames_per_shard: usize) -> Scene {
        let dir = tempfile::tempdir().unwrap();
        let text = std::fs::read_to_string(repo().join("pipeline/synthetic-tiny.toml")).unwrap();
        let replace = |text: String, from: &str, to: &str| {
            assert!(
                text.contains(from),
                "pipeline/synthetic-tiny.toml: no {from:?}"
            );
            text.replace(from, to)
        };
        let text = replace(text, "work = \"../work/synthetic-tiny\"", "work = \"work\"");
        let text = replace(
            text,
            "frames_per_shard = 500",
            &format!("frames_per_shard = {frames_per_shard}"),
        );
        let text = replace(
            text,
            "iterations = 100\ncheckpoint_every = 50",
            "iterations = 20\ncheckpoint_every = 10",
        );
        let pipeline = dir.path().join("pipeline.toml");
        std::fs::write(&pipeline, text).unwrap();
        Scene {
            pipeline,
            work: dir.path().join("work"),
            plain: dir.path().join("plain"),
            logs: dir.path().join("slurm-logs"),
            dir,
        }
    }

    fn root(&self) -> &Path {
        self.dir.path()
    }

    /// One `pl2map run` on this machine, kept as `plain/`.
    fn run_plain(&self) {
        ok(
            pl2map().arg("run").arg(&self.pipeline).output().unwrap(),
            "plain pl2map run",
        );
        std::fs::rename(&self.work, &self.plain).unwrap();
    }

    /// deploy/slurm/submit.sh with `args`: (array job, its tasks, train + score job).
    fn submit(&self, slurm: &Cluster, args: &[&str]) -> (String, String, String) {
        let out = slurm
            .cmd("bash")
            .arg(repo().join("deploy/slurm/submit.sh"))
            .args(args)
            .arg("--logs")
            .arg(&self.logs)
            .arg(&self.pipeline)
            .arg(&self.work)
            .current_dir(self.root())
            .env("PL2MAP", env!("CARGO_BIN_EXE_pl2map"))
            .output()
            .unwrap();
        let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
        assert!(
            out.status.success(),
            "submit.sh {args:?}: {}\n{stdout}\n{}\n{}",
            out.status,
            String::from_utf8_lossy(&out.stderr),
            slurm.logs()
        );
        let value = |key: &str| {
            stdout
                .lines()
                .find_map(|l| l.strip_prefix(key))
                .unwrap_or_else(|| panic!("submit.sh printed no {key}: {stdout}"))
                .to_string()
        };
        (
            value("shards_job="),
            value("tasks="),
            value("train_score_job="),
        )
    }

    /// Waits for `jobs` and checks that every record completed, printing the jobs' logs
    /// otherwise.
    fn wait_completed(&self, slurm: &Cluster, jobs: &[&str]) -> Vec<JobState> {
        let states = slurm.wait_final(jobs, JOB_TIMEOUT);
        assert!(
            states.iter().all(|s| s.state == "COMPLETED"),
            "{states:?}\n{}\n{}",
            self.job_logs(),
            slurm.logs()
        );
        states
    }

    /// Every job log under `slurm-logs/`.
    fn job_logs(&self) -> String {
        let mut s = String::new();
        for (name, bytes) in testkit::files::folder_bytes(&self.logs) {
            s.push_str(&format!(
                "--- {name}\n{}\n",
                String::from_utf8_lossy(&bytes)
            ));
        }
        s
    }

    /// The Slurm work folder against the plain run's, file by file (sha256): the same
    /// files with the same bytes, and besides them only the work units' manifests
    /// `shard/manifest.<a>-<b>.json` of `units` and their merge lock (a plain run has no
    /// units). Then the lock
    /// file of the Slurm folder verifies (`pl2map lock`, `pl2map verify`: the data
    /// stages rebuilt elsewhere, every hash compared).
    fn check_equals_one_run(&self, units: &[(usize, usize)]) {
        let plain = hashes(&self.plain);
        let slurm = hashes(&self.work);
        assert!(plain.contains_key("score/stage.json"), "{plain:?}");
        for (name, hash) in &plain {
            if TIMED.contains(&name.as_str()) {
                continue;
            }
            assert_eq!(
                slurm.get(name),
                Some(hash),
                "{name}: the Slurm work folder differs from one pl2map run"
            );
        }
        same_but_timings(&self.plain, &self.work);
        let extra: Vec<&String> = slurm.keys().filter(|k| !plain.contains_key(*k)).collect();
        // The units' manifests, and the lock file of their merge step (empty).
        let expected: Vec<String> = units
            .iter()
            .map(|(a, b)| format!("shard/manifest.{a}-{b}.json"))
            .chain(["shard/.merge.lock".to_string()])
            .collect();
        let mut extra_sorted: Vec<String> = extra.iter().map(|s| s.to_string()).collect();
        extra_sorted.sort();
        let mut expected_sorted = expected.clone();
        expected_sorted.sort();
        assert_eq!(
            extra_sorted, expected_sorted,
            "files of the Slurm run that one run does not write"
        );

        let lock = self.root().join("lock.toml");
        ok(
            pl2map()
                .arg("lock")
                .arg(&self.pipeline)
                .arg("--out")
                .arg(&lock)
                .output()
                .unwrap(),
            "pl2map lock of the Slurm work folder",
        );
        let said = ok(
            pl2map().arg("verify").arg(&lock).output().unwrap(),
            "pl2map verify of the Slurm run's lock file",
        );
        assert!(said.contains("hashes match"), "{said}");
    }
}

/// The files that hold measured times, which differ between any two runs on one machine
/// too: the `time_*_ms` columns of the score stage's per-frame table
/// (crates/score/src/table.rs), the `seconds` and `data_seconds` columns of the training
/// metrics (crates/train/src/metrics.rs), and so their hashes in the stage records.
const TIMED: [&str; 4] = [
    "score/per_frame.parquet",
    "score/stage.json",
    "train/metrics.csv",
    "train/stage.json",
];

/// The [`TIMED`] files of two work folders: equal but for their times.
fn same_but_timings(a: &Path, b: &Path) {
    // The per-frame tables: values, nulls and key-value metadata, time_* aside.
    let table = |dir: &Path| {
        let (df, meta) = tables::parquet::read_parquet(&dir.join(TIMED[0]))
            .unwrap_or_else(|e| panic!("{}: {e}", dir.display()));
        let timed: Vec<String> = df
            .get_column_names()
            .into_iter()
            .filter(|c| c.starts_with("time_"))
            .map(|c| c.to_string())
            .collect();
        assert!(!timed.is_empty(), "no time_* column in {}", dir.display());
        (df.drop_many(timed), meta)
    };
    let ((x, xm), (y, ym)) = (table(a), table(b));
    assert!(x.height() > 0);
    assert!(
        x.equals_missing(&y),
        "{}: the Slurm run's differs from one run's (time_* columns aside):\n{x}\n{y}",
        TIMED[0]
    );
    assert_eq!(xm, ym, "{}: key-value metadata", TIMED[0]);
    // The training metrics, seconds aside.
    let metrics = |dir: &Path| -> Vec<Vec<String>> {
        let text = std::fs::read_to_string(dir.join(TIMED[2])).unwrap();
        let rows: Vec<Vec<&str>> = text.lines().map(|l| l.split(',').collect()).collect();
        let timed: Vec<usize> = rows[0]
            .iter()
            .enumerate()
            .filter(|(_, c)| matches!(**c, "seconds" | "data_seconds"))
            .map(|(i, _)| i)
            .collect();
        assert_eq!(timed.len(), 2, "{}: {:?}", TIMED[2], rows[0]);
        rows.iter()
            .map(|r| {
                r.iter()
                    .enumerate()
                    .filter(|(i, _)| !timed.contains(i))
                    .map(|(_, v)| v.to_string())
                    .collect()
            })
            .collect()
    };
    let m = metrics(a);
    assert!(m.len() > 1, "{}: no rows", TIMED[2]);
    assert!(m == metrics(b), "{}: differs, seconds aside", TIMED[2]);
    // The stage records, the timed file's hash aside.
    for (record, timed) in [(TIMED[1], "per_frame.parquet"), (TIMED[3], "metrics.csv")] {
        let load = |dir: &Path| {
            let path = dir.join(record);
            let mut v: serde_json::Value =
                serde_json::from_slice(&std::fs::read(&path).unwrap()).unwrap();
            let outputs = v["outputs"].as_object_mut().expect("outputs in the record");
            assert!(outputs.remove(timed).is_some(), "{record}: no {timed}");
            v
        };
        assert_eq!(load(a), load(b), "{record}, {timed}'s hash aside");
    }
}

/// sha256 of every file under `dir`, by path relative to it.
fn hashes(dir: &Path) -> BTreeMap<String, String> {
    testkit::files::folder_bytes(dir)
        .into_iter()
        .map(|(name, bytes)| (name, stage::sha256_bytes(&bytes)))
        .collect()
}

/// Starts the one-node Slurm in `scene`'s folder, or says why it cannot.
fn start(scene: &Scene) -> Option<Cluster> {
    match Cluster::start(&scene.root().join("slurm")) {
        Ok(c) => Some(c),
        Err(why) => {
            testkit::skip(format!("no Slurm here: {why}"));
            None
        }
    }
}

/// The shard ranges of `tasks` array tasks of `per_task` shards over `shards`.
fn ranges(shards: usize, per_task: usize) -> Vec<(usize, usize)> {
    (0..shards.div_ceil(per_task))
        .map(|t| (t * per_task, ((t + 1) * per_task).min(shards)))
        .collect()
}

#[test]
fn shard_array_then_train_and_score_equal_one_run() {
    let _one = ONE_CLUSTER.lock().unwrap_or_else(|e| e.into_inner());
    // 24 training + 8 test frames, 4 per shard: 8 shards, 3 per task: 3 tasks, the last
    // one shorter.
    let scene = Scene::new(4);
    std::fs::create_dir_all(scene.root().join("slurm")).unwrap();
    let Some(slurm) = start(&scene) else { return };
    scene.run_plain();

    let (array, tasks, train) = scene.submit(&slurm, &["--per-task", "3"]);
    assert_eq!(tasks, "0-2");
    let states = scene.wait_completed(&slurm, &[&array, &train]);
    assert_eq!(
        states.len(),
        4,
        "3 array tasks and the dependent job: {states:?}"
    );
    // One log per task, and the dependent job's.
    for t in 0..3 {
        let log = scene.logs.join(format!("pl2map-shards-{array}_{t}.out"));
        let text = std::fs::read_to_string(&log)
            .unwrap_or_else(|e| panic!("{}: {e}\n{}", log.display(), scene.job_logs()));
        assert!(text.contains(&format!("task {t} on ")), "{text}");
    }
    let log = scene.logs.join(format!("pl2map-train-score-{train}.out"));
    assert!(log.is_file(), "{}", scene.job_logs());
    scene.check_equals_one_run(&ranges(8, 3));

    // The per-scene scripts and the GPU variant are accepted by the scheduler as they
    // are (their datasets are not here, so they are not run): the array, the per-task
    // log and --gres=gpu:1 (-c 1 on this 2-CPU node instead of the GPU script's 4).
    for (script, extra) in [("scenes.sh", &[][..]), ("scenes-gpu.sh", &["-c", "1"][..])] {
        let out = slurm
            .cmd("sbatch")
            .args(["--test-only", "--array=0-6"])
            .args(extra)
            .arg(repo().join("deploy/slurm").join(script))
            .arg(repo().join("pipeline/7scenes.toml"))
            .arg(scene.root().join("scenes"))
            .current_dir(scene.root())
            .output()
            .unwrap();
        let said = String::from_utf8_lossy(&out.stderr);
        assert!(
            out.status.success() && said.contains("to start at"),
            "sbatch --test-only {script}: {said}"
        );
    }
}

#[test]
fn cancelled_array_task_resubmitted_alone_equals_one_run() {
    let _one = ONE_CLUSTER.lock().unwrap_or_else(|e| e.into_inner());
    // One frame per shard: 24 training shards, then 8 test shards. 24 per task: task 0
    // writes the training shards, task 1 the test shards.
    let scene = Scene::new(1);
    std::fs::create_dir_all(scene.root().join("slurm")).unwrap();
    let Some(slurm) = start(&scene) else { return };
    scene.run_plain();

    let (array, tasks, train) = scene.submit(&slurm, &["--per-task", "24"]);
    assert_eq!(tasks, "0-1");
    // Cancel task 0 as soon as its first shard is there.
    let shard_dir = scene.work.join("shard");
    let train_shards = || -> usize {
        std::fs::read_dir(&shard_dir).map_or(0, |d| {
            d.filter_map(Result::ok)
                .filter(|e| {
                    let n = e.file_name().to_string_lossy().into_owned();
                    n.starts_with("train-") && n.ends_with(".mcap")
                })
                .count()
        })
    };
    let start = Instant::now();
    while train_shards() == 0 {
        let states = slurm.states(&array);
        assert!(
            !states
                .iter()
                .any(|s| s.id == format!("{array}_0") && s.is_final()),
            "task 0 ended before it could be cancelled: {states:?}\n{}",
            scene.job_logs()
        );
        assert!(
            start.elapsed() < JOB_TIMEOUT,
            "task 0 wrote no shard: {states:?}\n{}",
            scene.job_logs()
        );
        std::thread::sleep(Duration::from_millis(2));
    }
    ok(
        slurm
            .cmd("scancel")
            .arg(format!("{array}_0"))
            .output()
            .unwrap(),
        "scancel",
    );
    let states = slurm.wait_final(&[&array, &train], JOB_TIMEOUT);
    let state = |id: &str| {
        states
            .iter()
            .find(|s| s.id == id)
            .unwrap_or_else(|| panic!("no {id} in {states:?}"))
    };
    assert_eq!(
        state(&format!("{array}_0")).state,
        "CANCELLED",
        "{states:?}\n{}",
        scene.job_logs()
    );
    assert_eq!(
        state(&format!("{array}_1")).state,
        "COMPLETED",
        "{states:?}"
    );
    // The dependent job never ran: afterok failed, --kill-on-invalid-dep cancelled it.
    let t = state(&train);
    assert_eq!(
        (t.state.as_str(), t.reason.as_str()),
        ("CANCELLED", "DependencyNeverSatisfied"),
        "{states:?}"
    );
    // Part way: some training shards, not all, no unit manifest, nothing complete.
    let written = train_shards();
    assert!(
        (1..24).contains(&written),
        "task 0 was not cancelled part way: {written} of 24 training shards"
    );
    assert!(!shard_dir.join("manifest.0-24.json").exists());
    assert!(shard_dir.join("manifest.24-32.json").is_file());
    assert!(!shard_dir.join("manifest.json").exists());
    assert!(!scene.work.join("train").exists());

    // Task 0 alone, and a new dependent job.
    let (again, tasks, train) = scene.submit(&slurm, &["--per-task", "24", "--tasks", "0"]);
    assert_eq!(tasks, "0");
    let states = scene.wait_completed(&slurm, &[&again, &train]);
    assert_eq!(states.len(), 2, "{states:?}");
    scene.check_equals_one_run(&ranges(32, 24));
}
