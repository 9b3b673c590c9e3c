//! `pl2map limap info` on the limap crate's `limap-mini` fixture (a LIMAP output folder
//! in LIMAP's exact layout); expected numbers come from the fixture generator's JSON,
//! computed in Python.

use std::path::{Path, PathBuf};
use std::process::Command;

use serde_json::Value;

fn data() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../limap/tests/data")
}

fn pl2map(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_pl2map"))
        .args(args)
        .output()
        .unwrap()
}

fn expected() -> Value {
    serde_json::from_str(&std::fs::read_to_string(data().join("limap-mini.expected.json")).unwrap())
        .unwrap()
}

#[test]
fn info_json_matches_the_fixture() {
    let dir = data().join("limap-mini");
    let out = pl2map(&["limap", "info", dir.to_str().unwrap(), "--json"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let s: Value = serde_json::from_slice(&out.stdout).unwrap();
    let e = expected();
    for key in ["images", "finaltracks", "alltracks", "tracks_with_4_images"] {
        assert_eq!(s[key], e[key], "{key}");
    }
    let segments: u64 = e["segments_per_image"]
        .as_object()
        .unwrap()
        .values()
        .map(|v| v.as_u64().unwrap())
        .sum();
    assert_eq!(s["segments"].as_u64(), Some(segments));
    assert_eq!(s["segment_files"].as_u64(), Some(6));
    for key in ["supports_per_track", "images_per_track", "length_3d"] {
        for stat in ["min", "mean", "median", "max"] {
            let got = s[key][stat].as_f64().unwrap();
            let want = e[key][stat].as_f64().unwrap();
            assert!((got - want).abs() < 1e-12, "{key}.{stat}: {got} vs {want}");
        }
    }
    assert_eq!(s["segments_origin"], "detected");
    let checks = s["checks"].as_array().unwrap();
    assert_eq!(checks.len(), 6);
    assert!(checks.iter().all(|c| c["status"] == "ok"), "{checks:?}");
}

#[test]
fn info_text_lists_counts_and_checks() {
    let dir = data().join("limap-mini");
    let seg = dir.join("line_detections/lsd/segments");
    let out = pl2map(&[
        "limap",
        "info",
        dir.to_str().unwrap(),
        "--segments",
        seg.to_str().unwrap(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8(out.stdout).unwrap();
    let e = expected();
    assert!(
        text.contains(&format!("finaltracks            {}", e["finaltracks"])),
        "{text}"
    );
    assert!(
        text.contains(&format!("alltracks.txt          {}", e["alltracks"])),
        "{text}"
    );
    assert!(text.contains("(given)"), "{text}");
    for name in [
        "known_images",
        "line_ids_in_range",
        "unique_supports",
        "lines2d_match_segments",
        "alltracks_match_finaltracks",
        "segments_match_image_list",
    ] {
        assert!(text.contains(name), "{name} missing:\n{text}");
    }
}

#[test]
fn info_fails_on_inconsistent_folders_after_reporting() {
    let tmp = tempfile::tempdir().unwrap();
    testkit::files::copy_dir(&data().join("limap-mini"), tmp.path());
    // Point support 0 of track_1.txt at an image that is not listed.
    let p = tmp.path().join("finaltracks/track_1.txt");
    let text = std::fs::read_to_string(&p).unwrap();
    let line = text
        .lines()
        .find(|l| l.starts_with("image_id_list"))
        .unwrap();
    let mut ids: Vec<&str> = line.split_whitespace().collect();
    let n_images_before = ids[1..]
        .iter()
        .collect::<std::collections::HashSet<_>>()
        .len();
    let replaced = ids[1];
    ids[1] = "99";
    let n_images_after = ids[1..]
        .iter()
        .collect::<std::collections::HashSet<_>>()
        .len();
    let mut new_text = text.replacen(line, &format!("{} ", ids.join(" ")), 1);
    if n_images_after != n_images_before {
        // keep the header consistent so only the cross-file check fails
        let header = new_text.lines().nth(1).unwrap().to_string();
        let n_lines = header.split(' ').next().unwrap();
        new_text = new_text.replacen(&header, &format!("{n_lines} {n_images_after}"), 1);
    }
    std::fs::write(&p, new_text).unwrap();
    assert_ne!(replaced, "99");

    let out = pl2map(&["limap", "info", tmp.path().to_str().unwrap()]);
    assert!(!out.status.success());
    let stdout = String::from_utf8(out.stdout).unwrap();
    let stderr = String::from_utf8(out.stderr).unwrap();
    assert!(
        stdout.contains("known_images") && stdout.contains("FAILED"),
        "{stdout}"
    );
    assert!(
        stdout.contains("track_1.txt: support 0 is in image 99"),
        "{stdout}"
    );
    assert!(stderr.contains("consistency error"), "{stderr}");
}

#[test]
fn info_names_the_broken_file() {
    let tmp = tempfile::tempdir().unwrap();
    testkit::files::copy_dir(&data().join("limap-mini"), tmp.path());
    std::fs::remove_file(tmp.path().join("finaltracks/track_4.txt")).unwrap();
    let out = pl2map(&["limap", "info", tmp.path().to_str().unwrap()]);
    assert!(!out.status.success());
    let stderr = String::from_utf8(out.stderr).unwrap();
    assert!(stderr.contains("track_4.txt is missing"), "{stderr}");
}
