//! Checkpoint files: the training configuration, the progress, the network's weights and
//! (for resuming) Adam's state, in one file written atomically (temp file + rename).
//!
//! Layout (little endian):
//! `"PL2MAPCK"` | u32 format version | u64 n | n bytes of JSON header | u64 m | m bytes
//! of weights | u64 k | k bytes of optimiser state (k = 0: weights only).
//! Weights and optimiser state are burn records in named MessagePack at full precision
//! (f32 values bit for bit). Nothing else is needed to resume exactly: every random
//! choice of the trainer is derived from the seed and the iteration (see `seeds.rs`),
//! and the stream position is the iteration.

use crate::config::TrainConfig;
use crate::error::{TrainError, io_err};
use crate::step::Pl2MapOptimizer;
use model::burn::module::{Module, ModuleVisitor, Param, ParamId};
use model::burn::optim::Optimizer;
use model::burn::record::{
    FullPrecisionSettings, NamedMpkBytesRecorder, PrecisionSettings, Record, Recorder,
};
use model::burn::tensor::Tensor;
use model::burn::tensor::backend::{AutodiffBackend, Backend};
use model::{Device, Pl2Map, Pl2MapBackend};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::io::Write;
use std::path::{Path, PathBuf};

const MAGIC: &[u8; 8] = b"PL2MAPCK";
/// 2: the front-end configuration records `descriptor.method` and
/// `lsd.implementation`. Format 1 files were all written with OpenCV's SIFT descriptor
/// and OpenCV's LSD and are read as such.
pub const FORMAT_VERSION: u32 = 2;
const OPENCV_DESCRIPTOR_VERSION: u32 = 1;

/// File names inside a training output folder.
pub const CHECKPOINT_FILE: &str = "checkpoint.ckpt";
pub const MODEL_FILE: &str = "model.ckpt";

/// What a checkpoint says about the run.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CheckpointHeader {
    pub tool_version: String,
    pub config: TrainConfig,
    /// Iterations done (= the stream position to continue from).
    pub iteration: u64,
    pub has_optimizer: bool,
    /// Origin of the network's world coordinates in the scene's frame (see
    /// `sample::recentre`): predictions are `network output + scene_centre`.
    #[serde(default)]
    pub scene_centre: [f64; 3],
    /// FNV-1a 64 of the weights and optimiser bytes: corruption is reported before any
    /// decoding (a decoder fed damaged records may build tensors of the wrong shape).
    #[serde(default)]
    pub weights_hash: String,
    #[serde(default)]
    pub optimizer_hash: String,
}

fn fnv1a(bytes: &[u8]) -> String {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for &b in bytes {
        h ^= b as u64;
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    format!("{h:016x}")
}

/// A checkpoint read from disk, records still serialised.
pub struct CheckpointFile {
    pub path: PathBuf,
    pub header: CheckpointHeader,
    weights: Vec<u8>,
    optimizer: Vec<u8>,
}

type Rec = NamedMpkBytesRecorder<FullPrecisionSettings>;

fn ck_err(path: &Path, reason: impl Into<String>) -> TrainError {
    TrainError::Checkpoint {
        path: path.to_path_buf(),
        reason: reason.into(),
    }
}

/// Every float parameter of a network as little-endian f32 bytes, in module order: what
/// "byte-identical weights" means. (The burn record also holds parameter ids: a network
/// built by `ModelConfig::init` numbers them in module order, so a seeded run's
/// checkpoint files are byte-identical too; a network loaded from a file keeps its ids.)
pub fn parameter_bytes<B: Backend>(model: &Pl2Map<B>) -> Vec<u8> {
    struct Collect(Vec<u8>);
    impl<B: Backend> ModuleVisitor<B> for Collect {
        fn visit_float<const D: usize>(&mut self, param: &Param<Tensor<B, D>>) {
            let data = param.val().into_data().convert::<f32>();
            for v in data.iter::<f32>() {
                self.0.extend_from_slice(&v.to_le_bytes());
            }
        }
    }
    let mut c = Collect(Vec::new());
    model.visit(&mut c);
    c.0
}

/// Adam's state by parameter id, serialised in id order. burn's own record is a
/// `HashMap`, written in a per-process random order, so the same state gave different
/// bytes on every save. The wire format (a MessagePack map from id to state) is the
/// same, so files written before this still load.
/// (Held as pairs: burn's map is its own `hashbrown` one.)
struct OrderedById<T>(Vec<(ParamId, T)>);

impl<B: Backend, T: Record<B>> Record<B> for OrderedById<T> {
    type Item<S: PrecisionSettings> = BTreeMap<String, T::Item<S>>;

    fn into_item<S: PrecisionSettings>(self) -> Self::Item<S> {
        self.0
            .into_iter()
            .map(|(id, r)| (id.serialize(), r.into_item()))
            .collect()
    }

    fn from_item<S: PrecisionSettings>(item: Self::Item<S>, device: &B::Device) -> Self {
        OrderedById(
            item.into_iter()
                .map(|(id, i)| (ParamId::deserialize(&id), T::from_item(i, device)))
                .collect(),
        )
    }
}

/// The serialised record of a network's weights.
pub fn weight_bytes<B: Backend>(model: &Pl2Map<B>) -> Result<Vec<u8>, TrainError> {
    Recorder::<B>::record(&Rec::default(), model.clone().into_record(), ()).map_err(|e| {
        TrainError::Checkpoint {
            path: PathBuf::new(),
            reason: format!("serialising the weights: {e}"),
        }
    })
}

/// Writes a checkpoint atomically; `optimizer = None` writes weights only.
pub fn save<B: AutodiffBackend<InnerBackend: Pl2MapBackend> + Pl2MapBackend>(
    path: &Path,
    header: &CheckpointHeader,
    model: &Pl2Map<B>,
    optimizer: Option<&Pl2MapOptimizer<B>>,
) -> Result<(), TrainError> {
    let weights = weight_bytes(model).map_err(|_| ck_err(path, "serialising the weights"))?;
    let optim = match optimizer {
        Some(o) => Recorder::<B>::record(
            &Rec::default(),
            OrderedById(o.to_record().into_iter().collect()),
            (),
        )
        .map_err(|e| ck_err(path, format!("serialising the optimiser: {e}")))?,
        None => Vec::new(),
    };
    let header = CheckpointHeader {
        has_optimizer: optimizer.is_some(),
        weights_hash: fnv1a(&weights),
        optimizer_hash: fnv1a(&optim),
        ..header.clone()
    };
    let json = serde_json::to_vec(&header).map_err(|e| ck_err(path, e.to_string()))?;
    let mut bytes = Vec::with_capacity(weights.len() + optim.len() + json.len() + 40);
    bytes.extend_from_slice(MAGIC);
    bytes.extend_from_slice(&FORMAT_VERSION.to_le_bytes());
    for part in [&json, &weights, &optim] {
        bytes.extend_from_slice(&(part.len() as u64).to_le_bytes());
        bytes.extend_from_slice(part);
    }
    write_atomic(path, &bytes)
}

/// Temp file in the same folder, fsync, rename: a reader (or a killed run) sees the old
/// file or the new one, never half of one.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), TrainError> {
    let dir = path.parent().unwrap_or(Path::new("."));
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let tmp = dir.join(format!(".{name}.tmp"));
    let mut f = std::fs::File::create(&tmp).map_err(io_err(&tmp))?;
    f.write_all(bytes).map_err(io_err(&tmp))?;
    f.sync_all().map_err(io_err(&tmp))?;
    drop(f);
    Ok(std::fs::rename(&tmp, path).map_err(io_err(path))?)
}

impl CheckpointFile {
    pub fn read(path: &Path) -> Result<Self, TrainError> {
        let bytes = std::fs::read(path).map_err(io_err(path))?;
        if bytes.len() < 12 || &bytes[..8] != MAGIC {
            return Err(ck_err(path, "not a pl2map checkpoint (bad magic)"));
        }
        let version = u32::from_le_bytes(bytes[8..12].try_into().unwrap_or_default());
        if version != FORMAT_VERSION && version != OPENCV_DESCRIPTOR_VERSION {
            return Err(ck_err(
                path,
                format!(
                    "format version {version}, this build reads {OPENCV_DESCRIPTOR_VERSION} and {FORMAT_VERSION}"
                ),
            ));
        }
        let mut at = 12usize;
        let mut part = |what: &str| -> Result<Vec<u8>, TrainError> {
            let len_end = at
                .checked_add(8)
                .filter(|&e| e <= bytes.len())
                .ok_or_else(|| ck_err(path, format!("truncated before the {what} length")))?;
            let len = u64::from_le_bytes(bytes[at..len_end].try_into().unwrap_or_default());
            let end = usize::try_from(len)
                .ok()
                .and_then(|l| len_end.checked_add(l))
                .filter(|&e| e <= bytes.len())
                .ok_or_else(|| {
                    ck_err(
                        path,
                        format!("{what} of {len} bytes at offset {len_end} runs past the end"),
                    )
                })?;
            at = end;
            Ok(bytes[len_end..end].to_vec())
        };
        let json = part("header")?;
        let weights = part("weights")?;
        let optimizer = part("optimiser state")?;
        if at != bytes.len() {
            return Err(ck_err(path, format!("{} trailing bytes", bytes.len() - at)));
        }
        let mut header: CheckpointHeader =
            serde_json::from_slice(&json).map_err(|e| ck_err(path, format!("header: {e}")))?;
        if version == OPENCV_DESCRIPTOR_VERSION {
            header.config.front_end.descriptor.method = features::DescriptorMethod::Opencv;
            header.config.front_end.lsd.implementation = features::LsdImplementation::Opencv;
        }
        // The device recorded is where the network trained, not where it is read: a
        // checkpoint from a GPU (or LibTorch) build loads in any build.
        TrainConfig {
            device: Device::Cpu,
            ..header.config.clone()
        }
        .validate()
        .map_err(|e| ck_err(path, format!("configuration: {e}")))?;
        if header.has_optimizer == optimizer.is_empty() {
            return Err(ck_err(path, "header and optimiser state disagree"));
        }
        if fnv1a(&weights) != header.weights_hash || fnv1a(&optimizer) != header.optimizer_hash {
            return Err(ck_err(path, "checksum mismatch: the file is damaged"));
        }
        Ok(CheckpointFile {
            path: path.to_path_buf(),
            header,
            weights,
            optimizer,
        })
    }

    pub fn weights(&self) -> &[u8] {
        &self.weights
    }

    /// The network with this checkpoint's weights on `device`.
    pub fn model<B: Pl2MapBackend>(&self, device: &B::Device) -> Result<Pl2Map<B>, TrainError> {
        let fresh = self.header.config.model.init::<B>(0, device)?;
        let record = Recorder::<B>::load(&Rec::default(), self.weights.clone(), device)
            .map_err(|e| ck_err(&self.path, format!("weights: {e}")))?;
        Ok(fresh.load_record(record))
    }

    /// Adam with this checkpoint's state (None for a weights-only file).
    pub fn optimizer<B: AutodiffBackend<InnerBackend: Pl2MapBackend> + Pl2MapBackend>(
        &self,
        device: &B::Device,
    ) -> Result<Option<Pl2MapOptimizer<B>>, TrainError> {
        if !self.header.has_optimizer {
            return Ok(None);
        }
        let record: OrderedById<_> =
            Recorder::<B>::load(&Rec::default(), self.optimizer.clone(), device)
                .map_err(|e| ck_err(&self.path, format!("optimiser state: {e}")))?;
        Ok(Some(
            crate::step::new_optimizer::<B>().load_record(record.0.into_iter().collect()),
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use model::CpuAutodiffBackend as AD;

    fn tiny() -> TrainConfig {
        let mut c = TrainConfig::default();
        c.model.head_hidden = vec![16];
        c.model.ffn_dim = 32;
        c.model.layers.truncate(2);
        c
    }

    /// A header before `save` fills the hashes.
    fn header(config: TrainConfig, iteration: u64) -> CheckpointHeader {
        CheckpointHeader {
            tool_version: "test".into(),
            config,
            iteration,
            has_optimizer: false,
            scene_centre: [0.0; 3],
            weights_hash: String::new(),
            optimizer_hash: String::new(),
        }
    }

    #[test]
    fn round_trip_is_bit_exact_and_corruption_is_an_error() {
        let dir = tempfile::tempdir().unwrap();
        let cfg = tiny();
        let net = cfg.model.init::<AD>(3, &Default::default()).unwrap();
        let path = dir.path().join("a.ckpt");
        let header = header(cfg.clone(), 42);
        save(&path, &header, &net, None).unwrap();
        let back = CheckpointFile::read(&path).unwrap();
        assert_eq!(back.header.iteration, 42);
        assert!(back.optimizer::<AD>(&Default::default()).unwrap().is_none());
        let loaded = back.model::<AD>(&Default::default()).unwrap();
        assert_eq!(parameter_bytes(&loaded), parameter_bytes(&net));
        assert_eq!(parameter_bytes(&net).len(), 4 * net.num_params());

        let bytes = std::fs::read(&path).unwrap();
        for (cut, want) in [
            (5, "magic"),
            (30, "runs past"),
            (bytes.len() - 3, "truncated"),
        ] {
            std::fs::write(&path, &bytes[..cut]).unwrap();
            let e = CheckpointFile::read(&path).err().unwrap().to_string();
            assert!(e.contains(want) && e.contains("a.ckpt"), "{e}");
        }
        let mut bad = bytes.clone();
        let n = bad.len();
        bad[n / 2] ^= 0xff;
        bad[n / 2 + 1] ^= 0xff;
        std::fs::write(&path, &bad).unwrap();
        let e = CheckpointFile::read(&path).err().unwrap().to_string();
        assert!(e.contains("checksum"), "{e}");
    }

    /// A format-1 file (written before `descriptor.method` existed, its JSON without the
    /// key) was trained on OpenCV's descriptors and is read as such; format 2 records the
    /// method; other versions are refused by number.
    #[test]
    fn format_1_checkpoints_keep_opencv_descriptors_and_lsd() {
        let dir = tempfile::tempdir().unwrap();
        let cfg = tiny();
        assert_eq!(
            cfg.front_end.descriptor.method,
            features::DescriptorMethod::Dense
        );
        let net = cfg.model.init::<AD>(3, &Default::default()).unwrap();
        let path = dir.path().join("old.ckpt");
        let header = header(cfg, 1);
        save(&path, &header, &net, None).unwrap();
        let new = CheckpointFile::read(&path).unwrap();
        assert_eq!(
            new.header.config.front_end.descriptor.method,
            features::DescriptorMethod::Dense
        );
        // Rewrite it as format 1 wrote it: version 1, no `method` key in the header.
        let bytes = std::fs::read(&path).unwrap();
        let json_len = u64::from_le_bytes(bytes[12..20].try_into().unwrap()) as usize;
        let json = std::str::from_utf8(&bytes[20..20 + json_len]).unwrap();
        assert!(json.contains(r#""method":"dense","#));
        assert!(json.contains(r#""implementation":"pytlsd","#));
        let old_json = json
            .replace(r#""method":"dense","#, "")
            .replace(r#""implementation":"pytlsd","#, "");
        let mut old = Vec::new();
        old.extend_from_slice(MAGIC);
        old.extend_from_slice(&1u32.to_le_bytes());
        old.extend_from_slice(&(old_json.len() as u64).to_le_bytes());
        old.extend_from_slice(old_json.as_bytes());
        old.extend_from_slice(&bytes[20 + json_len..]);
        std::fs::write(&path, &old).unwrap();
        let back = CheckpointFile::read(&path).unwrap();
        assert_eq!(
            back.header.config.front_end.descriptor.method,
            features::DescriptorMethod::Opencv
        );
        assert_eq!(
            back.header.config.front_end.lsd.implementation,
            features::LsdImplementation::Opencv
        );
        old[8..12].copy_from_slice(&7u32.to_le_bytes());
        std::fs::write(&path, &old).unwrap();
        let e = CheckpointFile::read(&path).err().unwrap().to_string();
        assert!(e.contains("format version 7"), "{e}");
    }
}
