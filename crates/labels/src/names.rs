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
