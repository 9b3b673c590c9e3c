//! The front-end factory: a [`FrontEndConfig`] -> the front-end of its kind, SIFT + LSD
//! (`features`) or SuperPoint (`superpoint`).
//!
//! A crate of its own because it names both kinds: `features` must not depend on burn
//! (ARCHITECTURE.md, "... a front-end"), and the SuperPoint crate should not be where a
//! SIFT front-end is built. The stages and the predictor call [`build`] (or [`build_on`]
//! with a GPU); a caller that needs one kind only builds it directly
//! (`features::SiftFrontEnd::new`, `superpoint::SuperPointFrontEnd::from_config`).

#![forbid(unsafe_code)]

use features::{FrontEnd, FrontEndConfig, FrontEndKind, SiftFrontEnd};
use std::sync::Arc;
use superpoint::{SuperPointError, SuperPointFrontEnd};

/// Builds the front-end `config` describes. SuperPoint reads its weights from
/// `superpoint.weights` (else `PL2MAP_SUPERPOINT_WEIGHTS`); when the configuration
/// records a weights hash (a checkpoint's does), the file must have that hash. The
/// returned front-end's configuration records the file's hash.
pub fn build(config: &FrontEndConfig) -> Result<Arc<dyn FrontEnd>, SuperPointError> {
    build_on(config, None)
}

/// [`build`] with SuperPoint's network on CUDA GPU `gpu` (None: the CPU; a GPU needs
/// the `superpoint/cuda` feature, which `train`'s `cuda` feature turns on). SIFT and
/// LSD run on the CPU either way.
pub fn build_on(
    config: &FrontEndConfig,
    gpu: Option<usize>,
) -> Result<Arc<dyn FrontEnd>, SuperPointError> {
    config.validate()?;
    match config.kind {
        FrontEndKind::Sift => Ok(Arc::new(SiftFrontEnd::new(config.clone())?)),
        FrontEndKind::Superpoint => Ok(Arc::new(SuperPointFrontEnd::from_config_on(config, gpu)?)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn builds_sift_from_its_configuration() {
        let config = FrontEndConfig::query();
        let fe = build(&config).unwrap();
        assert_eq!(fe.kind(), FrontEndKind::Sift);
        assert_eq!(fe.config(), &config);
        assert_eq!(fe.dim(), features::SIFT_DIM);
    }

    #[test]
    fn refuses_an_invalid_configuration_of_either_kind() {
        for kind in [FrontEndKind::Sift, FrontEndKind::Superpoint] {
            let config = FrontEndConfig {
                kind,
                samples_per_line: 1,
                ..FrontEndConfig::default()
            };
            let e = build(&config).err().unwrap().to_string();
            assert!(e.contains("samples_per_line must be >= 2"), "{kind}: {e}");
        }
    }

    #[test]
    fn superpoint_without_weights_says_where_to_name_them() {
        if std::env::var_os(features::SUPERPOINT_WEIGHTS_ENV).is_some() {
            return;
        }
        let config = FrontEndConfig {
            kind: FrontEndKind::Superpoint,
            ..FrontEndConfig::default()
        };
        let e = build(&config).err().unwrap().to_string();
        assert!(
            e.contains("superpoint_weights") && e.contains("--weights"),
            "{e}"
        );
    }

    #[test]
    fn superpoint_names_a_missing_weights_file() {
        let config = FrontEndConfig {
            kind: FrontEndKind::Superpoint,
            superpoint: features::SuperPointConfig {
                weights: Some("/nonexistent/pl2map-frontends/sp.pth".into()),
                weights_sha256: Some("0".repeat(64)),
                ..Default::default()
            },
            ..FrontEndConfig::default()
        };
        let e = build_on(&config, None).err().unwrap().to_string();
        assert!(e.contains("/nonexistent/pl2map-frontends/sp.pth"), "{e}");
    }
}
