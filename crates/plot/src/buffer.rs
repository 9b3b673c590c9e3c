//! The RGB buffer the plots are drawn into, and its PNG encoding.

/// A drawing error as text.
pub fn draw_err<E: std::fmt::Display>(e: E) -> String {
    format!("drawing the plot: {e}")
}

/// A white RGB buffer of `width` x `height` pixels to draw on.
pub fn white_buffer(width: u32, height: u32) -> Vec<u8> {
    vec![255u8; width as usize * height as usize * 3]
}

/// The PNG bytes of an RGB buffer (deterministic: no time stamp, fixed settings).
///
/// The one PNG encoder of the plotting crates: the PNG encoder itself, with the settings
/// `write_to(.., ImageFormat::Png)` uses (same bytes), because `write_to` is generic
/// over its writer and compiles every enabled encoder (PNG, JPEG, TIFF) again in each
/// crate that calls it.
pub fn png(buf: Vec<u8>, width: u32, height: u32) -> Result<Vec<u8>, String> {
    use image::ImageEncoder as _;
    let expected = width as usize * height as usize * 3;
    if buf.len() != expected {
        return Err(format!(
            "plot buffer of the wrong size: {} bytes for {width} x {height} RGB",
            buf.len()
        ));
    }
    let mut out = Vec::new();
    image::codecs::png::PngEncoder::new(&mut out)
        .write_image(&buf, width, height, image::ExtendedColorType::Rgb8)
        .map_err(|e| format!("encoding the plot: {e}"))?;
    Ok(out)
}
