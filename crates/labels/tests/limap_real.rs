//! The real tools' output, read unconverted: the tiny synthetic scene through pycolmap
//! (SIFT, exhaustive matching, point triangulation with the known poses) and LIMAP 2.0
//! (LSD, exhaustive line matching, line triangulation with the known poses), run by
//! scripts/limap-tiny.py in the LIMAP venv (scripts/setup-python.sh;
//! `PL2MAP_LIMAP_PYTHON`). The LIMAP folder is read as LIMAP 2.0 writes it
//! (docs/formats.md section 2) and its counts are compared with what the script read
//! through LIMAP's own Python API (`report.json`); then the import takes both folders
//! unconverted and its label counts are compared with the same numbers, and
//! `point_labels = "detected"` keeps what OpenCV's Python SIFT and pycolmap count
//! (`opencv_detected.py`). Skips with its reason without the venv.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;

use datasets::ingest::{DatasetKind, IngestConfig};
use datasets::ingest_stage;
use labels::import::{self, DETECTED_RADIUS_PX, ImportConfig, LineTrackSet, PointLabels};
use labels::import_stage;
use limap::{Layout, LimapDir, LimapDirOptions, SegmentsOrigin};
use serde_json::Value;
use synth::generate_tiny;

fn script() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scripts/limap-tiny.py")
}

fn as_u64(v: &Value) -> u64 {
    v.as_u64().unwrap_or_else(|| panic!("not an integer: {v}"))
}

#[test]
fn limap2_output_of_the_real_tools_reads_unconverted() {
    let Some(python) = testkit::python::limap_python(&["limap", "pycolmap", "pytlsd"]) else {
        return;
    };
    let dir = tempfile::Builder::new()
        .prefix("labels-limap-real-")
        .tempdir_in(env!("CARGO_TARGET_TMPDIR"))
        .unwrap();
    let synth = generate_tiny(&dir.path().join("data")).expect("synth");
    let out = dir.path().join("tools");
    let started = std::time::Instant::now();
    testkit::python::run(
        Command::new(&python)
            .arg(script())
            .arg(&synth.root)
            .arg(&out),
    );
    eprintln!(
        "scripts/limap-tiny.py ran in {:.1} s",
        started.elapsed().as_secs_f64()
    );
    let report: Value =
        serde_json::from_slice(&std::fs::read(out.join("report.json")).unwrap()).unwrap();

    let root = out.join("limap");
    let limap = LimapDir::load(&root, &LimapDirOptions::default()).expect("LIMAP 2.0 folder");
    assert_eq!(limap.layout, Layout::Limap2);
    assert_eq!(limap.segments_origin, SegmentsOrigin::Detected);
    assert!(
        limap
            .segments_dir
            .ends_with("frontend/line_detections/lsd/segments")
    );

    // Images: the model's, by id, with their names.
    let images: Vec<(u32, String)> = report["images"]
        .as_object()
        .unwrap()
        .iter()
        .map(|(id, name)| (id.parse().unwrap(), name.as_str().unwrap().to_string()))
        .collect::<BTreeMap<_, _>>()
        .into_iter()
        .collect();
    assert_eq!(limap.image_list.images, images);

    // Segments: one file per image, as many rows as LIMAP's structures hold.
    let per_image: BTreeMap<u32, usize> = report["lines2d_per_image"]
        .as_object()
        .unwrap()
        .iter()
        .map(|(id, n)| (id.parse().unwrap(), as_u64(n) as usize))
        .collect();
    let ours: BTreeMap<u32, usize> = limap
        .segments
        .iter()
        .map(|(id, s)| (*id, s.len()))
        .collect();
    assert_eq!(ours, per_image);

    // Tracks: the same 3D lines in id order, each with the same supports.
    let lines = report["lines3d"].as_array().unwrap();
    assert_eq!(limap.tracks.len(), lines.len());
    let ids = limap.line3d_ids.as_ref().unwrap();
    for (k, (track, line)) in limap.tracks.iter().zip(lines).enumerate() {
        assert_eq!(ids[k], as_u64(&line["id"]), "track {k}");
        let supports: Vec<(u32, u32)> = line["supports"]
            .as_array()
            .unwrap()
            .iter()
            .map(|s| (as_u64(&s[0]) as u32, as_u64(&s[1]) as u32))
            .collect();
        assert_eq!(track.supports().collect::<Vec<_>>(), supports, "track {k}");
        assert_eq!(
            track.n_images() as u64,
            as_u64(&line["n_images"]),
            "track {k}"
        );
    }
    // The alltracks label set: tracks seen in >= 4 images.
    let all = limap.alltracks.as_ref().unwrap();
    assert_eq!(all.len() as u64, as_u64(&report["tracks_in_4_images"]));
    let supports: usize = limap.tracks.iter().map(|t| t.n_lines()).sum();
    eprintln!(
        "LIMAP 2.0: {} images, {} segments, {} 3D lines ({} supports), {} in >= 4 images; \
         {} 3D points",
        limap.image_list.len(),
        ours.values().sum::<usize>(),
        limap.tracks.len(),
        supports,
        all.len(),
        as_u64(&report["points3d"])
    );
    assert!(!limap.tracks.is_empty() && !all.is_empty());

    // The same folder given as final_model/ reads the same.
    let inside = LimapDir::load(root.join("final_model"), &LimapDirOptions::default()).unwrap();
    assert_eq!(inside.root, root);
    assert_eq!(inside.tracks, limap.tracks);
    assert_eq!(inside.segments, limap.segments);

    // Without frontend/ (LIMAP's default clean-up deletes it), the segments come from
    // structures2d.bin: the same rows, the same tracks.
    std::fs::rename(root.join("frontend"), out.join("frontend.aside")).unwrap();
    let cleaned = LimapDir::load(&root, &LimapDirOptions::default()).unwrap();
    std::fs::rename(out.join("frontend.aside"), root.join("frontend")).unwrap();
    assert_eq!(cleaned.segments_origin, SegmentsOrigin::Structures);
    assert_eq!(cleaned.segments, limap.segments);
    assert_eq!(cleaned.tracks, limap.tracks);
    assert_eq!(cleaned.alltracks, limap.alltracks);

    // The import takes both folders as they are, with its default settings (the bounds
    // tolerance covers LSD's overshoot past the border, the detector check takes
    // pycolmap's SIFT and LIMAP's LSD for the front-end's detectors; docs/formats.md
    // section 2): every support labels one segment, every observation one keypoint. The
    // rates are printed.
    let frames = ingest_stage::run(
        &IngestConfig::new(DatasetKind::SevenScenes, &synth.root),
        &dir.path().join("frames"),
    )
    .expect("ingest")
    .output
    .frames_path;
    let observations = as_u64(&report["observations"]) as usize;
    for (set, tracks) in [
        (LineTrackSet::Finaltracks, &limap.tracks),
        (LineTrackSet::Alltracks, all),
    ] {
        let config = ImportConfig {
            model: Some(out.join("colmap/sparse")),
            limap: Some(root.clone()),
            line_tracks: set,
            ..ImportConfig::default()
        };
        let done = import_stage::run(
            &config,
            &frames,
            &dir.path().join(set.as_str()),
            &import::sift_only,
        )
        .expect("import");
        let r = &done.output.report;
        assert_eq!(r.limap.tracks, tracks.len(), "{set:?}");
        assert_eq!(r.limap.tracks_used, tracks.len(), "{set:?}");
        assert_eq!(
            r.lines.valid,
            tracks.iter().map(|t| t.n_lines()).sum::<usize>(),
            "{set:?}"
        );
        assert_eq!(r.lines.segments, ours.values().sum::<usize>(), "{set:?}");
        assert_eq!(r.points.valid, observations, "{set:?}");
        assert_eq!(
            r.points.points3d_observed as u64,
            as_u64(&report["points3d"])
        );
        let d = r.detector_check.as_ref().unwrap();
        assert_eq!(d.decision, "passed", "{}", d.rates());
        eprintln!(
            "import ({}): {} line labels, {} point labels; detector check: {}",
            set.as_str(),
            r.lines.valid,
            r.points.valid,
            d.rates()
        );
    }

    // point_labels = "detected" on pycolmap's model keeps the keypoints (and labels) that
    // OpenCV's Python SIFT detects within the radius, as pycolmap and OpenCV count them.
    let counted = testkit::python::run(
        Command::new(&python)
            .arg(Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/opencv_detected.py"))
            .arg(out.join("colmap/sparse"))
            .arg(&synth.root)
            .arg(DETECTED_RADIUS_PX.to_string()),
    );
    let counted: Value = serde_json::from_slice(&counted).unwrap();
    let config = ImportConfig {
        model: Some(out.join("colmap/sparse")),
        limap: Some(root.clone()),
        point_labels: PointLabels::Detected,
        ..ImportConfig::default()
    };
    let done = import_stage::run(
        &config,
        &frames,
        &dir.path().join("detected"),
        &import::sift_only,
    )
    .expect("import");
    let d = done.output.report.detected_labels.clone().unwrap();
    eprintln!("{}; OpenCV (Python) and pycolmap count {counted}", d.line());
    assert_eq!(d.keypoints as u64, as_u64(&counted["keypoints"]));
    assert_eq!(d.labels as u64, as_u64(&counted["labels"]));
    // The Python wheel's OpenCV may be another release than the one pl2map links: equal
    // on 2026-12-03 (5.1.0 against 4.6.0), within half a percent allowed.
    for (ours, theirs) in [
        (d.keypoints_kept, &counted["keypoints_kept"]),
        (d.labels_kept, &counted["labels_kept"]),
    ] {
        let theirs = as_u64(theirs) as f64;
        assert!(
            (ours as f64 - theirs).abs() <= 0.005 * theirs,
            "{ours} kept against {theirs} counted: {}",
            d.line()
        );
    }
    assert!(d.keypoints_kept < d.keypoints && d.labels_kept > 0);
}
