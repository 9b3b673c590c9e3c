use crate::StageError;
use fileio::io_err;
use serde::Serialize;
use sha2::{Digest, Sha256};
use std::io::Read;
use std::path::Path;

pub fn sha256_bytes(bytes: &[u8]) -> String {
    hex::encode(Sha256::digest(bytes))
}

/// sha256 of a file's contents, streamed.
pub fn sha256_file(path: &Path) -> Result<String, StageError> {
    // Inputs are files: a device (`/dev/zero`), a FIFO or a folder would be read
    // forever, or block, instead of being refused.
    let meta = std::fs::metadata(path).map_err(io_err(path))?;
    if !meta.is_file() {
        return Err(io_err(path)(std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            "not a regular file: an input must be a file",
        ))
        .into());
    }
    let mut f = std::fs::File::open(path).map_err(io_err(path))?;
    let mut h = Sha256::new();
    let mut buf = vec![0u8; 1 << 20];
    loop {
        let n = f.read(&mut buf).map_err(io_err(path))?;
        if n == 0 {
            break;
        }
        h.update(&buf[..n]);
    }
    Ok(hex::encode(h.finalize()))
}

/// One hash over several files: each file's relative name and content hash, in the
/// given order (callers sort), so a renamed or reordered input changes the hash.
pub fn sha256_files<'a>(
    root: &Path,
    rel_paths: impl IntoIterator<Item = &'a str>,
) -> Result<String, StageError> {
    let mut h = Sha256::new();
    for rel in rel_paths {
        let fh = sha256_file(&root.join(rel))?;
        h.update(rel.as_bytes());
        h.update([0]);
        h.update(fh.as_bytes());
        h.update([b'\n']);
    }
    Ok(hex::encode(h.finalize()))
}

/// Hash of a configuration: sha256 of its JSON serialisation. serde_json writes struct
/// fields in declaration order and maps as the map iterates (use BTreeMap), so the
/// hash is stable for a given config type.
pub fn hash_config<T: Serialize>(config: &T) -> Result<String, StageError> {
    let json = serde_json::to_vec(config).map_err(StageError::Config)?;
    Ok(sha256_bytes(&json))
}

#[cfg(test)]
mod tests {
    /// `/dev/zero` (and any non-file) is refused by name at once, not hashed forever.
    #[test]
    fn a_device_or_folder_is_refused_not_hashed() {
        for p in ["/dev/zero", "/"] {
            let e = sha256_file(Path::new(p)).unwrap_err().to_string();
            assert!(e.contains(p) && e.contains("not a regular file"), "{e}");
        }
    }

    use super::*;

    #[test]
    fn known_digest() {
        // sha256("abc") from FIPS 180-2.
        assert_eq!(
            sha256_bytes(b"abc"),
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
        );
    }
}
