//! Whole-detector tests on synthetic images (the pytlsd comparisons on real and noisy
//! images are in tests/pytlsd.rs).

use super::*;

/// A `width` x `height` image of `bg` with the rectangle `x0..x1` x `y0..y1` at `fg`.
fn rectangle_image(
    width: usize,
    height: usize,
    (x0, x1, y0, y1): (usize, usize, usize, usize),
    bg: u8,
    fg: u8,
) -> Vec<u8> {
    let mut img = vec![bg; width * height];
    for y in y0..y1 {
        for x in x0..x1 {
            img[x + y * width] = fg;
        }
    }
    img
}

#[test]
fn a_bright_rectangle_gives_its_four_edges_as_pytlsd_does() {
    // pytlsd 0.0.2: `img = np.zeros((120, 160), np.uint8); img[30:90, 40:120] = 200;
    // pytlsd.lsd(img)`, float32 values printed in full.
    let want = [
        [
            40.10444259643555,
            88.75003051757812,
            40.105838775634766,
            31.250001907348633,
        ],
        [
            41.25,
            30.108291625976562,
            118.75001525878906,
            30.107242584228516,
        ],
        [
            118.75001525878906,
            90.12124633789062,
            41.25,
            90.12040710449219,
        ],
        [
            120.12213897705078,
            31.249998092651367,
            120.12325286865234,
            88.7500228881836,
        ],
    ];
    let img = rectangle_image(160, 120, (40, 120, 30, 90), 0, 200);
    let segs = detect(&img, 160, 120, &Params::pytlsd()).unwrap();
    assert_eq!(segs.len(), 4, "{segs:#?}");
    for (s, w) in segs.iter().zip(want) {
        let got = [s.x1 as f32, s.y1 as f32, s.x2 as f32, s.y2 as f32];
        assert_eq!(got, w.map(|v| v as f32), "{s:?}");
        assert_eq!(s.p, 0.125);
        assert!(s.log_nfa > 0.0);
        assert!(s.width >= 1.0 / 0.8);
    }
}

#[test]
fn the_brighter_side_is_on_the_right_going_from_first_to_second_endpoint() {
    // Vertical step, bright on the right: the segment runs upwards on screen (y falls).
    let img: Vec<u8> = (0..120 * 160)
        .map(|i| if i % 160 >= 80 { 200 } else { 0 })
        .collect();
    let segs = detect(&img, 160, 120, &Params::pytlsd()).unwrap();
    assert_eq!(segs.len(), 1, "{segs:?}");
    let s = segs[0];
    assert!(s.y1 > s.y2, "{s:?}");
    // The edge between columns 79 and 80 comes out at 80.115 (pytlsd: 80.11539), close to
    // 80, its COLMAP coordinate; see the crate docs.
    assert!(
        (s.x1 - 80.115).abs() < 0.01 && (s.x2 - 80.115).abs() < 0.01,
        "{s:?}"
    );
}

#[test]
fn grey_bytes_and_the_same_values_as_f64_give_the_same_segments() {
    let img = rectangle_image(90, 70, (20, 70, 10, 50), 30, 180);
    let as_f64: Vec<f64> = img.iter().map(|&v| f64::from(v)).collect();
    let a = detect(&img, 90, 70, &Params::pytlsd()).unwrap();
    let b = detect_f64(&as_f64, 90, 70, &Params::pytlsd()).unwrap();
    assert_eq!(a, b);
    assert_eq!(a.len(), 4);
}

#[test]
fn density_refinement_keeps_straight_edges() {
    // The paper's defaults (density_th 0.7): a rectangle's straight edges fill their
    // rectangles, so refinement leaves them alone.
    let img = rectangle_image(160, 120, (40, 120, 30, 90), 0, 200);
    let with = detect(&img, 160, 120, &Params::default()).unwrap();
    let without = detect(&img, 160, 120, &Params::pytlsd()).unwrap();
    assert_eq!(with, without);
}

#[test]
fn density_refinement_splits_or_drops_a_sparse_corner_region() {
    // A thin bright "L" drawn with anti-aliased diagonal: every run of the detector must
    // terminate and give finite segments, with or without refinement.
    let (w, h) = (100, 100);
    let mut img = vec![0u8; w * h];
    for i in 10..90 {
        img[i + 50 * w] = 255;
        img[50 + i * w] = 255;
        img[i + i * w] = 255;
    }
    for params in [Params::default(), Params::pytlsd()] {
        let segs = detect(&img, w, h, &params).unwrap();
        assert!(!segs.is_empty());
        for s in segs {
            assert!(
                [s.x1, s.y1, s.x2, s.y2, s.width, s.log_nfa]
                    .iter()
                    .all(|v| v.is_finite())
            );
        }
    }
}

#[test]
fn scale_one_skips_the_resampling() {
    let img = rectangle_image(80, 60, (20, 60, 15, 45), 0, 200);
    let params = Params {
        scale: 1.0,
        ..Params::pytlsd()
    };
    let segs = detect(&img, 80, 60, &params).unwrap();
    assert_eq!(segs.len(), 4, "{segs:?}");
    // Without resampling the step between columns 19 and 20 is found at x = 20 (the
    // gradient window of column 20 spans 19 and 20; nothing is added).
    assert!(
        segs.iter()
            .any(|s| (s.x1 - 20.0).abs() < 0.01 && (s.x2 - 20.0).abs() < 0.01)
    );
}

#[test]
fn empty_and_mismatched_images_are_errors() {
    let p = Params::pytlsd();
    assert_eq!(
        detect(&[], 0, 10, &p),
        Err(LsdError::EmptyImage {
            width: 0,
            height: 10
        })
    );
    assert_eq!(
        detect(&[], 10, 0, &p),
        Err(LsdError::EmptyImage {
            width: 10,
            height: 0
        })
    );
    let err = detect(&[0; 5], 2, 3, &p).unwrap_err();
    assert_eq!(
        err,
        LsdError::SizeMismatch {
            width: 2,
            height: 3,
            len: 5
        }
    );
    assert_eq!(
        err.to_string(),
        "image of 2 x 3 pixels needs 6 values, got 5"
    );
}

#[test]
fn invalid_parameters_are_errors() {
    let img = vec![0u8; 100];
    for params in [
        Params {
            scale: 0.0,
            ..Params::default()
        },
        Params {
            ang_th: 180.0,
            ..Params::default()
        },
        Params {
            density_th: 1.5,
            ..Params::default()
        },
        Params {
            n_bins: 0,
            ..Params::default()
        },
        Params {
            sigma_scale: f64::NAN,
            ..Params::default()
        },
    ] {
        assert!(
            matches!(
                detect(&img, 10, 10, &params),
                Err(LsdError::InvalidParams(_))
            ),
            "{params:?}"
        );
    }
}

#[test]
fn tiny_and_flat_images_give_no_segments_without_panicking() {
    for (w, h) in [(1, 1), (2, 1), (1, 3), (2, 2), (3, 3), (5, 4)] {
        let img: Vec<u8> = (0..w * h).map(|i| (i * 97 % 256) as u8).collect();
        for scale in [0.8, 1.0, 2.0] {
            let params = Params {
                scale,
                ..Params::pytlsd()
            };
            let segs = detect(&img, w, h, &params).unwrap();
            assert!(segs.iter().all(|s| s.log_nfa > 0.0), "{w}x{h} {segs:?}");
        }
    }
    let flat = vec![128u8; 64 * 48];
    assert!(detect(&flat, 64, 48, &Params::pytlsd()).unwrap().is_empty());
}

#[test]
fn the_detector_is_deterministic() {
    let mut state = 12345u32;
    let img: Vec<u8> = (0..120 * 90)
        .map(|i| {
            state = state.wrapping_mul(1_103_515_245).wrapping_add(12345);
            let noise = (state >> 24) as u8 / 8;
            if (i % 120) > 40 && (i / 120) > 30 {
                150 + noise
            } else {
                40 + noise
            }
        })
        .collect();
    let a = detect(&img, 120, 90, &Params::pytlsd()).unwrap();
    let b = detect(&img, 120, 90, &Params::pytlsd()).unwrap();
    assert_eq!(a, b);
    assert!(!a.is_empty());
}
