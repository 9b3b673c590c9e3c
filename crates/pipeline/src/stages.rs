//! The stages of a pipeline, in run order: a typed list, so `--until`, the stage folders
//! and the run table all come from one place.

use serde::{Deserialize, Serialize};

/// One stage of a pipeline.
#[derive(
    Clone,
    Copy,
    Debug,
    PartialEq,
    Eq,
    PartialOrd,
    Ord,
    Hash,
    Serialize,
    Deserialize,
    clap::ValueEnum,
)]
#[serde(rename_all = "lowercase")]
pub enum StageName {
    /// Render the built-in synthetic scene (pipelines with `[synth]`).
    Synth,
    /// Read the dataset into the frames table.
    Ingest,
    /// Join the COLMAP model and LIMAP tracks to the frames: the label tables.
    Import,
    /// Move the labels onto the depth maps (pipelines with `[refine]`).
    Refine,
    /// Write the MCAP shards and their manifest.
    Shard,
    /// Train the network (pipelines with `[train]`).
    Train,
    /// Localise the test frames and score the poses (pipelines with `[score]`).
    Score,
}

impl StageName {
    /// Every stage, in run order.
    pub const ALL: [StageName; 7] = [
        StageName::Synth,
        StageName::Ingest,
        StageName::Import,
        StageName::Refine,
        StageName::Shard,
        StageName::Train,
        StageName::Score,
    ];

    /// The stage's name, which is also its folder under the work folder.
    pub fn as_str(self) -> &'static str {
        match self {
            StageName::Synth => "synth",
            StageName::Ingest => "ingest",
            StageName::Import => "import",
            StageName::Refine => "refine",
            StageName::Shard => "shard",
            StageName::Train => "train",
            StageName::Score => "score",
        }
    }

    /// `<work>/<dir>`.
    pub fn dir(self) -> &'static str {
        self.as_str()
    }

    /// Whether a label variant of the pipeline (`--compare-refine`) keeps its own copy
    /// of the stage (the data stages before it are shared).
    pub fn per_branch(self) -> bool {
        self >= StageName::Shard
    }
}

impl std::fmt::Display for StageName {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        // `pad`, so table widths (`{:<8}`) apply.
        f.pad(self.as_str())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn order_and_names() {
        let names: Vec<&str> = StageName::ALL.iter().map(|s| s.as_str()).collect();
        assert_eq!(
            names,
            [
                "synth", "ingest", "import", "refine", "shard", "train", "score"
            ]
        );
        assert!(StageName::ALL.windows(2).all(|w| w[0] < w[1]));
        let branch: Vec<_> = StageName::ALL.iter().filter(|s| s.per_branch()).collect();
        assert_eq!(
            branch,
            [&StageName::Shard, &StageName::Train, &StageName::Score]
        );
        use clap::ValueEnum;
        assert_eq!(StageName::from_str("shard", false), Ok(StageName::Shard));
    }
}
