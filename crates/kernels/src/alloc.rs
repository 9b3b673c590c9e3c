//! The allocator settings of training steps (glibc): the trainer's and `step_bench`'s.
//!
//! Why: a step allocates and frees the same few hundred buffers every time (activations,
//! gradients, Adam's outputs), most of them 0.1-16 MiB. glibc serves such sizes with
//! fresh `mmap`s and returns them with `munmap`, so every step page-faults its buffers in
//! again; with gradient groups (`crates/train/src/step/groups.rs`) the groups' threads also contend
//! for the process's memory map while doing so. Keeping freed memory in the heap for
//! reuse made the main job's step (`pipeline/synthetic.toml`, two groups) 6-11 % faster
//! on a 2-core Intel Xeon VM (docs/performance.md, "Gradient groups"). Values are not
//! affected: only where the buffers live.

/// Serve allocations up to this size from the heap, not from their own `mmap`.
const MMAP_THRESHOLD: i32 = 128 << 20;
/// Give freed memory at the top of the heap back only above this much.
const TRIM_THRESHOLD: i32 = 1 << 30;
/// Grow the heap by this much extra at a time (address space; pages are touched on use).
const TOP_PAD: i32 = 256 << 20;

/// Applies the settings once per process, unless the user set any of glibc's
/// `MALLOC_*_` variables (theirs then stand). Other C libraries: nothing to do.
pub fn keep_freed_memory() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        let user_set = [
            "MALLOC_MMAP_THRESHOLD_",
            "MALLOC_TRIM_THRESHOLD_",
            "MALLOC_TOP_PAD_",
        ]
        .iter()
        .any(|v| std::env::var_os(v).is_some());
        if !user_set {
            apply();
        }
    });
}

#[cfg(all(target_os = "linux", target_env = "gnu"))]
fn apply() {
    // SAFETY: mallopt only changes glibc's allocation parameters; it is documented as
    // safe to call at any time (allocations made before keep their placement).
    unsafe {
        libc::mallopt(libc::M_MMAP_THRESHOLD, MMAP_THRESHOLD);
        libc::mallopt(libc::M_TRIM_THRESHOLD, TRIM_THRESHOLD);
        libc::mallopt(libc::M_TOP_PAD, TOP_PAD);
    }
}

#[cfg(not(all(target_os = "linux", target_env = "gnu")))]
fn apply() {}
