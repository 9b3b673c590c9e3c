//! Gaussian sub-sampling (IPOL paper, section "Image scaling"): the image is resampled to
//! `scale` times its size with a Gaussian of standard deviation `sigma_scale / scale`
//! (`sigma_scale` when `scale >= 1`), which both removes aliasing and interpolates at the
//! non-integer sample positions.
//!
//! The sums run in the same order as the reference C code (x pass first, kernel taps in
//! increasing order), so the resampled values are bit-identical to pytlsd's: every later
//! decision (thresholds, bins, alignment) depends on them.

use crate::grid::Grid;

/// `prec` of the reference code: the kernel half-width `h` is chosen so that the first
/// dropped tap is at most 10^-3 of the central one, `h = ceil(sigma * sqrt(2 prec ln 10))`.
const KERNEL_PRECISION: f64 = 3.0;

/// Fills `kernel` with a normalised sampled Gaussian of standard deviation `sigma`
/// centred at (fractional) index `mean`.
fn gaussian_kernel(kernel: &mut [f64], sigma: f64, mean: f64) {
    let mut sum = 0.0;
    for (i, k) in kernel.iter_mut().enumerate() {
        let val = (i as f64 - mean) / sigma;
        *k = (-0.5 * val * val).exp();
        sum += *k;
    }
    // The reference normalises only for a non-negative sum (always true here); kept so a
    // NaN sum leaves the kernel as the reference would.
    if sum >= 0.0 {
        for k in kernel.iter_mut() {
            *k /= sum;
        }
    }
}

/// Index `j` folded into `0..size` by whole-sample symmetry (`-1 -> 0`, `size -> size-1`),
/// the reference's boundary condition.
#[inline]
fn mirror(mut j: i64, size: usize) -> usize {
    let double = 2 * size as i64;
    while j < 0 {
        j += double;
    }
    while j >= double {
        j -= double;
    }
    if j >= size as i64 {
        j = double - 1 - j;
    }
    j as usize
}

/// The size of the resampled image along an axis of `size` pixels.
pub(crate) fn scaled_size(size: usize, scale: f64) -> usize {
    (size as f64 * scale).ceil() as usize
}

/// Resamples `input` to `ceil(width * scale) x ceil(height * scale)`. Sample `x` of the
/// output sits at `x / scale` in the input, pixel centres being at integer coordinates.
pub(crate) fn gaussian_sampler(input: &Grid<f64>, scale: f64, sigma_scale: f64) -> Grid<f64> {
    let out_w = scaled_size(input.width, scale);
    let out_h = scaled_size(input.height, scale);
    let sigma = if scale < 1.0 {
        sigma_scale / scale
    } else {
        sigma_scale
    };
    let h = (sigma * (2.0 * KERNEL_PRECISION * 10f64.ln()).sqrt()).ceil() as i64;
    let mut kernel = vec![0.0; (1 + 2 * h) as usize];

    // x pass: input rows, output columns.
    let mut aux = Grid::filled(out_w, input.height, 0.0);
    for x in 0..out_w {
        let taps = kernel_at(&mut kernel, sigma, h, x, scale, input.width);
        for y in 0..input.height {
            let row = &input.data[y * input.width..(y + 1) * input.width];
            let mut sum = 0.0;
            for (&j, &k) in taps.iter().zip(&kernel) {
                sum += row[j] * k;
            }
            aux.set(x, y, sum);
        }
    }

    // y pass: the x pass's columns, output rows.
    let mut out = Grid::filled(out_w, out_h, 0.0);
    for y in 0..out_h {
        let taps = kernel_at(&mut kernel, sigma, h, y, scale, input.height);
        for x in 0..out_w {
            let mut sum = 0.0;
            for (&j, &k) in taps.iter().zip(&kernel) {
                sum += aux.get(x, j) * k;
            }
            out.set(x, y, sum);
        }
    }
    out
}

/// The kernel (into `kernel`) and the mirrored input indices it weighs for output sample
/// `i` of an axis of `n` input pixels: the input pixel whose cell (centre +- 0.5) holds
/// `i / scale`. The kernel is recomputed for each sample because the fractional offset
/// differs.
fn kernel_at(kernel: &mut [f64], sigma: f64, h: i64, i: usize, scale: f64, n: usize) -> Vec<usize> {
    let pos = i as f64 / scale;
    let centre = (pos + 0.5).floor() as i64;
    gaussian_kernel(kernel, sigma, h as f64 + pos - centre as f64);
    (0..kernel.len())
        .map(|k| mirror(centre - h + k as i64, n))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_kernel_is_normalised_and_centred() {
        let mut k = vec![0.0; 7];
        gaussian_kernel(&mut k, 0.75, 3.0);
        assert!((k.iter().sum::<f64>() - 1.0).abs() < 1e-15);
        for i in 0..3 {
            assert_eq!(k[i], k[6 - i], "symmetric about the centre");
        }
        assert!(k[3] > k[2] && k[2] > k[1]);
    }

    #[test]
    fn mirroring_repeats_the_border_sample() {
        assert_eq!(mirror(-1, 5), 0);
        assert_eq!(mirror(-2, 5), 1);
        assert_eq!(mirror(5, 5), 4);
        assert_eq!(mirror(6, 5), 3);
        assert_eq!(mirror(2, 5), 2);
        // Far outside (tiny images with a wide kernel) wraps the period 2 * size.
        assert_eq!(mirror(-11, 5), 0);
        assert_eq!(mirror(-13, 5), 2);
        assert_eq!(mirror(1, 1), 0);
    }

    #[test]
    fn a_constant_image_stays_constant_at_the_new_size() {
        let img = Grid::filled(10, 7, 42.0);
        let out = gaussian_sampler(&img, 0.8, 0.6);
        assert_eq!((out.width, out.height), (8, 6));
        for v in out.data {
            assert!((v - 42.0).abs() < 1e-12, "{v}");
        }
    }
}
