//! The one parquet helper of the workspace (polars): atomic, deterministic writing with
//! key-value metadata, and column accessors that turn a missing column, a wrong type or
//! a null into an error naming the file, the column and the row.

use fileio::IoResultExt;
/// The polars this helper is built with, for crates that build their own tables (one
/// polars in the workspace).
pub use polars;
use polars::prelude::*;
use std::collections::BTreeMap;
use std::io::Write;
use std::path::{Path, PathBuf};
use thiserror::Error;

#[derive(Debug, Error)]
pub enum TableError {
    #[error(transparent)]
    Io(#[from] fileio::IoError),
    #[error("{path}: parquet: {source}")]
    Polars {
        path: PathBuf,
        #[source]
        source: PolarsError,
    },
    #[error("{path}: {message}")]
    Invalid { path: PathBuf, message: String },
    #[error("{path}: row {row} ({column}): {message}")]
    Row {
        path: PathBuf,
        row: usize,
        column: String,
        message: String,
    },
    #[error(
        "the label tables were made from frames table {labels} but {} is {current}: run the \
         import again",
        frames.display()
    )]
    OtherFrames {
        frames: PathBuf,
        labels: String,
        current: String,
    },
    #[error(transparent)]
    Stage(#[from] stage::StageError),
}

/// Writes `df` to `path` through a temp file and a rename. Zstd pages; polars writes no
/// time stamp, so the same frame gives the same bytes. The key-value metadata is written
/// in the order given (it is part of the bytes).
pub fn write_parquet(
    path: &Path,
    df: &mut DataFrame,
    metadata: Vec<(String, String)>,
) -> Result<(), TableError> {
    let kv = KeyValueMetadata::from_static(metadata);
    let mut out = stage::AtomicFile::create(path)?;
    ParquetWriter::new(out.file())
        .with_compression(ParquetCompression::Zstd(None))
        .with_key_value_metadata(Some(kv))
        .finish(df)
        .map_err(|source| TableError::Polars {
            path: path.to_path_buf(),
            source,
        })?;
    out.flush().at(path)?;
    out.commit()?;
    Ok(())
}

/// Reads a parquet file and its key-value metadata.
pub fn read_parquet(path: &Path) -> Result<(DataFrame, BTreeMap<String, String>), TableError> {
    let file = std::fs::File::open(path).at(path)?;
    let polars_err = |source| TableError::Polars {
        path: path.to_path_buf(),
        source,
    };
    let mut reader = ParquetReader::new(file);
    let kv = reader
        .get_metadata()
        .map_err(polars_err)?
        .key_value_metadata()
        .clone()
        .unwrap_or_default();
    let meta = kv
        .into_iter()
        .filter_map(|e| e.value.map(|v| (e.key, v)))
        .collect();
    let df = reader.finish().map_err(polars_err)?;
    Ok((df, meta))
}

/// A list[f64] column from per-row slices (typed even when empty).
pub fn f64_list_column(name: &str, rows: impl Iterator<Item = Vec<f64>>) -> Column {
    let series: Vec<Option<Series>> = rows
        .map(|v| Some(Series::new(PlSmallStr::EMPTY, v)))
        .collect();
    if series.is_empty() {
        return Column::new_empty(name.into(), &DataType::List(Box::new(DataType::Float64)));
    }
    let ca: ListChunked = series.into_iter().collect();
    ca.into_series().with_name(name.into()).into_column()
}

/// Typed, checked access to the columns of a table read from `path`.
pub struct Cols<'a> {
    pub df: &'a DataFrame,
    pub path: &'a Path,
}

impl<'a> Cols<'a> {
    fn col(&self, name: &str) -> Result<&'a Column, TableError> {
        self.df.column(name).map_err(|_| TableError::Invalid {
            path: self.path.to_path_buf(),
            message: format!("missing column {name}"),
        })
    }

    fn wrong_type(&self, name: &str, e: PolarsError) -> TableError {
        TableError::Invalid {
            path: self.path.to_path_buf(),
            message: format!("column {name}: {e}"),
        }
    }

    pub fn row_error(&self, row: usize, column: &str, message: impl Into<String>) -> TableError {
        TableError::Row {
            path: self.path.to_path_buf(),
            row,
            column: column.to_string(),
            message: message.into(),
        }
    }

    fn required<T>(&self, name: &str, values: Vec<Option<T>>) -> Result<Vec<T>, TableError> {
        values
            .into_iter()
            .enumerate()
            .map(|(row, v)| v.ok_or_else(|| self.row_error(row, name, "null value")))
            .collect()
    }

    pub fn u32s(&self, name: &str) -> Result<Vec<u32>, TableError> {
        let ca = self
            .col(name)?
            .u32()
            .map_err(|e| self.wrong_type(name, e))?;
        self.required(name, ca.iter().collect())
    }

    pub fn i64s(&self, name: &str) -> Result<Vec<i64>, TableError> {
        let ca = self
            .col(name)?
            .i64()
            .map_err(|e| self.wrong_type(name, e))?;
        self.required(name, ca.iter().collect())
    }

    pub fn f64s(&self, name: &str) -> Result<Vec<f64>, TableError> {
        let ca = self
            .col(name)?
            .f64()
            .map_err(|e| self.wrong_type(name, e))?;
        self.required(name, ca.iter().collect())
    }

    pub fn opt_f64s(&self, name: &str) -> Result<Vec<Option<f64>>, TableError> {
        let ca = self
            .col(name)?
            .f64()
            .map_err(|e| self.wrong_type(name, e))?;
        Ok(ca.iter().collect())
    }

    pub fn bools(&self, name: &str) -> Result<Vec<bool>, TableError> {
        let ca = self
            .col(name)?
            .bool()
            .map_err(|e| self.wrong_type(name, e))?;
        self.required(name, ca.iter().collect())
    }

    /// A nullable string column.
    pub fn opt_strs(&self, name: &str) -> Result<Vec<Option<String>>, TableError> {
        let ca = self
            .col(name)?
            .str()
            .map_err(|e| self.wrong_type(name, e))?;
        Ok(ca.iter().map(|v| v.map(str::to_string)).collect())
    }

    pub fn strs(&self, name: &str) -> Result<Vec<String>, TableError> {
        let ca = self
            .col(name)?
            .str()
            .map_err(|e| self.wrong_type(name, e))?;
        self.required(name, ca.iter().map(|v| v.map(str::to_string)).collect())
    }

    pub fn f64_lists(&self, name: &str) -> Result<Vec<Vec<f64>>, TableError> {
        let ca = self
            .col(name)?
            .list()
            .map_err(|e| self.wrong_type(name, e))?;
        let mut out = Vec::with_capacity(ca.len());
        for (row, s) in ca.amortized_iter().enumerate() {
            let s = s.ok_or_else(|| self.row_error(row, name, "null value"))?;
            let values = s.as_ref().f64().map_err(|e| self.wrong_type(name, e))?;
            let v: Option<Vec<f64>> = values.iter().collect();
            out.push(v.ok_or_else(|| self.row_error(row, name, "null value in the list"))?);
        }
        Ok(out)
    }
}
