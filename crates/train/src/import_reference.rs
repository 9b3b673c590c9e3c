//! `pl2map checkpoint import`: the reference implementation's released PL2Map model (a
//! PyTorch state dict of its PL2Map module at D = 256) written as this project's
//! checkpoint, with a SuperPoint front-end, so that `pl2map score` and `pl2map localize`
//! use it (docs/formats.md, "Importing the reference's checkpoints"). The name and head
//! mapping is `model::import_reference`.

use crate::checkpoint::{CheckpointHeader, save};
use crate::config::TrainConfig;
use crate::error::TrainError;
use features::FrontEndKind;
use model::CpuAutodiffBackend;
use model::import_reference::{from_reference, reference_config};
use std::path::{Path, PathBuf};

/// The key under which the reference's training script saves the state dict
/// (`{"epoch": .., "model_state_dict": ..}`); a bare state dict is read as well.
pub const TOP_LEVEL_KEY: &str = "model_state_dict";

/// What a missing key says the file should have been.
const EXPECTED: &str = "the state dict of the reference implementation's PL2Map module at D = 256";

/// What was imported.
#[derive(Clone, Debug, PartialEq)]
pub struct ImportSummary {
    /// Tensors read (weights and biases).
    pub tensors: usize,
    pub parameters: usize,
    /// Whether the state dict sat under [`TOP_LEVEL_KEY`].
    pub nested: bool,
    pub superpoint_weights: PathBuf,
    pub superpoint_sha256: String,
}

/// Reads `reference` and writes the checkpoint `out` (weights only, iteration 0, scene
/// centre 0: the reference predicts world coordinates directly). `superpoint_weights`:
/// the SuperPoint weights file the query front-end will use (else
/// `PL2MAP_SUPERPOINT_WEIGHTS`); it is read (so a wrong file is refused now) and its path
/// and sha256 are recorded. The first missing or misshapen key refuses the file, naming
/// it, the key and the expected shape.
pub fn import_reference(
    reference: &Path,
    out: &Path,
    superpoint_weights: Option<&Path>,
) -> Result<ImportSummary, TrainError> {
    let mut config = TrainConfig {
        model: reference_config(),
        ..TrainConfig::default()
    };
    config.front_end.kind = FrontEndKind::Superpoint;
    config.front_end.superpoint.weights = superpoint_weights.map(Path::to_path_buf);
    let weights_path = config.front_end.superpoint.weights_path().ok_or_else(|| {
        TrainError::Reference(superpoint::SuperPointError::Weights {
            path: reference.to_path_buf(),
            key: None,
            reason: format!(
                "the imported model needs the SuperPoint weights it was trained with: pass \
                 --superpoint-weights FILE or set {} (README.md, \"SuperPoint weights\")",
                features::SUPERPOINT_WEIGHTS_ENV
            ),
        })
    })?;
    let weights = superpoint::Weights::read(&weights_path)?;
    let sha256 = weights.sha256.clone().unwrap_or_default();
    let weights_path = std::path::absolute(&weights_path).unwrap_or(weights_path);
    config.front_end.superpoint.weights = Some(weights_path.clone());
    config.front_end.superpoint.weights_sha256 = Some(sha256.clone());
    config.validate()?;

    if !reference.is_file() {
        return Err(TrainError::Reference(
            superpoint::SuperPointError::Weights {
                path: reference.to_path_buf(),
                key: None,
                reason: "no such file".into(),
            },
        ));
    }
    let (dict, nested) = match superpoint::StateDict::open(reference, Some(TOP_LEVEL_KEY)) {
        Ok(d) if !d.keys().is_empty() => (d, true),
        _ => (
            superpoint::StateDict::open(reference, None).map_err(TrainError::Reference)?,
            false,
        ),
    };
    let mut tensors = 0usize;
    let device = Default::default();
    let net = from_reference::<CpuAutodiffBackend, _, _>(&config.model, &device, |key, shape| {
        tensors += 1;
        dict.tensor(key, shape, EXPECTED)
    })?
    .map_err(TrainError::Reference)?;
    let header = CheckpointHeader {
        tool_version: env!("CARGO_PKG_VERSION").to_string(),
        config,
        iteration: 0,
        has_optimizer: false,
        scene_centre: [0.0; 3],
        weights_hash: String::new(),
        optimizer_hash: String::new(),
    };
    save(out, &header, &net, None)?;
    Ok(ImportSummary {
        tensors,
        parameters: net.parameter_counts().total(),
        nested,
        superpoint_weights: weights_path,
        superpoint_sha256: sha256,
    })
}
