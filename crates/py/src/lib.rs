//! The Python package `pl2map-shards` (import name `pl2map_shards`; docs/formats.md
//! section 6): this crate is its extension module `pl2map_shards._native`, the Python
//! files beside it (`python/pl2map_shards/`) hold the thin layer on top (the PyTorch
//! dataset). Reading and decoding are the `shards` crate's, the same code the Rust
//! trainer runs; the epoch order of every rank and DataLoader worker is [`order`].
//!
//! Built by maturin (`pip install ./crates/py`, pyproject.toml). `cargo build` and the
//! crate's tests build it as an ordinary library linked to libpython; maturin sets
//! `PYO3_BUILD_EXTENSION_MODULE` and the `extension-module` feature for the wheel.

mod convert;
pub mod order;
pub mod split_set;

use numpy::PyArray1;
use pyo3::create_exception;
use pyo3::exceptions::{PyException, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use split_set::{OpenOptions, ReadError, SplitSet};
use std::path::PathBuf;
use std::sync::Mutex;

create_exception!(
    pl2map_shards,
    ShardError,
    PyException,
    "A shard folder, manifest or shard that cannot be read. `shard` is the shard file \
     (None when the error is not about one) and `frame_id` the frame being read (or None)."
);

/// The Python exception for `e`, with its `shard` and `frame_id` attributes.
fn to_py(py: Python<'_>, e: ReadError) -> PyErr {
    let err = ShardError::new_err(e.message);
    let value = err.value(py);
    let shard = e.shard.map(|p| p.display().to_string());
    // Setting attributes on a fresh exception instance only fails without memory; the
    // message alone still names the shard and the frame then.
    let _ = value.setattr("shard", shard);
    let _ = value.setattr("frame_id", e.frame_id);
    err
}

/// The folder of `source`: a path as is; an s3:// or https:// URL fetched into the
/// shard cache and verified there (`remote::materialize`, settings from the
/// environment: `PL2MAP_SHARD_CACHE`, `PL2MAP_SHARD_CACHE_MAX_GB`, `AWS_*`).
fn local_folder(source: &str) -> Result<PathBuf, ReadError> {
    if !remote::is_remote(source) {
        return Ok(PathBuf::from(source));
    }
    remote::CacheOptions::from_env()
        .and_then(|opts| remote::materialize(source, &opts))
        .map_err(|e| ReadError {
            message: e.to_string(),
            shard: None,
            frame_id: None,
        })
}

/// One split of a shard folder (see the package's docs).
#[pyclass(name = "ShardSet", module = "pl2map_shards")]
struct PyShardSet {
    set: Mutex<SplitSet>,
    len: usize,
    folder: PathBuf,
    split: &'static str,
    manifest_json: String,
    frame_ids: Vec<u64>,
}

impl PyShardSet {
    fn read_with(
        &self,
        py: Python<'_>,
        read: impl FnOnce(&mut SplitSet) -> Result<shards::FrameRecord, ReadError> + Send,
        decode_image: bool,
    ) -> PyResult<Py<PyDict>> {
        let (record, pixels) = py
            .detach(|| {
                let mut set = self.set.lock().map_err(|_| ReadError {
                    message: "the reader was poisoned by a panic in another thread".into(),
                    shard: None,
                    frame_id: None,
                })?;
                let record = read(&mut set)?;
                let shard = set.shard_of(record.frame_id).map(PathBuf::from);
                drop(set);
                let pixels = if decode_image {
                    Some(
                        convert::decode_image(&record.image_bytes, record.image_format).map_err(
                            |reason| ReadError {
                                message: format!(
                                    "{}: frame {}: cannot decode its {} image: {reason}",
                                    shard.as_deref().unwrap_or(&self.folder).display(),
                                    record.frame_id,
                                    record.image_format.as_str()
                                ),
                                shard,
                                frame_id: Some(record.frame_id),
                            },
                        )?,
                    )
                } else {
                    None
                };
                Ok((record, pixels))
            })
            .map_err(|e| to_py(py, e))?;
        Ok(convert::frame_dict(py, &record, pixels)?.unbind())
    }
}

#[pymethods]
impl PyShardSet {
    /// Opens split `split` ("train" or "test") of the shard folder `source` (a path;
    /// s3:// and https:// URLs are fetched into the local cache first).
    #[new]
    #[pyo3(signature = (source, split = "train", *, verify = true, cache_bytes = 64 << 20))]
    fn new(
        py: Python<'_>,
        source: String,
        split: &str,
        verify: bool,
        cache_bytes: u64,
    ) -> PyResult<Self> {
        let split = split_set::parse_split(split).map_err(|e| to_py(py, e))?;
        let options = OpenOptions {
            verify,
            cache_bytes,
        };
        let set = py
            .detach(|| SplitSet::open(&local_folder(&source)?, split, &options))
            .map_err(|e| to_py(py, e))?;
        let manifest_json = String::from_utf8(set.manifest.to_json())
            .map_err(|e| PyValueError::new_err(e.to_string()))?;
        Ok(PyShardSet {
            len: set.len(),
            folder: set.dir.clone(),
            split: set.split.as_str(),
            manifest_json,
            frame_ids: set.frame_ids().to_vec(),
            set: Mutex::new(set),
        })
    }

    fn __len__(&self) -> usize {
        self.len
    }

    /// The local shard folder.
    #[getter]
    fn folder(&self) -> PathBuf {
        self.folder.clone()
    }

    #[getter]
    fn split(&self) -> &'static str {
        self.split
    }

    /// The folder's manifest.json as a string.
    #[getter]
    fn manifest_json(&self) -> &str {
        &self.manifest_json
    }

    /// Frame ids in reading order (shards in manifest order, frames by id).
    #[getter]
    fn frame_ids<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<u64>> {
        PyArray1::from_slice(py, &self.frame_ids)
    }

    /// The frame at position `index` of the reading order, as a dict.
    #[pyo3(signature = (index, *, decode_image = false))]
    fn read(&self, py: Python<'_>, index: usize, decode_image: bool) -> PyResult<Py<PyDict>> {
        self.read_with(py, move |s| s.read_index(index), decode_image)
    }

    /// The frame with id `frame_id`, as a dict.
    #[pyo3(signature = (frame_id, *, decode_image = false))]
    fn read_id(&self, py: Python<'_>, frame_id: u64, decode_image: bool) -> PyResult<Py<PyDict>> {
        self.read_with(py, move |s| s.read_id(frame_id), decode_image)
    }

    fn __repr__(&self) -> String {
        format!(
            "ShardSet({:?}, split={:?}, frames={})",
            self.folder.display().to_string(),
            self.split,
            self.len
        )
    }
}

/// The epoch's permutation of `range(frames)` (docs/formats.md section 6, "Order").
#[pyfunction]
fn permutation<'py>(
    py: Python<'py>,
    frames: usize,
    seed: u64,
    epoch: u64,
) -> Bound<'py, PyArray1<u64>> {
    let p: Vec<u64> = order::permutation(frames, seed, epoch)
        .into_iter()
        .map(|i| i as u64)
        .collect();
    PyArray1::from_vec(py, p)
}

/// The epoch's global order for `world` ranks: the permutation padded (or, with
/// `drop_last`, cut) to a multiple of `world`.
#[pyfunction]
#[pyo3(signature = (frames, seed, epoch, *, world = 1, drop_last = false, shuffle = true))]
fn global_order<'py>(
    py: Python<'py>,
    frames: usize,
    seed: u64,
    epoch: u64,
    world: usize,
    drop_last: bool,
    shuffle: bool,
) -> PyResult<Bound<'py, PyArray1<u64>>> {
    let plan = order::Plan {
        frames,
        seed,
        epoch,
        world,
        drop_last,
        shuffle,
    };
    plan.check().map_err(PyValueError::new_err)?;
    Ok(PyArray1::from_vec(
        py,
        plan.global_order().into_iter().map(|i| i as u64).collect(),
    ))
}

/// The frame indices one DataLoader worker of one rank yields, in order.
#[pyfunction]
#[pyo3(signature = (frames, seed, epoch, *, world = 1, rank = 0, workers = 1, worker = 0,
                    block = 1, start = 0, drop_last = false, shuffle = true))]
#[allow(clippy::too_many_arguments)] // Python keyword arguments, each documented.
fn epoch_indices<'py>(
    py: Python<'py>,
    frames: usize,
    seed: u64,
    epoch: u64,
    world: usize,
    rank: usize,
    workers: usize,
    worker: usize,
    block: usize,
    start: usize,
    drop_last: bool,
    shuffle: bool,
) -> PyResult<Bound<'py, PyArray1<u64>>> {
    let plan = order::Plan {
        frames,
        seed,
        epoch,
        world,
        drop_last,
        shuffle,
    };
    let place = order::Place {
        rank,
        worker,
        workers,
        block,
        start,
    };
    let idx = plan.indices(&place).map_err(PyValueError::new_err)?;
    Ok(PyArray1::from_vec(
        py,
        idx.into_iter().map(|i| i as u64).collect(),
    ))
}

/// Number of samples in the epoch's global order (see `global_order`).
#[pyfunction]
#[pyo3(signature = (frames, *, world = 1, drop_last = false))]
fn epoch_length(frames: usize, world: usize, drop_last: bool) -> PyResult<usize> {
    let plan = order::Plan {
        frames,
        seed: 0,
        epoch: 0,
        world,
        drop_last,
        shuffle: false,
    };
    plan.check().map_err(PyValueError::new_err)?;
    Ok(plan.total())
}

/// The extension module; `pl2map_shards/__init__.py` re-exports it.
#[pymodule(name = "_native")]
fn native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyShardSet>()?;
    m.add("ShardError", m.py().get_type::<ShardError>())?;
    m.add_function(wrap_pyfunction!(permutation, m)?)?;
    m.add_function(wrap_pyfunction!(global_order, m)?)?;
    m.add_function(wrap_pyfunction!(epoch_indices, m)?)?;
    m.add_function(wrap_pyfunction!(epoch_length, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
