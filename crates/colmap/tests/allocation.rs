//! Absurd counts must not turn into huge allocations: a counting global allocator
//! records the largest single request made while parsing hostile inputs.

mod small;

use colmap::Format;
use small::{files, model, parse_bin, parse_txt, text_files};
use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};

struct Counting;

static LARGEST: AtomicUsize = AtomicUsize::new(0);

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        LARGEST.fetch_max(layout.size(), Ordering::Relaxed);
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        LARGEST.fetch_max(new_size, Ordering::Relaxed);
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

/// The whole binary is one test function, so nothing else allocates while it measures
/// (the parser's own worker thread included, which a thread-local flag would miss).
fn largest_allocation_during(f: impl FnOnce()) -> usize {
    LARGEST.store(0, Ordering::SeqCst);
    f();
    LARGEST.load(Ordering::SeqCst)
}

const LIMIT: usize = 64 * 1024;

#[test]
fn huge_counts_allocate_nothing_big() {
    binary_counts();
    text_counts();
}

fn binary_counts() {
    let full = files(&model(), Format::Binary);
    let name_len = "rig/cam1/0001.png".len() + 1;
    let edits: Vec<(usize, usize, Vec<u8>)> = vec![
        (0, 0, u64::MAX.to_le_bytes().to_vec()),
        (1, 0, (1u64 << 40).to_le_bytes().to_vec()),
        (2, 0, (u64::MAX / 51).to_le_bytes().to_vec()),
        (3, 0, (u64::MAX / 8).to_le_bytes().to_vec()),
        (4, 0, (1u64 << 50).to_le_bytes().to_vec()),
        (
            1,
            8 + 4 + 56 + 4 + name_len,
            (u64::MAX / 24).to_le_bytes().to_vec(),
        ),
        (2, 8 + 8 + 24 + 3 + 8, (1u64 << 61).to_le_bytes().to_vec()),
        (3, 12, u32::MAX.to_le_bytes().to_vec()),
        (4, 8 + 4 + 4 + 56, u32::MAX.to_le_bytes().to_vec()),
    ];
    for (k, at, bytes) in edits {
        let mut f = full.clone();
        f[k][at..at + bytes.len()].copy_from_slice(&bytes);
        let mut result = None;
        let largest = largest_allocation_during(|| result = Some(parse_bin(&f)));
        let e = result.unwrap().unwrap_err();
        assert!(
            largest < LIMIT,
            "file {k} offset {at}: {largest} bytes allocated ({e})"
        );
    }
}

fn text_counts() {
    let full = text_files(&model());
    let cases: Vec<(usize, &str, &str)> = vec![
        (3, "1 3 CAMERA 1", "1 4294967295 CAMERA 1"),
        (4, " 1 CAMERA 1 3", " 4294967295 CAMERA 1 3"),
    ];
    for (k, from, to) in cases {
        let mut f = full.clone();
        assert!(f[k].contains(from), "{from:?} not in file {k}");
        f[k] = f[k].replacen(from, to, 1);
        let mut result = None;
        let largest = largest_allocation_during(|| result = Some(parse_txt(&f)));
        let e = result.unwrap().unwrap_err();
        assert!(largest < LIMIT, "file {k}: {largest} bytes allocated ({e})");
    }
}
