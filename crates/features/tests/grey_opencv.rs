//! Grey images exactly as the reference implementation reads them: Python's
//! `cv2.imread(path, cv2.IMREAD_GRAYSCALE)` (opencv-python, its own libjpeg and libpng)
//! against `features::load_gray` / `decode_gray`, byte for byte, on the real 7-Scenes
//! sample frames (JPEG), on those frames written as colour PNGs by OpenCV's Python
//! writer, on a real 16-bit depth PNG, and on a colour PNG with every RGB triple the
//! test draws. Also: `gray_from_rgb` (the synthetic scene's ground truth) equals the
//! grey reader on the PNG of the same RGB image.
//!
//! Needs `PL2MAP_PYTHON` with cv2 and numpy (scripts/setup-python.sh); the real frames
//! need the sample data (README.md, "Tests"). Each skips with its reason otherwise.

use std::path::{Path, PathBuf};
use std::process::Command;

/// What cv2's grey reader gives for each file: raw bytes of every image, in order,
/// each preceded by its width and height as u32 little-endian.
fn cv2_gray(python: &Path, files: &[PathBuf]) -> Vec<(u32, u32, Vec<u8>)> {
    let script = r#"
import sys, cv2, numpy as np
out = sys.stdout.buffer
for p in sys.argv[1:]:
    g = cv2.imread(p, cv2.IMREAD_GRAYSCALE)
    assert g is not None and g.dtype == np.uint8 and g.ndim == 2, p
    h, w = g.shape
    out.write(np.array([w, h], dtype="<u4").tobytes())
    out.write(np.ascontiguousarray(g).tobytes())
"#;
    let stdout = testkit::python::run(Command::new(python).args(["-c", script]).args(files));
    let mut images = Vec::new();
    let mut at = 0;
    while at < stdout.len() {
        let w = u32::from_le_bytes(stdout[at..at + 4].try_into().unwrap());
        let h = u32::from_le_bytes(stdout[at + 4..at + 8].try_into().unwrap());
        at += 8;
        let n = (w * h) as usize;
        images.push((w, h, stdout[at..at + n].to_vec()));
        at += n;
    }
    assert_eq!(images.len(), files.len());
    images
}

/// Writes each JPEG as a colour PNG with OpenCV's Python writer (another tool's PNG).
fn cv2_png_copies(python: &Path, jpegs: &[PathBuf], dir: &Path) -> Vec<PathBuf> {
    let pngs: Vec<PathBuf> = (0..jpegs.len())
        .map(|i| dir.join(format!("frame-{i}.color.png")))
        .collect();
    let script = r#"
import sys, cv2
n = (len(sys.argv) - 1) // 2
for src, dst in zip(sys.argv[1:1 + n], sys.argv[1 + n:]):
    assert cv2.imwrite(dst, cv2.imread(src, cv2.IMREAD_COLOR)), dst
"#;
    testkit::python::run(
        Command::new(python)
            .args(["-c", script])
            .args(jpegs)
            .args(&pngs),
    );
    pngs
}

fn assert_same(files: &[PathBuf], expected: &[(u32, u32, Vec<u8>)]) {
    for (path, (w, h, want)) in files.iter().zip(expected) {
        let got = features::load_gray(path).unwrap();
        assert_eq!((got.width(), got.height()), (*w, *h), "{}", path.display());
        let differ = got
            .as_raw()
            .iter()
            .zip(want)
            .filter(|(a, b)| a != b)
            .count();
        assert_eq!(
            differ,
            0,
            "{}: {differ} of {} pixels differ from cv2's grey reader",
            path.display(),
            want.len()
        );
    }
}

#[test]
fn real_frames_are_grey_as_cv2_reads_them() {
    let Some(python) = testkit::python::python(&["cv2", "numpy"]) else {
        return;
    };
    let Some(stairs) = testkit::sample::sample_data("7scenes-stairs-mini/stairs") else {
        return;
    };
    let mut jpegs = Vec::new();
    let mut depths = Vec::new();
    for seq in ["seq-01", "seq-02", "seq-03", "seq-04"] {
        for k in 0..3 {
            let stem = stairs.join(seq).join(format!("frame-{k:06}"));
            let jpg = stem.with_extension("color.jpg");
            if jpg.exists() {
                jpegs.push(jpg);
            }
            let depth = stem.with_extension("depth.png");
            if depth.exists() && depths.is_empty() {
                depths.push(depth);
            }
        }
    }
    assert!(jpegs.len() >= 4, "the sample has 12 frames");
    let dir = tempfile::tempdir().unwrap();
    let pngs = cv2_png_copies(&python, &jpegs, dir.path());
    let files: Vec<PathBuf> = jpegs.iter().chain(&pngs).chain(&depths).cloned().collect();
    let expected = cv2_gray(&python, &files);
    assert_same(&files, &expected);
    // The colour frames are really colour: the BT.709 weights of `image`'s `to_luma8`
    // give another image on many pixels (what this test guards against).
    let rgb = image::open(&pngs[0]).unwrap().to_luma8();
    let ours = features::load_gray(&pngs[0]).unwrap();
    let other = rgb
        .as_raw()
        .iter()
        .zip(ours.as_raw())
        .filter(|(a, b)| a != b)
        .count();
    eprintln!(
        "{}: to_luma8 differs from cv2's grey on {other} of {} pixels",
        pngs[0].display(),
        ours.as_raw().len()
    );
    assert!(other > 1000);
}

/// Every channel combination the test draws (saturated, equal channels, random), as
/// one colour PNG written by this project and read by cv2; and `gray_from_rgb` of the
/// same image.
#[test]
fn colour_png_and_gray_from_rgb_match_cv2() {
    let Some(python) = testkit::python::python(&["cv2", "numpy"]) else {
        return;
    };
    let (w, h) = (256u32, 260u32);
    let mut state = 0x2545_F491_4F6C_DD1Du64;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 24) as u8
    };
    let rgb = image::RgbImage::from_fn(w, h, |x, y| match y {
        // All grey levels, then pure red, green, blue ramps.
        0 => image::Rgb([x as u8; 3]),
        1 => image::Rgb([x as u8, 0, 0]),
        2 => image::Rgb([0, x as u8, 0]),
        3 => image::Rgb([0, 0, x as u8]),
        _ => image::Rgb([next(), next(), next()]),
    });
    let dir = tempfile::tempdir().unwrap();
    let png = dir.path().join("colour.png");
    rgb.save(&png).unwrap();
    let expected = cv2_gray(&python, std::slice::from_ref(&png));
    assert_same(std::slice::from_ref(&png), &expected);
    assert_eq!(
        features::gray_from_rgb(&rgb).as_raw(),
        &expected[0].2,
        "gray_from_rgb differs from cv2's grey reader on the PNG"
    );
}

/// `gray_from_rgb` equals this build's own OpenCV grey reader on the PNG of the image
/// (no Python needed): the synthetic ground truth sees what a query's front-end sees.
#[test]
fn gray_from_rgb_equals_decode_gray_of_the_png() {
    let rgb = image::RgbImage::from_fn(97, 61, |x, y| {
        image::Rgb([
            (x * 7 + y) as u8,
            (x * 3 + y * 5) as u8,
            (255 - x - y) as u8,
        ])
    });
    let mut png = Vec::new();
    rgb.write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
        .unwrap();
    assert_eq!(
        features::decode_gray(&png).unwrap(),
        features::gray_from_rgb(&rgb)
    );
    assert!(features::decode_gray(b"").is_err());
    let e = features::decode_gray(b"\x89PNG\r\n\x1a\nnot really").unwrap_err();
    assert!(e.to_string().contains("cannot decode"), "{e}");
}
