//! A small hand-built model that uses every feature of the formats: two camera models,
//! a rig with a posed second camera and an IMU without pose, an image without 2D points,
//! 2D points with and without 3D points.

use colmap::{
    CameraRecord, DataId, Format, Frame, INVALID_POINT3D_ID, Image, Point2D, Point3D,
    Reconstruction, Rig, RigSensor, RigidTransform, SensorId, SensorType, Table, TrackElement,
};
use geometry::{Camera, CameraModel, Pose, UnitQuaternion, Vector3};

pub fn model() -> Reconstruction {
    let cameras = vec![
        CameraRecord {
            camera_id: 1,
            camera: Camera::new(
                CameraModel::Pinhole,
                640,
                480,
                vec![500.0, 510.0, 320.0, 240.0],
            )
            .unwrap(),
        },
        CameraRecord {
            camera_id: 2,
            camera: Camera::new(
                CameraModel::SimpleRadial,
                800,
                600,
                vec![600.0, 400.0, 300.0, 0.01],
            )
            .unwrap(),
        },
    ];
    let rig_from_world = Pose::new(
        UnitQuaternion::from_euler_angles(0.1, -0.2, 0.3),
        Vector3::new(0.5, -1.0, 2.0),
    );
    let cam2_from_rig = Pose::new(
        UnitQuaternion::from_euler_angles(0.0, 0.05, 0.0),
        Vector3::new(-0.2, 0.0, 0.0),
    );
    let cam2_from_world = cam2_from_rig.compose(&rig_from_world);
    let frame2_pose = Pose::new(
        UnitQuaternion::from_euler_angles(-0.1, 0.0, 0.2),
        Vector3::new(1.0, 0.0, 3.0),
    );
    let rigs = vec![Rig {
        rig_id: 1,
        ref_sensor: Some(SensorId::camera(1)),
        sensors: vec![
            RigSensor {
                sensor: SensorId::camera(2),
                sensor_from_rig: Some(RigidTransform::from_pose(&cam2_from_rig)),
            },
            RigSensor {
                sensor: SensorId {
                    kind: SensorType::Imu,
                    id: 1,
                },
                sensor_from_rig: None,
            },
        ],
    }];
    let frames = vec![
        Frame {
            frame_id: 1,
            rig_id: 1,
            rig_from_world: RigidTransform::from_pose(&rig_from_world),
            data_ids: vec![
                DataId {
                    sensor: SensorId::camera(1),
                    id: 1,
                },
                DataId {
                    sensor: SensorId::camera(2),
                    id: 2,
                },
            ],
        },
        Frame {
            frame_id: 2,
            rig_id: 1,
            rig_from_world: RigidTransform::from_pose(&frame2_pose),
            data_ids: vec![DataId {
                sensor: SensorId::camera(1),
                id: 3,
            }],
        },
    ];
    let p = |x: f64, y: f64, id: u64| Point2D {
        xy: [x, y],
        point3d_id: id,
    };
    let image =
        |image_id: u32, camera_id: u32, pose: &Pose, name: &str, points2d: Vec<Point2D>| Image {
            image_id,
            qvec: pose.qvec(),
            tvec: pose.tvec(),
            camera_id,
            name: name.to_string(),
            points2d,
        };
    let images = vec![
        image(
            1,
            1,
            &rig_from_world,
            "rig/cam1/0001.png",
            vec![
                p(10.5, 20.25, 1),
                p(100.0, 200.0, INVALID_POINT3D_ID),
                p(33.0, 44.0, 2),
            ],
        ),
        image(
            2,
            2,
            &cam2_from_world,
            "rig/cam2/0001.png",
            vec![p(50.0, 60.0, 2), p(70.0, 80.0, 1)],
        ),
        image(3, 1, &frame2_pose, "rig/cam1/0002.png", vec![]),
    ];
    let el = |image_id, point2d_idx| TrackElement {
        image_id,
        point2d_idx,
    };
    let points3d = vec![
        Point3D {
            id: 1,
            xyz: [0.1, 0.2, 5.0],
            rgb: [255, 0, 7],
            error: 0.5,
            track: vec![el(1, 0), el(2, 1)],
        },
        Point3D {
            id: 2,
            xyz: [-1.0, 0.5, 4.0],
            rgb: [1, 2, 3],
            error: -1.0,
            track: vec![el(2, 0), el(1, 2)],
        },
        Point3D {
            id: 7,
            xyz: [3.0, 3.0, 3.0],
            rgb: [9, 9, 9],
            error: 0.0,
            track: vec![],
        },
    ];
    Reconstruction::new(cameras, images, points3d, rigs, frames).unwrap()
}

pub const TABLES: [Table; 5] = [
    Table::Cameras,
    Table::Images,
    Table::Points3D,
    Table::Rigs,
    Table::Frames,
];

/// The five files of the model in one format.
pub fn files(rec: &Reconstruction, format: Format) -> Vec<Vec<u8>> {
    TABLES
        .iter()
        .map(|&t| colmap::io::encode(rec, t, format).unwrap())
        .collect()
}

pub fn parse_bin(f: &[Vec<u8>]) -> colmap::Result<Reconstruction> {
    colmap::binary::parse_model(
        std::path::Path::new("model"),
        &colmap::binary::BinaryFiles {
            cameras: &f[0],
            images: &f[1],
            points3d: &f[2],
            rigs: Some(&f[3]),
            frames: Some(&f[4]),
        },
    )
}

pub fn parse_txt(f: &[String]) -> colmap::Result<Reconstruction> {
    colmap::text::parse_model(
        std::path::Path::new("model"),
        &colmap::text::TextFiles {
            cameras: &f[0],
            images: &f[1],
            points3d: &f[2],
            rigs: Some(&f[3]),
            frames: Some(&f[4]),
        },
    )
}

pub fn text_files(rec: &Reconstruction) -> Vec<String> {
    files(rec, Format::Text)
        .into_iter()
        .map(|b| String::from_utf8(b).unwrap())
        .collect()
}
