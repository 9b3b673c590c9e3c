//! COLMAP binary model parser: arbitrary bytes split into the five files.
//! Properties: no panic; a model that parses re-encodes to the same bytes (cameras,
//! images, points3D; rigs/frames too unless they were synthesised for a legacy model)
//! and parses back equal.
#![no_main]

use colmap::binary::{BinaryFiles, parse_model};
use colmap::{Format, Table};
use libfuzzer_sys::fuzz_target;
use std::path::Path;

/// First byte: flags (bit 0: rigs present, bit 1: frames present); then four u16
/// lengths; the rest is cut into five pieces by them.
fn split(data: &[u8]) -> Option<(u8, [&[u8]; 5])> {
    let (&flags, rest) = data.split_first()?;
    if rest.len() < 8 {
        return None;
    }
    let (lens, mut body) = rest.split_at(8);
    let mut parts: [&[u8]; 5] = [&[]; 5];
    for (k, part) in parts.iter_mut().take(4).enumerate() {
        let n = usize::from(u16::from_le_bytes([lens[2 * k], lens[2 * k + 1]])).min(body.len());
        let (a, b) = body.split_at(n);
        *part = a;
        body = b;
    }
    parts[4] = body;
    Some((flags, parts))
}

fuzz_target!(|data: &[u8]| {
    // Each parser alone on the whole input.
    let p = Path::new("fuzz.bin");
    let _ = colmap::binary::parse_cameras(p, data);
    let _ = colmap::binary::parse_images(p, data);
    let _ = colmap::binary::parse_points3d(p, data);
    let _ = colmap::binary::parse_rigs(p, data);
    let _ = colmap::binary::parse_frames(p, data);

    let Some((flags, [cameras, images, points3d, rigs, frames])) = split(data) else {
        return;
    };
    let files = BinaryFiles {
        cameras,
        images,
        points3d,
        rigs: (flags & 1 != 0).then_some(rigs),
        frames: (flags & 2 != 0).then_some(frames),
    };
    let Ok(rec) = parse_model(Path::new("fuzz"), &files) else {
        return;
    };
    let enc = |t| colmap::io::encode(&rec, t, Format::Binary).expect("a parsed model encodes");
    assert_eq!(enc(Table::Cameras), cameras);
    assert_eq!(enc(Table::Images), images);
    assert_eq!(enc(Table::Points3D), points3d);
    let legacy = files.rigs.is_none_or(|r| r.len() == 8 && r == [0; 8])
        && files.frames.is_none_or(|f| f.len() == 8 && f == [0; 8]);
    if !legacy {
        assert_eq!(enc(Table::Rigs), files.rigs.unwrap_or(&[0; 8]));
        assert_eq!(enc(Table::Frames), files.frames.unwrap_or(&[0; 8]));
    }
    let (r, f) = (enc(Table::Rigs), enc(Table::Frames));
    let again = parse_model(
        Path::new("fuzz"),
        &BinaryFiles {
            cameras,
            images,
            points3d,
            rigs: Some(&r),
            frames: Some(&f),
        },
    )
    .expect("a re-encoded model parses");
    assert_eq!(again, rec);
});
