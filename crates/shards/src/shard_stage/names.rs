//! The stage's name and the names of the files it writes, which the stage (`mod.rs`)
//! and its work units (`units.rs`) both use.

pub const STAGE: &str = "shard";
pub const MANIFEST_FILE: &str = "manifest.json";
pub const TRAIN_PREFIX: &str = "train-";
pub const TEST_PREFIX: &str = "test-";
