//! The Foxglove channels of a shard, built from a [`FrameRecord`] with the message
//! types and descriptor sets of the `foxglove` crate (foxglove-sdk's schemas).
//!
//! Frames of reference: `world` (the SfM model's frame) and one fixed `camera` frame
//! whose pose in `world` changes with every frame (`/tf`). The image and its
//! calibration are in `camera`; the 3D labels are in `world`. Scrubbing through a
//! shard in Foxglove's 3D panel then shows the camera moving through the labels.

use crate::record::FrameRecord;
use foxglove::messages::{
    CameraCalibration, Color, CompressedImage, FrameTransform, LinePrimitive, PackedElementField,
    Point3, PointCloud, Pose as FgPose, Quaternion as FgQuaternion, SceneEntity, SceneUpdate,
    Timestamp, Vector3 as FgVector3, line_primitive, packed_element_field,
};
use geometry::{Camera, CameraModel, Pose};

/// Parent frame of `/tf` and frame of the 3D labels.
pub const WORLD_FRAME: &str = "world";
/// Frame of the image, the calibration and the child of `/tf`.
pub const CAMERA_FRAME: &str = "camera";
/// Entity id of the line labels in `/labels/lines`; the same id in every frame, so
/// each frame's lines replace the previous frame's.
pub const LINES_ENTITY_ID: &str = "labels/lines";

pub(crate) fn timestamp(log_time_ns: u64) -> Option<Timestamp> {
    let sec = u32::try_from(log_time_ns / 1_000_000_000).ok()?;
    Timestamp::new_checked(sec, (log_time_ns % 1_000_000_000) as u32)
}

pub(crate) fn compressed_image(f: &FrameRecord, ts: Timestamp) -> CompressedImage {
    CompressedImage {
        timestamp: Some(ts),
        frame_id: CAMERA_FRAME.into(),
        data: f.image_bytes.clone(),
        format: f.image_format.as_str().into(),
    }
}

/// Foxglove's name and coefficients for the distortion of a COLMAP model, where the
/// two models are the same function of the normalised image point:
/// - SIMPLE_RADIAL, RADIAL, OPENCV -> `plumb_bob` [k1, k2, p1, p2, k3];
/// - FULL_OPENCV -> `rational_polynomial` [k1, k2, p1, p2, k3, k4, k5, k6] (COLMAP's
///   parameter order after fx fy cx cy is already OpenCV's);
/// - OPENCV_FISHEYE, SIMPLE_RADIAL_FISHEYE, RADIAL_FISHEYE and the pure equidistant
///   SIMPLE_FISHEYE, FISHEYE -> `kannala_brandt` [k1, k2, k3, k4] (OpenCV fisheye:
///   theta_d = theta (1 + k1 theta^2 + k2 theta^4 + k3 theta^6 + k4 theta^8));
/// - pinhole models -> `plumb_bob` with zeros.
///
/// None where Foxglove has no equal model (FOV, the division models, EUCM, the thin
/// prism fisheyes, EQUIRECTANGULAR): the calibration then carries K only and an empty
/// model name, and Foxglove shows the image without undistortion.
pub fn foxglove_distortion(camera: &Camera) -> Option<(&'static str, Vec<f64>)> {
    use CameraModel::*;
    let p = &camera.params;
    // The parameters after the focal length(s) and principal point.
    let extra = p.get(camera.model.focal_length_idxs().len() + 2..)?;
    let d = match camera.model {
        SimplePinhole | Pinhole => ("plumb_bob", vec![0.0; 5]),
        SimpleRadial => ("plumb_bob", vec![extra[0], 0.0, 0.0, 0.0, 0.0]),
        Radial => ("plumb_bob", vec![extra[0], extra[1], 0.0, 0.0, 0.0]),
        OpenCv => (
            "plumb_bob",
            vec![extra[0], extra[1], extra[2], extra[3], 0.0],
        ),
        FullOpenCv => ("rational_polynomial", extra.to_vec()),
        OpenCvFisheye => ("kannala_brandt", extra.to_vec()),
        SimpleRadialFisheye => ("kannala_brandt", vec![extra[0], 0.0, 0.0, 0.0]),
        RadialFisheye => ("kannala_brandt", vec![extra[0], extra[1], 0.0, 0.0]),
        SimpleFisheye | Fisheye => ("kannala_brandt", vec![0.0; 4]),
        Fov
        | SimpleDivision
        | Division
        | Eucm
        | ThinPrismFisheye
        | RadTanThinPrismFisheye
        | Equirectangular => return None,
    };
    Some(d)
}

/// K from the camera's pinhole part, P = [K | 0], R = I, in the `camera` frame. For
/// EQUIRECTANGULAR, which has no pinhole part, K is all zeros: Foxglove reads
/// K[0] == 0 as "uncalibrated". Also the score crate's `visual.mcap`.
pub fn camera_calibration(cam: &Camera, ts: Timestamp) -> CameraCalibration {
    let k = if cam.model.is_perspective() {
        let (fx, fy) = cam.focal_xy();
        let (cx, cy) = cam.principal_point();
        vec![fx, 0.0, cx, 0.0, fy, cy, 0.0, 0.0, 1.0]
    } else {
        vec![0.0; 9]
    };
    let p = vec![
        k[0], k[1], k[2], 0.0, k[3], k[4], k[5], 0.0, k[6], k[7], k[8], 0.0,
    ];
    let (model, d) = foxglove_distortion(cam)
        .map(|(m, d)| (m.to_string(), d))
        .unwrap_or_default();
    CameraCalibration {
        timestamp: Some(ts),
        frame_id: CAMERA_FRAME.into(),
        // Foxglove's sizes are u32; saturate rather than wrap a larger (bogus) size.
        width: u32::try_from(cam.width).unwrap_or(u32::MAX),
        height: u32::try_from(cam.height).unwrap_or(u32::MAX),
        distortion_model: model,
        d,
        k,
        r: vec![1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
        p,
    }
}

/// The camera's pose in the world (the inverse of the world-to-camera pose: rotation
/// R^T, translation -R^T t), as Foxglove's child-in-parent transform `world` -> `child`.
/// Also the score crate's `visual.mcap` (estimate and ground truth).
pub fn camera_transform(world_to_camera: &Pose, child: &str, ts: Timestamp) -> FrameTransform {
    let cam_in_world = world_to_camera.inverse();
    let q = cam_in_world.rotation.quaternion();
    let t = cam_in_world.translation;
    FrameTransform {
        timestamp: Some(ts),
        parent_frame_id: WORLD_FRAME.into(),
        child_frame_id: child.into(),
        translation: Some(FgVector3 {
            x: t.x,
            y: t.y,
            z: t.z,
        }),
        rotation: Some(FgQuaternion {
            x: q.i,
            y: q.j,
            z: q.k,
            w: q.w,
        }),
    }
}

/// The pose of an entity drawn in world coordinates.
pub fn identity_pose() -> FgPose {
    FgPose {
        position: Some(FgVector3 {
            x: 0.0,
            y: 0.0,
            z: 0.0,
        }),
        orientation: Some(FgQuaternion {
            x: 0.0,
            y: 0.0,
            z: 0.0,
            w: 1.0,
        }),
    }
}

/// Bytes per point of `/labels/points`: x, y, z as little-endian float32.
pub const POINT_STRIDE: u32 = 12;

/// The valid 3D point labels of the frame, in `world`.
pub(crate) fn point_cloud(f: &FrameRecord, ts: Timestamp) -> PointCloud {
    let mut data = Vec::with_capacity(f.valid_points() * POINT_STRIDE as usize);
    for (p, _) in f.points3d.iter().zip(&f.point_valid).filter(|(_, v)| **v) {
        for c in p {
            data.extend_from_slice(&(*c as f32).to_le_bytes());
        }
    }
    let field = |name: &str, offset: u32| PackedElementField {
        name: name.into(),
        offset,
        r#type: packed_element_field::NumericType::Float32 as i32,
    };
    PointCloud {
        timestamp: Some(ts),
        frame_id: WORLD_FRAME.into(),
        pose: Some(identity_pose()),
        point_stride: POINT_STRIDE,
        fields: vec![field("x", 0), field("y", 4), field("z", 8)],
        data: data.into(),
    }
}

/// The valid 3D line labels of the frame as one LINE_LIST (endpoint pairs), in
/// `world`.
pub(crate) fn scene_update(f: &FrameRecord, ts: Timestamp) -> SceneUpdate {
    let mut points = Vec::with_capacity(2 * f.valid_lines());
    for (l, _) in f.lines3d.iter().zip(&f.line_valid).filter(|(_, v)| **v) {
        points.push(Point3 {
            x: l[0],
            y: l[1],
            z: l[2],
        });
        points.push(Point3 {
            x: l[3],
            y: l[4],
            z: l[5],
        });
    }
    let lines = LinePrimitive {
        r#type: line_primitive::Type::LineList as i32,
        pose: Some(identity_pose()),
        thickness: 2.0,
        scale_invariant: true,
        points,
        color: Some(Color {
            r: 1.0,
            g: 0.55,
            b: 0.0,
            a: 1.0,
        }),
        colors: vec![],
        indices: vec![],
    };
    SceneUpdate {
        deletions: vec![],
        entities: vec![SceneEntity {
            timestamp: Some(ts),
            frame_id: WORLD_FRAME.into(),
            id: LINES_ENTITY_ID.into(),
            lifetime: None,
            frame_locked: false,
            lines: vec![lines],
            ..Default::default()
        }],
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::record::{ImageFormat, LabelSource, Split};
    use geometry::Pose;
    use nalgebra::{UnitQuaternion, Vector3};

    fn frame(camera: Camera) -> FrameRecord {
        FrameRecord {
            frame_id: 1,
            name: "a.png".into(),
            split: Split::Train,
            camera,
            pose: Pose::new(
                UnitQuaternion::from_euler_angles(0.1, -0.4, 0.9),
                Vector3::new(0.3, -1.0, 2.0),
            ),
            image_bytes: Default::default(),
            image_format: ImageFormat::Png,
            keypoints: vec![[0.0; 2]; 3],
            point3d_ids: vec![0, -1, 2],
            points3d: vec![[1.0, 2.0, 3.0], [f64::NAN; 3], [-4.0, 5.5, 0.25]],
            point_valid: vec![true, false, true],
            segments: vec![[0.0; 4]; 2],
            track_ids: vec![0, 1],
            lines3d: vec![[0.0; 6], [1.0, 2.0, 3.0, 4.0, 5.0, 6.0]],
            line_valid: vec![false, true],
            label_source: LabelSource::Sfm,
            endpoints_aligned: true,
        }
    }

    #[test]
    fn transform_is_the_camera_pose_in_the_world() {
        let f = frame(Camera::new(CameraModel::Pinhole, 8, 6, vec![5.0, 6.0, 4.0, 3.0]).unwrap());
        let tf = camera_transform(&f.pose, CAMERA_FRAME, Timestamp::new(0, 0));
        let t = tf.translation.unwrap();
        let c = f.pose.centre();
        assert!(
            (t.x - c.x).abs() < 1e-15 && (t.y - c.y).abs() < 1e-15 && (t.z - c.z).abs() < 1e-15
        );
        // A point on the camera's optical axis, 2 m ahead, computed by composing the
        // transform by hand (child-in-parent: X_world = R_fg X_cam + t_fg) ...
        let r = tf.rotation.unwrap();
        let q = UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(r.w, r.x, r.y, r.z));
        let x_world = q * Vector3::new(0.0, 0.0, 2.0) + Vector3::new(t.x, t.y, t.z);
        // ... lands at depth 2 on the axis of the world-to-camera pose.
        let x_cam = f.pose.transform_point(&x_world);
        assert!((x_cam - Vector3::new(0.0, 0.0, 2.0)).norm() < 1e-12);
        assert_eq!(
            (tf.parent_frame_id.as_str(), tf.child_frame_id.as_str()),
            ("world", "camera")
        );
    }

    #[test]
    fn calibration_k_p_and_distortion() {
        let f = frame(
            Camera::new(
                CameraModel::OpenCv,
                640,
                480,
                vec![500.0, 510.0, 320.5, 240.5, -0.1, 0.01, 0.001, -0.002],
            )
            .unwrap(),
        );
        let c = camera_calibration(&f.camera, Timestamp::new(1, 5));
        assert_eq!(
            c.k,
            vec![500.0, 0.0, 320.5, 0.0, 510.0, 240.5, 0.0, 0.0, 1.0]
        );
        assert_eq!(
            c.p,
            vec![
                500.0, 0.0, 320.5, 0.0, 0.0, 510.0, 240.5, 0.0, 0.0, 0.0, 1.0, 0.0
            ]
        );
        assert_eq!(c.distortion_model, "plumb_bob");
        assert_eq!(c.d, vec![-0.1, 0.01, 0.001, -0.002, 0.0]);
        assert_eq!(
            (c.width, c.height, c.frame_id.as_str()),
            (640, 480, "camera")
        );

        let full = Camera::new(
            CameraModel::FullOpenCv,
            10,
            10,
            (1..=12).map(f64::from).collect(),
        )
        .unwrap();
        assert_eq!(
            foxglove_distortion(&full),
            Some((
                "rational_polynomial",
                vec![5.0, 6.0, 7.0, 8.0, 9.0, 10.0, 11.0, 12.0]
            ))
        );
        let fish = Camera::new(
            CameraModel::RadialFisheye,
            10,
            10,
            vec![1.0, 2.0, 3.0, 0.1, 0.2],
        )
        .unwrap();
        assert_eq!(
            foxglove_distortion(&fish),
            Some(("kannala_brandt", vec![0.1, 0.2, 0.0, 0.0]))
        );
        let fov = Camera::new(CameraModel::Fov, 10, 10, vec![1.0, 1.0, 5.0, 5.0, 0.9]).unwrap();
        assert_eq!(foxglove_distortion(&fov), None);
        let eq =
            frame(Camera::new(CameraModel::Equirectangular, 100, 50, vec![100.0, 50.0]).unwrap());
        let c = camera_calibration(&eq.camera, Timestamp::new(0, 0));
        assert_eq!(c.k[0], 0.0, "no pinhole part: uncalibrated for Foxglove");
        assert_eq!(c.distortion_model, "");
    }

    #[test]
    fn points_and_lines_hold_only_valid_labels() {
        let f = frame(Camera::new(CameraModel::SimplePinhole, 8, 6, vec![5.0, 4.0, 3.0]).unwrap());
        let pc = point_cloud(&f, Timestamp::new(0, 0));
        let floats: Vec<f32> = pc
            .data
            .chunks_exact(4)
            .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
            .collect();
        assert_eq!(floats, vec![1.0, 2.0, 3.0, -4.0, 5.5, 0.25]);
        assert_eq!(pc.frame_id, "world");
        let su = scene_update(&f, Timestamp::new(0, 0));
        let line = &su.entities[0].lines[0];
        assert_eq!(line.r#type, line_primitive::Type::LineList as i32);
        let xyz: Vec<[f64; 3]> = line.points.iter().map(|p| [p.x, p.y, p.z]).collect();
        assert_eq!(xyz, vec![[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]]);
    }

    #[test]
    fn timestamps_split_seconds_and_refuse_overflow() {
        let t = timestamp(12_300_000_000).unwrap();
        assert_eq!((t.sec(), t.nsec()), (12, 300_000_000));
        assert!(timestamp(u64::MAX).is_none());
    }
}
