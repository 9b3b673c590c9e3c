//! Ground truth of synthetic frames from their rendered depth, shared by the examples.

use image::{ImageBuffer, Luma};
use std::path::Path;

pub type Depth = ImageBuffer<Luma<u16>, Vec<u16>>;

/// The rendered depth (`<stem>.depth.png`, camera-frame z in mm) of a 7-Scenes-layout
/// frame named `<stem>.color.png` under the scene root.
pub fn load_depth(root: &Path, name: &str) -> Result<Depth, image::ImageError> {
    let stem = name.strip_suffix(".color.png").unwrap_or(name);
    Ok(image::open(root.join(format!("{stem}.depth.png")))?.to_luma16())
}

/// Depth (metres) at a COLMAP pixel position: inverse depth interpolated bilinearly
/// (exact on planes); None off the image, on missing depth, or where the 2x2
/// neighbourhood spans more than 1 % (a depth edge).
pub fn depth_at(depth: &Depth, xy: [f64; 2]) -> Option<f64> {
    // COLMAP pixel centres at +0.5.
    let (fx, fy) = (xy[0] - 0.5, xy[1] - 0.5);
    let (x0, y0) = (fx.floor(), fy.floor());
    let (ax, ay) = (fx - x0, fy - y0);
    let mut inv = 0.0;
    let (mut lo, mut hi) = (f64::INFINITY, 0f64);
    for (dx, dy, w) in [
        (0.0, 0.0, (1.0 - ax) * (1.0 - ay)),
        (1.0, 0.0, ax * (1.0 - ay)),
        (0.0, 1.0, (1.0 - ax) * ay),
        (1.0, 1.0, ax * ay),
    ] {
        let (x, y) = (x0 + dx, y0 + dy);
        if x < 0.0 || y < 0.0 || x >= depth.width() as f64 || y >= depth.height() as f64 {
            return None;
        }
        let d = depth.get_pixel(x as u32, y as u32)[0];
        if d == 0 || d == u16::MAX {
            return None;
        }
        let z = d as f64 / 1000.0;
        lo = lo.min(z);
        hi = hi.max(z);
        inv += w / z;
    }
    (hi <= lo * 1.01).then(|| 1.0 / inv)
}
