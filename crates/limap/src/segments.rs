//! `segments_<image id>.txt`: the 2D line detections of one image (LIMAP
//! `save_txt_segments` / `read_txt_segments`).
//!
//! ```text
//! N
//! x1 y1 x2 y2        (N lines, Python repr of each float, single spaces)
//! ```
//! LIMAP writes 4 columns even when the detector returns a 5th (a score); its reader keeps
//! whatever columns a row has. Here a file may have 4 or 5 columns, the same in every row;
//! a 5th column is kept in [`Segments::scores`] and written back. Blank lines after the
//! last row are accepted (LIMAP's reader would not accept them); anything else there is an
//! error. The row index is the `line_id` that tracks refer to.

use std::fmt::Write as _;

use serde::Serialize;

use crate::error::{LimapError, ParseError};
use crate::numfmt::python_repr;
use crate::text::{bounded_capacity, fields, numbered_lines, parse_finite, parse_u64, quote};
use crate::track::Segment2d;

/// The detections of one image, in file order.
#[derive(Debug, Clone, PartialEq, Default, Serialize)]
pub struct Segments {
    pub lines: Vec<Segment2d>,
    /// The 5th column when the file has one (e.g. a detector score), one per line.
    pub scores: Option<Vec<f64>>,
}

impl Segments {
    pub fn new(lines: Vec<Segment2d>) -> Self {
        Segments {
            lines,
            scores: None,
        }
    }

    pub fn len(&self) -> usize {
        self.lines.len()
    }

    pub fn is_empty(&self) -> bool {
        self.lines.is_empty()
    }
}

/// File name LIMAP uses for the segments of an image.
pub fn segments_file_name(image_id: u32) -> String {
    format!("segments_{image_id}.txt")
}

/// Parses the text of a `segments_<id>.txt` file.
pub fn parse_segments(text: &str) -> Result<Segments, ParseError> {
    let mut lines = numbered_lines(text);
    let (count_line_no, count_line) = lines.next().unwrap_or((1, ""));
    let mut header = fields(count_line);
    let count = match (header.next(), header.next()) {
        (Some((col, tok)), None) => parse_u64(tok).ok_or_else(|| ParseError {
            line: count_line_no,
            column: col,
            expected: "number of segments (non-negative integer)".into(),
            found: quote(tok),
        })?,
        (None, _) => {
            return Err(ParseError {
                line: count_line_no,
                column: 1,
                expected: "number of segments".into(),
                found: if text.is_empty() {
                    "end of file".into()
                } else {
                    "an empty line".into()
                },
            });
        }
        (Some(_), Some((col, tok))) => {
            return Err(ParseError {
                line: count_line_no,
                column: col,
                expected: "only the number of segments on line 1".into(),
                found: quote(tok),
            });
        }
    };

    // A row is at least 4 one-character numbers with separators.
    let capacity = bounded_capacity(count, text.len(), 8);
    let mut out = Segments {
        lines: Vec::with_capacity(capacity),
        scores: None,
    };
    let mut scores = Vec::new();
    let mut columns: Option<usize> = None;
    for k in 0..count {
        let Some((line_no, line)) = lines.next() else {
            return Err(ParseError {
                line: count_line_no + k as usize + 1,
                column: 1,
                expected: format!("segment {} of {count}", k + 1),
                found: "end of file".into(),
            });
        };
        if fields(line).next().is_none() {
            let rest = text.get(line_end(text, line)..).unwrap_or("");
            return Err(ParseError {
                line: line_no,
                column: 1,
                expected: format!("segment {} of {count}", k + 1),
                found: if rest.trim().is_empty() {
                    "end of file".into()
                } else {
                    "an empty line".into()
                },
            });
        }
        let mut row = [0.0f64; 5];
        let mut n = 0;
        for (col, tok) in fields(line) {
            if n == 5 {
                return Err(ParseError {
                    line: line_no,
                    column: col,
                    expected: "at most 5 columns (x1 y1 x2 y2 [score])".into(),
                    found: quote(tok),
                });
            }
            row[n] = parse_finite(tok).ok_or_else(|| ParseError {
                line: line_no,
                column: col,
                expected: format!(
                    "{} of segment {} (finite number)",
                    ["x1", "y1", "x2", "y2", "score"][n],
                    k + 1
                ),
                found: quote(tok),
            })?;
            n += 1;
        }
        let want = *columns.get_or_insert(n);
        if n < 4 || n != want {
            return Err(ParseError {
                line: line_no,
                column: line.len() + 1,
                expected: if n < 4 {
                    format!("4 or 5 columns in segment {}", k + 1)
                } else {
                    format!("{want} columns like the first segment")
                },
                found: format!("{n} columns"),
            });
        }
        out.lines.push([row[0], row[1], row[2], row[3]]);
        if n == 5 {
            scores.push(row[4]);
        }
    }
    if columns == Some(5) {
        out.scores = Some(scores);
    }
    for (line_no, line) in lines {
        if let Some((col, tok)) = fields(line).next() {
            return Err(ParseError {
                line: line_no,
                column: col,
                expected: format!("end of file after {count} segments (count on line 1)"),
                found: quote(tok),
            });
        }
    }
    Ok(out)
}

/// Byte offset just past `line`, a slice of `text`.
fn line_end(text: &str, line: &str) -> usize {
    line.as_ptr() as usize - text.as_ptr() as usize + line.len()
}

/// Writes segments as LIMAP does (4 columns, Python float repr); a 5th column when
/// `scores` is set.
pub fn format_segments(segments: &Segments) -> Result<String, LimapError> {
    if let Some(s) = &segments.scores
        && s.len() != segments.lines.len()
    {
        return Err(LimapError::invalid(
            "segments",
            format!("{} lines but {} scores", segments.lines.len(), s.len()),
        ));
    }
    let mut out = String::with_capacity(16 + segments.lines.len() * 80);
    let _ = writeln!(out, "{}", segments.lines.len());
    for (k, line) in segments.lines.iter().enumerate() {
        let score = segments.scores.as_ref().and_then(|s| s.get(k));
        for (j, v) in line.iter().chain(score).enumerate() {
            if !v.is_finite() {
                return Err(LimapError::invalid(
                    "segments",
                    format!("segment {k} has the non-finite value {v}"),
                ));
            }
            if j > 0 {
                out.push(' ');
            }
            out.push_str(&python_repr(*v));
        }
        out.push('\n');
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn layout_is_limaps() {
        let s = Segments::new(vec![
            [1.0, 2.5, 1e-5, 300.25],
            [0.1, 0.2, 0.30000000000000004, 4.0],
        ]);
        assert_eq!(
            format_segments(&s).unwrap(),
            "2\n1.0 2.5 1e-05 300.25\n0.1 0.2 0.30000000000000004 4.0\n"
        );
    }

    #[test]
    fn round_trip_four_and_five_columns() {
        let mut s = Segments::new(vec![[1.0, 2.5, 3.0, 4.0], [5.0, 6.0, 7.0, 8.125]]);
        assert_eq!(parse_segments(&format_segments(&s).unwrap()).unwrap(), s);
        s.scores = Some(vec![0.5, 12.0]);
        let text = format_segments(&s).unwrap();
        assert!(text.contains("8.125 12.0\n"));
        assert_eq!(parse_segments(&text).unwrap(), s);
    }

    #[test]
    fn empty_image_and_blank_tail() {
        assert_eq!(parse_segments("0\n").unwrap(), Segments::default());
        assert_eq!(parse_segments("1\n1 2 3 4\n\n  \n").unwrap().len(), 1);
        assert_eq!(parse_segments("1\r\n1 2 3 4\r\n").unwrap().len(), 1);
    }

    #[test]
    fn mixed_column_counts_are_refused() {
        let e = parse_segments("2\n1 2 3 4 5\n1 2 3 4\n").unwrap_err();
        assert_eq!(e.line, 3);
        assert!(e.expected.contains("5 columns"), "{e}");
    }
}
