//! Which front-end runs, and the descriptor width of each kind. Its own file because
//! both the configuration (`config.rs`, the `kind` field) and the front-ends
//! (`frontend.rs`, [`crate::FrontEnd::kind`]) name it, and neither needs the other for it.

use crate::SIFT_DIM;
use serde::{Deserialize, Serialize};

/// SuperPoint's descriptor width.
pub const SUPERPOINT_DIM: usize = 256;

/// Which detector and descriptor a front-end runs.
#[derive(
    Clone,
    Copy,
    Debug,
    Default,
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
    parse_err_fn = unknown_kind
)]
pub enum FrontEndKind {
    /// OpenCV SIFT keypoints, upright fixed-scale SIFT descriptors (D = 128), LSD lines.
    #[default]
    Sift,
    /// SuperPoint keypoints and bilinearly sampled dense descriptors (D = 256), LSD lines
    /// (docs/method.md section 2b).
    Superpoint,
}

impl FrontEndKind {
    pub fn name(self) -> &'static str {
        self.into()
    }

    /// The descriptor width of this kind.
    pub fn dim(self) -> usize {
        match self {
            FrontEndKind::Sift => SIFT_DIM,
            FrontEndKind::Superpoint => SUPERPOINT_DIM,
        }
    }

    pub fn is_sift(&self) -> bool {
        *self == FrontEndKind::Sift
    }
}

/// The parse error, naming the accepted kinds.
fn unknown_kind(s: &str) -> String {
    use strum::VariantNames;
    format!(
        "expected {}, got {s:?}",
        FrontEndKind::VARIANTS.join(" or ")
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde::de::IntoDeserializer;
    use serde::de::value::{Error as ValueError, StrDeserializer};

    #[test]
    fn serde_and_strum_names_agree() {
        for kind in [FrontEndKind::Sift, FrontEndKind::Superpoint] {
            let name = kind.to_string();
            let de: StrDeserializer<'_, ValueError> = name.as_str().into_deserializer();
            assert_eq!(FrontEndKind::deserialize(de), Ok(kind));
            assert_eq!(kind.name(), name);
            assert_eq!(name.parse::<FrontEndKind>(), Ok(kind));
        }
        assert_eq!(
            "SIFT".parse::<FrontEndKind>(),
            Err("expected sift or superpoint, got \"SIFT\"".to_string())
        );
    }
}
