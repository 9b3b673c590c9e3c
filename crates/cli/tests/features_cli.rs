//! `pl2map features` on bad image folders: files that are no images to read (`/dev/zero`,
//! a PNG over the pixel limit, a sparse file of 3 GB behind a small header) are named
//! and left out, a link cycle is walked once with a warning, the pixel limit follows
//! `PL2MAP_MAX_IMAGE_PIXELS`, and the feature file gets the mode of any other output.

use std::io::Write;
use std::path::Path;
use std::process::{Command, Output};

fn features(images: &Path, out: &Path) -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_pl2map"));
    c.args(["--quiet", "features", "--front-end", "sift", "--images"])
        .arg(images)
        .arg("--out")
        .arg(out);
    c
}

fn text(o: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

/// A real PNG of 20000 x 20000 black pixels: about 1 MB, 400 MP decoded.
fn write_oversized_png(path: &Path) {
    use image::ImageEncoder;
    use image::codecs::png::{CompressionType, FilterType, PngEncoder};
    let (w, h) = (20_000u32, 20_000u32);
    let mut png = Vec::new();
    PngEncoder::new_with_quality(&mut png, CompressionType::Fast, FilterType::NoFilter)
        .write_image(
            &vec![0u8; w as usize * h as usize],
            w,
            h,
            image::ExtendedColorType::L8,
        )
        .unwrap();
    std::fs::write(path, png).unwrap();
}

/// The files of `dir` whose names start with a dot (temp files left behind).
fn hidden_files(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with('.'))
        .collect()
}

#[cfg(unix)]
#[test]
fn images_that_cannot_be_read_safely_are_named_and_a_link_cycle_is_walked_once() {
    let dir = tempfile::tempdir().unwrap();
    let images = dir.path().join("images");
    testkit::images::write_rgb(&images.join("good.png"), 160, 120, 1);
    write_oversized_png(&images.join("huge.png"));
    let sparse = images.join("sparse.png");
    let mut small = Vec::new();
    image::GrayImage::new(16, 12)
        .write_to(
            &mut std::io::Cursor::new(&mut small),
            image::ImageFormat::Png,
        )
        .unwrap();
    let mut f = std::fs::File::create(&sparse).unwrap();
    f.write_all(&small).unwrap();
    f.set_len(3 << 30).unwrap();
    drop(f);
    let zero = Path::new("/dev/zero").exists();
    if zero {
        std::os::unix::fs::symlink("/dev/zero", images.join("zero.png")).unwrap();
    }
    std::fs::create_dir_all(images.join("sub")).unwrap();
    std::os::unix::fs::symlink("..", images.join("sub/loop")).unwrap();
    let out = dir.path().join("feats.h5");
    let o = features(&images, &out).output().unwrap();
    let t = text(&o);
    assert!(!o.status.success(), "{t}");
    let n = if zero { 4 } else { 3 };
    assert!(
        t.contains(&format!("{} of {n} images could not be read", n - 1)),
        "{t}"
    );
    assert!(
        t.contains(&format!(
            "{}: the PNG is too large: 20000x20000 is 400000000 pixels, the limit is 50000000 \
             pixels (set PL2MAP_MAX_IMAGE_PIXELS to change it)",
            images.join("huge.png").display()
        )),
        "{t}"
    );
    assert!(
        t.contains(&format!(
            "{}: the file is 3221225472 bytes",
            sparse.display()
        )),
        "{t}"
    );
    if zero {
        assert!(
            t.contains(&format!(
                "{}: not a regular file but a device",
                images.join("zero.png").display()
            )),
            "{t}"
        );
    }
    assert!(!t.contains("OpenCV"), "{t}");
    // The cycle: one warning naming the link, no file listed twice.
    assert!(
        t.contains(&format!(
            "{}: not entered: it leads to",
            images.join("sub/loop").display()
        )),
        "{t}"
    );
    assert!(!t.contains("sub/loop/"), "{t}");
    assert!(out.exists(), "the readable image's features are written");
    assert!(hidden_files(dir.path()).is_empty());
}

#[test]
fn with_every_image_refused_no_feature_file_is_written() {
    let dir = tempfile::tempdir().unwrap();
    let images = dir.path().join("images");
    std::fs::create_dir_all(&images).unwrap();
    write_oversized_png(&images.join("huge.png"));
    let out = dir.path().join("feats.h5");
    let o = features(&images, &out).output().unwrap();
    let t = text(&o);
    assert!(!o.status.success(), "{t}");
    assert!(
        t.contains("none of the 1 images could be read")
            && t.contains("huge.png: the PNG is too large"),
        "{t}"
    );
    assert!(!out.exists(), "nothing under the final name");
    assert!(
        hidden_files(dir.path()).is_empty(),
        "{:?}",
        hidden_files(dir.path())
    );
}

#[test]
fn the_pixel_limit_follows_the_environment_and_a_bad_value_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let images = dir.path().join("images");
    testkit::images::write_rgb(&images.join("a.png"), 160, 120, 1);
    let out = dir.path().join("feats.h5");
    let o = features(&images, &out)
        .env("PL2MAP_MAX_IMAGE_PIXELS", "10000")
        .output()
        .unwrap();
    let t = text(&o);
    assert!(!o.status.success(), "{t}");
    assert!(
        t.contains("160x120 is 19200 pixels, the limit is 10000 pixels"),
        "{t}"
    );
    assert!(!out.exists());
    let o = features(&images, &out)
        .env("PL2MAP_MAX_IMAGE_PIXELS", "lots")
        .output()
        .unwrap();
    let t = text(&o);
    assert!(!o.status.success(), "{t}");
    assert!(
        t.contains("PL2MAP_MAX_IMAGE_PIXELS=lots: expected a positive whole number"),
        "{t}"
    );
    let o = features(&images, &out)
        .env("PL2MAP_MAX_IMAGE_PIXELS", "19200")
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", text(&o));
}

/// The feature file is an ordinary output: 0666 minus the umask (0644 under 022, 0640
/// under 027), not the 0600 of a temp file.
#[cfg(unix)]
#[test]
fn the_feature_file_has_the_mode_the_umask_gives() {
    use std::os::unix::fs::PermissionsExt;
    let dir = tempfile::tempdir().unwrap();
    let images = dir.path().join("images");
    testkit::images::write_rgb(&images.join("a.png"), 160, 120, 1);
    for (umask, mode) in [("022", 0o644), ("027", 0o640)] {
        let out = dir.path().join(format!("feats-{umask}.h5"));
        let cmd = features(&images, &out);
        let o = Command::new("sh")
            .arg("-c")
            .arg(format!("umask {umask}; exec \"$0\" \"$@\""))
            .arg(cmd.get_program())
            .args(cmd.get_args())
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", text(&o));
        let got = std::fs::metadata(&out).unwrap().permissions().mode() & 0o777;
        assert_eq!(got, mode, "umask {umask}: mode {got:o}");
    }
}
