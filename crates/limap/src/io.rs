//! File-level reading and writing: paths on errors, UTF-8 checks, atomic writes.

use fileio::{IoError, IoResultExt};
use std::io::Write as _;
use std::path::{Path, PathBuf};

use crate::alltracks::{AlltracksLayout, format_alltracks, parse_alltracks};
use crate::error::{LimapError, ParseError};
use crate::image_list::{ImageList, format_image_list, parse_image_list};
use crate::segments::{Segments, format_segments, parse_segments};
use crate::track::{LineTrack, format_track, parse_track, parse_track_allow_legacy};

pub(crate) fn read_text(path: &Path) -> Result<String, LimapError> {
    let bytes = std::fs::read(path).at(path)?;
    String::from_utf8(bytes).map_err(|e| LimapError::NotUtf8 {
        path: path.to_path_buf(),
        offset: e.utf8_error().valid_up_to(),
    })
}

fn read_with<T>(
    path: &Path,
    parse: impl FnOnce(&str) -> Result<T, ParseError>,
) -> Result<T, LimapError> {
    let text = read_text(path)?;
    parse(&text).map_err(|source| LimapError::Parse {
        path: path.to_path_buf(),
        source,
    })
}

pub fn read_track(path: impl AsRef<Path>) -> Result<LineTrack, LimapError> {
    read_with(path.as_ref(), parse_track)
}

/// Reads a track file that may be in the format of older LIMAP versions (no 2D segments).
pub fn read_track_allow_legacy(path: impl AsRef<Path>) -> Result<LineTrack, LimapError> {
    read_with(path.as_ref(), parse_track_allow_legacy)
}

pub fn read_alltracks(path: impl AsRef<Path>) -> Result<Vec<LineTrack>, LimapError> {
    read_with(path.as_ref(), parse_alltracks)
}

pub fn read_segments(path: impl AsRef<Path>) -> Result<Segments, LimapError> {
    read_with(path.as_ref(), parse_segments)
}

pub fn read_image_list(path: impl AsRef<Path>) -> Result<ImageList, LimapError> {
    read_with(path.as_ref(), parse_image_list)
}

pub fn write_track(path: impl AsRef<Path>, track: &LineTrack) -> Result<(), LimapError> {
    write_atomic(path.as_ref(), format_track(track)?.as_bytes())
}

pub fn write_alltracks<'a>(
    path: impl AsRef<Path>,
    tracks: impl IntoIterator<Item = &'a LineTrack>,
    layout: AlltracksLayout,
) -> Result<(), LimapError> {
    write_atomic(path.as_ref(), format_alltracks(tracks, layout)?.as_bytes())
}

pub fn write_segments(path: impl AsRef<Path>, segments: &Segments) -> Result<(), LimapError> {
    write_atomic(path.as_ref(), format_segments(segments)?.as_bytes())
}

pub fn write_image_list(path: impl AsRef<Path>, list: &ImageList) -> Result<(), LimapError> {
    write_atomic(path.as_ref(), format_image_list(list)?.as_bytes())
}

/// A sibling path that ends in `.tmp` (ignored by git) and is unique to this process.
pub(crate) fn temp_sibling(path: &Path) -> PathBuf {
    let mut name = path.file_name().unwrap_or_default().to_os_string();
    name.push(format!(".{}.tmp", std::process::id()));
    path.with_file_name(name)
}

/// Writes to a temporary sibling, syncs and renames, so a reader never sees half a file.
pub(crate) fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), LimapError> {
    let tmp = temp_sibling(path);
    let result = (|| {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
        std::fs::rename(&tmp, path)
    })();
    Ok(result.map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        IoError::new(path, e)
    })?)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn atomic_write_leaves_no_temp_file() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("image_list.txt");
        let list = ImageList {
            images: vec![(1, "a.png".into())],
        };
        write_image_list(&p, &list).unwrap();
        assert_eq!(read_image_list(&p).unwrap(), list);
        let names: Vec<_> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names, vec![std::ffi::OsString::from("image_list.txt")]);
    }

    #[test]
    fn errors_name_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("segments_3.txt");
        std::fs::write(&p, "2\n1 2 3 4\n").unwrap();
        let e = read_segments(&p).unwrap_err().to_string();
        assert!(e.contains("segments_3.txt") && e.contains("line 3"), "{e}");
        std::fs::write(&p, b"1\n1 2 \xff 4\n").unwrap();
        let e = read_segments(&p).unwrap_err().to_string();
        assert!(e.contains("offset 6"), "{e}");
        let e = read_segments(dir.path().join("missing.txt")).unwrap_err();
        assert!(matches!(e, LimapError::Io(_)));
    }
}
