//! The synth stage: renders the scene of a [`SynthConfig`] into `<dir>/<name>/` and
//! records it in `<dir>/stage.json` through the stage runner (the configuration's hash
//! and the hash of every file written), so a changed configuration or a touched file
//! renders the scene again and anything else skips it.

use crate::error::{Result, SynthError};
use crate::generate::{SynthConfig, WriteOptions, generate};
use fileio::IoResultExt;
use stage::{Done, Stage};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

pub const STAGE: &str = "synth";

/// The rendered scene.
#[derive(Clone, Debug)]
pub struct SceneDir {
    /// `<dir>/<name>`: the dataset folder, in the configured layout.
    pub root: PathBuf,
    pub config: SynthConfig,
}

impl stage::Note for SceneDir {
    fn note(&self) -> String {
        let size = if self.config.tiny {
            "tiny scene".to_string()
        } else {
            format!("{} frames", self.config.frames)
        };
        format!("{size}, seed {}", self.config.seed)
    }
}

/// The contact sheet `pl2map synth --preview` writes into the scene folder: known to
/// this stage, so a rerun replaces it like its own files.
pub const PREVIEW_FILE: &str = "preview.png";

/// Renders the scene into `dir/<name>` unless the record in `dir` matches. A scene
/// folder holding files this stage did not write (its record does not name them) is
/// refused, naming them, unless `replace_foreign` (`pl2map synth --overwrite`).
pub fn run(
    config: &SynthConfig,
    dir: &Path,
    progress: bool,
    replace_foreign: bool,
) -> Result<Done<SceneDir>> {
    config.validate()?;
    let stage = Stage::new(STAGE, dir, config, BTreeMap::new())?;
    let root = dir.join(&config.name);
    if root.is_dir() && !replace_foreign && stage.check()? != stage::RecordCheck::UpToDate {
        let ours: std::collections::BTreeSet<String> = stage
            .previous()
            .filter(|r| r.stage == STAGE)
            .map(|r| r.outputs.into_keys().collect())
            .unwrap_or_default();
        let preview = format!("{}/{PREVIEW_FILE}", config.name);
        let foreign: Vec<String> = files_under(dir, &config.name)?
            .into_iter()
            .filter(|f| !ours.contains(f) && *f != preview)
            .collect();
        if !foreign.is_empty() {
            return Err(SynthError::Foreign {
                dir: root,
                count: foreign.len(),
                first: foreign.into_iter().take(5).collect(),
            });
        }
    }
    let output = SceneDir {
        root: root.clone(),
        config: config.clone(),
    };
    stage.run(
        |_| Ok(output.clone()),
        |outputs| {
            let write = WriteOptions {
                out: dir.to_path_buf(),
                overwrite: true,
                progress,
            };
            generate(config, &write)?;
            for rel in files_under(dir, &config.name)? {
                outputs.path(&rel);
            }
            Ok(output.clone())
        },
    )
}

/// Every file under `dir/sub`, as `/`-separated paths relative to `dir`, sorted.
pub fn files_under(dir: &Path, sub: &str) -> Result<Vec<String>> {
    let mut out = Vec::new();
    let mut stack: Vec<PathBuf> = vec![dir.join(sub)];
    while let Some(d) = stack.pop() {
        for entry in std::fs::read_dir(&d).at(&d)? {
            let entry = entry.at(&d)?;
            let p = entry.path();
            let ty = entry.file_type().at(&p)?;
            if ty.is_dir() {
                stack.push(p);
            } else if ty.is_file() {
                let rel = p.strip_prefix(dir).unwrap_or(&p);
                let parts: Vec<String> = rel
                    .components()
                    .map(|c| c.as_os_str().to_string_lossy().into_owned())
                    .collect();
                out.push(parts.join("/"));
            }
        }
    }
    out.sort();
    Ok(out)
}
