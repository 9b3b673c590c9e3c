//! `image_list.txt`: LIMAP's image ids and names, in either of the two forms LIMAP writes.
//!
//! ```text
//! number of images, N                 number of images, N
//! <id>, <name>       (N lines)        <name>             (N lines)
//! ```
//! The id form (`save_txt_imname_dict`, left) is what LIMAP's line triangulation writes
//! today. LIMAP strips each line, splits on commas and drops the first character after
//! the comma. This reader splits at the first comma only and drops one space after it when
//! present, so it also reads `id,name` and names that contain commas (which LIMAP itself
//! would cut).
//!
//! The list form (`save_txt_imname_list`, right) is what LIMAP 1.x's runners wrote: one
//! name per line, often an absolute path, the image id being the line's position from 0
//! (the position in LIMAP's image collection, which its segments and track files use).
//! LIMAP strips each line; so does this reader. The first image line says which form a
//! file has: a comma, or a first word that is a number, make it the id form.
//!
//! Ids and names must be unique: the label import joins LIMAP to COLMAP by name.

use std::collections::HashMap;
use std::fmt::Write as _;

use serde::Serialize;

use crate::error::{LimapError, ParseError};
use crate::text::{numbered_lines, parse_u32, parse_u64, quote};

const HEADER: &str = "number of images";

/// Image ids and names in file order.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize)]
pub struct ImageList {
    pub images: Vec<(u32, String)>,
}

impl ImageList {
    pub fn len(&self) -> usize {
        self.images.len()
    }

    pub fn is_empty(&self) -> bool {
        self.images.is_empty()
    }

    pub fn name(&self, id: u32) -> Option<&str> {
        self.images
            .iter()
            .find(|(i, _)| *i == id)
            .map(|(_, n)| n.as_str())
    }

    pub fn ids(&self) -> impl Iterator<Item = u32> + '_ {
        self.images.iter().map(|(id, _)| *id)
    }
}

fn leading_ws(line: &str) -> usize {
    line.len() - line.trim_start().len()
}

/// Parses the text of `image_list.txt`.
pub fn parse_image_list(text: &str) -> Result<ImageList, ParseError> {
    let mut lines = numbered_lines(text);
    let (header_no, header) = lines.next().unwrap_or((1, ""));
    let expected_header = || format!("header \"{HEADER}, N\"");
    let count = match header.split_once(',') {
        Some((label, n)) if label.trim() == HEADER => {
            parse_u64(n.trim()).ok_or_else(|| ParseError {
                line: header_no,
                column: label.len() + 2 + leading_ws(n),
                expected: "number of images (non-negative integer)".into(),
                found: quote(n.trim()),
            })?
        }
        _ => {
            return Err(ParseError {
                line: header_no,
                column: 1,
                expected: expected_header(),
                found: if text.is_empty() {
                    "end of file".into()
                } else {
                    quote(header)
                },
            });
        }
    };

    let mut lines = lines.peekable();
    let list_form = lines
        .peek()
        .is_some_and(|(_, first)| is_list_form_line(first));
    let images = if list_form {
        parse_names(&mut lines, count, header_no, text.len())?
    } else {
        parse_entries(&mut lines, count, header_no, text.len())?
    };
    for (line_no, line) in lines {
        if !line.trim().is_empty() {
            return Err(ParseError {
                line: line_no,
                column: leading_ws(line) + 1,
                expected: format!("end of file after {count} images (count on line {header_no})"),
                found: quote(line.trim()),
            });
        }
    }
    Ok(ImageList { images })
}

/// Whether the first image line is a bare name (LIMAP's list form): no comma, and a
/// first word that is not a number (`1 a.png` is an id line that lacks its comma).
fn is_list_form_line(line: &str) -> bool {
    let line = line.trim();
    let first_word = line.split_ascii_whitespace().next().unwrap_or("");
    !line.is_empty() && !line.contains(',') && !first_word.bytes().all(|b| b.is_ascii_digit())
}

/// The list form: `count` names, ids 0, 1, ... by position.
fn parse_names<'a>(
    lines: &mut impl Iterator<Item = (usize, &'a str)>,
    count: u64,
    header_no: usize,
    text_len: usize,
) -> Result<Vec<(u32, String)>, ParseError> {
    // Each entry is at least "a\n".
    let capacity = crate::text::bounded_capacity(count, text_len, 2);
    let mut images = Vec::with_capacity(capacity);
    let mut seen_names: HashMap<String, usize> = HashMap::with_capacity(capacity);
    for k in 0..count {
        let Some((line_no, raw)) = lines.next() else {
            return Err(ParseError {
                line: header_no + k as usize + 1,
                column: 1,
                expected: format!("image {} of {count} (a name: the list form)", k + 1),
                found: "end of file".into(),
            });
        };
        let column = leading_ws(raw) + 1;
        let name = raw.trim();
        if name.is_empty() {
            return Err(ParseError {
                line: line_no,
                column,
                expected: format!(
                    "image {} of {count}: a name (the list form: one name per line, ids by \
                     position from 0)",
                    k + 1
                ),
                found: "an empty line".into(),
            });
        }
        let Ok(id) = u32::try_from(k) else {
            return Err(ParseError {
                line: line_no,
                column,
                expected: "at most 2^32 images (ids are 32-bit)".into(),
                found: format!("image {}", k + 1),
            });
        };
        if let Some(first) = seen_names.insert(name.to_string(), line_no) {
            return Err(ParseError {
                line: line_no,
                column,
                expected: format!("a new image name (already on line {first})"),
                found: quote(name),
            });
        }
        images.push((id, name.to_string()));
    }
    Ok(images)
}

/// The id form: `count` lines `id, name`.
fn parse_entries<'a>(
    lines: &mut impl Iterator<Item = (usize, &'a str)>,
    count: u64,
    header_no: usize,
    text_len: usize,
) -> Result<Vec<(u32, String)>, ParseError> {
    // Each entry is at least "0, a\n".
    let capacity = crate::text::bounded_capacity(count, text_len, 5);
    let mut images = Vec::with_capacity(capacity);
    let mut seen_ids: HashMap<u32, usize> = HashMap::with_capacity(capacity);
    let mut seen_names: HashMap<String, usize> = HashMap::with_capacity(capacity);
    for k in 0..count {
        let Some((line_no, raw)) = lines.next() else {
            return Err(ParseError {
                line: header_no + k as usize + 1,
                column: 1,
                expected: format!("image {} of {count} (\"id, name\")", k + 1),
                found: "end of file".into(),
            });
        };
        let indent = leading_ws(raw);
        let line = raw.trim();
        let Some((id_text, rest)) = line.split_once(',') else {
            return Err(ParseError {
                line: line_no,
                column: indent + 1,
                expected: format!("image {} of {count} as \"id, name\"", k + 1),
                found: quote(line),
            });
        };
        let id = parse_u32(id_text.trim()).ok_or_else(|| ParseError {
            line: line_no,
            column: indent + 1,
            expected: "image id (non-negative integer) before the comma".into(),
            found: quote(id_text),
        })?;
        let name = rest.strip_prefix(' ').unwrap_or(rest);
        let name_column = indent + id_text.len() + 2 + (rest.len() - name.len());
        if name.is_empty() {
            return Err(ParseError {
                line: line_no,
                column: name_column,
                expected: format!("the name of image {id} after the comma"),
                found: "nothing".into(),
            });
        }
        if let Some(first) = seen_ids.insert(id, line_no) {
            return Err(ParseError {
                line: line_no,
                column: indent + 1,
                expected: format!("a new image id ({id} is already on line {first})"),
                found: quote(id_text.trim()),
            });
        }
        if let Some(first) = seen_names.insert(name.to_string(), line_no) {
            return Err(ParseError {
                line: line_no,
                column: name_column,
                expected: format!("a new image name (already on line {first})"),
                found: quote(name),
            });
        }
        images.push((id, name.to_string()));
    }
    Ok(images)
}

/// Writes the list as LIMAP does (`id, name` per line).
pub fn format_image_list(list: &ImageList) -> Result<String, LimapError> {
    let mut ids = HashMap::new();
    let mut names = HashMap::new();
    let mut out = String::with_capacity(32 + list.images.len() * 48);
    let _ = writeln!(out, "{HEADER}, {}", list.images.len());
    for (id, name) in &list.images {
        let bad = |reason: String| LimapError::invalid(format!("image list entry {id}"), reason);
        if name.is_empty() || name.trim() != name || name.contains(['\n', '\r']) {
            return Err(bad(format!(
                "name {name:?} is empty, has a line break or surrounding whitespace (LIMAP strips lines)"
            )));
        }
        if ids.insert(*id, ()).is_some() {
            return Err(bad("duplicate id".into()));
        }
        if names.insert(name.as_str(), ()).is_some() {
            return Err(bad(format!("duplicate name {name:?}")));
        }
        let _ = writeln!(out, "{id}, {name}");
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn list() -> ImageList {
        ImageList {
            images: vec![
                (1, "stairs/seq-02/frame-000000.color.png".into()),
                (7, "a b, c.png".into()),
            ],
        }
    }

    #[test]
    fn layout_is_limaps() {
        assert_eq!(
            format_image_list(&list()).unwrap(),
            "number of images, 2\n1, stairs/seq-02/frame-000000.color.png\n7, a b, c.png\n"
        );
    }

    #[test]
    fn round_trip() {
        let l = list();
        assert_eq!(
            parse_image_list(&format_image_list(&l).unwrap()).unwrap(),
            l
        );
    }

    #[test]
    fn with_and_without_the_space_after_the_comma() {
        let l = parse_image_list("number of images,2\r\n3,x.png\r\n4, y.png  \n\n").unwrap();
        assert_eq!(
            l.images,
            vec![(3, "x.png".to_string()), (4, "y.png".to_string())]
        );
        assert_eq!(l.name(4), Some("y.png"));
        assert_eq!(l.name(5), None);
    }

    #[test]
    fn duplicates_name_both_lines() {
        let e = parse_image_list("number of images, 2\n3, a\n3, b\n").unwrap_err();
        assert_eq!(e.line, 3);
        assert!(e.expected.contains("line 2"), "{e}");
        let e = parse_image_list("number of images, 2\n3, a\n4, a\n").unwrap_err();
        assert!(e.expected.contains("line 2"), "{e}");
    }

    /// LIMAP's list form (`save_txt_imname_list`: the count, then one name per line, as
    /// LIMAP 1.x's runners wrote absolute paths): ids are the positions from 0.
    #[test]
    fn the_list_form_gives_ids_by_position() {
        let text = "number of images, 3\n/data/7scenes/stairs/seq-02/frame-000000.color.png\n\
                    /data/7scenes/stairs/seq-02/frame-000020.color.png\n  a b.png \r\n";
        let l = parse_image_list(text).unwrap();
        assert_eq!(
            l.images,
            vec![
                (
                    0,
                    "/data/7scenes/stairs/seq-02/frame-000000.color.png".to_string()
                ),
                (
                    1,
                    "/data/7scenes/stairs/seq-02/frame-000020.color.png".to_string()
                ),
                (2, "a b.png".to_string()),
            ]
        );
        // Relative names and a later name with a comma (which only the first line decides
        // against).
        let l = parse_image_list("number of images, 2\nseq-01/x.png\n3, y.png\n").unwrap();
        assert_eq!(l.name(1), Some("3, y.png"));
    }

    #[test]
    fn list_form_errors_name_the_line() {
        let e = parse_image_list("number of images, 3\na.png\n\nb.png\n").unwrap_err();
        assert_eq!((e.line, e.column), (3, 1));
        assert!(
            e.expected.contains("image 2 of 3: a name (the list form"),
            "{e}"
        );
        let e = parse_image_list("number of images, 2\na.png\n a.png\n").unwrap_err();
        assert_eq!((e.line, e.column), (3, 2));
        assert!(e.expected.contains("already on line 2"), "{e}");
        let e = parse_image_list("number of images, 2\na.png\n").unwrap_err();
        assert_eq!(e.line, 3);
        assert!(e.expected.contains("image 2 of 2"), "{e}");
        let e = parse_image_list("number of images, 1\na.png\nb.png\n").unwrap_err();
        assert!(e.expected.contains("end of file after 1 images"), "{e}");
    }

    #[test]
    fn writer_refuses_names_that_would_not_read_back() {
        for name in ["", " lead", "trail ", "two\nlines"] {
            let l = ImageList {
                images: vec![(1, name.into())],
            };
            assert!(format_image_list(&l).is_err(), "{name:?}");
        }
    }
}
