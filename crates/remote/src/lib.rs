//! Shard sets from object storage: `pl2map train --shards s3://bucket/prefix` (or
//! `https://host/path`, `http://` for a server of one's own) instead of a folder.
//!
//! [`materialize`] turns such a URL into a local folder that the train and score stages
//! read as they read the shard stage's own folder (crates/shards/src/shard_stage/checked.rs):
//! the set's `manifest.json`, its `stage.json` when it has one, and every shard the
//! manifest lists, each checked against the manifest's sha256 (and the manifest against
//! stage.json's record) before the folder is returned. The folder is in a cache
//! ([`CacheOptions`], `PL2MAP_SHARD_CACHE`): a shard already there with the manifest's
//! hash is not fetched again, while the manifest itself is fetched every time, so a set
//! republished under the same URL is noticed. The cache has a size limit
//! (`PL2MAP_SHARD_CACHE_MAX_GB`): the least recently used sets of other URLs are removed
//! to make room (never one a running process is using), and a set larger than the limit
//! alone is refused.
//!
//! The client is object_store's: S3 with the standard `AWS_*` environment variables
//! (`AWS_ACCESS_KEY_ID`, `AWS_SECRET_ACCESS_KEY`, `AWS_REGION`, `AWS_ENDPOINT_URL`,
//! `AWS_ALLOW_HTTP` ...), plain HTTP(S) GETs for a web server. A request that fails for
//! a reason worth retrying is retried with backoff ([`FetchOptions`]), then the error
//! names the URL. The API is blocking: each call runs a current-thread tokio runtime.

mod cache;
mod error;
mod fetch;
mod location;
mod options;
mod publish;
mod set;

pub use cache::release;
pub use error::RemoteError;
pub use location::is_remote;
pub use options::{
    CacheOptions, DEFAULT_MAX_GB, ENV_CACHE, ENV_CACHE_MAX_GB, ENV_REQUEST_TIMEOUT, ENV_RETRIES,
    ENV_RETRY_TIMEOUT, FetchOptions,
};
pub use publish::publish;
pub use set::SetReport;

use std::path::{Path, PathBuf};

/// A local folder holding the set's manifest.json (and stage.json if the set has one)
/// and every shard the manifest lists, each verified against the manifest's sha256
/// before it is returned; a folder path is returned as is. The client's settings come
/// from the environment ([`FetchOptions::from_env`]).
pub fn materialize(source: &str, opts: &CacheOptions) -> Result<PathBuf, RemoteError> {
    if !is_remote(source) {
        return Ok(PathBuf::from(source));
    }
    Ok(materialize_with(source, opts, &FetchOptions::from_env()?)?.dir)
}

/// [`materialize`] of a URL with the client's settings given, reporting what was
/// fetched, reused and evicted.
pub fn materialize_with(
    source: &str,
    opts: &CacheOptions,
    fetch: &FetchOptions,
) -> Result<SetReport, RemoteError> {
    set::materialize_set(source, opts, fetch)
}

/// A command's `--shards` argument: a folder as is (no report), a URL materialised with
/// the cache and client settings of the environment.
pub fn resolve(source: &Path) -> Result<(PathBuf, Option<SetReport>), RemoteError> {
    match source.to_str() {
        Some(s) if is_remote(s) => {
            let report =
                materialize_with(s, &CacheOptions::from_env()?, &FetchOptions::from_env()?)?;
            Ok((report.dir.clone(), Some(report)))
        }
        _ => Ok((source.to_path_buf(), None)),
    }
}
