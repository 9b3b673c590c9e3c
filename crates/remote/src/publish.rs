//! Publishing a local shard folder to a URL (S3, or an HTTP server that takes PUT): the
//! shards first, each checked against the manifest, then stage.json, then the manifest
//! last, so that a reader never finds a manifest whose shards are not all there.

use crate::location::Location;
use crate::{FetchOptions, RemoteError};
use object_store::{ObjectStoreExt, PutPayload};
use shards::{MANIFEST_FILE, Manifest};
use std::path::Path;

/// Uploads the set in `folder` (manifest.json, the shards it lists, stage.json if there
/// is one) to `url`. Returns the uploaded file names in upload order.
pub fn publish(folder: &Path, url: &str, o: &FetchOptions) -> Result<Vec<String>, RemoteError> {
    let loc = Location::parse(url)?;
    let (store, _) = loc.store(o)?;
    let manifest_path = folder.join(MANIFEST_FILE);
    let manifest = Manifest::load(&manifest_path).map_err(|e| RemoteError::Manifest {
        url: manifest_path.display().to_string(),
        reason: e.to_string(),
    })?;
    let mut order = Vec::new();
    for s in &manifest.shards {
        let path = folder.join(&s.file);
        let now = stage::sha256_file(&path)?;
        if now != s.sha256 {
            return Err(RemoteError::HashMismatch {
                url: path.display().to_string(),
                shard: s.file.clone(),
                expected: s.sha256.clone(),
                got: now,
            });
        }
        order.push(s.file.clone());
    }
    if folder.join(stage::RECORD_FILE).is_file() {
        order.push(stage::RECORD_FILE.to_string());
    }
    order.push(MANIFEST_FILE.to_string());
    let runtime = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .map_err(|e| RemoteError::Runtime {
            url: loc.url.clone(),
            reason: format!("cannot start the network runtime: {e}"),
        })?;
    for file in &order {
        let path = folder.join(file);
        let bytes = std::fs::read(&path).map_err(fileio::io_err(&path))?;
        let target = loc.object_path(file)?;
        runtime
            .block_on(store.put(&target, PutPayload::from(bytes)))
            .map_err(|source| RemoteError::Upload {
                url: loc.file_url(file),
                source,
            })?;
    }
    Ok(order)
}
