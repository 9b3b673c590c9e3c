//! Model invariants, checked after reading (COLMAP enforces the same ones with
//! THROW_CHECKs while it builds its in-memory model): unique ids, known cameras / rigs /
//! images, tracks and 2D points that refer to each other one to one, and image poses
//! that agree with their frames.

use crate::error::{Located, Location, Problem, RecordRef, Table};
use crate::model::{INVALID_POINT3D_ID, Reconstruction};
use crate::rig::{Frame, Rig, SensorId};
use std::collections::HashMap;
use std::collections::hash_map::Entry;

/// Largest difference accepted between an image's stored pose and the pose composed
/// from its frame and rig: rotation angle in radians, translation relative to
/// max(1, |t|). COLMAP recomputes one from the other in double precision, so agreeing
/// files differ by rounding only (~1e-16).
pub const POSE_TOLERANCE: f64 = 1e-9;

fn rec(table: Table, index: usize, id: u64) -> RecordRef {
    RecordRef {
        table,
        index,
        id: Some(id),
    }
}

/// Positions of ids: a dense table when the ids are small (the usual 1..=n), else a map.
pub(crate) enum IdLookup {
    Dense(Vec<u32>),
    Sparse(HashMap<u32, u32>),
}

impl IdLookup {
    pub(crate) fn get(&self, id: u32) -> Option<usize> {
        match self {
            IdLookup::Dense(v) => match v.get(id as usize) {
                Some(&i) if i != u32::MAX => Some(i as usize),
                _ => None,
            },
            IdLookup::Sparse(m) => m.get(&id).map(|&i| i as usize),
        }
    }

    /// Builds the lookup; Err((position, first position)) on a duplicated id.
    pub(crate) fn build(
        ids: impl ExactSizeIterator<Item = u32> + Clone,
    ) -> Result<Self, (usize, usize)> {
        let n = ids.len();
        let max = ids.clone().max().unwrap_or(0) as usize;
        if max <= 4 * n + 1024 {
            let mut v = vec![u32::MAX; max + 1];
            for (i, id) in ids.enumerate() {
                let slot = &mut v[id as usize];
                if *slot != u32::MAX {
                    return Err((i, *slot as usize));
                }
                *slot = i as u32;
            }
            Ok(IdLookup::Dense(v))
        } else {
            let mut m = HashMap::with_capacity(n);
            for (i, id) in ids.enumerate() {
                match m.entry(id) {
                    Entry::Occupied(e) => return Err((i, *e.get() as usize)),
                    Entry::Vacant(e) => {
                        e.insert(i as u32);
                    }
                }
            }
            Ok(IdLookup::Sparse(m))
        }
    }
}

fn unique_ids(
    table: Table,
    ids: impl ExactSizeIterator<Item = u32> + Clone,
) -> Result<IdLookup, Located> {
    IdLookup::build(ids.clone()).map_err(|(i, first)| {
        let id = u64::from(ids.clone().nth(i).unwrap_or_default());
        Located::record(
            rec(table, i, id),
            Problem::DuplicateId {
                id,
                first_index: first,
            },
        )
    })
}

fn geometry(record: RecordRef, what: &'static str, source: geometry::GeometryError) -> Located {
    Located::record(record, Problem::Geometry { what, source })
}

impl Reconstruction {
    /// COLMAP's rule for models without rigs and frames (older than 3.12): one rig per
    /// camera (rig id = camera id) and one frame per image (frame id = image id,
    /// rig_from_world = the image pose). Does nothing when either table has entries.
    pub fn add_trivial_rigs_and_frames(&mut self) {
        if !self.rigs.is_empty() || !self.frames.is_empty() {
            return;
        }
        let mut cam_ids: Vec<u32> = self.cameras.iter().map(|c| c.camera_id).collect();
        cam_ids.sort_unstable();
        cam_ids.dedup();
        self.rigs = cam_ids.into_iter().map(Rig::single_camera).collect();
        let mut frames: Vec<Frame> = self
            .images
            .iter()
            .map(|im| Frame::single_image(im.image_id, im.camera_id, im.cam_from_world()))
            .collect();
        frames.sort_by_key(|f| f.frame_id);
        self.frames = frames;
    }

    /// Checks every invariant of a model (see the module docs).
    pub fn validate(&self) -> crate::Result<()> {
        self.check().map_err(Located::into_invalid)
    }

    pub(crate) fn check(&self) -> Result<(), Located> {
        let cameras = unique_ids(Table::Cameras, self.cameras.iter().map(|c| c.camera_id))?;
        for (i, c) in self.cameras.iter().enumerate() {
            c.camera.validate().map_err(|e| {
                geometry(rec(Table::Cameras, i, u64::from(c.camera_id)), "camera", e)
            })?;
        }
        let rigs = unique_ids(Table::Rigs, self.rigs.iter().map(|r| r.rig_id))?;
        for (i, r) in self.rigs.iter().enumerate() {
            let at = rec(Table::Rigs, i, u64::from(r.rig_id));
            if r.ref_sensor.is_none() && !r.sensors.is_empty() {
                return Err(Located::record(
                    at,
                    Problem::SensorsWithoutReference {
                        count: r.sensors.len(),
                    },
                ));
            }
            for s in &r.sensors {
                if let Some(t) = &s.sensor_from_rig {
                    t.pose().map_err(|e| geometry(at, "sensor_from_rig", e))?;
                }
            }
        }
        // Images before frames: for a legacy model the frames are derived from the
        // images, so an image's unknown camera must be reported as such.
        let (images, num_observations) = self.check_images(&cameras)?;
        unique_ids(Table::Frames, self.frames.iter().map(|f| f.frame_id))?;
        for (i, f) in self.frames.iter().enumerate() {
            let at = rec(Table::Frames, i, u64::from(f.frame_id));
            if rigs.get(f.rig_id).is_none() {
                return Err(Located::record(at, Problem::UnknownRig(f.rig_id)));
            }
            f.rig_from_world
                .pose()
                .map_err(|e| geometry(at, "rig_from_world", e))?;
        }
        self.check_frames_of_images(&rigs)?;
        self.check_points(&images, num_observations)
    }

    /// Returns the image lookup and the number of observations.
    fn check_images(&self, cameras: &IdLookup) -> Result<(IdLookup, usize), Located> {
        let images = unique_ids(Table::Images, self.images.iter().map(|i| i.image_id))?;
        let mut names: HashMap<&str, usize> = HashMap::with_capacity(self.images.len());
        let mut num_observations = 0;
        for (i, im) in self.images.iter().enumerate() {
            let at = rec(Table::Images, i, u64::from(im.image_id));
            if let Some(&first) = names.get(im.name.as_str()) {
                return Err(Located::record(
                    at,
                    Problem::DuplicateName {
                        name: im.name.clone(),
                        first_index: first,
                    },
                ));
            }
            names.insert(&im.name, i);
            if cameras.get(im.camera_id).is_none() {
                return Err(Located::record(at, Problem::UnknownCamera(im.camera_id)));
            }
            im.pose().map_err(|e| geometry(at, "cam_from_world", e))?;
            let mut finite = true;
            for p in &im.points2d {
                finite &= p.xy[0].is_finite() & p.xy[1].is_finite();
                num_observations += usize::from(p.has_point3d());
            }
            if !finite {
                return Err(Located::record(
                    at,
                    Problem::NonFinite {
                        what: "point2D coordinate",
                    },
                ));
            }
        }
        Ok((images, num_observations))
    }

    /// With rigs/frames present, every image belongs to exactly one frame, through a
    /// sensor of that frame's rig, and its stored pose equals the composed one.
    fn check_frames_of_images(&self, rigs: &IdLookup) -> Result<(), Located> {
        if self.rigs.is_empty() && self.frames.is_empty() {
            return Ok(());
        }
        // image id -> (frame position, data sensor id)
        let mut image_frame: HashMap<u64, (usize, SensorId)> = HashMap::new();
        for (fi, f) in self.frames.iter().enumerate() {
            for d in f
                .data_ids
                .iter()
                .filter(|d| d.sensor.kind == crate::rig::SensorType::Camera)
            {
                if let Some(&(first, _)) = image_frame.get(&d.id) {
                    let at = rec(Table::Frames, fi, u64::from(f.frame_id));
                    return Err(Located::record(
                        at,
                        Problem::ImageInTwoFrames {
                            first: self.frames[first].frame_id,
                            second: f.frame_id,
                        },
                    ));
                }
                image_frame.insert(d.id, (fi, d.sensor));
            }
        }
        for (i, im) in self.images.iter().enumerate() {
            let at = rec(Table::Images, i, u64::from(im.image_id));
            let Some(&(fi, sensor)) = image_frame.get(&u64::from(im.image_id)) else {
                return Err(Located::record(at, Problem::ImageWithoutFrame));
            };
            if sensor.id != im.camera_id {
                return Err(Located::record(
                    at,
                    Problem::FrameSensorMismatch {
                        sensor_id: sensor.id,
                        camera_id: im.camera_id,
                    },
                ));
            }
            let frame = &self.frames[fi];
            // Frames were checked to have a known rig.
            let Some(rig) = rigs.get(frame.rig_id).and_then(|r| self.rigs.get(r)) else {
                return Err(Located::record(at, Problem::UnknownRig(frame.rig_id)));
            };
            let sensor_from_rig = match rig.sensor_from_rig(SensorId::camera(im.camera_id)) {
                None => {
                    return Err(Located::record(
                        at,
                        Problem::SensorNotInRig {
                            rig_id: rig.rig_id,
                            camera_id: im.camera_id,
                        },
                    ));
                }
                Some(None) => {
                    return Err(Located::record(
                        at,
                        Problem::SensorPoseMissing {
                            rig_id: rig.rig_id,
                            camera_id: im.camera_id,
                        },
                    ));
                }
                Some(Some(t)) => t,
            };
            let stored = im.pose().map_err(|e| geometry(at, "cam_from_world", e))?;
            let composed = sensor_from_rig
                .pose()
                .and_then(|s| Ok(s.compose(&frame.rig_from_world.pose()?)))
                .map_err(|e| geometry(at, "composed cam_from_world", e))?;
            let rotation_rad = stored.rotation.angle_to(&composed.rotation);
            let translation = (stored.translation - composed.translation).norm()
                / stored.translation.norm().max(1.0);
            if !(rotation_rad <= POSE_TOLERANCE && translation <= POSE_TOLERANCE) {
                return Err(Located::record(
                    at,
                    Problem::PoseMismatch {
                        rotation_rad,
                        translation,
                        tolerance: POSE_TOLERANCE,
                    },
                ));
            }
        }
        Ok(())
    }

    fn check_points(&self, images: &IdLookup, num_observations: usize) -> Result<(), Located> {
        // Unique point ids: COLMAP writes them sorted, so usually no allocation.
        let strictly_sorted = self.points3d.windows(2).all(|w| w[0].id < w[1].id);
        if !strictly_sorted {
            let mut ids: Vec<(u64, usize)> = self
                .points3d
                .iter()
                .enumerate()
                .map(|(i, p)| (p.id, i))
                .collect();
            ids.sort_unstable();
            if let Some(w) = ids.windows(2).find(|w| w[0].0 == w[1].0) {
                let (first, second) = (w[0].1.min(w[1].1), w[0].1.max(w[1].1));
                return Err(Located::record(
                    rec(Table::Points3D, second, w[0].0),
                    Problem::DuplicateId {
                        id: w[0].0,
                        first_index: first,
                    },
                ));
            }
        }
        for (pi, p) in self.points3d.iter().enumerate() {
            let at = || rec(Table::Points3D, pi, p.id);
            if !p.xyz.iter().all(|v| v.is_finite()) {
                return Err(Located::record(at(), Problem::NonFinite { what: "xyz" }));
            }
            if !p.error.is_finite() {
                return Err(Located::record(at(), Problem::NonFinite { what: "error" }));
            }
            if p.id == INVALID_POINT3D_ID {
                return Err(Located::record(at(), Problem::ReservedPointId));
            }
        }
        if self.tracks_match_observations(images, num_observations) {
            return Ok(());
        }
        self.locate_track_problem(images, num_observations)
    }

    /// Whether tracks and 2D points refer to each other one to one. Exact, and
    /// cache-friendly: the track elements are first bucketed by image (counting sort),
    /// so each image's 2D points are then visited while they sit in cache, instead of
    /// one random access into all images per observation.
    fn tracks_match_observations(&self, images: &IdLookup, num_observations: usize) -> bool {
        let n = self.images.len();
        let mut starts = vec![0usize; n + 1];
        let mut total = 0usize;
        let mut max_id = 0u64;
        for p in &self.points3d {
            for el in &p.track {
                let Some(ii) = images.get(el.image_id) else {
                    return false;
                };
                match self.images.get(ii) {
                    Some(im) if (el.point2d_idx as usize) < im.points2d.len() => {}
                    _ => return false,
                }
                starts[ii + 1] += 1;
                total += 1;
            }
            if !p.track.is_empty() {
                max_id = max_id.max(p.id);
            }
        }
        if total != num_observations {
            return false;
        }
        for i in 0..n {
            starts[i + 1] += starts[i];
        }
        // Ids below 2^32 (the usual case) pack with the 2D point index into 8 bytes:
        // half the memory traffic of the general 16-byte entries.
        if max_id <= u64::from(u32::MAX) {
            self.match_bucketed::<u64, 8>(
                images,
                &starts,
                total,
                |id, idx| (id << 32) | u64::from(idx),
                |e| (e >> 32, e as u32),
            )
        } else {
            self.match_bucketed::<(u64, u32), 4>(images, &starts, total, |id, idx| (id, idx), |e| e)
        }
    }

    /// Scatters packed (point3D id, point2D index) entries into per-image runs, then
    /// checks each run against its image. Writes go through a 64-byte buffer per image,
    /// flushed whole: thousands of scattered single writes would each miss the cache.
    fn match_bucketed<T: Copy + Default, const BUF: usize>(
        &self,
        images: &IdLookup,
        starts: &[usize],
        total: usize,
        pack: impl Fn(u64, u32) -> T,
        unpack: impl Fn(T) -> (u64, u32),
    ) -> bool {
        let n = self.images.len();
        let mut heads = starts[..n].to_vec();
        let mut entries = vec![T::default(); total];
        let mut bufs = vec![[T::default(); BUF]; n];
        let mut fill = vec![0usize; n];
        for p in &self.points3d {
            for el in &p.track {
                let Some(ii) = images.get(el.image_id) else {
                    return false;
                };
                let (Some(buf), Some(f), Some(head)) =
                    (bufs.get_mut(ii), fill.get_mut(ii), heads.get_mut(ii))
                else {
                    return false;
                };
                let Some(slot) = buf.get_mut(*f) else {
                    return false;
                };
                *slot = pack(p.id, el.point2d_idx);
                *f += 1;
                if *f == BUF {
                    let Some(dst) = entries.get_mut(*head..*head + BUF) else {
                        return false;
                    };
                    dst.copy_from_slice(buf);
                    *head += BUF;
                    *f = 0;
                }
            }
        }
        for ((buf, &f), &head) in bufs.iter().zip(&fill).zip(&heads) {
            let Some(dst) = entries.get_mut(head..head + f) else {
                return false;
            };
            dst.copy_from_slice(&buf[..f]);
        }
        drop(bufs);
        let mut seen = Vec::new();
        for (ii, im) in self.images.iter().enumerate() {
            seen.clear();
            seen.resize(im.points2d.len(), false);
            let Some(run) = entries.get(starts[ii]..starts[ii + 1]) else {
                return false;
            };
            for &e in run {
                let (id, idx) = unpack(e);
                let (Some(p2), Some(flag)) =
                    (im.points2d.get(idx as usize), seen.get_mut(idx as usize))
                else {
                    return false;
                };
                if p2.point3d_id != id || *flag {
                    return false;
                }
                *flag = true;
            }
        }
        // Each track element matched a distinct 2D point with its id, and there are as
        // many track elements as 2D points with an id: one to one.
        true
    }

    /// The first problem, in file order, of tracks that do not match the 2D points
    /// (slow: one random access per observation; only runs when there is a problem).
    fn locate_track_problem(
        &self,
        images: &IdLookup,
        num_observations: usize,
    ) -> Result<(), Located> {
        // One flag per 2D point of every image: each observation is claimed once.
        let mut offsets = Vec::with_capacity(self.images.len());
        let mut total = 0usize;
        for im in &self.images {
            offsets.push(total);
            total += im.points2d.len();
        }
        let mut claimed = vec![false; total];
        let mut num_track_elements = 0usize;
        for (pi, p) in self.points3d.iter().enumerate() {
            let at = || rec(Table::Points3D, pi, p.id);
            num_track_elements += p.track.len();
            for el in &p.track {
                let Some(ii) = images.get(el.image_id) else {
                    return Err(Located::record(at(), Problem::UnknownImage(el.image_id)));
                };
                let im = &self.images[ii];
                let Some(p2) = im.points2d.get(el.point2d_idx as usize) else {
                    return Err(Located::record(
                        at(),
                        Problem::Point2DOutOfRange {
                            image_id: el.image_id,
                            idx: el.point2d_idx,
                            num_points2d: im.points2d.len(),
                        },
                    ));
                };
                if p2.point3d_id != p.id {
                    let found = if p2.point3d_id == INVALID_POINT3D_ID {
                        "-1 (none)".to_string()
                    } else {
                        p2.point3d_id.to_string()
                    };
                    return Err(Located::record(
                        at(),
                        Problem::TrackMismatch {
                            image_id: el.image_id,
                            idx: el.point2d_idx,
                            found,
                        },
                    ));
                }
                let flag = &mut claimed[offsets[ii] + el.point2d_idx as usize];
                if *flag {
                    return Err(Located::record(
                        at(),
                        Problem::DuplicateObservation {
                            image_id: el.image_id,
                            idx: el.point2d_idx,
                        },
                    ));
                }
                *flag = true;
            }
        }
        // Every claimed observation is a 2D point with this id; if the counts agree, no
        // 2D point refers to a point3D that does not list it.
        if num_track_elements != num_observations {
            for (ii, im) in self.images.iter().enumerate() {
                for (k, p2) in im.points2d.iter().enumerate() {
                    if p2.has_point3d() && !claimed[offsets[ii] + k] {
                        return Err(Located {
                            table: Table::Images,
                            at: Location::Record(rec(Table::Images, ii, u64::from(im.image_id))),
                            problem: Box::new(Problem::DanglingObservation {
                                idx: k,
                                point3d_id: p2.point3d_id,
                            }),
                        });
                    }
                }
            }
        }
        Ok(())
    }
}
