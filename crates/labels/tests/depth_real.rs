//! `DepthMap::read` on real 7-Scenes depth maps (the sample data's Kinect PNGs, as the
//! dataset ships them), value for value against OpenCV's own PNG reader in Python
//! (`cv2.imread(.., IMREAD_UNCHANGED)`), an implementation independent of the image
//! crate this reader decodes with. Skips with a reason without the sample data or the
//! Python peer.

use labels::depth::{DepthError, DepthMap};
use std::path::PathBuf;
use std::process::Command;
use testkit::python::{python, run};
use testkit::sample::sample_data;

/// Writes, for each path argument, width and height (u32 LE) and then the raw u16 LE
/// values, row-major.
const DUMP: &str = r#"
import sys, struct, cv2, numpy as np
out = sys.stdout.buffer
for p in sys.argv[1:]:
    d = cv2.imread(p, cv2.IMREAD_UNCHANGED)
    assert d is not None and d.dtype == np.uint16 and d.ndim == 2, (p, None if d is None else d.dtype)
    out.write(struct.pack('<II', d.shape[1], d.shape[0]))
    out.write(d.astype('<u2').tobytes())
"#;

#[test]
fn real_seven_scenes_depth_maps_read_as_opencv_reads_them() {
    let Some(seq) = sample_data("7scenes-stairs-mini/stairs/seq-01") else {
        return;
    };
    let Some(py) = python(&["cv2", "numpy"]) else {
        return;
    };
    let mut paths: Vec<PathBuf> = std::fs::read_dir(&seq)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.to_string_lossy().ends_with(".depth.png"))
        .collect();
    paths.sort();
    paths.truncate(3);
    assert!(!paths.is_empty(), "no depth maps in {}", seq.display());
    let dump = run(Command::new(&py).arg("-c").arg(DUMP).args(&paths));

    let mut at = 0;
    let u32_at = |at: &mut usize| {
        let v = u32::from_le_bytes(dump[*at..*at + 4].try_into().unwrap());
        *at += 4;
        v
    };
    for path in &paths {
        let (w, h) = (u32_at(&mut at), u32_at(&mut at));
        let d = DepthMap::read(path, 1000.0, 1000.0).unwrap();
        assert_eq!((d.width(), d.height()), (w, h), "{}", path.display());
        let mut valid = 0usize;
        for j in 0..h as i64 {
            for i in 0..w as i64 {
                let raw = u16::from_le_bytes([dump[at], dump[at + 1]]);
                at += 2;
                let expected = (raw != 0 && raw != u16::MAX).then(|| f64::from(raw) / 1000.0);
                let got = d.pixel(i, j);
                match (got, expected) {
                    (None, None) => {}
                    (Some(g), Some(e)) => {
                        valid += 1;
                        assert!(
                            (g - e).abs() < 1e-12,
                            "{} ({i}, {j}): {g} m, OpenCV {raw} mm",
                            path.display()
                        );
                    }
                    _ => panic!(
                        "{} ({i}, {j}): {got:?} against OpenCV's {raw}",
                        path.display()
                    ),
                }
            }
        }
        println!(
            "{}: {w}x{h}, {valid} valid depths, every value as OpenCV reads it",
            path.display()
        );
        assert!(valid > (w * h / 2) as usize, "{valid} valid of {}", w * h);
    }
    assert_eq!(at, dump.len());

    // A missing file: the read error names it.
    let missing = seq.join("no-such-frame.depth.png");
    match DepthMap::read(&missing, 1000.0, 1000.0) {
        Err(DepthError::Read { path, .. }) => assert_eq!(path, missing),
        other => panic!("{other:?}"),
    }
}
