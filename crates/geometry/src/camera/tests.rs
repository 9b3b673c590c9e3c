use super::*;

mod behaviour;
mod cameras;
mod domain;
mod roundtrip;
mod scaling;

#[test]
fn model_table_matches_colmap_counts() {
    let counts = [3, 4, 4, 5, 8, 8, 12, 5, 4, 5, 12, 16, 4, 5, 3, 4, 6, 2];
    for (m, n) in CameraModel::ALL.iter().zip(counts) {
        assert_eq!(m.num_params(), n, "{m}");
        assert_eq!(CameraModel::from_id(m.id() as i64).unwrap(), *m);
        assert_eq!(CameraModel::from_name(m.name()).unwrap(), *m);
    }
    assert!(CameraModel::from_id(18).is_err());
    assert!(CameraModel::from_id(-1).is_err());
}
