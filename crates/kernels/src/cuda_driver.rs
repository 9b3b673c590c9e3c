//! Asks the NVIDIA driver (`libcuda`) whether it works, and how many GPUs it sees, before
//! a GPU engine does. burn's CUDA backend (through cudarc) loads the driver library on
//! its first tensor operation and panics, in a runtime thread, when it is missing or is
//! the CUDA toolkit's stub (docs/performance.md, "The CUDA backend on a GPU"); asked here
//! first, each of those is an error a run reports in one line before it writes anything.
//!
//! The library is looked up by the names cudarc tries first (`libcuda.so`, then
//! `libcuda.so.1`), so the probe sees the library the engine would load, the toolkit's
//! `lib/stubs/libcuda.so` on `LD_LIBRARY_PATH` included.

use std::ffi::{CStr, CString, c_char, c_int, c_uint, c_void};
use std::sync::OnceLock;

/// What the driver said.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct DriverInfo {
    /// The file the library was loaded from.
    pub library: String,
    /// The CUDA version the driver supports, as `cuDriverGetVersion` gives it (12040: 12.4).
    pub version: i32,
    /// How many GPUs it sees.
    pub devices: usize,
}

/// Why the driver cannot be used; `Display` says what to do.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum DriverProblem {
    /// No `libcuda.so` / `libcuda.so.1` on the library path.
    NotFound,
    /// A library of that name without the driver's entry points.
    NotADriver { library: String },
    /// `cuInit` or a query failed with this CUDA error code.
    Failed {
        library: String,
        call: &'static str,
        code: i32,
    },
}

/// CUDA_ERROR_STUB_LIBRARY: the toolkit's link-time stub, not a driver.
const STUB_LIBRARY: i32 = 34;
/// CUDA_ERROR_INSUFFICIENT_DRIVER.
const INSUFFICIENT_DRIVER: i32 = 35;
/// CUDA_ERROR_NO_DEVICE.
const NO_DEVICE: i32 = 100;
/// CUDA_ERROR_SYSTEM_DRIVER_MISMATCH.
const DRIVER_MISMATCH: i32 = 803;

impl std::fmt::Display for DriverProblem {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            DriverProblem::NotFound => f.write_str(
                "no NVIDIA driver: libcuda.so.1 is not on the library path \
                 (install the NVIDIA driver and check `nvidia-smi`, or use --device cpu)",
            ),
            DriverProblem::NotADriver { library } => write!(
                f,
                "{library} is not the NVIDIA driver (it has no cuInit): remove its folder \
                 from LD_LIBRARY_PATH, or use --device cpu"
            ),
            DriverProblem::Failed {
                library,
                code: STUB_LIBRARY,
                ..
            } => write!(
                f,
                "{library} is the CUDA toolkit's stub library, not the driver \
                 (CUDA_ERROR_STUB_LIBRARY): remove the toolkit's lib/stubs folder from \
                 LD_LIBRARY_PATH (and install the NVIDIA driver if `nvidia-smi` fails)"
            ),
            DriverProblem::Failed {
                library,
                call,
                code,
            } => {
                let what = match *code {
                    NO_DEVICE => {
                        "no CUDA-capable GPU is visible (CUDA_ERROR_NO_DEVICE): check `nvidia-smi` and CUDA_VISIBLE_DEVICES, or use --device cpu"
                    }
                    INSUFFICIENT_DRIVER => {
                        "the driver is older than this CUDA runtime (CUDA_ERROR_INSUFFICIENT_DRIVER): update the NVIDIA driver"
                    }
                    DRIVER_MISMATCH => {
                        "the driver library does not match the loaded kernel module (CUDA_ERROR_SYSTEM_DRIVER_MISMATCH): reboot or reinstall the NVIDIA driver"
                    }
                    _ => "check `nvidia-smi`, or use --device cpu",
                };
                write!(
                    f,
                    "the NVIDIA driver ({library}) failed in {call} with CUDA error {code}: {what}"
                )
            }
        }
    }
}

/// The driver of this process, asked once (the answer does not change while it runs).
pub fn probe() -> Result<DriverInfo, DriverProblem> {
    static ANSWER: OnceLock<Result<DriverInfo, DriverProblem>> = OnceLock::new();
    ANSWER
        .get_or_init(|| {
            let mut last = DriverProblem::NotFound;
            for name in ["libcuda.so", "libcuda.so.1"] {
                match probe_library(name) {
                    Err(DriverProblem::NotFound) => continue,
                    Ok(info) => return Ok(info),
                    // A library that loads but fails: the engine would load the same
                    // one first, so that is the answer.
                    Err(problem) => {
                        last = problem;
                        break;
                    }
                }
            }
            Err(last)
        })
        .clone()
}

type InitFn = unsafe extern "C" fn(c_uint) -> c_int;
type CountFn = unsafe extern "C" fn(*mut c_int) -> c_int;

/// Loads the library `name` (a file name searched on the library path, or a path) and
/// asks it to initialise and count its devices.
pub fn probe_library(name: &str) -> Result<DriverInfo, DriverProblem> {
    let c_name = CString::new(name).map_err(|_| DriverProblem::NotFound)?;
    // SAFETY: dlopen takes a NUL-terminated name; the handle is never closed, so symbols
    // taken from it stay valid for the process (as the engine keeps the library loaded).
    let handle = unsafe { libc::dlopen(c_name.as_ptr(), libc::RTLD_NOW | libc::RTLD_LOCAL) };
    if handle.is_null() {
        return Err(DriverProblem::NotFound);
    }
    let symbol = |s: &CStr| {
        // SAFETY: a valid handle from dlopen above and a NUL-terminated symbol name.
        let p = unsafe { libc::dlsym(handle, s.as_ptr()) };
        (!p.is_null()).then_some(p)
    };
    let Some(init) = symbol(c"cuInit") else {
        return Err(DriverProblem::NotADriver {
            library: library_file(handle, name),
        });
    };
    let library = library_file(init, name);
    let (Some(count), Some(version)) = (symbol(c"cuDeviceGetCount"), symbol(c"cuDriverGetVersion"))
    else {
        return Err(DriverProblem::NotADriver { library });
    };
    // SAFETY: the driver API's signatures: CUresult cuInit(unsigned int),
    // CUresult cuDeviceGetCount(int*), CUresult cuDriverGetVersion(int*) (cuda.h); the
    // pointers come from dlsym of those names.
    let (init, count, version) = unsafe {
        (
            std::mem::transmute::<*mut c_void, InitFn>(init),
            std::mem::transmute::<*mut c_void, CountFn>(count),
            std::mem::transmute::<*mut c_void, CountFn>(version),
        )
    };
    let failed = |call, code| DriverProblem::Failed {
        library: library.clone(),
        call,
        code,
    };
    // SAFETY: cuInit takes flags 0; it may be called more than once per process.
    let code = unsafe { init(0) };
    if code != 0 {
        return Err(failed("cuInit", code));
    }
    let mut v: c_int = 0;
    // SAFETY: writes one int through a valid pointer.
    let code = unsafe { version(&mut v) };
    if code != 0 {
        return Err(failed("cuDriverGetVersion", code));
    }
    let mut n: c_int = 0;
    // SAFETY: writes one int through a valid pointer.
    let code = unsafe { count(&mut n) };
    if code != 0 {
        return Err(failed("cuDeviceGetCount", code));
    }
    Ok(DriverInfo {
        library,
        version: v,
        devices: n.max(0) as usize,
    })
}

/// The file a loaded address belongs to (dladdr), or the name asked for.
fn library_file(address: *mut c_void, fallback: &str) -> String {
    let mut info = libc::Dl_info {
        dli_fname: std::ptr::null(),
        dli_fbase: std::ptr::null_mut(),
        dli_sname: std::ptr::null(),
        dli_saddr: std::ptr::null_mut(),
    };
    // SAFETY: dladdr only reads the address and fills `info`; dli_fname, when set,
    // points at a NUL-terminated string the loader owns for as long as the object is
    // loaded (it is never unloaded here).
    let found = unsafe { libc::dladdr(address as *const c_void, &mut info) } != 0;
    if found && !info.dli_fname.is_null() {
        let name: *const c_char = info.dli_fname;
        // SAFETY: see above.
        return unsafe { CStr::from_ptr(name) }
            .to_string_lossy()
            .into_owned();
    }
    fallback.to_string()
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;
    use std::process::Command;

    /// Builds a shared library from C source with the system's cc; None (the test
    /// prints why and skips) when there is no C compiler.
    fn shared_library(dir: &Path, name: &str, source: &str) -> Option<String> {
        let c = dir.join(format!("{name}.c"));
        std::fs::write(&c, source).unwrap();
        let so = dir.join(format!("{name}.so"));
        let out = Command::new("cc")
            .args(["-shared", "-fPIC", "-o"])
            .arg(&so)
            .arg(&c)
            .output();
        match out {
            Ok(o) if o.status.success() => Some(so.to_string_lossy().into_owned()),
            Ok(o) => panic!("cc failed: {}", String::from_utf8_lossy(&o.stderr)),
            Err(e) => {
                eprintln!("skipping: no C compiler (cc: {e})");
                None
            }
        }
    }

    #[test]
    fn a_stub_driver_is_named_and_explained() {
        let dir = tempfile_dir();
        let Some(stub) = shared_library(
            &dir,
            "stub",
            "int cuInit(unsigned f) { (void)f; return 34; }\n\
             int cuDeviceGetCount(int *n) { *n = 0; return 34; }\n\
             int cuDriverGetVersion(int *v) { *v = 0; return 34; }\n",
        ) else {
            return;
        };
        let e = probe_library(&stub).unwrap_err();
        assert_eq!(
            e,
            DriverProblem::Failed {
                library: stub.clone(),
                call: "cuInit",
                code: 34
            }
        );
        let text = e.to_string();
        assert!(
            text.contains("stub") && text.contains("LD_LIBRARY_PATH") && text.contains(&stub),
            "{text}"
        );
        assert!(!text.contains('\n'));
    }

    #[test]
    fn a_library_without_the_driver_api_is_not_a_driver() {
        let dir = tempfile_dir();
        let Some(empty) = shared_library(&dir, "empty", "int unrelated(void) { return 0; }\n")
        else {
            return;
        };
        let e = probe_library(&empty).unwrap_err();
        assert!(matches!(e, DriverProblem::NotADriver { .. }), "{e:?}");
        assert!(e.to_string().contains("not the NVIDIA driver"), "{e}");
    }

    #[test]
    fn a_working_driver_counts_its_devices() {
        // A library with the driver's entry points that answers like a driver with two
        // GPUs: the probe reads what it says.
        let dir = tempfile_dir();
        let Some(fake) = shared_library(
            &dir,
            "two",
            "int cuInit(unsigned f) { (void)f; return 0; }\n\
             int cuDeviceGetCount(int *n) { *n = 2; return 0; }\n\
             int cuDriverGetVersion(int *v) { *v = 12040; return 0; }\n",
        ) else {
            return;
        };
        let info = probe_library(&fake).unwrap();
        assert_eq!((info.devices, info.version), (2, 12040));
        assert_eq!(info.library, fake);
        let e = probe_library(&dir.join("missing.so").to_string_lossy()).unwrap_err();
        assert_eq!(e, DriverProblem::NotFound);
        assert!(e.to_string().contains("no NVIDIA driver"));
    }

    /// A fresh folder under the system's temporary folder, removed when dropped
    /// (kernels has no tempfile dependency).
    struct Scratch(std::path::PathBuf);

    impl Drop for Scratch {
        fn drop(&mut self) {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }

    impl std::ops::Deref for Scratch {
        type Target = Path;
        fn deref(&self) -> &Path {
            &self.0
        }
    }

    fn tempfile_dir() -> Scratch {
        use std::sync::atomic::{AtomicUsize, Ordering};
        static N: AtomicUsize = AtomicUsize::new(0);
        let d = std::env::temp_dir().join(format!(
            "kernels-cuda-driver-{}-{}",
            std::process::id(),
            N.fetch_add(1, Ordering::Relaxed)
        ));
        std::fs::create_dir_all(&d).unwrap();
        Scratch(d)
    }
}
