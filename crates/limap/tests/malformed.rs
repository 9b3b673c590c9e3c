//! Malformed input: every case gives an error with the right place and what was expected,
//! never a panic, and no allocation sized by a corrupt count.

use std::path::Path;

use limap::{ParseError, parse_alltracks, parse_image_list, parse_segments, parse_track};

/// Asserts the error's line, column and that `expected` mentions `what`.
fn at(result: Result<impl std::fmt::Debug, ParseError>, line: usize, column: usize, what: &str) {
    let e = result.expect_err("malformed input was accepted");
    assert_eq!((e.line, e.column), (line, column), "{e}");
    assert!(e.expected.contains(what), "expected {what:?} in: {e}");
}

const TRACK: &str = "1.0 2.0 3.0 4.0 5.0 6.0 \n\
                     2 2\n\
                     image_id_list 1 2 \n\
                     line_id_list 0 5 \n\
                     line2d_list\n\
                     1 2 3 4 \n\
                     5 6 7 8 \n\
                     END\n";

#[test]
fn track_base_case_is_valid() {
    let t = parse_track(TRACK).unwrap();
    assert_eq!(t.image_ids, vec![1, 2]);
    assert_eq!(t.line_ids, vec![0, 5]);
}

#[test]
fn track_malformed_cases() {
    let r = |from: &str, to: &str| parse_track(&TRACK.replacen(from, to, 1));
    // empty and truncated files
    at(parse_track(""), 1, 1, "3D line start x");
    at(
        parse_track(&TRACK[..TRACK.find("image_id_list").unwrap()]),
        3,
        1,
        "image_id_list",
    );
    at(
        parse_track(&TRACK[..TRACK.find("END").unwrap()]),
        8,
        1,
        "\"END\" or \"node_id_list\"",
    );
    at(
        parse_track(&TRACK[..TRACK.find("line2d_list").unwrap()]),
        5,
        1,
        "line2d_list",
    );
    // wrong keywords
    at(
        r("image_id_list", "image_ids"),
        3,
        1,
        "keyword \"image_id_list\"",
    );
    at(
        r("line_id_list", "line_ids"),
        4,
        1,
        "keyword \"line_id_list\"",
    );
    at(
        r("END", "node_ids 1 2"),
        8,
        1,
        "\"END\" or \"node_id_list\"",
    );
    // non-numeric, NaN, infinite
    at(r("3.0", "x"), 1, 9, "3D line start z");
    at(r("2.0", "nan"), 1, 5, "finite number");
    at(r("5 6 7 8", "5 6 inf 8"), 7, 5, "x2 of 2D segment 2 of 2");
    at(r("1 2 3 4", "1 NaN 3 4"), 6, 3, "y1 of 2D segment 1 of 2");
    // ids: negative, beyond u32, non-integer
    at(
        r("image_id_list 1", "image_id_list -1"),
        3,
        15,
        "image id 1 of 2",
    );
    at(
        r("image_id_list 1", "image_id_list 4294967296"),
        3,
        15,
        "image id 1 of 2",
    );
    at(
        r("line_id_list 0 5", "line_id_list 0 5.5"),
        4,
        16,
        "line id 2 of 2",
    );
    // counts: negative, absurd, inconsistent
    at(r("2 2\n", "-2 2\n"), 2, 1, "n_lines");
    at(r("2 2\n", "99999999999999999999 2\n"), 2, 1, "n_lines");
    at(
        r("2 2\n", "18446744073709551615 2\n"),
        4,
        1,
        "image id 3 of 18446744073709551615",
    );
    at(r("2 2\n", "3 2\n"), 4, 1, "image id 3 of 3");
    at(r("2 2\n", "1 1\n"), 3, 17, "keyword \"line_id_list\"");
    at(r("2 2\n", "2 1\n"), 2, 3, "n_images = 2");
    at(r("2 2\n", "2 3\n"), 2, 3, "n_images = 2");
    // fewer 2D rows than supports: END is read as a coordinate
    at(r("5 6 7 8 \n", ""), 7, 1, "x1 of 2D segment 2 of 2");
    // trailing data after END
    at(
        parse_track(&format!("{TRACK}extra\n")),
        9,
        1,
        "end of file after END",
    );
}

#[test]
fn track_extras_malformed_cases() {
    let full = TRACK.replace(
        "END\n",
        "node_id_list 4 9 \nscore_list 0.5 1.0 \nline3d_list\n1 2 3 4 5 6 \n1 2 3 4 5 6 \nEND\n",
    );
    let t = parse_track(&full).unwrap();
    assert_eq!(t.extras.unwrap().node_ids, vec![4, 9]);
    let r = |from: &str, to: &str| parse_track(&full.replacen(from, to, 1));
    // all three sections or none
    at(
        r("score_list 0.5 1.0 \n", ""),
        9,
        1,
        "keyword \"score_list\"",
    );
    at(
        r("line3d_list\n1 2 3 4 5 6 \n1 2 3 4 5 6 \n", ""),
        10,
        1,
        "keyword \"line3d_list\"",
    );
    at(
        r("score_list 0.5 1.0", "score_list 0.5 nan"),
        9,
        16,
        "score 2 of 2",
    );
    at(
        r("node_id_list 4 9", "node_id_list 4 x"),
        8,
        16,
        "node id 2 of 2",
    );
    at(
        r("1 2 3 4 5 6 \nEND", "1 2 3 4 5 inf \nEND"),
        12,
        11,
        "3D line 2 of 2 in line3d_list end z",
    );
    at(
        parse_track(&full[..full.rfind("END").unwrap()]),
        13,
        1,
        "keyword \"END\"",
    );
}

const ALL: &str = "1\n0 4 4\n0.5 0.0 0.0\n1.0 1.0 1.0\n1 2 3 4 \n0 0 0 0 \n";

#[test]
fn alltracks_malformed_cases() {
    assert_eq!(parse_alltracks(ALL).unwrap().len(), 1);
    let r = |from: &str, to: &str| parse_alltracks(&ALL.replacen(from, to, 1));
    at(parse_alltracks(""), 1, 1, "number of tracks");
    at(
        parse_alltracks(&ALL[..ALL.find("0 0 0 0").unwrap()]),
        6,
        1,
        "line id 1 of 4 of track 0",
    );
    at(r("1\n0 4 4", "-1\n0 4 4"), 1, 1, "number of tracks");
    at(
        r("1\n0 4 4", "1000000000000\n0 4 4"),
        7,
        1,
        "id of track 2 of 1000000000000",
    );
    at(r("0 4 4", "0 4 3"), 2, 5, "n_images = 4");
    at(
        r("0 4 4", "0 18446744073709551615 4"),
        7,
        1,
        "image id 9 of 18446744073709551615",
    );
    at(r("0.5", "nan"), 3, 1, "start x of track 0");
    at(r("1 2 3 4", "1 2 x 4"), 5, 5, "image id 3 of 4 of track 0");
    at(
        parse_alltracks(&format!("{ALL}7\n")),
        7,
        1,
        "end of file after 1 tracks",
    );
}

#[test]
fn segments_malformed_cases() {
    at(parse_segments(""), 1, 1, "number of segments");
    at(parse_segments("\n1 2 3 4\n"), 1, 1, "number of segments");
    at(parse_segments("x\n"), 1, 1, "number of segments");
    at(parse_segments("-1\n"), 1, 1, "number of segments");
    at(parse_segments("1 2\n1 2 3 4\n"), 1, 3, "only the number");
    at(parse_segments("2\n1 2 3 4\n"), 3, 1, "segment 2 of 2");
    at(
        parse_segments("18446744073709551615\n1 2 3 4\n"),
        3,
        1,
        "segment 2 of 18446744073709551615",
    );
    at(parse_segments("1\n1 2 3\n"), 2, 6, "4 or 5 columns");
    let e = parse_segments("2\n1 2 3 4\n\n5 6 7 8\n").unwrap_err();
    assert_eq!((e.line, e.found.as_str()), (3, "an empty line"), "{e}");
    let e = parse_segments("2\n1 2 3 4\n").unwrap_err();
    assert_eq!((e.line, e.found.as_str()), (3, "end of file"), "{e}");
    at(
        parse_segments("1\n1 2 3 4 5 6\n"),
        2,
        11,
        "at most 5 columns",
    );
    at(parse_segments("1\n1 2 x 4\n"), 2, 5, "x2 of segment 1");
    at(parse_segments("1\n1 nan 3 4\n"), 2, 3, "y1 of segment 1");
    at(parse_segments("1\n1 2 3 -inf\n"), 2, 7, "y2 of segment 1");
    at(
        parse_segments("1\n1 2 3 4\n5 6 7 8\n"),
        3,
        1,
        "end of file after 1 segments",
    );
}

#[test]
fn image_list_malformed_cases() {
    at(parse_image_list(""), 1, 1, "header");
    at(parse_image_list("images, 2\n1, a\n2, b\n"), 1, 1, "header");
    at(parse_image_list("number of images 2\n"), 1, 1, "header");
    at(
        parse_image_list("number of images, x\n"),
        1,
        19,
        "number of images",
    );
    at(
        parse_image_list("number of images, -1\n"),
        1,
        19,
        "number of images",
    );
    at(
        parse_image_list("number of images, 2\n1, a\n"),
        3,
        1,
        "image 2 of 2",
    );
    at(
        parse_image_list("number of images, 18446744073709551615\n1, a\n"),
        3,
        1,
        "image 2 of 18446744073709551615",
    );
    at(
        parse_image_list("number of images, 1\na, b\n"),
        2,
        1,
        "image id",
    );
    at(
        parse_image_list("number of images, 1\n-1, b\n"),
        2,
        1,
        "image id",
    );
    at(
        parse_image_list("number of images, 1\n1 b\n"),
        2,
        1,
        "\"id, name\"",
    );
    at(
        parse_image_list("number of images, 1\n1,\n"),
        2,
        3,
        "name of image 1",
    );
    at(
        parse_image_list("number of images, 1\n1, a\n2, b\n"),
        3,
        1,
        "end of file after 1 images",
    );
    at(
        parse_image_list("number of images, 2\n1, a\n1, b\n"),
        3,
        1,
        "already on line 2",
    );
    at(
        parse_image_list("number of images, 2\n1, a\n2, a\n"),
        3,
        4,
        "already on line 2",
    );
}

/// Start of the last token: a cut before it leaves the file incomplete in every format
/// (a cut inside the last number can still be a valid file).
fn last_token_start(text: &str) -> usize {
    let trimmed = text.trim_end();
    trimmed
        .rfind(|c: char| c.is_ascii_whitespace())
        .map_or(0, |i| i + 1)
}

fn fixture(rel: &str) -> String {
    let p = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/limap-mini")
        .join(rel);
    std::fs::read_to_string(p).unwrap()
}

#[test]
fn every_truncation_is_an_error() {
    type Parser = fn(&str) -> Result<(), ParseError>;
    let cases: [(&str, Parser); 4] = [
        ("finaltracks/track_3.txt", |t| parse_track(t).map(drop)),
        ("alltracks.txt", |t| parse_alltracks(t).map(drop)),
        ("line_detections/lsd/segments/segments_3.txt", |t| {
            parse_segments(t).map(drop)
        }),
        ("image_list.txt", |t| parse_image_list(t).map(drop)),
    ];
    for (rel, parse) in cases {
        let text = fixture(rel);
        assert!(parse(&text).is_ok(), "{rel}");
        // For track files END closes the file: any cut before its end is an error.
        let must_fail_below = if rel.starts_with("finaltracks") {
            text.trim_end().len()
        } else {
            last_token_start(&text)
        };
        for cut in 0..text.len() {
            let result = parse(&text[..cut]);
            if cut < must_fail_below {
                assert!(result.is_err(), "{rel} cut at byte {cut} was accepted");
            }
        }
    }
}

/// Single-byte corruptions of a real track file: never a panic.
#[test]
fn byte_corruptions_never_panic() {
    let text = fixture("finaltracks/track_3.txt");
    let mut bytes = text.into_bytes();
    for i in 0..bytes.len() {
        let original = bytes[i];
        for b in [b'x', b'-', b' ', b'\n', b'9', b'.', 0xff] {
            bytes[i] = b;
            if let Ok(s) = std::str::from_utf8(&bytes) {
                let _ = parse_track(s);
                let _ = parse_alltracks(s);
                let _ = parse_segments(s);
                let _ = parse_image_list(s);
            }
        }
        bytes[i] = original;
    }
}
