//! Images are read within bounds and decoded under the pixel limit
//! (crates/fileio/src/image.rs): `/dev/zero`, an oversized PNG and a sparse file of
//! gigabytes are refused by name before their pixels are read or decoded.

use features::{FeatureError, decode_gray, load_gray};
use std::io::Write;
use std::path::Path;

/// A real, valid PNG of 20000 x 20000 black pixels (400 MP, eight times the default
/// limit): about 1 MB of compressed zeros, as the example.
fn oversized_png() -> Vec<u8> {
    use image::ImageEncoder;
    use image::codecs::png::{CompressionType, FilterType, PngEncoder};
    let (w, h) = (20_000u32, 20_000u32);
    let zeros = vec![0u8; w as usize * h as usize];
    let mut png = Vec::new();
    PngEncoder::new_with_quality(&mut png, CompressionType::Fast, FilterType::NoFilter)
        .write_image(&zeros, w, h, image::ExtendedColorType::L8)
        .unwrap();
    png
}

#[test]
fn an_oversized_png_is_refused_before_decoding_naming_its_size_and_the_limit() {
    let png = oversized_png();
    assert!(png.len() < 2 << 20, "{} bytes", png.len());
    let e = decode_gray(&png).unwrap_err();
    assert!(matches!(e, FeatureError::Limit(_)), "{e:?}");
    assert_eq!(
        e.to_string(),
        "the PNG is too large: 20000x20000 is 400000000 pixels, the limit is 50000000 \
         pixels (set PL2MAP_MAX_IMAGE_PIXELS to change it)"
    );
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("huge.png");
    std::fs::write(&path, &png).unwrap();
    let text = load_gray(&path).unwrap_err().to_string();
    assert!(
        text.starts_with(&format!(
            "{}: cannot read image: the PNG is too large",
            path.display()
        )) && text.contains("the limit is 50000000 pixels"),
        "{text}"
    );
    assert!(!text.contains("OpenCV"), "{text}");
}

#[test]
fn dev_zero_is_refused_by_name_without_reading_it() {
    let zero = Path::new("/dev/zero");
    if !zero.exists() {
        return;
    }
    let e = load_gray(zero).unwrap_err();
    assert!(matches!(e, FeatureError::ReadImage(_)), "{e:?}");
    assert_eq!(
        e.to_string(),
        "/dev/zero: cannot read image: not a regular file but a device: an image must be a \
         PNG or JPEG file"
    );
}

#[test]
fn a_sparse_file_of_3_gb_behind_a_small_png_header_is_refused_unread() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("sparse.png");
    let mut small = Vec::new();
    image::GrayImage::new(16, 12)
        .write_to(
            &mut std::io::Cursor::new(&mut small),
            image::ImageFormat::Png,
        )
        .unwrap();
    let mut f = std::fs::File::create(&path).unwrap();
    f.write_all(&small).unwrap();
    // A hole: no disk used, and reading it whole would take gigabytes of memory.
    f.set_len(3 << 30).unwrap();
    drop(f);
    let text = load_gray(&path).unwrap_err().to_string();
    assert!(
        text.starts_with(&format!(
            "{}: cannot read image: the file is 3221225472 bytes, more than a 16x12 PNG can take",
            path.display()
        )),
        "{text}"
    );
}

#[test]
fn bytes_that_are_no_image_header_never_reach_opencv() {
    let e = decode_gray(b"\x89PNG\r\n\x1a\n\0\0\0\0\0\0\0\0").unwrap_err();
    assert!(matches!(e, FeatureError::Decode(_)), "{e:?}");
    let text = e.to_string();
    assert_eq!(
        text,
        "cannot decode the image: corrupt PNG: the chunk at byte 8 is \\x00\\x00\\x00\\x00, \
         not IHDR"
    );
    let e = decode_gray(b"BM\0\0").unwrap_err().to_string();
    assert!(e.contains("neither a PNG nor a JPEG"), "{e}");
}
