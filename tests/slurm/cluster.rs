//! A real one-node Slurm on 127.0.0.1 for tests/slurm.rs: MUNGE, slurmctld and slurmd
//! started from the Debian packages (scripts/setup-system.sh installs them) with their
//! configuration, state, spool, sockets and logs in one temporary folder, and stopped by
//! pid when the [`Cluster`] is dropped, also when a test panics.
//!
//! The container has no systemd and no cgroups to delegate: processes are tracked by
//! parentage (proctrack/linuxproc), tasks are not bound (task/none), nothing is accounted.

use std::fmt::Write as _;
use std::fs::File;
use std::os::unix::fs::PermissionsExt;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// The programs the tests run; a machine without any of them skips.
const PROGRAMS: [&str; 9] = [
    "munged",
    "slurmctld",
    "slurmd",
    "sbatch",
    "scancel",
    "scontrol",
    "sinfo",
    "squeue",
    "hostname",
];

/// Job states after which a job changes no more (`man squeue`, "JOB STATE CODES").
const FINAL_STATES: [&str; 11] = [
    "COMPLETED",
    "FAILED",
    "CANCELLED",
    "TIMEOUT",
    "NODE_FAIL",
    "OUT_OF_MEMORY",
    "PREEMPTED",
    "BOOT_FAIL",
    "DEADLINE",
    "REVOKED",
    "SPECIAL_EXIT",
];

/// A started daemon, stopped by its pid.
struct Daemon {
    name: &'static str,
    child: Child,
}

pub struct Cluster {
    dir: PathBuf,
    conf: PathBuf,
    /// In start order; stopped in reverse.
    daemons: Vec<Daemon>,
}

/// One array task or job as `scontrol show job` reports it.
#[derive(Clone, Debug)]
pub struct JobState {
    /// `<array job>_<task>` for an array task, else the job id.
    pub id: String,
    pub state: String,
    pub reason: String,
}

impl JobState {
    pub fn is_final(&self) -> bool {
        FINAL_STATES.contains(&self.state.as_str())
    }
}

impl Cluster {
    /// Configures and starts MUNGE, slurmctld and slurmd in `dir`, and waits until the
    /// node is idle. `Err` is the reason the test cannot run here (it then skips).
    pub fn start(dir: &Path) -> Result<Cluster, String> {
        if let Some(p) = PROGRAMS.iter().find(|p| which(p).is_none()) {
            return Err(format!(
                "`{p}` is not installed (scripts/setup-system.sh installs munge, slurmctld, \
                 slurmd and slurm-client)"
            ));
        }
        if run_out(Command::new("id").arg("-u"))?.trim() != "0" {
            return Err("slurmd runs the jobs and must be started as root".into());
        }
        let host = run_out(Command::new("hostname").arg("-s"))?
            .trim()
            .to_string();
        if host.is_empty() {
            return Err("`hostname -s` printed nothing".into());
        }
        // munged refuses a socket in a folder that others cannot enter, and a key that
        // others can read.
        chmod(dir, 0o755);
        for sub in ["munge", "key", "state", "spool", "log"] {
            std::fs::create_dir_all(dir.join(sub)).unwrap();
        }
        chmod(&dir.join("munge"), 0o755);
        chmod(&dir.join("key"), 0o700);
        let key = dir.join("key/munge.key");
        let mut random = vec![0u8; 1024];
        std::io::Read::read_exact(&mut File::open("/dev/urandom").unwrap(), &mut random).unwrap();
        std::fs::write(&key, &random).unwrap();
        chmod(&key, 0o600);

        let conf = dir.join("slurm.conf");
        std::fs::write(&conf, config(dir, &host, free_ports())).unwrap();
        // A GPU the scheduler can place `--gres=gpu:1` on (sbatch --test-only of
        // deploy/slurm/scenes-gpu.sh); no job here runs on it.
        std::fs::write(
            dir.join("gres.conf"),
            format!("NodeName={host} Name=gpu File=/dev/null\n"),
        )
        .unwrap();

        let mut cluster = Cluster {
            dir: dir.to_path_buf(),
            conf,
            daemons: Vec::new(),
        };
        let socket = dir.join("munge/munge.socket");
        cluster.spawn(
            "munged",
            Command::new(which("munged").unwrap())
                .arg("--foreground")
                .arg(format!("--key-file={}", key.display()))
                .arg(format!("--socket={}", socket.display()))
                .arg(format!(
                    "--pid-file={}",
                    dir.join("munge/munged.pid").display()
                ))
                .arg(format!(
                    "--seed-file={}",
                    dir.join("munge/munged.seed").display()
                )),
        )?;
        cluster.wait_for("the MUNGE socket", Duration::from_secs(20), |_| {
            socket.exists()
        })?;
        let conf = cluster.conf.clone();
        cluster.spawn(
            "slurmctld",
            Command::new(which("slurmctld").unwrap())
                .arg("-D")
                .arg("-f")
                .arg(&conf),
        )?;
        cluster.spawn(
            "slurmd",
            Command::new(which("slurmd").unwrap())
                .arg("-D")
                .arg("-f")
                .arg(&conf)
                .args(["-N", &host]),
        )?;
        cluster.wait_for("the node to be idle", Duration::from_secs(60), |c| {
            c.cmd("sinfo")
                .args(["--noheader", "--Node", "--format=%t"])
                .output()
                .is_ok_and(|o| String::from_utf8_lossy(&o.stdout).trim() == "idle")
        })?;
        Ok(cluster)
    }

    /// A Slurm command (sbatch, scontrol ...) or a script that runs them, talking to this
    /// cluster.
    pub fn cmd(&self, program: impl AsRef<std::ffi::OsStr>) -> Command {
        let mut c = Command::new(program);
        c.env("SLURM_CONF", &self.conf).stdin(Stdio::null());
        c
    }

    /// Every record of job `id` (an array job: one per task, pending tasks as one).
    pub fn states(&self, id: &str) -> Vec<JobState> {
        let out = self
            .cmd("scontrol")
            .args(["--oneliner", "show", "job", id])
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "scontrol show job {id}: {}\n{}",
            String::from_utf8_lossy(&out.stderr),
            self.logs()
        );
        String::from_utf8_lossy(&out.stdout)
            .lines()
            .filter(|l| !l.trim().is_empty())
            .map(|line| {
                let field = |name: &str| {
                    line.split_whitespace()
                        .find_map(|w| w.strip_prefix(name))
                        .unwrap_or("")
                        .to_string()
                };
                let id = match (field("ArrayJobId="), field("ArrayTaskId=")) {
                    (a, t) if !a.is_empty() && !t.is_empty() => format!("{a}_{t}"),
                    _ => field("JobId="),
                };
                JobState {
                    id,
                    state: field("JobState="),
                    reason: field("Reason="),
                }
            })
            .collect()
    }

    /// Waits until every record of each job is final (panics, with the logs, after
    /// `timeout`), and returns them.
    pub fn wait_final(&self, ids: &[&str], timeout: Duration) -> Vec<JobState> {
        let start = Instant::now();
        loop {
            let all: Vec<JobState> = ids.iter().flat_map(|id| self.states(id)).collect();
            if all.iter().all(JobState::is_final) {
                return all;
            }
            assert!(
                start.elapsed() < timeout,
                "jobs {ids:?} not done after {timeout:?}: {all:?}\n{}",
                self.logs()
            );
            std::thread::sleep(Duration::from_millis(200));
        }
    }

    /// The daemons' logs, for a failure message.
    pub fn logs(&self) -> String {
        let mut s = String::new();
        for d in &self.daemons {
            let path = self.log_path(d.name);
            let text = std::fs::read_to_string(&path).unwrap_or_default();
            let tail: Vec<&str> = text.lines().rev().take(40).collect();
            let _ = writeln!(s, "--- {} (last 40 lines)", path.display());
            for l in tail.iter().rev() {
                let _ = writeln!(s, "{l}");
            }
        }
        s
    }

    fn log_path(&self, name: &str) -> PathBuf {
        self.dir.join("log").join(format!("{name}.log"))
    }

    fn spawn(&mut self, name: &'static str, c: &mut Command) -> Result<(), String> {
        let log = File::create(self.log_path(name)).unwrap();
        let child = c
            .stdin(Stdio::null())
            .stdout(log.try_clone().unwrap())
            .stderr(log)
            .spawn()
            .map_err(|e| format!("starting {name}: {e}"))?;
        self.daemons.push(Daemon { name, child });
        Ok(())
    }

    fn wait_for(
        &mut self,
        what: &str,
        timeout: Duration,
        ready: impl Fn(&Cluster) -> bool,
    ) -> Result<(), String> {
        let start = Instant::now();
        while !ready(self) {
            let exited = self
                .daemons
                .iter_mut()
                .find_map(|d| match d.child.try_wait() {
                    Ok(Some(status)) => Some((d.name, status)),
                    _ => None,
                });
            if let Some((name, status)) = exited {
                return Err(format!(
                    "{name} exited ({status}) while waiting for {what}:\n{}",
                    self.logs()
                ));
            }
            if start.elapsed() > timeout {
                return Err(format!("no {what} after {timeout:?}:\n{}", self.logs()));
            }
            std::thread::sleep(Duration::from_millis(100));
        }
        Ok(())
    }
}

impl Drop for Cluster {
    /// Cancels what is left of the jobs, then stops the daemons by pid: SIGTERM, and
    /// SIGKILL for one still there after ten seconds.
    fn drop(&mut self) {
        if self.daemons.len() == 3 {
            let _ = self.cmd("scancel").arg("--user=root").status();
            let start = Instant::now();
            while start.elapsed() < Duration::from_secs(20) {
                let out = self.cmd("squeue").args(["--noheader"]).output();
                if out.is_ok_and(|o| o.stdout.is_empty()) {
                    break;
                }
                std::thread::sleep(Duration::from_millis(200));
            }
        }
        for d in self.daemons.iter_mut().rev() {
            let pid = d.child.id().to_string();
            let _ = Command::new("kill").args(["-TERM", &pid]).status();
            let start = Instant::now();
            loop {
                match d.child.try_wait() {
                    Ok(Some(_)) | Err(_) => break,
                    Ok(None) if start.elapsed() > Duration::from_secs(10) => {
                        let _ = d.child.kill();
                        let _ = d.child.wait();
                        break;
                    }
                    Ok(None) => std::thread::sleep(Duration::from_millis(50)),
                }
            }
        }
    }
}

/// slurm.conf (`man slurm.conf`, Slurm 22.05) for one node of this machine's 2 CPUs.
fn config(dir: &Path, host: &str, (ctld_port, slurmd_port): (u16, u16)) -> String {
    let d = dir.display();
    format!(
        "ClusterName=pl2maptest
SlurmctldHost={host}(127.0.0.1)
SlurmctldPort={ctld_port}
SlurmdPort={slurmd_port}
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket={d}/munge/munge.socket
StateSaveLocation={d}/state
SlurmdSpoolDir={d}/spool
SlurmctldPidFile={d}/slurmctld.pid
SlurmdPidFile={d}/slurmd.pid
MailProg=/bin/true
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
MpiDefault=none
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
ReturnToService=2
KillWait=5
MinJobAge=3600
GresTypes=gpu
NodeName={host} NodeAddr=127.0.0.1 CPUs=2 RealMemory=1000 Gres=gpu:1 State=UNKNOWN
PartitionName=pl2map Nodes={host} Default=YES MaxTime=INFINITE State=UP
"
    )
}

/// Two free TCP ports on 127.0.0.1 for slurmctld and slurmd (not Slurm's defaults, which
/// another Slurm on the machine may hold).
fn free_ports() -> (u16, u16) {
    let a = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let b = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    (
        a.local_addr().unwrap().port(),
        b.local_addr().unwrap().port(),
    )
}

fn which(program: &str) -> Option<PathBuf> {
    let path = std::env::var_os("PATH")?;
    // The daemons live in sbin, which a non-login PATH may lack.
    std::env::split_paths(&path)
        .chain(["/usr/sbin", "/sbin"].map(PathBuf::from))
        .map(|d| d.join(program))
        .find(|p| p.is_file())
}

fn run_out(c: &mut Command) -> Result<String, String> {
    let out = c.output().map_err(|e| format!("{c:?}: {e}"))?;
    if !out.status.success() {
        return Err(format!(
            "{c:?}: {}",
            String::from_utf8_lossy(&out.stderr).trim()
        ));
    }
    Ok(String::from_utf8_lossy(&out.stdout).into_owned())
}

fn chmod(path: &Path, mode: u32) {
    std::fs::set_permissions(path, std::fs::Permissions::from_mode(mode))
        .unwrap_or_else(|e| panic!("chmod {}: {e}", path.display()));
}
