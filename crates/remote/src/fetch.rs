//! Reading objects: a small file into memory (the manifest, stage.json) and a shard into
//! the cache under a temporary name, hashed as it streams in and renamed to its own name
//! only once its sha256 and size are the manifest's.

use crate::RemoteError;
use crate::location::Location;
use futures_util::StreamExt;
use object_store::{ObjectStore, ObjectStoreExt};
use sha2::{Digest, Sha256};
use std::io::Write;
use std::path::Path;

/// The client's error for `file`, naming its URL.
fn fetch_err(loc: &Location, file: &str, e: object_store::Error) -> RemoteError {
    match e {
        object_store::Error::NotFound { .. } => RemoteError::NotFound {
            url: loc.file_url(file),
        },
        source => RemoteError::Fetch {
            url: loc.file_url(file),
            source,
        },
    }
}

/// The bytes of `file`, or None when the server has no such object. Refused past
/// `limit` bytes (a manifest is small; a wrong URL may point at anything).
pub(crate) async fn small_file(
    store: &dyn ObjectStore,
    loc: &Location,
    file: &str,
    limit: u64,
) -> Result<Option<Vec<u8>>, RemoteError> {
    let path = loc.object_path(file)?;
    let result = match store.get(&path).await {
        Ok(r) => r,
        Err(object_store::Error::NotFound { .. }) => return Ok(None),
        Err(e) => return Err(fetch_err(loc, file, e)),
    };
    let mut bytes = Vec::new();
    let mut stream = result.into_stream();
    while let Some(chunk) = stream.next().await {
        let chunk = chunk.map_err(|e| fetch_err(loc, file, e))?;
        bytes.extend_from_slice(&chunk);
        if bytes.len() as u64 > limit {
            return Err(RemoteError::Manifest {
                url: loc.file_url(file),
                reason: format!("larger than {limit} bytes: not a shard set's {file}"),
            });
        }
    }
    Ok(Some(bytes))
}

/// Fetches the shard `file` into `dest`: written as `.<file>.*.tmp` beside it (a killed
/// fetch leaves only such a file, which the next one removes), checked, then renamed.
pub(crate) async fn shard(
    store: &dyn ObjectStore,
    loc: &Location,
    file: &str,
    sha256: &str,
    bytes: u64,
    dest: &Path,
) -> Result<(), RemoteError> {
    let path = loc.object_path(file)?;
    let result = store
        .get(&path)
        .await
        .map_err(|e| fetch_err(loc, file, e))?;
    let mut out = stage::AtomicFile::create(dest)?;
    let mut hash = Sha256::new();
    let mut got: u64 = 0;
    let mut stream = result.into_stream();
    while let Some(chunk) = stream.next().await {
        let chunk = chunk.map_err(|e| fetch_err(loc, file, e))?;
        got += chunk.len() as u64;
        if got > bytes {
            // Dropping `out` removes the temporary file.
            return Err(RemoteError::SizeMismatch {
                url: loc.file_url(file),
                shard: file.to_string(),
                expected: bytes,
                got,
                over: true,
            });
        }
        hash.update(&chunk);
        out.file().write_all(&chunk).map_err(fileio::io_err(dest))?;
    }
    if got != bytes {
        return Err(RemoteError::SizeMismatch {
            url: loc.file_url(file),
            shard: file.to_string(),
            expected: bytes,
            got,
            over: false,
        });
    }
    let got_sha = hex::encode(hash.finalize());
    if !got_sha.eq_ignore_ascii_case(sha256) {
        return Err(RemoteError::HashMismatch {
            url: loc.file_url(file),
            shard: file.to_string(),
            expected: sha256.to_string(),
            got: got_sha,
        });
    }
    out.commit()?;
    Ok(())
}
