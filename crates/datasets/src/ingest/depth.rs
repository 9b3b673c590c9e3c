//! Depth maps of the frames table: raw Kinect depth registered into the colour camera,
//! or rendered depth maps found by name.
//!
//! Every depth map the table points to is single-channel, in millimetres, with 0 and
//! 65535 meaning "no depth".

use super::error::{IngestError, Result};
use crate::dataset_kind::DatasetKind;
use geometry::{Camera, Pose, Vector2};
use image::codecs::png::{CompressionType, FilterType, PngEncoder};
use image::{DynamicImage, ExtendedColorType, ImageBuffer, ImageEncoder, Luma};
use std::path::{Path, PathBuf};

pub type DepthImage = ImageBuffer<Luma<u16>, Vec<u16>>;

/// No depth (both 0 and this value are invalid in 7-Scenes depth maps).
pub const INVALID_DEPTH: u16 = 65535;

/// Registers a depth map into another camera: every valid depth pixel is lifted at its
/// centre (COLMAP convention) with `depth_cam`, moved by `target_from_depth` and
/// projected with `target_cam`; it lands in the pixel that contains the projection. When
/// several land in one pixel the nearest wins (z-buffer). Pixels nothing lands in hold
/// [`INVALID_DEPTH`]. Values are millimetres along the target camera's z axis, rounded.
pub fn register_depth(
    depth: &DepthImage,
    depth_cam: &Camera,
    target_from_depth: &Pose,
    target_cam: &Camera,
) -> DepthImage {
    let (tw, th) = (target_cam.width as u32, target_cam.height as u32);
    let mut out = DepthImage::from_pixel(tw, th, Luma([INVALID_DEPTH]));
    for (x, y, px) in depth.enumerate_pixels() {
        let d = px.0[0];
        if d == 0 || d == INVALID_DEPTH {
            continue;
        }
        let centre = Vector2::new(x as f64 + 0.5, y as f64 + 0.5);
        let Some(ray) = depth_cam.unproject(&centre) else {
            continue;
        };
        // Perspective rays have z = 1: scaling by the depth gives the point.
        let p = ray * (d as f64 / 1000.0 / ray.z);
        let q = target_from_depth.transform_point(&p);
        let Some(uv) = target_cam.project(&q) else {
            continue;
        };
        if !(uv.x >= 0.0 && uv.y >= 0.0 && uv.x < tw as f64 && uv.y < th as f64) {
            continue;
        }
        let mm = (q.z * 1000.0).round();
        if !(mm >= 1.0 && mm < INVALID_DEPTH as f64) {
            continue;
        }
        let (u, v) = (uv.x as u32, uv.y as u32);
        let slot = &mut out.get_pixel_mut(u, v).0[0];
        // INVALID_DEPTH is the largest u16: an empty pixel always loses.
        *slot = (*slot).min(mm as u16);
    }
    out
}

/// Reads a 16-bit single-channel PNG depth map.
pub fn read_depth_png(path: &Path) -> Result<DepthImage> {
    match super::whole::decode_whole(path)? {
        DynamicImage::ImageLuma16(d) => Ok(d),
        other => Err(IngestError::ImageContent {
            path: path.to_path_buf(),
            message: format!(
                "expected a 16-bit single-channel depth map, got {:?}",
                other.color()
            ),
        }),
    }
}

/// Writes a 16-bit PNG atomically (fixed encoder settings: same pixels, same bytes);
/// returns the file's content hash (sha256, hex) for the frames table.
pub fn write_depth_png(path: &Path, depth: &DepthImage) -> Result<String> {
    // The encoder takes 16-bit samples in native byte order and writes them big-endian.
    let bytes: Vec<u8> = depth
        .as_raw()
        .iter()
        .flat_map(|v| v.to_ne_bytes())
        .collect();
    let mut buf = Vec::new();
    PngEncoder::new_with_quality(&mut buf, CompressionType::Default, FilterType::Adaptive)
        .write_image(
            &bytes,
            depth.width(),
            depth.height(),
            ExtendedColorType::L16,
        )
        .map_err(|source| IngestError::Image {
            path: path.to_path_buf(),
            source,
        })?;
    stage::write_atomic(path, &buf)?;
    Ok(stage::sha256_bytes(&buf))
}

/// The file names a rendered depth map of the frame `name_stem` may have in a rendered
/// depth folder, in the order they are listed in errors. `name_stem` is the frame name
/// without its colour suffix (`seq-01/frame-000000`, `seq1/frame00001`).
///
/// - every dataset: `<stem>.depth.png`, `<stem>.depth.tiff`, `<stem>.pose.depth.png`,
///   `<stem>.pose.depth.tiff` (per-sequence folders);
/// - 7-Scenes also the flat names of hloc (`seq01_frame-000000.pose.depth.tiff`,
///   `create_gt_sfm.image_path_to_rendered_depth_path`) and of DSAC*/ACE
///   (`seq-01-frame-000000.depth.png`).
pub fn rendered_candidates(kind: DatasetKind, name_stem: &str) -> Vec<String> {
    let mut c: Vec<String> = [
        "depth.png",
        "depth.tiff",
        "pose.depth.png",
        "pose.depth.tiff",
    ]
    .iter()
    .map(|ext| format!("{name_stem}.{ext}"))
    .collect();
    if kind == DatasetKind::SevenScenes
        && let Some((seq, frame)) = name_stem.split_once('/')
    {
        let hloc_seq: String = seq.chars().filter(|&ch| ch != '-').collect();
        c.push(format!("{hloc_seq}_{frame}.pose.depth.tiff"));
        c.push(format!("{hloc_seq}_{frame}.pose.depth.png"));
        c.push(format!("{seq}-{frame}.depth.png"));
        c.push(format!("{seq}-{frame}.depth.tiff"));
    }
    c
}

/// The one rendered depth map of a frame in `dir`: exactly one candidate must exist.
pub fn find_rendered(dir: &Path, kind: DatasetKind, name_stem: &str) -> Result<PathBuf> {
    let candidates = rendered_candidates(kind, name_stem);
    let found: Vec<&String> = candidates
        .iter()
        .filter(|c| dir.join(c.as_str()).is_file())
        .collect();
    match found.as_slice() {
        [one] => Ok(dir.join(one.as_str())),
        [] => Err(IngestError::Missing {
            path: dir.to_path_buf(),
            what: format!(
                "rendered depth map of {name_stem} (looked for {})",
                candidates.join(", ")
            ),
        }),
        many => Err(IngestError::Ambiguous {
            path: dir.to_path_buf(),
            what: format!("rendered depth map of {name_stem}"),
            candidates: many.iter().map(|s| s.to_string()).collect(),
        }),
    }
}

/// Checks that a depth map is whole and has its colour image's size.
pub fn check_depth_size(path: &Path, image_name: &str, w: u32, h: u32) -> Result<()> {
    let depth = super::whole::decode_whole(path)?;
    let (got_w, got_h) = (depth.width(), depth.height());
    if (got_w, got_h) != (w, h) {
        return Err(IngestError::DepthSize {
            path: path.to_path_buf(),
            image: image_name.to_string(),
            got_w,
            got_h,
            w,
            h,
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use geometry::{CameraModel, UnitQuaternion, Vector3};

    fn pinhole(f: f64, w: u64, h: u64) -> Camera {
        Camera::new(
            CameraModel::SimplePinhole,
            w,
            h,
            vec![f, w as f64 / 2.0, h as f64 / 2.0],
        )
        .unwrap()
    }

    #[test]
    fn identity_registration_is_the_identity() {
        let cam = pinhole(585.0, 64, 48);
        let mut d = DepthImage::from_fn(64, 48, |x, y| Luma([500 + (x * 7 + y * 13) as u16]));
        d.put_pixel(3, 4, Luma([0]));
        d.put_pixel(5, 6, Luma([INVALID_DEPTH]));
        let out = register_depth(&d, &cam, &Pose::identity(), &cam);
        let mut expected = d.clone();
        expected.put_pixel(3, 4, Luma([INVALID_DEPTH]));
        assert_eq!(out, expected);
    }

    /// A tilted plane seen by the depth camera, registered into a camera with another
    /// focal length, rotation and offset: every filled pixel holds the plane's depth along
    /// the ray through that pixel's centre, to within the plane's depth change across one
    /// pixel (the point that lands in a pixel is not exactly at its centre).
    #[test]
    fn plane_lands_at_its_analytic_depth() {
        let dcam = pinhole(585.0, 640, 480);
        let rcam = pinhole(525.0, 640, 480);
        // Plane n . X = c in the depth frame.
        let n = Vector3::new(0.1, -0.2, 1.0).normalize();
        let c = 2.0;
        let depth = DepthImage::from_fn(640, 480, |x, y| {
            let r = dcam
                .unproject(&Vector2::new(x as f64 + 0.5, y as f64 + 0.5))
                .unwrap();
            let t = c / n.dot(&r);
            Luma([(t * r.z * 1000.0).round() as u16])
        });
        let rgb_from_depth = Pose::new(
            UnitQuaternion::from_euler_angles(0.01, -0.02, 0.005),
            Vector3::new(-0.025, 0.001, 0.002),
        );
        let out = register_depth(&depth, &dcam, &rgb_from_depth, &rcam);
        // The plane in the colour frame: n' . X = c', n' = R n, c' = c + n' . t.
        let n2 = rgb_from_depth.rotation * n;
        let c2 = c + n2.dot(&rgb_from_depth.translation);
        let (mut filled, mut worst) = (0usize, 0.0f64);
        for (x, y, px) in out.enumerate_pixels() {
            if px.0[0] == INVALID_DEPTH {
                continue;
            }
            filled += 1;
            let r = rcam
                .unproject(&Vector2::new(x as f64 + 0.5, y as f64 + 0.5))
                .unwrap();
            let z = c2 / n2.dot(&r) * r.z * 1000.0;
            worst = worst.max((px.0[0] as f64 - z).abs());
        }
        // f 525 < 585: the colour camera sees a wider field than the depth camera, so
        // the depth image covers about (525/585)^2 = 80 % of it, and its pixels are
        // denser than the colour pixels: no holes inside that region.
        assert!(filled > 640 * 480 * 75 / 100, "{filled}");
        for y in 50..430 {
            for x in 60..580 {
                assert_ne!(out.get_pixel(x, y).0[0], INVALID_DEPTH, "hole at {x},{y}");
            }
        }
        // Depth changes by < 1 mm per pixel on this plane; rounding adds 0.5 mm.
        assert!(worst < 2.0, "worst {worst} mm");
    }

    #[test]
    fn nearest_point_wins() {
        // Several depth pixels that land on the same pixel: a camera that collapses the
        // image (tiny focal length, principal point at the centre of pixel (2, 2)) sends
        // every point there.
        let dcam = pinhole(585.0, 4, 4);
        let tcam = Camera::new(CameraModel::SimplePinhole, 4, 4, vec![1e-3, 2.5, 2.5]).unwrap();
        let mut d = DepthImage::from_pixel(4, 4, Luma([3000]));
        d.put_pixel(1, 1, Luma([1200]));
        d.put_pixel(2, 2, Luma([0]));
        let out = register_depth(&d, &dcam, &Pose::identity(), &tcam);
        assert_eq!(out.get_pixel(2, 2).0[0], 1200);
        assert_eq!(out.pixels().filter(|p| p.0[0] != INVALID_DEPTH).count(), 1);
    }

    #[test]
    fn png_round_trip_is_exact() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("sub/d.depth.png");
        let d = DepthImage::from_fn(17, 9, |x, y| Luma([(x * 3001 + y * 17) as u16]));
        let sha256 = write_depth_png(&p, &d).unwrap();
        assert_eq!(read_depth_png(&p).unwrap(), d);
        assert_eq!(sha256, stage::sha256_file(&p).unwrap());
    }

    #[test]
    fn rendered_lookup_needs_exactly_one() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let e = find_rendered(d, DatasetKind::SevenScenes, "seq-01/frame-000000").unwrap_err();
        assert!(
            e.to_string().contains("seq01_frame-000000.pose.depth.tiff"),
            "{e}"
        );
        std::fs::write(d.join("seq01_frame-000000.pose.depth.tiff"), b"x").unwrap();
        assert_eq!(
            find_rendered(d, DatasetKind::SevenScenes, "seq-01/frame-000000").unwrap(),
            d.join("seq01_frame-000000.pose.depth.tiff")
        );
        std::fs::write(d.join("seq-01-frame-000000.depth.png"), b"x").unwrap();
        assert!(matches!(
            find_rendered(d, DatasetKind::SevenScenes, "seq-01/frame-000000"),
            Err(IngestError::Ambiguous { .. })
        ));
        // Cambridge has no flat names.
        assert!(
            !rendered_candidates(DatasetKind::Cambridge, "seq1/frame00001")
                .iter()
                .any(|c| c.contains('_'))
        );
    }
}
