//! Which dataset layout a folder is in: the name `[ingest] dataset` says and the
//! descriptors' `[layouts.<name>]` sections use. Its own file, below both the ingest
//! stage and the descriptors (crates/datasets/src/descriptor.rs), which both name it.

use serde::{Deserialize, Serialize};

/// Which dataset layout to read.
#[derive(
    Clone,
    Copy,
    Debug,
    PartialEq,
    Eq,
    Hash,
    Serialize,
    Deserialize,
    strum::Display,
    strum::EnumString,
    strum::IntoStaticStr,
    strum::VariantNames,
)]
#[serde(rename_all = "lowercase")]
#[strum(
    serialize_all = "lowercase",
    parse_err_ty = String,
    parse_err_fn = unknown_dataset
)]
pub enum DatasetKind {
    // No case rule spells a leading digit: named by hand, on both sides.
    #[serde(rename = "7scenes")]
    #[strum(serialize = "7scenes")]
    SevenScenes,
    Cambridge,
}

impl DatasetKind {
    pub fn name(self) -> &'static str {
        self.into()
    }
}

/// The parse error, naming the accepted names.
fn unknown_dataset(s: &str) -> String {
    use strum::VariantNames;
    format!(
        "unknown dataset {s:?} (expected {})",
        DatasetKind::VARIANTS.join(" or ")
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn serde_and_strum_names_agree() {
        for kind in [DatasetKind::SevenScenes, DatasetKind::Cambridge] {
            let json = serde_json::to_string(&kind).unwrap();
            assert_eq!(json, format!("\"{kind}\""));
            assert_eq!(kind.name(), kind.to_string());
            assert_eq!(kind.to_string().parse::<DatasetKind>(), Ok(kind));
        }
        assert_eq!(
            "7Scenes".parse::<DatasetKind>(),
            Err("unknown dataset \"7Scenes\" (expected 7scenes or cambridge)".to_string())
        );
    }
}
