//! Reprojection errors, as COLMAP defines them.
//!
//! COLMAP's `ComputeMeanReprojectionError` (what pycolmap's summary prints) is the mean
//! of the *stored* per-point errors over the points that have one (error != -1); each
//! stored error is, when COLMAP last ran `UpdatePoint3DErrors`, the mean over the track
//! of the pixel distance between the observation and the projected point. The
//! recomputing variants below do that computation with `geometry::Camera::project`.

use crate::check::IdLookup;
use crate::error::{Located, Problem, RecordRef, Table};
use crate::model::{Point3D, Reconstruction};
use nalgebra::{Vector2, Vector3};

impl Reconstruction {
    /// Mean of the stored point errors over the points that have one (COLMAP
    /// `ComputeMeanReprojectionError`); 0 when none has.
    pub fn mean_reprojection_error(&self) -> f64 {
        let (sum, n) = self
            .points3d
            .iter()
            .filter(|p| p.has_error())
            .fold((0.0, 0usize), |(s, n), p| (s + p.error, n + 1));
        if n == 0 { 0.0 } else { sum / n as f64 }
    }

    /// Per point (in `points3d` order), the mean over its track of the distance in
    /// pixels between the observation and the projection of the point (COLMAP
    /// `UpdatePoint3DErrors`; 0 for an empty track). An observation the camera cannot
    /// image (behind it, outside a fisheye's domain) counts as +inf, where COLMAP uses
    /// sqrt(DBL_MAX).
    pub fn reprojection_errors(&self) -> crate::Result<Vec<f64>> {
        let ctx = Context::new(self).map_err(Located::into_invalid)?;
        self.points3d
            .iter()
            .enumerate()
            .map(|(i, p)| ctx.point_error(i, p).map_err(Located::into_invalid))
            .collect()
    }

    /// Mean over points of [`Reconstruction::reprojection_errors`] (what
    /// `mean_reprojection_error` returns after COLMAP's `UpdatePoint3DErrors`).
    pub fn recomputed_mean_reprojection_error(&self) -> crate::Result<f64> {
        let errors = self.reprojection_errors()?;
        Ok(if errors.is_empty() {
            0.0
        } else {
            errors.iter().sum::<f64>() / errors.len() as f64
        })
    }

    /// Replaces every stored point error by the recomputed one.
    pub fn update_point_errors(&mut self) -> crate::Result<()> {
        let errors = self.reprojection_errors()?;
        for (p, e) in self.points3d.iter_mut().zip(errors) {
            p.error = e;
        }
        Ok(())
    }
}

struct Context<'a> {
    rec: &'a Reconstruction,
    images: IdLookup,
    /// Per image: position of its camera and its checked pose.
    image_info: Vec<(usize, geometry::Pose)>,
}

impl<'a> Context<'a> {
    fn new(rec: &'a Reconstruction) -> Result<Self, Located> {
        let cameras =
            IdLookup::build(rec.cameras.iter().map(|c| c.camera_id)).map_err(|(i, f)| {
                Located::record(
                    RecordRef {
                        table: Table::Cameras,
                        index: i,
                        id: Some(u64::from(rec.cameras[i].camera_id)),
                    },
                    Problem::DuplicateId {
                        id: u64::from(rec.cameras[i].camera_id),
                        first_index: f,
                    },
                )
            })?;
        let images = IdLookup::build(rec.images.iter().map(|i| i.image_id)).map_err(|(i, f)| {
            Located::record(
                RecordRef {
                    table: Table::Images,
                    index: i,
                    id: Some(u64::from(rec.images[i].image_id)),
                },
                Problem::DuplicateId {
                    id: u64::from(rec.images[i].image_id),
                    first_index: f,
                },
            )
        })?;
        let mut image_info = Vec::with_capacity(rec.images.len());
        for (i, im) in rec.images.iter().enumerate() {
            let at = RecordRef {
                table: Table::Images,
                index: i,
                id: Some(u64::from(im.image_id)),
            };
            let cam = cameras
                .get(im.camera_id)
                .ok_or_else(|| Located::record(at, Problem::UnknownCamera(im.camera_id)))?;
            let pose = im.pose().map_err(|source| {
                Located::record(
                    at,
                    Problem::Geometry {
                        what: "cam_from_world",
                        source,
                    },
                )
            })?;
            image_info.push((cam, pose));
        }
        Ok(Context {
            rec,
            images,
            image_info,
        })
    }

    fn point_error(&self, index: usize, p: &Point3D) -> Result<f64, Located> {
        if p.track.is_empty() {
            return Ok(0.0);
        }
        let at = RecordRef {
            table: Table::Points3D,
            index,
            id: Some(p.id),
        };
        let xyz = Vector3::from(p.xyz);
        let mut sum = 0.0;
        for el in &p.track {
            let ii = self
                .images
                .get(el.image_id)
                .ok_or_else(|| Located::record(at, Problem::UnknownImage(el.image_id)))?;
            let im = &self.rec.images[ii];
            let p2 = im.points2d.get(el.point2d_idx as usize).ok_or_else(|| {
                Located::record(
                    at,
                    Problem::Point2DOutOfRange {
                        image_id: el.image_id,
                        idx: el.point2d_idx,
                        num_points2d: im.points2d.len(),
                    },
                )
            })?;
            let (cam, pose) = &self.image_info[ii];
            let camera = &self.rec.cameras[*cam].camera;
            sum += match camera.project(&pose.transform_point(&xyz)) {
                Some(px) => (px - Vector2::from(p2.xy)).norm(),
                None => f64::INFINITY,
            };
        }
        Ok(sum / p.track.len() as f64)
    }
}
