//! Reading the small text files of dataset layouts: whole-file UTF-8 with the line of an
//! encoding error, lines numbered from 1 with CR stripped (Windows files are common),
//! numbers parsed with the line they came from.

use super::error::{IngestError, Result};
use std::path::Path;

/// Reads a text file; a missing file is [`IngestError::Missing`] with `what`. A UTF-8
/// byte order mark (editors on Windows write one) is dropped: it is not part of the text.
pub(crate) fn read_text(path: &Path, what: &str) -> Result<String> {
    let bytes = match std::fs::read(path) {
        Ok(b) => b,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            return Err(IngestError::Missing {
                path: path.to_path_buf(),
                what: what.to_string(),
            });
        }
        Err(source) => {
            return Err(fileio::IoError::new(path, source).into());
        }
    };
    let text = String::from_utf8(bytes).map_err(|e| {
        let ok = e.utf8_error().valid_up_to();
        let line = e.as_bytes()[..ok].iter().filter(|&&b| b == b'\n').count() + 1;
        IngestError::Parse {
            path: path.to_path_buf(),
            line,
            message: format!("expected UTF-8 text, found an invalid byte at offset {ok}"),
        }
    })?;
    Ok(match text.strip_prefix('\u{feff}') {
        Some(rest) => rest.to_string(),
        None => text,
    })
}

/// `(line number, line)` with the line terminator (LF or CRLF) removed.
pub(crate) fn numbered_lines(text: &str) -> impl Iterator<Item = (usize, &str)> {
    text.split('\n')
        .enumerate()
        .map(|(i, l)| (i + 1, l.strip_suffix('\r').unwrap_or(l)))
}

/// A parse error at `path:line`.
pub(crate) fn parse_err(path: &Path, line: usize, message: impl Into<String>) -> IngestError {
    IngestError::Parse {
        path: path.to_path_buf(),
        line,
        message: message.into(),
    }
}

/// Parses a number token; NaN and infinities parse (they are rejected later with the
/// reason "non-finite", which says more than "not a number").
pub(crate) fn parse_f64(path: &Path, line: usize, token: &str, what: &str) -> Result<f64> {
    token.parse::<f64>().map_err(|_| {
        parse_err(
            path,
            line,
            format!("expected a number for {what}, got {token:?}"),
        )
    })
}

pub(crate) fn parse_usize(path: &Path, line: usize, token: &str, what: &str) -> Result<usize> {
    token.parse::<usize>().map_err(|_| {
        parse_err(
            path,
            line,
            format!("expected a non-negative integer for {what}, got {token:?}"),
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_byte_order_mark_is_not_text() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("pose.txt");
        std::fs::write(&p, "\u{feff}1 0 0 0\r\n").unwrap();
        assert_eq!(read_text(&p, "pose file").unwrap(), "1 0 0 0\r\n");
    }

    #[test]
    fn crlf_and_numbering() {
        let lines: Vec<_> = numbered_lines("a\r\nb\n\r\nc").collect();
        assert_eq!(lines, vec![(1, "a"), (2, "b"), (3, ""), (4, "c")]);
    }

    #[test]
    fn invalid_utf8_names_the_line() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("f.txt");
        std::fs::write(&p, b"ok\nstill ok\nbad \xff here\n").unwrap();
        match read_text(&p, "test file") {
            Err(IngestError::Parse { line, .. }) => assert_eq!(line, 3),
            other => panic!("{other:?}"),
        }
        assert!(matches!(
            read_text(&dir.path().join("nope"), "test file"),
            Err(IngestError::Missing { .. })
        ));
    }
}
