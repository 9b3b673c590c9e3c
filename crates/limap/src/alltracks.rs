//! `alltracks.txt`: every track seen in at least 4 images, in one file (LIMAP
//! `save_txt_linetracks`).
//!
//! ```text
//! N
//! track_id n_lines n_images          (N blocks; ids renumbered 0..N-1)
//! sx sy sz                           (10 decimals, separated by runs of spaces)
//! ex ey ez
//! i_0 i_1 .. (each followed by one space)
//! l_0 l_1 ..
//! ```
//! Current LIMAP builds the endpoint lines with an f-string continued by backslashes, which
//! leaves the next source line's indentation in the output: values are separated by one
//! space plus 18 spaces ([`AlltracksLayout::Limap`]). Older LIMAP wrote single spaces
//! ([`AlltracksLayout::SingleSpace`]). The reader is token based and takes both.
//! The file has no 2D segments, so tracks read from it have `lines2d: None`.

use std::fmt::Write as _;

use crate::error::{LimapError, ParseError};
use crate::numfmt::push_fixed10;
use crate::text::{Cursor, bounded_capacity};
use crate::track::{LineTrack, distinct};

/// LIMAP keeps a track in `alltracks.txt` when it is seen in at least this many images.
pub const ALLTRACKS_MIN_IMAGES: usize = 4;

/// Separator between the three coordinates of an endpoint line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum AlltracksLayout {
    /// Current LIMAP: one space and the 18 spaces of the f-string's continuation indent.
    #[default]
    Limap,
    /// Older LIMAP (`"{0:.10f} {1:.10f} {2:.10f}"`).
    SingleSpace,
}

impl AlltracksLayout {
    fn separator(self) -> &'static str {
        match self {
            AlltracksLayout::Limap => "                   ",
            AlltracksLayout::SingleSpace => " ",
        }
    }
}

/// The tracks LIMAP would put into `alltracks.txt`, in order.
pub fn select_for_alltracks(tracks: &[LineTrack]) -> impl Iterator<Item = &LineTrack> {
    tracks
        .iter()
        .filter(|t| t.n_images() >= ALLTRACKS_MIN_IMAGES)
}

/// Parses `alltracks.txt`. Track ids must run 0, 1, 2, ... as LIMAP writes them.
pub fn parse_alltracks(text: &str) -> Result<Vec<LineTrack>, ParseError> {
    let mut c = Cursor::new(text);
    let (n_tracks, _) = c.count(|| "number of tracks".into())?;
    // A block is at least 3 ids + 6 numbers + 2 ids, each a character and a separator.
    let mut tracks = Vec::with_capacity(bounded_capacity(n_tracks, c.remaining_bytes(), 22));
    for k in 0..n_tracks {
        let (id, id_token) = c.count(|| format!("id of track {} of {n_tracks}", k + 1))?;
        if id != k {
            return Err(id_token.error(format!("track id {k} (ids run 0..{n_tracks})")));
        }
        let (n_lines, _) = c.count(|| format!("n_lines of track {k}"))?;
        let (n_images, n_images_token) = c.count(|| format!("n_images of track {k}"))?;
        let mut line = [[0.0; 3]; 2];
        for (j, v) in line.iter_mut().flatten().enumerate() {
            *v = c.finite(|| {
                format!(
                    "{} {} of track {k} (finite number)",
                    if j < 3 { "start" } else { "end" },
                    ["x", "y", "z"][j % 3]
                )
            })?;
        }
        let capacity = bounded_capacity(n_lines, c.remaining_bytes(), 2);
        let mut image_ids = Vec::with_capacity(capacity);
        for i in 0..n_lines {
            image_ids.push(c.u32(|| format!("image id {} of {n_lines} of track {k}", i + 1))?);
        }
        let mut line_ids = Vec::with_capacity(capacity);
        for i in 0..n_lines {
            line_ids.push(c.u32(|| format!("line id {} of {n_lines} of track {k}", i + 1))?);
        }
        let distinct_images = distinct(&image_ids) as u64;
        if distinct_images != n_images {
            return Err(n_images_token.error(format!(
                "n_images = {distinct_images}, the number of distinct image ids of track {k}"
            )));
        }
        tracks.push(LineTrack {
            line,
            image_ids,
            line_ids,
            lines2d: None,
            extras: None,
        });
    }
    c.end(|| format!("end of file after {n_tracks} tracks"))?;
    Ok(tracks)
}

/// Writes the given tracks, numbered from 0, in LIMAP's layout. The selection (LIMAP keeps
/// tracks with at least 4 images) is the caller's: see [`select_for_alltracks`].
pub fn format_alltracks<'a>(
    tracks: impl IntoIterator<Item = &'a LineTrack>,
    layout: AlltracksLayout,
) -> Result<String, LimapError> {
    let tracks: Vec<&LineTrack> = tracks.into_iter().collect();
    let sep = layout.separator();
    let mut out = String::new();
    let _ = writeln!(out, "{}", tracks.len());
    for (k, t) in tracks.iter().enumerate() {
        if t.line_ids.len() != t.image_ids.len() {
            return Err(LimapError::invalid(
                format!("alltracks track {k}"),
                format!(
                    "{} image ids but {} line ids",
                    t.image_ids.len(),
                    t.line_ids.len()
                ),
            ));
        }
        let _ = writeln!(out, "{k} {} {}", t.n_lines(), t.n_images());
        for point in &t.line {
            for (j, v) in point.iter().enumerate() {
                if !v.is_finite() {
                    // LIMAP would write "nan", which no reader here accepts.
                    return Err(LimapError::invalid(
                        format!("alltracks track {k}"),
                        format!("endpoint coordinate {v}"),
                    ));
                }
                if j > 0 {
                    out.push_str(sep);
                }
                push_fixed10(&mut out, *v);
            }
            out.push('\n');
        }
        for id in &t.image_ids {
            let _ = write!(out, "{id} ");
        }
        out.push('\n');
        for id in &t.line_ids {
            let _ = write!(out, "{id} ");
        }
        out.push('\n');
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn track(images: &[u32]) -> LineTrack {
        LineTrack {
            line: [[1.0, -2.5, 0.125], [3.0, 4.0, 5.0]],
            image_ids: images.to_vec(),
            line_ids: (0..images.len() as u32).collect(),
            lines2d: None,
            extras: None,
        }
    }

    #[test]
    fn layout_is_limaps() {
        let t = track(&[1, 2, 3, 4, 4]);
        let text = format_alltracks([&t], AlltracksLayout::Limap).unwrap();
        let sep = " ".repeat(19);
        let want = format!(
            "1\n0 5 4\n1.0000000000{sep}-2.5000000000{sep}0.1250000000\n\
             3.0000000000{sep}4.0000000000{sep}5.0000000000\n1 2 3 4 4 \n0 1 2 3 4 \n"
        );
        assert_eq!(text, want);
    }

    #[test]
    fn round_trip_both_layouts() {
        let tracks = vec![track(&[1, 2, 3, 4]), track(&[5, 6, 7, 8, 9, 9])];
        for layout in [AlltracksLayout::Limap, AlltracksLayout::SingleSpace] {
            let text = format_alltracks(&tracks, layout).unwrap();
            assert_eq!(parse_alltracks(&text).unwrap(), tracks);
        }
    }

    #[test]
    fn selection_keeps_four_images_or_more() {
        let tracks = vec![track(&[1, 2, 3, 3]), track(&[1, 2, 3, 4]), track(&[1, 1])];
        let kept: Vec<_> = select_for_alltracks(&tracks).collect();
        assert_eq!(kept, vec![&tracks[1]]);
    }

    #[test]
    fn ids_must_run_from_zero() {
        let text = "2\n0 1 1\n0 0 0\n1 1 1\n5 \n0 \n2 1 1\n0 0 0\n1 1 1\n5 \n0 \n";
        let e = parse_alltracks(text).unwrap_err();
        assert_eq!((e.line, e.column), (7, 1));
        assert!(e.expected.contains("track id 1"), "{e}");
    }
}
