//! The per-frame table, `per_frame.parquet` (polars, zstd pages), one row per frame in
//! scoring order:
//!
//! | column | type | meaning |
//! |---|---|---|
//! | `name`, `frame_id` | str, u64 | image name, frames table id |
//! | `points_total`, `lines_total` | u64 | correspondences proposed |
//! | `points_kept`, `lines_kept` | u64 | after the reliability filters |
//! | `<v>_ok` | bool | the variant gave a pose (`<v>`: `points`, `points_lines`) |
//! | `<v>_t_cm`, `<v>_r_deg` | f64, null without a pose | errors against the ground truth |
//! | `<v>_point_inliers`, `<v>_line_inliers`, `<v>_iterations` | u64 | RANSAC |
//! | `<v>_qw` ... `<v>_tz` | f64, null without a pose | estimated world-to-camera pose |
//! | `<v>_failure` | str, null with a pose | why there is no pose |
//! | `time_<step>_ms` | f64, null when the step did not run | `read`, the localiser's steps, `filter`, `pose_points`, `pose_points_lines` |
//!
//! Key-value metadata: `pl2map.score.source` and `pl2map.score.split`. Everything but
//! the `time_*` columns is the same for the same inputs and seed.

use crate::error::ScoreError;
use crate::evaluate::{FrameResult, Variant};
use std::path::Path;
use tables::parquet::polars::prelude::*;

pub const SOURCE_KEY: &str = "pl2map.score.source";
pub const SPLIT_KEY: &str = "pl2map.score.split";

/// Step names over all frames, in the order they first appear.
pub fn step_names(results: &[FrameResult]) -> Vec<String> {
    let mut names: Vec<String> = Vec::new();
    for r in results {
        for t in &r.timings {
            if !names.contains(&t.step) {
                names.push(t.step.clone());
            }
        }
    }
    names
}

/// The table as a polars frame.
pub fn dataframe(results: &[FrameResult]) -> Result<DataFrame, PolarsError> {
    let u = |f: &dyn Fn(&FrameResult) -> usize| -> Vec<u64> {
        results.iter().map(|r| f(r) as u64).collect()
    };
    let mut cols = vec![
        Column::new(
            "name".into(),
            results.iter().map(|r| r.name.as_str()).collect::<Vec<_>>(),
        ),
        Column::new(
            "frame_id".into(),
            results.iter().map(|r| r.frame_id).collect::<Vec<_>>(),
        ),
        Column::new("points_total".into(), u(&|r| r.points_total)),
        Column::new("lines_total".into(), u(&|r| r.lines_total)),
        Column::new("points_kept".into(), u(&|r| r.points_kept)),
        Column::new("lines_kept".into(), u(&|r| r.lines_kept)),
    ];
    for v in Variant::ALL {
        let k = v.key();
        let vr = |r: &FrameResult| r.variant(v).clone();
        let name = |s: &str| PlSmallStr::from(format!("{k}_{s}"));
        cols.push(Column::new(
            name("ok"),
            results
                .iter()
                .map(|r| r.variant(v).pose.is_some())
                .collect::<Vec<_>>(),
        ));
        cols.push(Column::new(
            name("t_cm"),
            results
                .iter()
                .map(|r| r.variant(v).error.map(|e| e.translation_cm()))
                .collect::<Vec<_>>(),
        ));
        cols.push(Column::new(
            name("r_deg"),
            results
                .iter()
                .map(|r| r.variant(v).error.map(|e| e.rotation_deg))
                .collect::<Vec<_>>(),
        ));
        cols.push(Column::new(
            name("point_inliers"),
            u(&|r| vr(r).point_inliers),
        ));
        cols.push(Column::new(
            name("line_inliers"),
            u(&|r| vr(r).line_inliers),
        ));
        cols.push(Column::new(name("iterations"), u(&|r| vr(r).iterations)));
        for (i, c) in ["qw", "qx", "qy", "qz", "tx", "ty", "tz"]
            .into_iter()
            .enumerate()
        {
            cols.push(Column::new(
                name(c),
                results
                    .iter()
                    .map(|r| {
                        r.variant(v).pose.map(|p| {
                            let (q, t) = (p.qvec(), p.tvec());
                            if i < 4 { q[i] } else { t[i - 4] }
                        })
                    })
                    .collect::<Vec<_>>(),
            ));
        }
        cols.push(Column::new(
            name("failure"),
            results
                .iter()
                .map(|r| r.variant(v).failure.clone())
                .collect::<Vec<_>>(),
        ));
    }
    for step in step_names(results) {
        cols.push(Column::new(
            format!("time_{step}_ms").into(),
            results
                .iter()
                .map(|r| r.timings.iter().find(|t| t.step == step).map(|t| t.ms))
                .collect::<Vec<_>>(),
        ));
    }
    DataFrame::new(results.len(), cols)
}

/// Writes the table to `path` through a temp file and a rename.
pub fn write_table(
    path: &Path,
    results: &[FrameResult],
    source: &str,
    split: &str,
) -> Result<(), ScoreError> {
    let pq = |source| ScoreError::Parquet {
        path: path.to_path_buf(),
        source,
    };
    let mut df = dataframe(results).map_err(pq)?;
    tables::parquet::write_parquet(
        path,
        &mut df,
        vec![
            (SOURCE_KEY.to_string(), source.to_string()),
            (SPLIT_KEY.to_string(), split.to_string()),
        ],
    )?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::evaluate::VariantResult;
    use crate::localiser::Timing;
    use geometry::Pose;
    use geometry::metrics::PoseError;

    fn results() -> Vec<FrameResult> {
        let ok = VariantResult {
            pose: Some(Pose::identity()),
            error: Some(PoseError {
                translation_m: 0.015,
                rotation_deg: 0.25,
            }),
            failure: None,
            point_inliers: 40,
            line_inliers: 7,
            iterations: 1000,
            ms: 3.0,
            point_inlier_mask: vec![],
            line_inlier_mask: vec![],
        };
        let failed = VariantResult {
            pose: None,
            error: None,
            failure: Some("not enough".into()),
            point_inliers: 0,
            line_inliers: 0,
            iterations: 0,
            ms: 0.1,
            point_inlier_mask: vec![],
            line_inlier_mask: vec![],
        };
        let t = |s: &str, ms| Timing { step: s.into(), ms };
        vec![
            FrameResult {
                frame_id: 4,
                name: "a.png".into(),
                points_total: 50,
                lines_total: 9,
                points_kept: 45,
                lines_kept: 8,
                variants: [ok.clone(), ok.clone()],
                timings: vec![t("read", 1.0), t("network", 2.0)],
            },
            FrameResult {
                frame_id: 9,
                name: "b.png".into(),
                points_total: 2,
                lines_total: 0,
                points_kept: 2,
                lines_kept: 0,
                variants: [failed.clone(), failed],
                timings: vec![t("read", 1.5), t("pose_points", 0.1)],
            },
        ]
    }

    #[test]
    fn writes_a_readable_table_atomically() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("per_frame.parquet");
        write_table(&path, &results(), "oracle", "train").unwrap();
        // Only the final file: the temp file was renamed.
        let names: Vec<_> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name().into_string().unwrap())
            .collect();
        assert_eq!(names, vec!["per_frame.parquet".to_string()]);

        let mut reader = ParquetReader::new(std::fs::File::open(&path).unwrap());
        let kv = reader
            .get_metadata()
            .unwrap()
            .key_value_metadata()
            .clone()
            .unwrap();
        assert!(
            kv.iter()
                .any(|e| e.key == SOURCE_KEY && e.value.as_deref() == Some("oracle"))
        );
        let df = reader.finish().unwrap();
        assert_eq!(df.height(), 2);
        let names: Vec<Option<&str>> = df.column("name").unwrap().str().unwrap().iter().collect();
        assert_eq!(names, vec![Some("a.png"), Some("b.png")]);
        let t: Vec<Option<f64>> = df
            .column("points_lines_t_cm")
            .unwrap()
            .f64()
            .unwrap()
            .iter()
            .collect();
        assert!((t[0].unwrap() - 1.5).abs() < 1e-12);
        assert_eq!(t[1], None);
        let inl: Vec<Option<u64>> = df
            .column("points_point_inliers")
            .unwrap()
            .u64()
            .unwrap()
            .iter()
            .collect();
        assert_eq!(inl, vec![Some(40), Some(0)]);
        let fail: Vec<Option<&str>> = df
            .column("points_failure")
            .unwrap()
            .str()
            .unwrap()
            .iter()
            .collect();
        assert_eq!(fail, vec![None, Some("not enough")]);
        // One column per step seen in any frame; null where a frame lacks it.
        let net: Vec<Option<f64>> = df
            .column("time_network_ms")
            .unwrap()
            .f64()
            .unwrap()
            .iter()
            .collect();
        assert_eq!(net, vec![Some(2.0), None]);
        assert!(df.column("time_pose_points_ms").is_ok());
        assert_eq!(
            step_names(&results()),
            vec!["read", "network", "pose_points"]
        );
    }

    #[test]
    fn empty_table_has_the_columns() {
        let df = dataframe(&[]).unwrap();
        assert_eq!(df.height(), 0);
        assert!(df.column("points_lines_r_deg").is_ok());
    }
}
