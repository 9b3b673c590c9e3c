//! The `limap-mini` fixture: a LIMAP output folder written by tests/data/make_limap_mini.py
//! with LIMAP's exact layout (Python f-strings and `%.10f`). Expected values come from that
//! script's JSON, computed in Python, not by this crate.

use std::path::{Path, PathBuf};

use limap::{
    AlltracksLayout, Check, LimapDir, LimapDirOptions, SegmentsOrigin, Summary, format_alltracks,
    format_image_list, format_segments, format_track, parse_alltracks, parse_image_list,
    parse_segments, parse_track, select_for_alltracks, write_limap_dir,
};
use serde_json::Value;

fn data() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data")
}

fn fixture() -> PathBuf {
    data().join("limap-mini")
}

fn expected() -> Value {
    let text = std::fs::read_to_string(data().join("limap-mini.expected.json")).unwrap();
    serde_json::from_str(&text).unwrap()
}

fn read(path: impl AsRef<Path>) -> String {
    std::fs::read_to_string(path).unwrap()
}

fn close(a: f64, b: &Value, tol: f64) -> bool {
    (a - b.as_f64().unwrap()).abs() <= tol
}

#[test]
fn loads_and_matches_python_counts() {
    let dir = LimapDir::load(fixture(), &LimapDirOptions::default()).unwrap();
    let e = expected();
    assert_eq!(dir.image_list.len() as u64, e["images"].as_u64().unwrap());
    for (id, name) in &dir.image_list.images {
        assert_eq!(
            e["image_names"][id.to_string()].as_str(),
            Some(name.as_str())
        );
    }
    assert_eq!(dir.segments.len(), 6);
    for (id, segs) in &dir.segments {
        assert_eq!(
            segs.len() as u64,
            e["segments_per_image"][id.to_string()].as_u64().unwrap()
        );
        assert!(segs.scores.is_none());
    }
    assert_eq!(dir.tracks.len() as u64, e["finaltracks"].as_u64().unwrap());
    let all = dir.alltracks.as_ref().unwrap();
    assert_eq!(all.len() as u64, e["alltracks"].as_u64().unwrap());
    assert_eq!(dir.segments_origin, SegmentsOrigin::Detected);
    assert!(dir.segments_dir.ends_with("line_detections/lsd/segments"));

    let t0 = &dir.tracks[0];
    let ids = |v: &Value| -> Vec<u64> {
        v.as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_u64().unwrap())
            .collect()
    };
    let want = &e["track_0"];
    assert_eq!(
        t0.image_ids.iter().map(|&x| x as u64).collect::<Vec<_>>(),
        ids(&want["image_ids"])
    );
    assert_eq!(
        t0.line_ids.iter().map(|&x| x as u64).collect::<Vec<_>>(),
        ids(&want["line_ids"])
    );
    let extras = t0.extras.as_ref().unwrap();
    assert_eq!(
        extras
            .node_ids
            .iter()
            .map(|&x| x as u64)
            .collect::<Vec<_>>(),
        ids(&want["node_ids"])
    );
    for (p, q) in t0.line.iter().zip(want["line"].as_array().unwrap()) {
        for (a, b) in p.iter().zip(q.as_array().unwrap()) {
            assert_eq!(*a, b.as_f64().unwrap());
        }
    }

    // alltracks.txt is the finaltracks with >= 4 images, renumbered.
    let map: Vec<usize> = ids(&e["alltracks_to_finaltracks"])
        .into_iter()
        .map(|x| x as usize)
        .collect();
    for (k, a) in all.iter().enumerate() {
        let f = &dir.tracks[map[k]];
        assert_eq!(a.image_ids, f.image_ids);
        assert_eq!(a.line_ids, f.line_ids);
        assert_eq!(a.line, f.line);
    }
}

#[test]
fn summary_statistics_match_python() {
    let dir = LimapDir::load(fixture(), &LimapDirOptions::default()).unwrap();
    let report = dir.check();
    assert!(report.is_ok());
    let s = Summary::new(&dir, &report);
    let e = expected();
    assert_eq!(s.finaltracks as u64, e["finaltracks"].as_u64().unwrap());
    assert_eq!(s.alltracks, Some(e["alltracks"].as_u64().unwrap() as usize));
    assert_eq!(
        s.tracks_with_4_images as u64,
        e["tracks_with_4_images"].as_u64().unwrap()
    );
    for (got, key, tol) in [
        (&s.supports_per_track, "supports_per_track", 1e-12),
        (&s.images_per_track, "images_per_track", 1e-12),
        (&s.length_3d, "length_3d", 1e-12),
    ] {
        let got = got.as_ref().unwrap();
        let want = &e[key];
        assert!(close(got.min, &want["min"], tol), "{key} min");
        assert!(close(got.mean, &want["mean"], tol), "{key} mean");
        assert!(close(got.median, &want["median"], tol), "{key} median");
        assert!(close(got.max, &want["max"], tol), "{key} max");
    }
    assert!(s.checks.iter().all(|c| c.errors == 0 && c.warnings == 0));
    assert_eq!(s.checks.len(), Check::ALL.len());
}

/// Reading then writing each file gives LIMAP's bytes back.
#[test]
fn every_file_rewrites_byte_identical() {
    let root = fixture();
    let text = read(root.join("image_list.txt"));
    assert_eq!(
        format_image_list(&parse_image_list(&text).unwrap()).unwrap(),
        text
    );

    let text = read(root.join("alltracks.txt"));
    let all = parse_alltracks(&text).unwrap();
    assert_eq!(
        format_alltracks(&all, AlltracksLayout::Limap).unwrap(),
        text
    );

    let seg_dir = root.join("line_detections/lsd/segments");
    for id in 1..=6 {
        let text = read(seg_dir.join(format!("segments_{id}.txt")));
        assert_eq!(
            format_segments(&parse_segments(&text).unwrap()).unwrap(),
            text,
            "segments_{id}"
        );
    }
    let mut tracks = Vec::new();
    for i in 0..10 {
        let text = read(root.join(format!("finaltracks/track_{i}.txt")));
        let t = parse_track(&text).unwrap();
        assert_eq!(format_track(&t).unwrap(), text, "track_{i}");
        tracks.push(t);
    }
    // alltracks written from the finaltracks equals LIMAP's too.
    assert_eq!(
        format_alltracks(select_for_alltracks(&tracks), AlltracksLayout::Limap).unwrap(),
        read(root.join("alltracks.txt"))
    );
}

/// Writing the loaded folder reproduces every file LIMAP wrote.
#[test]
fn write_limap_dir_reproduces_the_folder() {
    let dir = LimapDir::load(fixture(), &LimapDirOptions::default()).unwrap();
    let out = tempfile::tempdir().unwrap();
    write_limap_dir(
        out.path(),
        "lsd",
        &dir.image_list,
        &dir.segments,
        &dir.tracks,
    )
    .unwrap();
    // A second write over the first replaces the folders cleanly.
    write_limap_dir(
        out.path(),
        "lsd",
        &dir.image_list,
        &dir.segments,
        &dir.tracks,
    )
    .unwrap();
    let files = testkit::files::folder_bytes(out.path());
    let mut want = testkit::files::folder_bytes(&fixture());
    want.remove("metainfos.txt");
    assert_eq!(
        files.keys().collect::<Vec<_>>(),
        want.keys().collect::<Vec<_>>()
    );
    for (name, bytes) in &want {
        assert!(files[name] == *bytes, "{name} differs");
    }
    let back = LimapDir::load(out.path(), &LimapDirOptions::default()).unwrap();
    assert_eq!(back.tracks, dir.tracks);
}
