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
            // `parse_camera` builds the camera with `Camera::new`, which refuses one that
            // cannot exist (focal length <= 0, principal point far outside the image): a
            // bad query then, not a pose. Its message starts with `camera: `.
            pose::io::parse_camera(spec).map_err(|e| e.to_string())
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
/// whitespace (which the results file cannot hold) becomes a failed query. Second: one
/// line per link not followed because it leads to a folder listed already (a link
/// cycle; `tables::image_file::list`), for the caller to warn with.
pub fn folder_queries(
    dir: &Path,
    camera: &Camera,
) -> Result<(Vec<Query>, Vec<String>), ScoreError> {
    let listing = tables::image_file::list(dir).map_err(io_err(dir))?;
    let mut names: Vec<String> = listing
        .files
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
    let queries = names
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
        .collect();
    Ok((queries, listing.skipped))
}

/// The image of a query as a frame to localise (no ground truth: identity pose, never
/// read), or why it cannot be one. Decoding and the size check against the camera
/// happen in the localiser, as for the score stage's frames.
pub fn load_query(images: &Path, q: &Query) -> Result<TestFrame, String> {
    let camera = q.camera.clone()?;
    let path: PathBuf = images.join(&q.name);
    // Within bounds: no device or FIFO, the header and the pixel limit before the rest,
    // no more bytes than the header's image can take (crates/fileio/src/image.rs).
    let bytes = fileio::image::read_image(&path).map_err(|e| e.to_string())?;
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

    /// A camera that cannot exist is a bad query naming what is wrong, never a pose
    /// (docs/errors.md).
    #[test]
    fn impossible_cameras_are_bad_queries() {
        let text = "neg.png SIMPLE_PINHOLE 640 480 -525 320 240\n\
                    zero.png PINHOLE 640 480 525 0 320 240\n\
                    far.png SIMPLE_PINHOLE 640 480 525 1e12 240\n\
                    ok.png SIMPLE_PINHOLE 640 480 525 320 240\n";
        let q = parse_query_list(text, Path::new("q.txt"));
        let reason = |i: usize| q[i].camera.as_ref().unwrap_err().clone();
        assert_eq!(
            reason(0),
            "camera: focal length f = -525 must be positive and finite"
        );
        assert_eq!(
            reason(1),
            "camera: focal length fy = 0 must be positive and finite"
        );
        assert!(
            reason(2).starts_with("camera: principal point cx = 1000000000000 lies more than"),
            "{}",
            reason(2)
        );
        assert_eq!(q[2].origin, "q.txt:3");
        assert!(q[3].camera.is_ok());
        // `load_query` hands the reason on (`run` puts the query's origin before it).
        let e = load_query(Path::new("."), &q[0]).unwrap_err();
        assert!(e.contains("focal length f = -525"), "{e}");
    }

    #[test]
    fn folder_queries_are_sorted_relative_names() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::create_dir_all(dir.path().join("b")).unwrap();
        for f in ["b/2.JPG", "a.png", "b/1.jpeg", "notes.txt", "c d.png"] {
            std::fs::write(dir.path().join(f), b"x").unwrap();
        }
        let cam = pose::io::parse_camera("SIMPLE_PINHOLE 4 3 2 2 1.5").unwrap();
        let (q, skipped) = folder_queries(dir.path(), &cam).unwrap();
        assert!(skipped.is_empty());
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

    /// Images read within bounds (crates/fileio/src/image.rs): `/dev/zero`, a PNG over the
    /// pixel limit and a sparse file of 3 GB behind a small PNG header are refused naming
    /// the file, before their pixels are read; no OpenCV text.
    #[cfg(unix)]
    #[test]
    fn dev_zero_an_oversized_png_and_a_sparse_file_are_refused_by_name() {
        use image::ImageEncoder;
        use image::codecs::png::{CompressionType, FilterType, PngEncoder};
        use std::io::Write;
        let dir = tempfile::tempdir().unwrap();
        let cam = pose::io::parse_camera("SIMPLE_PINHOLE 16 12 10 8 6").unwrap();
        let query = |name: &str| Query {
            id: 0,
            name: name.into(),
            origin: format!("q.txt:{name}"),
            camera: Ok(cam.clone()),
        };
        if Path::new("/dev/zero").exists() {
            std::os::unix::fs::symlink("/dev/zero", dir.path().join("zero.png")).unwrap();
            let e = load_query(dir.path(), &query("zero.png")).unwrap_err();
            assert_eq!(
                e,
                format!(
                    "{}: not a regular file but a device: an image must be a PNG or JPEG file",
                    dir.path().join("zero.png").display()
                )
            );
        }
        let (w, h) = (20_000u32, 20_000u32);
        let mut huge = Vec::new();
        PngEncoder::new_with_quality(&mut huge, CompressionType::Fast, FilterType::NoFilter)
            .write_image(
                &vec![0u8; w as usize * h as usize],
                w,
                h,
                image::ExtendedColorType::L8,
            )
            .unwrap();
        std::fs::write(dir.path().join("huge.png"), &huge).unwrap();
        let e = load_query(dir.path(), &query("huge.png")).unwrap_err();
        assert_eq!(
            e,
            format!(
                "{}: the PNG is too large: 20000x20000 is 400000000 pixels, the limit is \
                 50000000 pixels (set PL2MAP_MAX_IMAGE_PIXELS to change it)",
                dir.path().join("huge.png").display()
            )
        );
        let mut small = Vec::new();
        PngEncoder::new(&mut small)
            .write_image(&[0u8; 16 * 12], 16, 12, image::ExtendedColorType::L8)
            .unwrap();
        let sparse = dir.path().join("sparse.png");
        let mut f = std::fs::File::create(&sparse).unwrap();
        f.write_all(&small).unwrap();
        f.set_len(3 << 30).unwrap();
        drop(f);
        let e = load_query(dir.path(), &query("sparse.png")).unwrap_err();
        assert!(
            e.starts_with(&format!(
                "{}: the file is 3221225472 bytes",
                sparse.display()
            )),
            "{e}"
        );
    }
}
