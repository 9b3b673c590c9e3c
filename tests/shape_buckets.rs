//! How many tensor shapes a training run presents to the network, with shape buckets off
//! and on (crates/model/src/buckets.rs): a JIT engine (CUDA, CubeCL) compiles kernels
//! for each new shape, so this count is what buckets are for.
//!
//! The synthetic room (300 frames, `pl2map run` of the built binary up to the shards)
//! feeds the trainer's own data path, `train::trainer::sample_stream`
//! (the shuffled epoch order, each frame prepared with the SIFT front-end, seeded by its
//! stream position, the descriptor cache filled up front). Shapes counted:
//! - the network's passes, (images, N, M) each, from `train::step::pass_shapes` (the
//!   step's own grouping);
//! - without buckets, the loss's index gathers (crates/model/src/loss.rs): the labelled
//!   points and lines of the map term, and with the reprojection term on, its target
//!   sets. With buckets the loss runs over masks in the pass's shape: nothing to add.
//!
//! Recipes: the main job (pipeline/synthetic.toml's [train]: 16 images a step in two
//! gradient groups, limits 32 / 12, no augmentation) and the paper recipe's data path
//! (pipeline/7scenes-paper.toml's [train]: one image a step, limits 2048 / 128 (its
//! `max_keypoints`; lines take the default), augmentation on half the samples), with the
//! SIFT front-end on the synthetic room (its SuperPoint needs the user's weights; the
//! front-end does not change the counts). Also the default limits 1024 / 128. Each over
//! 2,000 steps.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::process::Command;
use train::config::ShapeBuckets;
use train::{Device, Limits, TrainConfig};

const STEPS: u64 = 2000;

fn pl2map() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_pl2map"));
    c.arg("--quiet");
    c
}

/// The synthetic room's training shards under `root`: `pl2map run` of the default room
/// (synth, ingest, import and shard with their defaults; no refine) up to the shards.
fn room_shards(root: &Path) -> Vec<PathBuf> {
    let file = root.join("room.toml");
    std::fs::write(
        &file,
        "work = \"work\"\n[synth]\n[ingest]\n[import]\n[shard]\n",
    )
    .unwrap();
    testkit::process::ok(
        pl2map()
            .arg("run")
            .arg(&file)
            .args(["--until", "shard"])
            .output()
            .unwrap(),
        "pl2map run --until shard",
    );
    let mut shards: Vec<PathBuf> = std::fs::read_dir(root.join("work/shard"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| {
            p.file_name()
                .and_then(|n| n.to_str())
                .is_some_and(|n| n.starts_with("train-") && n.ends_with(".mcap"))
        })
        .collect();
    shards.sort();
    assert!(!shards.is_empty());
    shards
}

/// What the shapes of one image depend on: its (N, M) and the sizes of its loss's index
/// gathers without buckets.
#[derive(Clone, Copy)]
struct ImageSizes {
    rows: (usize, usize),
    labelled_points: usize,
    labelled_lines: usize,
    /// Labelled lines of non-zero length (the paper's reprojection target set).
    reprojectable_lines: usize,
}

/// The sizes that decide one prepared image's shapes.
fn image_sizes(p: &train::sample::Prepared) -> ImageSizes {
    let s = &p.sample;
    let labelled = |valid: &[bool]| valid.iter().filter(|v| **v).count();
    ImageSizes {
        rows: (s.num_points(), s.num_lines()),
        labelled_points: labelled(&s.point_valid),
        labelled_lines: labelled(&s.line_valid),
        reprojectable_lines: s
            .segments
            .iter()
            .zip(&s.line_valid)
            .filter(|(seg, v)| **v && model::sample::line_equation(seg).is_some())
            .count(),
    }
}

/// Over `STEPS` steps of `config`'s data path (the trainer's own sample stream, its
/// descriptor cache filled up front as in training, spilled into `work`): the distinct
/// shapes with buckets off (passes and gathers) and on (passes), and the distinct real
/// (N, M) of the images.
fn count_shapes(shards: &[PathBuf], config: &TrainConfig, work: &Path) -> (usize, usize, usize) {
    let front_end = frontends::build(&config.front_end).unwrap();
    let spill = work.join(format!("spill-{}", config.limits.max_keypoints));
    let mut stream =
        train::trainer::sample_stream(config, shards, front_end, ([0.0; 3], 0), &spill, false)
            .unwrap();
    let reprojection = config.loss.weight_reprojection > 0.0;
    let on = TrainConfig {
        shape_buckets: ShapeBuckets::On,
        ..config.clone()
    };
    let buckets = on.training_buckets(Device::Cpu);
    assert!(buckets.is_some());
    // The default policy on the CPU: no buckets.
    assert_eq!(config.training_buckets(Device::Cpu), None);
    let (mut off_shapes, mut on_shapes, mut sizes) =
        (BTreeSet::new(), BTreeSet::new(), BTreeSet::new());
    // A gather's shape: (which gather, rows); a pass's: (images, N, M).
    let mut gathers = BTreeSet::new();
    for _ in 0..STEPS {
        let images: Vec<ImageSizes> = (0..config.batch_frames)
            .map(|_| image_sizes(&stream.next_item().unwrap().1))
            .collect();
        let step: Vec<(usize, usize)> = images.iter().map(|i| i.rows).collect();
        sizes.extend(step.iter().copied());
        let passes = |b| train::step::pass_shapes(&step, config.batch_groups, b);
        off_shapes.extend(passes(None));
        on_shapes.extend(passes(buckets));
        for i in &images {
            gathers.insert(("labelled points", i.labelled_points));
            gathers.insert(("labelled lines", i.labelled_lines));
            if reprojection {
                gathers.insert(("reprojectable labelled lines", i.reprojectable_lines));
            }
        }
    }
    let off_shapes = off_shapes.len() + gathers.len();
    (off_shapes, on_shapes.len(), sizes.len())
}

#[test]
fn shape_buckets_bound_the_shapes_a_run_presents() {
    let dir = tempfile::tempdir().unwrap();
    let shards = room_shards(dir.path());
    let pipeline = |name: &str| {
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../pipeline")
            .join(name)
    };
    // The main job: pipeline/synthetic.toml's [train] as it is.
    let text = std::fs::read_to_string(pipeline("synthetic.toml")).unwrap();
    let mut table: toml::Table = toml::from_str(&text).unwrap();
    let train = toml::Table::from_iter([("train".to_string(), table.remove("train").unwrap())]);
    let main_job = TrainConfig::from_toml_str(&toml::to_string(&train).unwrap()).unwrap();
    assert_eq!(
        (main_job.batch_frames, main_job.batch_groups),
        (16, 2),
        "pipeline/synthetic.toml changed: update this test's doc comment"
    );
    assert_eq!(
        main_job.limits,
        Limits {
            max_keypoints: 32,
            max_lines: 12
        }
    );
    // The paper recipe: pipeline/7scenes-paper.toml's batch, limits and augmentation.
    let text = std::fs::read_to_string(pipeline("7scenes-paper.toml")).unwrap();
    let table: toml::Table = toml::from_str(&text).unwrap();
    let paper_train = &table["train"];
    let paper_limits: Limits = paper_train["limits"].clone().try_into().unwrap();
    let paper = TrainConfig {
        batch_frames: paper_train["batch_frames"].as_integer().unwrap() as usize,
        limits: paper_limits,
        augment: paper_train["augment"].clone().try_into().unwrap(),
        loss: paper_train["loss"].clone().try_into().unwrap(),
        ..TrainConfig::default()
    };
    let default_limits = TrainConfig {
        limits: Limits::default(),
        ..paper.clone()
    };
    // Bounds on the distinct passes with buckets on: the main job's images sit at its
    // limits or one ladder size under (two gradient groups of 8 share one shape); the
    // paper's ladders hold 13 (N: 0 and 12 sizes) x 10 (M) pairs, of which the room's
    // images meet a few.
    for c in [&main_job, &paper] {
        assert_eq!(c.front_end, TrainConfig::default().front_end);
    }
    for (name, config, bound) in [
        (
            "main job (batch 16 in 2 groups, limits 32/12)",
            &main_job,
            4,
        ),
        (
            "paper recipe (batch 1, limits 2048/128, augmented)",
            &paper,
            30,
        ),
        (
            "default limits (batch 1, limits 1024/128, augmented)",
            &default_limits,
            30,
        ),
    ] {
        let (off, on, sizes) = count_shapes(&shards, config, dir.path());
        eprintln!(
            "{name}: {STEPS} steps, {sizes} distinct image sizes (N, M); distinct tensor \
             shapes (network passes and loss gathers): {off} with buckets off, {on} with \
             buckets on"
        );
        assert!(on <= bound, "{name}: {on} shapes with buckets on");
        assert!(on <= off, "{name}: {on} > {off}");
    }
}
