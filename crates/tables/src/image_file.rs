//! Is an image file whole? A structural check of PNG and JPEG files, for the stages that
//! put images into the frames table (ingest) and copy them into shards.
//!
//! Decoders forgive truncation: a JPEG cut short decodes with the missing part filled in,
//! and some PNG readers stop at the last complete row. A damaged download would then
//! pass as a valid frame. This module walks the file's own structure instead: every PNG
//! chunk up to `IEND` (lengths and CRCs), and every JPEG marker segment and entropy-coded
//! scan up to `EOI`. It reads no pixels; the ingest stage decodes each image fully as
//! well (docs/errors.md lists both refusals). The bytes come from
//! `fileio::image::read_image`, which reads the header first and bounds what it reads.

/// The encodings the frames table accepts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Encoding {
    Png,
    Jpeg,
}

impl Encoding {
    /// The encoding whose signature starts `bytes`.
    pub fn sniff(bytes: &[u8]) -> Option<Self> {
        if bytes.starts_with(PNG_SIGNATURE) {
            Some(Encoding::Png)
        } else if bytes.starts_with(&[0xFF, 0xD8]) {
            Some(Encoding::Jpeg)
        } else {
            None
        }
    }
}

/// The image files of a folder ([`list`]).
#[derive(Debug, Default, PartialEq)]
pub struct Listing {
    /// Every image file, sorted by path.
    pub files: Vec<std::path::PathBuf>,
    /// One line per link that was not followed because it leads to a folder listed
    /// already (a link cycle such as `loop -> ..`, or a second path to one folder), for
    /// the caller to warn with.
    pub skipped: Vec<String>,
}

/// Every `.png`, `.jpg` and `.jpeg` file under `dir` (recursively, extension in any
/// case), sorted by path: the image folders `pl2map localize`, `pl2map features` and the
/// front-end bench read. Links are followed, but each folder is entered once: a link to
/// a folder entered already is named in [`Listing::skipped`] instead, so a link cycle
/// neither loops nor lists a file twice. Folders are walked in name order, so which of
/// two paths to one folder is kept does not depend on the order the OS lists them in.
pub fn list(dir: &std::path::Path) -> std::io::Result<Listing> {
    let mut listing = Listing::default();
    let mut entered = std::collections::HashSet::new();
    entered.insert(folder_id(dir)?);
    walk(dir, &mut entered, &mut listing)?;
    listing.files.sort();
    Ok(listing)
}

fn walk(
    dir: &std::path::Path,
    entered: &mut std::collections::HashSet<FolderId>,
    listing: &mut Listing,
) -> std::io::Result<()> {
    let mut paths = std::fs::read_dir(dir)?
        .map(|e| e.map(|e| e.path()))
        .collect::<std::io::Result<Vec<_>>>()?;
    paths.sort();
    for path in paths {
        if path.is_dir() {
            if entered.insert(folder_id(&path)?) {
                walk(&path, entered, listing)?;
            } else {
                let target = std::fs::canonicalize(&path).unwrap_or_else(|_| path.clone());
                listing.skipped.push(format!(
                    "{}: not entered: it leads to {}, a folder listed already (a link cycle, \
                     or a second path to the same folder)",
                    path.display(),
                    target.display()
                ));
            }
            continue;
        }
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase);
        if matches!(ext.as_deref(), Some("png" | "jpg" | "jpeg")) {
            listing.files.push(path);
        }
    }
    Ok(())
}

/// A folder's identity whichever path leads to it: device and inode.
#[cfg(unix)]
type FolderId = (u64, u64);

#[cfg(unix)]
fn folder_id(dir: &std::path::Path) -> std::io::Result<FolderId> {
    use std::os::unix::fs::MetadataExt;
    let m = std::fs::metadata(dir)?;
    Ok((m.dev(), m.ino()))
}

/// A folder's identity whichever path leads to it: its canonical path.
#[cfg(not(unix))]
type FolderId = std::path::PathBuf;

#[cfg(not(unix))]
fn folder_id(dir: &std::path::Path) -> std::io::Result<FolderId> {
    std::fs::canonicalize(dir)
}

const PNG_SIGNATURE: &[u8] = &[0x89, b'P', b'N', b'G', b'\r', b'\n', 0x1A, b'\n'];

/// Checks that `bytes` hold one whole PNG or JPEG file. The error says what is wrong
/// and at which byte offset, e.g. `truncated JPEG: the file ends at byte 30720 inside
/// the entropy-coded data of scan 1 (no end-of-image marker)`.
pub fn check_complete(bytes: &[u8]) -> Result<Encoding, String> {
    match Encoding::sniff(bytes) {
        Some(Encoding::Png) => check_png(bytes).map(|()| Encoding::Png),
        Some(Encoding::Jpeg) => check_jpeg(bytes).map(|()| Encoding::Jpeg),
        None => Err(format!(
            "neither a PNG nor a JPEG file (it starts with {:02X?})",
            &bytes[..bytes.len().min(8)]
        )),
    }
}

/// Chunk by chunk (length, type, data, CRC-32 over type and data) up to `IEND`.
fn check_png(bytes: &[u8]) -> Result<(), String> {
    let mut at = PNG_SIGNATURE.len();
    let mut idat = 0usize;
    loop {
        let Some(header) = bytes.get(at..at + 8) else {
            return Err(format!(
                "truncated PNG: the file ends at byte {} before its IEND chunk ({idat} image \
                 data chunks read)",
                bytes.len()
            ));
        };
        let len = u32::from_be_bytes([header[0], header[1], header[2], header[3]]) as usize;
        let kind = &header[4..8];
        let end = at + 8 + len + 4;
        if end > bytes.len() {
            return Err(format!(
                "truncated PNG: the {} chunk at byte {at} needs {} bytes, the file ends at \
                 byte {}",
                fileio::image::printable(kind),
                len + 12,
                bytes.len()
            ));
        }
        let stored = u32::from_be_bytes(bytes[end - 4..end].try_into().expect("4 bytes"));
        if fileio::image::crc32(&bytes[at + 4..end - 4]) != stored {
            return Err(format!(
                "corrupt PNG: the {} chunk at byte {at} fails its CRC check",
                fileio::image::printable(kind)
            ));
        }
        match kind {
            b"IDAT" => idat += 1,
            b"IEND" if idat == 0 => return Err("corrupt PNG: no image data chunk".into()),
            b"IEND" => return Ok(()),
            _ => {}
        }
        at = end;
    }
}

/// Marker segment by marker segment; a scan's entropy-coded data runs to the next marker
/// that is neither a stuffed `FF 00` nor a restart marker. Whole when `EOI` is reached
/// after at least one scan.
fn check_jpeg(bytes: &[u8]) -> Result<(), String> {
    let truncated = |at: usize, inside: String| {
        Err(format!(
            "truncated JPEG: the file ends at byte {} inside {inside} that starts at byte \
             {at} (no end-of-image marker)",
            bytes.len()
        ))
    };
    let mut at = 2;
    let mut scans = 0usize;
    loop {
        // Markers may be preceded by fill bytes 0xFF.
        while bytes.get(at) == Some(&0xFF) && bytes.get(at + 1) == Some(&0xFF) {
            at += 1;
        }
        if at + 1 >= bytes.len() {
            return truncated(at, "a marker".into());
        }
        if bytes[at] != 0xFF {
            return Err(format!(
                "corrupt JPEG: expected a marker at byte {at}, found {:02X}",
                bytes[at]
            ));
        }
        let marker = bytes[at + 1];
        match marker {
            0xD9 if scans == 0 => return Err("corrupt JPEG: end of image before any scan".into()),
            0xD9 => return Ok(()),
            // Standalone markers (TEM, RSTn outside a scan): no length.
            0x01 | 0xD0..=0xD7 => {
                at += 2;
                continue;
            }
            _ => {}
        }
        let Some(len) = bytes.get(at + 2..at + 4) else {
            return truncated(at, format!("marker segment {marker:02X}"));
        };
        let len = u16::from_be_bytes([len[0], len[1]]) as usize;
        if len < 2 {
            return Err(format!(
                "corrupt JPEG: marker segment {marker:02X} at byte {at} has length {len}"
            ));
        }
        let segment_end = at + 2 + len;
        if segment_end > bytes.len() {
            return truncated(at, format!("marker segment {marker:02X}"));
        }
        at = segment_end;
        if marker == 0xDA {
            scans += 1;
            let scan_start = at;
            loop {
                match (bytes.get(at), bytes.get(at + 1)) {
                    (Some(0xFF), Some(0x00 | 0xD0..=0xD7)) => at += 2,
                    (Some(0xFF), Some(0xFF)) => at += 1,
                    (Some(0xFF), Some(_)) => break,
                    (Some(_), _) => at += 1,
                    (None, _) => {
                        return truncated(
                            scan_start,
                            format!("the entropy-coded data of scan {scans}"),
                        );
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 2x1 grey PNG: signature, IHDR, one IDAT (zlib stored block), IEND.
    fn tiny_png() -> Vec<u8> {
        fn chunk(out: &mut Vec<u8>, kind: &[u8], data: &[u8]) {
            out.extend_from_slice(&(data.len() as u32).to_be_bytes());
            let mut body = kind.to_vec();
            body.extend_from_slice(data);
            out.extend_from_slice(&body);
            out.extend_from_slice(&fileio::image::crc32(&body).to_be_bytes());
        }
        let mut png = PNG_SIGNATURE.to_vec();
        chunk(&mut png, b"IHDR", &[0, 0, 0, 2, 0, 0, 0, 1, 8, 0, 0, 0, 0]);
        // zlib header, one final stored block of 3 bytes (filter 0, two pixels), adler32.
        let raw = [0u8, 10, 20];
        let mut z = vec![0x78, 0x01, 0x01, 3, 0, 0xFC, 0xFF];
        z.extend_from_slice(&raw);
        let (mut a, mut b) = (1u32, 0u32);
        for &x in &raw {
            a = (a + x as u32) % 65521;
            b = (b + a) % 65521;
        }
        z.extend_from_slice(&((b << 16) | a).to_be_bytes());
        chunk(&mut png, b"IDAT", &z);
        chunk(&mut png, b"IEND", &[]);
        png
    }

    #[test]
    fn a_whole_png_passes_and_every_cut_is_refused() {
        let png = tiny_png();
        assert_eq!(check_complete(&png), Ok(Encoding::Png));
        for cut in 8..png.len() {
            let e = check_complete(&png[..cut]).unwrap_err();
            assert!(e.starts_with("truncated PNG"), "cut {cut}: {e}");
        }
        let mut flipped = png.clone();
        flipped[40] ^= 0x01;
        assert!(check_complete(&flipped).unwrap_err().contains("CRC"));
    }

    #[test]
    fn a_jpeg_structure_is_walked_to_its_end_of_image() {
        // SOI, an APP0 segment, SOS with 3 bytes of entropy data containing a stuffed FF 00
        // and a restart marker, EOI. The walk needs structure, not valid pixels.
        let jpeg: Vec<u8> = vec![
            0xFF, 0xD8, 0xFF, 0xE0, 0x00, 0x04, 0xAA, 0xBB, 0xFF, 0xDA, 0x00, 0x03, 0x01, 0x12,
            0xFF, 0x00, 0x34, 0xFF, 0xD0, 0x56, 0xFF, 0xD9,
        ];
        assert_eq!(check_complete(&jpeg), Ok(Encoding::Jpeg));
        for cut in 2..jpeg.len() {
            let e = check_complete(&jpeg[..cut]).unwrap_err();
            assert!(e.starts_with("truncated JPEG"), "cut {cut}: {e}");
        }
        let no_scan = [0xFF, 0xD8, 0xFF, 0xD9];
        assert!(
            check_complete(&no_scan)
                .unwrap_err()
                .contains("before any scan")
        );
        assert!(check_complete(b"GIF89a").unwrap_err().contains("neither"));
    }

    #[test]
    fn a_chunk_type_of_control_bytes_is_escaped_in_the_message() {
        let mut png = tiny_png();
        // The IDAT chunk's type (bytes 37..41) made NULs: its CRC no longer matches.
        png[37..41].copy_from_slice(&[0, 0, 0, 0]);
        let e = check_complete(&png).unwrap_err();
        assert_eq!(
            e,
            "corrupt PNG: the \\x00\\x00\\x00\\x00 chunk at byte 33 fails its CRC check"
        );
        assert!(!e.contains('\0'));
        let cut = check_complete(&png[..45]).unwrap_err();
        assert!(cut.contains("the \\x00\\x00\\x00\\x00 chunk"), "{cut}");
    }

    #[cfg(unix)]
    #[test]
    fn a_link_cycle_is_not_followed_and_each_file_is_listed_once() {
        let dir = tempfile::tempdir().unwrap();
        let root = dir.path();
        std::fs::create_dir_all(root.join("a/b")).unwrap();
        for f in ["one.png", "a/two.JPG", "a/b/three.jpeg", "a/notes.txt"] {
            std::fs::write(root.join(f), b"x").unwrap();
        }
        // A cycle back to the root, one to a parent, and a second path to `a/b`.
        std::os::unix::fs::symlink("..", root.join("a/loop")).unwrap();
        std::os::unix::fs::symlink("..", root.join("a/b/up")).unwrap();
        std::os::unix::fs::symlink("a/b", root.join("z")).unwrap();
        let listing = list(root).unwrap();
        let rel: Vec<_> = listing
            .files
            .iter()
            .map(|p| p.strip_prefix(root).unwrap().to_str().unwrap())
            .collect();
        assert_eq!(rel, ["a/b/three.jpeg", "a/two.JPG", "one.png"]);
        assert_eq!(listing.skipped.len(), 3, "{:?}", listing.skipped);
        for (line, link) in listing.skipped.iter().zip(["a/b/up", "a/loop", "z"]) {
            assert!(
                line.starts_with(&root.join(link).display().to_string())
                    && line.contains("a folder listed already"),
                "{line}"
            );
        }
    }
}
