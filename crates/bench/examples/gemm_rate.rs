//! How fast `gemm` (the crate burn-flex's matrix products use) multiplies the shapes of
//! the main job's heads and of the graph network's layers on this machine: on 1 thread,
//! threaded by gemm over all of the rayon pool's, and split into one band of rows per
//! thread, each band a single-threaded call (as the network's kernels multiply,
//! `flex_matrix::product`): the bound on a training step made of these products
//! (docs/performance.md, "The main job's step" and "The attention's softmax").
//!
//! cargo run --release -p bench --example gemm_rate

use rayon::prelude::*;
use std::time::Instant;

/// One product shape: m x k times k x n, and whether each operand is read transposed
/// (as the backward pass reads them).
struct Shape {
    what: &'static str,
    m: usize,
    k: usize,
    n: usize,
    lhs_transposed: bool,
    rhs_transposed: bool,
}

/// Seconds per product, in `bands` bands of rows (1: one call), each with `parallelism`.
fn seconds_per_product(s: &Shape, parallelism: gemm::Parallelism, bands: usize) -> f64 {
    let a = vec![0.5f32; s.m * s.k];
    let b = vec![0.25f32; s.k * s.n];
    let mut c = vec![0.0f32; s.m * s.n];
    // (column stride, row stride) of each operand in its row-major storage.
    let (lhs_cs, lhs_rs) = if s.lhs_transposed {
        (s.m as isize, 1)
    } else {
        (1, s.k as isize)
    };
    let (rhs_cs, rhs_rs) = if s.rhs_transposed {
        (s.k as isize, 1)
    } else {
        (1, s.n as isize)
    };
    // Addresses as integers, so that the bands' tasks may share them.
    let (a_at, b_at) = (a.as_ptr() as usize, b.as_ptr() as usize);
    let run = |c: &mut [f32]| {
        let rows = s.m.div_ceil(bands);
        let c_at = c.as_mut_ptr() as usize;
        (0..bands).into_par_iter().for_each(|band| {
            let first = band * rows;
            let count = rows.min(s.m - first);
            // SAFETY: a, b and c hold m x k, k x n and m x n elements, reached through the
            // strides above; band `band` reads and writes its own rows only.
            unsafe {
                gemm::gemm(
                    count,
                    s.n,
                    s.k,
                    (c_at as *mut f32).add(first * s.n),
                    1,
                    s.n as isize,
                    false,
                    (a_at as *const f32).offset(first as isize * lhs_rs),
                    lhs_cs,
                    lhs_rs,
                    b_at as *const f32,
                    rhs_cs,
                    rhs_rs,
                    0.0,
                    1.0,
                    false,
                    false,
                    false,
                    parallelism,
                )
            }
        });
    };
    for _ in 0..10 {
        run(&mut c);
    }
    let reps = 200;
    let start = Instant::now();
    for _ in 0..reps {
        run(&mut c);
    }
    start.elapsed().as_secs_f64() / reps as f64
}

fn main() {
    let shapes = [
        ("point head, hidden layer", 512, 512, 512, false, false),
        ("  its input gradient", 512, 512, 512, false, true),
        ("  its weight gradient", 512, 512, 512, true, false),
        ("graph (D 128), projection", 1024, 128, 128, false, false),
        ("  its weight gradient", 128, 1024, 128, true, false),
        ("graph, message layer", 1024, 256, 256, false, false),
        ("  its weight gradient", 256, 1024, 256, true, false),
        ("graph, head input layer", 1024, 128, 512, false, false),
        ("graph, head hidden layer", 1024, 512, 1024, false, false),
        ("  its input gradient", 1024, 1024, 512, false, true),
        ("  its weight gradient", 512, 1024, 1024, true, false),
        ("line head, hidden layer", 192, 512, 512, false, false),
        ("  its input gradient", 192, 512, 512, false, true),
        ("  its weight gradient", 512, 192, 512, true, false),
    ];
    let threads = rayon::current_num_threads();
    println!(
        "| product | m x k x n | 1 thread GFLOP/s | {threads} threads (gemm's) | {threads} bands of rows |"
    );
    println!("|---|---|---:|---:|---:|");
    for (what, m, k, n, lhs_transposed, rhs_transposed) in shapes {
        let s = Shape {
            what,
            m,
            k,
            n,
            lhs_transposed,
            rhs_transposed,
        };
        let flop = 2.0 * (m * k * n) as f64;
        let one = flop / seconds_per_product(&s, gemm::Parallelism::None, 1) / 1e9;
        let all = flop / seconds_per_product(&s, gemm::Parallelism::Rayon(0), 1) / 1e9;
        let bands = flop / seconds_per_product(&s, gemm::Parallelism::None, threads) / 1e9;
        println!(
            "| {} | {m} x {k} x {n} | {one:.0} | {all:.0} | {bands:.0} |",
            s.what
        );
    }
}
