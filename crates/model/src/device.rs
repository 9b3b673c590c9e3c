//! Where the network runs: `cpu` (burn's Flex backend, always built) or `cuda[:N]`
//! (burn's CUDA backend on GPU N, only in builds with the `cuda` cargo feature).
//!
//! The device is a setting of a run, not of a network: a checkpoint holds plain f32
//! weights, so a model trained on one device loads on the other. Results differ between
//! devices in the last bits (other kernels, other summation orders); on the CPU they do
//! not depend on the thread count.

use crate::error::ModelError;
use serde::{Deserialize, Deserializer, Serialize, Serializer};

/// A device the network can run on.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Device {
    #[default]
    Cpu,
    /// The CUDA GPU of this index (as `nvidia-smi` numbers them).
    Cuda(usize),
}

/// Whether this build has the CUDA backend (the `cuda` cargo feature).
pub const CUDA_BUILT: bool = cfg!(feature = "cuda");

/// What to run to get a build with the CUDA backend.
pub const CUDA_BUILD_HINT: &str = "build it with `cargo build --release --locked -p cli --features cuda` \
     (building needs no GPU; running needs the NVIDIA driver and the CUDA toolkit's nvrtc)";

impl Device {
    pub fn is_cpu(&self) -> bool {
        *self == Device::Cpu
    }

    /// The CUDA GPU index, None for the CPU.
    pub fn gpu(&self) -> Option<usize> {
        match self {
            Device::Cpu => None,
            Device::Cuda(i) => Some(*i),
        }
    }

    /// Refuses a device this build cannot use, saying how to get a build that can.
    pub fn check_built(&self) -> Result<(), ModelError> {
        match self {
            Device::Cuda(_) if !CUDA_BUILT => Err(self.not_built()),
            _ => Ok(()),
        }
    }

    /// The error for a device this build has no backend for.
    pub fn not_built(&self) -> ModelError {
        ModelError::DeviceUnavailable(format!(
            "device {self}: this pl2map was built without CUDA; {CUDA_BUILD_HINT}"
        ))
    }

    /// burn's device of the CUDA backend for this index.
    #[cfg(feature = "cuda")]
    pub fn cuda(index: usize) -> burn::backend::cuda::CudaDevice {
        burn::backend::cuda::CudaDevice::new(index)
    }
}

impl std::fmt::Display for Device {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Device::Cpu => f.write_str("cpu"),
            Device::Cuda(i) => write!(f, "cuda:{i}"),
        }
    }
}

impl std::str::FromStr for Device {
    type Err = String;

    /// `cpu`, `cuda` (GPU 0) or `cuda:N`, as PyTorch spells them.
    fn from_str(s: &str) -> Result<Self, String> {
        let bad = || format!("expected cpu, cuda or cuda:N, got {s:?}");
        match s.trim() {
            "cpu" => Ok(Device::Cpu),
            "cuda" => Ok(Device::Cuda(0)),
            other => {
                let index = other.strip_prefix("cuda:").ok_or_else(bad)?;
                index.parse().map(Device::Cuda).map_err(|_| bad())
            }
        }
    }
}

impl Serialize for Device {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_str(self)
    }
}

impl<'de> Deserialize<'de> for Device {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let s = String::deserialize(d)?;
        s.parse().map_err(serde::de::Error::custom)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_and_prints_the_torch_spellings() {
        assert_eq!("cpu".parse::<Device>(), Ok(Device::Cpu));
        assert_eq!("cuda".parse::<Device>(), Ok(Device::Cuda(0)));
        assert_eq!("cuda:3".parse::<Device>(), Ok(Device::Cuda(3)));
        for bad in ["gpu", "cuda:", "cuda:x", "cuda:-1", "CPU"] {
            let e = bad.parse::<Device>().unwrap_err();
            assert!(e.contains("cpu, cuda or cuda:N") && e.contains(bad), "{e}");
        }
        assert_eq!(Device::Cuda(1).to_string(), "cuda:1");
        assert_eq!(
            Device::Cuda(1).to_string().parse::<Device>(),
            Ok(Device::Cuda(1))
        );
        assert_eq!(Device::Cpu.to_string(), "cpu");
    }

    #[test]
    fn serialises_as_its_name() {
        #[derive(Serialize, Deserialize, PartialEq, Debug)]
        struct S {
            device: Device,
        }
        let text = toml::to_string(&S {
            device: Device::Cuda(2),
        })
        .unwrap();
        assert_eq!(text.trim(), "device = \"cuda:2\"");
        assert_eq!(
            toml::from_str::<S>(&text).unwrap(),
            S {
                device: Device::Cuda(2)
            }
        );
        let e = toml::from_str::<S>("device = \"tpu\"").unwrap_err();
        assert!(e.to_string().contains("cpu, cuda or cuda:N"), "{e}");
    }

    #[test]
    fn cuda_in_a_cpu_build_says_how_to_build_it() {
        assert!(Device::Cpu.check_built().is_ok());
        let r = Device::Cuda(0).check_built();
        if CUDA_BUILT {
            assert!(r.is_ok());
        } else {
            let e = r.unwrap_err().to_string();
            assert!(
                e.contains("cuda:0") && e.contains("--features cuda") && e.contains("without CUDA"),
                "{e}"
            );
        }
    }
}
