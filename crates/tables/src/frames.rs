//! The frames table: one row per image of a dataset, as the ingest stage writes it and
//! every later stage reads it (ARCHITECTURE.md, "Data flow").
//!
//! Stored as parquet through polars. Columns, in order:
//!
//! | column | type | meaning |
//! |---|---|---|
//! | `id` | u32 | frame id: rows sorted by split (train, then test), then by name (byte order) |
//! | `name` | str | dataset-relative path with `/` separators, the join key with SfM models |
//! | `path` | str | absolute path of the image file |
//! | `split` | str | `train` or `test` |
//! | `camera_model` | str | COLMAP model name, e.g. `SIMPLE_PINHOLE` |
//! | `width`, `height` | u32 | image size in pixels |
//! | `camera_params` | list[f64] | COLMAP parameters of that model, in COLMAP order |
//! | `qw` `qx` `qy` `qz` `tx` `ty` `tz` | f64 | world-to-camera pose, Hamilton quaternion w-first |
//! | `depth_path` | str, nullable | absolute path of the depth map aligned with the image |
//! | `content_hash` | str | sha256 (hex) of the image file |
//! | `depth_hash` | str, nullable | sha256 (hex) of the depth map file, null exactly when `depth_path` is |
//!
//! Readers check a file against its hash where they read it: the shard stage each image
//! (crates/shards/src/shard_stage/source.rs), the refine stage each depth map
//! (crates/labels/src/refine/inputs.rs). A table written before `depth_hash` existed
//! reads with no depth hashes; the refine stage refuses its depth maps and the ingest
//! stage writes the table again (crates/datasets/src/ingest_stage.rs).
//!
//! The [`IngestMeta`] (dataset, scene, pose and depth source, excluded frames) is stored
//! as JSON in the parquet file's key-value metadata under [`META_KEY`], not in a sidecar:
//! it is then written in the same atomic rename as the rows it describes and can never
//! drift from them, and any parquet reader shows it (pyarrow: `read_metadata(f).metadata`).

use crate::parquet::{Cols, TableError, read_parquet, write_parquet};
use geometry::{Camera, CameraModel, Pose, UnitQuaternion, Vector3};
use nalgebra::Quaternion;
use polars::prelude::*;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// Key of the JSON-encoded [`IngestMeta`] in the parquet key-value metadata.
pub const META_KEY: &str = "pl2map.frames.meta";
/// Key of the table layout version; a reader refuses other versions.
pub const VERSION_KEY: &str = "pl2map.frames.version";
pub const TABLE_VERSION: &str = "1";
/// The stage that writes the frames table (crates/datasets/src/ingest_stage.rs): a stage
/// reads a frames table only with that stage's record (`stage::recorded_outputs`).
pub const FRAMES_STAGE: &str = "ingest";

#[derive(
    Clone,
    Copy,
    Debug,
    PartialEq,
    Eq,
    Hash,
    PartialOrd,
    Ord,
    Serialize,
    Deserialize,
    strum::EnumString,
    strum::IntoStaticStr,
)]
#[serde(rename_all = "lowercase")]
#[strum(serialize_all = "lowercase")]
pub enum Split {
    Train,
    Test,
}

impl Split {
    pub fn as_str(self) -> &'static str {
        self.into()
    }

    pub fn parse(s: &str) -> Option<Split> {
        s.parse().ok()
    }
}

impl std::fmt::Display for Split {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

/// One image of a dataset.
#[derive(Clone, Debug, PartialEq)]
pub struct Frame {
    pub id: u32,
    /// Dataset-relative path with `/` separators (`seq-01/frame-000000.color.png`,
    /// `seq1/frame00001.png`): the name SfM models use for this image.
    pub name: String,
    /// Absolute path of the image file.
    pub path: PathBuf,
    pub split: Split,
    pub camera: Camera,
    /// World-to-camera.
    pub pose: Pose,
    /// Absolute path of a depth map in this image's camera (16-bit, millimetres).
    pub depth_path: Option<PathBuf>,
    /// sha256 (hex) of the depth map file; None without a depth map, or in a table
    /// written before depth maps were hashed.
    pub depth_hash: Option<String>,
    pub width: u32,
    pub height: u32,
    /// sha256 (hex) of the image file.
    pub content_hash: String,
}

/// A frame listed by the dataset but left out of the table, and why.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct ExcludedFrame {
    pub name: String,
    pub split: Split,
    pub reason: String,
}

/// What the table was made from; stored with it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct IngestMeta {
    /// `7scenes`, `cambridge`, ...
    pub dataset: String,
    pub scene: String,
    /// Absolute path of the scene folder that was read.
    pub root: String,
    /// Where the poses come from and what they are, e.g. `published: pose.txt ...`.
    pub pose_source: String,
    /// `none`, `raw: ...` or `rendered: DIR ...`.
    pub depth_source: String,
    /// Depth values per metre in every depth map of the table (1000: millimetres); None
    /// without depth. 0 and 65535 are invalid in every depth map the table points to.
    pub depth_units_per_metre: Option<f64>,
    /// How the cameras were obtained, e.g. `SIMPLE_PINHOLE 640 480 525 320 240 (default)`.
    pub intrinsics: String,
    pub excluded: Vec<ExcludedFrame>,
}

/// Rows and their description.
#[derive(Clone, Debug, PartialEq)]
pub struct FramesTable {
    pub frames: Vec<Frame>,
    pub meta: IngestMeta,
}

/// The table stores normalised quaternions: anything further from unit norm was not
/// written by [`FramesTable::write_parquet`].
const UNIT_QUATERNION_TOLERANCE: f64 = 1e-9;

const POSE_COLUMNS: [&str; 7] = ["qw", "qx", "qy", "qz", "tx", "ty", "tz"];

fn path_str<'a>(p: &'a Path, file: &Path, row: usize) -> Result<&'a str, TableError> {
    p.to_str().ok_or_else(|| TableError::Row {
        path: file.to_path_buf(),
        row,
        column: "path".into(),
        message: format!("path {} is not valid UTF-8", p.display()),
    })
}

impl FramesTable {
    /// Number of frames of a split.
    pub fn count(&self, split: Split) -> usize {
        self.frames.iter().filter(|f| f.split == split).count()
    }

    /// The table as a polars DataFrame (columns as in the module docs).
    pub fn to_dataframe(&self, file_for_errors: &Path) -> Result<DataFrame, TableError> {
        let n = self.frames.len();
        let f = &self.frames;
        let polars_err = |source| TableError::Polars {
            path: file_for_errors.to_path_buf(),
            source,
        };
        let mut paths = Vec::with_capacity(n);
        let mut depths = Vec::with_capacity(n);
        for (row, fr) in f.iter().enumerate() {
            paths.push(path_str(&fr.path, file_for_errors, row)?.to_string());
            depths.push(match &fr.depth_path {
                Some(p) => Some(path_str(p, file_for_errors, row)?.to_string()),
                None => None,
            });
        }
        let params: ListChunked = f
            .iter()
            .map(|fr| Some(Series::new(PlSmallStr::EMPTY, fr.camera.params.as_slice())))
            .collect();
        let mut columns = vec![
            Column::new("id".into(), f.iter().map(|x| x.id).collect::<Vec<u32>>()),
            Column::new(
                "name".into(),
                f.iter().map(|x| x.name.as_str()).collect::<Vec<&str>>(),
            ),
            Column::new("path".into(), paths),
            Column::new(
                "split".into(),
                f.iter().map(|x| x.split.as_str()).collect::<Vec<&str>>(),
            ),
            Column::new(
                "camera_model".into(),
                f.iter()
                    .map(|x| x.camera.model.name())
                    .collect::<Vec<&str>>(),
            ),
            Column::new(
                "width".into(),
                f.iter().map(|x| x.width).collect::<Vec<u32>>(),
            ),
            Column::new(
                "height".into(),
                f.iter().map(|x| x.height).collect::<Vec<u32>>(),
            ),
            params
                .into_series()
                .with_name("camera_params".into())
                .into_column(),
        ];
        for (k, name) in POSE_COLUMNS.iter().enumerate() {
            let values: Vec<f64> = f
                .iter()
                .map(|x| {
                    if k < 4 {
                        x.pose.qvec()[k]
                    } else {
                        x.pose.tvec()[k - 4]
                    }
                })
                .collect();
            columns.push(Column::new((*name).into(), values));
        }
        columns.push(Column::new("depth_path".into(), depths));
        columns.push(Column::new(
            "content_hash".into(),
            f.iter()
                .map(|x| x.content_hash.as_str())
                .collect::<Vec<&str>>(),
        ));
        columns.push(Column::new(
            "depth_hash".into(),
            f.iter()
                .map(|x| x.depth_hash.as_deref())
                .collect::<Vec<Option<&str>>>(),
        ));
        DataFrame::new(n, columns).map_err(polars_err)
    }

    /// Writes the table to `path` atomically (temp file in the same folder, fsync,
    /// rename). Same table => same bytes.
    pub fn write_parquet(&self, path: &Path) -> Result<(), TableError> {
        let mut df = self.to_dataframe(path)?;
        let meta = serde_json::to_string(&self.meta).map_err(|e| TableError::Invalid {
            path: path.to_path_buf(),
            message: format!("cannot encode the table metadata: {e}"),
        })?;
        write_parquet(
            path,
            &mut df,
            vec![
                (VERSION_KEY.to_string(), TABLE_VERSION.to_string()),
                (META_KEY.to_string(), meta),
            ],
        )
    }

    /// Reads a table written by [`FramesTable::write_parquet`], checking every value.
    pub fn read_parquet(path: &Path) -> Result<FramesTable, TableError> {
        let invalid = |message: String| TableError::Invalid {
            path: path.to_path_buf(),
            message,
        };
        let (df, kv) = read_parquet(path)?;
        match kv.get(VERSION_KEY) {
            Some(v) if v == TABLE_VERSION => {}
            Some(v) => {
                return Err(invalid(format!(
                    "frames table version {v}, this reader knows version {TABLE_VERSION}"
                )));
            }
            None => {
                return Err(invalid(format!(
                    "no {VERSION_KEY} key in the parquet metadata: not a frames table"
                )));
            }
        }
        let meta_json = kv
            .get(META_KEY)
            .ok_or_else(|| invalid(format!("no {META_KEY} key in the parquet metadata")))?;
        let meta: IngestMeta = serde_json::from_str(meta_json)
            .map_err(|e| invalid(format!("{META_KEY} is not valid: {e}")))?;
        let frames = frames_from_dataframe(&df, path)?;
        Ok(FramesTable { frames, meta })
    }
}

fn frames_from_dataframe(df: &DataFrame, path: &Path) -> Result<Vec<Frame>, TableError> {
    let c = Cols { df, path };
    let ids = c.u32s("id")?;
    let names = c.strs("name")?;
    let paths = c.strs("path")?;
    let splits = c.strs("split")?;
    let models = c.strs("camera_model")?;
    let widths = c.u32s("width")?;
    let heights = c.u32s("height")?;
    let params = c.f64_lists("camera_params")?;
    let mut pose_cols = Vec::with_capacity(7);
    for name in POSE_COLUMNS {
        pose_cols.push(c.f64s(name)?);
    }
    let depths = c.opt_strs("depth_path")?;
    let hashes = c.strs("content_hash")?;
    // Absent in tables written before depth maps were hashed: no hashes, not an error.
    let depth_hashes = match df.column("depth_hash") {
        Ok(_) => Some(c.opt_strs("depth_hash")?),
        Err(_) => None,
    };

    let row_err = |row: usize, column: &str, message: String| c.row_error(row, column, message);
    let mut frames = Vec::with_capacity(ids.len());
    for row in 0..ids.len() {
        if row > 0 && ids[row] <= ids[row - 1] {
            return Err(row_err(
                row,
                "id",
                format!(
                    "ids must be strictly increasing, got {} after {}",
                    ids[row],
                    ids[row - 1]
                ),
            ));
        }
        let split = Split::parse(&splits[row]).ok_or_else(|| {
            row_err(
                row,
                "split",
                format!("expected train or test, got {:?}", splits[row]),
            )
        })?;
        let model = CameraModel::from_name(&models[row])
            .map_err(|e| row_err(row, "camera_model", e.to_string()))?;
        // `Camera::new` refuses a camera that cannot exist (focal length <= 0, size 0, a
        // principal point far outside the image): a table of such frames came from a bad
        // ingest configuration or another tool, and every stage after would use it.
        let camera = Camera::new(
            model,
            widths[row] as u64,
            heights[row] as u64,
            params[row].clone(),
        )
        .map_err(|e| {
            let column = match e {
                geometry::GeometryError::InvalidSize { .. } => "width",
                _ => "camera_params",
            };
            row_err(row, column, e.to_string())
        })?;
        let p: Vec<f64> = pose_cols.iter().map(|col| col[row]).collect();
        let (q, t) = ([p[0], p[1], p[2], p[3]], [p[4], p[5], p[6]]);
        // Validated, but not renormalised: the stored unit quaternion comes back with
        // the same bits.
        Pose::from_qvec_tvec_tol(q, t, UNIT_QUATERNION_TOLERANCE)
            .map_err(|e| row_err(row, "qw", e.to_string()))?;
        let pose = Pose::new(
            UnitQuaternion::new_unchecked(Quaternion::new(q[0], q[1], q[2], q[3])),
            Vector3::from(t),
        );
        let depth_hash = depth_hashes.as_ref().and_then(|h| h[row].clone());
        if depth_hashes.is_some() && depth_hash.is_some() != depths[row].is_some() {
            return Err(row_err(
                row,
                "depth_hash",
                format!(
                    "a depth hash {} a depth path: expected both or neither",
                    if depth_hash.is_some() {
                        "without"
                    } else {
                        "missing for"
                    }
                ),
            ));
        }
        frames.push(Frame {
            id: ids[row],
            name: names[row].clone(),
            path: PathBuf::from(&paths[row]),
            split,
            camera,
            pose,
            depth_path: depths[row].as_ref().map(PathBuf::from),
            depth_hash,
            width: widths[row],
            height: heights[row],
            content_hash: hashes[row].clone(),
        });
    }
    Ok(frames)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn table() -> FramesTable {
        let frames = (0..5u32)
            .map(|i| {
                let x = i as f64;
                Frame {
                    id: i,
                    name: format!("seq-01/frame-{i:06}.color.png"),
                    path: PathBuf::from(format!("/data/stairs/seq-01/frame-{i:06}.color.png")),
                    split: if i < 3 { Split::Train } else { Split::Test },
                    camera: Camera::new(
                        CameraModel::SimpleRadial,
                        640,
                        480,
                        vec![525.0 + x / 3.0, 320.1, 239.9, -1e-3 * x],
                    )
                    .unwrap(),
                    pose: Pose::new(
                        UnitQuaternion::from_euler_angles(0.1 * x, -0.7, 1.0 / 3.0),
                        Vector3::new(std::f64::consts::PI * x, -1e-300, 1.0 / 7.0),
                    ),
                    depth_path: (i % 2 == 0).then(|| PathBuf::from(format!("/d/{i}.png"))),
                    depth_hash: (i % 2 == 0).then(|| format!("{:064x}", 100 + i)),
                    width: 640,
                    height: 480,
                    content_hash: format!("{i:064x}"),
                }
            })
            .collect();
        FramesTable {
            frames,
            meta: IngestMeta {
                dataset: "7scenes".into(),
                scene: "stairs".into(),
                root: "/data/stairs".into(),
                pose_source: "published".into(),
                depth_source: "none".into(),
                depth_units_per_metre: Some(1000.0),
                intrinsics: "SIMPLE_PINHOLE 640 480 525 320 240".into(),
                excluded: vec![ExcludedFrame {
                    name: "seq-02/frame-000000.color.png".into(),
                    split: Split::Test,
                    reason: "why not".into(),
                }],
            },
        }
    }

    #[test]
    fn parquet_round_trip_is_bit_exact_and_deterministic() {
        let dir = tempfile::tempdir().unwrap();
        let t = table();
        let a = dir.path().join("a.parquet");
        let b = dir.path().join("b.parquet");
        t.write_parquet(&a).unwrap();
        t.write_parquet(&b).unwrap();
        assert_eq!(std::fs::read(&a).unwrap(), std::fs::read(&b).unwrap());
        let back = FramesTable::read_parquet(&a).unwrap();
        assert_eq!(back.meta, t.meta);
        assert_eq!(back.frames.len(), t.frames.len());
        for (x, y) in back.frames.iter().zip(&t.frames) {
            let bits = |v: &[f64]| v.iter().map(|f| f.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&x.camera.params), bits(&y.camera.params));
            assert_eq!(bits(&x.pose.qvec()), bits(&y.pose.qvec()));
            assert_eq!(bits(&x.pose.tvec()), bits(&y.pose.tvec()));
            assert_eq!(x, y);
        }
        // Nothing but the table is left in the folder (no temp file).
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 2);
    }

    #[test]
    fn refuses_a_parquet_file_that_is_not_a_frames_table() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("other.parquet");
        let mut df = DataFrame::new(1, vec![Column::new("id".into(), vec![1u32])]).unwrap();
        ParquetWriter::new(std::fs::File::create(&p).unwrap())
            .finish(&mut df)
            .unwrap();
        let e = FramesTable::read_parquet(&p).unwrap_err();
        assert!(e.to_string().contains(VERSION_KEY), "{e}");
        std::fs::write(&p, b"not parquet at all").unwrap();
        assert!(matches!(
            FramesTable::read_parquet(&p),
            Err(TableError::Polars { .. })
        ));
    }

    /// A table written before the `depth_hash` column existed still reads (no depth
    /// hashes); a hash without its depth map, or a depth map without its hash in a
    /// table that has the column, is refused naming the row.
    #[test]
    fn tables_without_depth_hashes_read_and_half_pairs_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        let t = table();
        let p = dir.path().join("old.parquet");
        let mut df = t.to_dataframe(&p).unwrap();
        df.drop_in_place("depth_hash").unwrap();
        let meta = serde_json::to_string(&t.meta).unwrap();
        write_parquet(
            &p,
            &mut df,
            vec![
                (VERSION_KEY.to_string(), TABLE_VERSION.to_string()),
                (META_KEY.to_string(), meta),
            ],
        )
        .unwrap();
        let back = FramesTable::read_parquet(&p).unwrap();
        assert!(back.frames.iter().all(|f| f.depth_hash.is_none()));
        assert_eq!(back.frames[0].depth_path, t.frames[0].depth_path);

        let mut bad = t.clone();
        bad.frames[2].depth_hash = None;
        let q = dir.path().join("bad.parquet");
        bad.write_parquet(&q).unwrap();
        let e = FramesTable::read_parquet(&q).unwrap_err().to_string();
        assert!(
            e.contains("row 2 (depth_hash)") && e.contains("missing for a depth path"),
            "{e}"
        );
    }

    /// A row whose camera cannot exist is refused naming the file, the row and what is
    /// wrong (docs/errors.md); the cameras are set field by field, as another tool could
    /// write them.
    #[test]
    fn refuses_rows_whose_camera_cannot_exist() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("frames.parquet");
        type Edit = fn(&mut Frame);
        let cases: [(Edit, &str); 4] = [
            (
                |f| f.camera.params[0] = -525.0,
                "row 3 (camera_params): focal length f = -525 must be positive and finite",
            ),
            (
                |f| f.camera.params[0] = 0.0,
                "row 3 (camera_params): focal length f = 0 must be positive",
            ),
            (
                |f| f.camera.params[1] = 1e12,
                "row 3 (camera_params): principal point cx = 1000000000000",
            ),
            (
                |f| {
                    f.width = 0;
                    f.camera.width = 0;
                },
                "row 3 (width): camera size 0x480 is invalid",
            ),
        ];
        for (edit, expect) in cases {
            let mut t = table();
            edit(&mut t.frames[3]);
            t.write_parquet(&p).unwrap();
            let e = FramesTable::read_parquet(&p).unwrap_err().to_string();
            assert!(
                e.starts_with(&p.display().to_string()) && e.contains(expect),
                "{e}"
            );
        }
    }

    #[test]
    fn split_serde_and_strum_names_agree() {
        for split in [Split::Train, Split::Test] {
            let json = serde_json::to_string(&split).unwrap();
            assert_eq!(json, format!("\"{}\"", split.as_str()));
            assert_eq!(Split::parse(split.as_str()), Some(split));
        }
        assert_eq!(Split::parse("Train"), None);
    }
}
