//! Rigs and frames (COLMAP >= 3.12): a rig groups sensors with fixed relative poses, a
//! frame is one capture of a rig at a pose; an image's cam_from_world is
//! `sensor_from_rig(camera) * frame.rig_from_world` (identity for the reference sensor).

use geometry::{GeometryError, Pose};

/// COLMAP `SensorType` (stored as i32, written as its name in text files).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
#[repr(i32)]
pub enum SensorType {
    Invalid = -1,
    Camera = 0,
    Imu = 1,
}

impl SensorType {
    pub fn from_i32(v: i32) -> Option<Self> {
        match v {
            -1 => Some(SensorType::Invalid),
            0 => Some(SensorType::Camera),
            1 => Some(SensorType::Imu),
            _ => None,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            SensorType::Invalid => "INVALID",
            SensorType::Camera => "CAMERA",
            SensorType::Imu => "IMU",
        }
    }

    pub fn from_name(s: &str) -> Option<Self> {
        match s {
            "INVALID" => Some(SensorType::Invalid),
            "CAMERA" => Some(SensorType::Camera),
            "IMU" => Some(SensorType::Imu),
            _ => None,
        }
    }
}

/// A sensor of a rig: type and id (for cameras, the camera id).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct SensorId {
    pub kind: SensorType,
    pub id: u32,
}

impl SensorId {
    pub fn camera(camera_id: u32) -> Self {
        SensorId {
            kind: SensorType::Camera,
            id: camera_id,
        }
    }
}

/// A rigid transform exactly as stored: w-first quaternion (not normalised) and
/// translation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RigidTransform {
    pub qvec: [f64; 4],
    pub tvec: [f64; 3],
}

impl RigidTransform {
    pub const IDENTITY: RigidTransform = RigidTransform {
        qvec: [1.0, 0.0, 0.0, 0.0],
        tvec: [0.0; 3],
    };

    /// Checked conversion (finite, unit quaternion within tolerance).
    pub fn pose(&self) -> Result<Pose, GeometryError> {
        Pose::from_qvec_tvec(self.qvec, self.tvec)
    }

    pub fn from_pose(p: &Pose) -> Self {
        RigidTransform {
            qvec: p.qvec(),
            tvec: p.tvec(),
        }
    }

    pub fn is_finite(&self) -> bool {
        self.qvec.iter().chain(&self.tvec).all(|v| v.is_finite())
    }
}

/// A non-reference sensor of a rig and its pose relative to the rig (None: unknown).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RigSensor {
    pub sensor: SensorId,
    pub sensor_from_rig: Option<RigidTransform>,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Rig {
    pub rig_id: u32,
    /// The reference sensor (its sensor_from_rig is the identity). None only for a rig
    /// without any sensor.
    pub ref_sensor: Option<SensorId>,
    /// The other sensors, in file order.
    pub sensors: Vec<RigSensor>,
}

impl Rig {
    /// COLMAP's rig for a legacy model: one camera, which is the reference.
    pub fn single_camera(camera_id: u32) -> Self {
        Rig {
            rig_id: camera_id,
            ref_sensor: Some(SensorId::camera(camera_id)),
            sensors: Vec::new(),
        }
    }

    pub fn num_sensors(&self) -> usize {
        usize::from(self.ref_sensor.is_some()) + self.sensors.len()
    }

    /// sensor_from_rig of a sensor: Some(Some(identity)) for the reference sensor,
    /// Some(None) for a sensor with an unknown pose, None when the rig lacks it.
    pub fn sensor_from_rig(&self, sensor: SensorId) -> Option<Option<RigidTransform>> {
        if self.ref_sensor == Some(sensor) {
            return Some(Some(RigidTransform::IDENTITY));
        }
        self.sensors
            .iter()
            .find(|s| s.sensor == sensor)
            .map(|s| s.sensor_from_rig)
    }
}

/// One datum of a frame: the sensor that produced it and its id (for cameras, the
/// image id).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct DataId {
    pub sensor: SensorId,
    pub id: u64,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Frame {
    pub frame_id: u32,
    pub rig_id: u32,
    pub rig_from_world: RigidTransform,
    pub data_ids: Vec<DataId>,
}

impl Frame {
    /// COLMAP's frame for an image of a legacy model: frame id = image id, rig id =
    /// camera id, rig_from_world = the image pose.
    pub fn single_image(image_id: u32, camera_id: u32, cam_from_world: RigidTransform) -> Self {
        Frame {
            frame_id: image_id,
            rig_id: camera_id,
            rig_from_world: cam_from_world,
            data_ids: vec![DataId {
                sensor: SensorId::camera(camera_id),
                id: u64::from(image_id),
            }],
        }
    }

    /// Ids of the images of this frame (data of camera sensors).
    pub fn image_ids(&self) -> impl Iterator<Item = u64> + '_ {
        self.data_ids
            .iter()
            .filter(|d| d.sensor.kind == SensorType::Camera)
            .map(|d| d.id)
    }
}
