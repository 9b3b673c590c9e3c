//! The label tables the import and refine stages write and the shard stage reads.
//!
//! `points.parquet`, one row per keypoint of a training image (COLMAP images.bin
//! points2D, in order), sorted by (frame_id, kp_index):
//!
//! | column | type | meaning |
//! |---|---|---|
//! | `frame_id` | u32 | frames table id |
//! | `kp_index` | u32 | index in the image's points2D |
//! | `x`, `y` | f64 | COLMAP pixels (centre of the top-left pixel at (0.5, 0.5)) |
//! | `point3d_id` | i64 | COLMAP point3D id, -1 = none |
//! | `X`, `Y`, `Z` | f64, null when not valid | 3D label, world frame, metres |
//! | `valid` | bool | the keypoint has a 3D label |
//!
//! `lines.parquet`, one row per 2D segment of a training image (LIMAP
//! `segments_<id>.txt`, in order), sorted by (frame_id, seg_index):
//!
//! | column | type | meaning |
//! |---|---|---|
//! | `frame_id` | u32 | frames table id |
//! | `seg_index` | u32 | row of the segments file (the LIMAP line id) |
//! | `x1`, `y1`, `x2`, `y2` | f64 | segment, COLMAP pixels of the image |
//! | `track_id` | i64 | LIMAP track (`finaltracks/track_<id>.txt`), -1 = none |
//! | `X1` `Y1` `Z1` `X2` `Y2` `Z2` | f64, null when not valid | 3D endpoints; (X1,Y1,Z1) is the one that projects onto (x1,y1) |
//! | `valid` | bool | the segment has a 3D label |
//! | `swapped` | bool | the endpoints are in the reverse of the track file's order |
//!
//! `poses.parquet`, one row per training frame, sorted by frame_id: the camera and
//! world-to-camera pose the labels were made with (`frame_id` u32, `name` str,
//! `sfm_image_id` u32, `limap_image_id` u32, `camera_model` str, `width` u32,
//! `height` u32, `camera_params` list[f64], `qw qx qy qz tx ty tz` f64).
//!
//! Every file carries key-value metadata: [`VERSION_KEY`], [`SOURCE_KEY`] (`sfm` or
//! `depth-refined`), [`FRAMES_KEY`] (sha256 of the frames table they were made from;
//! the shard stage refuses a different one) and [`POSE_SOURCE_KEY`]; [`LINE_TRACKS_KEY`]
//! when the line labels come from another track set than LIMAP's finaltracks (written
//! only then, so tables of the default keep their bytes).

use crate::parquet::{Cols, TableError, f64_list_column, read_parquet, write_parquet};
use geometry::{Camera, CameraModel, Pose, UnitQuaternion, Vector3};
use nalgebra::Quaternion;
use polars::prelude::*;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

pub const POINTS_FILE: &str = "points.parquet";
pub const LINES_FILE: &str = "lines.parquet";
pub const POSES_FILE: &str = "poses.parquet";
/// The three tables, as a reader takes them.
pub const LABEL_FILES: [&str; 3] = [POINTS_FILE, LINES_FILE, POSES_FILE];
/// The stages that write label tables (crates/labels/src/import_stage.rs,
/// crates/labels/src/refine_stage.rs): a stage reads label tables only with the record
/// of one of them (`stage::recorded_outputs`).
pub const LABEL_STAGES: [&str; 2] = ["import", "refine"];

pub const VERSION_KEY: &str = "pl2map.labels.version";
pub const TABLE_VERSION: &str = "1";
pub const SOURCE_KEY: &str = "pl2map.labels.source";
pub const FRAMES_KEY: &str = "pl2map.labels.frames_sha256";
pub const POSE_SOURCE_KEY: &str = "pl2map.labels.pose_source";
pub const LINE_TRACKS_KEY: &str = "pl2map.labels.line_tracks";

/// Where the 3D labels come from.
#[derive(
    Clone,
    Copy,
    Debug,
    PartialEq,
    Eq,
    Hash,
    Serialize,
    Deserialize,
    strum::EnumString,
    strum::IntoStaticStr,
)]
#[serde(rename_all = "kebab-case")]
#[strum(serialize_all = "kebab-case")]
pub enum LabelSource {
    /// COLMAP points and LIMAP tracks as triangulated.
    Sfm,
    /// Moved onto depth maps by the refine stage.
    DepthRefined,
    /// The exact ground truth of a synthetic scene.
    SyntheticExact,
}

impl LabelSource {
    pub fn as_str(self) -> &'static str {
        self.into()
    }

    pub fn parse(s: &str) -> Option<Self> {
        s.parse().ok()
    }
}

/// Which pose (and camera) the labels were computed with.
#[derive(
    Clone,
    Copy,
    Debug,
    Default,
    PartialEq,
    Eq,
    Hash,
    Serialize,
    Deserialize,
    strum::Display,
    strum::EnumString,
    strum::IntoStaticStr,
    strum::VariantNames,
)]
#[serde(rename_all = "lowercase")]
#[strum(
    serialize_all = "lowercase",
    parse_err_ty = String,
    parse_err_fn = unknown_pose_source
)]
pub enum PoseSource {
    /// The SfM model's pose and camera (the reference implementation's choice).
    #[default]
    Sfm,
    /// The frames table's pose and camera.
    Dataset,
}

impl PoseSource {
    pub fn as_str(self) -> &'static str {
        self.into()
    }

    pub fn parse(s: &str) -> Option<Self> {
        s.parse().ok()
    }
}

/// The parse error, naming the accepted sources.
fn unknown_pose_source(s: &str) -> String {
    use strum::VariantNames;
    format!("expected {}, got {s:?}", PoseSource::VARIANTS.join(" or "))
}

#[derive(Clone, Debug, PartialEq)]
pub struct PointRow {
    pub frame_id: u32,
    pub kp_index: u32,
    pub xy: [f64; 2],
    /// -1 = none.
    pub point3d_id: i64,
    /// None = no 3D label (`valid` false).
    pub xyz: Option<[f64; 3]>,
}

#[derive(Clone, Debug, PartialEq)]
pub struct LineRow {
    pub frame_id: u32,
    pub seg_index: u32,
    pub segment: [f64; 4],
    /// -1 = none.
    pub track_id: i64,
    /// `[start, end]`, start projecting onto (x1, y1). None = no 3D label.
    pub endpoints: Option<[[f64; 3]; 2]>,
    pub swapped: bool,
}

#[derive(Clone, Debug, PartialEq)]
pub struct PoseRow {
    pub frame_id: u32,
    pub name: String,
    pub sfm_image_id: u32,
    pub limap_image_id: u32,
    pub camera: Camera,
    /// World-to-camera.
    pub pose: Pose,
}

/// The three tables of a label folder.
#[derive(Clone, Debug, PartialEq)]
pub struct LabelTables {
    pub source: LabelSource,
    pub pose_source: PoseSource,
    /// sha256 of the frames table the labels were made from.
    pub frames_sha256: String,
    /// The LIMAP track set of the line labels when not finaltracks (`alltracks`).
    pub line_tracks: Option<String>,
    pub points: Vec<PointRow>,
    pub lines: Vec<LineRow>,
    pub poses: Vec<PoseRow>,
}

fn opt(v: Option<[f64; 3]>, k: usize) -> Option<f64> {
    v.map(|p| p[k])
}

impl LabelTables {
    /// The key-value metadata, in the order it is written (sorted by key).
    fn metadata(&self) -> Vec<(String, String)> {
        let mut sorted = BTreeMap::from([
            (VERSION_KEY.to_string(), TABLE_VERSION.to_string()),
            (SOURCE_KEY.to_string(), self.source.as_str().to_string()),
            (FRAMES_KEY.to_string(), self.frames_sha256.clone()),
            (
                POSE_SOURCE_KEY.to_string(),
                self.pose_source.as_str().to_string(),
            ),
        ]);
        if let Some(t) = &self.line_tracks {
            sorted.insert(LINE_TRACKS_KEY.to_string(), t.clone());
        }
        sorted.into_iter().collect()
    }

    /// Refuses tables made from another frames table than `frames_path` (whose sha256
    /// is `frames_sha256`): their frame ids would name other images.
    pub fn require_frames(
        &self,
        frames_path: &Path,
        frames_sha256: &str,
    ) -> Result<(), TableError> {
        if self.frames_sha256 == frames_sha256 {
            return Ok(());
        }
        Err(TableError::OtherFrames {
            frames: frames_path.to_path_buf(),
            labels: self.frames_sha256.clone(),
            current: frames_sha256.to_string(),
        })
    }

    /// Sorts every table by its key (frame id, then index).
    pub fn sort(&mut self) {
        self.points.sort_by_key(|r| (r.frame_id, r.kp_index));
        self.lines.sort_by_key(|r| (r.frame_id, r.seg_index));
        self.poses.sort_by_key(|r| r.frame_id);
    }

    pub fn points_dataframe(&self) -> Result<DataFrame, PolarsError> {
        let p = &self.points;
        let mut cols = vec![
            Column::new(
                "frame_id".into(),
                p.iter().map(|r| r.frame_id).collect::<Vec<_>>(),
            ),
            Column::new(
                "kp_index".into(),
                p.iter().map(|r| r.kp_index).collect::<Vec<_>>(),
            ),
            Column::new("x".into(), p.iter().map(|r| r.xy[0]).collect::<Vec<_>>()),
            Column::new("y".into(), p.iter().map(|r| r.xy[1]).collect::<Vec<_>>()),
            Column::new(
                "point3d_id".into(),
                p.iter().map(|r| r.point3d_id).collect::<Vec<_>>(),
            ),
        ];
        for (k, name) in ["X", "Y", "Z"].into_iter().enumerate() {
            cols.push(Column::new(
                name.into(),
                p.iter().map(|r| opt(r.xyz, k)).collect::<Vec<_>>(),
            ));
        }
        cols.push(Column::new(
            "valid".into(),
            p.iter().map(|r| r.xyz.is_some()).collect::<Vec<_>>(),
        ));
        DataFrame::new(p.len(), cols)
    }

    pub fn lines_dataframe(&self) -> Result<DataFrame, PolarsError> {
        let l = &self.lines;
        let mut cols = vec![
            Column::new(
                "frame_id".into(),
                l.iter().map(|r| r.frame_id).collect::<Vec<_>>(),
            ),
            Column::new(
                "seg_index".into(),
                l.iter().map(|r| r.seg_index).collect::<Vec<_>>(),
            ),
        ];
        for (k, name) in ["x1", "y1", "x2", "y2"].into_iter().enumerate() {
            cols.push(Column::new(
                name.into(),
                l.iter().map(|r| r.segment[k]).collect::<Vec<_>>(),
            ));
        }
        cols.push(Column::new(
            "track_id".into(),
            l.iter().map(|r| r.track_id).collect::<Vec<_>>(),
        ));
        for (e, names) in [["X1", "Y1", "Z1"], ["X2", "Y2", "Z2"]]
            .into_iter()
            .enumerate()
        {
            for (k, name) in names.into_iter().enumerate() {
                cols.push(Column::new(
                    name.into(),
                    l.iter()
                        .map(|r| r.endpoints.map(|ep| ep[e][k]))
                        .collect::<Vec<_>>(),
                ));
            }
        }
        cols.push(Column::new(
            "valid".into(),
            l.iter().map(|r| r.endpoints.is_some()).collect::<Vec<_>>(),
        ));
        cols.push(Column::new(
            "swapped".into(),
            l.iter().map(|r| r.swapped).collect::<Vec<_>>(),
        ));
        DataFrame::new(l.len(), cols)
    }

    pub fn poses_dataframe(&self) -> Result<DataFrame, PolarsError> {
        let p = &self.poses;
        let mut cols = vec![
            Column::new(
                "frame_id".into(),
                p.iter().map(|r| r.frame_id).collect::<Vec<_>>(),
            ),
            Column::new(
                "name".into(),
                p.iter().map(|r| r.name.as_str()).collect::<Vec<_>>(),
            ),
            Column::new(
                "sfm_image_id".into(),
                p.iter().map(|r| r.sfm_image_id).collect::<Vec<_>>(),
            ),
            Column::new(
                "limap_image_id".into(),
                p.iter().map(|r| r.limap_image_id).collect::<Vec<_>>(),
            ),
            Column::new(
                "camera_model".into(),
                p.iter().map(|r| r.camera.model.name()).collect::<Vec<_>>(),
            ),
            // Camera sizes are image sizes: u32 like the frames table (checked on import).
            Column::new(
                "width".into(),
                p.iter().map(|r| r.camera.width as u32).collect::<Vec<_>>(),
            ),
            Column::new(
                "height".into(),
                p.iter().map(|r| r.camera.height as u32).collect::<Vec<_>>(),
            ),
            f64_list_column("camera_params", p.iter().map(|r| r.camera.params.clone())),
        ];
        for (k, name) in ["qw", "qx", "qy", "qz", "tx", "ty", "tz"]
            .into_iter()
            .enumerate()
        {
            let values: Vec<f64> = p
                .iter()
                .map(|r| {
                    if k < 4 {
                        r.pose.qvec()[k]
                    } else {
                        r.pose.tvec()[k - 4]
                    }
                })
                .collect();
            cols.push(Column::new(name.into(), values));
        }
        DataFrame::new(p.len(), cols)
    }

    /// Writes the three tables into `dir` (each atomically). Rows must be sorted
    /// ([`LabelTables::sort`]).
    pub fn write(&self, dir: &Path) -> Result<(), TableError> {
        let meta = self.metadata();
        let polars_err = |path: PathBuf| move |source| TableError::Polars { path, source };
        let path = dir.join(POINTS_FILE);
        let mut df = self.points_dataframe().map_err(polars_err(path.clone()))?;
        write_parquet(&path, &mut df, meta.clone())?;
        let path = dir.join(LINES_FILE);
        let mut df = self.lines_dataframe().map_err(polars_err(path.clone()))?;
        write_parquet(&path, &mut df, meta.clone())?;
        let path = dir.join(POSES_FILE);
        let mut df = self.poses_dataframe().map_err(polars_err(path.clone()))?;
        write_parquet(&path, &mut df, meta.clone())?;
        Ok(())
    }

    /// Reads a label folder written by [`LabelTables::write`], checking every value.
    pub fn read(dir: &Path) -> Result<LabelTables, TableError> {
        let (pdf, pmeta) = read_parquet(&dir.join(POINTS_FILE))?;
        let (ldf, lmeta) = read_parquet(&dir.join(LINES_FILE))?;
        let (odf, ometa) = read_parquet(&dir.join(POSES_FILE))?;
        let ppath = dir.join(POINTS_FILE);
        let (source, pose_source, frames_sha256) = parse_meta(&ppath, &pmeta)?;
        // Only our keys: the writer adds its own (the arrow schema) per file.
        let ours = |m: &BTreeMap<String, String>| -> BTreeMap<String, String> {
            m.iter()
                .filter(|(k, _)| k.starts_with("pl2map.labels."))
                .map(|(k, v)| (k.clone(), v.clone()))
                .collect()
        };
        for (file, meta) in [(LINES_FILE, &lmeta), (POSES_FILE, &ometa)] {
            if ours(meta) != ours(&pmeta) {
                return Err(TableError::Invalid {
                    path: dir.join(file),
                    message: format!(
                        "its metadata differs from {POINTS_FILE}'s: the tables are not from \
                         one run"
                    ),
                });
            }
        }
        let points = read_points(&Cols {
            df: &pdf,
            path: &ppath,
        })?;
        let lpath = dir.join(LINES_FILE);
        let lines = read_lines(&Cols {
            df: &ldf,
            path: &lpath,
        })?;
        let opath = dir.join(POSES_FILE);
        let poses = read_poses(&Cols {
            df: &odf,
            path: &opath,
        })?;
        Ok(LabelTables {
            source,
            pose_source,
            frames_sha256,
            line_tracks: pmeta.get(LINE_TRACKS_KEY).cloned(),
            points,
            lines,
            poses,
        })
    }
}

fn parse_meta(
    path: &Path,
    meta: &BTreeMap<String, String>,
) -> Result<(LabelSource, PoseSource, String), TableError> {
    let invalid = |message: String| TableError::Invalid {
        path: path.to_path_buf(),
        message,
    };
    let get = |key: &str| {
        meta.get(key).ok_or_else(|| {
            invalid(format!(
                "no {key} key in the parquet metadata: not a label table"
            ))
        })
    };
    let version = get(VERSION_KEY)?;
    if version != TABLE_VERSION {
        return Err(invalid(format!(
            "label table version {version}, this reader knows version {TABLE_VERSION}"
        )));
    }
    let source = get(SOURCE_KEY)?;
    let source = LabelSource::parse(source)
        .ok_or_else(|| invalid(format!("unknown label source {source:?}")))?;
    let pose_source = get(POSE_SOURCE_KEY)?;
    let pose_source = PoseSource::parse(pose_source)
        .ok_or_else(|| invalid(format!("unknown pose source {pose_source:?}")))?;
    Ok((source, pose_source, get(FRAMES_KEY)?.clone()))
}

fn check_sorted(c: &Cols, keys: &[(u32, u32)], column: &str) -> Result<(), TableError> {
    if let Some(i) = keys.windows(2).position(|w| w[1] <= w[0]) {
        return Err(c.row_error(
            i + 1,
            column,
            format!(
                "rows must be sorted by (frame_id, {column}) without repeats, got {:?} after {:?}",
                keys[i + 1],
                keys[i]
            ),
        ));
    }
    Ok(())
}

fn finite_xyz(
    c: &Cols,
    row: usize,
    column: &str,
    valid: bool,
    v: [Option<f64>; 3],
) -> Result<Option<[f64; 3]>, TableError> {
    match (valid, v) {
        (true, [Some(x), Some(y), Some(z)]) if x.is_finite() && y.is_finite() && z.is_finite() => {
            Ok(Some([x, y, z]))
        }
        (true, _) => Err(c.row_error(row, column, "valid label with a null or non-finite value")),
        (false, _) => Ok(None),
    }
}

fn read_points(c: &Cols) -> Result<Vec<PointRow>, TableError> {
    let frame = c.u32s("frame_id")?;
    let index = c.u32s("kp_index")?;
    let x = c.f64s("x")?;
    let y = c.f64s("y")?;
    let ids = c.i64s("point3d_id")?;
    let xs = c.opt_f64s("X")?;
    let ys = c.opt_f64s("Y")?;
    let zs = c.opt_f64s("Z")?;
    let valid = c.bools("valid")?;
    let keys: Vec<(u32, u32)> = frame.iter().copied().zip(index.iter().copied()).collect();
    check_sorted(c, &keys, "kp_index")?;
    let mut out = Vec::with_capacity(frame.len());
    for row in 0..frame.len() {
        if ids[row] < -1 {
            return Err(c.row_error(row, "point3d_id", format!("{} (ids are >= -1)", ids[row])));
        }
        if !(x[row].is_finite() && y[row].is_finite()) {
            return Err(c.row_error(row, "x", "keypoint is not finite"));
        }
        let xyz = finite_xyz(c, row, "X", valid[row], [xs[row], ys[row], zs[row]])?;
        out.push(PointRow {
            frame_id: frame[row],
            kp_index: index[row],
            xy: [x[row], y[row]],
            point3d_id: ids[row],
            xyz,
        });
    }
    Ok(out)
}

fn read_lines(c: &Cols) -> Result<Vec<LineRow>, TableError> {
    let frame = c.u32s("frame_id")?;
    let index = c.u32s("seg_index")?;
    let seg: Vec<Vec<f64>> = ["x1", "y1", "x2", "y2"]
        .into_iter()
        .map(|n| c.f64s(n))
        .collect::<Result<_, _>>()?;
    let ids = c.i64s("track_id")?;
    let ends: Vec<Vec<Option<f64>>> = ["X1", "Y1", "Z1", "X2", "Y2", "Z2"]
        .into_iter()
        .map(|n| c.opt_f64s(n))
        .collect::<Result<_, _>>()?;
    let valid = c.bools("valid")?;
    let swapped = c.bools("swapped")?;
    let keys: Vec<(u32, u32)> = frame.iter().copied().zip(index.iter().copied()).collect();
    check_sorted(c, &keys, "seg_index")?;
    let mut out = Vec::with_capacity(frame.len());
    for row in 0..frame.len() {
        if ids[row] < -1 {
            return Err(c.row_error(row, "track_id", format!("{} (ids are >= -1)", ids[row])));
        }
        let segment = [seg[0][row], seg[1][row], seg[2][row], seg[3][row]];
        if !segment.iter().all(|v| v.is_finite()) {
            return Err(c.row_error(row, "x1", "segment is not finite"));
        }
        let a = finite_xyz(
            c,
            row,
            "X1",
            valid[row],
            [ends[0][row], ends[1][row], ends[2][row]],
        )?;
        let b = finite_xyz(
            c,
            row,
            "X2",
            valid[row],
            [ends[3][row], ends[4][row], ends[5][row]],
        )?;
        out.push(LineRow {
            frame_id: frame[row],
            seg_index: index[row],
            segment,
            track_id: ids[row],
            endpoints: a.zip(b).map(|(a, b)| [a, b]),
            swapped: swapped[row],
        });
    }
    Ok(out)
}

fn read_poses(c: &Cols) -> Result<Vec<PoseRow>, TableError> {
    let frame = c.u32s("frame_id")?;
    let names = c.strs("name")?;
    let sfm = c.u32s("sfm_image_id")?;
    let limap = c.u32s("limap_image_id")?;
    let models = c.strs("camera_model")?;
    let widths = c.u32s("width")?;
    let heights = c.u32s("height")?;
    let params = c.f64_lists("camera_params")?;
    let pose_cols: Vec<Vec<f64>> = ["qw", "qx", "qy", "qz", "tx", "ty", "tz"]
        .into_iter()
        .map(|n| c.f64s(n))
        .collect::<Result<_, _>>()?;
    let keys: Vec<(u32, u32)> = frame.iter().map(|&f| (f, 0)).collect();
    check_sorted(c, &keys, "frame_id")?;
    let mut out = Vec::with_capacity(frame.len());
    for row in 0..frame.len() {
        let model = CameraModel::from_name(&models[row])
            .map_err(|e| c.row_error(row, "camera_model", e.to_string()))?;
        let camera = Camera::new(
            model,
            u64::from(widths[row]),
            u64::from(heights[row]),
            params[row].clone(),
        )
        .map_err(|e| c.row_error(row, "camera_params", e.to_string()))?;
        let p: Vec<f64> = pose_cols.iter().map(|col| col[row]).collect();
        let (q, t) = ([p[0], p[1], p[2], p[3]], [p[4], p[5], p[6]]);
        // Checked, not renormalised: the stored unit quaternion keeps its bits.
        Pose::from_qvec_tvec_tol(q, t, 1e-9).map_err(|e| c.row_error(row, "qw", e.to_string()))?;
        let pose = Pose::new(
            UnitQuaternion::new_unchecked(Quaternion::new(q[0], q[1], q[2], q[3])),
            Vector3::from(t),
        );
        out.push(PoseRow {
            frame_id: frame[row],
            name: names[row].clone(),
            sfm_image_id: sfm[row],
            limap_image_id: limap[row],
            camera,
            pose,
        });
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tables() -> LabelTables {
        LabelTables {
            source: LabelSource::Sfm,
            pose_source: PoseSource::Sfm,
            frames_sha256: "ab".repeat(32),
            line_tracks: None,
            points: vec![
                PointRow {
                    frame_id: 0,
                    kp_index: 0,
                    xy: [1.5, 2.5],
                    point3d_id: 7,
                    xyz: Some([0.1, 1.0 / 3.0, -2.0]),
                },
                PointRow {
                    frame_id: 0,
                    kp_index: 1,
                    xy: [3.0, 4.0],
                    point3d_id: -1,
                    xyz: None,
                },
            ],
            lines: vec![LineRow {
                frame_id: 2,
                seg_index: 0,
                segment: [0.5, 0.5, 10.0, 20.0],
                track_id: 3,
                endpoints: Some([[0.0, 0.0, 1.0], [1.0, 2.0, 3.0]]),
                swapped: true,
            }],
            poses: vec![PoseRow {
                frame_id: 0,
                name: "seq-01/frame-000000.color.png".into(),
                sfm_image_id: 5,
                limap_image_id: 5,
                camera: Camera::new(
                    CameraModel::SimpleRadial,
                    640,
                    480,
                    vec![525.0, 320.0, 240.0, 0.01],
                )
                .unwrap(),
                pose: Pose::new(
                    UnitQuaternion::from_euler_angles(0.1, 0.2, 0.3),
                    Vector3::new(1.0, -2.0, std::f64::consts::PI),
                ),
            }],
        }
    }

    #[test]
    fn round_trip_is_bit_exact_and_deterministic() {
        let dir = tempfile::tempdir().unwrap();
        let t = tables();
        let a = dir.path().join("a");
        let b = dir.path().join("b");
        t.write(&a).unwrap();
        t.write(&b).unwrap();
        for f in [POINTS_FILE, LINES_FILE, POSES_FILE] {
            assert_eq!(
                std::fs::read(a.join(f)).unwrap(),
                std::fs::read(b.join(f)).unwrap(),
                "{f}"
            );
        }
        assert_eq!(LabelTables::read(&a).unwrap(), t);
        // Empty tables are written with their types and read back.
        let mut e = t.clone();
        e.points.clear();
        e.lines.clear();
        e.poses.clear();
        e.write(&b).unwrap();
        assert_eq!(LabelTables::read(&b).unwrap(), e);
    }

    #[test]
    fn refuses_unsorted_rows_and_mixed_runs() {
        let dir = tempfile::tempdir().unwrap();
        let mut t = tables();
        t.points.swap(0, 1);
        t.write(dir.path()).unwrap();
        let e = LabelTables::read(dir.path()).unwrap_err().to_string();
        assert!(
            e.contains("row 1 (kp_index)") && e.contains("sorted"),
            "{e}"
        );

        let t = tables();
        t.write(dir.path()).unwrap();
        let mut other = tables();
        other.source = LabelSource::DepthRefined;
        let mut df = other.lines_dataframe().unwrap();
        write_parquet(&dir.path().join(LINES_FILE), &mut df, other.metadata()).unwrap();
        let e = LabelTables::read(dir.path()).unwrap_err().to_string();
        assert!(e.contains("not from one run"), "{e}");
    }

    #[test]
    fn label_source_serde_and_strum_names_agree() {
        for source in [
            LabelSource::Sfm,
            LabelSource::DepthRefined,
            LabelSource::SyntheticExact,
        ] {
            let json = serde_json::to_string(&source).unwrap();
            assert_eq!(json, format!("\"{}\"", source.as_str()));
            assert_eq!(LabelSource::parse(source.as_str()), Some(source));
        }
        assert_eq!(LabelSource::parse("depth_refined"), None);
    }

    #[test]
    fn pose_source_serde_and_strum_names_agree() {
        for source in [PoseSource::Sfm, PoseSource::Dataset] {
            let json = serde_json::to_string(&source).unwrap();
            assert_eq!(json, format!("\"{source}\""));
            assert_eq!(source.as_str(), source.to_string());
            assert_eq!(source.to_string().parse::<PoseSource>(), Ok(source));
            assert_eq!(PoseSource::parse(source.as_str()), Some(source));
        }
        assert_eq!(
            "SfM".parse::<PoseSource>(),
            Err("expected sfm or dataset, got \"SfM\"".to_string())
        );
    }
}
