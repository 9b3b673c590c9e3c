//! `pl2map localize` through the built binary:
//! - on the tiny synthetic scene's images, the same poses, bit for bit, as the score
//!   stage with the same model and seed, for any thread count;
//! - bad queries (missing image, bad camera line, image of another size) are named with
//!   their file and line, the others localised, the exit status non-zero;
//! - a query list in hloc's format over the real 7-Scenes sample frames, whose results
//!   file is read back the way hloc's evaluation reads it (Python), and the `--visual`
//!   MCAP read with Python's `mcap` library.
//!
//! The model is trained for a few iterations only: these tests check the localisation
//! path and the files, not the accuracy.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::OnceLock;
use testkit::process::ok;

fn pl2map() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_pl2map"));
    c.arg("--quiet");
    c
}

/// RANSAC iterations at most: a barely trained model leaves few inliers.
const MAX_ITERATIONS: &str = "300";

struct Scene {
    root: PathBuf,
    scene: PathBuf,
    frames: tables::FramesTable,
    model: PathBuf,
    score: PathBuf,
}

/// synth --tiny -> ingest -> import -> shard -> train (3 iterations) -> score, once
/// for every test of this file.
fn scene() -> &'static Scene {
    static SCENE: OnceLock<Scene> = OnceLock::new();
    SCENE.get_or_init(|| {
        let root = tempfile::tempdir().unwrap().keep();
        ok(
            pl2map()
                .arg("synth")
                .arg(root.join("data"))
                .arg("--tiny")
                .output()
                .unwrap(),
            "synth",
        );
        let scene = root.join("data/synthroom");
        ok(
            pl2map()
                .args(["ingest", "--dataset", "7scenes", "--root"])
                .arg(&scene)
                .arg("--out")
                .arg(root.join("frames"))
                .output()
                .unwrap(),
            "ingest",
        );
        let frames_path = root.join("frames/frames.parquet");
        ok(
            pl2map()
                .arg("import")
                .arg("--frames")
                .arg(&frames_path)
                .arg("--model")
                .arg(scene.join("sfm_gt/colmap"))
                .arg("--limap")
                .arg(scene.join("sfm_gt/limap"))
                .arg("--out")
                .arg(root.join("labels"))
                .output()
                .unwrap(),
            "import",
        );
        ok(
            pl2map()
                .arg("shard")
                .arg("--frames")
                .arg(&frames_path)
                .arg("--labels")
                .arg(root.join("labels"))
                .arg("--out")
                .arg(root.join("shards"))
                .output()
                .unwrap(),
            "shard",
        );
        ok(
            pl2map()
                .arg("train")
                .arg("--shards")
                .arg(root.join("shards"))
                .arg("--out")
                .arg(root.join("train"))
                .args(["--iterations", "3", "--checkpoint-every", "3"])
                .output()
                .unwrap(),
            "train",
        );
        let model = root.join("train/model.ckpt");
        ok(
            pl2map()
                .arg("score")
                .arg("--shards")
                .arg(root.join("shards"))
                .arg("--checkpoint")
                .arg(&model)
                .arg("--out")
                .arg(root.join("score"))
                .args(["--max-iterations", MAX_ITERATIONS])
                .output()
                .unwrap(),
            "score",
        );
        Scene {
            frames: tables::FramesTable::read_parquet(&frames_path).unwrap(),
            score: root.join("score"),
            root,
            scene,
            model,
        }
    })
}

/// `name MODEL W H PARAMS...` of a camera, numbers in round-trip form.
fn camera_spec(c: &geometry::Camera) -> String {
    let mut s = format!("{} {} {}", c.model.name(), c.width, c.height);
    for p in &c.params {
        s.push_str(&format!(" {p}"));
    }
    s
}

/// `pl2map localize` of the scene's model over `list`, RANSAC capped; more flags may follow.
fn localize_cmd(list: &Path, images: &Path, out: &Path) -> Command {
    let mut c = pl2map();
    c.arg("localize")
        .arg("--checkpoint")
        .arg(&scene().model)
        .arg("--queries")
        .arg(list)
        .arg("--images")
        .arg(images)
        .arg("--out")
        .arg(out)
        .args(["--max-iterations", MAX_ITERATIONS]);
    c
}

fn localize(list: &Path, images: &Path, out: &Path, threads: usize) -> Output {
    localize_cmd(list, images, out)
        .env("RAYON_NUM_THREADS", threads.to_string())
        .output()
        .unwrap()
}

fn lines_of(path: &Path) -> Vec<String> {
    std::fs::read_to_string(path)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
        .lines()
        .map(str::to_string)
        .collect()
}

/// `name MODEL W H PARAMS...` lines of `frames`.
fn query_list<'a>(frames: impl IntoIterator<Item = &'a tables::Frame>) -> String {
    let mut list = String::from("# the tiny synthetic scene\n");
    for f in frames {
        list.push_str(&format!("{} {}\n", f.name, camera_spec(&f.camera)));
    }
    list
}

/// The lines of an hloc results file by image name.
fn results_by_name(path: &Path) -> std::collections::BTreeMap<String, String> {
    lines_of(path)
        .into_iter()
        .map(|l| (l.split(' ').next().unwrap().to_string(), l))
        .collect()
}

#[test]
fn same_poses_as_the_score_stage_for_any_thread_count_and_list_order() {
    let s = scene();
    // Every frame, in a shuffled order (reversed, then every third one moved to the
    // front): an image's pose must depend neither on its place in the list nor on the
    // command that localised it (RANSAC is seeded by the image's name).
    let mut order: Vec<&tables::Frame> = s.frames.frames.iter().rev().collect();
    let (mut front, back): (Vec<_>, Vec<_>) =
        order.drain(..).enumerate().partition(|(i, _)| i % 3 == 0);
    front.extend(back);
    let order: Vec<&tables::Frame> = front.into_iter().map(|(_, f)| f).collect();
    assert!(order.iter().enumerate().any(|(i, f)| f.id as usize != i));
    let dir = tempfile::tempdir().unwrap();
    let list_path = dir.path().join("queries_with_intrinsics.txt");
    std::fs::write(&list_path, query_list(order)).unwrap();
    let one = dir.path().join("one");
    let two = dir.path().join("two");
    let stdout = ok(
        localize(&list_path, &s.scene, &one, 1),
        "localize (1 thread)",
    );
    assert!(stdout.contains("0 bad input"), "{stdout}");
    ok(
        localize(&list_path, &s.scene, &two, 2),
        "localize (2 threads)",
    );
    assert_eq!(
        std::fs::read(one.join("results.txt")).unwrap(),
        std::fs::read(two.join("results.txt")).unwrap(),
        "results differ between 1 and 2 threads"
    );
    // The score stage's points + lines poses of the test frames, image for image.
    let scored = results_by_name(&s.score.join("results_points_lines.txt"));
    assert!(!scored.is_empty(), "the score stage localised no frame");
    let localized = results_by_name(&one.join("results.txt"));
    let test_names: Vec<&str> = s
        .frames
        .frames
        .iter()
        .filter(|f| f.split == tables::Split::Test)
        .map(|f| f.name.as_str())
        .collect();
    let localized_test: std::collections::BTreeMap<String, String> = localized
        .into_iter()
        .filter(|(name, _)| test_names.contains(&name.as_str()))
        .collect();
    assert_eq!(localized_test, scored, "localize and score disagree");
    // The table: one row per query, every one read.
    let table = lines_of(&one.join("per_image.csv"));
    assert_eq!(table.len(), 1 + s.frames.frames.len());
    assert!(table[0].starts_with("id,name,origin,status,"));
    assert!(!table.iter().any(|l| l.contains("bad_input")));
}

/// A JPEG cut short (a damaged download) is named with its file and the byte offset
/// where it ends, by `pl2map localize` and by `pl2map features`; the other images are
/// still localised / written, and the exit status is non-zero.
#[test]
fn truncated_jpeg_queries_are_named_with_the_byte_offset() {
    let s = scene();
    let dir = tempfile::tempdir().unwrap();
    let good = &s.frames.frames[24];
    let rgb = image::open(s.scene.join(&good.name)).unwrap().to_rgb8();
    let mut jpeg = Vec::new();
    image::codecs::jpeg::JpegEncoder::new_with_quality(&mut jpeg, 95)
        .encode_image(&rgb)
        .unwrap();
    let cut = jpeg.len() / 2;
    std::fs::write(dir.path().join("whole.jpg"), &jpeg).unwrap();
    std::fs::write(dir.path().join("cut.jpg"), &jpeg[..cut]).unwrap();
    let cam = camera_spec(&good.camera);
    let list_path = dir.path().join("q.txt");
    std::fs::write(&list_path, format!("whole.jpg {cam}\ncut.jpg {cam}\n")).unwrap();
    let out = dir.path().join("out");
    let o = localize(&list_path, dir.path(), &out, 2);
    assert!(!o.status.success(), "a damaged query must fail the command");
    let table = lines_of(&out.join("per_image.csv"));
    assert_eq!(table.len(), 3, "{table:?}");
    assert!(!table[1].contains("bad_input"), "{}", table[1]);
    assert!(
        table[2].contains("bad_input")
            && table[2].contains("cut.jpg")
            && table[2].contains("truncated JPEG")
            && table[2].contains(&format!("byte {cut}")),
        "{}",
        table[2]
    );

    // `pl2map features` over the same folder: the whole image written, the cut one named.
    let images = dir.path().join("images");
    std::fs::create_dir_all(&images).unwrap();
    for f in ["whole.jpg", "cut.jpg"] {
        std::fs::copy(dir.path().join(f), images.join(f)).unwrap();
    }
    let h5 = dir.path().join("feats.h5");
    let o = pl2map()
        .args(["features", "--front-end", "sift", "--images"])
        .arg(&images)
        .arg("--out")
        .arg(&h5)
        .output()
        .unwrap();
    assert!(!o.status.success(), "features must fail on a damaged image");
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(
        stderr.contains("1 of 2 images")
            && stderr.contains("cut.jpg")
            && stderr.contains(&format!("byte {cut}")),
        "{stderr}"
    );
    assert!(h5.exists(), "the readable image's features are written");
}

#[test]
fn bad_queries_are_named_and_the_others_localised() {
    let s = scene();
    let dir = tempfile::tempdir().unwrap();
    let good = &s.frames.frames[24];
    let cam = camera_spec(&good.camera);
    // Line 2: good; 3: missing image; 4: unparsable camera; 5: another size; 6: not an
    // image; 7: line 2's name again.
    std::fs::write(dir.path().join("notes.png"), b"not an image").unwrap();
    let other = &s.frames.frames[25];
    for copy in ["copy.png", "copy2.png"] {
        std::fs::copy(s.scene.join(&other.name), dir.path().join(copy)).unwrap();
    }
    std::fs::create_dir_all(dir.path().join(good.name.rsplit_once('/').unwrap().0)).unwrap();
    std::fs::copy(s.scene.join(&good.name), dir.path().join(&good.name)).unwrap();
    let wrong_size = format!(
        "PINHOLE {} {} 100 100 50 50",
        good.camera.width * 2,
        good.camera.height
    );
    let list = format!(
        "# queries\n{g} {cam}\nmissing.png {cam}\ncopy.png SIMPLE_PINHOLE 640 x 1\n\
         copy2.png {wrong_size}\nnotes.png {cam}\n{g} {cam}\n",
        g = good.name
    );
    let list_path = dir.path().join("q.txt");
    std::fs::write(&list_path, list).unwrap();
    let out = dir.path().join("out");
    let o = localize(&list_path, dir.path(), &out, 2);
    assert!(!o.status.success(), "bad queries must fail the command");
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(stderr.contains("5 of 6 queries"), "{stderr}");
    let table = std::fs::read_to_string(out.join("per_image.csv")).unwrap();
    let rows: Vec<&str> = table.lines().collect();
    assert_eq!(rows.len(), 7, "{table}");
    let q = list_path.display().to_string();
    assert!(!rows[1].contains("bad_input"), "{}", rows[1]);
    for (row, (line, what)) in rows[2..].iter().zip([
        (3, "missing.png"),
        (4, "height"),
        (5, "camera says"),
        (6, "neither a PNG nor a JPEG"),
        (7, "listed twice (first at line 2)"),
    ]) {
        assert!(
            row.contains("bad_input") && row.contains(&format!("{q}:{line}")) && row.contains(what),
            "line {line}: {row}"
        );
    }
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(stdout.contains(&format!("{q}:3")), "{stdout}");
    // The good query's pose is written.
    let results = lines_of(&out.join("results.txt"));
    assert!(results.len() <= 1);
    if let Some(r) = results.first() {
        assert!(r.starts_with(&good.name));
    }
}

/// Cameras that cannot exist (a negative focal length, which images the scene turned 180
/// degrees; a focal length of 0; a principal point at 1e12) are bad input naming the
/// line and what is wrong, never a pose in results.txt; with `--camera` the command
/// refuses before anything is written (docs/errors.md).
#[test]
fn impossible_cameras_are_refused_not_localised() {
    let s = scene();
    let dir = tempfile::tempdir().unwrap();
    let good = &s.frames.frames[24];
    let (w, h) = (good.camera.width, good.camera.height);
    for name in ["neg.png", "zero.png", "far.png"] {
        std::fs::copy(s.scene.join(&good.name), dir.path().join(name)).unwrap();
    }
    let list = format!(
        "neg.png SIMPLE_PINHOLE {w} {h} -525 {cx} {cy}\n\
         zero.png SIMPLE_PINHOLE {w} {h} 0 {cx} {cy}\n\
         far.png SIMPLE_PINHOLE {w} {h} 525 1e12 {cy}\n",
        cx = w / 2,
        cy = h / 2
    );
    let list_path = dir.path().join("q.txt");
    std::fs::write(&list_path, list).unwrap();
    let out = dir.path().join("out");
    let o = localize(&list_path, dir.path(), &out, 2);
    assert!(
        !o.status.success(),
        "impossible cameras must fail the command"
    );
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(stderr.contains("3 of 3 queries"), "{stderr}");
    let table = std::fs::read_to_string(out.join("per_image.csv")).unwrap();
    let rows: Vec<&str> = table.lines().collect();
    assert_eq!(rows.len(), 4, "{table}");
    let q = list_path.display().to_string();
    for (row, (line, what)) in rows[1..].iter().zip([
        (1, "focal length f = -525 must be positive and finite"),
        (2, "focal length f = 0 must be positive and finite"),
        (3, "principal point cx = 1000000000000"),
    ]) {
        assert!(
            row.contains("bad_input") && row.contains(&format!("{q}:{line}")) && row.contains(what),
            "line {line}: {row}"
        );
    }
    assert!(lines_of(&out.join("results.txt")).is_empty());

    // One camera for a folder: refused before any image, nothing written.
    let out = dir.path().join("folder-out");
    let o = pl2map()
        .arg("localize")
        .arg("--checkpoint")
        .arg(&s.model)
        .arg("--camera")
        .arg(format!("SIMPLE_PINHOLE {w} {h} 0 {} {}", w / 2, h / 2))
        .arg("--images")
        .arg(dir.path())
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert!(
        !o.status.success(),
        "--camera with focal length 0 must fail"
    );
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(
        stderr.contains("--camera") && stderr.contains("focal length f = 0 must be positive"),
        "{stderr}"
    );
    assert!(!out.exists(), "nothing may be written");
}

#[test]
fn real_7scenes_queries_give_a_results_file_hloc_reads() {
    let Some(stairs) = testkit::sample::sample_data("7scenes-stairs-mini/stairs") else {
        return;
    };
    // hloc's 7-Scenes query list: the test sequences, PINHOLE with the dataset's focal.
    let mut names = Vec::new();
    for seq in ["seq-01", "seq-04"] {
        let mut v: Vec<String> = std::fs::read_dir(stairs.join(seq))
            .unwrap()
            .filter_map(|e| {
                let n = e.unwrap().file_name().to_string_lossy().into_owned();
                n.ends_with(".color.jpg").then(|| format!("{seq}/{n}"))
            })
            .collect();
        v.sort();
        names.extend(v);
    }
    assert!(!names.is_empty());
    let dir = tempfile::tempdir().unwrap();
    let list: String = names
        .iter()
        .map(|n| format!("{n} PINHOLE 640 480 525 525 320 240\n"))
        .collect();
    let list_path = dir.path().join("queries_with_intrinsics.txt");
    std::fs::write(&list_path, list).unwrap();
    let out = dir.path().join("out");
    let stdout = ok(
        localize_cmd(&list_path, &stairs, &out)
            .arg("--visual")
            .output()
            .unwrap(),
        "localize (7-Scenes)",
    );
    assert!(
        stdout.contains(&format!("{} queries", names.len())),
        "{stdout}"
    );
    let results = out.join("results.txt");
    let n_results = lines_of(&results).len();
    let Some(python) = testkit::python::python(&["numpy", "mcap"]) else {
        return;
    };
    // hloc's evaluation: split each line, name then 7 floats, q -> R (w first).
    let script = r#"
import sys, numpy as np
from mcap.reader import make_reader
results, names, visual = sys.argv[1], sys.argv[2].split(","), sys.argv[3]
def qvec2rotmat(q):
    w, x, y, z = q
    return np.array([
        [1 - 2*y*y - 2*z*z, 2*x*y - 2*w*z, 2*z*x + 2*w*y],
        [2*x*y + 2*w*z, 1 - 2*x*x - 2*z*z, 2*y*z - 2*w*x],
        [2*z*x - 2*w*y, 2*y*z + 2*w*x, 1 - 2*x*x - 2*y*y]])
predictions = {}
text = open(results).read().rstrip()
for data in (text.split("\n") if text else []):
    data = data.split()
    name = data[0]
    q, t = np.split(np.array(data[1:], float), [4])
    R = qvec2rotmat(q)
    assert abs(np.linalg.det(R) - 1) < 1e-9, name
    assert np.allclose(R @ R.T, np.eye(3), atol=1e-9), name
    assert t.shape == (3,) and np.all(np.isfinite(t)), name
    predictions[name] = (R, t)
assert set(predictions) <= set(names), set(predictions) - set(names)
counts, schemas = {}, {}
with open(visual, "rb") as f:
    for schema, channel, message in make_reader(f).iter_messages():
        counts[channel.topic] = counts.get(channel.topic, 0) + 1
        schemas[channel.topic] = (schema.name, schema.encoding, channel.message_encoding)
print(len(predictions))
for topic in sorted(counts):
    print(topic, counts[topic], *schemas[topic])
"#;
    let stdout = testkit::python::run(
        Command::new(&python)
            .arg("-c")
            .arg(script)
            .arg(&results)
            .arg(names.join(","))
            .arg(out.join("visual.mcap")),
    );
    let stdout = String::from_utf8(stdout).unwrap();
    let mut lines = stdout.lines();
    assert_eq!(lines.next().unwrap().parse::<usize>().unwrap(), n_results);
    let channels: Vec<&str> = lines.collect();
    let n = names.len();
    let posed = n_results; // one /tf per estimated pose (points + lines, else points)
    let expected = [
        format!("/camera/calibration {n} foxglove.CameraCalibration protobuf protobuf"),
        format!("/camera/image {n} foxglove.CompressedImage protobuf protobuf"),
        format!("/predictions/lines {n} foxglove.SceneUpdate protobuf protobuf"),
        format!("/predictions/points {n} foxglove.PointCloud protobuf protobuf"),
    ];
    for e in &expected {
        assert!(channels.contains(&e.as_str()), "{e} not in {channels:?}");
    }
    // /tf: one per pose shown (none without ground truth here); absent when no query
    // got a pose.
    let tf = channels.iter().find(|c| c.starts_with("/tf "));
    if posed > 0 {
        let tf = tf.expect("a /tf channel");
        let count: usize = tf.split(' ').nth(1).unwrap().parse().unwrap();
        assert!(count >= posed, "{tf}");
    }
}

#[test]
fn a_folder_with_one_camera() {
    let s = scene();
    let dir = tempfile::tempdir().unwrap();
    let f = &s.frames.frames[26];
    std::fs::copy(s.scene.join(&f.name), dir.path().join("a.png")).unwrap();
    let out = dir.path().join("out");
    let stdout = ok(
        pl2map()
            .arg("localize")
            .arg("--checkpoint")
            .arg(&s.model)
            .arg("--camera")
            .arg(camera_spec(&f.camera))
            .arg("--images")
            .arg(dir.path())
            .arg("--out")
            .arg(&out)
            .args(["--lines", "off", "--max-iterations", MAX_ITERATIONS])
            .output()
            .unwrap(),
        "localize a folder",
    );
    assert!(stdout.contains("1 queries"), "{stdout}");
    let table = lines_of(&out.join("per_image.csv"));
    assert!(table[1].starts_with("0,a.png,"), "{}", table[1]);
    let _ = &s.root;
}

/// Query lines from LIMAP-format segment files (`pl2map score --query-segments`): files
/// holding exactly the segments the model's own line detector finds give the score
/// stage's poses bit for bit; the summary says where the lines came from; a test frame
/// missing from the files is named.
#[test]
fn query_segments_from_limap_files() {
    let s = scene();
    let predictor = train::Predictor::load(&s.model).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let limap_dir = dir.path().join("limap-queries");
    let segments_dir = limap_dir.join("line_detections/lsd/segments");
    std::fs::create_dir_all(&segments_dir).unwrap();
    let test: Vec<&tables::Frame> = s
        .frames
        .frames
        .iter()
        .filter(|f| f.split == tables::Split::Test)
        .collect();
    let mut list = format!("number of images, {}\n", test.len());
    for (k, f) in test.iter().enumerate() {
        let id = k + 1;
        list.push_str(&format!("{id}, {}\n", f.name));
        let gray = features::load_gray(&s.scene.join(&f.name)).unwrap();
        let segments = predictor.front_end().segments(&gray).unwrap();
        // Round-trip numbers: the file holds the detector's segments exactly.
        let mut text = format!("{}\n", segments.len());
        for seg in &segments {
            text.push_str(&format!(
                "{:?} {:?} {:?} {:?}\n",
                seg[0], seg[1], seg[2], seg[3]
            ));
        }
        std::fs::write(segments_dir.join(format!("segments_{id}.txt")), text).unwrap();
    }
    std::fs::write(limap_dir.join("image_list.txt"), list).unwrap();
    let score = |out: &Path| {
        pl2map()
            .arg("score")
            .arg("--shards")
            .arg(s.root.join("shards"))
            .arg("--checkpoint")
            .arg(&s.model)
            .arg("--out")
            .arg(out)
            .args(["--max-iterations", MAX_ITERATIONS])
            .arg("--query-segments")
            .arg(&limap_dir)
            .output()
            .unwrap()
    };
    let out = dir.path().join("score");
    ok(score(&out), "score with query segments");

    // `pl2map localize --query-segments`: the same folder gives the poses of the
    // detector's own lines; a folder that does not exist is refused before any image.
    let list_path = dir.path().join("q.txt");
    std::fs::write(&list_path, query_list(test.iter().copied())).unwrap();
    let localize_with = |segments: &Path, out: &Path| {
        localize_cmd(&list_path, &s.scene, out)
            .arg("--query-segments")
            .arg(segments)
            .output()
            .unwrap()
    };
    let with = dir.path().join("localize-segments");
    ok(
        localize_with(&limap_dir, &with),
        "localize --query-segments",
    );
    let without = dir.path().join("localize-lsd");
    ok(localize(&list_path, &s.scene, &without, 2), "localize");
    assert_eq!(
        std::fs::read(with.join("results.txt")).unwrap(),
        std::fs::read(without.join("results.txt")).unwrap()
    );
    let gone = dir.path().join("no-such-folder");
    let refused = dir.path().join("localize-refused");
    let o = localize_with(&gone, &refused);
    assert!(
        !o.status.success(),
        "a missing --query-segments folder must be refused"
    );
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(stderr.contains("no-such-folder"), "{stderr}");
    assert!(!refused.join("results.txt").exists());
    assert_eq!(
        std::fs::read(out.join("results_points_lines.txt")).unwrap(),
        std::fs::read(s.score.join("results_points_lines.txt")).unwrap()
    );
    let summary = std::fs::read_to_string(out.join("summary.md")).unwrap();
    assert!(
        summary.contains("query lines from the segment files"),
        "{summary}"
    );

    // One test frame's file removed: that frame fails with its name, the others do not.
    std::fs::remove_file(segments_dir.join("segments_1.txt")).unwrap();
    let out = dir.path().join("score-missing");
    let o = score(&out);
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    let summary = std::fs::read_to_string(out.join("summary.md")).unwrap_or_default();
    assert!(
        text.contains(&format!("no segments for {}", test[0].name))
            || summary.contains(&format!("no segments for {}", test[0].name)),
        "{text}\n{summary}"
    );
}

/// Images that are no images to read: a PNG over the pixel limit and `/dev/zero` are bad
/// queries naming the list line, the file and what is wrong (too large, with the limit;
/// not a regular file), read no further than their header and never handed to OpenCV.
#[cfg(unix)]
#[test]
fn oversized_and_special_files_are_bad_queries_named_without_opencv_text() {
    use image::ImageEncoder;
    use image::codecs::png::{CompressionType, FilterType, PngEncoder};
    let s = scene();
    let dir = tempfile::tempdir().unwrap();
    let good = &s.frames.frames[24];
    let cam = camera_spec(&good.camera);
    let (w, h) = (20_000u32, 20_000u32);
    let mut huge = Vec::new();
    PngEncoder::new_with_quality(&mut huge, CompressionType::Fast, FilterType::NoFilter)
        .write_image(
            &vec![0u8; w as usize * h as usize],
            w,
            h,
            image::ExtendedColorType::L8,
        )
        .unwrap();
    std::fs::write(dir.path().join("huge.png"), &huge).unwrap();
    let zero = Path::new("/dev/zero").exists();
    let mut list = format!("huge.png {cam}\n");
    if zero {
        std::os::unix::fs::symlink("/dev/zero", dir.path().join("zero.png")).unwrap();
        list.push_str(&format!("zero.png {cam}\n"));
    }
    let list_path = dir.path().join("q.txt");
    std::fs::write(&list_path, list).unwrap();
    let out = dir.path().join("out");
    let o = localize(&list_path, dir.path(), &out, 2);
    assert!(!o.status.success(), "bad queries must fail the command");
    let table = lines_of(&out.join("per_image.csv"));
    let q = list_path.display().to_string();
    assert!(
        table[1].contains("bad_input")
            && table[1].contains(&format!("{q}:1"))
            && table[1].contains(&dir.path().join("huge.png").display().to_string())
            && table[1].contains("the PNG is too large: 20000x20000 is 400000000 pixels")
            && table[1].contains("the limit is 50000000 pixels"),
        "{}",
        table[1]
    );
    if zero {
        assert!(
            table[2].contains("bad_input")
                && table[2].contains(&format!("{q}:2"))
                && table[2].contains("zero.png: not a regular file but a device"),
            "{}",
            table[2]
        );
    }
    let all = format!(
        "{}{}{}",
        table.join("\n"),
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(
        !all.contains("OpenCV") && !all.contains("Assertion"),
        "{all}"
    );
}
