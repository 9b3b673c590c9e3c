//! Explicit image-name mapping between a reconstruction (COLMAP, LIMAP) and the frames
//! table. SfM tools name images relative to whatever folder they were run on
//! (`frame-000000.color.png`, `/data/7scenes/stairs/seq-01/frame-000000.color.png`,
//! `seq1/frame00001.jpg` for `.png` files ...); the frames table names them relative to
//! the dataset root. The mapping says how to get from one to the other, and a name it
//! cannot map is an error, never a fuzzy match.

use serde::{Deserialize, Serialize};

/// Source name -> dataset name, applied in this order: strip `strip_prefix` (which the
/// name must start with), prepend `add_prefix`, then replace the extension `from` by
/// `to` (which the name must end with). The default is the identity.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct NameMapping {
    pub strip_prefix: Option<String>,
    pub add_prefix: Option<String>,
    /// `(from, to)`, e.g. `(".jpg", ".png")`; matched at the end of the name.
    pub replace_extension: Option<(String, String)>,
}

impl NameMapping {
    pub fn identity() -> Self {
        NameMapping::default()
    }

    pub fn is_identity(&self) -> bool {
        self == &NameMapping::default()
    }

    /// The command-line form: `identity`, or comma-separated rules
    /// `strip_prefix=P`, `add_prefix=P`, `replace_extension=FROM:TO`
    /// (e.g. `add_prefix=seq-01/,replace_extension=.jpg:.png`).
    pub fn parse_rules(text: &str) -> Result<NameMapping, String> {
        let mut m = NameMapping::identity();
        if text == "identity" || text.is_empty() {
            return Ok(m);
        }
        for rule in text.split(',') {
            let (key, value) = rule
                .split_once('=')
                .ok_or_else(|| format!("expected KEY=VALUE, got {rule:?}"))?;
            match key {
                "strip_prefix" => m.strip_prefix = Some(value.to_string()),
                "add_prefix" => m.add_prefix = Some(value.to_string()),
                "replace_extension" => {
                    let (a, b) = value.split_once(':').ok_or_else(|| {
                        format!(
                            "replace_extension: expected FROM:TO (e.g. .jpg:.png), got {value:?}"
                        )
                    })?;
                    if a.is_empty() {
                        return Err("replace_extension: the extension to replace is empty".into());
                    }
                    m.replace_extension = Some((a.to_string(), b.to_string()));
                }
                _ => {
                    return Err(format!(
                        "unknown rule {key:?} (expected strip_prefix, add_prefix or replace_extension)"
                    ));
                }
            }
        }
        Ok(m)
    }

    /// The dataset name of `source`, or why the mapping does not apply to it.
    pub fn apply(&self, source: &str) -> Result<String, String> {
        let mut name = source;
        if let Some(p) = &self.strip_prefix {
            name = name
                .strip_prefix(p.as_str())
                .ok_or_else(|| format!("does not start with the prefix {p:?} to strip"))?;
        }
        let mut out = match &self.add_prefix {
            Some(p) => format!("{p}{name}"),
            None => name.to_string(),
        };
        if let Some((from, to)) = &self.replace_extension {
            let stem = out
                .strip_suffix(from.as_str())
                .ok_or_else(|| format!("does not end with the extension {from:?} to replace"))?;
            out = format!("{stem}{to}");
        }
        if out.is_empty() {
            return Err("maps to an empty name".into());
        }
        Ok(out)
    }
}

impl std::fmt::Display for NameMapping {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.is_identity() {
            return f.write_str("identity");
        }
        let mut parts = Vec::new();
        if let Some(p) = &self.strip_prefix {
            parts.push(format!("strip prefix {p:?}"));
        }
        if let Some(p) = &self.add_prefix {
            parts.push(format!("add prefix {p:?}"));
        }
        if let Some((a, b)) = &self.replace_extension {
            parts.push(format!("extension {a:?} -> {b:?}"));
        }
        f.write_str(&parts.join(", "))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn command_line_rules() {
        assert_eq!(
            NameMapping::parse_rules("identity"),
            Ok(NameMapping::identity())
        );
        let m = NameMapping::parse_rules(
            "strip_prefix=a/,add_prefix=seq-01/,replace_extension=.jpg:.png",
        )
        .unwrap();
        assert_eq!(m.apply("a/x.jpg").unwrap(), "seq-01/x.png");
        assert!(NameMapping::parse_rules("prefix=a").is_err());
        assert!(NameMapping::parse_rules("replace_extension=.jpg").is_err());
    }

    #[test]
    fn identity_and_each_rule() {
        assert_eq!(NameMapping::identity().apply("a/b.png").unwrap(), "a/b.png");
        let m = NameMapping {
            strip_prefix: Some("/data/stairs/".into()),
            add_prefix: None,
            replace_extension: None,
        };
        assert_eq!(
            m.apply("/data/stairs/seq-01/f.png").unwrap(),
            "seq-01/f.png"
        );
        assert!(m.apply("seq-01/f.png").unwrap_err().contains("prefix"));
        let m = NameMapping {
            strip_prefix: None,
            add_prefix: Some("seq-01/".into()),
            replace_extension: Some((".jpg".into(), ".png".into())),
        };
        assert_eq!(m.apply("f.jpg").unwrap(), "seq-01/f.png");
        assert!(m.apply("f.jpeg").unwrap_err().contains("extension"));
        // The extension is matched at the end only.
        assert_eq!(m.apply("a.jpg.jpg").unwrap(), "seq-01/a.jpg.png");
        let empty = NameMapping {
            strip_prefix: Some("x".into()),
            ..Default::default()
        };
        assert!(empty.apply("x").unwrap_err().contains("empty"));
    }
}
