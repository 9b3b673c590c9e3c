//! Same frames + config => the same bytes: across runs, for 1 and 2 rayon threads,
//! and for a run split into work units whose manifests are merged.

use shards::{FrameRecord, Manifest, ShardJob, plan_shards, write_shard, write_shards};
use std::collections::BTreeMap;
use std::path::Path;
use testkit::files::folder_bytes;
use testkit::shard_frames::{frame, small_chunks};

fn input() -> Vec<FrameRecord> {
    (0..37).map(|i| frame(5 + 2 * i, 200, 30, 40, 30)).collect()
}

fn load(
    all: &[FrameRecord],
) -> impl Fn(u64) -> Result<FrameRecord, Box<dyn std::error::Error + Send + Sync>> + Sync + '_ {
    move |id| {
        all.iter()
            .find(|f| f.frame_id == id)
            .cloned()
            .ok_or_else(|| format!("no frame {id}").into())
    }
}

fn inputs() -> BTreeMap<String, String> {
    BTreeMap::from([
        ("frames".to_string(), "a1".to_string()),
        ("labels".to_string(), "b2".to_string()),
    ])
}

/// Writes the run as the given work units (shard ranges) and merges their manifests.
fn run(dir: &Path, threads: usize, units: &[(usize, usize)]) -> Manifest {
    let all = input();
    let ids: Vec<u64> = all.iter().map(|f| f.frame_id).collect();
    let config = small_chunks();
    let plans = plan_shards(&ids, config.frames_per_shard).unwrap();
    let job = ShardJob {
        out_dir: dir,
        plans: &plans,
        config: &config,
        config_hash: stage::hash_config(&config).unwrap(),
        inputs: inputs(),
        digests: None,
    };
    let manifests: Vec<Manifest> = testkit::on_threads(threads, || {
        units
            .iter()
            .map(|&(a, b)| write_shards(&job, a..b, &load(&all)).unwrap().manifest)
            .collect()
    });
    Manifest::merge(&manifests).unwrap()
}

#[test]
fn same_input_same_bytes() {
    let dir = tempfile::tempdir().unwrap();
    let frames = input();
    let a = write_shard(dir.path().join("a.mcap"), &frames, &small_chunks()).unwrap();
    let b = write_shard(dir.path().join("b.mcap"), &frames, &small_chunks()).unwrap();
    assert_eq!(a.sha256, b.sha256);
    assert_eq!(
        std::fs::read(dir.path().join("a.mcap")).unwrap(),
        std::fs::read(dir.path().join("b.mcap")).unwrap()
    );
    // A different config is a different file.
    let mut other = small_chunks();
    other.zstd_level = 9;
    let c = write_shard(dir.path().join("c.mcap"), &frames, &other).unwrap();
    assert_ne!(c.sha256, a.sha256);
}

#[test]
fn thread_count_and_work_units_do_not_change_anything() {
    let one = tempfile::tempdir().unwrap();
    let two = tempfile::tempdir().unwrap();
    let units = tempfile::tempdir().unwrap();
    let m1 = run(one.path(), 1, &[(0, 4)]);
    let m2 = run(two.path(), 2, &[(0, 4)]);
    // Two work units (as two machines would run them), merged.
    let mu = run(units.path(), 2, &[(2, 4), (0, 2)]);

    assert_eq!(m1.shards.len(), 4);
    assert!(m1.is_complete());
    assert_eq!(m1.planned_frames, 37);
    assert_eq!(m1, m2);
    assert_eq!(m1, mu);
    assert_eq!(m1.to_json(), mu.to_json());
    let f1 = folder_bytes(one.path());
    assert_eq!(f1.len(), 4, "{:?}", f1.keys());
    assert_eq!(f1, folder_bytes(two.path()));
    assert_eq!(f1, folder_bytes(units.path()));
    // The manifest's hashes are the files' hashes.
    for s in &m1.shards {
        assert_eq!(stage::sha256_bytes(&f1[&s.file]), s.sha256);
        assert_eq!(f1[&s.file].len() as u64, s.bytes);
    }
}
