//! The shard manifest: what a run (or a work unit of it) wrote, and from what.
//!
//! Format: JSON (pretty, keys in a fixed order, trailing newline), for three reasons:
//! it is what `stage.json` already uses, so one parser reads every record of a work
//! dir; frame ids and byte sizes are u64, which TOML cannot hold above i64::MAX; and
//! serde_json writes struct fields in declaration order and BTreeMaps sorted, so the
//! same manifest is the same bytes wherever it is written (it is committed under
//! `manifests/` and compared by hash).

use crate::error::ShardError;
use fileio::io_err;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::Path;

/// One shard in a manifest.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct ManifestShard {
    /// Position in the run's plan (shard-<index>.mcap).
    pub index: usize,
    /// File name, relative to the shard folder.
    pub file: String,
    pub first_frame: u64,
    pub last_frame: u64,
    pub frame_count: u64,
    /// sha256 of the file, hex.
    pub sha256: String,
    pub bytes: u64,
}

#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Manifest {
    /// Shard layout version (channels, schema, log time mapping).
    pub format_version: u32,
    /// pl2map version that wrote the shards.
    pub tool_version: String,
    /// Hash of the shard stage's configuration.
    pub config_hash: String,
    /// Input name -> content hash (frames table, label tables ...), from the caller.
    pub inputs: BTreeMap<String, String>,
    /// The label tables' LIMAP track set when not finaltracks (`alltracks`): written
    /// only then, so manifests of the default keep their bytes.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub line_tracks: Option<String>,
    /// Shards in the whole run's plan, and frames in them: a unit's manifest holds a
    /// range of the shards but describes the same run.
    pub planned_shards: usize,
    pub planned_frames: u64,
    /// The shards this manifest covers, by index.
    pub shards: Vec<ManifestShard>,
}

impl Manifest {
    /// Whether every planned shard is listed.
    pub fn is_complete(&self) -> bool {
        self.missing_shards().is_empty()
            && self.shards.iter().map(|s| s.frame_count).sum::<u64>() == self.planned_frames
    }

    /// Indexes of planned shards not in this manifest.
    pub fn missing_shards(&self) -> Vec<usize> {
        let mut have = vec![false; self.planned_shards];
        for s in &self.shards {
            if let Some(h) = have.get_mut(s.index) {
                *h = true;
            }
        }
        (0..self.planned_shards).filter(|&i| !have[i]).collect()
    }

    /// Merges the manifests of work units of one run (same format, tool version,
    /// config, inputs and plan). Shards listed by several units must agree exactly.
    /// The result lists the shards by index, so merging the units of a run gives
    /// the manifest of a single run over all of them.
    pub fn merge<'a>(
        units: impl IntoIterator<Item = &'a Manifest>,
    ) -> Result<Manifest, ShardError> {
        let mut units = units.into_iter();
        let first = units
            .next()
            .ok_or_else(|| ShardError::ManifestMerge("no manifests to merge".into()))?;
        let mut shards: BTreeMap<usize, ManifestShard> = BTreeMap::new();
        let mut add = |m: &Manifest| -> Result<(), ShardError> {
            for s in &m.shards {
                if let Some(prev) = shards.insert(s.index, s.clone())
                    && &prev != s
                {
                    return Err(ShardError::ManifestMerge(format!(
                        "shard {} differs between units ({} sha256 {} vs {} sha256 {})",
                        s.index, prev.file, prev.sha256, s.file, s.sha256
                    )));
                }
            }
            Ok(())
        };
        add(first)?;
        for m in units {
            let differs = |what: &str, a: &dyn std::fmt::Debug, b: &dyn std::fmt::Debug| {
                ShardError::ManifestMerge(format!("{what} differs: {a:?} vs {b:?}"))
            };
            if m.format_version != first.format_version {
                return Err(differs(
                    "format version",
                    &first.format_version,
                    &m.format_version,
                ));
            }
            if m.tool_version != first.tool_version {
                return Err(differs(
                    "tool version",
                    &first.tool_version,
                    &m.tool_version,
                ));
            }
            if m.config_hash != first.config_hash {
                return Err(differs("config hash", &first.config_hash, &m.config_hash));
            }
            if m.inputs != first.inputs {
                return Err(differs("inputs", &first.inputs, &m.inputs));
            }
            if (m.planned_shards, m.planned_frames) != (first.planned_shards, first.planned_frames)
            {
                return Err(differs(
                    "plan (shards, frames)",
                    &(first.planned_shards, first.planned_frames),
                    &(m.planned_shards, m.planned_frames),
                ));
            }
            add(m)?;
        }
        Ok(Manifest {
            shards: shards.into_values().collect(),
            ..first.clone()
        })
    }

    pub fn to_json(&self) -> Vec<u8> {
        // Serialising plain structs, strings and BTreeMaps cannot fail.
        let mut json = serde_json::to_vec_pretty(self).unwrap_or_default();
        json.push(b'\n');
        json
    }

    /// Writes the manifest atomically.
    pub fn save(&self, path: impl AsRef<Path>) -> Result<(), ShardError> {
        stage::write_atomic(path, &self.to_json())?;
        Ok(())
    }

    pub fn load(path: impl AsRef<Path>) -> Result<Manifest, ShardError> {
        let path = path.as_ref();
        let bytes = std::fs::read(path).map_err(io_err(path))?;
        serde_json::from_slice(&bytes).map_err(|source| ShardError::ManifestParse {
            path: path.to_path_buf(),
            source,
        })
    }

    /// Paths of the listed shards under `dir`, in index order (for [`crate::ShardReader`]).
    pub fn shard_paths(&self, dir: &Path) -> Vec<std::path::PathBuf> {
        self.shards.iter().map(|s| dir.join(&s.file)).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn shard(i: usize) -> ManifestShard {
        ManifestShard {
            index: i,
            file: format!("shard-{i:05}.mcap"),
            first_frame: 10 * i as u64,
            last_frame: 10 * i as u64 + 9,
            frame_count: 10,
            sha256: format!("{i:064}"),
            bytes: 1000 + i as u64,
        }
    }

    fn manifest(shards: Vec<ManifestShard>) -> Manifest {
        Manifest {
            format_version: 1,
            tool_version: "0.1.0".into(),
            config_hash: "c".into(),
            inputs: BTreeMap::from([("frames".into(), "f".into())]),
            line_tracks: None,
            planned_shards: 3,
            planned_frames: 30,
            shards,
        }
    }

    #[test]
    fn merge_is_order_independent_and_checks_agreement() {
        let whole = manifest(vec![shard(0), shard(1), shard(2)]);
        let a = manifest(vec![shard(2)]);
        let b = manifest(vec![shard(0), shard(1)]);
        assert_eq!(Manifest::merge([&a, &b]).unwrap(), whole);
        assert_eq!(Manifest::merge([&b, &a, &b]).unwrap(), whole);
        assert!(whole.is_complete() && !a.is_complete());
        assert_eq!(a.missing_shards(), vec![0, 1]);

        let mut other = shard(1);
        other.sha256 = "x".into();
        let err = Manifest::merge([&b, &manifest(vec![other])]).unwrap_err();
        assert!(err.to_string().contains("shard 1 differs"), "{err}");
        let mut c = a.clone();
        c.config_hash = "d".into();
        assert!(
            Manifest::merge([&b, &c])
                .unwrap_err()
                .to_string()
                .contains("config hash")
        );
        assert!(Manifest::merge([]).is_err());
    }

    #[test]
    fn json_round_trip_and_bad_file() {
        let dir = tempfile::tempdir().unwrap();
        let m = manifest(vec![shard(0)]);
        let p = dir.path().join("manifest.json");
        m.save(&p).unwrap();
        assert_eq!(Manifest::load(&p).unwrap(), m);
        assert_eq!(std::fs::read(&p).unwrap(), m.to_json());
        std::fs::write(&p, b"{\"format_version\": 1,").unwrap();
        let err = Manifest::load(&p).unwrap_err().to_string();
        assert!(
            err.contains("manifest.json") && err.contains("line 1"),
            "{err}"
        );
    }
}
