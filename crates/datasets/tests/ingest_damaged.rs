//! Truncated and corrupt images are refused at ingest, all of them in one error that
//! names each file: on the small fixture and on real 7-Scenes frames of the sample data.

use datasets::ingest::{self, DatasetKind, DepthOption, IngestConfig, IngestError};
use std::path::Path;
use testkit::layouts::seven_scenes;

/// Keeps the first `fraction` of the file's bytes, as an interrupted download does.
fn cut(path: &Path, fraction: f64) {
    let bytes = std::fs::read(path).unwrap();
    let keep = (bytes.len() as f64 * fraction) as usize;
    std::fs::write(path, &bytes[..keep]).unwrap();
}

fn damaged(config: &IngestConfig, depth_out: Option<&Path>) -> Box<ingest::DamagedImagesError> {
    match ingest::read_dataset(config, depth_out) {
        Err(IngestError::DamagedImages(e)) => e,
        Err(e) => panic!("expected the damaged-images error, got: {e}"),
        Ok(_) => panic!("damaged images were ingested"),
    }
}

#[test]
fn truncated_png_and_jpeg_are_refused_together_with_their_names() {
    let dir = tempfile::tempdir().unwrap();
    // The 7-Scenes default camera's size, so no camera needs to be given.
    let scene = seven_scenes(dir.path(), 640, 480);
    let png = scene.join("seq-01/frame-000001.color.png");
    let jpg = scene.join("seq-02/frame-000000.color.jpg");
    cut(&png, 2.0 / 3.0);
    cut(&jpg, 0.6);
    let mut config = IngestConfig::new(DatasetKind::SevenScenes, &scene);
    config.count_check = false;
    let e = damaged(&config, None);
    assert_eq!(e.total, 3);
    let names: Vec<&Path> = e.damaged.iter().map(|(p, _)| p.as_path()).collect();
    assert_eq!(names, [png.as_path(), jpg.as_path()]);
    assert!(
        e.damaged[0].1.starts_with("truncated PNG"),
        "{}",
        e.damaged[0].1
    );
    assert!(
        e.damaged[1].1.starts_with("truncated JPEG"),
        "{}",
        e.damaged[1].1
    );
    let text = e.to_string();
    assert!(text.contains("2 of 3 images are damaged"), "{text}");
    assert!(text.contains("frame-000001.color.png") && text.contains("frame-000000.color.jpg"));
}

#[test]
fn a_flipped_byte_in_a_png_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let scene = seven_scenes(dir.path(), 640, 480);
    let png = scene.join("seq-01/frame-000000.color.png");
    let mut bytes = std::fs::read(&png).unwrap();
    let middle = bytes.len() / 2;
    bytes[middle] ^= 0x40;
    std::fs::write(&png, bytes).unwrap();
    let mut config = IngestConfig::new(DatasetKind::SevenScenes, &scene);
    config.count_check = false;
    let e = damaged(&config, None);
    assert_eq!(e.damaged.len(), 1);
    assert!(e.damaged[0].1.contains("CRC"), "{}", e.damaged[0].1);
}

#[test]
fn real_sample_frames_cut_short_are_refused() {
    let Some(base) = testkit::sample::sample_data("7scenes-stairs-mini") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("stairs");
    testkit::files::copy_dir(&base.join("stairs"), &scene);
    let jpg = scene.join("seq-01/frame-000001.color.jpg");
    let depth = scene.join("seq-01/frame-000002.depth.png");
    cut(&jpg, 0.6);
    cut(&depth, 2.0 / 3.0);
    // The reason for the structural walk: the JPEG decoder alone accepts this file.
    let decodes = image::load_from_memory(&std::fs::read(&jpg).unwrap()).is_ok();
    println!("the real JPEG cut to 60 % decodes without the check: {decodes}");
    let mut config = IngestConfig::new(DatasetKind::SevenScenes, &scene);
    config.count_check = false;
    config.depth = DepthOption::Raw;
    let out = dir.path().join("depth-out");
    let e = damaged(&config, Some(&out));
    let names: Vec<&Path> = e.damaged.iter().map(|(p, _)| p.as_path()).collect();
    assert_eq!(names, [jpg.as_path(), depth.as_path()]);
    assert!(
        e.damaged[0].1.starts_with("truncated JPEG"),
        "{}",
        e.damaged[0].1
    );
    assert!(
        e.damaged[1].1.starts_with("truncated PNG"),
        "{}",
        e.damaged[1].1
    );
    assert_eq!(e.total, 12);
}

/// A valid PNG over the pixel limit is refused as too large, naming the file and the
/// limit; it is not counted among damaged downloads, and nothing is written.
#[test]
fn an_oversized_png_is_refused_as_too_large_naming_the_limit() {
    use image::ImageEncoder;
    use image::codecs::png::{CompressionType, FilterType, PngEncoder};
    let dir = tempfile::tempdir().unwrap();
    let scene = seven_scenes(dir.path(), 640, 480);
    let png = scene.join("seq-01/frame-000001.color.png");
    // 20000 x 20000 black pixels: about 1 MB of compressed zeros, 400 MP decoded.
    let (w, h) = (20_000u32, 20_000u32);
    let mut bytes = Vec::new();
    PngEncoder::new_with_quality(&mut bytes, CompressionType::Fast, FilterType::NoFilter)
        .write_image(
            &vec![0u8; w as usize * h as usize],
            w,
            h,
            image::ExtendedColorType::L8,
        )
        .unwrap();
    std::fs::write(&png, &bytes).unwrap();
    let mut config = IngestConfig::new(DatasetKind::SevenScenes, &scene);
    config.count_check = false;
    let out = dir.path().join("work/ingest");
    let e = datasets::ingest_stage::run(&config, &out).unwrap_err();
    let text = e.to_string();
    assert_eq!(
        text,
        format!(
            "{}: the PNG is too large: 20000x20000 is 400000000 pixels, the limit is \
             50000000 pixels (set PL2MAP_MAX_IMAGE_PIXELS to change it)",
            png.display()
        )
    );
    assert!(
        !text.contains("damaged") && !text.contains("Memory limit"),
        "{text}"
    );
    for name in ["frames.parquet", "stage.json"] {
        assert!(!out.join(name).exists(), "{name} was written");
    }
}
