//! One LIMAP line track and its `finaltracks/track_<i>.txt` file.
//!
//! Layout (LIMAP `LineTrack::Write`; fixed notation, 10 decimals; every value followed by
//! one space, then the line break):
//! ```text
//! sx sy sz ex ey ez
//! n_lines n_images
//! image_id_list i_0 .. i_{n-1}
//! line_id_list l_0 .. l_{n-1}
//! line2d_list
//! x1 y1 x2 y2                    (n_lines rows)
//! [node_id_list k_0 ..]          (optional; the three sections come all together or not)
//! [score_list s_0 ..]
//! [line3d_list + n_lines rows of sx sy sz ex ey ez]
//! END
//! ```
//! LIMAP's reader is token based, so this one is too. It differs from LIMAP where LIMAP
//! would silently accept an inconsistent or truncated file: `n_images` must equal the
//! number of distinct image ids, `END` is required, nothing may follow it, numbers must be
//! finite. Files of older LIMAP versions stop after the line ids (LIMAP's reader returns
//! when `line2d_list` is missing); since a truncated file looks the same, they are read
//! only by [`parse_track_allow_legacy`].

use std::collections::HashSet;
use std::fmt::Write as _;

use serde::Serialize;

use crate::error::{LimapError, ParseError};
use crate::numfmt::push_fixed10;
use crate::text::{Cursor, bounded_capacity};

/// A 3D segment: `[start, end]`, metres in the SfM world frame.
pub type Line3d = [[f64; 3]; 2];
/// A 2D segment `[x1, y1, x2, y2]` in pixels of the (undistorted, resized) image.
pub type Segment2d = [f64; 4];

/// A triangulated 3D line and the 2D detections that support it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LineTrack {
    pub line: Line3d,
    /// Image of each support; the same image may appear more than once.
    pub image_ids: Vec<u32>,
    /// Row of each support in `segments_<image id>.txt`, parallel to `image_ids`.
    pub line_ids: Vec<u32>,
    /// The supporting 2D segments, parallel to `image_ids`; `None` for files of old LIMAP
    /// versions and for tracks read from `alltracks.txt`.
    pub lines2d: Option<Vec<Segment2d>>,
    /// LIMAP's auxiliary sections, present together or not at all.
    pub extras: Option<TrackExtras>,
}

/// The optional `node_id_list`, `score_list` and `line3d_list` sections, one entry per support.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TrackExtras {
    pub node_ids: Vec<i32>,
    pub scores: Vec<f64>,
    pub lines3d: Vec<Line3d>,
}

impl LineTrack {
    /// Number of supporting 2D lines.
    pub fn n_lines(&self) -> usize {
        self.image_ids.len()
    }

    /// Number of distinct images among the supports (LIMAP `count_images`).
    pub fn n_images(&self) -> usize {
        distinct(&self.image_ids)
    }

    /// Length of the 3D segment.
    pub fn length(&self) -> f64 {
        let [s, e] = self.line;
        ((e[0] - s[0]).powi(2) + (e[1] - s[1]).powi(2) + (e[2] - s[2]).powi(2)).sqrt()
    }

    /// `(image id, line id)` of each support, in file order.
    pub fn supports(&self) -> impl Iterator<Item = (u32, u32)> + '_ {
        self.image_ids
            .iter()
            .copied()
            .zip(self.line_ids.iter().copied())
    }

    /// Checks that every per-support list has one entry per support, so that the track can
    /// be written and read back.
    pub fn check_shape(&self) -> Result<(), String> {
        let n = self.image_ids.len();
        let mut bad = Vec::new();
        if self.line_ids.len() != n {
            bad.push(format!("line_ids has {}", self.line_ids.len()));
        }
        if let Some(l) = &self.lines2d
            && l.len() != n
        {
            bad.push(format!("lines2d has {}", l.len()));
        }
        if let Some(x) = &self.extras {
            if self.lines2d.is_none() {
                return Err("extras need lines2d (LIMAP reads them after line2d_list)".into());
            }
            for (name, len) in [
                ("node_ids", x.node_ids.len()),
                ("scores", x.scores.len()),
                ("lines3d", x.lines3d.len()),
            ] {
                if len != n {
                    bad.push(format!("{name} has {len}"));
                }
            }
        }
        if bad.is_empty() {
            Ok(())
        } else {
            Err(format!("image_ids has {n} entries but {}", bad.join(", ")))
        }
    }
}

pub(crate) fn distinct(ids: &[u32]) -> usize {
    ids.iter().collect::<HashSet<_>>().len()
}

const COORD: [&str; 3] = ["x", "y", "z"];

/// Parses the text of a `track_<i>.txt` file of current LIMAP (with `line2d_list`).
pub fn parse_track(text: &str) -> Result<LineTrack, ParseError> {
    parse(text, false)
}

/// Like [`parse_track`], and also reads files of older LIMAP versions that end (optionally
/// with `END`) after the line ids; those tracks have `lines2d: None`.
pub fn parse_track_allow_legacy(text: &str) -> Result<LineTrack, ParseError> {
    parse(text, true)
}

fn parse(text: &str, allow_legacy: bool) -> Result<LineTrack, ParseError> {
    let mut c = Cursor::new(text);
    let line = read_line3d(&mut c, "3D line")?;
    let (n_lines, _) = c.count(|| "n_lines (number of supporting 2D lines)".into())?;
    let (n_images, n_images_token) = c.count(|| "n_images (number of distinct images)".into())?;

    c.keyword("image_id_list")?;
    let image_ids = read_list(&mut c, n_lines, "image id", "image_id_list", |c, e| {
        c.u32(e)
    })?;
    c.keyword("line_id_list")?;
    let line_ids = read_list(&mut c, n_lines, "line id", "line_id_list", |c, e| c.u32(e))?;

    let distinct_images = distinct(&image_ids) as u64;
    if distinct_images != n_images {
        return Err(n_images_token.error(format!(
            "n_images = {distinct_images}, the number of distinct ids in image_id_list"
        )));
    }

    let mut track = LineTrack {
        line,
        image_ids,
        line_ids,
        lines2d: None,
        extras: None,
    };
    let section = if allow_legacy {
        "keyword \"line2d_list\" or \"END\" or the end of an old-format file"
    } else {
        "keyword \"line2d_list\" (old files without it need the legacy reader)"
    };
    match c.next_token() {
        None if allow_legacy => return Ok(track),
        None => return Err(c.eof_error(section)),
        Some(t) if allow_legacy && t.text == "END" => {
            c.end(|| "end of file after END".into())?;
            return Ok(track);
        }
        Some(t) if t.text == "line2d_list" => {}
        Some(t) => return Err(t.error(section)),
    }
    track.lines2d = Some(read_list(
        &mut c,
        n_lines,
        "2D segment",
        "line2d_list",
        |c, e| {
            let mut s = [0.0; 4];
            for (k, v) in s.iter_mut().enumerate() {
                *v = c.finite(|| format!("{} of {}", ["x1", "y1", "x2", "y2"][k], e()))?;
            }
            Ok(s)
        },
    )?);

    let t = c.token(|| "keyword \"END\" or \"node_id_list\"".into())?;
    match t.text {
        "END" => {}
        "node_id_list" => {
            let node_ids = read_list(&mut c, n_lines, "node id", "node_id_list", |c, e| c.i32(e))?;
            c.keyword("score_list")?;
            let scores = read_list(&mut c, n_lines, "score", "score_list", |c, e| c.finite(e))?;
            c.keyword("line3d_list")?;
            let lines3d = read_list(&mut c, n_lines, "3D line", "line3d_list", |c, e| {
                read_line3d(c, &e())
            })?;
            c.keyword("END")?;
            track.extras = Some(TrackExtras {
                node_ids,
                scores,
                lines3d,
            });
        }
        _ => return Err(t.error("keyword \"END\" or \"node_id_list\"")),
    }
    c.end(|| "end of file after END".into())?;
    Ok(track)
}

fn read_line3d(c: &mut Cursor<'_>, what: &str) -> Result<Line3d, ParseError> {
    let mut line = [[0.0; 3]; 2];
    for (k, v) in line.iter_mut().flatten().enumerate() {
        let end = if k < 3 { "start" } else { "end" };
        *v = c.finite(|| format!("{what} {end} {} (finite number)", COORD[k % 3]))?;
    }
    Ok(line)
}

/// Reads `count` items; the description of item `i` is "`what` i of `count` in `section`".
fn read_list<T>(
    c: &mut Cursor<'_>,
    count: u64,
    what: &str,
    section: &str,
    mut item: impl FnMut(&mut Cursor<'_>, &dyn Fn() -> String) -> Result<T, ParseError>,
) -> Result<Vec<T>, ParseError> {
    // Every item takes at least one character and one separator.
    let mut out = Vec::with_capacity(bounded_capacity(count, c.remaining_bytes(), 2));
    for i in 0..count {
        let describe = || format!("{what} {} of {count} in {section}", i + 1);
        out.push(item(c, &describe)?);
    }
    Ok(out)
}

/// Writes a track the way LIMAP's `LineTrack::Write` does.
///
/// As in LIMAP, a NaN endpoint coordinate is written as `0.0000000000`. Any other
/// non-finite value is refused: LIMAP would write `nan`/`inf`, which its reader cannot read.
pub fn format_track(track: &LineTrack) -> Result<String, LimapError> {
    track
        .check_shape()
        .map_err(|r| LimapError::invalid("line track", r))?;
    let n = track.n_lines();
    let mut out = String::with_capacity(128 + n * 80);
    for v in track.line.iter().flatten() {
        if v.is_nan() {
            push_fixed10(&mut out, 0.0);
        } else if v.is_infinite() {
            return Err(LimapError::invalid(
                "line track",
                format!("3D endpoint coordinate {v}"),
            ));
        } else {
            push_fixed10(&mut out, *v);
        }
        out.push(' ');
    }
    out.push('\n');
    let _ = writeln!(out, "{n} {}", track.n_images());
    out.push_str("image_id_list ");
    for id in &track.image_ids {
        let _ = write!(out, "{id} ");
    }
    out.push_str("\nline_id_list ");
    for id in &track.line_ids {
        let _ = write!(out, "{id} ");
    }
    out.push('\n');
    if let Some(lines2d) = &track.lines2d {
        out.push_str("line2d_list\n");
        for s in lines2d {
            push_row(&mut out, s, "2D segment")?;
        }
        if let Some(x) = &track.extras {
            out.push_str("node_id_list ");
            for id in &x.node_ids {
                let _ = write!(out, "{id} ");
            }
            out.push_str("\nscore_list ");
            for s in &x.scores {
                push_value(&mut out, *s, "score")?;
            }
            out.push_str("\nline3d_list\n");
            for l in &x.lines3d {
                let flat = [l[0][0], l[0][1], l[0][2], l[1][0], l[1][1], l[1][2]];
                push_row(&mut out, &flat, "3D line of a support")?;
            }
        }
    }
    out.push_str("END\n");
    Ok(out)
}

fn push_value(out: &mut String, v: f64, what: &str) -> Result<(), LimapError> {
    if !v.is_finite() {
        return Err(LimapError::invalid(
            "line track",
            format!("{what} value {v}"),
        ));
    }
    push_fixed10(out, v);
    out.push(' ');
    Ok(())
}

fn push_row(out: &mut String, values: &[f64], what: &str) -> Result<(), LimapError> {
    for v in values {
        push_value(out, *v, what)?;
    }
    out.push('\n');
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample(with_extras: bool) -> LineTrack {
        LineTrack {
            line: [[0.25, -1.5, 3.0], [1e-11, 2.0, -0.125]],
            image_ids: vec![3, 7, 3],
            line_ids: vec![10, 0, 11],
            lines2d: Some(vec![
                [1.5, 2.5, 100.25, 200.0],
                [0.0, 0.0, 639.5, 479.5],
                [10.0, 20.0, 30.0, 40.0],
            ]),
            extras: with_extras.then(|| TrackExtras {
                node_ids: vec![5, -1, 8],
                scores: vec![0.5, 1.0, 0.0],
                lines3d: vec![[[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]]; 3],
            }),
        }
    }

    #[test]
    fn layout_is_limaps() {
        let text = format_track(&sample(false)).unwrap();
        let want = "0.2500000000 -1.5000000000 3.0000000000 0.0000000000 2.0000000000 -0.1250000000 \n\
                    3 2\n\
                    image_id_list 3 7 3 \n\
                    line_id_list 10 0 11 \n\
                    line2d_list\n\
                    1.5000000000 2.5000000000 100.2500000000 200.0000000000 \n\
                    0.0000000000 0.0000000000 639.5000000000 479.5000000000 \n\
                    10.0000000000 20.0000000000 30.0000000000 40.0000000000 \n\
                    END\n";
        assert_eq!(text, want);
    }

    #[test]
    fn round_trip_with_and_without_extras() {
        for extras in [false, true] {
            let t = sample(extras);
            let text = format_track(&t).unwrap();
            let back = parse_track(&text).unwrap();
            // 1e-11 is below the 10-decimal resolution and comes back as 0.
            let mut want = t.clone();
            want.line[1][0] = 0.0;
            assert_eq!(back, want);
            assert_eq!(format_track(&back).unwrap(), text);
        }
    }

    #[test]
    fn legacy_file_without_line2d_list() {
        let text = "1 2 3 4 5 6\n2 2\nimage_id_list 1 2\nline_id_list 0 0\n";
        let e = parse_track(text).unwrap_err();
        assert_eq!((e.line, e.found.as_str()), (5, "end of file"));
        let t = parse_track_allow_legacy(text).unwrap();
        assert_eq!(t.lines2d, None);
        assert_eq!(t.image_ids, vec![1, 2]);
        let written = format_track(&t).unwrap();
        assert!(written.ends_with("line_id_list 0 0 \nEND\n"));
        assert_eq!(parse_track_allow_legacy(&written).unwrap(), t);
        assert!(parse_track(&written).is_err());
    }

    #[test]
    fn nan_endpoint_is_written_as_zero_like_limap() {
        let mut t = sample(false);
        t.line[0][1] = f64::NAN;
        let text = format_track(&t).unwrap();
        assert!(text.starts_with("0.2500000000 0.0000000000 3.0000000000 "));
        t.line[0][1] = f64::INFINITY;
        assert!(format_track(&t).is_err());
    }

    #[test]
    fn non_finite_support_values_are_refused() {
        let mut t = sample(true);
        t.extras.as_mut().unwrap().scores[1] = f64::NAN;
        let e = format_track(&t).unwrap_err().to_string();
        assert!(e.contains("score"), "{e}");
    }

    #[test]
    fn inconsistent_shapes_are_refused() {
        let mut t = sample(false);
        t.line_ids.pop();
        let e = format_track(&t).unwrap_err().to_string();
        assert!(e.contains("line_ids has 2"), "{e}");
    }

    #[test]
    fn stats() {
        let t = sample(false);
        assert_eq!(t.n_lines(), 3);
        assert_eq!(t.n_images(), 2);
        let d: [f64; 3] = [1e-11 - 0.25, 3.5, -3.125];
        let want = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        assert!((t.length() - want).abs() < 1e-12);
        assert_eq!(
            t.supports().collect::<Vec<_>>(),
            vec![(3, 10), (7, 0), (3, 11)]
        );
    }
}
