//! Round trips through our writers, against files COLMAP (pycolmap 4.2.1) wrote.

use colmap::Reconstruction;
use std::path::Path;

/// The five files of a COLMAP model, by stem.
const TABLES: [&str; 5] = ["cameras", "images", "points3D", "rigs", "frames"];

fn assert_same_files(a: &Path, b: &Path, ext: &str) {
    for t in TABLES {
        let name = format!("{t}.{ext}");
        let x = std::fs::read(a.join(&name)).unwrap();
        let y = std::fs::read(b.join(&name)).unwrap();
        if x != y {
            let at = x
                .iter()
                .zip(&y)
                .position(|(p, q)| p != q)
                .unwrap_or(x.len().min(y.len()));
            let show = |v: &[u8]| {
                String::from_utf8_lossy(&v[at.saturating_sub(60)..(at + 60).min(v.len())])
                    .into_owned()
            };
            panic!(
                "{name} differs at byte {at} (sizes {} / {}):\n ours:   {:?}\n theirs: {:?}",
                x.len(),
                y.len(),
                show(&x),
                show(&y)
            );
        }
    }
}

const SCENES: [&str; 2] = ["colmap-maupertuis", "colmap-sacre-coeur"];

#[test]
fn binary_files_are_rewritten_byte_identically() {
    for scene in SCENES {
        let Some(dir) = testkit::sample::sample_data(scene) else {
            return;
        };
        let rec = colmap::read_binary(&dir.join("model-bin")).unwrap();
        let tmp = tempfile::tempdir().unwrap();
        rec.write_binary(tmp.path()).unwrap();
        assert_same_files(tmp.path(), &dir.join("model-bin"), "bin");
    }
}

/// Our text writer reproduces, from the binary model, the text files pycolmap wrote.
#[test]
fn text_writer_reproduces_colmap_text_files() {
    for scene in SCENES {
        let Some(dir) = testkit::sample::sample_data(scene) else {
            return;
        };
        let from_bin = colmap::read_binary(&dir.join("model-bin")).unwrap();
        let tmp = tempfile::tempdir().unwrap();
        from_bin.write_text(tmp.path()).unwrap();
        assert_same_files(tmp.path(), &dir.join("model-txt"), "txt");

        let from_txt = colmap::read_text(&dir.join("model-txt")).unwrap();
        let tmp = tempfile::tempdir().unwrap();
        from_txt.write_text(tmp.path()).unwrap();
        assert_same_files(tmp.path(), &dir.join("model-txt"), "txt");
    }
}

#[test]
fn bin_txt_bin_and_txt_bin_txt() {
    for scene in SCENES {
        let Some(dir) = testkit::sample::sample_data(scene) else {
            return;
        };
        let bin = colmap::read_binary(&dir.join("model-bin")).unwrap();
        let tmp = tempfile::tempdir().unwrap();
        let (t, b) = (tmp.path().join("txt"), tmp.path().join("bin"));
        bin.write_text(&t).unwrap();
        let via_txt = colmap::read_text(&t).unwrap();
        assert_eq!(via_txt, bin);
        via_txt.write_binary(&b).unwrap();
        assert_eq!(colmap::read_binary(&b).unwrap(), bin);
        assert_same_files(&b, &dir.join("model-bin"), "bin");

        let txt = colmap::read_text(&dir.join("model-txt")).unwrap();
        let tmp = tempfile::tempdir().unwrap();
        let (t, b) = (tmp.path().join("txt"), tmp.path().join("bin"));
        txt.write_binary(&b).unwrap();
        let via_bin = colmap::read_binary(&b).unwrap();
        assert_eq!(via_bin, txt);
        via_bin.write_text(&t).unwrap();
        assert_eq!(colmap::read_text(&t).unwrap(), txt);
    }
}

/// A legacy text model (no rigs/frames, 6-digit values) survives txt -> bin -> txt, and
/// the written model carries COLMAP's trivial rigs and frames.
#[test]
fn legacy_text_model_round_trips() {
    let Some(dir) = testkit::sample::sample_data("colmap-maupertuis") else {
        return;
    };
    let orig = colmap::read_text(&dir.join("model-original-txt")).unwrap();
    let tmp = tempfile::tempdir().unwrap();
    orig.write_binary(tmp.path()).unwrap();
    assert!(tmp.path().join("rigs.bin").is_file() && tmp.path().join("frames.bin").is_file());
    let bin = Reconstruction::read(tmp.path()).unwrap();
    assert_eq!(bin, orig);
    let t = tmp.path().join("txt");
    bin.write_text(&t).unwrap();
    assert_eq!(colmap::read_text(&t).unwrap(), orig);
    // No temporary files are left behind.
    for e in std::fs::read_dir(tmp.path()).unwrap() {
        let name = e.unwrap().file_name().into_string().unwrap();
        assert!(!name.starts_with('.'), "left over: {name}");
    }
}

/// A fresh model built from records: sorted, given trivial rigs/frames, valid, and it
/// round-trips through both formats.
#[test]
fn fresh_model_round_trips() {
    let spec = colmap::synthetic::SyntheticSpec {
        num_points3d: 300,
        num_images: 12,
        num_observations: 1000,
        unmatched_per_image: 5,
        images_per_camera: 4,
        seed: 7,
    };
    let rec = colmap::synthetic::large_model(&spec);
    let mut shuffled = rec.clone();
    shuffled.images.reverse();
    shuffled.points3d.reverse();
    let rebuilt = Reconstruction::new(
        shuffled.cameras,
        shuffled.images,
        shuffled.points3d,
        Vec::new(),
        Vec::new(),
    )
    .unwrap();
    assert_eq!(rebuilt, rec);
    let tmp = tempfile::tempdir().unwrap();
    rec.write_binary(&tmp.path().join("b")).unwrap();
    rec.write_text(&tmp.path().join("t")).unwrap();
    assert_eq!(colmap::read(&tmp.path().join("b")).unwrap(), rec);
    assert_eq!(colmap::read(&tmp.path().join("t")).unwrap(), rec);
}
