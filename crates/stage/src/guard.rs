//! One writer per folder: a [`FolderGuard`] holds an operating-system file lock on
//! `<dir>/.pl2map.lock` for as long as a run or a stage writes there. (Named a guard,
//! not a lock, so that "lock" keeps one meaning in this repository: the lock files of
//! training sets, `manifests/*.toml`, crates/pipeline/src/lock.rs. The file on disk
//! keeps its name, so folders written before the rename behave the same.) The OS lock
//! dies with its process, so a SIGKILLed run never leaves a stale guard behind; the
//! file itself only says who holds it (pid, start time, command line) for the message a
//! second run prints.
//!
//! Exclusive for a whole run or a stage; shared for the shard stage's work units, which
//! write disjoint files of one folder side by side (a whole run then waits for them).
//! A busy folder is refused with the holder named, or waited for when the process asked
//! to wait ([`set_wait`], `--wait` on the command line).

use crate::StageError;
use fileio::io_err;
use std::fs::{File, OpenOptions, TryLockError};
use std::io::{Read, Seek, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{SystemTime, UNIX_EPOCH};

/// The guard's file in a folder (its OS lock is the guard; its text names the holder).
pub const GUARD_FILE: &str = ".pl2map.lock";

static WAIT: AtomicBool = AtomicBool::new(false);

/// `--wait` for the whole process: wait for a busy folder instead of refusing it.
pub fn set_wait(wait: bool) {
    WAIT.store(wait, Ordering::Relaxed);
}

/// How a folder is held.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GuardMode {
    /// One holder: a run or a stage.
    Exclusive,
    /// Several holders that write disjoint files (work units).
    Shared,
}

/// A held guard; released when dropped (or when the process ends, however it ends).
#[derive(Debug)]
pub struct FolderGuard {
    file: File,
    path: PathBuf,
    mode: GuardMode,
}

impl FolderGuard {
    /// Guards `dir` (created if needed). Refuses a folder another process holds, naming
    /// it, unless the process asked to wait.
    pub fn acquire(dir: &Path, mode: GuardMode) -> Result<FolderGuard, StageError> {
        FolderGuard::acquire_named(dir, GUARD_FILE, mode)
    }

    /// As [`FolderGuard::acquire`] with another guard file in `dir`: a guard on one step of
    /// the folder's work (the shard stage's merge of unit manifests).
    pub fn acquire_named(
        dir: &Path,
        name: &str,
        mode: GuardMode,
    ) -> Result<FolderGuard, StageError> {
        FolderGuard::open(dir, name, mode, WAIT.load(Ordering::Relaxed))
    }

    /// As [`FolderGuard::acquire_named`], always waiting: for short steps that take
    /// turns (never refused).
    pub fn wait_named(dir: &Path, name: &str, mode: GuardMode) -> Result<FolderGuard, StageError> {
        FolderGuard::open(dir, name, mode, true)
    }

    fn open(
        dir: &Path,
        name: &str,
        mode: GuardMode,
        wait: bool,
    ) -> Result<FolderGuard, StageError> {
        crate::require_folder(dir)?;
        std::fs::create_dir_all(dir).map_err(io_err(dir))?;
        let path = dir.join(name);
        let mut file = OpenOptions::new()
            .read(true)
            .write(true)
            .create(true)
            .truncate(false)
            .open(&path)
            .map_err(io_err(&path))?;
        let attempt = match mode {
            GuardMode::Exclusive => file.try_lock(),
            GuardMode::Shared => file.try_lock_shared(),
        };
        match attempt {
            Ok(()) => {}
            Err(TryLockError::WouldBlock) => {
                if !wait {
                    return Err(StageError::Busy {
                        dir: dir.to_path_buf(),
                        holder: holder(&mut file),
                    });
                }
                tracing::info!(
                    "{} is in use ({}): waiting",
                    dir.display(),
                    holder(&mut file)
                );
                match mode {
                    GuardMode::Exclusive => file.lock(),
                    GuardMode::Shared => file.lock_shared(),
                }
                .map_err(io_err(&path))?;
            }
            Err(TryLockError::Error(e)) => return Err(io_err(&path)(e).into()),
        }
        // Who holds it, for the message of a second run; written under the lock.
        // Shared holders all write the same line (they may overwrite each other).
        let text = match mode {
            GuardMode::Exclusive => {
                let now = SystemTime::now()
                    .duration_since(UNIX_EPOCH)
                    .map_or(0, |d| d.as_secs());
                let command: Vec<String> = std::env::args_os()
                    .map(|a| a.to_string_lossy().into_owned())
                    .collect();
                format!(
                    "pid {}\nstarted {now}\ncommand {}\n",
                    std::process::id(),
                    command.join(" ")
                )
            }
            GuardMode::Shared => SHARED_TEXT.to_string(),
        };
        file.set_len(0).map_err(io_err(&path))?;
        file.rewind().map_err(io_err(&path))?;
        file.write_all(text.as_bytes()).map_err(io_err(&path))?;
        Ok(FolderGuard { file, path, mode })
    }

    pub fn mode(&self) -> GuardMode {
        self.mode
    }

    pub fn path(&self) -> &Path {
        &self.path
    }
}

impl Drop for FolderGuard {
    fn drop(&mut self) {
        // The holder's name goes with it (a killed holder's stays until the next one
        // overwrites it; a shared holder may clear the line of others still holding,
        // who are then named "another process"). Closing the file releases the lock
        // too; unlocking first makes it explicit.
        let _ = self.file.set_len(0);
        let _ = self.file.unlock();
    }
}

const SHARED_TEXT: &str = "shared by work units\n";

/// "process 1234 (pl2map run ...), started 2026-12-02 21:04:05 UTC, 35 s ago" from the
/// guard file, or what is known.
fn holder(file: &mut File) -> String {
    let mut text = String::new();
    let _ = file.rewind();
    let _ = file.read_to_string(&mut text);
    let field = |key: &str| {
        text.lines()
            .find_map(|l| l.strip_prefix(key))
            .map(|v| v.trim().to_string())
    };
    match (field("pid "), field("started "), field("command ")) {
        (Some(pid), started, command) => {
            let started = started
                .and_then(|s| s.parse::<u64>().ok())
                .map(|s| {
                    let now = SystemTime::now()
                        .duration_since(UNIX_EPOCH)
                        .map_or(s, |d| d.as_secs());
                    format!(", started {}, {} s ago", utc(s), now.saturating_sub(s))
                })
                .unwrap_or_default();
            let command = command.map(|c| format!(" ({c})")).unwrap_or_default();
            format!("process {pid}{command}{started}")
        }
        _ if text == SHARED_TEXT => "work units of another process".to_string(),
        // Between taking the lock and writing its name.
        _ => "another process".to_string(),
    }
}

/// `YYYY-MM-DD hh:mm:ss UTC` of a Unix time (the proleptic Gregorian calendar, from the
/// day count: March-based years make the leap day the year's last).
fn utc(secs: u64) -> String {
    let (days, rem) = (secs / 86_400, secs % 86_400);
    let z = days as i64 + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1_460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    format!(
        "{year:04}-{month:02}-{day:02} {:02}:{:02}:{:02} UTC",
        rem / 3_600,
        rem % 3_600 / 60,
        rem % 60
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unix_times_read_as_utc_dates() {
        // Values from `date -u -d @N`.
        assert_eq!(utc(0), "1970-01-01 00:00:00 UTC");
        assert_eq!(utc(951_782_400), "2000-02-29 00:00:00 UTC");
        assert_eq!(utc(1_796_245_445), "2026-12-02 21:04:05 UTC");
    }

    #[test]
    fn exclusive_refuses_a_second_holder_and_names_the_first() {
        let dir = tempfile::tempdir().unwrap();
        let first = FolderGuard::acquire(dir.path(), GuardMode::Exclusive).unwrap();
        // A second open file description conflicts even within one process (flock).
        let e = FolderGuard::acquire(dir.path(), GuardMode::Exclusive).unwrap_err();
        let text = e.to_string();
        assert!(
            text.contains(&format!("process {}", std::process::id())),
            "{text}"
        );
        assert!(text.contains("--wait"), "{text}");
        assert!(FolderGuard::acquire(dir.path(), GuardMode::Shared).is_err());
        drop(first);
        let a = FolderGuard::acquire(dir.path(), GuardMode::Shared).unwrap();
        let b = FolderGuard::acquire(dir.path(), GuardMode::Shared).unwrap();
        assert!(FolderGuard::acquire(dir.path(), GuardMode::Exclusive).is_err());
        drop((a, b));
        FolderGuard::acquire(dir.path(), GuardMode::Exclusive).unwrap();
    }
}
