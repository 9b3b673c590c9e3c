//! Folder-level reading and the cross-file checks, on altered copies of `limap-mini`.

use std::path::{Path, PathBuf};

use limap::{
    Check, LimapDir, LimapDirOptions, LimapError, Problem, SegmentsOrigin, Severity,
    write_limap_dir,
};

fn fixture() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/limap-mini")
}

fn copy() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    testkit::files::copy_dir(&fixture(), dir.path());
    dir
}

fn original() -> LimapDir {
    LimapDir::load(fixture(), &LimapDirOptions::default()).unwrap()
}

/// Writes `dir` (altered by the caller) as a LIMAP folder and opens it without checks.
fn rewrite(dir: &LimapDir) -> (tempfile::TempDir, LimapDir) {
    let out = tempfile::tempdir().unwrap();
    write_limap_dir(
        out.path(),
        "lsd",
        &dir.image_list,
        &dir.segments,
        &dir.tracks,
    )
    .unwrap();
    let back = LimapDir::open_unchecked(out.path(), &LimapDirOptions::default()).unwrap();
    (out, back)
}

fn problems(dir: &LimapDir, check: Check) -> Vec<Problem> {
    dir.check().get(check).unwrap().problems.clone()
}

#[test]
fn missing_track_index_is_named() {
    let d = copy();
    std::fs::remove_file(d.path().join("finaltracks/track_3.txt")).unwrap();
    let e = LimapDir::load(d.path(), &LimapDirOptions::default()).unwrap_err();
    assert!(
        matches!(
            e,
            LimapError::MissingTrack {
                missing: 3,
                count: 9,
                ..
            }
        ),
        "{e}"
    );
    assert!(e.to_string().contains("track_3.txt is missing"), "{e}");

    // The last index missing: 10 files counted, track_9 absent.
    let d = copy();
    let t = d.path().join("finaltracks");
    std::fs::rename(t.join("track_9.txt"), t.join("track_10.txt")).unwrap();
    let e = LimapDir::load(d.path(), &LimapDirOptions::default()).unwrap_err();
    assert!(
        matches!(
            e,
            LimapError::MissingTrack {
                missing: 9,
                count: 10,
                ..
            }
        ),
        "{e}"
    );
}

#[test]
fn files_limap_would_count_as_tracks_are_refused() {
    for name in ["tracks_backup.txt", "track_01.txt", "track.txt"] {
        let d = copy();
        std::fs::write(d.path().join("finaltracks").join(name), "").unwrap();
        let e = LimapDir::load(d.path(), &LimapDirOptions::default()).unwrap_err();
        assert!(
            matches!(e, LimapError::StrayTrackFile { .. }),
            "{name}: {e}"
        );
        assert!(e.to_string().contains(name), "{e}");
    }
    // LIMAP's own side files are ignored.
    let d = copy();
    std::fs::write(d.path().join("finaltracks/config.npy"), b"\x93NUMPY").unwrap();
    assert_eq!(
        LimapDir::load(d.path(), &LimapDirOptions::default())
            .unwrap()
            .tracks
            .len(),
        10
    );
}

#[test]
fn a_malformed_file_is_named() {
    let d = copy();
    let p = d.path().join("finaltracks/track_4.txt");
    let text = std::fs::read_to_string(&p).unwrap();
    std::fs::write(&p, text.replace("END\n", "")).unwrap();
    let e = LimapDir::load(d.path(), &LimapDirOptions::default()).unwrap_err();
    let msg = e.to_string();
    assert!(
        msg.contains("track_4.txt") && msg.contains("keyword \"END\""),
        "{msg}"
    );
}

#[test]
fn segments_location_is_explicit() {
    // Two candidates: refused, both named.
    let d = copy();
    testkit::files::copy_dir(
        &d.path().join("line_detections/lsd/segments"),
        &d.path().join("line_detections/deeplsd/segments"),
    );
    let e = LimapDir::load(d.path(), &LimapDirOptions::default()).unwrap_err();
    let msg = e.to_string();
    assert!(matches!(e, LimapError::SegmentsAmbiguous { .. }), "{msg}");
    assert!(
        msg.contains("deeplsd/segments") && msg.contains("lsd/segments"),
        "{msg}"
    );
    // Given explicitly: used, and said so.
    let given = d.path().join("line_detections/deeplsd/segments");
    let opts = LimapDirOptions {
        segments: Some(given.clone()),
        ..Default::default()
    };
    let dir = LimapDir::load(d.path(), &opts).unwrap();
    assert_eq!(
        (dir.segments_dir, dir.segments_origin),
        (given, SegmentsOrigin::Given)
    );

    // A plain segments/ folder is the only candidate.
    let d = copy();
    std::fs::rename(
        d.path().join("line_detections/lsd/segments"),
        d.path().join("segments"),
    )
    .unwrap();
    let dir = LimapDir::load(d.path(), &LimapDirOptions::default()).unwrap();
    assert_eq!(dir.segments_dir, d.path().join("segments"));

    // None at all.
    std::fs::remove_dir_all(d.path().join("segments")).unwrap();
    let e = LimapDir::load(d.path(), &LimapDirOptions::default()).unwrap_err();
    assert!(matches!(e, LimapError::SegmentsNotFound { .. }), "{e}");
}

#[test]
fn bad_segments_file_names_are_refused() {
    let d = copy();
    let s = d.path().join("line_detections/lsd/segments");
    std::fs::rename(s.join("segments_2.txt"), s.join("segments_02.txt")).unwrap();
    let e = LimapDir::load(d.path(), &LimapDirOptions::default()).unwrap_err();
    assert!(e.to_string().contains("segments_02.txt"), "{e}");
}

#[test]
fn a_support_claimed_by_two_tracks_names_both() {
    let mut dir = original();
    // Track 5 takes over the first support of track 2, 2D segment included, so that only
    // the duplicate is wrong.
    let (img, line) = (dir.tracks[2].image_ids[0], dir.tracks[2].line_ids[0]);
    let seg = dir.tracks[2].lines2d.as_ref().unwrap()[0];
    let t = &mut dir.tracks[5];
    t.image_ids[0] = img;
    t.line_ids[0] = line;
    t.lines2d.as_mut().unwrap()[0] = seg;
    let (_tmp, back) = rewrite(&dir);
    let report = back.check();
    assert!(!report.is_ok());
    let errors: Vec<_> = report.errors().collect();
    assert_eq!(
        errors,
        vec![&Problem::DuplicateSupport {
            image_id: img,
            line_id: line,
            first: 2,
            second: 5
        }]
    );
    let msg = errors[0].to_string();
    assert!(
        msg.contains("track_2.txt") && msg.contains("track_5.txt"),
        "{msg}"
    );
    let e = LimapDir::load(back.root.clone(), &LimapDirOptions::default()).unwrap_err();
    assert!(
        e.to_string()
            .contains("claimed by both track_2.txt and track_5.txt"),
        "{e}"
    );
}

#[test]
fn the_same_support_twice_in_one_track() {
    let mut dir = original();
    let t = &mut dir.tracks[0];
    t.image_ids.push(t.image_ids[0]);
    t.line_ids.push(t.line_ids[0]);
    let first = t.lines2d.as_ref().unwrap()[0];
    t.lines2d.as_mut().unwrap().push(first);
    let x = t.extras.as_mut().unwrap();
    x.node_ids.push(x.node_ids[0]);
    x.scores.push(x.scores[0]);
    x.lines3d.push(x.lines3d[0]);
    let (_tmp, back) = rewrite(&dir);
    let p = problems(&back, Check::UniqueSupports);
    assert_eq!(p.len(), 1);
    assert!(
        p[0].to_string().contains("track_0.txt lists the support"),
        "{}",
        p[0]
    );
}

#[test]
fn unknown_images_and_out_of_range_line_ids() {
    let mut dir = original();
    dir.tracks[1].image_ids[0] = 99;
    let n3 = dir.segments[&dir.tracks[4].image_ids[1]].len() as u32;
    dir.tracks[4].line_ids[1] = n3;
    let (_tmp, back) = rewrite(&dir);
    let known = problems(&back, Check::KnownImages);
    assert_eq!(
        known,
        vec![Problem::UnknownImage {
            track: 1,
            support: 0,
            image_id: 99
        }]
    );
    assert!(known[0].to_string().contains("track_1.txt"));
    let range = problems(&back, Check::LineIdsInRange);
    assert_eq!(range.len(), 2, "{range:?}");
    assert!(matches!(
        range[0],
        Problem::NoSegmentsFile {
            track: 1,
            image_id: 99,
            ..
        }
    ));
    assert!(
        matches!(range[1], Problem::LineIdOutOfRange { track: 4, support: 1, line_id, n_segments, .. }
            if line_id == n3 && n_segments == n3 as usize),
        "{range:?}"
    );
    assert!(range[1].to_string().contains(&format!("has {n3} segments")));
}

#[test]
fn segments_that_are_not_the_triangulated_ones() {
    // Segments from images at another resolution (2x): every stored 2D line disagrees.
    let mut dir = original();
    for s in dir.segments.values_mut() {
        for l in &mut s.lines {
            l.iter_mut().for_each(|v| *v *= 2.0);
        }
    }
    let (_tmp, back) = rewrite(&dir);
    let p = problems(&back, Check::Lines2dMatchSegments);
    let supports: usize = dir.tracks.iter().map(|t| t.n_lines()).sum();
    assert_eq!(p.len(), supports);
    assert!(
        back.check()
            .get(Check::UniqueSupports)
            .unwrap()
            .problems
            .is_empty()
    );
}

#[test]
fn alltracks_must_copy_the_finaltracks() {
    let d = copy();
    let p = d.path().join("alltracks.txt");
    let mut all = limap::read_alltracks(&p).unwrap();
    all[3].line[0][0] += 0.01;
    all.pop();
    limap::write_alltracks(&p, &all, limap::AlltracksLayout::SingleSpace).unwrap();
    let dir = LimapDir::open_unchecked(d.path(), &LimapDirOptions::default()).unwrap();
    let p = problems(&dir, Check::AlltracksMatchFinaltracks);
    assert_eq!(p.len(), 2, "{p:?}");
    assert_eq!(
        p[0],
        Problem::AlltracksCount {
            alltracks: 6,
            expected: 7
        }
    );
    assert!(
        matches!(&p[1], Problem::AlltracksMismatch { alltracks_id: 3, track: 4, what } if what.contains("endpoints"))
    );

    // Without alltracks.txt the check is skipped, not failed.
    std::fs::remove_file(d.path().join("alltracks.txt")).unwrap();
    let dir = LimapDir::load(d.path(), &LimapDirOptions::default()).unwrap();
    let r = dir.check();
    assert!(
        r.get(Check::AlltracksMatchFinaltracks)
            .unwrap()
            .skipped
            .is_some()
    );
}

#[test]
fn image_list_and_segments_coverage() {
    let d = copy();
    // Image 7 listed without segments: a warning only (no track uses it).
    let list = d.path().join("image_list.txt");
    let text = std::fs::read_to_string(&list)
        .unwrap()
        .replace("number of images, 6", "number of images, 7");
    std::fs::write(
        &list,
        format!("{text}7, stairs/seq-03/frame-000060.color.png\n"),
    )
    .unwrap();
    // Segments of an unlisted image 8: a warning too.
    let s = d.path().join("line_detections/lsd/segments");
    std::fs::write(s.join("segments_8.txt"), "1\n1.0 2.0 3.0 4.0\n").unwrap();
    let dir = LimapDir::load(d.path(), &LimapDirOptions::default()).unwrap();
    let p = problems(&dir, Check::SegmentsMatchImageList);
    assert_eq!(
        p,
        vec![
            Problem::ImageWithoutSegments { image_id: 7 },
            Problem::SegmentsOfUnlistedImage { image_id: 8 }
        ]
    );
    assert!(p.iter().all(|x| x.severity() == Severity::Warning));

    // Removing the segments of an image that tracks use is an error.
    std::fs::remove_file(s.join("segments_6.txt")).unwrap();
    let e = LimapDir::load(d.path(), &LimapDirOptions::default()).unwrap_err();
    assert!(e.to_string().contains("no segments_6.txt"), "{e}");
}

#[test]
fn legacy_track_files_need_the_option() {
    let d = copy();
    let p = d.path().join("finaltracks/track_0.txt");
    let text = std::fs::read_to_string(&p).unwrap();
    let legacy = &text[..text.find("line2d_list").unwrap()];
    std::fs::write(&p, legacy).unwrap();
    assert!(LimapDir::load(d.path(), &LimapDirOptions::default()).is_err());
    let opts = LimapDirOptions {
        allow_legacy_tracks: true,
        ..Default::default()
    };
    let dir = LimapDir::load(d.path(), &opts).unwrap();
    assert!(dir.tracks[0].lines2d.is_none());
    assert!(dir.tracks[1].lines2d.is_some());
}

#[test]
fn check_reports_every_problem_at_once() {
    let mut dir = original();
    dir.tracks[1].image_ids[0] = 99;
    let (img, line) = (dir.tracks[2].image_ids[0], dir.tracks[2].line_ids[0]);
    dir.tracks[6].image_ids[0] = img;
    dir.tracks[6].line_ids[0] = line;
    let (_tmp, back) = rewrite(&dir);
    let r = back.check();
    for check in [
        Check::KnownImages,
        Check::UniqueSupports,
        Check::LineIdsInRange,
    ] {
        assert!(r.get(check).unwrap().errors() > 0, "{check:?}");
    }
    match LimapDir::load(back.root.clone(), &LimapDirOptions::default()) {
        Err(LimapError::Inconsistent { problems, .. }) => {
            assert_eq!(problems.len(), r.errors().count())
        }
        other => panic!("{other:?}"),
    }
}
