//! COLMAP text model parser: arbitrary text split at NUL characters into the five files.
//! Properties: no panic; a model that parses is written (17 significant digits) and
//! parses back equal.
#![no_main]

use colmap::text::{TextFiles, parse_model};
use colmap::{Format, Table};
use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    let p = Path::new("fuzz.txt");
    let _ = colmap::text::parse_cameras(p, &text);
    let _ = colmap::text::parse_images(p, &text);
    let _ = colmap::text::parse_points3d(p, &text);
    let _ = colmap::text::parse_rigs(p, &text);
    let _ = colmap::text::parse_frames(p, &text);

    let mut parts = text.split('\0');
    let cameras = parts.next().unwrap_or("");
    let images = parts.next().unwrap_or("");
    let points3d = parts.next().unwrap_or("");
    let rigs = parts.next();
    let frames = parts.next();
    let files = TextFiles {
        cameras,
        images,
        points3d,
        rigs,
        frames,
    };
    let Ok(rec) = parse_model(Path::new("fuzz"), &files) else {
        return;
    };
    let enc = |t| {
        String::from_utf8(
            colmap::io::encode(&rec, t, Format::Text).expect("a parsed model encodes"),
        )
        .expect("text output is UTF-8")
    };
    let written: Vec<String> = [
        Table::Cameras,
        Table::Images,
        Table::Points3D,
        Table::Rigs,
        Table::Frames,
    ]
    .into_iter()
    .map(enc)
    .collect();
    let again = parse_model(
        Path::new("fuzz"),
        &TextFiles {
            cameras: &written[0],
            images: &written[1],
            points3d: &written[2],
            rigs: Some(&written[3]),
            frames: Some(&written[4]),
        },
    )
    .expect("a written model parses");
    assert_eq!(again, rec);
});
