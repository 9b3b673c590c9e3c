//! Whitespace tokenising with positions, shared by the parsers.
//!
//! LIMAP's C++ reader (`std::ifstream >>`) and its Python readers split on whitespace, so
//! line breaks carry no meaning in track files; positions are kept only for messages.
//! Expected-value descriptions are closures so that the common, valid path allocates
//! nothing per token.

use crate::error::ParseError;

/// A whitespace-separated token with its 1-based line and byte column.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Token<'a> {
    pub text: &'a str,
    pub line: usize,
    pub column: usize,
}

impl Token<'_> {
    pub fn error(&self, expected: impl Into<String>) -> ParseError {
        ParseError {
            line: self.line,
            column: self.column,
            expected: expected.into(),
            found: quote(self.text),
        }
    }
}

/// Shortened, escaped rendering of an offending token for messages.
pub(crate) fn quote(text: &str) -> String {
    const MAX_CHARS: usize = 40;
    if text.chars().count() > MAX_CHARS {
        let head: String = text.chars().take(MAX_CHARS).collect();
        format!("{head:?}...")
    } else {
        format!("{text:?}")
    }
}

pub(crate) struct Cursor<'a> {
    text: &'a str,
    pos: usize,
    line: usize,
    line_start: usize,
}

impl<'a> Cursor<'a> {
    pub fn new(text: &'a str) -> Self {
        Cursor {
            text,
            pos: 0,
            line: 1,
            line_start: 0,
        }
    }

    fn skip_whitespace(&mut self) {
        let bytes = self.text.as_bytes();
        while let Some(&b) = bytes.get(self.pos) {
            if !b.is_ascii_whitespace() {
                break;
            }
            if b == b'\n' {
                self.line += 1;
                self.line_start = self.pos + 1;
            }
            self.pos += 1;
        }
    }

    pub fn next_token(&mut self) -> Option<Token<'a>> {
        self.skip_whitespace();
        let bytes = self.text.as_bytes();
        let start = self.pos;
        while let Some(&b) = bytes.get(self.pos) {
            if b.is_ascii_whitespace() {
                break;
            }
            self.pos += 1;
        }
        // Token boundaries sit next to ASCII whitespace or the ends, so they are char
        // boundaries; `get` keeps that an invariant rather than a panic.
        let text = self.text.get(start..self.pos)?;
        if text.is_empty() {
            return None;
        }
        Some(Token {
            text,
            line: self.line,
            column: start - self.line_start + 1,
        })
    }

    /// Bytes not yet consumed: an upper bound for how many tokens can still follow, used to
    /// cap allocations driven by counts read from the file.
    pub fn remaining_bytes(&self) -> usize {
        self.text.len().saturating_sub(self.pos)
    }

    pub fn eof_error(&mut self, expected: impl Into<String>) -> ParseError {
        self.skip_whitespace();
        ParseError {
            line: self.line,
            column: self.pos - self.line_start + 1,
            expected: expected.into(),
            found: "end of file".to_string(),
        }
    }

    pub fn token(&mut self, expected: impl FnOnce() -> String) -> Result<Token<'a>, ParseError> {
        match self.next_token() {
            Some(t) => Ok(t),
            None => Err(self.eof_error(expected())),
        }
    }

    pub fn keyword(&mut self, keyword: &str) -> Result<Token<'a>, ParseError> {
        let t = self.token(|| format!("keyword {keyword:?}"))?;
        if t.text == keyword {
            Ok(t)
        } else {
            Err(t.error(format!("keyword {keyword:?}")))
        }
    }

    pub fn parse<T>(
        &mut self,
        expected: impl FnOnce() -> String,
        convert: impl FnOnce(&str) -> Option<T>,
    ) -> Result<(T, Token<'a>), ParseError> {
        match self.next_token() {
            Some(t) => match convert(t.text) {
                Some(v) => Ok((v, t)),
                None => Err(t.error(expected())),
            },
            None => Err(self.eof_error(expected())),
        }
    }

    pub fn count(
        &mut self,
        expected: impl FnOnce() -> String,
    ) -> Result<(u64, Token<'a>), ParseError> {
        self.parse(expected, parse_u64)
    }

    pub fn u32(&mut self, expected: impl FnOnce() -> String) -> Result<u32, ParseError> {
        self.parse(expected, parse_u32).map(|(v, _)| v)
    }

    pub fn i32(&mut self, expected: impl FnOnce() -> String) -> Result<i32, ParseError> {
        self.parse(expected, |s| s.parse::<i32>().ok())
            .map(|(v, _)| v)
    }

    pub fn finite(&mut self, expected: impl FnOnce() -> String) -> Result<f64, ParseError> {
        self.parse(expected, parse_finite).map(|(v, _)| v)
    }

    /// Succeeds only when nothing but whitespace is left.
    pub fn end(&mut self, expected: impl FnOnce() -> String) -> Result<(), ParseError> {
        match self.next_token() {
            None => Ok(()),
            Some(t) => Err(t.error(expected())),
        }
    }
}

pub(crate) fn parse_u64(s: &str) -> Option<u64> {
    // `u64::from_str` accepts a leading '+', as C++ `>>` and Python `int()` do.
    s.parse::<u64>().ok()
}

pub(crate) fn parse_u32(s: &str) -> Option<u32> {
    s.parse::<u32>().ok()
}

/// A finite decimal number. "nan" and "inf" parse in Rust but not with LIMAP's C++ reader,
/// and a non-finite coordinate is never a valid label, so both are refused.
pub(crate) fn parse_finite(s: &str) -> Option<f64> {
    s.parse::<f64>().ok().filter(|v| v.is_finite())
}

/// Capacity for `count` items of at least `min_bytes` bytes each, given what is left of the
/// input: a corrupt count can never reserve more than the file could hold.
pub(crate) fn bounded_capacity(count: u64, remaining_bytes: usize, min_bytes: usize) -> usize {
    let max_items = remaining_bytes / min_bytes.max(1) + 1;
    usize::try_from(count).unwrap_or(usize::MAX).min(max_items)
}

/// The lines of a text with 1-based numbers, a trailing `\r` removed (Python's universal
/// newlines read CRLF files the same way).
pub(crate) fn numbered_lines(text: &str) -> impl Iterator<Item = (usize, &str)> {
    text.split('\n')
        .enumerate()
        .map(|(i, l)| (i + 1, l.strip_suffix('\r').unwrap_or(l)))
}

/// Whitespace-separated fields of one line with their 1-based byte columns.
pub(crate) fn fields(line: &str) -> impl Iterator<Item = (usize, &str)> {
    let base = line.as_ptr() as usize;
    line.split_ascii_whitespace()
        .map(move |f| (f.as_ptr() as usize - base + 1, f))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tokens_carry_line_and_column() {
        let mut c = Cursor::new("a  bb\n\n  ccc\r\nd");
        let t: Vec<_> = std::iter::from_fn(|| c.next_token())
            .map(|t| (t.text, t.line, t.column))
            .collect();
        assert_eq!(
            t,
            vec![("a", 1, 1), ("bb", 1, 4), ("ccc", 3, 3), ("d", 4, 1)]
        );
    }

    #[test]
    fn eof_error_points_past_the_last_token() {
        let mut c = Cursor::new("1 2\n");
        c.next_token();
        c.next_token();
        let e = c.eof_error("x");
        assert_eq!((e.line, e.column, e.found.as_str()), (2, 1, "end of file"));
    }

    #[test]
    fn numbers() {
        assert_eq!(parse_u32("+7"), Some(7));
        assert_eq!(parse_u32("-1"), None);
        assert_eq!(parse_u32("4294967296"), None);
        assert_eq!(parse_finite("1e-05"), Some(1e-5));
        assert_eq!(parse_finite("nan"), None);
        assert_eq!(parse_finite("-inf"), None);
        assert_eq!(parse_finite("1.5x"), None);
    }

    #[test]
    fn capacity_is_bounded_by_the_input() {
        assert_eq!(bounded_capacity(u64::MAX, 100, 4), 26);
        assert_eq!(bounded_capacity(3, 1_000_000, 4), 3);
    }

    #[test]
    fn field_columns() {
        let f: Vec<_> = fields("  1.5 2\t3").collect();
        assert_eq!(f, vec![(3, "1.5"), (7, "2"), (9, "3")]);
    }

    #[test]
    fn long_tokens_are_shortened() {
        let q = quote(&"x".repeat(100));
        assert!(q.len() < 60 && q.ends_with("..."));
    }
}
