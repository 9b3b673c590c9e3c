//! Where the CUDA engine (CubeCL) keeps the kernels it compiles and its autotune results,
//! so that a second run on a machine compiles nothing.
//!
//! CubeCL compiles every kernel with nvrtc at run time (the first GPU run compiled about
//! 1,930; docs/performance.md, "The CUDA backend on a GPU"). Left alone it keeps no
//! compiled kernel between runs, and it writes its autotune results into a `target/`
//! folder next to the nearest `Cargo.toml` above the working directory: a user's project
//! folder, or `/target`. This module points both at one folder of the user's cache:
//!
//! 1. `PL2MAP_KERNEL_CACHE` when set (an empty value counts as unset);
//! 2. otherwise `$XDG_CACHE_HOME/pl2map-rs/cubecl`;
//! 3. otherwise `$HOME/.cache/pl2map-rs/cubecl`.
//!
//! A `cubecl.toml` (or a `[cubecl]` section of `burn.toml`) that names a cache of its own
//! keeps it: CubeCL's own configuration file wins over these defaults. The folder holds
//! PTX per kernel (keyed by CubeCL's stable kernel hash, so a driver or CubeCL upgrade
//! writes new entries beside old ones) and the autotune choices per GPU; deleting it
//! costs one slow first step, nothing else.

use std::path::PathBuf;

/// The environment variable that overrides the cache folder.
pub const ENV_KERNEL_CACHE: &str = "PL2MAP_KERNEL_CACHE";

/// The folder under the user's cache where the kernels go by default.
const SUBFOLDER: &str = "pl2map-rs/cubecl";

/// The cache folder from the environment (see the module's list), or None when neither
/// `PL2MAP_KERNEL_CACHE`, `XDG_CACHE_HOME` nor `HOME` is set.
pub fn cache_dir() -> Option<PathBuf> {
    cache_dir_from(|var| std::env::var_os(var))
}

/// [`cache_dir`] over any environment (tests pass a map).
fn cache_dir_from(env: impl Fn(&str) -> Option<std::ffi::OsString>) -> Option<PathBuf> {
    let set = |var: &str| env(var).filter(|v| !v.is_empty()).map(PathBuf::from);
    if let Some(dir) = set(ENV_KERNEL_CACHE) {
        return Some(dir);
    }
    if let Some(xdg) = set("XDG_CACHE_HOME") {
        return Some(xdg.join(SUBFOLDER));
    }
    set("HOME").map(|home| home.join(".cache").join(SUBFOLDER))
}

/// What [`configure`] did, for the run's log line.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum CacheSetting {
    /// Compiled kernels and autotune results go to this folder.
    Folder(PathBuf),
    /// CubeCL's configuration was already read (a GPU operation ran before the first
    /// device check) or a configuration file names its own cache: left as it is.
    LeftToCubeCl(String),
    /// No folder could be named (no `HOME`): CubeCL's defaults apply.
    NoFolder,
}

impl std::fmt::Display for CacheSetting {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            CacheSetting::Folder(dir) => write!(f, "CUDA kernel cache: {}", dir.display()),
            CacheSetting::LeftToCubeCl(why) => write!(f, "CUDA kernel cache: {why}"),
            CacheSetting::NoFolder => write!(
                f,
                "CUDA kernel cache: none (set {ENV_KERNEL_CACHE} or HOME to keep compiled kernels between runs)"
            ),
        }
    }
}

/// Points CubeCL's compilation cache and autotune cache at [`cache_dir`], once per
/// process, before the CUDA engine first reads its configuration. Later calls return
/// the first call's answer; the first prints it (one line on stderr). Called by
/// `Device::check_usable` for `cuda[:N]` (every run checks its device before it touches
/// the GPU) and by `Device::cuda`.
#[cfg(feature = "cuda")]
pub fn configure() -> CacheSetting {
    static DONE: std::sync::OnceLock<CacheSetting> = std::sync::OnceLock::new();
    DONE.get_or_init(|| {
        let setting = apply(cache_dir());
        eprintln!("{setting}");
        setting
    })
    .clone()
}

#[cfg(feature = "cuda")]
fn apply(dir: Option<PathBuf>) -> CacheSetting {
    use cubecl_runtime::config::{CubeClRuntimeConfig, RuntimeConfig, cache::CacheConfig};
    let Some(dir) = dir else {
        return CacheSetting::NoFolder;
    };
    // `RuntimeConfig::set` panics once the configuration has been read; look first.
    if CubeClRuntimeConfig::storage().lock().is_some() {
        return CacheSetting::LeftToCubeCl(
            "CubeCL's configuration was read before pl2map could set its cache folder; its own settings apply".into(),
        );
    }
    // The user's cubecl.toml / burn.toml and CubeCL's environment variables first.
    let mut config = CubeClRuntimeConfig::from_current_dir().override_from_env();
    if config.compilation.cache.is_some() {
        return CacheSetting::LeftToCubeCl("as CubeCL's configuration file says".into());
    }
    if let Err(e) = std::fs::create_dir_all(&dir) {
        return CacheSetting::LeftToCubeCl(format!(
            "cannot create {}: {e}; kernels are compiled afresh in every run",
            dir.display()
        ));
    }
    config.compilation.cache = Some(CacheConfig::File(dir.clone()));
    // CubeCL's default (`Target`) writes beside the nearest Cargo.toml; a file the user
    // chose (`Local`, `Global`, `File`) is kept.
    if matches!(config.autotune.cache, CacheConfig::Target) {
        config.autotune.cache = CacheConfig::File(dir.clone());
    }
    CubeClRuntimeConfig::set(config);
    CacheSetting::Folder(dir)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashMap;
    use std::ffi::OsString;

    fn env(pairs: &[(&str, &str)]) -> impl Fn(&str) -> Option<OsString> {
        let map: HashMap<String, OsString> = pairs
            .iter()
            .map(|(k, v)| (k.to_string(), OsString::from(v)))
            .collect();
        move |k| map.get(k).cloned()
    }

    #[test]
    fn the_override_then_xdg_then_home() {
        let all = [
            (ENV_KERNEL_CACHE, "/k"),
            ("XDG_CACHE_HOME", "/x"),
            ("HOME", "/h"),
        ];
        assert_eq!(cache_dir_from(env(&all)), Some(PathBuf::from("/k")));
        assert_eq!(
            cache_dir_from(env(&all[1..])),
            Some(PathBuf::from("/x/pl2map-rs/cubecl"))
        );
        assert_eq!(
            cache_dir_from(env(&all[2..])),
            Some(PathBuf::from("/h/.cache/pl2map-rs/cubecl"))
        );
        assert_eq!(cache_dir_from(env(&[])), None);
    }

    #[test]
    fn empty_values_count_as_unset() {
        let e = env(&[
            (ENV_KERNEL_CACHE, ""),
            ("XDG_CACHE_HOME", ""),
            ("HOME", "/h"),
        ]);
        assert_eq!(
            cache_dir_from(e),
            Some(PathBuf::from("/h/.cache/pl2map-rs/cubecl"))
        );
    }

    /// With the CUDA engine built (no GPU needed): the process's CubeCL configuration
    /// names the folder for both caches afterwards, and a second call changes nothing.
    #[cfg(feature = "cuda")]
    #[test]
    fn cubecl_keeps_its_kernels_in_the_folder() {
        use cubecl_runtime::config::{CubeClRuntimeConfig, RuntimeConfig, cache::CacheConfig};
        let dir = std::env::temp_dir().join(format!("pl2map-kernel-cache-{}", std::process::id()));
        let setting = apply(Some(dir.clone()));
        assert_eq!(setting, CacheSetting::Folder(dir.clone()));
        assert!(dir.is_dir());
        let config = CubeClRuntimeConfig::get();
        match (&config.compilation.cache, &config.autotune.cache) {
            (Some(CacheConfig::File(c)), CacheConfig::File(a)) => {
                assert_eq!((c, a), (&dir, &dir));
            }
            other => panic!("caches not set: {other:?}"),
        }
        // Read once: a second attempt leaves it and says so instead of panicking.
        assert!(matches!(
            apply(Some(dir.clone())),
            CacheSetting::LeftToCubeCl(_)
        ));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
