//! Where the network runs, and on which engine:
//!
//! - `cpu`: burn's Flex backend with this workspace's kernels (always built);
//! - `cuda[:N]`: burn's CUDA backend (CubeCL: kernels compiled at run time with nvrtc) on
//!   GPU N, in builds with the `cuda` cargo feature;
//! - `libtorch:cpu`, `libtorch:cuda[:N]`: burn's LibTorch backend (PyTorch's own
//!   precompiled kernels, no run-time compilation) in builds with the `tch` cargo feature
//!   (`scripts/libtorch-env.sh` gives the environment it builds and runs in).
//!
//! The device is a setting of a run, not of a network: a checkpoint holds plain f32
//! weights, so a model trained on one device loads on any other. Results differ between
//! devices in the last bits (other kernels, other summation orders); on the CPU they do
//! not depend on the thread count.
//!
//! [`Device::check_built`] refuses a device the build has no engine for;
//! [`Device::check_usable`] also asks the machine (the NVIDIA driver, the GPU index,
//! PyTorch's CUDA) before a run writes anything (`crate::device_probe`).

use crate::error::ModelError;
use serde::{Deserialize, Deserializer, Serialize, Serializer};

/// A device the network can run on.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Device {
    #[default]
    Cpu,
    /// The CUDA GPU of this index (as `nvidia-smi` numbers them) on burn's CUDA backend.
    Cuda(usize),
    /// LibTorch (PyTorch's kernels) on the CPU.
    LibTorchCpu,
    /// LibTorch on the CUDA GPU of this index.
    LibTorchCuda(usize),
}

/// Whether this build has the CUDA backend (the `cuda` cargo feature).
pub const CUDA_BUILT: bool = cfg!(feature = "cuda");

/// Whether this build has the LibTorch backend (the `tch` cargo feature).
pub const TCH_BUILT: bool = cfg!(feature = "tch");

/// What to run to get a build with the CUDA backend.
pub const CUDA_BUILD_HINT: &str = "build it with `cargo build --release --locked -p cli --features cuda` \
     (building needs no GPU; running needs the NVIDIA driver and the CUDA toolkit's nvrtc)";

/// What to run to get a build with the LibTorch backend.
pub const TCH_BUILD_HINT: &str = "build it with `eval \"$(scripts/libtorch-env.sh)\" && cargo build --release --locked -p cli --features tch` \
     (needs PyTorch 2.9 in a Python environment, where it is built and where it runs)";

impl Device {
    pub fn is_cpu(&self) -> bool {
        *self == Device::Cpu
    }

    /// The GPU index of burn's CUDA backend, None for every other device. SuperPoint's
    /// front-end runs on that GPU too; with LibTorch it runs on the CPU (Flex).
    pub fn gpu(&self) -> Option<usize> {
        match self {
            Device::Cuda(i) => Some(*i),
            _ => None,
        }
    }

    /// The GPU index on either engine, None for the CPU ones.
    pub fn gpu_index(&self) -> Option<usize> {
        match self {
            Device::Cuda(i) | Device::LibTorchCuda(i) => Some(*i),
            Device::Cpu | Device::LibTorchCpu => None,
        }
    }

    /// Whether the device runs on LibTorch.
    pub fn is_libtorch(&self) -> bool {
        matches!(self, Device::LibTorchCpu | Device::LibTorchCuda(_))
    }

    /// The engine's name, as reports print it.
    pub fn engine(&self) -> &'static str {
        match self {
            Device::Cpu => "flex",
            Device::Cuda(_) => "cubecl-cuda",
            Device::LibTorchCpu | Device::LibTorchCuda(_) => "libtorch",
        }
    }

    /// Refuses a device this build cannot use, saying how to get a build that can.
    pub fn check_built(&self) -> Result<(), ModelError> {
        match self {
            Device::Cuda(_) if !CUDA_BUILT => Err(self.not_built()),
            Device::LibTorchCpu | Device::LibTorchCuda(_) if !TCH_BUILT => Err(self.not_built()),
            _ => Ok(()),
        }
    }

    /// [`Device::check_built`], then whether this machine can run it: the NVIDIA driver
    /// answers, the GPU index exists (`crate::device_probe`). Runs before a run writes
    /// anything, so a missing driver is one line, not a panic in a runtime thread.
    /// For `cuda[:N]` it also points CubeCL's kernel caches at the user's cache folder
    /// (`crate::kernel_cache`), before anything touches the GPU.
    pub fn check_usable(&self) -> Result<(), ModelError> {
        self.check_built()?;
        crate::device_probe::check(self)?;
        #[cfg(feature = "cuda")]
        if let Device::Cuda(_) = self {
            crate::kernel_cache::configure();
        }
        Ok(())
    }

    /// The error for a device this build has no backend for.
    pub fn not_built(&self) -> ModelError {
        ModelError::DeviceUnavailable(if self.is_libtorch() {
            format!("device {self}: this pl2map was built without LibTorch; {TCH_BUILD_HINT}")
        } else {
            format!("device {self}: this pl2map was built without CUDA; {CUDA_BUILD_HINT}")
        })
    }

    /// burn's device of the CUDA backend for this index.
    #[cfg(feature = "cuda")]
    pub fn cuda(index: usize) -> burn::backend::cuda::CudaDevice {
        crate::kernel_cache::configure();
        burn::backend::cuda::CudaDevice::new(index)
    }

    /// burn's LibTorch device for a LibTorch device (the CPU for the others).
    #[cfg(feature = "tch")]
    pub fn libtorch(&self) -> burn::backend::libtorch::LibTorchDevice {
        use burn::backend::libtorch::LibTorchDevice;
        match self {
            Device::LibTorchCuda(i) => LibTorchDevice::Cuda(*i),
            _ => LibTorchDevice::Cpu,
        }
    }
}

impl std::fmt::Display for Device {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Device::Cpu => f.write_str("cpu"),
            Device::Cuda(i) => write!(f, "cuda:{i}"),
            Device::LibTorchCpu => f.write_str("libtorch:cpu"),
            Device::LibTorchCuda(i) => write!(f, "libtorch:cuda:{i}"),
        }
    }
}

/// `cuda` (GPU 0) or `cuda:N`.
fn parse_cuda(s: &str) -> Option<usize> {
    match s {
        "cuda" => Some(0),
        other => other.strip_prefix("cuda:")?.parse().ok(),
    }
}

impl std::str::FromStr for Device {
    type Err = String;

    /// `cpu`, `cuda` (GPU 0) or `cuda:N`, as PyTorch spells them; `libtorch:` before
    /// `cpu`, `cuda` or `cuda:N` picks the LibTorch engine.
    fn from_str(s: &str) -> Result<Self, String> {
        let bad = || {
            format!(
                "expected cpu, cuda or cuda:N (CubeCL), or libtorch:cpu, libtorch:cuda or libtorch:cuda:N, got {s:?}"
            )
        };
        let s = s.trim();
        if let Some(rest) = s.strip_prefix("libtorch:") {
            return match rest {
                "cpu" => Ok(Device::LibTorchCpu),
                other => parse_cuda(other).map(Device::LibTorchCuda).ok_or_else(bad),
            };
        }
        match s {
            "cpu" => Ok(Device::Cpu),
            other => parse_cuda(other).map(Device::Cuda).ok_or_else(bad),
        }
    }
}

/// Makes the panics a GPU engine raises for a condition of the machine (GPU memory
/// exhausted, a CUDA driver error) one line saying what to do, and ends the process with
/// status 1 at once: burn's engines panic instead of returning these errors, on the
/// calling thread (LibTorch) or in a runtime thread (CubeCL), where the run would
/// otherwise wait on it. Files in progress stay under their temporary names. Other
/// panics keep Rust's report. Does nothing for the CPU devices.
pub fn explain_gpu_panics(device: Device) {
    static INSTALLED: std::sync::Once = std::sync::Once::new();
    if device.gpu_index().is_none() {
        return;
    }
    // Once a process: a run has one GPU device.
    INSTALLED.call_once(|| install_gpu_panic_hook(device));
}

fn install_gpu_panic_hook(device: Device) {
    let default = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        let payload = info.payload();
        let message = payload
            .downcast_ref::<String>()
            .map(String::as_str)
            .or_else(|| payload.downcast_ref::<&str>().copied())
            .unwrap_or("");
        if let Some(line) = explain_gpu_panic(device, message) {
            eprintln!("error: {line}");
            std::process::exit(1);
        }
        default(info)
    }));
}

/// The line [`explain_gpu_panics`] prints for a panic message, None for a panic that
/// is not about the GPU.
pub fn explain_gpu_panic(device: Device, message: &str) -> Option<String> {
    let lower = message.to_lowercase();
    // The engine's own words, shortened to one line.
    let first = message
        .lines()
        .find(|l| !l.trim().is_empty())
        .unwrap_or("")
        .trim();
    let said: String = first.chars().take(160).collect();
    if lower.contains("out of memory") || lower.contains("outofmemory") {
        return Some(format!(
            "device {device}: GPU memory exhausted ({said}): lower [train] limits \
             (max_keypoints, max_lines) or batch_size, or free the GPU (`nvidia-smi` \
             shows what holds it)"
        ));
    }
    if lower.contains("cuda_error") || lower.contains("cuda error") || lower.contains("cudaerror") {
        return Some(format!(
            "device {device}: the CUDA driver failed ({said}): check `nvidia-smi`, or use --device cpu"
        ));
    }
    None
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
        assert_eq!("libtorch:cpu".parse::<Device>(), Ok(Device::LibTorchCpu));
        assert_eq!(
            "libtorch:cuda".parse::<Device>(),
            Ok(Device::LibTorchCuda(0))
        );
        assert_eq!(
            "libtorch:cuda:2".parse::<Device>(),
            Ok(Device::LibTorchCuda(2))
        );
        assert_eq!(Device::LibTorchCuda(2).to_string(), "libtorch:cuda:2");
        assert_eq!(Device::LibTorchCpu.to_string(), "libtorch:cpu");
        for bad in [
            "gpu",
            "cuda:",
            "cuda:x",
            "cuda:-1",
            "CPU",
            "libtorch",
            "libtorch:",
            "libtorch:gpu",
            "libtorch:cuda:",
            "libtorch:libtorch:cpu",
        ] {
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
        let t = toml::from_str::<S>("device = \"libtorch:cuda:1\"").unwrap();
        assert_eq!(t.device, Device::LibTorchCuda(1));
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
        for d in [Device::LibTorchCpu, Device::LibTorchCuda(1)] {
            match d.check_built() {
                Ok(()) => assert!(d.check_built().is_ok() && TCH_BUILT.then_some(()).is_some()),
                Err(e) => {
                    let e = e.to_string();
                    assert!(TCH_BUILT.then_some(()).is_none());
                    assert!(
                        e.contains(&d.to_string())
                            && e.contains("--features tch")
                            && e.contains("libtorch-env.sh")
                            && e.contains("without LibTorch"),
                        "{e}"
                    );
                }
            }
        }
    }

    #[test]
    fn gpu_panics_become_one_line() {
        let d = Device::LibTorchCuda(0);
        let oom = "Torch(\"CUDA out of memory. Tried to allocate 20.00 MiB (GPU 0; 79.1 GiB total capacity)\nmore\")";
        let e = explain_gpu_panic(d, oom).unwrap();
        assert!(
            e.contains("libtorch:cuda:0") && e.contains("GPU memory exhausted"),
            "{e}"
        );
        assert!(!e.contains('\n') && e.contains("max_keypoints"), "{e}");
        let e = explain_gpu_panic(
            Device::Cuda(1),
            "DriverError(CUDA_ERROR_STUB_LIBRARY, \"stub\")",
        )
        .unwrap();
        assert!(
            e.contains("cuda:1") && e.contains("CUDA driver failed"),
            "{e}"
        );
        assert_eq!(
            explain_gpu_panic(d, "index out of bounds: the len is 3"),
            None
        );
    }

    #[test]
    fn engines_and_gpus() {
        assert_eq!(Device::Cuda(2).gpu(), Some(2));
        assert_eq!(Device::LibTorchCuda(2).gpu(), None);
        assert_eq!(Device::LibTorchCuda(2).gpu_index(), Some(2));
        assert_eq!(Device::LibTorchCpu.gpu_index(), None);
        assert!(Device::LibTorchCpu.is_libtorch() && !Device::LibTorchCpu.is_cpu());
        assert_eq!(Device::Cpu.engine(), "flex");
        assert_eq!(Device::Cuda(0).engine(), "cubecl-cuda");
        assert_eq!(Device::LibTorchCuda(0).engine(), "libtorch");
    }
}
