//! The Kubernetes manifests of the work units (deploy/k8s/): parsed as YAML and checked
//! for the fields they must have, and for running the commands of the Slurm scripts
//! (deploy/slurm/) that tests/slurm.rs runs on a real Slurm. There is no cluster here to
//! apply them to.

use yaml_rust2::{Yaml, YamlLoader};

fn load(name: &str) -> Yaml {
    let path = super::repo().join("deploy/k8s").join(name);
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut docs =
        YamlLoader::load_from_str(&text).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    assert_eq!(docs.len(), 1, "{name}: one document");
    docs.remove(0)
}

/// `doc.a.b.c`, panicking with the path where it is missing.
fn at<'a>(doc: &'a Yaml, path: &str) -> &'a Yaml {
    let mut y = doc;
    for key in path.split('.') {
        y = match key.parse::<usize>() {
            Ok(i) => &y[i],
            Err(_) => &y[key],
        };
        assert!(!y.is_badvalue(), "no {path} (at {key})");
    }
    y
}

fn str_at<'a>(doc: &'a Yaml, path: &str) -> &'a str {
    at(doc, path)
        .as_str()
        .unwrap_or_else(|| panic!("{path} is not a string"))
}

fn int_at(doc: &Yaml, path: &str) -> i64 {
    at(doc, path)
        .as_i64()
        .unwrap_or_else(|| panic!("{path} is not an integer"))
}

/// The container's command as its strings.
fn command(job: &Yaml) -> Vec<String> {
    at(job, "spec.template.spec.containers.0.command")
        .as_vec()
        .expect("command is a list")
        .iter()
        .map(|y| y.as_str().expect("command strings").to_string())
        .collect()
}

fn env(job: &Yaml, name: &str) -> String {
    at(job, "spec.template.spec.containers.0.env")
        .as_vec()
        .expect("env is a list")
        .iter()
        .find(|e| e["name"].as_str() == Some(name))
        .and_then(|e| e["value"].as_str())
        .unwrap_or_else(|| panic!("no env {name}"))
        .to_string()
}

/// Every Job: a batch/v1 Job that does not restart its pods in place, with the pipeline
/// file at /cfg (a ConfigMap, read-only) and the shared work folder at /mnt/work (a
/// claim), the paths its command names.
fn check_job(job: &Yaml, name: &str) {
    assert_eq!(str_at(job, "apiVersion"), "batch/v1", "{name}");
    assert_eq!(str_at(job, "kind"), "Job", "{name}");
    let pod = at(job, "spec.template.spec");
    assert_eq!(str_at(pod, "restartPolicy"), "Never", "{name}");
    let mounts = at(pod, "containers.0.volumeMounts").as_vec().unwrap();
    let volumes = at(pod, "volumes").as_vec().unwrap();
    let mount = |path: &str| {
        let m = mounts
            .iter()
            .find(|m| m["mountPath"].as_str() == Some(path))
            .unwrap_or_else(|| panic!("{name}: nothing mounted at {path}"));
        let volume = m["name"].as_str().unwrap();
        let v = volumes
            .iter()
            .find(|v| v["name"].as_str() == Some(volume))
            .unwrap_or_else(|| panic!("{name}: no volume {volume}"));
        (m.clone(), v.clone())
    };
    let (m, v) = mount("/cfg");
    assert_eq!(
        m["readOnly"].as_bool(),
        Some(true),
        "{name}: /cfg read-only"
    );
    assert!(
        v["configMap"]["name"].as_str().is_some(),
        "{name}: /cfg from a ConfigMap"
    );
    let (m, v) = mount("/mnt/work");
    assert_ne!(
        m["readOnly"].as_bool(),
        Some(true),
        "{name}: /mnt/work is written"
    );
    assert!(
        v["persistentVolumeClaim"]["claimName"].as_str().is_some(),
        "{name}: /mnt/work on a claim every pod shares"
    );
}

/// The line of a deploy/slurm script that runs pl2map.
fn slurm_exec_line(script: &str) -> String {
    let path = super::repo().join("deploy/slurm").join(script);
    let text = std::fs::read_to_string(&path).unwrap();
    text.lines()
        .find(|l| l.starts_with("exec \"${PL2MAP:-pl2map}\""))
        .unwrap_or_else(|| panic!("{}: no exec line", path.display()))
        .to_string()
}

/// A manifest's pl2map command as the Slurm scripts write it: the same arguments, with
/// the pipeline file and the work folder as the scripts' variables.
fn as_slurm_line(line: &str) -> String {
    line.replace("exec pl2map ", "exec \"${PL2MAP:-pl2map}\" ")
        .replace("/cfg/pipeline.toml", "\"$pipeline\"")
        .replace("/mnt/work", "\"$work\"")
}

#[test]
fn k8s_indexed_job_runs_the_shard_units_of_the_slurm_array() {
    let job = load("shards-job.yaml");
    check_job(&job, "shards-job.yaml");
    assert_eq!(str_at(&job, "spec.completionMode"), "Indexed");
    let completions = int_at(&job, "spec.completions");
    let parallelism = int_at(&job, "spec.parallelism");
    assert!(parallelism >= 1 && parallelism <= completions);
    assert!(
        int_at(&job, "spec.backoffLimitPerIndex") >= 1,
        "an index retried alone"
    );
    // One completion per unit: ceil(SHARDS / PER_TASK).
    let shards: i64 = env(&job, "SHARDS").parse().unwrap();
    let per_task: i64 = env(&job, "PER_TASK").parse().unwrap();
    assert_eq!(completions, (shards + per_task - 1) / per_task);

    let cmd = command(&job);
    assert_eq!(cmd[..2], ["/bin/sh", "-c"]);
    let script = &cmd[2];
    assert!(
        script.contains("$((JOB_COMPLETION_INDEX * PER_TASK))"),
        "{script}"
    );
    let exec = script
        .lines()
        .find(|l| l.trim_start().starts_with("exec "))
        .expect("an exec line")
        .trim();
    assert_eq!(
        exec,
        "exec pl2map run /cfg/pipeline.toml --work /mnt/work --until shard --shards \"$start..$end\""
    );
    assert_eq!(as_slurm_line(exec), slurm_exec_line("shards.sh"));
}

#[test]
fn k8s_prepare_and_dependent_jobs_run_the_slurm_commands() {
    let prepare = load("prepare-job.yaml");
    check_job(&prepare, "prepare-job.yaml");
    assert_eq!(
        command(&prepare).join(" "),
        "pl2map run /cfg/pipeline.toml --work /mnt/work --until refine"
    );
    // The prepare step of deploy/slurm/submit.sh.
    let submit = std::fs::read_to_string(super::repo().join("deploy/slurm/submit.sh")).unwrap();
    assert!(
        submit.contains("\"$pl2map\" --quiet run \"$pipeline\" --work \"$work\" --until refine")
    );

    let train = load("train-score-job.yaml");
    check_job(&train, "train-score-job.yaml");
    assert!(train["spec"]["completionMode"].is_badvalue(), "one pod");
    let cmd = command(&train).join(" ");
    assert_eq!(cmd, "pl2map run /cfg/pipeline.toml --work /mnt/work");
    assert_eq!(
        format!("{} \"$@\"", as_slurm_line(&format!("exec {cmd}"))),
        slurm_exec_line("train-score.sh")
    );
    // No Job is left without its manifest being checked.
    let mut names: Vec<String> = std::fs::read_dir(super::repo().join("deploy/k8s"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(
        names,
        [
            "prepare-job.yaml",
            "shards-job.yaml",
            "train-score-job.yaml"
        ]
    );
}
