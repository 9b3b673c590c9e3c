use crate::StageError;
use fileio::io_err;
use std::io::Write;
use std::path::{Path, PathBuf};

/// A file written under a temporary name in its destination folder and renamed to its
/// final name by `commit` (after an fsync). Dropped without `commit`, the temp file is
/// removed; killed, it leaves only a `.<name>.tmp*` file that no reader looks for.
pub struct AtomicFile {
    tmp: tempfile::NamedTempFile,
    dest: PathBuf,
}

impl AtomicFile {
    pub fn create(dest: impl AsRef<Path>) -> Result<Self, StageError> {
        let dest = dest.as_ref().to_path_buf();
        let dir = match dest.parent() {
            Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
            _ => PathBuf::from("."),
        };
        std::fs::create_dir_all(&dir).map_err(io_err(&dir))?;
        let prefix = format!(
            ".{}.",
            dest.file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default()
        );
        remove_stale_temps(&dir, &prefix)?;
        let mut builder = tempfile::Builder::new();
        builder.prefix(&prefix).suffix(".tmp");
        // tempfile creates 0600 files; outputs are ordinary files (0666 minus umask).
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            builder.permissions(std::fs::Permissions::from_mode(0o666));
        }
        let tmp = builder.tempfile_in(&dir).map_err(io_err(&dir))?;
        Ok(AtomicFile { tmp, dest })
    }

    pub fn file(&mut self) -> &mut std::fs::File {
        self.tmp.as_file_mut()
    }

    pub fn dest(&self) -> &Path {
        &self.dest
    }

    /// Flushes to disk and moves the file to its final name.
    pub fn commit(self) -> Result<(), StageError> {
        self.tmp.as_file().sync_all().map_err(io_err(&self.dest))?;
        let dest = self.dest;
        self.tmp
            .persist(&dest)
            .map_err(|e| fileio::IoError::new(&dest, e.error))?;
        Ok(())
    }
}

/// Removes the `.<name>.*.tmp` files a killed earlier writer of the same destination
/// left behind, so that a rerun ends with exactly the files of a clean run. (Two live
/// writers of one destination are already a conflict: the last rename would win.)
fn remove_stale_temps(dir: &Path, prefix: &str) -> Result<(), StageError> {
    let entries = std::fs::read_dir(dir).map_err(io_err(dir))?;
    for e in entries {
        let e = e.map_err(io_err(dir))?;
        let name = e.file_name();
        let name = name.to_string_lossy();
        if name.starts_with(prefix) && name.ends_with(".tmp") && name.len() > prefix.len() + 4 {
            let p = e.path();
            match std::fs::remove_file(&p) {
                Ok(()) => {}
                // Gone meanwhile: fine.
                Err(err) if err.kind() == std::io::ErrorKind::NotFound => {}
                Err(err) => return Err(io_err(&p)(err).into()),
            }
        }
    }
    Ok(())
}

impl Write for AtomicFile {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.tmp.write(buf)
    }
    fn flush(&mut self) -> std::io::Result<()> {
        self.tmp.flush()
    }
}

/// Writes `bytes` to `dest` atomically.
pub fn write_atomic(dest: impl AsRef<Path>, bytes: &[u8]) -> Result<(), StageError> {
    let mut f = AtomicFile::create(dest)?;
    let path = f.dest().to_path_buf();
    f.write_all(bytes).map_err(io_err(path))?;
    f.commit()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn commit_renames_and_drop_cleans_up() {
        let dir = tempfile::tempdir().unwrap();
        let dest = dir.path().join("sub/out.bin");
        write_atomic(&dest, b"hello").unwrap();
        assert_eq!(std::fs::read(&dest).unwrap(), b"hello");
        {
            let mut f = AtomicFile::create(dir.path().join("never.bin")).unwrap();
            f.write_all(b"partial").unwrap();
            // dropped without commit
        }
        let names: Vec<_> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names.len(), 1, "{names:?}");
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            let mode = std::fs::metadata(&dest).unwrap().permissions().mode() & 0o777;
            // Linux reports the process umask in /proc/self/status.
            let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
            if let Some(umask) = status
                .lines()
                .find_map(|l| l.strip_prefix("Umask:"))
                .and_then(|v| u32::from_str_radix(v.trim(), 8).ok())
            {
                assert_eq!(mode, 0o666 & !umask, "mode {mode:o} with umask {umask:o}");
            }
        }
    }

    #[test]
    fn a_rewrite_removes_what_a_killed_writer_left() {
        let dir = tempfile::tempdir().unwrap();
        // What a writer killed before `commit` leaves: `.<name>.<random>.tmp`.
        std::fs::write(dir.path().join(".out.bin.XYZ123.tmp"), b"partial").unwrap();
        // Another destination's temp file is not touched.
        std::fs::write(dir.path().join(".other.bin.ABC.tmp"), b"x").unwrap();
        write_atomic(dir.path().join("out.bin"), b"done").unwrap();
        let mut names: Vec<_> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        assert_eq!(names, [".other.bin.ABC.tmp", "out.bin"]);
    }
}
