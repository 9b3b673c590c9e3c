//! `lsd::detect` against pytlsd 0.0.2 itself (LIMAP's LSD, in the LIMAP venv:
//! `PL2MAP_LIMAP_PYTHON`, default `~/.cache/pl2map-rs/limap-venv/bin/python`;
//! scripts/setup-python.sh) on the same grey bytes: the real 7-Scenes frames of the
//! sample data, decoded as LIMAP decodes them (`cv2.imread` then `cv2.cvtColor(...,
//! COLOR_BGR2GRAY)`, the grey bytes sent back to us), and seeded synthetic images. Every
//! segment must agree: same count, same order, endpoints and `p` equal after rounding to
//! float32 (pytlsd hands out float32). Also prints the time per image of both.
//! Skips with its reason without the venv or the sample data.

use std::process::Command;
use std::time::Instant;

use lsd::{Params, Segment};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Reads `jpg <path>` or `raw <w> <h> <name>` + w*h bytes from stdin; for each, prints
/// `image <name> <w> <h> <n> <ms>`, for a JPEG `grey <hex>`, then the n segments (x1 y1
/// x2 y2 p, each float32 written as the shortest repr of its double value: exact).
/// `<ms>`: median of 5 runs of pytlsd.lsd.
const PEER: &str = r#"
import sys, time
import numpy as np, cv2, pytlsd

out = sys.stdout
inp = sys.stdin.buffer

def emit(name, grey, dump):
    h, w = grey.shape
    segs = pytlsd.lsd(grey)
    times = []
    for _ in range(5):
        t = time.perf_counter()
        pytlsd.lsd(grey)
        times.append(time.perf_counter() - t)
    ms = 1000.0 * sorted(times)[2]
    out.write(f"image {name} {w} {h} {len(segs)} {ms!r}\n")
    if dump:
        out.write("grey " + np.ascontiguousarray(grey).tobytes().hex() + "\n")
    for r in segs:
        out.write(" ".join(repr(float(v)) for v in r) + "\n")

while True:
    line = inp.readline()
    if not line:
        break
    text = line.decode().rstrip("\n")
    if text.startswith("jpg "):
        path = text[4:]
        # As LIMAP's LSDDetector.detect: colour decode, then BGR -> grey.
        grey = cv2.cvtColor(cv2.imread(path), cv2.COLOR_BGR2GRAY)
        emit(path, grey, True)
    else:
        _, w, h, name = text.split(" ", 3)
        w, h = int(w), int(h)
        data = inp.read(w * h)
        grey = np.frombuffer(data, np.uint8).reshape(h, w)
        emit(name, grey, False)
out.flush()
"#;

/// One image as pytlsd saw it.
struct PeerImage {
    name: String,
    width: usize,
    height: usize,
    grey: Vec<u8>,
    ms: f64,
    /// x1 y1 x2 y2 p.
    segments: Vec<[f32; 5]>,
}

/// An input for the peer: a JPEG path, or raw grey bytes with a name.
enum Input {
    Jpeg(String),
    Raw {
        name: String,
        width: usize,
        height: usize,
        grey: Vec<u8>,
    },
}

fn run_peer(python: &std::path::Path, inputs: &[Input]) -> Vec<PeerImage> {
    let mut stdin = Vec::new();
    for input in inputs {
        match input {
            Input::Jpeg(path) => stdin.extend_from_slice(format!("jpg {path}\n").as_bytes()),
            Input::Raw {
                name,
                width,
                height,
                grey,
            } => {
                stdin.extend_from_slice(format!("raw {width} {height} {name}\n").as_bytes());
                stdin.extend_from_slice(grey);
            }
        }
    }
    let stdout = testkit::python::run_with_input(Command::new(python).args(["-c", PEER]), stdin);
    let text = String::from_utf8(stdout).expect("utf-8 peer output");
    let mut lines = text.lines();
    let mut images = Vec::new();
    for input in inputs {
        let head: Vec<&str> = lines.next().expect("image line").split(' ').collect();
        assert_eq!(head[0], "image", "{head:?}");
        let n = head.len();
        let (width, height): (usize, usize) =
            (head[n - 4].parse().unwrap(), head[n - 3].parse().unwrap());
        let count: usize = head[n - 2].parse().unwrap();
        let ms: f64 = head[n - 1].parse().unwrap();
        let grey = match input {
            Input::Jpeg(_) => {
                let hex = lines
                    .next()
                    .expect("grey line")
                    .strip_prefix("grey ")
                    .expect("grey");
                (0..hex.len() / 2)
                    .map(|i| u8::from_str_radix(&hex[2 * i..2 * i + 2], 16).unwrap())
                    .collect()
            }
            Input::Raw { grey, .. } => grey.clone(),
        };
        assert_eq!(grey.len(), width * height);
        let segments = (0..count)
            .map(|_| {
                let v: Vec<f32> = lines
                    .next()
                    .expect("segment line")
                    .split(' ')
                    // The repr of a float32's double value parses back to it exactly.
                    .map(|t| t.parse::<f64>().unwrap() as f32)
                    .collect();
                [v[0], v[1], v[2], v[3], v[4]]
            })
            .collect();
        images.push(PeerImage {
            name: head[1..n - 4].join(" "),
            width,
            height,
            grey,
            ms,
            segments,
        });
    }
    images
}

/// Median time (ms) of 5 runs, and the segments.
fn timed_detect(img: &PeerImage) -> (Vec<Segment>, f64) {
    let params = Params::pytlsd();
    let segs = lsd::detect(&img.grey, img.width, img.height, &params).unwrap();
    let mut times: Vec<f64> = (0..5)
        .map(|_| {
            let t = Instant::now();
            let s = lsd::detect(&img.grey, img.width, img.height, &params).unwrap();
            let ms = t.elapsed().as_secs_f64() * 1e3;
            assert_eq!(s, segs, "deterministic");
            ms
        })
        .collect();
    times.sort_by(f64::total_cmp);
    (segs, times[2])
}

/// Compares every image; prints one line each and a total; panics on any difference.
fn compare(images: &[PeerImage]) {
    let (mut total, mut differing, mut count_mismatch) = (0usize, 0usize, 0usize);
    let (mut ms_ours, mut ms_peer) = (0.0, 0.0);
    for img in images {
        let (ours, ms) = timed_detect(img);
        ms_ours += ms;
        ms_peer += img.ms;
        let mut diff = 0usize;
        let mut max_err = 0f64;
        for (a, b) in ours.iter().zip(&img.segments) {
            let a32 = [
                a.x1 as f32,
                a.y1 as f32,
                a.x2 as f32,
                a.y2 as f32,
                a.p as f32,
            ];
            if a32 != *b {
                diff += 1;
            }
            for (u, v) in [a.x1, a.y1, a.x2, a.y2].iter().zip(b) {
                max_err = max_err.max((u - f64::from(*v)).abs());
            }
        }
        if ours.len() != img.segments.len() {
            count_mismatch += 1;
        }
        total += img.segments.len();
        differing += diff + ours.len().abs_diff(img.segments.len());
        eprintln!(
            "{} ({}x{}): pytlsd {} segments, lsd {}; {} differ (max endpoint diff {:.2e} px, \
             float32 rounding included); {:.1} ms pytlsd, {:.1} ms lsd",
            img.name,
            img.width,
            img.height,
            img.segments.len(),
            ours.len(),
            diff,
            max_err,
            img.ms,
            ms,
        );
    }
    let n = images.len() as f64;
    eprintln!(
        "{} images, {total} pytlsd segments: {differing} differ, {count_mismatch} counts differ; \
         mean {:.1} ms pytlsd, {:.1} ms lsd per image",
        images.len(),
        ms_peer / n,
        ms_ours / n
    );
    assert_eq!(count_mismatch, 0, "segment counts differ");
    assert_eq!(differing, 0, "segments differ from pytlsd's");
}

#[test]
fn real_7scenes_frames_match_pytlsd() {
    let Some(python) = testkit::python::limap_python(&["pytlsd", "cv2", "numpy"]) else {
        return;
    };
    let Some(stairs) = testkit::sample::sample_data("7scenes-stairs-mini/stairs") else {
        return;
    };
    let mut frames: Vec<String> = Vec::new();
    for seq in std::fs::read_dir(&stairs).unwrap() {
        let seq = seq.unwrap().path();
        if !seq.is_dir() {
            continue;
        }
        for f in std::fs::read_dir(&seq).unwrap() {
            let f = f.unwrap().path();
            if f.to_string_lossy().ends_with(".color.jpg") {
                frames.push(f.to_str().expect("utf-8 path").to_string());
            }
        }
    }
    frames.sort();
    assert!(
        !frames.is_empty(),
        "no *.color.jpg under {}",
        stairs.display()
    );
    let inputs: Vec<Input> = frames.into_iter().map(Input::Jpeg).collect();
    let mut images = run_peer(&python, &inputs);
    for img in &mut images {
        // Shorter lines: the frame's path below the sample folder.
        if let Ok(rel) = std::path::Path::new(&img.name).strip_prefix(&stairs) {
            img.name = rel.display().to_string();
        }
    }
    compare(&images);
}

/// A seeded synthetic grey image: a horizontal intensity ramp, filled rectangles (some
/// rotated, anti-aliased by 4x4 supersampling), a disc (curved edges) and noise.
fn synthetic(width: usize, height: usize, seed: u64, noise: f64) -> Vec<u8> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    // (centre x, centre y, half length, half width, angle, grey)
    let rects: Vec<(f64, f64, f64, f64, f64, f64)> = (0..12)
        .map(|_| {
            (
                rng.random_range(0.0..width as f64),
                rng.random_range(0.0..height as f64),
                rng.random_range(10.0..width as f64 / 4.0),
                rng.random_range(4.0..height as f64 / 6.0),
                if rng.random_bool(0.3) {
                    0.0
                } else {
                    rng.random_range(0.0..std::f64::consts::PI)
                },
                rng.random_range(0.0..255.0),
            )
        })
        .collect();
    let disc = (
        width as f64 * 0.7,
        height as f64 * 0.3,
        height as f64 * 0.15,
    );
    let shade = |x: f64, y: f64| -> f64 {
        let mut v = 60.0 + 80.0 * x / width as f64;
        if (x - disc.0).hypot(y - disc.1) < disc.2 {
            v = 220.0;
        }
        for &(cx, cy, hl, hw, a, g) in &rects {
            let (dx, dy) = (x - cx, y - cy);
            let (l, w) = (dx * a.cos() + dy * a.sin(), -dx * a.sin() + dy * a.cos());
            if l.abs() < hl && w.abs() < hw {
                v = g;
            }
        }
        v
    };
    let mut img = Vec::with_capacity(width * height);
    for y in 0..height {
        for x in 0..width {
            let mut acc = 0.0;
            for sy in 0..4 {
                for sx in 0..4 {
                    acc += shade(
                        x as f64 + (sx as f64 + 0.5) / 4.0 - 0.5,
                        y as f64 + (sy as f64 + 0.5) / 4.0 - 0.5,
                    );
                }
            }
            // Roughly Gaussian noise: the sum of 4 uniforms.
            let n: f64 = (0..4).map(|_| rng.random_range(-1.0..1.0)).sum::<f64>() * noise / 1.15;
            img.push((acc / 16.0 + n).round().clamp(0.0, 255.0) as u8);
        }
    }
    img
}

#[test]
fn synthetic_images_match_pytlsd() {
    let Some(python) = testkit::python::limap_python(&["pytlsd", "numpy"]) else {
        return;
    };
    let inputs: Vec<Input> = [
        ("synthetic-640x480-noise3", 640, 480, 1, 3.0),
        ("synthetic-640x480-noise8", 640, 480, 2, 8.0),
        // An odd size: ceil(317 * 0.8) = 254 columns; border and symmetric-padding cases.
        ("synthetic-317x229-noise5", 317, 229, 3, 5.0),
        ("synthetic-64x48-clean", 64, 48, 4, 0.0),
    ]
    .into_iter()
    .map(|(name, width, height, seed, noise)| Input::Raw {
        name: name.to_string(),
        width,
        height,
        grey: synthetic(width, height, seed, noise),
    })
    .collect();
    let images = run_peer(&python, &inputs);
    assert!(images.iter().all(|i| !i.segments.is_empty()));
    compare(&images);
}
