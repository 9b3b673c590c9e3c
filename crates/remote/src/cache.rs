//! The cache folder: one folder per set, named by the hash of its URL (and S3
//! endpoint), so two sets never mix; the least recently used sets of other URLs are
//! removed when a set needs room.
//!
//! Each set folder holds the set's files under their own names (what the train and
//! score stages read, crates/shards/src/shard_stage/checked.rs) and three files of the
//! cache's own:
//! - `.pl2map-set.json`: the URL and when the set was last materialised (the LRU order);
//! - `.use.lock`: locked shared by every process that materialised the set, for as long
//!   as it runs (or until [`crate::release`]); a set locked so is never removed;
//! - `.write.lock`: locked exclusively while a process fetches into the folder, so two
//!   processes that materialise one set take turns.

use crate::RemoteError;
use fileio::io_err;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::fs::{File, OpenOptions, TryLockError};
use std::path::{Path, PathBuf};
use std::sync::Mutex;

pub(crate) const SET_FILE: &str = ".pl2map-set.json";
pub(crate) const USE_LOCK: &str = ".use.lock";
pub(crate) const WRITE_LOCK: &str = ".write.lock";

/// The cache's own files in a set folder (not the set's).
pub(crate) fn is_cache_file(name: &str) -> bool {
    [SET_FILE, USE_LOCK, WRITE_LOCK].contains(&name)
}

/// The folder of the set named `key` (its URL, and the endpoint for S3).
pub(crate) fn set_folder(cache: &Path, key: &str) -> PathBuf {
    let h = stage::sha256_bytes(key.as_bytes());
    cache.join(&h[..32])
}

/// `.pl2map-set.json`.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub(crate) struct SetInfo {
    pub url: String,
    /// The S3 endpoint, empty for the default one and for HTTP.
    pub endpoint: String,
    /// Milliseconds since the Unix epoch.
    pub last_used_ms: u64,
}

impl SetInfo {
    pub fn save(&self, dir: &Path) -> Result<(), RemoteError> {
        let mut json = serde_json::to_vec_pretty(self).unwrap_or_default();
        json.push(b'\n');
        stage::write_atomic(dir.join(SET_FILE), &json)?;
        Ok(())
    }

    fn load(dir: &Path) -> Option<SetInfo> {
        let bytes = std::fs::read(dir.join(SET_FILE)).ok()?;
        serde_json::from_slice(&bytes).ok()
    }
}

pub(crate) fn now_ms() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_millis() as u64)
        .unwrap_or(0)
}

/// This process's shared locks on the sets it materialised, by folder.
static HELD: Mutex<BTreeMap<PathBuf, File>> = Mutex::new(BTreeMap::new());

/// Creates `dir` and locks its `.use.lock` shared for the rest of the process (once per
/// folder). A process that was removing the folder meanwhile holds the lock
/// exclusively: this waits for it, then starts over on a fresh folder.
pub(crate) fn hold(dir: &Path) -> Result<(), RemoteError> {
    let mut held = HELD.lock().unwrap_or_else(|p| p.into_inner());
    if held.contains_key(dir) && dir.join(USE_LOCK).is_file() {
        return Ok(());
    }
    loop {
        std::fs::create_dir_all(dir).map_err(io_err(dir))?;
        let path = dir.join(USE_LOCK);
        let file = open_lock(&path)?;
        file.lock_shared().map_err(io_err(&path))?;
        if same_file(&file, &path) {
            held.insert(dir.to_path_buf(), file);
            return Ok(());
        }
    }
}

/// Drops this process's hold on a set folder, so that another set may evict it.
pub fn release(dir: &Path) {
    HELD.lock().unwrap_or_else(|p| p.into_inner()).remove(dir);
}

fn held_here(dir: &Path) -> bool {
    HELD.lock()
        .unwrap_or_else(|p| p.into_inner())
        .contains_key(dir)
}

/// The exclusive write lock of a set folder, released when dropped.
pub(crate) fn lock_for_writing(dir: &Path) -> Result<File, RemoteError> {
    let path = dir.join(WRITE_LOCK);
    let file = open_lock(&path)?;
    file.lock().map_err(io_err(&path))?;
    Ok(file)
}

fn open_lock(path: &Path) -> Result<File, RemoteError> {
    Ok(OpenOptions::new()
        .create(true)
        .truncate(false)
        .write(true)
        .open(path)
        .map_err(io_err(path))?)
}

/// Whether the open `file` is still the one at `path` (not removed by an eviction).
fn same_file(file: &File, path: &Path) -> bool {
    use std::os::unix::fs::MetadataExt;
    match (file.metadata(), std::fs::metadata(path)) {
        (Ok(a), Ok(b)) => a.dev() == b.dev() && a.ino() == b.ino(),
        _ => false,
    }
}

/// Bytes of the regular files under `dir`.
fn folder_bytes(dir: &Path) -> u64 {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return 0;
    };
    entries
        .flatten()
        .map(|e| match e.file_type() {
            Ok(t) if t.is_dir() => folder_bytes(&e.path()),
            Ok(t) if t.is_file() => e.metadata().map(|m| m.len()).unwrap_or(0),
            _ => 0,
        })
        .sum()
}

/// Makes room for `needed` bytes in `own` (the set being materialised): removes the
/// least recently used other sets until all of them together with `needed` fit under
/// `max_bytes`. Sets in use (by this process or another) are kept; if they alone leave
/// too little room, nothing is removed and the error names them. Returns the URLs of
/// the removed sets.
pub(crate) fn make_room(
    cache: &Path,
    own: &Path,
    url: &str,
    needed: u64,
    max_bytes: u64,
) -> Result<Vec<String>, RemoteError> {
    if needed > max_bytes {
        return Err(RemoteError::TooLarge {
            url: url.to_string(),
            needed,
            max_bytes,
            folder: cache.to_path_buf(),
        });
    }
    // Other set folders, oldest first (ties by folder name: the same order every run).
    let mut others: Vec<(u64, PathBuf, String, u64)> = std::fs::read_dir(cache)
        .map_err(io_err(cache))?
        .flatten()
        .map(|e| e.path())
        .filter(|p| p != own && p.is_dir())
        .filter_map(|p| {
            let info = SetInfo::load(&p)?;
            let bytes = folder_bytes(&p);
            Some((info.last_used_ms, p, info.url, bytes))
        })
        .collect();
    others.sort();
    let mut total: u64 = others.iter().map(|o| o.3).sum();
    let mut evicted = Vec::new();
    let mut in_use: Vec<(String, u64)> = Vec::new();
    for (_, dir, set_url, bytes) in others {
        if total + needed <= max_bytes {
            break;
        }
        if held_here(&dir) || !try_remove(&dir)? {
            in_use.push((set_url, bytes));
            continue;
        }
        total -= bytes;
        evicted.push(set_url);
    }
    if total + needed > max_bytes {
        return Err(RemoteError::CacheFull {
            url: url.to_string(),
            folder: cache.to_path_buf(),
            needed,
            max_bytes,
            in_use: in_use.iter().map(|s| s.1).sum(),
            sets: in_use
                .iter()
                .map(|s| s.0.as_str())
                .collect::<Vec<_>>()
                .join(", "),
        });
    }
    Ok(evicted)
}

/// Removes a set folder unless a process holds it; whether it was removed.
fn try_remove(dir: &Path) -> Result<bool, RemoteError> {
    let path = dir.join(USE_LOCK);
    let file = open_lock(&path)?;
    match file.try_lock() {
        Ok(()) => {}
        Err(TryLockError::WouldBlock) => return Ok(false),
        Err(TryLockError::Error(e)) => return Err(io_err(&path)(e).into()),
    }
    // The set's info first: a folder half removed by a killed process is no set.
    match std::fs::remove_file(dir.join(SET_FILE)) {
        Ok(()) => {}
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
        Err(e) => return Err(io_err(dir.join(SET_FILE))(e).into()),
    }
    std::fs::remove_dir_all(dir).map_err(io_err(dir))?;
    Ok(true)
}
