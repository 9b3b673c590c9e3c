//! The training step's matrix products with bf16 operands and f32 sums
//! (`[train] products = "bf16"`), as mixed-precision training computes them.
//!
//! Why: the products of the dense layers are most of a CPU training step, and on CPUs
//! with AMX (`amx.rs`) bf16 operands multiply about three times as fast as gemm's f32
//! kernels. Each operand is rounded to bf16 (8 bits of mantissa, f32's exponent range,
//! round to nearest even) and every sum is kept in f32. The weights, Adam's moments,
//! bias additions, activations between layers and the losses stay f32
//! (docs/performance.md, "bf16 products on AMX tiles", has their speed and accuracy).
//!
//! What is rounded is fixed by the configuration and the shapes: a product takes bf16
//! operands when every dimension is at least [`MIN_DIM`] (the hidden layers of the
//! heads); smaller ones (an output layer of 3 or 4 columns, a gradient summed over 4
//! terms) stay f32, so the coordinates and reliabilities come out of f32 products. On a
//! CPU without AMX the rounded operands are multiplied by gemm: the same products, summed
//! in another order (results differ in the last bits), and slower than f32. Results
//! never depend on the thread count: every output element is one block's sum, whoever
//! computes it.
//!
//! The setting is per thread ([`with_products`]): the training step sets it on the
//! threads that run its passes, so inference and other users of the same kernels stay
//! f32.

use crate::flex_matrix::{Operand, SendPtr, new_product, parallelism_of};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::cell::Cell;
use std::mem::MaybeUninit;

/// How a training step's matrix products are computed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Products {
    /// f32 operands and sums (gemm), as the reference trains.
    #[default]
    F32,
    /// Operands rounded to bf16, sums in f32, in the forward and backward passes; AMX
    /// tiles where the CPU has them.
    Bf16,
}

impl std::fmt::Display for Products {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Products::F32 => "f32",
            Products::Bf16 => "bf16",
        })
    }
}

impl std::str::FromStr for Products {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "f32" => Ok(Products::F32),
            "bf16" => Ok(Products::Bf16),
            _ => Err(format!("expected f32 or bf16, got {s:?}")),
        }
    }
}

/// Products with a dimension under this stay f32 whatever the setting.
pub const MIN_DIM: usize = 32;

thread_local! {
    static CURRENT: Cell<Products> = const { Cell::new(Products::F32) };
}

/// Runs `f` with this thread's products set to `products`, restored afterwards (also
/// when `f` panics).
pub fn with_products<R>(products: Products, f: impl FnOnce() -> R) -> R {
    struct Restore(Products);
    impl Drop for Restore {
        fn drop(&mut self) {
            CURRENT.with(|c| c.set(self.0));
        }
    }
    let _restore = Restore(CURRENT.with(|c| c.replace(products)));
    f()
}

/// Whether an m x k x n product on this thread takes bf16 operands.
pub(crate) fn takes_bf16(m: usize, n: usize, k: usize) -> bool {
    CURRENT.with(Cell::get) == Products::Bf16 && m.min(n).min(k) >= MIN_DIM
}

/// Whether the bf16 products run on AMX tiles here (else through gemm, slower than f32).
pub fn on_amx() -> bool {
    crate::amx::available()
}

/// lhs [m, k] x rhs [k, n] as this thread's setting computes it: bf16 operands where
/// [`takes_bf16`], gemm's f32 product otherwise.
///
/// SAFETY: as [`new_product_bf16`].
pub(crate) unsafe fn new_product_as_set(
    (m, n, k): (usize, usize, usize),
    lhs: Operand,
    rhs: Operand,
) -> Vec<f32> {
    // SAFETY: the caller's promises.
    unsafe {
        if takes_bf16(m, n, k) {
            new_product_bf16((m, n, k), lhs, rhs)
        } else {
            new_product((m, n, k), lhs, rhs, parallelism_of(m, n, k))
        }
    }
}

/// f32 -> bf16 bits, rounded to nearest even; NaN stays a (quiet) NaN of its sign
/// (the `half` crate's conversion).
#[inline(always)]
fn to_bf16(x: f32) -> u16 {
    half::bf16::from_f32(x).to_bits()
}

/// bf16 bits -> f32 (exact).
#[inline(always)]
fn from_bf16(x: u16) -> f32 {
    half::bf16::from_bits(x).to_f32()
}

/// A new [m, n] row-major buffer holding lhs [m, k] x rhs [k, n] with both operands
/// rounded to bf16 and the sums in f32.
///
/// SAFETY: lhs reaches m x k and rhs k x n valid elements through their strides; m, n,
/// k > 0.
pub(crate) unsafe fn new_product_bf16(
    dims: (usize, usize, usize),
    lhs: Operand,
    rhs: Operand,
) -> Vec<f32> {
    // SAFETY: the caller's promises.
    unsafe { product_on(dims, lhs, rhs, crate::amx::available()) }
}

/// [`new_product_bf16`] on AMX tiles (`amx`: only where [`crate::amx::available`]) or
/// through gemm.
///
/// SAFETY: as [`new_product_bf16`].
unsafe fn product_on(
    (m, n, k): (usize, usize, usize),
    lhs: Operand,
    rhs: Operand,
    amx: bool,
) -> Vec<f32> {
    if !amx {
        // SAFETY: the caller's promises.
        let (a, b) = unsafe { (rounded(lhs, m, k), rounded(rhs, k, n)) };
        // SAFETY: both are contiguous row-major buffers of the product's sizes.
        return unsafe {
            new_product(
                (m, n, k),
                crate::flex_matrix::row_major(&a, k),
                crate::flex_matrix::row_major(&b, n),
                parallelism_of(m, n, k),
            )
        };
    }
    let bl = crate::amx::BLOCK;
    let (mp, np, kp) = (
        m.next_multiple_of(bl),
        n.next_multiple_of(bl),
        k.next_multiple_of(crate::amx::K_STEP),
    );
    // SAFETY: the caller's promises.
    let (a, b) = unsafe { (pack_rows(lhs, m, k, mp, kp), pack_pairs(rhs, k, n, kp, np)) };
    // Padded rows and columns land in a padded buffer, cut to [m, n] after.
    let exact = mp == m && np == n;
    let mut c: Vec<f32> = Vec::with_capacity(mp * np);
    let dst = SendPtr(c.as_mut_ptr());
    let (a_stride, b_stride, c_stride) = (2 * kp, 4 * np, 4 * np);
    // One task per column of blocks (fixed, whatever the threads): each writes its own
    // 32 columns of every row.
    (0..np / bl).into_par_iter().for_each(|j| {
        let dst = &dst;
        let blocks = (0..mp / bl).map(|i| {
            (
                a[i * bl * kp / 2..].as_ptr() as *const u16,
                b[j * bl..].as_ptr() as *const u16,
                dst.0.wrapping_add(i * bl * np + j * bl),
            )
        });
        // SAFETY: AMX is available; kp is a positive multiple of K_STEP; A holds mp
        // rows of kp values, B kp / 2 rows of np pairs, C mp x np values, and block
        // (i, j) stays inside each.
        unsafe { crate::amx::blocks(blocks, kp, a_stride, b_stride, c_stride) };
    });
    // SAFETY: every element of the mp x np buffer was written by one block.
    unsafe { c.set_len(mp * np) };
    if exact {
        return c;
    }
    let mut out = Vec::with_capacity(m * n);
    for row in c.chunks_exact(np).take(m) {
        out.extend_from_slice(&row[..n]);
    }
    out
}

/// The operand's rows x cols values rounded to bf16, as f32, row-major.
///
/// SAFETY: o reaches rows x cols valid elements.
unsafe fn rounded(o: Operand, rows: usize, cols: usize) -> Vec<f32> {
    // SAFETY: the caller's promise.
    let plain = unsafe { contiguous(o, rows, cols) };
    plain.iter().map(|v| from_bf16(to_bf16(*v))).collect()
}

/// The operand's rows x cols values as a row-major buffer: a transposed contiguous
/// operand through the vectorised transpose (`transpose.rs`), anything else gathered.
///
/// SAFETY: o reaches rows x cols valid elements.
unsafe fn contiguous<'a>(o: Operand, rows: usize, cols: usize) -> std::borrow::Cow<'a, [f32]> {
    use std::borrow::Cow;
    if o.col_stride == 1 && o.row_stride == cols {
        // SAFETY: rows x cols contiguous values inside the operand, which outlives
        // the caller's use of the result.
        return Cow::Borrowed(unsafe { std::slice::from_raw_parts(o.ptr, rows * cols) });
    }
    if o.row_stride == 1 && o.col_stride == rows {
        // SAFETY: the operand's storage is a contiguous cols x rows matrix.
        let src = unsafe { std::slice::from_raw_parts(o.ptr, rows * cols) };
        return Cow::Owned(crate::transpose::transposed_copy(src, cols, rows));
    }
    let mut out = Vec::with_capacity(rows * cols);
    for r in 0..rows {
        for c in 0..cols {
            // SAFETY: inside the operand, by the caller's promise.
            out.push(unsafe { *o.ptr.add(r * o.row_stride + c * o.col_stride) });
        }
    }
    Cow::Owned(out)
}

/// A [rows, cols] operand as bf16 rows of `cols_p` values (zeros past `cols`), `rows_p`
/// rows (zero rows past `rows`): the tiles' A layout, as neighbouring pairs (the first in
/// the low half).
///
/// SAFETY: o reaches rows x cols valid elements.
unsafe fn pack_rows(
    o: Operand,
    rows: usize,
    cols: usize,
    rows_p: usize,
    cols_p: usize,
) -> Vec<u32> {
    let mut out = if o.row_stride == 1 && o.col_stride == rows {
        // A transposed contiguous operand (the weight gradient's x^T): its storage S is
        // [cols, rows], and A's pair of columns (2q, 2q + 1) in row r is S's rows 2q and
        // 2q + 1 at r. So pairs of S's rows interleaved, then transposed as 32-bit pairs:
        // half the values of an f32 transpose.
        // SAFETY: the operand's storage is a contiguous cols x rows matrix.
        let src = unsafe { std::slice::from_raw_parts(o.ptr, rows * cols) };
        let pairs = pairs_of_rows(src, cols, rows, cols_p, rows);
        crate::transpose::transposed_copy_u32(&pairs, cols_p / 2, rows)
    } else {
        // SAFETY: the caller's promise.
        let src = unsafe { contiguous(o, rows, cols) };
        rows_as_pairs(&src, cols, cols_p)
    };
    out.resize(rows_p * cols_p / 2, 0);
    out
}

/// A [rows, cols] operand (rows: the summed dimension) as the tiles' B layout: row p
/// holds the pairs (rows 2p and 2p + 1, the first in the low half) of every column,
/// `cols_p` pairs a row (zeros past `cols`), `rows_p / 2` rows (zeros past `rows`).
///
/// SAFETY: o reaches rows x cols valid elements.
unsafe fn pack_pairs(
    o: Operand,
    rows: usize,
    cols: usize,
    rows_p: usize,
    cols_p: usize,
) -> Vec<u32> {
    if o.row_stride == 1 && o.col_stride == rows && cols == cols_p {
        // A transposed contiguous operand (the input gradient's W^T): its storage S is
        // [cols, rows], and the pair (2p, 2p + 1) of column c is S's neighbours at row c:
        // S's rows as neighbouring pairs, transposed.
        // SAFETY: the operand's storage is a contiguous cols x rows matrix.
        let src = unsafe { std::slice::from_raw_parts(o.ptr, rows * cols) };
        let pairs = rows_as_pairs(src, rows, rows_p);
        return crate::transpose::transposed_copy_u32(&pairs, cols, rows_p / 2);
    }
    // SAFETY: the caller's promise.
    let src = unsafe { contiguous(o, rows, cols) };
    pairs_of_rows(&src, rows, cols, rows_p, cols_p)
}

/// The rows of `src` (each `len` values) as neighbouring bf16 pairs (2i, 2i + 1), the
/// first in the low half, each row padded with zeros to `padded / 2` pairs.
fn rows_as_pairs(src: &[f32], len: usize, padded: usize) -> Vec<u32> {
    let (rows, width) = (src.len() / len, padded / 2);
    let mut out: Vec<u32> = Vec::with_capacity(rows * width);
    let spare = &mut out.spare_capacity_mut()[..rows * width];
    for (dst, row) in spare.chunks_exact_mut(width).zip(src.chunks_exact(len)) {
        row_pairs(dst, row);
    }
    // SAFETY: row_pairs wrote every one of the rows x width values.
    unsafe { out.set_len(rows * width) };
    out
}

/// The rows (2p, 2p + 1) of a row-major [rows, cols] matrix as bf16 pairs, the first in
/// the low half: `rows_p / 2` rows of `cols_p` pairs, zeros past `rows` and `cols`.
fn pairs_of_rows(src: &[f32], rows: usize, cols: usize, rows_p: usize, cols_p: usize) -> Vec<u32> {
    let filled = rows.div_ceil(2);
    let mut out: Vec<u32> = Vec::with_capacity(rows_p / 2 * cols_p);
    let zeros = vec![0f32; cols];
    let spare = &mut out.spare_capacity_mut()[..filled * cols_p];
    for (p, dst) in spare.chunks_exact_mut(cols_p).enumerate() {
        let first = &src[2 * p * cols..][..cols];
        let second = src
            .get((2 * p + 1) * cols..(2 * p + 2) * cols)
            .unwrap_or(&zeros);
        interleave(&mut dst[..cols], first, second);
        zero(&mut dst[cols..]);
    }
    // SAFETY: every one of the filled x cols_p values was written above.
    unsafe { out.set_len(filled * cols_p) };
    out.resize(rows_p / 2 * cols_p, 0);
    out
}

/// `dst` (every element written) = `row`'s neighbours (2i, 2i + 1) as bf16 pairs, the
/// first in the low half, zeros past the row's end.
fn row_pairs(dst: &mut [MaybeUninit<u32>], row: &[f32]) {
    let even = row.len() / 2;
    neighbours(&mut dst[..even], &row[..2 * even]);
    let mut rest = even;
    if row.len() % 2 == 1 {
        dst[even].write(to_bf16(row[row.len() - 1]) as u32);
        rest += 1;
    }
    zero(&mut dst[rest..]);
}

fn zero(dst: &mut [MaybeUninit<u32>]) {
    for d in dst {
        d.write(0);
    }
}

/// `dst[i]` = the pair (`src[2i]`, `src[2i + 1]`) in bf16, the first in the low half, with
/// the widest vectors this CPU has.
fn neighbours(dst: &mut [MaybeUninit<u32>], src: &[f32]) {
    crate::simd_dispatch::dispatch!(
        baseline,
        (dst: &mut [MaybeUninit<u32>], src: &[f32]),
        for (d, s) in dst.iter_mut().zip(src.chunks_exact(2)) {
            d.write(to_bf16(s[0]) as u32 | (to_bf16(s[1]) as u32) << 16);
        }
    )
}

/// `dst[i]` = the pair (`first[i]`, `second[i]`) in bf16, the first in the low half.
fn interleave(dst: &mut [MaybeUninit<u32>], first: &[f32], second: &[f32]) {
    crate::simd_dispatch::dispatch!(
        baseline,
        (dst: &mut [MaybeUninit<u32>], first: &[f32], second: &[f32]),
        for ((d, a), b) in dst.iter_mut().zip(first).zip(second) {
            d.write(to_bf16(*a) as u32 | (to_bf16(*b) as u32) << 16);
        }
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::flex_matrix::{row_major, transposed};
    use crate::testutil::{on_threads, pseudo};

    #[test]
    fn rounding_is_to_nearest_even() {
        assert_eq!(to_bf16(1.0), 0x3f80);
        // 1 + 2^-8 is halfway between 1 and 1 + 2^-7: to the even one, 1.
        assert_eq!(to_bf16(1.0 + 2f32.powi(-8)), 0x3f80);
        // 1 + 3 * 2^-8 is halfway between 1 + 2^-7 and 1 + 2^-6: to the even one.
        assert_eq!(
            from_bf16(to_bf16(1.0 + 3.0 * 2f32.powi(-8))),
            1.0 + 2f32.powi(-6)
        );
        assert_eq!(
            from_bf16(to_bf16(1.0 + 2f32.powi(-8) + 2f32.powi(-20))),
            1.0 + 2f32.powi(-7)
        );
        assert_eq!(to_bf16(-0.0), 0x8000);
        assert_eq!(from_bf16(to_bf16(f32::INFINITY)), f32::INFINITY);
        assert_eq!(from_bf16(to_bf16(f32::MAX)), f32::INFINITY);
        assert!(from_bf16(to_bf16(f32::NAN)).is_nan());
        assert!(from_bf16(to_bf16(-f32::NAN)).is_nan());
        // A NaN whose payload sits in the low 16 bits stays a NaN.
        assert!(from_bf16(to_bf16(f32::from_bits(0x7f80_0001))).is_nan());
        for v in pseudo(1000, 5) {
            let r = from_bf16(to_bf16(v * 100.0));
            assert!((r - v * 100.0).abs() <= (v * 100.0).abs() * 2f32.powi(-8));
        }
    }

    /// Products on rounded operands summed in f64: the reference.
    fn reference(a: &[f32], b: &[f32], (m, n, k): (usize, usize, usize)) -> Vec<f64> {
        let mut out = vec![0f64; m * n];
        for i in 0..m {
            for t in 0..k {
                let x = from_bf16(to_bf16(a[i * k + t])) as f64;
                for j in 0..n {
                    out[i * n + j] += x * from_bf16(to_bf16(b[t * n + j])) as f64;
                }
            }
        }
        out
    }

    /// Every operand layout and shapes that fill and do not fill the tiles, on both
    /// engines (AMX where this CPU has it): the products of the rounded operands, to
    /// f32's rounding of the sums; the same bits for 1, 2 and 3 threads.
    #[test]
    fn products_are_the_rounded_operands_products() {
        if !crate::amx::available() {
            println!("SKIPPED (AMX engine only): this CPU or kernel gives no AMX tiles");
        }
        let engines: &[bool] = if crate::amx::available() {
            &[false, true]
        } else {
            &[false]
        };
        for &amx in engines {
            check_products(amx);
        }
    }

    fn check_products(amx: bool) {
        for (m, n, k) in [(64, 64, 64), (96, 512, 256), (37, 45, 70), (33, 100, 32)] {
            let a = pseudo(m * k, 1);
            let b = pseudo(k * n, 2);
            let at: Vec<f32> = (0..k * m).map(|i| a[(i % m) * k + i / m]).collect();
            let bt: Vec<f32> = (0..n * k).map(|i| b[(i % k) * n + i / k]).collect();
            let want = reference(&a, &b, (m, n, k));
            for (lhs, rhs, what) in [
                (row_major(&a, k), row_major(&b, n), "row-major"),
                (
                    transposed(row_major(&at, m)),
                    row_major(&b, n),
                    "lhs transposed",
                ),
                (
                    row_major(&a, k),
                    transposed(row_major(&bt, k)),
                    "rhs transposed",
                ),
            ] {
                let first = unsafe { product_on((m, n, k), lhs, rhs, amx) };
                for (i, (g, w)) in first.iter().zip(&want).enumerate() {
                    let scale: f64 = (0..k)
                        .map(|t| (a[(i / n) * k + t] * b[t * n + i % n]).abs() as f64)
                        .sum();
                    // f32 sums of k terms: within k roundings of the terms' magnitude.
                    assert!(
                        (*g as f64 - w).abs() <= k as f64 * 2f64.powi(-24) * scale + 1e-30,
                        "{m}x{n}x{k} {what}, AMX {amx}: element {i}: {g} against {w}"
                    );
                }
                for threads in [1, 2, 3] {
                    let again =
                        on_threads(threads, || unsafe { product_on((m, n, k), lhs, rhs, amx) });
                    assert!(
                        again
                            .iter()
                            .zip(&first)
                            .all(|(x, y)| x.to_bits() == y.to_bits()),
                        "{m}x{n}x{k} {what}: {threads} threads"
                    );
                }
            }
        }
    }

    #[test]
    fn the_setting_is_the_threads_and_restored() {
        assert!(!takes_bf16(64, 64, 64));
        with_products(Products::Bf16, || {
            assert!(takes_bf16(64, 64, 64));
            assert!(!takes_bf16(64, 4, 64), "an output layer stays f32");
            assert!(!takes_bf16(64, 64, 4));
            let other = std::thread::spawn(|| takes_bf16(64, 64, 64))
                .join()
                .unwrap();
            assert!(!other, "another thread keeps its own setting");
        });
        assert!(!takes_bf16(64, 64, 64));
        let _ = std::panic::catch_unwind(|| with_products(Products::Bf16, || panic!("x")));
        assert!(!takes_bf16(64, 64, 64), "restored after a panic");
        assert_eq!("bf16".parse::<Products>(), Ok(Products::Bf16));
        assert!("f16".parse::<Products>().is_err());
    }
}
