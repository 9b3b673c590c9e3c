//! `${NAME}` in path values of pipeline files: the dataset, hloc and LIMAP folders of a
//! template come from the environment, so one committed file serves every machine.

/// Replaces every `${NAME}` by the value `lookup` gives; `$$` is a literal `$`. An
/// unset or empty variable or an unclosed `${` is an error naming it: an empty value
/// would turn `${DATA}/w` into `/w`, a path nobody meant.
pub fn expand(s: &str, lookup: impl Fn(&str) -> Option<String>) -> Result<String, String> {
    let mut out = String::with_capacity(s.len());
    let mut rest = s;
    while let Some(i) = rest.find('$') {
        out.push_str(&rest[..i]);
        let after = &rest[i + 1..];
        if let Some(tail) = after.strip_prefix('$') {
            out.push('$');
            rest = tail;
        } else if let Some(tail) = after.strip_prefix('{') {
            let end = tail
                .find('}')
                .ok_or_else(|| format!("unclosed ${{ in {s:?}"))?;
            let name = &tail[..end];
            if name.is_empty() || !name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') {
                return Err(format!("bad variable name {name:?} in {s:?}"));
            }
            let value = lookup(name)
                .ok_or_else(|| format!("environment variable {name} is not set (used in {s:?})"))?;
            if value.is_empty() {
                return Err(format!(
                    "environment variable {name} is set but empty (used in {s:?})"
                ));
            }
            out.push_str(&value);
            rest = &tail[end + 1..];
        } else {
            // A lone `$` followed by anything else is kept: paths may contain it.
            out.push('$');
            rest = after;
        }
    }
    out.push_str(rest);
    Ok(out)
}

/// 1-based line and column (in characters) of byte offset `at` in `text`.
pub fn line_column(text: &str, at: usize) -> (usize, usize) {
    let at = at.min(text.len());
    let before = &text[..at];
    let line = before.matches('\n').count() + 1;
    let col = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    (line, col)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn env(name: &str) -> Option<String> {
        match name {
            "DATA" => Some("/data/7scenes".to_string()),
            "EMPTY" => Some(String::new()),
            _ => None,
        }
    }

    #[test]
    fn expands_and_refuses() {
        assert_eq!(
            expand("${DATA}/stairs", env).unwrap(),
            "/data/7scenes/stairs"
        );
        assert_eq!(expand("a$$b$c", env).unwrap(), "a$b$c");
        assert_eq!(expand("plain", env).unwrap(), "plain");
        let e = expand("${NOPE}/x", env).unwrap_err();
        assert!(e.contains("NOPE is not set"), "{e}");
        assert!(expand("${DATA", env).unwrap_err().contains("unclosed"));
        assert!(expand("${A B}", env).unwrap_err().contains("bad variable"));
    }

    /// `${EMPTY}/w` with EMPTY="" is refused like an unset variable, not read as `/w`.
    #[test]
    fn an_empty_variable_is_refused() {
        assert_eq!(
            expand("${EMPTY}/w", env).unwrap_err(),
            "environment variable EMPTY is set but empty (used in \"${EMPTY}/w\")"
        );
    }

    #[test]
    fn positions() {
        let t = "a = 1\nbb = \"x\"\n";
        assert_eq!(line_column(t, 0), (1, 1));
        assert_eq!(line_column(t, 6), (2, 1));
        assert_eq!(line_column(t, 11), (2, 6));
    }
}
