//! Seeded test images: the same arguments give the same pixels and the same file bytes.

use image::{ImageBuffer, ImageFormat, Luma, Rgb, RgbImage};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::path::Path;

/// An RGB pattern of `w` x `h` pixels: pixel (x, y) is (7x + seed, 5y + seed, x xor y),
/// each modulo 256.
pub fn rgb(w: u32, h: u32, seed: u32) -> RgbImage {
    ImageBuffer::from_fn(w, h, |x, y| {
        Rgb([(x * 7 + seed) as u8, (y * 5 + seed) as u8, (x ^ y) as u8])
    })
}

/// Writes [`rgb`]`(w, h, seed)` to `path`, creating its folder, in the format its
/// extension names (`.png`, `.jpg` ...).
pub fn write_rgb(path: &Path, w: u32, h: u32, seed: u32) {
    save(path, &rgb(w, h, seed));
}

/// Writes a 16-bit single-channel PNG (a depth map) of `w` x `h` pixels whose pixel
/// (x, y) is `value(x, y)`, called in row-major order; creates the folder.
pub fn write_depth(path: &Path, w: u32, h: u32, mut value: impl FnMut(u32, u32) -> u16) {
    let img: ImageBuffer<Luma<u16>, Vec<u16>> =
        ImageBuffer::from_fn(w, h, |x, y| Luma([value(x, y)]));
    save(path, &img);
}

/// Saves `img` to `path` in the format its extension names, creating the folder.
pub fn save<P>(path: &Path, img: &ImageBuffer<P, Vec<P::Subpixel>>)
where
    P: image::PixelWithColorType,
    [P::Subpixel]: image::EncodableLayout,
{
    if let Some(parent) = path.parent() {
        std::fs::create_dir_all(parent)
            .unwrap_or_else(|e| panic!("creating {}: {e}", parent.display()));
    }
    img.save(path)
        .unwrap_or_else(|e| panic!("writing {}: {e}", path.display()));
}

/// An encoded (PNG or JPEG) RGB image of `w` x `h` pixels: a gradient plus noise seeded
/// by `seed`.
pub fn noisy_rgb_bytes(w: u32, h: u32, seed: u64, format: ImageFormat) -> Vec<u8> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let img = RgbImage::from_fn(w, h, |x, y| {
        let n: u8 = rng.random_range(0..32);
        Rgb([
            (x % 256) as u8 ^ n,
            (y % 256) as u8,
            ((x + y) % 256) as u8 | n,
        ])
    });
    let mut out = std::io::Cursor::new(Vec::new());
    img.write_to(&mut out, format).expect("encode test image");
    out.into_inner()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn writers_are_deterministic_and_follow_the_extension() {
        let dir = tempfile::tempdir().unwrap();
        let (a, b) = (dir.path().join("x/a.png"), dir.path().join("y/b.png"));
        write_rgb(&a, 9, 7, 3);
        write_rgb(&b, 9, 7, 3);
        assert_eq!(std::fs::read(&a).unwrap(), std::fs::read(&b).unwrap());
        assert_eq!(image::open(&a).unwrap().to_rgb8(), rgb(9, 7, 3));
        let jpg = dir.path().join("c.jpg");
        write_rgb(&jpg, 9, 7, 3);
        assert_eq!(
            ImageFormat::from_path(&jpg).unwrap(),
            image::guess_format(&std::fs::read(&jpg).unwrap()).unwrap()
        );
        let depth = dir.path().join("d.png");
        write_depth(&depth, 4, 3, |x, y| (x * 1000 + y) as u16);
        let d = image::open(&depth).unwrap().to_luma16();
        assert_eq!(d.get_pixel(3, 2).0, [3002]);
        assert_eq!(
            noisy_rgb_bytes(8, 8, 5, ImageFormat::Png),
            noisy_rgb_bytes(8, 8, 5, ImageFormat::Png)
        );
        assert_ne!(
            noisy_rgb_bytes(8, 8, 5, ImageFormat::Png),
            noisy_rgb_bytes(8, 8, 6, ImageFormat::Png)
        );
    }
}
