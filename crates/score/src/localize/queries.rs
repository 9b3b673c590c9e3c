//! The images `pl2map localize` reads: hloc's query list with intrinsics
//! (`name MODEL W H PARAMS...` per line, any COLMAP camera model) or a folder of images
//! sharing one camera. A line that does not parse, a name listed twice, a missing or
//! unreadable image are recorded against their query (file and line named) instead of
//! stopping the others (docs/formats.md, "Query lists").

use crate::error::ScoreError;
use crate::localiser::TestFrame;
use fileio::io_err;
use geometry::{Camera, Pose};
use shards::{FrameRecord, ImageFormat, Split};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// One image to localise.
#[derive(Clone, Debug, PartialEq)]
pub struct Query {
    /// 0-based position among the queries: the `id` column of the table. (RANSAC is
    /// seeded by the name, [`crate::evaluate::frame_seed`], not by this position.)
    pub id: u64,
    /// Path relative to the images folder, `/`-separated (the results file's key).
    pub name: String,
    /// Where the query comes from: `<list>:<line>`, or the image path for a folder.
    pub origin: String,
    /// The camera, or why the line gave none.
    pub camera: Result<Camera, String>,
}

/// Parses hloc's `queries_with_intrinsics.txt`: one `name MODEL WIDTH HEIGHT PARAMS...`
/// per line, blank lines and `#` comments skipped, model names as COLMAP's
/// (case-insensitive). Only an unreadable list is an error; a bad line becomes a query
/// whose camera is the reason.
pub fn read_query_list(path: &Path) -> Result<Vec<Query>, ScoreError> {
    let bytes = std::fs::read(path).map_err(io_err(path))?;
    let text = String::from_utf8(bytes).map_err(|e| ScoreError::QueryList {
        path: path.to_path_buf(),
        line: text_line_of(e.as_bytes(), e.utf8_error().valid_up_to()),
        reason: "not UTF-8 text".into(),
    })?;
    Ok(parse_query_list(&text, path))
}

fn text_line_of(bytes: &[u8], offset: usize) -> usize {
    1 + bytes[..offset].iter().filter(|&&b| b == b'\n').count()
}

/// [`read_query_list`] on text already read (`path` names it in the origins).
pub fn parse_query_list(text: &str, path: &Path) -> Vec<Query> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut out: Vec<Query> = Vec::new();
    let mut first_line: HashMap<String, usize> = HashMap::new();
    for (i, raw) in text.lines().enumerate() {
        let line = raw.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let (name, spec) = match line.split_once(char::is_whitespace) {
            Some((n, rest)) => (n, rest.trim()),
            None => (line, ""),
        };
        let camera = if spec.is_empty() {
            Err("no camera after the image name (expected `name MODEL W H PARAMS...`)".into())
        } else {
            pose::io::parse_camera(spec).map_err(|e| format!("camera: {e}"))
        };
        let camera = match first_line.get(name) {
            Some(first) => Err(format!("{name} is listed twice (first at line {first})")),
            None => camera,
        };
        first_line.entry(name.to_string()).or_insert(i + 1);
        out.push(Query {
            id: out.len() as u64,
            name: name.to_string(),
            origin: format!("{}:{}", path.display(), i + 1),
            camera,
        });
    }
    out
}

/// Every `.png`, `.jpg` and `.jpeg` under `dir` (recursively, any case), named by its
/// `/`-separated path relative to `dir`, in byte order, all with `camera`. A name with
/// whitespace (which the results file cannot hold) becomes a failed query.
pub fn folder_queries(dir: &Path, camera: &Camera) -> Result<Vec<Query>, ScoreError> {
    let files = tables::image_file::list(dir).map_err(io_err(dir))?;
    let mut names: Vec<String> = files
        .iter()
        .map(|path| {
            let rel = path.strip_prefix(dir).unwrap_or(path);
            let parts: Vec<String> = rel
                .components()
                .map(|c| c.as_os_str().to_string_lossy().into_owned())
                .collect();
            parts.join("/")
        })
        .collect();
    names.sort();
    Ok(names
        .into_iter()
        .enumerate()
        .map(|(i, name)| Query {
            id: i as u64,
            origin: dir.join(&name).display().to_string(),
            camera: if name.chars().any(char::is_whitespace) {
                Err("the name contains whitespace, which the results file cannot hold".into())
            } else {
                Ok(camera.clone())
            },
            name,
        })
        .collect())
}

/// The image of a query as a frame to localise (no ground truth: identity pose, never
/// read), or why it cannot be one. Decoding and the size check against the camera
/// happen in the localiser, as for the score stage's frames.
pub fn load_query(images: &Path, q: &Query) -> Result<TestFrame, String> {
    let camera = q.camera.clone()?;
    let path: PathBuf = images.join(&q.name);
    let bytes = std::fs::read(&path).map_err(|e| format!("{}: {e}", path.display()))?;
    // The structural check ingest makes: a file cut short is refused with the byte
    // offset instead of being decoded with its missing part filled in.
    let format: ImageFormat = tables::image_file::check_complete(&bytes)
        .map_err(|reason| format!("{}: {reason}", path.display()))?
        .into();
    Ok(TestFrame {
        record: FrameRecord::unlabelled(
            q.id,
            q.name.clone(),
            Split::Test,
            camera,
            Pose::identity(),
            bytes,
            format,
        ),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_hloc_lines_and_records_bad_ones() {
        let text = "\u{feff}# queries\nseq-01/a.png SIMPLE_PINHOLE 640 480 525 320 240\n\n\
                    b.jpg pinhole 10 8 5 5 5 4\nc.png SIMPLE_RADIAL 640 480 500 320\n\
                    d.png\nseq-01/a.png SIMPLE_PINHOLE 640 480 525 320 240\n\
                    e.png OPENCV 1 1 1 1 1 1 0 0 0 0\n";
        let q = parse_query_list(text, Path::new("q.txt"));
        let names: Vec<_> = q.iter().map(|q| q.name.as_str()).collect();
        assert_eq!(
            names,
            [
                "seq-01/a.png",
                "b.jpg",
                "c.png",
                "d.png",
                "seq-01/a.png",
                "e.png"
            ]
        );
        assert_eq!(
            q.iter().map(|q| q.id).collect::<Vec<_>>(),
            [0, 1, 2, 3, 4, 5]
        );
        assert_eq!(q[0].origin, "q.txt:2");
        let cam = q[0].camera.as_ref().unwrap();
        assert_eq!(
            (cam.width, cam.height, cam.params.clone()),
            (640, 480, vec![525.0, 320.0, 240.0])
        );
        assert_eq!(
            q[1].camera.as_ref().unwrap().model,
            geometry::CameraModel::Pinhole
        );
        assert_eq!(q[2].origin, "q.txt:5");
        assert!(q[2].camera.is_err(), "SIMPLE_RADIAL needs 4 parameters");
        assert!(q[3].camera.as_ref().unwrap_err().contains("no camera"));
        assert!(
            q[4].camera
                .as_ref()
                .unwrap_err()
                .contains("listed twice (first at line 2)"),
            "{:?}",
            q[4].camera
        );
        assert!(q[5].camera.is_ok());
    }

    #[test]
    fn folder_queries_are_sorted_relative_names() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::create_dir_all(dir.path().join("b")).unwrap();
        for f in ["b/2.JPG", "a.png", "b/1.jpeg", "notes.txt", "c d.png"] {
            std::fs::write(dir.path().join(f), b"x").unwrap();
        }
        let cam = pose::io::parse_camera("SIMPLE_PINHOLE 4 3 2 2 1.5").unwrap();
        let q = folder_queries(dir.path(), &cam).unwrap();
        let names: Vec<_> = q.iter().map(|q| q.name.as_str()).collect();
        assert_eq!(names, ["a.png", "b/1.jpeg", "b/2.JPG", "c d.png"]);
        assert!(q[3].camera.is_err());
        let e = load_query(dir.path(), &q[0]).unwrap_err();
        assert!(
            e.contains("a.png") && e.contains("neither a PNG nor a JPEG"),
            "{e}"
        );
        let missing = Query {
            name: "gone.png".into(),
            ..q[0].clone()
        };
        let e = load_query(dir.path(), &missing).unwrap_err();
        assert!(e.contains("gone.png"), "{e}");
    }
}
