//! Materialising one set: its manifest (fetched every time, so a republished set is
//! noticed), the shards the cache lacks or holds with another hash, then the manifest
//! and stage.json under their names, last.

use crate::cache::{self, SetInfo};
use crate::location::Location;
use crate::{CacheOptions, FetchOptions, RemoteError, fetch};
use futures_util::StreamExt;
use object_store::ObjectStore;
use shards::{MANIFEST_FILE, Manifest};
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

/// A manifest or stage.json larger than this is not one (the main job's manifest is a
/// few kB; a set of 100 000 shards would be ~30 MB).
const RECORD_LIMIT: u64 = 256 << 20;

/// What [`crate::materialize_with`] did.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SetReport {
    /// The set's normalised URL.
    pub url: String,
    /// The local folder (manifest.json, stage.json when the set has one, the shards).
    pub dir: PathBuf,
    /// Shards fetched now, in manifest order.
    pub fetched: Vec<String>,
    /// Shards the cache already held with the manifest's hash.
    pub reused: Vec<String>,
    /// Bytes of the fetched shards.
    pub fetched_bytes: u64,
    /// URLs of the sets removed from the cache to make room.
    pub evicted: Vec<String>,
}

impl SetReport {
    /// One line for a command's output.
    pub fn line(&self) -> String {
        let mut s = format!(
            "shards: {} -> {}: {} fetched ({:.1} MB), {} reused from the cache",
            self.url,
            self.dir.display(),
            self.fetched.len(),
            self.fetched_bytes as f64 / 1e6,
            self.reused.len()
        );
        if !self.evicted.is_empty() {
            s.push_str(&format!(
                "; removed from the cache: {}",
                self.evicted.join(", ")
            ));
        }
        s
    }
}

/// The record of the stage that wrote the set, as far as this crate reads it.
#[derive(serde::Deserialize)]
struct StageOutputs {
    outputs: std::collections::BTreeMap<String, String>,
}

pub(crate) fn materialize_set(
    source: &str,
    cache: &CacheOptions,
    o: &FetchOptions,
) -> Result<SetReport, RemoteError> {
    let loc = Location::parse(source)?;
    let (store, endpoint) = loc.store(o)?;
    let runtime = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .map_err(|e| RemoteError::Runtime {
            url: loc.url.clone(),
            reason: format!("cannot start the network runtime: {e}"),
        })?;
    let key = format!("{}\n{endpoint}", loc.url);
    let dir = cache::set_folder(&cache.folder, &key);
    cache::hold(&dir)?;
    let _writing = cache::lock_for_writing(&dir)?;
    SetInfo {
        url: loc.url.clone(),
        endpoint,
        last_used_ms: cache::now_ms(),
    }
    .save(&dir)?;
    runtime.block_on(fill(&*store, &loc, &dir, cache, o))
}

async fn fill(
    store: &dyn ObjectStore,
    loc: &Location,
    dir: &Path,
    cache: &CacheOptions,
    o: &FetchOptions,
) -> Result<SetReport, RemoteError> {
    let record = fetch::small_file(store, loc, stage::RECORD_FILE, RECORD_LIMIT).await?;
    let manifest_bytes = fetch::small_file(store, loc, MANIFEST_FILE, RECORD_LIMIT)
        .await?
        .ok_or_else(|| RemoteError::NotFound {
            url: loc.file_url(MANIFEST_FILE),
        })?;
    let manifest = checked(loc, &manifest_bytes, record.as_deref())?;

    let needed = manifest_bytes.len() as u64
        + record.as_ref().map_or(0, |r| r.len() as u64)
        + manifest.shards.iter().map(|s| s.bytes).sum::<u64>();
    let evicted = cache::make_room(&cache.folder, dir, &loc.url, needed, cache.max_bytes)?;
    remove_unlisted(dir, &manifest)?;

    // Cached shards whose hash is still the manifest's are kept; the rest are fetched,
    // a few at a time, errors reported in manifest order.
    let mut reused = Vec::new();
    let mut wanted = Vec::new();
    for s in &manifest.shards {
        let path = dir.join(&s.file);
        let cached = std::fs::metadata(&path).is_ok_and(|m| m.is_file() && m.len() == s.bytes)
            && stage::sha256_file(&path)?.eq_ignore_ascii_case(&s.sha256);
        if cached {
            reused.push(s.file.clone());
        } else {
            wanted.push(s);
        }
    }
    let bar = o
        .progress
        .then(|| stage::progress_bar(wanted.len() as u64, "fetch"));
    let results: Vec<Result<(), RemoteError>> = futures_util::stream::iter(&wanted)
        .map(|s| {
            let bar = bar.clone();
            async move {
                let r =
                    fetch::shard(store, loc, &s.file, &s.sha256, s.bytes, &dir.join(&s.file)).await;
                if let Some(b) = &bar {
                    b.set_message(s.file.clone());
                    b.inc(1);
                }
                r
            }
        })
        .buffered(o.concurrency.max(1))
        .collect()
        .await;
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    results.into_iter().collect::<Result<Vec<()>, _>>()?;

    // The set's records last: a folder with this manifest holds every shard it lists.
    match &record {
        Some(r) => stage::write_atomic(dir.join(stage::RECORD_FILE), r)?,
        None => remove_if_present(&dir.join(stage::RECORD_FILE))?,
    }
    stage::write_atomic(dir.join(MANIFEST_FILE), &manifest_bytes)?;
    Ok(SetReport {
        url: loc.url.clone(),
        dir: dir.to_path_buf(),
        fetched_bytes: wanted.iter().map(|s| s.bytes).sum(),
        fetched: wanted.iter().map(|s| s.file.clone()).collect(),
        reused,
        evicted,
    })
}

/// The manifest, parsed and checked against the set's stage.json where there is one:
/// the manifest's own hash and each shard's must be the ones the shard stage recorded
/// (the check crates/shards/src/shard_stage/checked.rs makes of a local folder, here
/// before anything is fetched, naming the URL). File names must be plain names.
fn checked(loc: &Location, bytes: &[u8], record: Option<&[u8]>) -> Result<Manifest, RemoteError> {
    let manifest_url = loc.file_url(MANIFEST_FILE);
    let bad = |url: &str, reason: String| RemoteError::Manifest {
        url: url.to_string(),
        reason,
    };
    let manifest: Manifest = serde_json::from_slice(bytes)
        .map_err(|e| bad(&manifest_url, format!("not a shard manifest: {e}")))?;
    let mut seen = BTreeSet::new();
    for s in &manifest.shards {
        let plain = !s.file.is_empty()
            && !s.file.starts_with('.')
            && !s.file.contains(['/', '\\', '\0'])
            && !cache::is_cache_file(&s.file)
            && s.file != MANIFEST_FILE
            && s.file != stage::RECORD_FILE;
        if !plain {
            return Err(bad(
                &manifest_url,
                format!("shard {}: {:?} is not a plain file name", s.index, s.file),
            ));
        }
        if !seen.insert(s.file.as_str()) {
            return Err(bad(&manifest_url, format!("{} is listed twice", s.file)));
        }
        if s.sha256.len() != 64 || !s.sha256.bytes().all(|c| c.is_ascii_hexdigit()) {
            return Err(bad(
                &manifest_url,
                format!("{}: {:?} is not a sha256", s.file, s.sha256),
            ));
        }
    }
    if let Some(record) = record {
        let record_url = loc.file_url(stage::RECORD_FILE);
        let rec: StageOutputs = serde_json::from_slice(record)
            .map_err(|e| bad(&record_url, format!("not a stage record: {e}")))?;
        let now = stage::sha256_bytes(bytes);
        match rec.outputs.get(MANIFEST_FILE) {
            Some(h) if h == &now => {}
            Some(h) => {
                return Err(bad(
                    &manifest_url,
                    format!(
                        "sha256 {now}, but {record_url} records {h} (a set being republished, \
                         or a damaged manifest)"
                    ),
                ));
            }
            None => {
                return Err(bad(
                    &record_url,
                    format!("does not list {MANIFEST_FILE} among its outputs"),
                ));
            }
        }
        for s in &manifest.shards {
            if rec.outputs.get(&s.file) != Some(&s.sha256) {
                return Err(bad(
                    &manifest_url,
                    format!(
                        "{}: sha256 {}, but {record_url} records {}",
                        s.file,
                        s.sha256,
                        rec.outputs.get(&s.file).map_or("nothing", String::as_str)
                    ),
                ));
            }
        }
    }
    Ok(manifest)
}

/// Removes files of an earlier version of the set that the manifest no longer lists,
/// so that the folder holds one set and its size is the set's.
fn remove_unlisted(dir: &Path, manifest: &Manifest) -> Result<(), RemoteError> {
    let keep: BTreeSet<&str> = manifest
        .shards
        .iter()
        .map(|s| s.file.as_str())
        .chain([MANIFEST_FILE, stage::RECORD_FILE])
        .collect();
    for e in std::fs::read_dir(dir).map_err(fileio::io_err(dir))? {
        let e = e.map_err(fileio::io_err(dir))?;
        let name = e.file_name().to_string_lossy().into_owned();
        if keep.contains(name.as_str()) || cache::is_cache_file(&name) {
            continue;
        }
        let p = e.path();
        let r = if e.file_type().is_ok_and(|t| t.is_dir()) {
            std::fs::remove_dir_all(&p)
        } else {
            std::fs::remove_file(&p)
        };
        r.map_err(fileio::io_err(&p))?;
    }
    Ok(())
}

fn remove_if_present(p: &Path) -> Result<(), RemoteError> {
    match std::fs::remove_file(p) {
        Ok(()) => Ok(()),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(()),
        Err(e) => Err(fileio::io_err(p)(e).into()),
    }
}
