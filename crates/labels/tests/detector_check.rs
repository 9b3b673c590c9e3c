//! The import's detector check (docs/method.md section 3) on inputs whose detectors are
//! known: the tiny synthetic scene's SfM model holds OpenCV SIFT detections and its LIMAP
//! folder OpenCV LSD segments of the rendered images (crates/synth/src/gt/frame.rs);
//! SuperPoint (random weights: a legitimate network, not the released one) stands for
//! another keypoint detector; LSD on the half-resolution image for another line detector;
//! and COLMAP's own SIFT model of real photos (sample data) for another implementation of
//! the configured detector. Every test prints the rates it measured.

use datasets::ingest::{DatasetKind, IngestConfig};
use datasets::ingest_stage;
use features::{FrontEnd, FrontEndConfig, FrontEndKind, SiftFrontEnd};
use labels::import::{
    self, DETECTED_RADIUS_PX, DetectorCheck, ImportConfig, ImportError, MATCH_RADIUS_PX,
    MIN_KEYPOINT_RATE, MIN_SEGMENT_RATE, PointLabels, matched_keypoints,
};
use labels::import_stage;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::path::{Path, PathBuf};
use std::sync::{Arc, OnceLock};
use synth::generate_tiny;
use tables::frames::FramesTable;

/// The tiny synthetic scene, rendered and ingested once per test binary.
struct Fixture {
    _dir: tempfile::TempDir,
    root: PathBuf,
    frames: PathBuf,
}

fn fixture() -> &'static Fixture {
    static F: OnceLock<Fixture> = OnceLock::new();
    F.get_or_init(|| {
        // A static is never dropped: the folder (about 20 MB) stays in the target's tmp
        // folder, named so that it can be found.
        let dir = tempfile::Builder::new()
            .prefix("labels-detector-check-")
            .tempdir_in(env!("CARGO_TARGET_TMPDIR"))
            .unwrap();
        let synth = generate_tiny(&dir.path().join("data")).expect("synth");
        let ic = IngestConfig::new(DatasetKind::SevenScenes, &synth.root);
        let frames = ingest_stage::run(&ic, &dir.path().join("frames"))
            .expect("ingest")
            .output
            .frames_path;
        Fixture {
            root: synth.root.clone(),
            frames,
            _dir: dir,
        }
    })
}

fn gt(f: &Fixture) -> PathBuf {
    f.root.join(synth::gt::GT_DIR)
}

fn config(f: &Fixture, limap: Option<PathBuf>) -> ImportConfig {
    ImportConfig {
        model: Some(gt(f).join("colmap")),
        limap: Some(limap.unwrap_or_else(|| gt(f).join("limap"))),
        ..ImportConfig::default()
    }
}

fn superpoint_config(f: &Fixture) -> ImportConfig {
    let mut c = config(f, None);
    c.front_end.kind = FrontEndKind::Superpoint;
    c
}

/// SuperPoint on random weights (seeded): the test's other keypoint detector.
fn make_superpoint(c: &FrontEndConfig) -> Result<Arc<dyn FrontEnd>, String> {
    match c.kind {
        FrontEndKind::Superpoint => Ok(Arc::new(
            superpoint::SuperPointFrontEnd::from_weights(
                c.clone(),
                &superpoint::Weights::random(7),
            )
            .map_err(|e| e.to_string())?,
        )),
        FrontEndKind::Sift => import::sift_only(c),
    }
}

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let e = e.unwrap();
        let target = to.join(e.file_name());
        if e.path().is_dir() {
            copy_dir(&e.path(), &target);
        } else {
            std::fs::copy(e.path(), target).unwrap();
        }
    }
}

/// A copy of the scene's LIMAP folder whose segments `change` rewrote: it gets the
/// image of the segments' LIMAP image and their lines, and returns as many lines.
fn limap_with(
    f: &Fixture,
    out: &Path,
    change: impl Fn(&image::GrayImage, &[[f64; 4]]) -> Vec<[f64; 4]>,
) -> PathBuf {
    let dir = out.join("limap");
    copy_dir(&gt(f).join("limap"), &dir);
    let frames = FramesTable::read_parquet(&f.frames).unwrap();
    let list = limap::read_image_list(dir.join(limap::dir::IMAGE_LIST_FILE)).unwrap();
    let segs_dir = dir.join("line_detections/lsd/segments");
    let mut changed = std::collections::HashMap::new();
    for id in list.ids() {
        let path = segs_dir.join(limap::segments::segments_file_name(id));
        if !path.is_file() {
            continue;
        }
        let name = list.name(id).unwrap();
        let frame = frames.frames.iter().find(|fr| fr.name == name).unwrap();
        let img = features::load_gray(&frame.path).unwrap();
        let mut segs = limap::read_segments(&path).unwrap();
        let lines = change(&img, &segs.lines);
        assert_eq!(lines.len(), segs.lines.len());
        segs.lines = lines.clone();
        limap::write_segments(&path, &segs).unwrap();
        changed.insert(id, lines);
    }
    // The tracks list their supports' 2D segments too: a LIMAP run of that detector
    // would have written the same ones there.
    let tracks = dir.join("finaltracks");
    for e in std::fs::read_dir(&tracks).unwrap() {
        let path = e.unwrap().path();
        if path.extension().is_none_or(|x| x != "txt") {
            continue;
        }
        let mut t = limap::read_track(&path).unwrap();
        if let Some(l2) = t.lines2d.as_mut() {
            for (k, (img, line)) in t.image_ids.iter().zip(&t.line_ids).enumerate() {
                l2[k] = changed[img][*line as usize];
            }
        }
        limap::write_track(&path, &t).unwrap();
    }
    dir
}

#[test]
fn the_synthetic_sift_model_passes_under_sift() {
    let f = fixture();
    let out = tempfile::tempdir().unwrap();
    let done = import_stage::run(&config(f, None), &f.frames, out.path(), &import::sift_only)
        .expect("import");
    let c = done
        .output
        .report
        .detector_check
        .clone()
        .expect("the check ran");
    println!("SIFT model under sift: {}", c.rates());
    assert_eq!(c.decision, "passed");
    assert_eq!(c.front_end, "sift");
    assert_eq!(c.images.len(), import::SAMPLE_IMAGES);
    assert!(c.keypoint_rate >= MIN_KEYPOINT_RATE && c.segment_rate >= MIN_SEGMENT_RATE);
    // The model's keypoints and LIMAP's segments are these very detections.
    assert!(
        c.keypoint_rate > 0.99 && c.segment_rate > 0.99,
        "{}",
        c.rates()
    );
    let json = std::fs::read_to_string(out.path().join(import_stage::REPORT_FILE)).unwrap();
    assert!(json.contains("\"detector_check\"") && json.contains("\"passed\""));
    assert!(
        done.output
            .report
            .table()
            .contains("detector check (passed)")
    );
}

#[test]
fn a_sift_model_under_superpoint_is_refused_with_the_rates_cause_and_fix() {
    let f = fixture();
    let out = tempfile::tempdir().unwrap();
    let e = import_stage::run(
        &superpoint_config(f),
        &f.frames,
        out.path(),
        &make_superpoint,
    )
    .unwrap_err();
    let ImportError::DetectorMismatch { report } = &e else {
        panic!("expected a detector mismatch, got {e}");
    };
    println!("SIFT model under superpoint: {}", report.rates());
    assert_eq!(report.front_end, "superpoint");
    assert_eq!(report.decision, "refused");
    assert!(
        report.keypoint_rate < MIN_KEYPOINT_RATE,
        "{}",
        report.rates()
    );
    // LIMAP's segments are LSD's, SuperPoint's line detector too.
    assert!(report.segment_rate > 0.99, "{}", report.rates());
    let msg = e.to_string();
    for needle in [
        "% of",
        "model keypoints",
        "SuperPoint for hloc's sfm_superpoint+superglue",
        "[features] kind",
        "detector_check = \"accept\"",
    ] {
        assert!(msg.contains(needle), "{needle:?} missing from: {msg}");
    }
    assert!(!msg.contains("DeepLSD"), "{msg}");
    // Nothing written under a final name, no record.
    assert!(!out.path().join(import_stage::REPORT_FILE).exists());
    assert!(!out.path().join("stage.json").exists());
}

#[test]
fn accept_imports_the_mismatch_and_the_report_keeps_it() {
    let f = fixture();
    let out = tempfile::tempdir().unwrap();
    let mut c = superpoint_config(f);
    c.detector_check = DetectorCheck::Accept;
    let done = import_stage::run(&c, &f.frames, out.path(), &make_superpoint).expect("accepted");
    let r = &done.output.report;
    let check = r.detector_check.as_ref().expect("the check ran");
    assert_eq!(check.decision, "accepted");
    assert!(check.keypoint_rate < MIN_KEYPOINT_RATE);
    let json = std::fs::read_to_string(out.path().join(import_stage::REPORT_FILE)).unwrap();
    assert!(json.contains("\"accepted\"") && json.contains("\"keypoint_rate\""));
    assert!(json.contains("\"detector_check\": \"accept\""), "{json}");
    assert!(r.table().contains("detector check (accepted)"));
    assert!(r.warnings.iter().any(|w| w.contains("accepted")));
}

#[test]
fn off_runs_no_check_and_keeps_the_default_bytes() {
    let f = fixture();
    let out = tempfile::tempdir().unwrap();
    let mut c = superpoint_config(f);
    c.detector_check = DetectorCheck::Off;
    // SuperPoint is never built: the plain run (SIFT only) is enough.
    let done = import_stage::run(&c, &f.frames, out.path(), &import::sift_only).expect("import");
    assert!(done.output.report.detector_check.is_none());
    let json = std::fs::read_to_string(out.path().join(import_stage::REPORT_FILE)).unwrap();
    assert!(!json.contains("keypoint_rate"));
    // The defaults are left out of the serialised configuration (records and reports of
    // imports made before the check keep their bytes).
    let default = serde_json::to_string(&ImportConfig::default()).unwrap();
    assert!(!default.contains("detector_check") && !default.contains("front_end"));
}

#[test]
fn jittered_limap_segments_are_refused() {
    let f = fixture();
    let out = tempfile::tempdir().unwrap();
    let rng = std::sync::Mutex::new(ChaCha8Rng::seed_from_u64(5));
    let limap = limap_with(f, out.path(), |img, lines| {
        let mut rng = rng.lock().unwrap();
        let (w, h) = (f64::from(img.width()), f64::from(img.height()));
        lines
            .iter()
            .map(|s| {
                let mut j = s.map(|v| v + rng.random_range(-3.0..3.0));
                for (k, v) in j.iter_mut().enumerate() {
                    let max = if k % 2 == 0 { w } else { h };
                    *v = v.clamp(0.5, max - 0.5);
                }
                j
            })
            .collect()
    });
    let e = import_stage::run(
        &config(f, Some(limap)),
        &f.frames,
        &out.path().join("out"),
        &import::sift_only,
    )
    .unwrap_err();
    let ImportError::DetectorMismatch { report } = &e else {
        panic!("expected a detector mismatch, got {e}");
    };
    println!("LIMAP segments jittered by up to 3 px: {}", report.rates());
    assert!(report.segment_rate < MIN_SEGMENT_RATE);
    assert!(report.keypoint_rate > 0.99);
    assert!(e.to_string().contains("another line detector"), "{e}");
}

/// LIMAP's LSD keeps segments of every length, the front-end drops those under its
/// `lsd.min_length`: short LIMAP segments are counted apart, not as mismatches.
#[test]
fn short_limap_segments_are_left_out_of_the_rate() {
    let f = fixture();
    let out = tempfile::tempdir().unwrap();
    // Every other segment cut to 8 px about its midpoint.
    let limap = limap_with(f, out.path(), |_, lines| {
        lines
            .iter()
            .enumerate()
            .map(|(i, s)| {
                if i % 2 == 1 {
                    return *s;
                }
                let (mx, my) = ((s[0] + s[2]) / 2.0, (s[1] + s[3]) / 2.0);
                let (dx, dy) = (s[2] - s[0], s[3] - s[1]);
                let k = 4.0 / dx.hypot(dy);
                [mx - k * dx, my - k * dy, mx + k * dx, my + k * dy]
            })
            .collect()
    });
    let done = import_stage::run(
        &config(f, Some(limap)),
        &f.frames,
        &out.path().join("out"),
        &import::sift_only,
    )
    .expect("import");
    let c = done.output.report.detector_check.expect("the check ran");
    println!("half the LIMAP segments cut to 8 px: {}", c.rates());
    assert_eq!(c.decision, "passed");
    assert_eq!(
        c.min_segment_length_px,
        features::LsdConfig::default().min_length + 2.0 * c.radius_px
    );
    assert!(c.segments_short > 0 && c.segments > 0, "{}", c.rates());
    assert!(c.segment_rate > 0.99, "{}", c.rates());
    assert!(c.rates().contains("shorter ones not compared"));
}

#[test]
fn limap_segments_of_another_detector_are_refused() {
    let f = fixture();
    let out = tempfile::tempdir().unwrap();
    // Another detector: LSD on the half-resolution image, its segments scaled back
    // (COLMAP pixels scale exactly); each LIMAP segment becomes that detector's segment
    // nearest to it (midpoints), so that the tracks keep their line ids.
    let limap = limap_with(f, out.path(), |img, lines| {
        let (w, h) = img.dimensions();
        let half = image::imageops::resize(img, w / 2, h / 2, image::imageops::Triangle);
        let other: Vec<[f64; 4]> =
            features::detect_segments(&half, &features::LsdConfig::default())
                .unwrap()
                .into_iter()
                .map(|s| s.map(|v| v * 2.0))
                .collect();
        assert!(!other.is_empty());
        let mid = |s: &[f64; 4]| [(s[0] + s[2]) / 2.0, (s[1] + s[3]) / 2.0];
        lines
            .iter()
            .map(|s| {
                let m = mid(s);
                *other
                    .iter()
                    .min_by(|a, b| {
                        let d = |x: &[f64; 4]| {
                            let n = mid(x);
                            (n[0] - m[0]).powi(2) + (n[1] - m[1]).powi(2)
                        };
                        d(a).total_cmp(&d(b))
                    })
                    .unwrap()
            })
            .collect()
    });
    let e = import_stage::run(
        &config(f, Some(limap)),
        &f.frames,
        &out.path().join("out"),
        &import::sift_only,
    )
    .unwrap_err();
    let ImportError::DetectorMismatch { report } = &e else {
        panic!("expected a detector mismatch, got {e}");
    };
    println!(
        "LIMAP segments of LSD at half resolution: {}",
        report.rates()
    );
    assert!(report.segment_rate < MIN_SEGMENT_RATE);
}

/// COLMAP's SIFT (pycolmap 4.2.1, sample data) is another implementation of the SIFT
/// detector: the check must take its model for SIFT's under the sift front-end.
#[test]
fn colmap_s_own_sift_model_passes_under_sift() {
    let Some(dir) = testkit::sample::sample_data("colmap-sacre-coeur") else {
        return;
    };
    let model = colmap::read(&dir.join("model-bin")).unwrap();
    let (mut n, mut matched) = (0, 0);
    for im in &model.images {
        let img = features::load_gray(&dir.join("images").join(&im.name)).unwrap();
        let kps: Vec<[f64; 2]> = im.points2d.iter().map(|p| p.xy).collect();
        let mut c = FrontEndConfig::default();
        c.sift.max_keypoints = c.sift.max_keypoints.max(kps.len());
        let det = SiftFrontEnd::new(c)
            .unwrap()
            .detect(&img)
            .unwrap()
            .keypoints;
        let m = matched_keypoints(&kps, &det, MATCH_RADIUS_PX);
        println!(
            "{}: {m} of {} COLMAP SIFT keypoints matched ({} detections)",
            im.name,
            kps.len(),
            det.len()
        );
        n += kps.len();
        matched += m;
    }
    let rate = matched as f64 / n as f64;
    println!("COLMAP SIFT model under sift: {:.1} % of {n}", 100.0 * rate);
    assert!(rate >= MIN_KEYPOINT_RATE, "{rate}");
}

/// Imports `c` with `point_labels = "detected"` into a fresh folder; prints what it kept.
fn import_detected(
    mut c: ImportConfig,
    what: &str,
) -> (
    tempfile::TempDir,
    stage::Done<import_stage::ImportOutput>,
    import::DetectedLabelsReport,
) {
    c.point_labels = PointLabels::Detected;
    let out = tempfile::tempdir().unwrap();
    let done =
        import_stage::run(&c, &fixture().frames, out.path(), &import::sift_only).expect("import");
    let d = done.output.report.detected_labels.clone().expect("ran");
    println!("{what}: {}", d.line());
    (out, done, d)
}

/// `point_labels = "detected"` keeps the model keypoints the front-end detects and
/// leaves the others out: the synthetic model's keypoints are the front-end's own
/// detections (all kept); moved by 3 px, none is a detection any more.
#[test]
fn detected_point_labels_keep_the_front_end_s_own_keypoints_only() {
    let f = fixture();
    let all = tempfile::tempdir().unwrap();
    let base = import_stage::run(&config(f, None), &f.frames, all.path(), &import::sift_only)
        .expect("import");
    let (keypoints, labelled) = (
        base.output.report.points.keypoints,
        base.output.report.points.valid,
    );
    assert!(base.output.report.detected_labels.is_none());

    let (out, done, d) = import_detected(config(f, None), "own keypoints");
    assert_eq!((d.keypoints, d.keypoints_kept), (keypoints, keypoints));
    assert_eq!((d.labels, d.labels_kept), (labelled, labelled));
    assert!(
        done.output
            .report
            .table()
            .contains("model keypoints at sift detections")
    );
    assert!(
        stage::Note::note(&done.output).contains(&format!(
            "{labelled} of {keypoints} keypoints at the front-end's detections"
        )),
        "{}",
        stage::Note::note(&done.output)
    );
    let same = |a: &Path, b: &Path| {
        let (a, b) = (
            tables::labels::LabelTables::read(a).unwrap(),
            tables::labels::LabelTables::read(b).unwrap(),
        );
        a.points == b.points
    };
    assert!(same(all.path(), out.path()));

    // The same model with every keypoint 3 px to the right. A moved keypoint survives
    // only where it lands within 1 px of another keypoint of its image (the model's
    // keypoints are the detections): counted here by brute force.
    let mut model = colmap::read(&gt(f).join("colmap")).unwrap();
    let train: std::collections::HashSet<String> = FramesTable::read_parquet(&f.frames)
        .unwrap()
        .frames
        .iter()
        .filter(|fr| fr.split == tables::frames::Split::Train)
        .map(|fr| fr.name.clone())
        .collect();
    let mut survivors = (0, 0);
    for im in model.images.iter_mut() {
        let before: Vec<[f64; 2]> = im.points2d.iter().map(|p| p.xy).collect();
        for p in im.points2d.iter_mut() {
            p.xy[0] += 3.0;
            let near = before
                .iter()
                .any(|q| (q[0] - p.xy[0]).hypot(q[1] - p.xy[1]) <= DETECTED_RADIUS_PX);
            if near && train.contains(&im.name) {
                survivors.0 += 1;
                survivors.1 += p.has_point3d() as usize;
            }
        }
    }
    let moved = tempfile::tempdir().unwrap();
    colmap::write_binary(&model, moved.path()).unwrap();
    let mut c = config(f, None);
    c.model = Some(moved.path().to_path_buf());
    c.detector_check = DetectorCheck::Off;
    let (out, _, d) = import_detected(c, "keypoints moved by 3 px");
    assert_eq!((d.keypoints, d.labels), (keypoints, labelled));
    assert_eq!((d.keypoints_kept, d.labels_kept), survivors);
    assert!(d.keypoints_kept * 20 < keypoints, "{}", d.line());
    let points = tables::labels::LabelTables::read(out.path())
        .unwrap()
        .points;
    assert_eq!(points.len(), survivors.0);
}
