//! The records of a COLMAP sparse model and the model itself.
//!
//! Poses are kept exactly as stored (w-first quaternion + translation, not normalised)
//! so that a read + write round trip reproduces COLMAP's files bit for bit; `pose()`
//! turns them into a checked `geometry::Pose`.

use crate::rig::{Frame, Rig, RigidTransform};
use geometry::{Camera, GeometryError, Pose};
use std::collections::HashMap;

/// `kInvalidPoint3DId`: a 2D point without a 3D point (`-1` in text files).
pub const INVALID_POINT3D_ID: u64 = u64::MAX;

#[derive(Clone, Debug, PartialEq)]
pub struct CameraRecord {
    pub camera_id: u32,
    pub camera: Camera,
}

/// A keypoint of an image and the 3D point it observes (or `INVALID_POINT3D_ID`).
/// `repr(C)`: the same 24 bytes as one entry of images.bin.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C)]
pub struct Point2D {
    pub xy: [f64; 2],
    pub point3d_id: u64,
}

impl Point2D {
    pub fn has_point3d(&self) -> bool {
        self.point3d_id != INVALID_POINT3D_ID
    }
}

/// A registered image: world-to-camera pose, camera, name and keypoints.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    pub image_id: u32,
    /// Quaternion of cam_from_world, w first, as stored.
    pub qvec: [f64; 4],
    /// Translation of cam_from_world.
    pub tvec: [f64; 3],
    pub camera_id: u32,
    pub name: String,
    pub points2d: Vec<Point2D>,
}

impl Image {
    /// cam_from_world, checked (finite, unit quaternion within tolerance).
    pub fn pose(&self) -> Result<Pose, GeometryError> {
        Pose::from_qvec_tvec(self.qvec, self.tvec)
    }

    pub fn cam_from_world(&self) -> RigidTransform {
        RigidTransform {
            qvec: self.qvec,
            tvec: self.tvec,
        }
    }

    pub fn num_points2d(&self) -> usize {
        self.points2d.len()
    }

    /// Number of 2D points with a 3D point (COLMAP `Image::NumPoints3D`).
    pub fn num_points3d(&self) -> usize {
        self.points2d.iter().filter(|p| p.has_point3d()).count()
    }
}

/// One observation of a 3D point: image and index into its `points2d`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
#[repr(C)]
pub struct TrackElement {
    pub image_id: u32,
    pub point2d_idx: u32,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Point3D {
    pub id: u64,
    pub xyz: [f64; 3],
    pub rgb: [u8; 3],
    /// Mean reprojection error in pixels as stored; -1 means "not computed" (COLMAP).
    pub error: f64,
    pub track: Vec<TrackElement>,
}

impl Point3D {
    /// COLMAP `Point3D::HasError`: the error was computed (it is not the -1 sentinel).
    pub fn has_error(&self) -> bool {
        self.error != -1.0
    }
}

/// A sparse model. Records keep the order in which they were read, so writing a model
/// read from COLMAP's files reproduces them; `sort_by_id` orders freshly built ones.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Reconstruction {
    pub cameras: Vec<CameraRecord>,
    /// Registered images (COLMAP's files hold only those).
    pub images: Vec<Image>,
    pub points3d: Vec<Point3D>,
    pub rigs: Vec<Rig>,
    /// Frames with a pose (COLMAP's files hold only those).
    pub frames: Vec<Frame>,
}

impl Reconstruction {
    /// A checked model from freshly built records: sorted by id, with COLMAP's trivial
    /// rigs and frames added when both `rigs` and `frames` are empty, then validated.
    pub fn new(
        cameras: Vec<CameraRecord>,
        images: Vec<Image>,
        points3d: Vec<Point3D>,
        rigs: Vec<Rig>,
        frames: Vec<Frame>,
    ) -> crate::Result<Self> {
        let mut rec = Reconstruction {
            cameras,
            images,
            points3d,
            rigs,
            frames,
        };
        rec.sort_by_id();
        rec.add_trivial_rigs_and_frames();
        rec.validate()?;
        Ok(rec)
    }

    /// Orders every table by id (COLMAP writes cameras, points, rigs and frames sorted;
    /// images in registration order, which for a fresh model we take to be id order).
    pub fn sort_by_id(&mut self) {
        self.cameras.sort_by_key(|c| c.camera_id);
        self.images.sort_by_key(|i| i.image_id);
        self.points3d.sort_by_key(|p| p.id);
        self.rigs.sort_by_key(|r| r.rig_id);
        self.frames.sort_by_key(|f| f.frame_id);
    }

    /// Linear search; use [`Reconstruction::index`] for many lookups.
    pub fn camera(&self, camera_id: u32) -> Option<&CameraRecord> {
        self.cameras.iter().find(|c| c.camera_id == camera_id)
    }

    pub fn image(&self, image_id: u32) -> Option<&Image> {
        self.images.iter().find(|i| i.image_id == image_id)
    }

    pub fn image_by_name(&self, name: &str) -> Option<&Image> {
        self.images.iter().find(|i| i.name == name)
    }

    pub fn point3d(&self, id: u64) -> Option<&Point3D> {
        self.points3d.iter().find(|p| p.id == id)
    }

    pub fn rig(&self, rig_id: u32) -> Option<&Rig> {
        self.rigs.iter().find(|r| r.rig_id == rig_id)
    }

    pub fn frame(&self, frame_id: u32) -> Option<&Frame> {
        self.frames.iter().find(|f| f.frame_id == frame_id)
    }

    /// Hash maps from ids (and image names) to positions, for bulk lookups.
    pub fn index(&self) -> ModelIndex<'_> {
        ModelIndex {
            cameras: positions(self.cameras.iter().map(|c| c.camera_id)),
            images: positions(self.images.iter().map(|i| i.image_id)),
            names: positions(self.images.iter().map(|i| i.name.as_str())),
            points3d: positions(self.points3d.iter().map(|p| p.id)),
            rigs: positions(self.rigs.iter().map(|r| r.rig_id)),
            frames: positions(self.frames.iter().map(|f| f.frame_id)),
        }
    }

    pub fn num_points2d(&self) -> usize {
        self.images.iter().map(|i| i.points2d.len()).sum()
    }

    /// Sum over registered images of their 2D points with a 3D point
    /// (COLMAP `ComputeNumObservations`).
    pub fn num_observations(&self) -> usize {
        self.images.iter().map(Image::num_points3d).sum()
    }

    /// Observations per 3D point (COLMAP `ComputeMeanTrackLength`; 0 without points).
    pub fn mean_track_length(&self) -> f64 {
        if self.points3d.is_empty() {
            0.0
        } else {
            self.num_observations() as f64 / self.points3d.len() as f64
        }
    }

    /// COLMAP `ComputeMeanObservationsPerRegImage` (0 without images).
    pub fn mean_observations_per_image(&self) -> f64 {
        if self.images.is_empty() {
            0.0
        } else {
            self.num_observations() as f64 / self.images.len() as f64
        }
    }
}

fn positions<K: std::hash::Hash + Eq>(keys: impl Iterator<Item = K>) -> HashMap<K, usize> {
    let mut map = HashMap::new();
    for (i, k) in keys.enumerate() {
        map.entry(k).or_insert(i);
    }
    map
}

/// Id -> position maps of a model (the first record wins for duplicated ids, which a
/// validated model does not have).
#[derive(Clone, Debug)]
pub struct ModelIndex<'a> {
    pub cameras: HashMap<u32, usize>,
    pub images: HashMap<u32, usize>,
    pub names: HashMap<&'a str, usize>,
    pub points3d: HashMap<u64, usize>,
    pub rigs: HashMap<u32, usize>,
    pub frames: HashMap<u32, usize>,
}
