//! From the dense maps to keypoints and descriptors (docs/method.md section 2b):
//! non-maximum suppression, threshold, border, top-k, and bilinear sampling of the 1/8
//! descriptor map. Plain Rust on the host: cheap next to the network, and exact.
//!
//! Coordinates here are pixel indices of the network's input (centre of the top-left
//! pixel at (0, 0)); `frontend.rs` converts to and from COLMAP pixels of the original
//! image.

use crate::net::DenseMaps;

/// Sliding maximum over a window of `2 r + 1` along rows then columns (the window is
/// clipped at the border, as a max-pool padded with -inf).
fn max_filter(v: &[f32], w: usize, h: usize, r: usize) -> Vec<f32> {
    let mut rows = vec![0f32; v.len()];
    for y in 0..h {
        let row = &v[y * w..(y + 1) * w];
        for x in 0..w {
            let (a, b) = (x.saturating_sub(r), (x + r).min(w - 1));
            rows[y * w + x] = row[a..=b].iter().copied().fold(f32::NEG_INFINITY, f32::max);
        }
    }
    let mut out = vec![0f32; v.len()];
    for y in 0..h {
        let (a, b) = (y.saturating_sub(r), (y + r).min(h - 1));
        for x in 0..w {
            out[y * w + x] = (a..=b)
                .map(|yy| rows[yy * w + x])
                .fold(f32::NEG_INFINITY, f32::max);
        }
    }
    out
}

/// Non-maximum suppression with radius `r`: a pixel is kept when it is the maximum of
/// its (2r + 1)^2 window; then, twice, the pixels within r of a kept one are suppressed
/// and the maxima among the remaining scores are added. Suppressed pixels score 0.
pub fn nms(scores: &[f32], w: usize, h: usize, r: usize) -> Vec<f32> {
    if scores.is_empty() {
        return Vec::new();
    }
    let local_max = |s: &[f32]| -> Vec<bool> {
        let m = max_filter(s, w, h, r);
        s.iter().zip(&m).map(|(a, b)| a == b).collect()
    };
    let mut keep = local_max(scores);
    for _ in 0..2 {
        let as_f: Vec<f32> = keep.iter().map(|&k| if k { 1.0 } else { 0.0 }).collect();
        let near = max_filter(&as_f, w, h, r);
        let suppressed: Vec<bool> = near.iter().map(|&v| v > 0.0).collect();
        let rest: Vec<f32> = scores
            .iter()
            .zip(&suppressed)
            .map(|(&s, &sup)| if sup { 0.0 } else { s })
            .collect();
        let new_max = local_max(&rest);
        for i in 0..keep.len() {
            keep[i] |= new_max[i] && !suppressed[i];
        }
    }
    scores
        .iter()
        .zip(&keep)
        .map(|(&s, &k)| if k { s } else { 0.0 })
        .collect()
}

/// Keypoints of a score map: NMS, scores above `threshold`, at least `border` pixels
/// from every edge of the map, the `max_keypoints` strongest. Returns (x, y, score) in
/// pixel indices, strongest first (ties: row-major order).
pub fn select(
    maps: &DenseMaps,
    nms_radius: usize,
    threshold: f32,
    border: usize,
    max_keypoints: usize,
) -> Vec<(usize, usize, f32)> {
    let (w, h) = (maps.score_width, maps.score_height);
    let s = nms(&maps.scores, w, h, nms_radius);
    let mut kps: Vec<(usize, usize, f32)> = Vec::new();
    for y in border..h.saturating_sub(border) {
        for x in border..w.saturating_sub(border) {
            let v = s[y * w + x];
            if v > threshold {
                kps.push((x, y, v));
            }
        }
    }
    // Stable sort: equal scores keep row-major order.
    kps.sort_by(|a, b| b.2.total_cmp(&a.2));
    kps.truncate(max_keypoints);
    kps
}

/// The descriptor at pixel-index position (x, y) of the network input: bilinear in the
/// Wc x Hc map at map position u = (x - 3.5) / (8 Wc - 4.5) (Wc - 1) (v likewise), which
/// is SuperPoint's released sampling rule (docs/method.md section 2b: normalised grid
/// coordinates with align_corners); map corners outside the map count as zero; the
/// result is L2-normalised. Appends D values to `out`.
pub fn sample_descriptor(maps: &DenseMaps, x: f64, y: f64, out: &mut Vec<f32>) {
    let (wc, hc) = (maps.cell_width, maps.cell_height);
    let c = maps.descriptors.len().checked_div(wc * hc).unwrap_or(0);
    let start = out.len();
    out.resize(start + c, 0.0);
    if c == 0 {
        return;
    }
    let u = (x - 3.5) / (8.0 * wc as f64 - 4.5) * (wc - 1) as f64;
    let v = (y - 3.5) / (8.0 * hc as f64 - 4.5) * (hc - 1) as f64;
    let (u0, v0) = (u.floor(), v.floor());
    let (fu, fv) = ((u - u0) as f32, (v - v0) as f32);
    let corners = [
        (u0, v0, (1.0 - fu) * (1.0 - fv)),
        (u0 + 1.0, v0, fu * (1.0 - fv)),
        (u0, v0 + 1.0, (1.0 - fu) * fv),
        (u0 + 1.0, v0 + 1.0, fu * fv),
    ];
    let dst = &mut out[start..];
    let plane = wc * hc;
    for (cu, cv, weight) in corners {
        if cu < 0.0 || cv < 0.0 || cu > (wc - 1) as f64 || cv > (hc - 1) as f64 || weight == 0.0 {
            continue;
        }
        let at = cv as usize * wc + cu as usize;
        for (k, d) in dst.iter_mut().enumerate() {
            *d += weight * maps.descriptors[k * plane + at];
        }
    }
    let norm = dst.iter().map(|v| v * v).sum::<f32>().sqrt().max(1e-12);
    dst.iter_mut().for_each(|v| *v /= norm);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nms_keeps_isolated_maxima_and_suppresses_their_neighbours() {
        let (w, h) = (12, 9);
        let mut s = vec![0.01f32; w * h];
        s[4 * w + 4] = 0.9;
        s[4 * w + 6] = 0.8; // within r = 3 of the first: suppressed
        s[4 * w + 10] = 0.7; // 6 px away: a maximum of its own after suppression
        let out = nms(&s, w, h, 3);
        assert_eq!(out[4 * w + 4], 0.9);
        assert_eq!(out[4 * w + 6], 0.0);
        assert_eq!(out[4 * w + 10], 0.7);
    }

    #[test]
    fn sampling_at_the_first_cell_centre_returns_that_cell() {
        let (wc, hc, c) = (3, 2, 4);
        let descriptors: Vec<f32> = (0..c * wc * hc).map(|i| (i % 7) as f32 + 1.0).collect();
        let maps = DenseMaps {
            scores: vec![0.0; 64 * wc * hc],
            score_width: 8 * wc,
            score_height: 8 * hc,
            descriptors: descriptors.clone(),
            cell_width: wc,
            cell_height: hc,
        };
        let mut out = Vec::new();
        sample_descriptor(&maps, 3.5, 3.5, &mut out);
        let cell: Vec<f32> = (0..c).map(|k| descriptors[k * wc * hc]).collect();
        let n = cell.iter().map(|v| v * v).sum::<f32>().sqrt();
        for (a, b) in out.iter().zip(&cell) {
            assert!((a - b / n).abs() < 1e-6);
        }
    }
}
