//! The synthetic scene as a recorded stage. `datasets::synth::generate` has no record of
//! its own (`pl2map synth` is a one-off command), so the pipeline keeps one in
//! `<work>/synth/stage.json`: the section's hash, and the hash of every file it wrote,
//! so a changed section or a touched file renders the scene again.

use crate::config::SynthSection;
use crate::error::{Result, io_err, stage_err};
use stage::{RecordCheck, StageRecord};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

pub const STAGE: &str = "synth";
/// `stage::record::RECORD_FILE` (not exported by the stage crate).
const RECORD_FILE: &str = "stage.json";

/// Renders the scene into `dir/<name>` unless the record matches. Returns whether it
/// was skipped.
pub fn run(section: &SynthSection, dir: &Path, progress: bool) -> Result<bool> {
    std::fs::create_dir_all(dir).map_err(io_err(dir))?;
    let config_hash = stage::hash_config(section)?;
    let inputs = BTreeMap::new();
    let check = match StageRecord::check(dir, STAGE, &config_hash, &inputs) {
        // An unreadable record only means "render again".
        Err(stage::StageError::Record { .. }) => RecordCheck::Missing,
        other => other?,
    };
    match check {
        RecordCheck::UpToDate => return Ok(true),
        RecordCheck::Missing => {}
        RecordCheck::Changed(why) => tracing::info!("synth: rerunning ({why})"),
    }
    let record_path = dir.join(RECORD_FILE);
    match std::fs::remove_file(&record_path) {
        Ok(()) => {}
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
        Err(e) => return Err(io_err(&record_path)(e)),
    }
    let cfg = datasets::synth::SynthConfig {
        out: dir.to_path_buf(),
        scene_name: section.name.clone(),
        frames: section.frames,
        seed: section.seed,
        layout: match section.layout {
            datasets::ingest::DatasetKind::SevenScenes => datasets::synth::Layout::SevenScenes,
            datasets::ingest::DatasetKind::Cambridge => datasets::synth::Layout::Cambridge,
        },
        tiny: section.tiny,
        overwrite: true,
        progress,
        ground_truth: true,
        label_noise_cm: section.label_noise_cm,
        train_sequences: section.train_sequences,
    };
    datasets::synth::generate(&cfg).map_err(|e| stage_err(STAGE)(&e))?;
    let mut record = StageRecord::new(STAGE, config_hash, inputs);
    for rel in files_under(dir, &section.name)? {
        record.add_output(dir, &rel)?;
    }
    record.save(dir)?;
    Ok(false)
}

/// Every file under `dir/sub`, as `/`-separated paths relative to `dir`, sorted.
pub fn files_under(dir: &Path, sub: &str) -> Result<Vec<String>> {
    let mut out = Vec::new();
    let mut stack: Vec<PathBuf> = vec![dir.join(sub)];
    while let Some(d) = stack.pop() {
        for entry in std::fs::read_dir(&d).map_err(io_err(&d))? {
            let entry = entry.map_err(io_err(&d))?;
            let p = entry.path();
            let ty = entry.file_type().map_err(io_err(&p))?;
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
