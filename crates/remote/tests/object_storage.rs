//! The remote crate against real servers started here on 127.0.0.1: s3s-fs (an S3
//! server; scripts/setup-s3.sh installs it) and Python's http.server. A test whose server
//! cannot be started skips, printing why.
//!
//! The sets are written here in the shard stage's layout (manifest.json, stage.json as
//! crates/stage/src/record.rs writes it, the files the manifest lists), with seeded bytes
//! as the shards' contents: this crate moves and checks files and never parses a shard.
//! tests/remote_shards.rs trains from real shards served the same way.

mod support;

use remote::{CacheOptions, FetchOptions, RemoteError, SetReport};
use shards::{MANIFEST_FILE, Manifest, ManifestShard};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};
use support::Server;

/// Writes a set of `sizes.len()` shards into `dir` (seeded by `seed`) and returns its
/// manifest.
fn make_set(dir: &Path, seed: u64, sizes: &[usize]) -> Manifest {
    std::fs::create_dir_all(dir).unwrap();
    let mut shards = Vec::new();
    let mut first = 0u64;
    for (i, &n) in sizes.iter().enumerate() {
        // A split's shards as the shard stage names them: training ones, then a test one.
        let file = if i + 1 == sizes.len() && sizes.len() > 1 {
            "test-00000.mcap".to_string()
        } else {
            format!("train-{i:05}.mcap")
        };
        let mut x = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ (i as u64 + 1);
        let bytes: Vec<u8> = (0..n)
            .map(|_| {
                x ^= x << 13;
                x ^= x >> 7;
                x ^= x << 17;
                x as u8
            })
            .collect();
        std::fs::write(dir.join(&file), &bytes).unwrap();
        shards.push(ManifestShard {
            index: i,
            file,
            first_frame: first,
            last_frame: first + 9,
            frame_count: 10,
            sha256: stage::sha256_bytes(&bytes),
            bytes: n as u64,
        });
        first += 10;
    }
    let manifest = Manifest {
        format_version: 1,
        tool_version: "0.1.0".into(),
        config_hash: format!("config-{seed}"),
        inputs: BTreeMap::from([("frames".to_string(), format!("frames-{seed}"))]),
        line_tracks: None,
        planned_shards: sizes.len(),
        planned_frames: 10 * sizes.len() as u64,
        shards,
    };
    write_records(dir, &manifest);
    manifest
}

/// manifest.json and the shard stage's stage.json listing it and every shard.
fn write_records(dir: &Path, manifest: &Manifest) {
    manifest.save(dir.join(MANIFEST_FILE)).unwrap();
    let mut rec = stage::StageRecord::new("shard", "c".into(), BTreeMap::new());
    rec.add_output(dir, MANIFEST_FILE).unwrap();
    for s in &manifest.shards {
        rec.add_output(dir, &s.file).unwrap();
    }
    rec.save(dir).unwrap();
}

fn cache(dir: &Path, max_bytes: u64) -> CacheOptions {
    CacheOptions {
        folder: dir.join("cache"),
        max_bytes,
    }
}

/// Quick retries: a test that fails does so in seconds.
fn quick() -> FetchOptions {
    FetchOptions {
        retries: 2,
        retry_timeout: Duration::from_secs(3),
        request_timeout: Duration::from_secs(30),
        progress: false,
        ..FetchOptions::default()
    }
}

fn s3_options(server: &Server) -> FetchOptions {
    FetchOptions {
        s3_config: support::s3_config(server),
        ..quick()
    }
}

/// The materialised folder is what the train and score stages accept, with the same
/// bytes as the published set.
fn assert_same_set(local: &Path, report: &SetReport) {
    let manifest = shards::checked_manifest(&report.dir)
        .unwrap_or_else(|e| panic!("the materialised folder is refused: {e}"));
    assert_eq!(manifest, Manifest::load(local.join(MANIFEST_FILE)).unwrap());
    for f in support::files_of(local) {
        assert_eq!(
            std::fs::read(local.join(&f)).unwrap(),
            std::fs::read(report.dir.join(&f)).unwrap(),
            "{f}"
        );
    }
}

macro_rules! server_or_skip {
    ($start:expr) => {
        match $start {
            Ok(s) => s,
            Err(why) => {
                eprintln!("skipping: {why}");
                return;
            }
        }
    };
}

#[test]
fn s3_set_is_fetched_checked_and_reused() {
    let tmp = tempfile::tempdir().unwrap();
    let server = server_or_skip!(support::start_s3(tmp.path(), "sets"));
    let local = tmp.path().join("local");
    let m = make_set(&local, 1, &[70_000, 50_000, 30_000]);
    support::upload_s3(&server, "sets", "scene/v1", &local);
    let opts = cache(tmp.path(), 1 << 30);
    let url = "s3://sets/scene/v1/";

    let first = remote::materialize_with(url, &opts, &s3_options(&server)).unwrap();
    assert_eq!(first.url, "s3://sets/scene/v1");
    assert_eq!(first.fetched.len(), 3);
    assert!(first.reused.is_empty());
    assert_eq!(
        first.fetched_bytes,
        m.shards.iter().map(|s| s.bytes).sum::<u64>()
    );
    assert_same_set(&local, &first);
    assert!(first.line().contains("3 fetched"), "{}", first.line());

    // Again: the manifest is read anew, every shard comes from the cache.
    let second = remote::materialize_with(url, &opts, &s3_options(&server)).unwrap();
    assert_eq!(second.dir, first.dir);
    assert!(second.fetched.is_empty(), "{second:?}");
    assert_eq!(second.reused.len(), 3);
    // The manifest URL names the same set.
    let third = remote::materialize_with(
        "s3://sets/scene/v1/manifest.json",
        &opts,
        &s3_options(&server),
    )
    .unwrap();
    assert_eq!((third.dir, third.fetched.len()), (first.dir.clone(), 0));

    // A cached shard damaged on the local disk is fetched again.
    let victim = first.dir.join(&m.shards[1].file);
    let mut bytes = std::fs::read(&victim).unwrap();
    bytes[100] ^= 1;
    std::fs::write(&victim, bytes).unwrap();
    let fourth = remote::materialize_with(url, &opts, &s3_options(&server)).unwrap();
    assert_eq!(fourth.fetched, vec![m.shards[1].file.clone()]);
    assert_same_set(&local, &fourth);
}

#[test]
fn s3_damaged_object_is_refused_naming_url_and_shard() {
    let tmp = tempfile::tempdir().unwrap();
    let server = server_or_skip!(support::start_s3(tmp.path(), "sets"));
    let local = tmp.path().join("local");
    let m = make_set(&local, 2, &[40_000, 20_000]);
    support::upload_s3(&server, "sets", "damaged", &local);
    // One bit flipped in the object the server stores (s3s-fs keeps it as a file).
    let shard = &m.shards[0].file;
    let stored = server.root.join("sets/damaged").join(shard);
    let mut bytes = std::fs::read(&stored).unwrap();
    bytes[1234] ^= 0x10;
    std::fs::write(&stored, bytes).unwrap();

    let opts = cache(tmp.path(), 1 << 30);
    let err =
        remote::materialize_with("s3://sets/damaged", &opts, &s3_options(&server)).unwrap_err();
    assert!(matches!(err, RemoteError::HashMismatch { .. }), "{err:?}");
    let msg = err.to_string();
    assert!(
        msg.contains(&format!("s3://sets/damaged/{shard}")) && msg.contains(&m.shards[0].sha256),
        "{msg}"
    );
    // Nothing under the shard's name, no temporary file, no manifest in the cache.
    let dir = std::fs::read_dir(&opts.folder)
        .unwrap()
        .flatten()
        .next()
        .unwrap()
        .path();
    let names = support::files_of(&dir);
    assert!(
        !names
            .iter()
            .any(|n| n.contains(shard.as_str()) || n == MANIFEST_FILE),
        "{names:?}"
    );

    // A manifest that is not the one stage.json records is refused before any fetch.
    let stored_manifest = server.root.join("sets/damaged").join(MANIFEST_FILE);
    let mut edited = Manifest::load(&stored_manifest).unwrap();
    edited.shards.pop();
    edited.save(&stored_manifest).unwrap();
    let err = remote::materialize_with("s3://sets/damaged", &opts, &s3_options(&server))
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("s3://sets/damaged/manifest.json") && err.contains("stage.json records"),
        "{err}"
    );
}

#[test]
fn s3_wrong_credentials_and_missing_set_name_the_url() {
    let tmp = tempfile::tempdir().unwrap();
    let server = server_or_skip!(support::start_s3(tmp.path(), "sets"));
    let local = tmp.path().join("local");
    make_set(&local, 3, &[1000]);
    support::upload_s3(&server, "sets", "one", &local);
    let opts = cache(tmp.path(), 1 << 30);

    let err = remote::materialize_with("s3://sets/none", &opts, &s3_options(&server))
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("s3://sets/none/manifest.json") && err.contains("not found"),
        "{err}"
    );
    let mut wrong = s3_options(&server);
    wrong
        .s3_config
        .push(("aws_secret_access_key".into(), "not-the-secret".into()));
    let err = remote::materialize_with("s3://sets/one", &opts, &wrong)
        .unwrap_err()
        .to_string();
    assert!(err.contains("s3://sets/one/"), "{err}");
}

#[test]
fn unreachable_server_fails_after_retries_naming_the_url() {
    let tmp = tempfile::tempdir().unwrap();
    let opts = cache(tmp.path(), 1 << 30);
    // A port nobody listens on: every connection is refused.
    let port = support::free_port();
    let o = FetchOptions {
        retries: 3,
        retry_timeout: Duration::from_secs(10),
        ..quick()
    };
    for url in [
        format!("http://127.0.0.1:{port}/sets/a"),
        "s3://sets/a".to_string(),
    ] {
        let o = FetchOptions {
            s3_config: vec![
                ("aws_endpoint".into(), format!("http://127.0.0.1:{port}")),
                ("aws_allow_http".into(), "true".into()),
                ("aws_access_key_id".into(), "k".into()),
                ("aws_secret_access_key".into(), "s".into()),
                ("aws_region".into(), "us-east-1".into()),
            ],
            ..o.clone()
        };
        let start = Instant::now();
        let err = remote::materialize_with(&url, &opts, &o).unwrap_err();
        let took = start.elapsed();
        assert!(matches!(err, RemoteError::Fetch { .. }), "{err:?}");
        let msg = err.to_string();
        // The set's file, and the client's account of its retries.
        assert!(msg.starts_with(&format!("{url}/")), "{msg}");
        assert!(msg.contains("after 3 retries"), "{msg}");
        // Three backoffs of at least 100, 200, 400 ms (with jitter, 0 to that), yet
        // bounded by the retry timeout.
        assert!(took < Duration::from_secs(30), "{took:?}");
    }
}

#[test]
fn http_set_is_fetched_once_then_served_from_the_cache() {
    let tmp = tempfile::tempdir().unwrap();
    let server = server_or_skip!(support::start_http(tmp.path()));
    let local = tmp.path().join("local");
    let m = make_set(&local, 4, &[60_000, 10_000, 5_000]);
    support::publish_http(&server, "sets/scene", &local);
    let url = format!("http://127.0.0.1:{}/sets/scene", server.port);
    let opts = cache(tmp.path(), 1 << 30);

    let first = remote::materialize_with(&url, &opts, &quick()).unwrap();
    assert_eq!(first.fetched.len(), 3);
    assert_same_set(&local, &first);
    let second = remote::materialize_with(&url, &opts, &quick()).unwrap();
    assert!(second.fetched.is_empty());
    // The server's own log: each shard was requested once, the manifest and stage.json
    // on every call.
    for s in &m.shards {
        assert_eq!(
            support::http_gets(&server, &format!("/sets/scene/{}", s.file)),
            1
        );
    }
    assert_eq!(support::http_gets(&server, "/sets/scene/manifest.json"), 2);
    assert_eq!(support::http_gets(&server, "/sets/scene/stage.json"), 2);

    // Republished under the same URL: only the changed shard is fetched, and the
    // folder holds the new set and nothing of the old one.
    let republished = tmp.path().join("v2");
    let mut m2 = make_set(&republished, 4, &[60_000, 10_000, 5_000]);
    let changed = republished.join("train-00001.mcap");
    std::fs::write(&changed, vec![7u8; 3000]).unwrap();
    m2.shards[1].sha256 = stage::sha256_file(&changed).unwrap();
    m2.shards[1].bytes = 3000;
    let dropped = m2.shards.pop().unwrap();
    std::fs::remove_file(republished.join(dropped.file)).unwrap();
    (m2.planned_shards, m2.planned_frames) = (2, 20);
    write_records(&republished, &m2);
    for f in support::files_of(&server.root.join("sets/scene")) {
        std::fs::remove_file(server.root.join("sets/scene").join(f)).unwrap();
    }
    support::publish_http(&server, "sets/scene", &republished);
    let third = remote::materialize_with(&url, &opts, &quick()).unwrap();
    assert_eq!(third.fetched, vec!["train-00001.mcap".to_string()]);
    assert_eq!(third.reused, vec!["train-00000.mcap".to_string()]);
    assert_same_set(&republished, &third);
    assert!(!third.dir.join("test-00000.mcap").exists());

    // A shard missing on the server: an error naming its URL.
    std::fs::remove_file(server.root.join("sets/scene/train-00001.mcap")).unwrap();
    std::fs::remove_file(third.dir.join("train-00001.mcap")).unwrap();
    let err = remote::materialize_with(&url, &opts, &quick())
        .unwrap_err()
        .to_string();
    assert!(
        err.contains(&format!("{url}/train-00001.mcap")) && err.contains("not found"),
        "{err}"
    );
}

#[test]
fn cache_limit_evicts_the_least_recently_used_set_and_refuses_what_cannot_fit() {
    let tmp = tempfile::tempdir().unwrap();
    let server = server_or_skip!(support::start_http(tmp.path()));
    let base = format!("http://127.0.0.1:{}", server.port);
    // Three sets of ~100 kB; the cache holds two.
    let mut urls = Vec::new();
    for (i, name) in ["a", "b", "c"].iter().enumerate() {
        let local = tmp.path().join(name);
        make_set(&local, 10 + i as u64, &[60_000, 40_000]);
        support::publish_http(&server, name, &local);
        urls.push(format!("{base}/{name}"));
    }
    let opts = cache(tmp.path(), 250_000);
    let dirs: Vec<PathBuf> = urls
        .iter()
        .take(2)
        .map(|u| remote::materialize_with(u, &opts, &quick()).unwrap().dir)
        .collect();
    assert_ne!(dirs[0], dirs[1], "two URLs share a folder");

    // Both are held by this process: the third set cannot evict them.
    let err = remote::materialize_with(&urls[2], &opts, &quick()).unwrap_err();
    assert!(matches!(err, RemoteError::CacheFull { .. }), "{err:?}");
    assert!(err.to_string().contains(&urls[0]), "{err}");
    assert!(dirs[0].is_dir() && dirs[1].is_dir());

    // Released, a is the least recently used of the two and makes way for c.
    for d in &dirs {
        remote::release(d);
    }
    let c = remote::materialize_with(&urls[2], &opts, &quick()).unwrap();
    assert_eq!(c.evicted, vec![urls[0].clone()]);
    assert!(!dirs[0].exists() && dirs[1].is_dir() && c.dir.is_dir());

    // A set larger than the limit alone is refused before anything is fetched.
    let small = cache(&tmp.path().join("small"), 50_000);
    let err = remote::materialize_with(&urls[1], &small, &quick()).unwrap_err();
    assert!(matches!(err, RemoteError::TooLarge { .. }), "{err:?}");
    assert!(err.to_string().starts_with(&urls[1]), "{err}");
    let b_gets = support::http_gets(&server, "/b/train-00000.mcap");
    assert_eq!(b_gets, 1, "the refused set was fetched");
}

#[test]
fn a_folder_is_returned_as_is() {
    let opts = CacheOptions {
        folder: PathBuf::from("/nonexistent"),
        max_bytes: 1,
    };
    assert_eq!(
        remote::materialize("work/shard", &opts).unwrap(),
        PathBuf::from("work/shard")
    );
    let (dir, report) = remote::resolve(Path::new("/data/shard")).unwrap();
    assert_eq!((dir, report), (PathBuf::from("/data/shard"), None));
}
