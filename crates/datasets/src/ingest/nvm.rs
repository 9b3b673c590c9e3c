//! The camera block of a VisualSfM NVM_V3 file (Cambridge Landmarks'
//! `reconstruction.nvm`): `NVM_V3`, the camera count, then one line per camera
//! `name f qw qx qy qz Cx Cy Cz k 0`. Only the cameras are read (the focal lengths); the
//! point block that follows is not needed for ingest and is left unread.

use super::error::{IngestError, Result};
use super::text::{numbered_lines, parse_err, parse_f64, parse_usize, read_text};
use std::collections::HashMap;
use std::path::Path;

#[derive(Clone, Debug, PartialEq)]
pub struct NvmCamera {
    /// The name as written (Cambridge: `seq1/frame00001.jpg`).
    pub name: String,
    /// Focal length in pixels.
    pub focal: f64,
    pub line: usize,
}

/// Cameras of an NVM file, looked up by name without extension (the Cambridge files say
/// `.jpg` where the images are `.png`; matching on the path without its extension is the
/// explicit rule, and two cameras with the same stem are an error).
#[derive(Clone, Debug)]
pub struct NvmCameras {
    pub cameras: Vec<NvmCamera>,
    by_stem: HashMap<String, usize>,
}

/// `seq1/frame00001.jpg` -> `seq1/frame00001`: the extension of the last path component.
pub fn name_stem(name: &str) -> &str {
    let file_start = name.rfind('/').map_or(0, |i| i + 1);
    match name[file_start..].rfind('.') {
        Some(dot) if dot > 0 => &name[..file_start + dot],
        _ => name,
    }
}

impl NvmCameras {
    pub fn read(path: &Path) -> Result<NvmCameras> {
        let text = read_text(path, "NVM reconstruction")?;
        parse(path, &text)
    }

    /// The camera whose name has this stem.
    pub fn by_stem(&self, stem: &str) -> Option<&NvmCamera> {
        self.by_stem.get(stem).map(|&i| &self.cameras[i])
    }
}

const CAMERA_LINE: &str = "`name f qw qx qy qz Cx Cy Cz k 0` (11 fields)";

fn parse(path: &Path, text: &str) -> Result<NvmCameras> {
    let mut lines = numbered_lines(text).filter(|(_, l)| !l.trim().is_empty());
    let (line, header) = lines
        .next()
        .ok_or_else(|| parse_err(path, 1, "expected the NVM_V3 header, the file is empty"))?;
    if header.split_whitespace().next() != Some("NVM_V3") {
        return Err(parse_err(
            path,
            line,
            format!("expected the NVM_V3 header, got {:?}", header.trim()),
        ));
    }
    let (line, count) = lines
        .next()
        .ok_or_else(|| parse_err(path, line + 1, "expected the camera count, the file ends"))?;
    let count = parse_usize(path, line, count.trim(), "the camera count")?;
    // Bound the allocation by what the file can hold: one camera per remaining line.
    let remaining = text.bytes().filter(|&b| b == b'\n').count() + 1;
    if count > remaining {
        return Err(parse_err(
            path,
            line,
            format!("camera count {count} exceeds the {remaining} lines of the file"),
        ));
    }
    let mut cameras = Vec::with_capacity(count);
    let mut by_stem = HashMap::with_capacity(count);
    let mut last = line;
    for k in 0..count {
        let (line, l) = lines.next().ok_or_else(|| {
            parse_err(
                path,
                last + 1,
                format!("expected {count} cameras, the file ends after {k}"),
            )
        })?;
        last = line;
        let t: Vec<&str> = l.split_whitespace().collect();
        if t.len() != 11 {
            return Err(parse_err(
                path,
                line,
                format!("expected a camera {CAMERA_LINE}, found {} fields", t.len()),
            ));
        }
        let mut values = [0.0; 10];
        for (v, tok) in values.iter_mut().zip(&t[1..]) {
            *v = parse_f64(path, line, tok, "a camera field")?;
        }
        let focal = values[0];
        if !(focal.is_finite() && focal > 0.0) {
            return Err(parse_err(
                path,
                line,
                format!("expected a positive focal length, got {focal}"),
            ));
        }
        let name = t[0].to_string();
        let stem = name_stem(&name).to_string();
        if let Some(&first) = by_stem.get(&stem) {
            let first: &NvmCamera = &cameras[first];
            return Err(IngestError::Duplicate {
                path: path.to_path_buf(),
                line,
                name,
                first: format!("as {} at line {}", first.name, first.line),
            });
        }
        by_stem.insert(stem, cameras.len());
        cameras.push(NvmCamera { name, focal, line });
    }
    Ok(NvmCameras { cameras, by_stem })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p() -> &'static Path {
        Path::new("r.nvm")
    }

    #[test]
    fn reads_cameras_and_maps_jpg_to_png_by_stem() {
        let text = "NVM_V3\n\n2\nseq1/frame00001.jpg 1671.5 1 0 0 0 1 2 3 0 0\r\n\
                    seq1/frame00002.jpg 1670 0.5 0.5 0.5 0.5 4 5 6 -0.01 0\n\n1\n1 2 3 4 5 6 0\n";
        let c = parse(p(), text).unwrap();
        assert_eq!(c.cameras.len(), 2);
        assert_eq!(c.by_stem("seq1/frame00001").unwrap().focal, 1671.5);
        assert_eq!(c.by_stem("seq1/frame00002").unwrap().line, 5);
        assert!(c.by_stem("seq1/frame00003").is_none());
        assert_eq!(name_stem("seq1/frame00001.png"), "seq1/frame00001");
        assert_eq!(name_stem("a.b/c"), "a.b/c");
    }

    #[test]
    fn malformed_files_name_the_line() {
        let cases: [(&str, usize, &str); 8] = [
            ("", 1, "empty"),
            ("NVM_V2\n\n1\n", 1, "NVM_V3 header"),
            ("NVM_V3\n\nx\n", 3, "camera count"),
            ("NVM_V3\n\n999999\na 1 1 0 0 0 0 0 0 0 0\n", 3, "exceeds"),
            (
                "NVM_V3\n\n2\na 1 1 0 0 0 0 0 0 0 0\n",
                5,
                "file ends after 1",
            ),
            ("NVM_V3\n\n1\na 1 1 0 0 0 0 0 0 0\n", 4, "11 fields"),
            (
                "NVM_V3\n\n1\na f 1 0 0 0 0 0 0 0 0\n",
                4,
                "expected a number",
            ),
            ("NVM_V3\n\n1\na -5 1 0 0 0 0 0 0 0 0\n", 4, "positive focal"),
        ];
        for (text, want_line, want) in cases {
            match parse(p(), text) {
                Err(IngestError::Parse { line, message, .. }) => {
                    assert_eq!(line, want_line, "{text:?}: {message}");
                    assert!(message.contains(want), "{text:?}: {message}");
                }
                other => panic!("{text:?}: {other:?}"),
            }
        }
        let dup = "NVM_V3\n\n2\nseq1/a.jpg 1 1 0 0 0 0 0 0 0 0\nseq1/a.png 1 1 0 0 0 0 0 0 0 0\n";
        assert!(matches!(
            parse(p(), dup),
            Err(IngestError::Duplicate { line: 5, .. })
        ));
    }
}
