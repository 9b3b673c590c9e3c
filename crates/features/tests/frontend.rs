//! Front-end behaviour on images with known geometry, and on real frames.

use features::*;
use image::{GrayImage, Luma};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// A textured test image: random discs and rectangles of random grey on noise.
fn textured(w: u32, h: u32, seed: u64) -> GrayImage {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut img = GrayImage::from_fn(w, h, |_, _| Luma([rng.random_range(100..130u8)]));
    for _ in 0..250 {
        let (cx, cy) = (
            rng.random_range(0.0..w as f64),
            rng.random_range(0.0..h as f64),
        );
        let r = rng.random_range(3.0..25.0);
        let v: u8 = rng.random();
        let rect = rng.random_bool(0.4);
        for y in 0..h {
            for x in 0..w {
                let (dx, dy) = (x as f64 + 0.5 - cx, y as f64 + 0.5 - cy);
                let inside = if rect {
                    dx.abs() < r && dy.abs() < 0.6 * r
                } else {
                    dx * dx + dy * dy < r * r
                };
                if inside {
                    img.put_pixel(x, y, Luma([v]));
                }
            }
        }
    }
    img
}

#[test]
fn gaussian_blob_is_found_at_its_colmap_centre() {
    // Blobs centred on a pixel centre (COLMAP (200.5, 150.5)), on a pixel corner and
    // in between: the detected position must follow the true centre, not the grid.
    for (cx, cy) in [(200.5, 150.5), (200.0, 150.0), (200.3, 149.8)] {
        blob_at(cx, cy);
    }
}

fn blob_at(cx: f64, cy: f64) {
    let s = 4.0f64;
    let img = GrayImage::from_fn(400, 300, |x, y| {
        let (dx, dy) = (x as f64 + 0.5 - cx, y as f64 + 0.5 - cy);
        Luma([(30.0 + 200.0 * (-(dx * dx + dy * dy) / (2.0 * s * s)).exp()).round() as u8])
    });
    let kps = detect_keypoints(&img, &SiftConfig::default()).unwrap();
    let best = kps
        .iter()
        .min_by(|a, b| {
            let da = (a.xy[0] - cx).hypot(a.xy[1] - cy);
            let db = (b.xy[0] - cx).hypot(b.xy[1] - cy);
            da.total_cmp(&db)
        })
        .expect("a keypoint on the blob");
    let err = (best.xy[0] - cx).hypot(best.xy[1] - cy);
    eprintln!(
        "blob at ({cx}, {cy}): detected {:?}, {err:.3} px off",
        best.xy
    );
    assert!(
        err < 0.1,
        "blob at ({cx}, {cy}) detected at {:?} ({err} px off)",
        best.xy
    );
}

#[test]
fn step_edge_segment_lies_on_the_pixel_boundary() {
    // Dark columns 0..=99, bright from 100: the edge is the boundary x = 100 in COLMAP
    // coordinates (99.5 in OpenCV's).
    let img = GrayImage::from_fn(200, 160, |x, _| Luma([if x < 100 { 40 } else { 210 }]));
    let segs = detect_segments(&img, &LsdConfig::default()).unwrap();
    assert!(!segs.is_empty());
    let s = segs[0];
    assert!(
        (s[0] - 100.0).abs() < 0.15 && (s[2] - 100.0).abs() < 0.15,
        "segment {s:?}"
    );
    assert!(
        (s[3] - s[1]).abs() > 120.0,
        "segment should span most of the edge: {s:?}"
    );
}

#[test]
fn segments_stay_inside_the_image() {
    // Edges that run into every border (LSD's refinement can place endpoints past it),
    // on the textured images and on slanted half-planes.
    let mut imgs: Vec<GrayImage> = (0..6).map(|i| textured(320, 240, 100 + i)).collect();
    for k in 0..6u32 {
        let a = 0.3 + 0.45 * k as f64;
        imgs.push(GrayImage::from_fn(320, 240, |x, y| {
            let v = (x as f64 - 160.0) * a.cos() + (y as f64 - 120.0) * a.sin();
            Luma([if v < 0.0 { 30 } else { 220 }])
        }));
    }
    let mut near_border = 0;
    for img in &imgs {
        let (w, h) = (img.width() as f64, img.height() as f64);
        for s in detect_segments(img, &LsdConfig::default()).unwrap() {
            for p in [[s[0], s[1]], [s[2], s[3]]] {
                assert!(
                    p[0] >= 0.0 && p[1] >= 0.0 && p[0] <= w && p[1] <= h,
                    "segment {s:?} leaves the {w}x{h} image"
                );
                if p[0] < 2.0 || p[1] < 2.0 || p[0] > w - 2.0 || p[1] > h - 2.0 {
                    near_border += 1;
                }
            }
        }
    }
    assert!(
        near_border > 0,
        "no segment reached the border: the test tests nothing"
    );
}

#[test]
fn extraction_is_deterministic_and_thread_count_independent() {
    let imgs: Vec<GrayImage> = (0..4).map(|i| textured(320, 240, i)).collect();
    let cfg = FrontEndConfig::default();
    let run = |threads: usize| {
        testkit::on_threads(threads, || {
            extract_batch(&imgs, &indicatif::ProgressBar::hidden(), |img| {
                extract(img, &cfg)
            })
            .into_iter()
            .map(|r| r.unwrap())
            .collect::<Vec<_>>()
        })
    };
    let one = run(1);
    let two = run(2);
    assert_eq!(one, two);
    for f in &one {
        assert!(f.num_keypoints() > 100, "{} keypoints", f.num_keypoints());
        assert!(f.num_segments() > 20, "{} segments", f.num_segments());
        assert_eq!(f.descriptors.len(), f.num_keypoints() * SIFT_DIM);
        assert_eq!(f.line_descriptors.len(), f.num_segments() * 12 * SIFT_DIM);
        // Unit-norm descriptor rows.
        let n: f32 = f.descriptor(0).iter().map(|v| v * v).sum();
        assert!((n - 1.0).abs() < 1e-4);
    }
}

#[test]
fn top_k_keeps_the_strongest_unique_positions() {
    let img = textured(320, 240, 7);
    let all = detect_keypoints(
        &img,
        &SiftConfig {
            max_keypoints: usize::MAX,
            ..Default::default()
        },
    )
    .unwrap();
    let top = detect_keypoints(
        &img,
        &SiftConfig {
            max_keypoints: 50,
            ..Default::default()
        },
    )
    .unwrap();
    assert_eq!(top.len(), 50);
    assert_eq!(&all[..50], &top[..]);
    assert!(top.windows(2).all(|w| w[0].response >= w[1].response));
    let mut pos: Vec<_> = all
        .iter()
        .map(|k| (k.xy[0].to_bits(), k.xy[1].to_bits()))
        .collect();
    pos.sort();
    pos.dedup();
    assert_eq!(pos.len(), all.len(), "positions are unique");
}

#[test]
fn describe_points_keeps_every_position_in_order() {
    let img = textured(320, 240, 3);
    let positions = [
        [0.5, 0.5],
        [160.0, 120.0],
        [319.5, 239.5],
        [-3.0, 50.0],
        [100.25, 80.75],
    ];
    let d = describe_points(
        &img,
        &positions,
        &SiftConfig::default(),
        &DescriptorConfig::default(),
    )
    .unwrap();
    assert_eq!(d.len(), positions.len() * SIFT_DIM);
    // Order: describing a single position reproduces its row.
    let one = describe_points(
        &img,
        &positions[1..2],
        &SiftConfig::default(),
        &DescriptorConfig::default(),
    )
    .unwrap();
    assert_eq!(&d[SIFT_DIM..2 * SIFT_DIM], &one[..]);
}

fn cosine(a: &[f32], b: &[f32]) -> f32 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// Rotating the image by 90 degrees and the segment with it gives the same line
/// descriptors: they are oriented along the segment.
#[test]
fn line_descriptors_follow_the_segment_orientation() {
    for method in [DescriptorMethod::Dense, DescriptorMethod::Opencv] {
        line_descriptors_follow_the_segment_orientation_with(method);
    }
}

fn line_descriptors_follow_the_segment_orientation_with(method: DescriptorMethod) {
    let img = textured(240, 240, 11);
    let (w, h) = img.dimensions();
    // Rotate 90 deg clockwise: pixel (x, y) -> (h - 1 - y, x); in COLMAP coordinates
    // the continuous point (u, v) -> (h - v, u).
    let rot = GrayImage::from_fn(h, w, |x, y| *img.get_pixel(y, h - 1 - x));
    let seg = [60.3, 70.7, 170.2, 150.9];
    let map = |u: f64, v: f64| [h as f64 - v, u];
    let a = map(seg[0], seg[1]);
    let b = map(seg[2], seg[3]);
    let seg_rot = [a[0], a[1], b[0], b[1]];
    let mut cfg = FrontEndConfig::default();
    cfg.descriptor.method = method;
    let d0 = describe_lines(&img, &[seg], 12, &cfg.sift, &cfg.descriptor).unwrap();
    let d1 = describe_lines(&rot, &[seg_rot], 12, &cfg.sift, &cfg.descriptor).unwrap();
    for i in 0..12 {
        let c = cosine(
            &d0[i * SIFT_DIM..(i + 1) * SIFT_DIM],
            &d1[i * SIFT_DIM..(i + 1) * SIFT_DIM],
        );
        assert!(c > 0.97, "{method:?} sample {i}: cosine {c}");
    }
    // Control: upright point descriptors do change under the rotation.
    let p = sample_points(&seg, 12)[5];
    let pr = map(p[0], p[1]);
    let u0 = describe_points(&img, &[p], &cfg.sift, &cfg.descriptor).unwrap();
    let u1 = describe_points(&rot, &[pr], &cfg.sift, &cfg.descriptor).unwrap();
    assert!(cosine(&u0, &u1) < 0.9);
}

#[test]
fn samples_include_both_endpoints() {
    let pts = sample_points(&[10.0, 20.0, 32.0, 42.0], 12);
    assert_eq!(pts.len(), 12);
    assert_eq!(pts[0], [10.0, 20.0]);
    assert!((pts[11][0] - 32.0).abs() < 1e-12 && (pts[11][1] - 42.0).abs() < 1e-12);
    assert!((pts[1][0] - 12.0).abs() < 1e-12);
}

#[test]
fn real_7scenes_frame() {
    let Some(stairs) = testkit::sample::sample_data("7scenes-stairs-mini/stairs") else {
        return;
    };
    let img = load_gray(&stairs.join("seq-01/frame-000000.color.jpg")).unwrap();
    let f = extract(&img, &FrontEndConfig::query()).unwrap();
    eprintln!(
        "7-Scenes stairs frame: {} keypoints, {} segments",
        f.num_keypoints(),
        f.num_segments()
    );
    assert!(f.num_keypoints() > 300 && f.num_keypoints() <= 2048);
    assert!(f.num_segments() > 30);
    for k in &f.keypoints {
        assert!(k[0] > 0.0 && k[0] < 640.0 && k[1] > 0.0 && k[1] < 480.0);
    }
}

/// The query path (`extract`: detection and LSD side by side, every descriptor in one
/// pass over one pyramid, chunks side by side) equals the public calls one after the
/// other (`extract_per_call`) bit for bit, on 1 and 2 threads and on real frames.
#[test]
fn extract_equals_the_per_call_path() {
    let mut images = vec![textured(320, 240, 11), textured(640, 480, 12)];
    let real = testkit::sample::root().map(|r| r.join("7scenes-stairs-mini/stairs/seq-01"));
    if let Some(dir) = real.filter(|d| d.is_dir()) {
        images.push(load_gray(&dir.join("frame-000000.color.jpg")).unwrap());
    }
    for method in [DescriptorMethod::Dense, DescriptorMethod::Opencv] {
        let mut cfg = FrontEndConfig::query();
        cfg.descriptor.method = method;
        extract_equals_the_per_call_path_with(&images, &cfg);
    }
}

fn extract_equals_the_per_call_path_with(images: &[GrayImage], cfg: &FrontEndConfig) {
    for img in images {
        let cfg = cfg.clone();
        let reference = extract_per_call(img, &cfg).unwrap();
        assert!(reference.num_keypoints() > 0 && reference.num_segments() > 0);
        for threads in [1, 2, 3] {
            let fast = testkit::on_threads(threads, || extract(img, &cfg).unwrap());
            assert_eq!(fast.keypoints, reference.keypoints);
            assert_eq!(fast.segments, reference.segments);
            let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&fast.descriptors), bits(&reference.descriptors));
            assert_eq!(
                bits(&fast.line_descriptors),
                bits(&reference.line_descriptors)
            );
        }
    }
}

/// The dense map's descriptor is SIFT's up to its approximations (`dense.rs`): at the
/// same positions, sizes and angles it points the same way as OpenCV's, and a position
/// is its own nearest neighbour among the others of the image under either method.
#[test]
fn dense_descriptors_approximate_opencv_sift() {
    let mut images = vec![textured(640, 480, 21)];
    let real = testkit::sample::root().map(|r| r.join("7scenes-stairs-mini/stairs/seq-01"));
    match real.filter(|d| d.is_dir()) {
        Some(dir) => images.push(load_gray(&dir.join("frame-000000.color.jpg")).unwrap()),
        None => eprintln!(
            "skipping the real frame: no 7scenes-stairs-mini/stairs/seq-01 under PL2MAP_SAMPLE_DATA"
        ),
    }
    for img in &images {
        let mut cfg = FrontEndConfig::query();
        let f = extract(img, &cfg).unwrap();
        cfg.descriptor.method = DescriptorMethod::Opencv;
        let cv = describe_points(img, &f.keypoints, &cfg.sift, &cfg.descriptor).unwrap();
        let cv_lines = describe_lines(img, &f.segments, 12, &cfg.sift, &cfg.descriptor).unwrap();
        let median_cos = |a: &[f32], b: &[f32]| {
            let mut c: Vec<f32> = a
                .chunks_exact(SIFT_DIM)
                .zip(b.chunks_exact(SIFT_DIM))
                .map(|(x, y)| cosine(x, y))
                .collect();
            c.sort_by(|x, y| x.total_cmp(y));
            c[c.len() / 2]
        };
        let points = median_cos(&f.descriptors, &cv);
        let lines = median_cos(&f.line_descriptors, &cv_lines);
        eprintln!(
            "{}x{}: median cosine dense vs OpenCV: points {points:.3}, line samples {lines:.3}",
            img.width(),
            img.height()
        );
        assert!(points > 0.98 && lines > 0.98, "{points} {lines}");
    }
}
