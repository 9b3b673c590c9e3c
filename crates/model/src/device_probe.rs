//! Asks the machine whether it can run a device, before a run writes anything: the
//! NVIDIA driver for the GPU devices of both engines (`kernels::cuda_driver`: missing,
//! the toolkit's stub, a GPU index that does not exist) and, for `libtorch:cuda[:N]`,
//! whether the linked PyTorch has CUDA and sees that GPU (`kernels::libtorch`). Each
//! answer is one line naming the device and saying what to do.

use crate::device::Device;
use crate::error::ModelError;

/// Ok when the device can run here (CPU devices always can).
pub fn check(device: &Device) -> Result<(), ModelError> {
    let Some(index) = device.gpu_index() else {
        return Ok(());
    };
    let refuse = |why: String| {
        Err(ModelError::DeviceUnavailable(format!(
            "device {device}: {why}"
        )))
    };
    let driver = match kernels::cuda_driver::probe() {
        Ok(d) => d,
        Err(problem) => return refuse(problem.to_string()),
    };
    if index >= driver.devices {
        return refuse(format!(
            "there is no GPU {index}: the NVIDIA driver ({}) sees {} (use {})",
            driver.library,
            driver.devices,
            match driver.devices {
                0 => "--device cpu".to_string(),
                1 => "index 0".to_string(),
                n => format!("an index from 0 to {}", n - 1),
            }
        ));
    }
    #[cfg(feature = "tch")]
    if device.is_libtorch() {
        if let Err(why) = kernels::libtorch::check_cuda(index) {
            return refuse(why);
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cpu_devices_need_nothing_and_gpus_need_a_driver() {
        assert!(check(&Device::Cpu).is_ok());
        assert!(check(&Device::LibTorchCpu).is_ok());
        // A GPU index no machine has: refused whether or not a driver is present, in
        // one line naming the device.
        for d in [Device::Cuda(4096), Device::LibTorchCuda(4096)] {
            let e = check(&d).unwrap_err().to_string();
            assert!(e.contains(&d.to_string()) && !e.contains('\n'), "{e}");
            assert!(
                e.contains("no NVIDIA driver")
                    || e.contains("there is no GPU 4096")
                    || e.contains("stub")
                    || e.contains("not the NVIDIA driver")
                    || e.contains("CUDA error"),
                "{e}"
            );
        }
    }
}
