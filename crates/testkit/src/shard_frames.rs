//! Synthetic frames for the shards crate's tests and benchmark: random but seeded
//! labels, a real PNG or JPEG file per frame, cameras of several COLMAP models, and
//! values that stress a bitwise round trip (-0.0, subnormals, NaN payloads in invalid
//! labels).

use geometry::{Camera, CameraModel, Pose};
use nalgebra::{Quaternion, UnitQuaternion, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use shards::{FrameRecord, ImageFormat, LabelSource, Split};

/// An encoded image of `w` x `h` pixels: a gradient plus seeded noise
/// ([`crate::images::noisy_rgb_bytes`]).
pub fn image_bytes(w: u32, h: u32, seed: u64, format: ImageFormat) -> Vec<u8> {
    let fmt = match format {
        ImageFormat::Png => image::ImageFormat::Png,
        ImageFormat::Jpeg => image::ImageFormat::Jpeg,
    };
    crate::images::noisy_rgb_bytes(w, h, seed, fmt)
}

fn camera(frame_id: u64, w: u64, h: u64) -> Camera {
    let (fw, fh) = (w as f64, h as f64);
    let (model, params) = match frame_id % 4 {
        0 => (CameraModel::SimplePinhole, vec![525.0, fw / 2.0, fh / 2.0]),
        1 => (
            CameraModel::OpenCv,
            vec![
                500.5,
                501.25,
                fw / 2.0 + 0.3,
                fh / 2.0 - 0.2,
                -0.12,
                0.03,
                1e-4,
                -2e-4,
            ],
        ),
        2 => (
            CameraModel::FullOpenCv,
            vec![
                480.0,
                481.0,
                fw / 2.0,
                fh / 2.0,
                0.1,
                -0.01,
                1e-3,
                2e-3,
                1e-4,
                0.05,
                -0.002,
                1e-5,
            ],
        ),
        _ => (
            CameraModel::Fov,
            vec![400.0, 400.0, fw / 2.0, fh / 2.0, 0.9],
        ),
    };
    Camera::new(model, w, h, params).expect("test camera")
}

/// Frame `frame_id` with `n_kp` keypoints and `n_lines` segments and an image of
/// `w` x `h` pixels.
pub fn frame(frame_id: u64, n_kp: usize, n_lines: usize, w: u32, h: u32) -> FrameRecord {
    let format = if frame_id % 5 == 3 {
        ImageFormat::Jpeg
    } else {
        ImageFormat::Png
    };
    frame_with_image(
        frame_id,
        n_kp,
        n_lines,
        image_bytes(w, h, frame_id, format),
        format,
        w,
        h,
    )
}

pub fn frame_with_image(
    frame_id: u64,
    n_kp: usize,
    n_lines: usize,
    image: Vec<u8>,
    format: ImageFormat,
    w: u32,
    h: u32,
) -> FrameRecord {
    let mut rng = ChaCha8Rng::seed_from_u64(frame_id.wrapping_mul(0x9E37_79B9_7F4A_7C15));
    let q = Quaternion::new(
        rng.random_range(-1.0..1.0),
        rng.random_range(-1.0..1.0),
        rng.random_range(-1.0..1.0),
        rng.random_range(-1.0..1.0),
    );
    let pose = Pose::new(
        UnitQuaternion::from_quaternion(q),
        Vector3::new(
            rng.random_range(-5.0..5.0),
            -0.0,
            rng.random_range(-5.0..5.0),
        ),
    );
    let (fw, fh) = (f64::from(w), f64::from(h));
    let mut keypoints = Vec::with_capacity(n_kp);
    let mut ids = Vec::with_capacity(n_kp);
    let mut pts = Vec::with_capacity(n_kp);
    let mut valid = Vec::with_capacity(n_kp);
    for i in 0..n_kp {
        keypoints.push([rng.random_range(0.0..fw), rng.random_range(0.0..fh)]);
        let ok = rng.random_bool(0.7);
        valid.push(ok);
        if ok {
            ids.push(rng.random_range(0..1_000_000));
            let z = if i == 0 {
                -0.0
            } else {
                rng.random_range(-3.0..3.0)
            };
            pts.push([rng.random_range(-3.0..3.0), 5e-324, z]);
        } else {
            ids.push(-1);
            // Invalid labels may hold anything; a NaN with a payload must survive too.
            pts.push([
                f64::from_bits(0x7ff8_0000_0000_0000 | i as u64),
                f64::NAN,
                0.0,
            ]);
        }
    }
    let mut segments = Vec::with_capacity(n_lines);
    let mut tracks = Vec::with_capacity(n_lines);
    let mut lines = Vec::with_capacity(n_lines);
    let mut lvalid = Vec::with_capacity(n_lines);
    for _ in 0..n_lines {
        segments.push([
            rng.random_range(0.0..fw),
            rng.random_range(0.0..fh),
            rng.random_range(0.0..fw),
            rng.random_range(0.0..fh),
        ]);
        let ok = rng.random_bool(0.6);
        lvalid.push(ok);
        tracks.push(if ok { rng.random_range(0..50_000) } else { -1 });
        let mut l = [0.0; 6];
        for v in &mut l {
            *v = if ok {
                rng.random_range(-4.0..4.0)
            } else {
                f64::INFINITY
            };
        }
        lines.push(l);
    }
    FrameRecord {
        frame_id,
        name: format!(
            "seq-{:02}/frame-{frame_id:06}.color.{}",
            frame_id % 3,
            format.as_str()
        ),
        split: if frame_id.is_multiple_of(7) {
            Split::Test
        } else {
            Split::Train
        },
        camera: camera(frame_id, u64::from(w), u64::from(h)),
        pose,
        image_bytes: image.into(),
        image_format: format,
        keypoints,
        point3d_ids: ids,
        points3d: pts,
        point_valid: valid,
        segments,
        track_ids: tracks,
        lines3d: lines,
        line_valid: lvalid,
        label_source: match frame_id % 3 {
            0 => LabelSource::Sfm,
            1 => LabelSource::DepthRefined,
            _ => LabelSource::SyntheticExact,
        },
        endpoints_aligned: frame_id.is_multiple_of(2),
    }
}

fn bits<const N: usize>(v: &[[f64; N]]) -> Vec<u64> {
    v.iter().flatten().map(|x| x.to_bits()).collect()
}

/// Panics unless `a` and `b` are equal, comparing every double by its bits.
pub fn assert_bitwise_eq(a: &FrameRecord, b: &FrameRecord) {
    let id = a.frame_id;
    assert_eq!(a.frame_id, b.frame_id);
    assert_eq!(a.name, b.name, "frame {id}");
    assert_eq!(a.split, b.split, "frame {id}");
    assert_eq!(a.camera.model, b.camera.model, "frame {id}");
    assert_eq!(
        (a.camera.width, a.camera.height),
        (b.camera.width, b.camera.height)
    );
    let pb = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    assert_eq!(
        pb(&a.camera.params),
        pb(&b.camera.params),
        "frame {id} camera"
    );
    assert_eq!(pb(&a.pose.qvec()), pb(&b.pose.qvec()), "frame {id} qvec");
    assert_eq!(pb(&a.pose.tvec()), pb(&b.pose.tvec()), "frame {id} tvec");
    assert!(
        a.image_bytes == b.image_bytes,
        "frame {id} image bytes differ"
    );
    assert_eq!(a.image_format, b.image_format, "frame {id}");
    assert_eq!(
        bits(&a.keypoints),
        bits(&b.keypoints),
        "frame {id} keypoints"
    );
    assert_eq!(a.point3d_ids, b.point3d_ids, "frame {id}");
    assert_eq!(bits(&a.points3d), bits(&b.points3d), "frame {id} points3d");
    assert_eq!(a.point_valid, b.point_valid, "frame {id}");
    assert_eq!(bits(&a.segments), bits(&b.segments), "frame {id} segments");
    assert_eq!(a.track_ids, b.track_ids, "frame {id}");
    assert_eq!(bits(&a.lines3d), bits(&b.lines3d), "frame {id} lines3d");
    assert_eq!(a.line_valid, b.line_valid, "frame {id}");
    assert_eq!(a.label_source, b.label_source, "frame {id}");
    assert_eq!(a.endpoints_aligned, b.endpoints_aligned, "frame {id}");
}

/// A small config whose chunks hold a few frames, so frames straddle chunk bounds.
pub fn small_chunks() -> shards::ShardConfig {
    shards::ShardConfig {
        frames_per_shard: 10,
        chunk_size: 16 * 1024,
        zstd_level: 3,
    }
}
