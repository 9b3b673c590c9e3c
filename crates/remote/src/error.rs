use std::path::PathBuf;

/// Everything that can go wrong fetching a shard set. Each message names the URL (and
/// the shard) or the local file it is about.
#[derive(Debug, thiserror::Error)]
pub enum RemoteError {
    #[error("{url}: not a shard set URL ({reason})")]
    BadUrl { url: String, reason: String },

    #[error("{var}: {reason}")]
    Env { var: String, reason: String },

    /// The client's error after its retries (a refused connection, a timeout, a 5xx
    /// answer, a 403 for wrong credentials ...).
    #[error("{url}: fetching failed: {source}")]
    Fetch {
        url: String,
        #[source]
        source: object_store::Error,
    },

    #[error("{url}: uploading failed: {source}")]
    Upload {
        url: String,
        #[source]
        source: object_store::Error,
    },

    #[error("{url}: not found on the server")]
    NotFound { url: String },

    /// The set's manifest.json or stage.json is unreadable or disagrees with itself.
    #[error("{url}: {reason}")]
    Manifest { url: String, reason: String },

    #[error(
        "{url}: shard {shard} does not match the manifest: sha256 {got}, the manifest says \
         {expected} (damaged in storage or in transit, or the set is being republished); \
         nothing was kept"
    )]
    HashMismatch {
        url: String,
        shard: String,
        expected: String,
        got: String,
    },

    #[error(
        "{url}: shard {shard} is {got} bytes{more}, the manifest says {expected}; nothing was kept",
        more = if *.over { " or more" } else { "" }
    )]
    SizeMismatch {
        url: String,
        shard: String,
        expected: u64,
        got: u64,
        over: bool,
    },

    #[error(
        "{url}: the set needs {needed} bytes in the cache, more than its limit of {max_bytes} \
         bytes ({folder}; raise PL2MAP_SHARD_CACHE_MAX_GB or point PL2MAP_SHARD_CACHE elsewhere)"
    )]
    TooLarge {
        url: String,
        needed: u64,
        max_bytes: u64,
        folder: PathBuf,
    },

    #[error(
        "{url}: the cache {folder} cannot make room for {needed} bytes under its limit of \
         {max_bytes}: {in_use} bytes belong to sets in use by a running process ({sets}); \
         raise PL2MAP_SHARD_CACHE_MAX_GB or wait for them"
    )]
    CacheFull {
        url: String,
        folder: PathBuf,
        needed: u64,
        max_bytes: u64,
        in_use: u64,
        sets: String,
    },

    #[error("{url}: {reason}")]
    Runtime { url: String, reason: String },

    #[error(transparent)]
    Io(#[from] fileio::IoError),

    #[error(transparent)]
    Stage(#[from] stage::StageError),
}
