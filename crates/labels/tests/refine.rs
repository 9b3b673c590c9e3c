//! Depth refinement on the analytic scene: noisy SfM labels move back to the exact
//! geometry, holes in the depth drop labels, bad depth is refused, output bytes do not
//! depend on the thread count.

use labels::import::{self, ImportConfig};
use labels::import_stage;
use labels::refine::{PointSampling, RefineConfig, RefineError};
use labels::refine_stage;
use labels::{LabelTables, Spread};
use testkit::files::folder_bytes;
use testkit::scene::{Scene, SceneOptions};

/// `--label-noise-cm 5`: 5 cm RMS 3D error, i.e. 5 / sqrt(3) cm per coordinate.
fn noisy_scene() -> Scene {
    Scene::build(&SceneOptions {
        noise_sigma_m: 0.05 / 3f64.sqrt(),
        seed: 7,
        ..Default::default()
    })
}

fn import(scene: &Scene) -> LabelTables {
    import_stage::run(
        &scene.with_inputs(&ImportConfig::default()),
        &scene.frames_path,
        &scene.out("labels"),
        &import::sift_only,
    )
    .unwrap();
    LabelTables::read(&scene.out("labels")).unwrap()
}

fn d3(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    (0..3).map(|k| (a[k] - b[k]).powi(2)).sum::<f64>().sqrt()
}

/// 3D errors of the valid point labels against the exact points.
fn point_errors(scene: &Scene, t: &LabelTables) -> Vec<f64> {
    t.points
        .iter()
        .filter_map(|r| Some(d3(&r.xyz?, &scene.gt_points[&(r.point3d_id as u64)])))
        .collect()
}

/// Mean endpoint error of the valid line labels against the exact segment (best order).
fn line_errors(scene: &Scene, t: &LabelTables) -> Vec<f64> {
    t.lines
        .iter()
        .filter_map(|r| {
            let e = r.endpoints?;
            let g = scene.gt_tracks[r.track_id as usize];
            let keep = 0.5 * (d3(&e[0], &g[0]) + d3(&e[1], &g[1]));
            let swap = 0.5 * (d3(&e[0], &g[1]) + d3(&e[1], &g[0]));
            Some(keep.min(swap))
        })
        .collect()
}

struct Ablation {
    points: (Spread, Spread, usize, usize),
    lines: (Spread, Spread, usize, usize),
}

fn ablation(scene: &Scene, config: &RefineConfig, out: &str) -> Ablation {
    let before = import(scene);
    let o = refine_stage::run(
        config,
        &scene.frames_path,
        &scene.out("labels"),
        &scene.out(out),
    )
    .unwrap();
    let after = LabelTables::read(&scene.out(out)).unwrap();
    assert_eq!(after.source, labels::LabelSource::DepthRefined);
    let r = &o.output.report;
    print!("{}", r.table());
    let a = Ablation {
        points: (
            Spread::of(&point_errors(scene, &before)),
            Spread::of(&point_errors(scene, &after)),
            r.points.dropped(),
            r.points.labels,
        ),
        lines: (
            Spread::of(&line_errors(scene, &before)),
            Spread::of(&line_errors(scene, &after)),
            r.lines.dropped(),
            r.lines.labels,
        ),
    };
    println!(
        "ablation ({:?} sampling), 3D label error against the exact scene:",
        config.point_sampling
    );
    println!("labels   median before (cm)  median after (cm)  reduction  dropped");
    for (name, (b, f, dropped, n)) in [("points", &a.points), ("lines", &a.lines)] {
        println!(
            "{name:<7} {:>19.3} {:>18.3} {:>9.1} % {:>5} / {}",
            b.median * 100.0,
            f.median * 100.0,
            100.0 * (1.0 - f.median / b.median),
            dropped,
            n
        );
    }
    a
}

#[test]
fn refinement_brings_noisy_labels_back_to_the_exact_scene() {
    let scene = noisy_scene();
    let a = ablation(&scene, &RefineConfig::default(), "refined");
    for (name, (before, after, dropped, n)) in [("points", a.points), ("lines", a.lines)] {
        assert!(before.median > 0.03, "{name}: noise {:?}", before);
        assert!(
            after.median <= 0.2 * before.median,
            "{name}: median error {} -> {} is not an 80 % reduction",
            before.median,
            after.median
        );
        assert!(
            (dropped as f64) < 0.05 * n as f64,
            "{name}: dropped {dropped} of {n}"
        );
    }
}

#[test]
fn upstream_projection_sampling_only_corrects_along_the_ray() {
    // Reading depth at the projection of a mislocated point removes only the error's
    // component along the viewing ray: less than the keypoint sampling.
    let scene = noisy_scene();
    let config = RefineConfig {
        point_sampling: PointSampling::Projection,
        ..Default::default()
    };
    let proj = ablation(&scene, &config, "projection");
    let kp = ablation(&scene, &RefineConfig::default(), "keypoint");
    assert!(proj.points.1.median < proj.points.0.median);
    assert!(proj.points.1.median > 2.0 * kp.points.1.median);
}

#[test]
fn observations_without_valid_depth_lose_their_label() {
    let mut scene = Scene::build(&SceneOptions::default());
    let labels = import(&scene);
    // Punch a hole (0 = no depth) into the depth map of frame 0 around its first
    // labelled keypoint.
    let f0 = &scene.train_frames()[0];
    let row = labels
        .points
        .iter()
        .find(|r| r.frame_id == f0.id && r.xyz.is_some())
        .unwrap()
        .clone();
    let path = f0.depth_path.clone().unwrap();
    let mut depth = image::open(&path).unwrap().into_luma16();
    let (cx, cy) = (row.xy[0] as i64, row.xy[1] as i64);
    for y in cy - 3..=cy + 3 {
        for x in cx - 3..=cx + 3 {
            if x >= 0
                && y >= 0
                && x < testkit::scene::WIDTH as i64
                && y < testkit::scene::HEIGHT as i64
            {
                depth.put_pixel(
                    x as u32,
                    y as u32,
                    image::Luma([if x % 2 == 0 { 0 } else { 65535 }]),
                );
            }
        }
    }
    depth.save(&path).unwrap();
    // Ingested again with the new depth map (its hash), and so imported again.
    scene.rehash_depth();
    import(&scene);
    let o = refine_stage::run(
        &RefineConfig::default(),
        &scene.frames_path,
        &scene.out("labels"),
        &scene.out("refined"),
    )
    .unwrap();
    let after = LabelTables::read(&scene.out("refined")).unwrap();
    let same = |r: &labels::PointRow| r.frame_id == row.frame_id && r.kp_index == row.kp_index;
    assert_eq!(after.points.iter().find(|r| same(r)).unwrap().xyz, None);
    // The same 3D point keeps its label elsewhere, at the exact position (1 mm depth steps).
    let gt = scene.gt_points[&(row.point3d_id as u64)];
    let others: Vec<_> = after
        .points
        .iter()
        .filter(|r| r.point3d_id == row.point3d_id && !same(r))
        .collect();
    assert!(!others.is_empty());
    for r in others {
        assert!(d3(&r.xyz.unwrap(), &gt) < 2e-3, "{:?} vs {gt:?}", r.xyz);
    }
    assert!(o.output.report.points.dropped_no_depth >= 1);
    assert_eq!(o.output.report.points.dropped_disagree, 0);
}

#[test]
fn refuses_depth_maps_of_another_size() {
    let mut scene = Scene::build(&SceneOptions::default());
    let f = &scene.train_frames()[1];
    image::ImageBuffer::<image::Luma<u16>, Vec<u16>>::from_pixel(320, 240, image::Luma([1000]))
        .save(f.depth_path.as_ref().unwrap())
        .unwrap();
    scene.rehash_depth();
    import(&scene);
    let e = refine_stage::run(
        &RefineConfig::default(),
        &scene.frames_path,
        &scene.out("labels"),
        &scene.out("refined"),
    )
    .unwrap_err();
    assert!(matches!(e, RefineError::Depth(_)), "{e:?}");
    let msg = e.to_string();
    assert!(
        msg.contains(
            "depth map is 320x240, but the image of frame 1 (seq-01/frame-000001.color.png) is 640x480"
        ),
        "{msg}"
    );
    assert!(!scene.out("refined").join("stage.json").exists());
}

#[test]
fn refuses_depth_maps_that_are_not_16_bit() {
    let mut scene = Scene::build(&SceneOptions::default());
    let f = &scene.train_frames()[2];
    image::GrayImage::from_pixel(640, 480, image::Luma([7]))
        .save(f.depth_path.as_ref().unwrap())
        .unwrap();
    scene.rehash_depth();
    import(&scene);
    let e = refine_stage::run(
        &RefineConfig::default(),
        &scene.frames_path,
        &scene.out("labels"),
        &scene.out("refined"),
    )
    .unwrap_err();
    let msg = e.to_string();
    assert!(
        msg.contains("expected a 16-bit single-channel depth map, got L8"),
        "{msg}"
    );
}

#[test]
fn refuses_labels_of_another_frames_table_and_tables_without_depth() {
    let mut scene = Scene::build(&SceneOptions::default());
    import(&scene);
    scene.table.meta.scene = "another".into();
    scene.write_frames();
    let e = refine_stage::run(
        &RefineConfig::default(),
        &scene.frames_path,
        &scene.out("labels"),
        &scene.out("refined"),
    )
    .unwrap_err();
    assert!(
        matches!(
            e,
            RefineError::Table(tables::TableError::OtherFrames { .. })
        ),
        "{e:?}"
    );
    assert!(e.to_string().contains("run the import again"), "{e}");

    for f in &mut scene.table.frames {
        f.depth_path = None;
        f.depth_hash = None;
    }
    scene.table.meta.depth_source = "none".into();
    scene.write_frames();
    import(&scene);
    let e = refine_stage::run(
        &RefineConfig::default(),
        &scene.frames_path,
        &scene.out("labels"),
        &scene.out("refined"),
    )
    .unwrap_err();
    assert_eq!(
        e.to_string(),
        "no training frame has a depth map (frames table depth source: none)"
    );
}

#[test]
fn same_bytes_for_any_thread_count_and_reruns_are_skipped() {
    let mut scene = noisy_scene();
    import(&scene);
    let run_with = |threads: usize, out: &str| {
        testkit::on_threads(threads, || {
            refine_stage::run(
                &RefineConfig::default(),
                &scene.frames_path,
                &scene.out("labels"),
                &scene.out(out),
            )
            .unwrap()
        })
    };
    let a = run_with(1, "one");
    let b = run_with(2, "two");
    assert!(!a.skipped && !b.skipped);
    assert_eq!(
        folder_bytes(&scene.out("one")),
        folder_bytes(&scene.out("two"))
    );
    assert!(run_with(2, "one").skipped);
    // A changed depth map (ingested again) is a changed input.
    let f = &scene.train_frames()[0];
    let path = f.depth_path.clone().unwrap();
    let mut depth = image::open(&path).unwrap().into_luma16();
    depth.put_pixel(0, 0, image::Luma([0]));
    depth.save(&path).unwrap();
    scene.rehash_depth();
    import(&scene);
    let run_with = |threads: usize, out: &str| {
        testkit::on_threads(threads, || {
            refine_stage::run(
                &RefineConfig::default(),
                &scene.frames_path,
                &scene.out("labels"),
                &scene.out(out),
            )
            .unwrap()
        })
    };
    assert!(!run_with(1, "one").skipped);
}

#[test]
fn refinement_survives_sensor_noise() {
    // Kinect-like depth noise (4 mm per pixel) and noisy detections (0.5 px) on top of
    // the 5 cm label noise.
    let scene = Scene::build(&SceneOptions {
        noise_sigma_m: 0.05 / 3f64.sqrt(),
        depth_noise_mm: 4.0,
        detection_noise_px: 0.5,
        seed: 11,
        ..Default::default()
    });
    let a = ablation(&scene, &RefineConfig::default(), "refined");
    for (name, (before, after, dropped, n)) in [("points", a.points), ("lines", a.lines)] {
        assert!(
            after.median <= 0.2 * before.median,
            "{name}: median error {} -> {}",
            before.median,
            after.median
        );
        assert!(
            (dropped as f64) < 0.05 * n as f64,
            "{name}: dropped {dropped} of {n}"
        );
    }
}

/// Overwrites the depth map of `frame` with `mm` on the pixels within `r` of `points`.
fn paint_depth(scene: &Scene, frame: u32, points: &[[f64; 2]], r: f64, mm: u16) {
    let f = scene.table.frames.iter().find(|f| f.id == frame).unwrap();
    let path = f.depth_path.clone().unwrap();
    let mut depth = image::open(&path).unwrap().into_luma16();
    for (x, y, px) in depth.enumerate_pixels_mut() {
        let (cx, cy) = (x as f64 + 0.5, y as f64 + 0.5);
        if points
            .iter()
            .any(|p| (p[0] - cx).powi(2) + (p[1] - cy).powi(2) <= r * r)
        {
            *px = image::Luma([mm]);
        }
    }
    depth.save(&path).unwrap();
}

#[test]
fn observations_that_disagree_with_the_others_are_rejected() {
    let mut scene = Scene::build(&SceneOptions::default());
    let labels = import(&scene);
    // A point seen in at least three frames: its observation in one frame reads an
    // occluder at 1 m.
    let mut count: std::collections::BTreeMap<i64, usize> = Default::default();
    for r in labels.points.iter().filter(|r| r.xyz.is_some()) {
        *count.entry(r.point3d_id).or_default() += 1;
    }
    let (&pid, _) = count.iter().find(|&(_, &n)| n >= 3).unwrap();
    let victim = labels
        .points
        .iter()
        .find(|r| r.point3d_id == pid)
        .unwrap()
        .clone();
    paint_depth(&scene, victim.frame_id, &[victim.xy], 3.0, 1000);
    // A track with at least three supports: one support reads the occluder along its
    // first half, so its samples are not on one line.
    let mut supports: std::collections::BTreeMap<i64, Vec<&labels::LineRow>> = Default::default();
    for r in labels.lines.iter().filter(|r| r.endpoints.is_some()) {
        supports.entry(r.track_id).or_default().push(r);
    }
    let (&tid, rows) = supports
        .iter()
        .find(|(_, v)| v.len() >= 3 && v[0].frame_id != victim.frame_id)
        .unwrap();
    let bad = rows[0].clone();
    let s = bad.segment;
    let half: Vec<[f64; 2]> = (0..=20)
        .map(|k| {
            let t = 0.5 * k as f64 / 20.0;
            [s[0] + t * (s[2] - s[0]), s[1] + t * (s[3] - s[1])]
        })
        .collect();
    paint_depth(&scene, bad.frame_id, &half, 3.0, 1000);
    scene.rehash_depth();
    import(&scene);

    let o = refine_stage::run(
        &RefineConfig::default(),
        &scene.frames_path,
        &scene.out("labels"),
        &scene.out("refined"),
    )
    .unwrap();
    print!("{}", o.output.report.table());
    let after = LabelTables::read(&scene.out("refined")).unwrap();
    let row = |f: u32, k: u32| {
        after
            .points
            .iter()
            .find(|r| r.frame_id == f && r.kp_index == k)
            .unwrap()
    };
    assert_eq!(row(victim.frame_id, victim.kp_index).xyz, None);
    let gt = scene.gt_points[&(pid as u64)];
    for r in after
        .points
        .iter()
        .filter(|r| r.point3d_id == pid && r.frame_id != victim.frame_id)
    {
        assert!(d3(&r.xyz.unwrap(), &gt) < 2e-3);
    }
    assert!(o.output.report.points.dropped_disagree >= 1);

    let line = |f: u32, k: u32| {
        after
            .lines
            .iter()
            .find(|r| r.frame_id == f && r.seg_index == k)
            .unwrap()
    };
    assert_eq!(line(bad.frame_id, bad.seg_index).endpoints, None);
    assert!(o.output.report.lines.dropped_fit >= 1);
    let g = scene.gt_tracks[tid as usize];
    for r in &rows[1..] {
        let e = line(r.frame_id, r.seg_index).endpoints.unwrap();
        let err = (0.5 * (d3(&e[0], &g[0]) + d3(&e[1], &g[1])))
            .min(0.5 * (d3(&e[0], &g[1]) + d3(&e[1], &g[0])));
        assert!(err < 2e-3, "{err}");
    }
}

/// The refine stage's out folder holds nothing under a final name after a refusal.
fn assert_nothing_written(dir: &std::path::Path) {
    for f in [
        "stage.json",
        "points.parquet",
        "lines.parquet",
        "poses.parquet",
    ] {
        assert!(!dir.join(f).exists(), "{f} written");
    }
}

/// Frame 1's depth map copied over frame 0's after ingest: refused, naming the file,
/// the frame and both hashes (frame 0 would be refined against frame 1's depth).
#[test]
fn refuses_a_depth_map_changed_since_ingest() {
    let scene = Scene::build(&SceneOptions::default());
    import(&scene);
    let (f0, f1) = (&scene.train_frames()[0], &scene.train_frames()[1]);
    let (d0, d1) = (
        f0.depth_path.clone().unwrap(),
        f1.depth_path.clone().unwrap(),
    );
    std::fs::copy(&d1, &d0).unwrap();
    let out = scene.out("refined");
    let e = refine_stage::run(
        &RefineConfig::default(),
        &scene.frames_path,
        &scene.out("labels"),
        &out,
    )
    .unwrap_err();
    assert!(matches!(e, RefineError::DepthChanged { .. }), "{e:?}");
    assert_eq!(
        e.to_string(),
        format!(
            "{}: the depth map of frame 0 ({}) changed since ingest (sha256 {}, the frames \
             table says {}): run the ingest again",
            d0.display(),
            f0.name,
            stage::sha256_file(&d1).unwrap(),
            f0.depth_hash.as_deref().unwrap()
        )
    );
    assert_nothing_written(&out);
}

/// A frames table written before depth maps were hashed: its depth maps are refused
/// (the ingest writes the table again, crates/datasets/tests/ingest_stage.rs).
#[test]
fn refuses_depth_maps_without_a_hash() {
    let scene = Scene::build(&SceneOptions::default());
    let mut df = scene.table.to_dataframe(&scene.frames_path).unwrap();
    df.drop_in_place("depth_hash").unwrap();
    let (_, kv) = tables::parquet::read_parquet(&scene.frames_path).unwrap();
    let ours = kv.into_iter().filter(|(k, _)| k.starts_with("pl2map."));
    tables::parquet::write_parquet(&scene.frames_path, &mut df, ours.collect()).unwrap();
    let dir = scene.frames_path.parent().unwrap();
    let mut rec = stage::StageRecord::load(dir).unwrap().unwrap();
    rec.add_output(dir, "frames.parquet").unwrap();
    rec.save(dir).unwrap();
    import(&scene);
    let out = scene.out("refined");
    let e = refine_stage::run(
        &RefineConfig::default(),
        &scene.frames_path,
        &scene.out("labels"),
        &out,
    )
    .unwrap_err();
    assert!(
        e.to_string().ends_with(
            "frame 0 (seq-01/frame-000000.color.png) has a depth map but no depth hash (a \
             frames table written before depth maps were hashed): run the ingest again"
        ),
        "{e}"
    );
    assert_nothing_written(&out);
}

/// The refine stage reads the import's tables and the frames table only as their stages
/// recorded them: tables a refused import left (no record), tables changed after the
/// import, a frames table without its record, another stage's folder are each refused,
/// naming the file and the stage to run again, and nothing is written.
#[test]
fn refuses_tables_their_stage_did_not_record() {
    let scene = Scene::build(&SceneOptions::default());
    import(&scene);
    let labels = scene.out("labels");
    let out = scene.out("refined");
    let refine = |labels: &std::path::Path| {
        refine_stage::run(&RefineConfig::default(), &scene.frames_path, labels, &out)
            .unwrap_err()
            .to_string()
    };

    // A refused rerun of the import removes its record and may leave the tables.
    let record = std::fs::read(labels.join("stage.json")).unwrap();
    std::fs::remove_file(labels.join("stage.json")).unwrap();
    let e = refine(&labels);
    assert_eq!(
        e,
        format!(
            "{}: missing: points.parquet, lines.parquet, poses.parquet in {} are not the \
             outputs of a finished import or refine run (a refused or killed run leaves no \
             record): run the import or refine stage again",
            labels.join("stage.json").display(),
            labels.display()
        )
    );
    assert_nothing_written(&out);

    // Tables changed after the import recorded them.
    std::fs::write(labels.join("stage.json"), &record).unwrap();
    let points = std::fs::read(labels.join("points.parquet")).unwrap();
    std::fs::copy(labels.join("lines.parquet"), labels.join("points.parquet")).unwrap();
    let e = refine(&labels);
    assert!(
        e.starts_with(&format!(
            "{}: changed after the import stage recorded it",
            labels.join("points.parquet").display()
        )) && e.ends_with("run the import stage again"),
        "{e}"
    );
    assert_nothing_written(&out);
    std::fs::write(labels.join("points.parquet"), points).unwrap();

    // Another stage's folder.
    let ingest = scene.frames_path.parent().unwrap();
    let e = refine(ingest);
    assert!(
        e.contains("the record of the ingest stage, expected the import or refine stage's"),
        "{e}"
    );

    // A frames table without its record (a refused ingest).
    std::fs::remove_file(ingest.join("stage.json")).unwrap();
    let e = refine(&labels);
    assert!(
        e.starts_with(&ingest.join("stage.json").display().to_string())
            && e.contains("frames.parquet in")
            && e.ends_with("run the ingest stage again"),
        "{e}"
    );
    assert_nothing_written(&out);
    scene.write_frames();
    refine_stage::run(&RefineConfig::default(), &scene.frames_path, &labels, &out).unwrap();
}
