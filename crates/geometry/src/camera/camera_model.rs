//! The COLMAP camera models ([`CameraModel`]): ids, names and parameter layouts, as
//! COLMAP's sensor/models.h lists them. Its own file because both the camera
//! (`mod.rs`) and the projection math (`models.rs` and its family files) name it.

use crate::error::GeometryError;
use serde::{Deserialize, Serialize};

/// COLMAP camera model, with COLMAP's numeric id as discriminant.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[repr(i32)]
pub enum CameraModel {
    SimplePinhole = 0,
    Pinhole = 1,
    SimpleRadial = 2,
    Radial = 3,
    OpenCv = 4,
    OpenCvFisheye = 5,
    FullOpenCv = 6,
    Fov = 7,
    SimpleRadialFisheye = 8,
    RadialFisheye = 9,
    ThinPrismFisheye = 10,
    RadTanThinPrismFisheye = 11,
    SimpleDivision = 12,
    Division = 13,
    SimpleFisheye = 14,
    Fisheye = 15,
    Eucm = 16,
    Equirectangular = 17,
}

/// Static description of a model: COLMAP name and parameter names, in file order.
struct ModelInfo {
    name: &'static str,
    params: &'static [&'static str],
    /// Indices of the focal length parameters (1 or 2; empty for spherical models).
    focal: &'static [usize],
    /// Indices of the principal point (cx, cy; empty for spherical models).
    pp: &'static [usize],
}

const F1: &[usize] = &[0];
const F2: &[usize] = &[0, 1];
const PP1: &[usize] = &[1, 2];
const PP2: &[usize] = &[2, 3];

const INFO: [ModelInfo; 18] = [
    ModelInfo {
        name: "SIMPLE_PINHOLE",
        params: &["f", "cx", "cy"],
        focal: F1,
        pp: PP1,
    },
    ModelInfo {
        name: "PINHOLE",
        params: &["fx", "fy", "cx", "cy"],
        focal: F2,
        pp: PP2,
    },
    ModelInfo {
        name: "SIMPLE_RADIAL",
        params: &["f", "cx", "cy", "k"],
        focal: F1,
        pp: PP1,
    },
    ModelInfo {
        name: "RADIAL",
        params: &["f", "cx", "cy", "k1", "k2"],
        focal: F1,
        pp: PP1,
    },
    ModelInfo {
        name: "OPENCV",
        params: &["fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2"],
        focal: F2,
        pp: PP2,
    },
    ModelInfo {
        name: "OPENCV_FISHEYE",
        params: &["fx", "fy", "cx", "cy", "k1", "k2", "k3", "k4"],
        focal: F2,
        pp: PP2,
    },
    ModelInfo {
        name: "FULL_OPENCV",
        params: &[
            "fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3", "k4", "k5", "k6",
        ],
        focal: F2,
        pp: PP2,
    },
    ModelInfo {
        name: "FOV",
        params: &["fx", "fy", "cx", "cy", "omega"],
        focal: F2,
        pp: PP2,
    },
    ModelInfo {
        name: "SIMPLE_RADIAL_FISHEYE",
        params: &["f", "cx", "cy", "k"],
        focal: F1,
        pp: PP1,
    },
    ModelInfo {
        name: "RADIAL_FISHEYE",
        params: &["f", "cx", "cy", "k1", "k2"],
        focal: F1,
        pp: PP1,
    },
    ModelInfo {
        name: "THIN_PRISM_FISHEYE",
        params: &[
            "fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3", "k4", "sx1", "sy1",
        ],
        focal: F2,
        pp: PP2,
    },
    ModelInfo {
        name: "RAD_TAN_THIN_PRISM_FISHEYE",
        params: &[
            "fx", "fy", "cx", "cy", "k0", "k1", "k2", "k3", "k4", "k5", "p0", "p1", "s0", "s1",
            "s2", "s3",
        ],
        focal: F2,
        pp: PP2,
    },
    ModelInfo {
        name: "SIMPLE_DIVISION",
        params: &["f", "cx", "cy", "k"],
        focal: F1,
        pp: PP1,
    },
    ModelInfo {
        name: "DIVISION",
        params: &["fx", "fy", "cx", "cy", "k"],
        focal: F2,
        pp: PP2,
    },
    ModelInfo {
        name: "SIMPLE_FISHEYE",
        params: &["f", "cx", "cy"],
        focal: F1,
        pp: PP1,
    },
    ModelInfo {
        name: "FISHEYE",
        params: &["fx", "fy", "cx", "cy"],
        focal: F2,
        pp: PP2,
    },
    ModelInfo {
        name: "EUCM",
        params: &["fx", "fy", "cx", "cy", "alpha", "beta"],
        focal: F2,
        pp: PP2,
    },
    ModelInfo {
        name: "EQUIRECTANGULAR",
        params: &["w", "h"],
        focal: &[],
        pp: &[],
    },
];

impl CameraModel {
    /// Every model, in id order.
    pub const ALL: [CameraModel; 18] = [
        CameraModel::SimplePinhole,
        CameraModel::Pinhole,
        CameraModel::SimpleRadial,
        CameraModel::Radial,
        CameraModel::OpenCv,
        CameraModel::OpenCvFisheye,
        CameraModel::FullOpenCv,
        CameraModel::Fov,
        CameraModel::SimpleRadialFisheye,
        CameraModel::RadialFisheye,
        CameraModel::ThinPrismFisheye,
        CameraModel::RadTanThinPrismFisheye,
        CameraModel::SimpleDivision,
        CameraModel::Division,
        CameraModel::SimpleFisheye,
        CameraModel::Fisheye,
        CameraModel::Eucm,
        CameraModel::Equirectangular,
    ];

    fn info(self) -> &'static ModelInfo {
        &INFO[self as usize]
    }

    /// COLMAP's numeric model id.
    pub fn id(self) -> i32 {
        self as i32
    }

    pub fn from_id(id: i64) -> Result<Self, GeometryError> {
        if (0..18).contains(&id) {
            Ok(Self::ALL[id as usize])
        } else {
            Err(GeometryError::UnknownModelId(id))
        }
    }

    /// COLMAP's model name, e.g. `SIMPLE_RADIAL`.
    pub fn name(self) -> &'static str {
        self.info().name
    }

    pub fn from_name(name: &str) -> Result<Self, GeometryError> {
        Self::ALL
            .iter()
            .copied()
            .find(|m| m.name() == name)
            .ok_or_else(|| GeometryError::UnknownModelName(name.to_string()))
    }

    pub fn num_params(self) -> usize {
        self.info().params.len()
    }

    /// Parameter names in file order, e.g. `["f", "cx", "cy", "k"]`.
    pub fn param_names(self) -> &'static [&'static str] {
        self.info().params
    }

    pub fn focal_length_idxs(self) -> &'static [usize] {
        self.info().focal
    }

    pub fn principal_point_idxs(self) -> &'static [usize] {
        self.info().pp
    }

    /// False only for the spherical EQUIRECTANGULAR model, which has no image plane.
    pub fn is_perspective(self) -> bool {
        self != CameraModel::Equirectangular
    }
}

impl std::fmt::Display for CameraModel {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}
