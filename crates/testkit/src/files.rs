//! Folder walkers and copies, for the byte-identity checks ("same inputs, same bytes")
//! and for tests that alter a copy of a fixture folder.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Every file under `root` (recursively), as paths relative to `root`, sorted.
pub fn files(root: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    walk(root, root, &mut |rel, _| out.push(rel.to_path_buf()));
    out.sort();
    out
}

/// The bytes of every file under `root` (recursively), by path relative to `root`.
pub fn folder_bytes(root: &Path) -> BTreeMap<String, Vec<u8>> {
    let mut out = BTreeMap::new();
    walk(root, root, &mut |rel, path| {
        let bytes =
            std::fs::read(path).unwrap_or_else(|e| panic!("reading {}: {e}", path.display()));
        out.insert(rel.to_string_lossy().into_owned(), bytes);
    });
    out
}

/// Copies the folder `from` into `to` (created if missing), recursively.
pub fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap_or_else(|e| panic!("creating {}: {e}", to.display()));
    for path in entries(from) {
        let target = to.join(path.file_name().expect("a named entry"));
        if path.is_dir() {
            copy_dir(&path, &target);
        } else {
            std::fs::copy(&path, &target).unwrap_or_else(|e| {
                panic!("copying {} to {}: {e}", path.display(), target.display())
            });
        }
    }
}

/// Calls `visit(path relative to root, path)` for every file under `dir` (anything not
/// a folder), recursively.
fn walk(root: &Path, dir: &Path, visit: &mut dyn FnMut(&Path, &Path)) {
    for path in entries(dir) {
        if path.is_dir() {
            walk(root, &path, visit);
        } else {
            visit(path.strip_prefix(root).expect("below the root"), &path);
        }
    }
}

/// The paths of the entries of `dir`.
fn entries(dir: &Path) -> Vec<PathBuf> {
    std::fs::read_dir(dir)
        .and_then(|entries| entries.map(|e| e.map(|e| e.path())).collect())
        .unwrap_or_else(|e| panic!("listing {}: {e}", dir.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn copies_and_walks_nested_folders() {
        let dir = tempfile::tempdir().unwrap();
        let src = dir.path().join("src");
        std::fs::create_dir_all(src.join("b/c")).unwrap();
        std::fs::write(src.join("a.txt"), b"a").unwrap();
        std::fs::write(src.join("b/c/d.bin"), [0u8, 1, 2]).unwrap();
        std::fs::write(src.join("b/e.txt"), b"e").unwrap();
        let dst = dir.path().join("dst");
        copy_dir(&src, &dst);
        let want: Vec<PathBuf> = ["a.txt", "b/c/d.bin", "b/e.txt"]
            .iter()
            .map(PathBuf::from)
            .collect();
        assert_eq!(files(&src), want);
        assert_eq!(files(&dst), want);
        let bytes = folder_bytes(&dst);
        assert_eq!(bytes, folder_bytes(&src));
        assert_eq!(bytes[Path::new("b/c/d.bin").to_str().unwrap()], [0u8, 1, 2]);
    }
}
