//! LSD, the Line Segment Detector of R. Grompone von Gioi, J. Jakubowicz, J.-M. Morel and
//! G. Randall ("LSD: a Line Segment Detector", Image Processing On Line, 2012), in pure
//! Rust, as pytlsd 0.0.2 runs it: the LSD that LIMAP detects its 2D lines with
//! (`pytlsd.lsd(grey)`), on which the product's line maps are trained.
//!
//! On the same grey image, [`detect`] with [`Params::pytlsd`] returns pytlsd's segments:
//! the same number, in the same order, with bit-identical endpoints (pytlsd hands them
//! out as `float32`; see `tests/pytlsd.rs`). To get there it follows the reference C
//! arithmetic operation by operation (sum orders, the truncated pi constants, the
//! reciprocal table of the NFA) and pytlsd's departures from the IPOL code:
//! - the 2x2 gradient window sits up-left of its pixel and the level-line angle is the
//!   opposite one (`gradient`), so segments run the other way round;
//! - the half-pixel offset the IPOL code adds to its output is not added;
//! - the density refinement is switched off (`refine`), whatever `density_th` says.
//!
//! # Coordinates
//!
//! As pytlsd returns them: `x` to the right, `y` down, in pixels of the input image, the
//! scaled image's sample `i` mapped to `i / scale`, with the centre of the input's
//! top-left pixel at (0, 0). Because pytlsd's gradient sits half a pixel up-left of the
//! sample it is stored at and pytlsd does not add the half pixel back, a step edge
//! between pixel columns 79 and 80 (x = 79.5 with centres at integers, 80.0 in COLMAP's
//! convention, where the top-left pixel's centre is (0.5, 0.5)) comes out at x ~ 80.1:
//! the output is already close to COLMAP's convention (0.5 / scale - 0.5 = +0.125 px of
//! systematic offset at scale 0.8). LIMAP uses these numbers unchanged with its COLMAP
//! cameras, so a caller that wants LIMAP's segments must not add 0.5.
//!
//! Deterministic and single-threaded; the work is a few array passes plus region growing.

mod angle;
mod gaussian;
mod gradient;
mod grid;
mod improve;
mod nfa;
mod rect;
mod refine;
mod region;

use grid::Grid;
use region::Region;

/// LSD's parameters (names as in the IPOL paper and code).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Params {
    /// The image is Gaussian-resampled to `scale` times its size first (1 = not at all).
    pub scale: f64,
    /// The Gaussian's standard deviation is `sigma_scale / scale` (when `scale < 1`).
    pub sigma_scale: f64,
    /// Bound on the gradient quantisation error; with `ang_th` it sets the gradient norm
    /// threshold `quant / sin(ang_th)` (5.2262518595055063 for the defaults, the value
    /// pytlsd hard-codes).
    pub quant: f64,
    /// Angle tolerance, degrees, in (0, 180).
    pub ang_th: f64,
    /// Detection threshold: segments with `-log10(NFA) > log_eps` are kept.
    pub log_eps: f64,
    /// Minimal fraction of a rectangle its region must fill, in [0, 1]; 0 disables the
    /// refinement (pytlsd).
    pub density_th: f64,
    /// Number of bins of the gradient-norm pseudo-ordering.
    pub n_bins: usize,
}

impl Default for Params {
    /// The paper's defaults: scale 0.8, sigma_scale 0.6, quant 2, ang_th 22.5, log_eps 0,
    /// density_th 0.7, n_bins 1024.
    fn default() -> Self {
        Self {
            scale: 0.8,
            sigma_scale: 0.6,
            quant: 2.0,
            ang_th: 22.5,
            log_eps: 0.0,
            density_th: 0.7,
            n_bins: 1024,
        }
    }
}

impl Params {
    /// What `pytlsd.lsd(img)` runs, with LIMAP's call (all defaults): the paper's
    /// parameters without the density refinement (`density_th` 0).
    pub fn pytlsd() -> Self {
        Self {
            density_th: 0.0,
            ..Self::default()
        }
    }
}

/// A detected segment.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Segment {
    /// First endpoint, input-image pixels (see the crate docs for the convention).
    pub x1: f64,
    pub y1: f64,
    /// Second endpoint. Going from the first endpoint to the second, the brighter side is
    /// on the right as seen on screen (x right, y down): pytlsd's orientation, the
    /// opposite of the IPOL code's.
    pub x2: f64,
    pub y2: f64,
    /// Rectangle width, input-image pixels.
    pub width: f64,
    /// Angle precision as a probability (`ang_th / 180`, or a power-of-two fraction of
    /// it after improvement): the fifth column pytlsd returns, which LIMAP calls `score`.
    pub p: f64,
    /// `-log10(NFA)`: larger is more meaningful; always `> log_eps`.
    pub log_nfa: f64,
}

impl Segment {
    /// Endpoint distance, pixels.
    pub fn length(&self) -> f64 {
        (self.x2 - self.x1).hypot(self.y2 - self.y1)
    }
}

/// Why [`detect`] refused its input.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LsdError {
    #[error("empty image: {width} x {height} pixels")]
    EmptyImage { width: usize, height: usize },
    #[error("image of {width} x {height} pixels needs {} values, got {len}", width * height)]
    SizeMismatch {
        width: usize,
        height: usize,
        len: usize,
    },
    #[error("invalid LSD parameter: {0}")]
    InvalidParams(String),
}

/// Detects the segments of a grey image of `width` x `height` 8-bit pixels, row-major
/// (`pixels[x + y * width]`). The values are taken as they are (pytlsd converts its
/// `uint8` array to `float64` the same way).
pub fn detect(
    pixels: &[u8],
    width: usize,
    height: usize,
    params: &Params,
) -> Result<Vec<Segment>, LsdError> {
    check_size(pixels.len(), width, height)?;
    let data = pixels.iter().map(|&v| f64::from(v)).collect();
    detect_grid(
        Grid {
            data,
            width,
            height,
        },
        params,
    )
}

/// [`detect`] for a grey image of `f64` values (any range: the threshold is absolute,
/// tuned for 0..255).
pub fn detect_f64(
    pixels: &[f64],
    width: usize,
    height: usize,
    params: &Params,
) -> Result<Vec<Segment>, LsdError> {
    check_size(pixels.len(), width, height)?;
    detect_grid(
        Grid {
            data: pixels.to_vec(),
            width,
            height,
        },
        params,
    )
}

fn check_size(len: usize, width: usize, height: usize) -> Result<(), LsdError> {
    if width == 0 || height == 0 {
        return Err(LsdError::EmptyImage { width, height });
    }
    match width.checked_mul(height) {
        Some(n) if n == len && n <= u32::MAX as usize => Ok(()),
        _ => Err(LsdError::SizeMismatch { width, height, len }),
    }
}

fn check_params(p: &Params) -> Result<(), LsdError> {
    let bad = |what: &str| Err(LsdError::InvalidParams(what.to_string()));
    if !(p.scale > 0.0) || !p.scale.is_finite() {
        return bad("scale must be positive");
    }
    if !(p.sigma_scale > 0.0) || !p.sigma_scale.is_finite() {
        return bad("sigma_scale must be positive");
    }
    if !(p.quant >= 0.0) {
        return bad("quant must be non-negative");
    }
    if !(p.ang_th > 0.0 && p.ang_th < 180.0) {
        return bad("ang_th must be in (0, 180) degrees");
    }
    if p.log_eps.is_nan() {
        return bad("log_eps is NaN");
    }
    if !(p.density_th >= 0.0 && p.density_th <= 1.0) {
        return bad("density_th must be in [0, 1]");
    }
    if p.n_bins == 0 {
        return bad("n_bins must be positive");
    }
    Ok(())
}

/// The detector proper (IPOL paper, Algorithm 1).
fn detect_grid(image: Grid<f64>, params: &Params) -> Result<Vec<Segment>, LsdError> {
    check_params(params)?;
    let prec = std::f64::consts::PI * params.ang_th / 180.0;
    let p = params.ang_th / 180.0;
    // Gradient norm below which the angle error from 8-bit quantisation could exceed the
    // tolerance.
    let rho = params.quant / prec.sin();

    let scaled = if params.scale != 1.0 {
        gaussian::gaussian_sampler(&image, params.scale, params.sigma_scale)
    } else {
        image
    };
    let ll = gradient::level_lines(&scaled, rho, params.n_bins);
    let (w, h) = (ll.angles.width, ll.angles.height);

    // Number of tests: 11 angle precisions times (w h)^(5/2) rectangles.
    let log_nt = 5.0 * ((w as f64).log10() + (h as f64).log10()) / 2.0 + 11f64.log10();
    // Fewer aligned pixels than this cannot be meaningful even if all aligned.
    let min_reg_size = (-log_nt / p.log10()) as usize;

    let mut used = Grid::filled(w, h, false);
    let mut region = Region {
        points: Vec::new(),
        angle: 0.0,
    };
    let mut out = Vec::new();
    for &(sx, sy) in &ll.order {
        let (sx, sy) = (sx as usize, sy as usize);
        if used.get(sx, sy) || ll.angles.get(sx, sy) == gradient::NOTDEF {
            continue;
        }
        region::region_grow(sx, sy, &ll.angles, &mut used, prec, &mut region);
        // The rectangle needs two pixels (the reference aborts the process on one, which
        // only images of two scaled pixels or fewer can reach).
        if region.points.len() < min_reg_size.max(2) {
            continue;
        }
        let mut rec = region::region_to_rect(&region, &ll.modgrad, prec, p);
        if params.density_th > 0.0
            && !refine::refine(
                &mut region,
                &mut rec,
                &ll.modgrad,
                &ll.angles,
                &mut used,
                params.density_th,
            )
        {
            continue;
        }
        let log_nfa = improve::rect_improve(&mut rec, &ll.angles, log_nt, params.log_eps);
        if log_nfa <= params.log_eps {
            continue;
        }
        let mut seg = Segment {
            x1: rec.x1,
            y1: rec.y1,
            x2: rec.x2,
            y2: rec.y2,
            width: rec.width,
            p: rec.p,
            log_nfa,
        };
        if params.scale != 1.0 {
            seg.x1 /= params.scale;
            seg.y1 /= params.scale;
            seg.x2 /= params.scale;
            seg.y2 /= params.scale;
            seg.width /= params.scale;
        }
        out.push(seg);
    }
    Ok(out)
}

#[cfg(test)]
mod tests;
