//! SuperPoint's weights: the released state-dict file read tensor by tensor.
//!
//! The file (`superpoint_v1.pth`, a PyTorch state dict, zip or legacy pickle format) has
//! one weight and one bias per convolution, named after the layer: `conv1a.weight`,
//! `conv1a.bias`, ..., `convDb.bias` (docs/method.md section 2b). [`LAYERS`] lists them
//! in network order with their shapes; anything else in the file is ignored, and a
//! missing key or a wrong shape is one error naming the file and the key.

use crate::error::SuperPointError;
use burn::tensor::TensorData;
use std::path::Path;

/// One convolution: name, output and input channels, kernel size.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Layer {
    pub name: &'static str,
    pub out_channels: usize,
    pub in_channels: usize,
    pub kernel: usize,
}

const fn layer(
    name: &'static str,
    out_channels: usize,
    in_channels: usize,
    kernel: usize,
) -> Layer {
    Layer {
        name,
        out_channels,
        in_channels,
        kernel,
    }
}

/// The network's convolutions in order: the shared VGG-style encoder (1/8 resolution,
/// 128 channels), the detector head (65 channels: 64 pixels of an 8 x 8 cell and a
/// "no keypoint" dustbin) and the descriptor head (256 channels).
pub const LAYERS: [Layer; 12] = [
    layer("conv1a", 64, 1, 3),
    layer("conv1b", 64, 64, 3),
    layer("conv2a", 64, 64, 3),
    layer("conv2b", 64, 64, 3),
    layer("conv3a", 128, 64, 3),
    layer("conv3b", 128, 128, 3),
    layer("conv4a", 128, 128, 3),
    layer("conv4b", 128, 128, 3),
    layer("convPa", 256, 128, 3),
    layer("convPb", 65, 256, 1),
    layer("convDa", 256, 128, 3),
    layer("convDb", 256, 256, 1),
];

/// The weights of every layer of [`LAYERS`], in that order: (weight, out x in x k x k
/// row-major; bias, out).
#[derive(Clone, Debug, PartialEq)]
pub struct Weights {
    pub layers: Vec<(Vec<f32>, Vec<f32>)>,
    /// sha256 of the file they were read from (hex); None for weights made in memory.
    pub sha256: Option<String>,
}

/// Parameters of the network (1,300,865).
pub fn parameter_count() -> usize {
    LAYERS
        .iter()
        .map(|l| l.out_channels * (l.in_channels * l.kernel * l.kernel + 1))
        .sum()
}

/// sha256 of a file, hex (the stage records' hash, `stage::sha256_file`).
pub fn file_sha256(path: &Path) -> Result<String, SuperPointError> {
    stage::sha256_file(path).map_err(|e| match e {
        // The error names the file already.
        stage::StageError::Io(e) => SuperPointError::Io(e),
        other => SuperPointError::weights(path, None, other),
    })
}

impl Weights {
    /// Reads the state dict at `path`.
    pub fn read(path: &Path) -> Result<Weights, SuperPointError> {
        if !path.is_file() {
            return Err(SuperPointError::weights(
                path,
                None,
                "no such file (the SuperPoint weights are supplied by the user: README.md, \
                 \"SuperPoint weights\")",
            ));
        }
        let sha256 = file_sha256(path)?;
        let reader = StateDict::open(path, None)?;
        let mut layers = Vec::with_capacity(LAYERS.len());
        for l in &LAYERS {
            let w_shape = [l.out_channels, l.in_channels, l.kernel, l.kernel];
            let w = reader.tensor(&format!("{}.weight", l.name), &w_shape, EXPECTED)?;
            let b = reader.tensor(&format!("{}.bias", l.name), &[l.out_channels], EXPECTED)?;
            layers.push((w, b));
        }
        Ok(Weights {
            layers,
            sha256: Some(sha256),
        })
    }

    /// Weights drawn from a seeded generator (He-uniform weights, small biases): a
    /// legitimate but untrained network, for tests and benchmarks.
    pub fn random(seed: u64) -> Weights {
        // SplitMix64: no dependency, the same stream everywhere.
        let mut state = seed;
        let mut next = move || {
            state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = state;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            z ^= z >> 31;
            (z >> 40) as f32 / (1u64 << 24) as f32 * 2.0 - 1.0
        };
        let layers = LAYERS
            .iter()
            .map(|l| {
                let fan_in = (l.in_channels * l.kernel * l.kernel) as f32;
                let bound = (6.0 / fan_in).sqrt();
                let w = (0..l.out_channels * l.in_channels * l.kernel * l.kernel)
                    .map(|_| next() * bound)
                    .collect();
                let b = (0..l.out_channels).map(|_| next() * 0.01).collect();
                (w, b)
            })
            .collect();
        Weights {
            layers,
            sha256: None,
        }
    }
}

/// What a SuperPoint weights file is, for the refusal of a missing key.
const EXPECTED: &str = "the state dict of the released SuperPoint network";

/// A PyTorch state-dict file (zip or legacy pickle format) read with burn's reader,
/// tensor by tensor; errors name the file and the key. Shared by the SuperPoint weights
/// and the import of the reference's PL2Map checkpoints (`train::import_reference`).
pub struct StateDict {
    path: std::path::PathBuf,
    reader: burn_store::pytorch::PytorchReader,
}

impl StateDict {
    /// Opens `path`; `top_level_key`: the state dict is the value of this key of a
    /// dictionary saved with `torch.save` (e.g. `{"epoch": .., "model_state_dict": ..}`).
    pub fn open(path: &Path, top_level_key: Option<&str>) -> Result<StateDict, SuperPointError> {
        let reader = match top_level_key {
            None => burn_store::pytorch::PytorchReader::new(path),
            Some(k) => burn_store::pytorch::PytorchReader::with_top_level_key(path, k),
        }
        .map_err(|e| {
            SuperPointError::weights(path, None, format!("not a PyTorch state dict: {e}"))
        })?;
        Ok(StateDict {
            path: path.to_path_buf(),
            reader,
        })
    }

    /// The file's keys, sorted.
    pub fn keys(&self) -> Vec<String> {
        let mut k = self.reader.keys();
        k.sort();
        k
    }

    /// The tensor `key` as f32 values in row-major order, refused unless it is there,
    /// has `shape` and holds finite values only. `expected` says what the file should
    /// have been (the message of a missing key).
    pub fn tensor(
        &self,
        key: &str,
        shape: &[usize],
        expected: &str,
    ) -> Result<Vec<f32>, SuperPointError> {
        let path = &self.path;
        let snapshot = self.reader.get(key).ok_or_else(|| {
            SuperPointError::weights(
                path,
                Some(key),
                format!("missing (expected {expected}; shape {shape:?})"),
            )
        })?;
        if snapshot.shape.as_slice() != shape {
            return Err(SuperPointError::weights(
                path,
                Some(key),
                format!("shape {:?}, expected {shape:?}", snapshot.shape.as_slice()),
            ));
        }
        let data: TensorData = snapshot.to_data().map_err(|e| {
            SuperPointError::weights(path, Some(key), format!("cannot read the tensor: {e:?}"))
        })?;
        let values = data
            .convert::<f32>()
            .into_vec::<f32>()
            .map_err(|e| SuperPointError::weights(path, Some(key), format!("{e:?}")))?;
        if values.iter().any(|v| !v.is_finite()) {
            return Err(SuperPointError::weights(
                path,
                Some(key),
                "holds a value that is not finite",
            ));
        }
        Ok(values)
    }
}
