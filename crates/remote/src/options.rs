//! The settings of the cache and of the client, and the environment variables they are
//! read from (documented in docs/operations.md, "Shards from object storage").

use crate::RemoteError;
use std::path::PathBuf;
use std::time::Duration;

/// Where fetched sets are kept: `PL2MAP_SHARD_CACHE`.
pub const ENV_CACHE: &str = "PL2MAP_SHARD_CACHE";
/// The cache's size limit in GB (10^9 bytes, decimals allowed): `PL2MAP_SHARD_CACHE_MAX_GB`.
pub const ENV_CACHE_MAX_GB: &str = "PL2MAP_SHARD_CACHE_MAX_GB";
/// Retries of a failed request: `PL2MAP_SHARD_RETRIES`.
pub const ENV_RETRIES: &str = "PL2MAP_SHARD_RETRIES";
/// Seconds after a request's first try past which it is not retried:
/// `PL2MAP_SHARD_RETRY_TIMEOUT_S`.
pub const ENV_RETRY_TIMEOUT: &str = "PL2MAP_SHARD_RETRY_TIMEOUT_S";
/// Seconds one request (one whole shard) may take: `PL2MAP_SHARD_REQUEST_TIMEOUT_S`.
pub const ENV_REQUEST_TIMEOUT: &str = "PL2MAP_SHARD_REQUEST_TIMEOUT_S";

/// The default limit: room for a few hundred thousand frames of shards.
pub const DEFAULT_MAX_GB: f64 = 20.0;

/// The local cache of fetched shard sets.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct CacheOptions {
    /// One folder per set URL below it.
    pub folder: PathBuf,
    /// The limit of all sets together, in bytes: the least recently used sets of other
    /// URLs are removed to stay under it, and a set larger than it alone is refused.
    pub max_bytes: u64,
}

impl CacheOptions {
    /// `PL2MAP_SHARD_CACHE` (default `$XDG_CACHE_HOME/pl2map-rs/shards`, else
    /// `$HOME/.cache/pl2map-rs/shards`) and `PL2MAP_SHARD_CACHE_MAX_GB` (default 20).
    pub fn from_env() -> Result<Self, RemoteError> {
        let folder = match env_nonempty(ENV_CACHE) {
            Some(f) => PathBuf::from(f),
            None => default_folder().ok_or_else(|| RemoteError::Env {
                var: ENV_CACHE.into(),
                reason: "not set, and neither is HOME (or XDG_CACHE_HOME) to put the \
                         cache under"
                    .into(),
            })?,
        };
        let max_gb = match env_nonempty(ENV_CACHE_MAX_GB) {
            Some(v) => parse_positive(ENV_CACHE_MAX_GB, &v)?,
            None => DEFAULT_MAX_GB,
        };
        Ok(CacheOptions {
            folder,
            max_bytes: (max_gb * 1e9) as u64,
        })
    }
}

fn default_folder() -> Option<PathBuf> {
    let base = env_nonempty("XDG_CACHE_HOME")
        .map(PathBuf::from)
        .or_else(|| env_nonempty("HOME").map(|h| PathBuf::from(h).join(".cache")))?;
    Some(base.join("pl2map-rs").join("shards"))
}

/// How sets are fetched.
#[derive(Clone, Debug, PartialEq)]
pub struct FetchOptions {
    /// Retries of a request that failed for a reason worth retrying (a refused or
    /// dropped connection, a timeout, a 5xx answer), with exponential backoff.
    pub retries: usize,
    /// No retry starts later than this after the request's first try.
    pub retry_timeout: Duration,
    /// One request, connecting to the last byte of a shard.
    pub request_timeout: Duration,
    /// Shards fetched at once.
    pub concurrency: usize,
    /// S3 settings applied over the `AWS_*` environment variables, by the names
    /// object_store's `AmazonS3ConfigKey` parses (`aws_endpoint`, `aws_access_key_id`,
    /// `aws_allow_http` ...): a program that talks to several stores sets them here.
    pub s3_config: Vec<(String, String)>,
    /// A progress bar on a terminal (crates/stage/src/progress.rs: hidden under --quiet
    /// and when stderr is not a terminal).
    pub progress: bool,
}

impl Default for FetchOptions {
    fn default() -> Self {
        FetchOptions {
            retries: 5,
            retry_timeout: Duration::from_secs(60),
            request_timeout: Duration::from_secs(600),
            concurrency: 4,
            s3_config: Vec::new(),
            progress: true,
        }
    }
}

impl FetchOptions {
    /// The defaults with `PL2MAP_SHARD_RETRIES`, `PL2MAP_SHARD_RETRY_TIMEOUT_S` and
    /// `PL2MAP_SHARD_REQUEST_TIMEOUT_S` where set.
    pub fn from_env() -> Result<Self, RemoteError> {
        let mut o = FetchOptions::default();
        if let Some(v) = env_nonempty(ENV_RETRIES) {
            o.retries = v.trim().parse().map_err(|_| RemoteError::Env {
                var: ENV_RETRIES.into(),
                reason: format!("{v:?} is not a whole number"),
            })?;
        }
        if let Some(v) = env_nonempty(ENV_RETRY_TIMEOUT) {
            o.retry_timeout = Duration::from_secs_f64(parse_positive(ENV_RETRY_TIMEOUT, &v)?);
        }
        if let Some(v) = env_nonempty(ENV_REQUEST_TIMEOUT) {
            o.request_timeout = Duration::from_secs_f64(parse_positive(ENV_REQUEST_TIMEOUT, &v)?);
        }
        Ok(o)
    }
}

fn env_nonempty(var: &str) -> Option<String> {
    std::env::var(var).ok().filter(|v| !v.trim().is_empty())
}

fn parse_positive(var: &str, v: &str) -> Result<f64, RemoteError> {
    match v.trim().parse::<f64>() {
        Ok(x) if x.is_finite() && x > 0.0 && x < 1e9 => Ok(x),
        _ => Err(RemoteError::Env {
            var: var.into(),
            reason: format!("{v:?} is not a positive number"),
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_are_checked() {
        assert_eq!(parse_positive("X", " 0.5 ").unwrap(), 0.5);
        for bad in ["0", "-1", "nan", "inf", "1e12", "lots"] {
            let e = parse_positive("X", bad).unwrap_err().to_string();
            assert!(e.starts_with("X: ") && e.contains("positive"), "{e}");
        }
    }
}
