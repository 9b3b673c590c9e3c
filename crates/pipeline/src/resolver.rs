//! Where a pipeline file's values are written: `${NAME}` expansion and paths relative to
//! the file, and errors that name the file and, where the key is written in it, the
//! line and column (crates/pipeline/src/config.rs resolves a pipeline through it).

use crate::Result;
use crate::error::PipelineError;
use crate::expand::{expand, line_column};
use std::path::{Path, PathBuf};

/// Expands and places path values; errors name the file and, where the key is written
/// in it, the line and column.
pub(crate) struct Resolver<'a> {
    text: &'a str,
    origin: &'a Path,
    base: &'a Path,
    /// Where the pipeline's tables sit in `text` (`["pipeline"]` in a lock file).
    prefix: Vec<String>,
    /// `${SCENE}`: `ingest.scene` (after `--scene`); other names come from the environment.
    scene: Option<String>,
    doc: Option<toml::Spanned<toml::de::DeTable<'a>>>,
}

impl<'a> Resolver<'a> {
    pub(crate) fn new(
        text: &'a str,
        origin: &'a Path,
        base: &'a Path,
        prefix: &[&str],
        scene: Option<String>,
    ) -> Self {
        Resolver {
            text,
            origin,
            base,
            prefix: prefix.iter().map(|s| s.to_string()).collect(),
            scene,
            doc: toml::de::DeTable::parse(text).ok(),
        }
    }

    /// The span of the value of `key` (a path of table names and a key) in the text.
    fn span(&self, key: &[&str]) -> Option<std::ops::Range<usize>> {
        let doc = self.doc.as_ref()?;
        let mut table = doc.get_ref();
        let path: Vec<&str> = self
            .prefix
            .iter()
            .map(String::as_str)
            .chain(key.iter().copied())
            .collect();
        let (last, tables) = path.split_last()?;
        for name in tables {
            match table.get(*name)?.get_ref() {
                toml::de::DeValue::Table(t) => table = t,
                _ => return None,
            }
        }
        table.get(*last).map(|v| v.span())
    }

    /// Whether `key` is written in the file.
    pub(crate) fn given(&self, key: &[&str]) -> bool {
        self.span(key).is_some()
    }

    pub(crate) fn value(&self, key: &[&str], message: String) -> PipelineError {
        match self.span(key) {
            Some(span) => {
                let (line, column) = line_column(self.text, span.start);
                PipelineError::Value {
                    path: self.origin.to_path_buf(),
                    line,
                    column,
                    key: key.join("."),
                    message,
                }
            }
            None => self.config(format!("{}: {message}", key.join("."))),
        }
    }

    /// A section's invalid value, at the line of the key the message names (the first
    /// key of the section written in the file that the message mentions), else at the
    /// section.
    pub(crate) fn section(&self, section: &str, message: String) -> PipelineError {
        let is_ident = |c: char| c.is_ascii_alphanumeric() || c == '_';
        let mentions = |key: &str| {
            message.match_indices(key).map(|(at, _)| at).find(|&at| {
                let before = message[..at].chars().next_back();
                let after = message[at + key.len()..].chars().next();
                !before.is_some_and(is_ident) && !after.is_some_and(is_ident)
            })
        };
        let keys = self.keys(section);
        let named = keys
            .iter()
            .filter_map(|k| mentions(k).map(|at| (at, k)))
            .min();
        match named {
            Some((_, key)) => self.value(&[section, key], message),
            None => self.config(format!("[{section}]: {message}")),
        }
    }

    /// The keys written in a section of the file.
    fn keys(&self, section: &str) -> Vec<String> {
        let Some(doc) = self.doc.as_ref() else {
            return Vec::new();
        };
        let mut table = doc.get_ref();
        for name in self.prefix.iter().map(String::as_str).chain([section]) {
            match table.get(name).map(|v| v.get_ref()) {
                Some(toml::de::DeValue::Table(t)) => table = t,
                _ => return Vec::new(),
            }
        }
        table.keys().map(|k| k.get_ref().to_string()).collect()
    }

    pub(crate) fn config(&self, message: String) -> PipelineError {
        PipelineError::Config {
            path: self.origin.to_path_buf(),
            message,
        }
    }

    /// Expanded (`${NAME}`), then relative to the pipeline file's folder.
    pub(crate) fn path(&self, key: &[&str], v: &str) -> Result<PathBuf> {
        let lookup = |n: &str| match n {
            "SCENE" => self.scene.clone(),
            _ => std::env::var(n).ok(),
        };
        let s = expand(v, lookup).map_err(|m| self.value(key, m))?;
        if s.is_empty() {
            return Err(self.value(key, "empty path".into()));
        }
        Ok(self.base.join(s))
    }
}
