//! Integration tests of the synthetic scene: exact geometry, layouts, determinism.

use geometry::{Camera, CameraModel, Pose};
use nalgebra::{Matrix4, Vector2, Vector3};
use std::path::Path;
use std::sync::OnceLock;
use synth::layout::{format_pose_txt, seven_scenes_names};
use synth::render::{NO_SURFACE, SAMPLES};
use synth::texture::luma;
use synth::trajectory::{CLEARANCE_M, HEIGHT_RANGE_M, plan_frames, plan_sequences};
use synth::{
    EdgeKind, Layout, Scene, Split, SynthConfig, SynthDataset, SynthError, WriteOptions, generate,
};
use testkit::files::files;

const SEED: u64 = 7;

fn tiny() -> &'static SynthDataset {
    static D: OnceLock<SynthDataset> = OnceLock::new();
    D.get_or_init(|| SynthDataset::new(0, SEED, true).expect("tiny dataset"))
}

/// World ray through the centre of pixel (i, j): origin and direction with camera z = 1.
fn pixel_ray(cam: &Camera, pose: &Pose, i: u32, j: u32) -> (Vector3<f64>, Vector3<f64>) {
    let p = &cam.params;
    let d = Vector3::new(
        (i as f64 + 0.5 - p[2]) / p[0],
        (j as f64 + 0.5 - p[3]) / p[1],
        1.0,
    );
    (pose.centre(), pose.rotation.inverse() * d)
}

#[test]
fn depth_map_matches_raycast_and_reprojects() {
    let ds = tiny();
    let mut checked = 0usize;
    let mut mismatched = 0usize;
    for &fi in &[0usize, 13, 27] {
        let f = &ds.frames[fi];
        let r = ds.render_frame(fi).unwrap();
        assert_eq!((r.width, r.height), (640, 480));
        let depth_png = r.depth_mm();
        for j in (0..480u32).step_by(3) {
            for i in (0..640u32).step_by(3) {
                let k = (j * 640 + i) as usize;
                let (o, d) = pixel_ray(&ds.camera, &f.pose, i, j);
                let hit = ds.scene.raycast(&o, &d);
                checked += 1;
                let Some(hit) = hit else {
                    assert_eq!(r.quad_ids[k], NO_SURFACE);
                    continue;
                };
                if hit.quad_id != r.quad_ids[k] {
                    // Only possible exactly on a shared boundary (rounding differs).
                    mismatched += 1;
                    continue;
                }
                // The ray has camera z = 1, so t is the depth.
                let z = r.depth_m[k] as f64;
                assert!(
                    (hit.t - z).abs() <= 1e-6 * z.max(1.0),
                    "pixel ({i},{j}): {} vs {z}",
                    hit.t
                );
                let mm = depth_png.get_pixel(i, j)[0];
                assert_eq!(mm as f64, (r.depth_m[k] as f64 * 1000.0).round());
                // The hit point projects back onto the pixel centre.
                let px = ds
                    .camera
                    .project(&f.pose.transform_point(&hit.point))
                    .unwrap();
                assert!(
                    (px - Vector2::new(i as f64 + 0.5, j as f64 + 0.5)).norm() < 1e-6,
                    "{px:?}"
                );
                // And it lies on the quad it names.
                let q = &ds.scene.quads()[hit.quad_id as usize];
                assert!(q.plane_distance(&hit.point).abs() < 1e-9);
            }
        }
    }
    assert!(
        mismatched * 2000 < checked,
        "{mismatched} of {checked} pixels disagree on the visible quad"
    );
}

#[test]
fn every_pixel_sees_the_room() {
    // Cameras are inside the closed room: no pixel may miss every surface.
    let ds = tiny();
    let r = ds.render_frame(5).unwrap();
    assert!(r.quad_ids.iter().all(|&q| q != NO_SURFACE));
    assert!(r.depth_m.iter().all(|&z| z > 0.3 && z < 6.0));
}

#[test]
fn edges_lie_on_their_faces() {
    let scene = &tiny().scene;
    let quads = scene.quads();
    let mut kinds = std::collections::HashMap::new();
    for (n, e) in scene.edges().iter().enumerate() {
        *kinds.entry(e.kind).or_insert(0usize) += 1;
        assert!(e.a.iter().chain(e.b.iter()).all(|v| v.is_finite()));
        assert!(e.length() >= 0.01, "edge {n} is {} m long", e.length());
        assert!(e.faces.iter().any(Option::is_some), "edge {n} has no face");
        let mut on_boundary_of_some_face = false;
        for (slot, f) in e.faces.iter().enumerate() {
            let Some(f) = f else { continue };
            let q = &quads[*f as usize];
            // A decal's second face is the surface it lies on, a few millimetres behind it.
            let tol = if e.kind == EdgeKind::DecalBorder && slot == 1 {
                0.02
            } else {
                1e-9
            };
            for p in [&e.a, &e.b, &((e.a + e.b) * 0.5)] {
                let dist = q.plane_distance(p);
                assert!(
                    dist > -1e-9 && dist < tol,
                    "edge {n} ({:?}) leaves the plane of quad {f}: {dist}",
                    e.kind
                );
                let [a, b] = q.local_of(p);
                assert!(
                    a > -1e-9 && a < q.size[0] + 1e-9 && b > -1e-9 && b < q.size[1] + 1e-9,
                    "edge {n} ({:?}) leaves quad {f}: ({a}, {b}) of {:?}",
                    e.kind,
                    q.size
                );
            }
            // Both endpoints on the same side of the rectangle.
            let la = q.local_of(&e.a);
            let lb = q.local_of(&e.b);
            let same_side = (0..2).any(|ax| {
                [0.0, q.size[ax]]
                    .iter()
                    .any(|&v| (la[ax] - v).abs() < 1e-9 && (lb[ax] - v).abs() < 1e-9)
            });
            on_boundary_of_some_face |= same_side;
        }
        match e.kind {
            EdgeKind::RoomCorner | EdgeKind::ObjectEdge | EdgeKind::DecalBorder => {
                assert!(
                    on_boundary_of_some_face,
                    "edge {n} ({:?}) is not a quad side",
                    e.kind
                )
            }
            EdgeKind::TextureEdge => assert_eq!(e.faces[1], None),
        }
    }
    assert_eq!(kinds[&EdgeKind::RoomCorner], 12);
    assert!(kinds[&EdgeKind::ObjectEdge] > 300, "{kinds:?}");
    assert!(kinds[&EdgeKind::DecalBorder] >= 4 * 5, "{kinds:?}");
    assert!(kinds[&EdgeKind::TextureEdge] > 200, "{kinds:?}");
}

#[test]
fn texture_edges_are_intensity_steps() {
    // Sample the painted texture on both sides of every texture edge: the step must be
    // there, at the listed place (3 texels either side), along most of the edge.
    let scene = &tiny().scene;
    let mut weak = Vec::new();
    let mut total = 0;
    for (n, e) in scene.edges().iter().enumerate() {
        if e.kind != EdgeKind::TextureEdge {
            continue;
        }
        total += 1;
        let face = e.faces[0].unwrap();
        let q = &scene.quads()[face as usize];
        let tex = scene.texture(face).unwrap();
        let rho = tex.texels_per_metre();
        let (a, b) = (q.local_of(&e.a), q.local_of(&e.b));
        let dir = Vector2::new(b[0] - a[0], b[1] - a[1]).normalize();
        let nrm = Vector2::new(-dir.y, dir.x) * (3.0 / rho);
        let mut diffs = Vec::new();
        for k in 1..10 {
            let t = k as f64 / 10.0;
            let p = Vector2::new(a[0] + (b[0] - a[0]) * t, a[1] + (b[1] - a[1]) * t);
            let (p1, p2) = (p + nrm, p - nrm);
            let inside =
                |p: &Vector2<f64>| p.x >= 0.0 && p.y >= 0.0 && p.x < q.size[0] && p.y < q.size[1];
            if !(inside(&p1) && inside(&p2)) {
                continue;
            }
            let s = |p: &Vector2<f64>| luma(tex.texel((p.x * rho) as usize, (p.y * rho) as usize));
            diffs.push((s(&p1) - s(&p2)).abs());
        }
        if diffs.is_empty() {
            continue;
        }
        diffs.sort_by(f32::total_cmp);
        let median = diffs[diffs.len() / 2];
        let expected = e.contrast.unwrap() / q.shade;
        if median < 0.5 * expected || median < 0.05 {
            weak.push((n, median, expected));
        }
    }
    assert!(total > 200);
    assert!(
        weak.len() * 100 <= total,
        "{} of {total} texture edges show no step: {:?}",
        weak.len(),
        &weak[..weak.len().min(10)]
    );
}

#[test]
fn rendered_geometric_edges_show_steps() {
    // Project visible object/room/decal edges into rendered frames and compare the image
    // on both sides, 2.5 px from the edge.
    let ds = tiny();
    let (mut seen, mut stepped) = (0usize, 0usize);
    for fi in [2usize, 9, 16, 26] {
        let f = &ds.frames[fi];
        let r = ds.render_frame(fi).unwrap();
        let c = f.pose.centre();
        for e in ds.scene.edges() {
            if e.kind == EdgeKind::TextureEdge {
                continue;
            }
            for t in [0.3, 0.5, 0.7] {
                let p = e.a + (e.b - e.a) * t;
                // Visible with a little slack (points on the edge touch both faces).
                if !ds.scene.is_visible(&c, &p, 2e-3) {
                    continue;
                }
                let (Some(x), Some(x2)) = (
                    ds.camera.project(&f.pose.transform_point(&p)),
                    ds.camera.project(
                        &f.pose
                            .transform_point(&(p + (e.b - e.a).normalize() * 0.01)),
                    ),
                ) else {
                    continue;
                };
                let d = (x2 - x).normalize();
                let nrm = Vector2::new(-d.y, d.x) * 2.5;
                let (p1, p2) = (x + nrm, x - nrm);
                let ok = |p: &Vector2<f64>| p.x >= 1.0 && p.y >= 1.0 && p.x < 639.0 && p.y < 479.0;
                if !(ok(&p1) && ok(&p2)) {
                    continue;
                }
                let g = |p: &Vector2<f64>| {
                    let px = r.rgb.get_pixel(p.x as u32, p.y as u32);
                    luma([
                        px[0] as f32 / 255.0,
                        px[1] as f32 / 255.0,
                        px[2] as f32 / 255.0,
                    ])
                };
                seen += 1;
                if (g(&p1) - g(&p2)).abs() >= 0.02 {
                    stepped += 1;
                }
            }
        }
    }
    assert!(seen > 100, "only {seen} visible edge points");
    assert!(
        stepped as f64 >= 0.8 * seen as f64,
        "{stepped} of {seen} edge points show a step"
    );
}

#[test]
fn trajectories_keep_clearance_and_move_smoothly() {
    let ds = tiny();
    let plans = plan_sequences(300, false).unwrap();
    let frames = plan_frames(&ds.scene, &plans, SEED).unwrap();
    assert_eq!(frames.len(), 300);
    for f in &frames {
        let c = f.pose.centre();
        assert!(ds.scene.clearance(&c) >= CLEARANCE_M - 1e-9, "{c:?}");
        assert!(c.z >= HEIGHT_RANGE_M.0 && c.z <= HEIGHT_RANGE_M.1);
        // Looking roughly horizontally: optical axis within 35 deg of the horizon.
        let axis = f.pose.rotation.inverse() * Vector3::z();
        assert!(axis.z.abs() < 35f64.to_radians().sin(), "{axis:?}");
    }
    for w in frames.windows(2) {
        if w[0].sequence != w[1].sequence {
            continue;
        }
        let step = (w[0].pose.centre() - w[1].pose.centre()).norm();
        let turn = w[0]
            .pose
            .rotation
            .angle_to(&w[1].pose.rotation)
            .to_degrees();
        assert!(step > 0.005 && step < 0.08, "step {step} m");
        assert!(turn < 6.0, "turn {turn} deg");
    }
    // Test sequences run on other paths (they may cross a training path, but most of
    // their frames are away from it) and look at what training frames saw.
    let train: Vec<&_> = frames.iter().filter(|f| f.split == Split::Train).collect();
    let test_seqs: std::collections::BTreeSet<u32> = frames
        .iter()
        .filter(|f| f.split == Split::Test)
        .map(|f| f.sequence)
        .collect();
    for s in test_seqs {
        let mut nearest: Vec<f64> = Vec::new();
        for t in frames.iter().filter(|f| f.sequence == s) {
            let ct = t.pose.centre();
            nearest.push(
                train
                    .iter()
                    .map(|f| (f.pose.centre() - ct).norm())
                    .fold(f64::INFINITY, f64::min),
            );
            let at = t.pose.rotation.inverse() * Vector3::z();
            let similar = train.iter().any(|f| {
                let af = f.pose.rotation.inverse() * Vector3::z();
                at.dot(&af) > 30f64.to_radians().cos() && (f.pose.centre() - ct).norm() < 1.0
            });
            assert!(
                similar,
                "test frame {} of sequence {s} sees nothing a training frame saw",
                t.index
            );
        }
        nearest.sort_by(f64::total_cmp);
        let median = nearest[nearest.len() / 2];
        assert!(
            median > 0.1,
            "test sequence {s} follows a training path (median {median} m)"
        );
    }
}

fn quiet(out: &Path) -> WriteOptions {
    WriteOptions {
        progress: false,
        ..WriteOptions::new(out)
    }
}

fn generate_in_pool(threads: usize, out: &Path, layout: Layout) -> synth::SynthOutput {
    testkit::on_threads(threads, || {
        generate(
            &SynthConfig {
                seed: SEED,
                tiny: true,
                layout,
                ground_truth: false,
                ..SynthConfig::default()
            },
            &quiet(out),
        )
        .unwrap()
    })
}

#[test]
fn seven_scenes_layout_is_byte_identical_for_any_thread_count() {
    let (d1, d2) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
    let o1 = generate_in_pool(1, d1.path(), Layout::SevenScenes);
    let o2 = generate_in_pool(2, d2.path(), Layout::SevenScenes);
    let f1 = files(&o1.root);
    assert_eq!(f1, files(&o2.root));
    assert_eq!(f1.len(), 2 + 32 * 3);
    for f in &f1 {
        assert_eq!(
            std::fs::read(o1.root.join(f)).unwrap(),
            std::fs::read(o2.root.join(f)).unwrap(),
            "{f:?} differs"
        );
    }
    // Nothing but the scene folder is left in the output folder.
    assert_eq!(std::fs::read_dir(d1.path()).unwrap().count(), 1);
    assert_eq!(
        std::fs::read_to_string(o1.root.join("TrainSplit.txt")).unwrap(),
        "sequence1\r\nsequence2\r\nsequence4\r\nsequence5\r\n"
    );
    assert_eq!(
        std::fs::read_to_string(o1.root.join("TestSplit.txt")).unwrap(),
        "sequence3\r\nsequence6\r\n"
    );
    // The files decode to what the renderer produced, and the frame list matches them.
    let info = &o1.frames[3];
    assert_eq!(
        info.name,
        seven_scenes_names(info.sequence, info.frame_in_sequence).0
    );
    let rgb = image::open(&info.color_path).unwrap();
    assert_eq!(rgb.color(), image::ColorType::Rgb8);
    let depth = image::open(info.depth_path.as_ref().unwrap()).unwrap();
    assert_eq!(depth.color(), image::ColorType::L16);
    let r = o1.dataset.render_frame(info.index).unwrap();
    assert_eq!(rgb.to_rgb8().as_raw(), r.rgb.as_raw());
    assert_eq!(depth.to_luma16().as_raw(), r.depth_mm().as_raw());
    // Written again into the same place: refused, then replaced with overwrite.
    let again = generate(
        &SynthConfig {
            seed: SEED,
            tiny: true,
            ground_truth: false,
            ..SynthConfig::default()
        },
        &quiet(d1.path()),
    );
    assert!(matches!(again, Err(SynthError::OutputExists(_))));
}

/// Parses a 7-Scenes pose.txt (16 numbers).
fn parse_pose_txt(s: &str) -> Matrix4<f64> {
    let v: Vec<f64> = s.split_whitespace().map(|t| t.parse().unwrap()).collect();
    assert_eq!(v.len(), 16);
    Matrix4::from_row_slice(&v)
}

#[test]
fn pose_txt_round_trip() {
    let ds = tiny();
    for f in &ds.frames {
        let txt = format_pose_txt(&f.pose.inverse().to_matrix());
        let back = Pose::from_cam_to_world(&parse_pose_txt(&txt), 1e-6).unwrap();
        assert!(back.rotation.angle_to(&f.pose.rotation) < 1e-6);
        assert!((back.centre() - f.pose.centre()).norm() < 1e-6);
    }
}

#[test]
fn pose_txt_format_matches_real_7scenes_files() {
    let Some(dir) = testkit::sample::sample_data("7scenes-stairs-mini/stairs") else {
        return;
    };
    let mut n = 0;
    for seq in ["seq-01", "seq-02", "seq-03", "seq-04"] {
        let Ok(entries) = std::fs::read_dir(dir.join(seq)) else {
            continue;
        };
        for e in entries {
            let p = e.unwrap().path();
            if !p.to_string_lossy().ends_with(".pose.txt") {
                continue;
            }
            let original = std::fs::read_to_string(&p).unwrap();
            // Re-printing the parsed values reproduces the Microsoft files byte for byte.
            assert_eq!(
                format_pose_txt(&parse_pose_txt(&original)),
                original,
                "{p:?}"
            );
            n += 1;
        }
    }
    if n == 0 {
        testkit::skip(format_args!("no pose files under {dir:?}"));
    }
    // The split files use CRLF line ends like ours.
    if let Ok(s) = std::fs::read_to_string(dir.join("TrainSplit.txt")) {
        assert!(s.ends_with("\r\n") && s.starts_with("sequence"));
    }
}

#[test]
fn cambridge_layout_reads_back() {
    let d = tempfile::tempdir().unwrap();
    let out = generate_in_pool(2, d.path(), Layout::Cambridge);
    let train = std::fs::read_to_string(out.root.join("dataset_train.txt")).unwrap();
    let mut lines = train.lines();
    assert_eq!(lines.next(), Some("Visual Landmark Dataset V1"));
    assert_eq!(
        lines.next(),
        Some("ImageFile, Camera Position [X Y Z W P Q R]")
    );
    assert_eq!(lines.next(), Some(""));
    let rows: Vec<&str> = lines.collect();
    assert_eq!(rows.len(), 24);
    for row in rows {
        let t: Vec<&str> = row.split(' ').collect();
        let v: Vec<f64> = t[1..].iter().map(|x| x.parse().unwrap()).collect();
        let pose = Pose::from_centre_qvec([v[0], v[1], v[2]], [v[3], v[4], v[5], v[6]]).unwrap();
        let f = out
            .frames
            .iter()
            .find(|f| f.name == t[0])
            .expect("row names a written frame");
        assert!(out.root.join(t[0]).exists());
        assert!(pose.rotation.angle_to(&f.pose.rotation) < 1e-5);
        assert!((pose.centre() - f.pose.centre()).norm() < 1e-5);
        // w-first world-to-camera: the camera's optical axis in world coordinates.
        assert!(
            (pose.rotation.inverse() * Vector3::z() - f.pose.rotation.inverse() * Vector3::z())
                .norm()
                < 1e-5
        );
    }
    let test = std::fs::read_to_string(out.root.join("dataset_test.txt")).unwrap();
    assert_eq!(test.lines().count(), 3 + 8);
    let nvm = std::fs::read_to_string(out.root.join("reconstruction.nvm")).unwrap();
    let mut l = nvm.lines();
    assert_eq!(l.next(), Some("NVM_V3"));
    assert_eq!(l.next(), Some(""));
    assert_eq!(l.next(), Some("32"));
    for _ in 0..32 {
        let t: Vec<&str> = l.next().unwrap().split(' ').collect();
        assert_eq!(t.len(), 11);
        assert!(t[0].ends_with(".jpg"));
        assert!(out.root.join(t[0].replace(".jpg", ".png")).exists());
        assert_eq!(t[1], "525");
        assert_eq!(&t[9..], ["0", "0"]);
        let v: Vec<f64> = t[2..9].iter().map(|x| x.parse().unwrap()).collect();
        let pose = Pose::from_centre_qvec([v[4], v[5], v[6]], [v[0], v[1], v[2], v[3]]).unwrap();
        let f = out
            .frames
            .iter()
            .find(|f| f.name == t[0].replace(".jpg", ".png"))
            .unwrap();
        assert!(pose.rotation.angle_to(&f.pose.rotation) < 1e-12);
    }
    assert_eq!(l.next(), Some(""));
    assert_eq!(l.next(), Some("0"));
    assert_eq!(l.next(), None);
}

#[test]
fn render_rejects_what_it_cannot_draw() {
    let scene = &tiny().scene;
    let pose = tiny().frames[0].pose;
    let radial = Camera::new(
        CameraModel::SimpleRadial,
        64,
        48,
        vec![50.0, 32.0, 24.0, 0.1],
    )
    .unwrap();
    assert!(matches!(
        scene.render(&radial, &pose),
        Err(SynthError::UnsupportedCamera(_))
    ));
    // Built field by field: `Camera::new` refuses a size of 0 itself.
    let empty = Camera {
        model: CameraModel::Pinhole,
        width: 0,
        height: 48,
        params: vec![50.0, 50.0, 32.0, 24.0],
    };
    assert!(matches!(
        scene.render(&empty, &pose),
        Err(SynthError::InvalidCameraSize { .. })
    ));
    let mut bad = pose;
    bad.translation.x = f64::NAN;
    let cam = Camera::new(CameraModel::Pinhole, 64, 48, vec![50.0, 50.0, 32.0, 24.0]).unwrap();
    assert!(matches!(
        scene.render(&cam, &bad),
        Err(SynthError::NonFinitePose)
    ));
    assert!(matches!(
        tiny().render_frame(10_000),
        Err(SynthError::FrameIndex { .. })
    ));
    assert!(matches!(
        SynthDataset::new(3, 0, false),
        Err(SynthError::InvalidConfig(_))
    ));
}

#[test]
fn antialiasing_blends_only_at_edges() {
    // A pixel whose samples all hit one quad gets that quad's colour alone; pixels on a
    // silhouette mix. Check that mixed pixels exist and are a small minority.
    let ds = tiny();
    let f = &ds.frames[20];
    let mut mixed = 0usize;
    for j in 0..480u32 {
        for i in 0..640u32 {
            let ids: std::collections::BTreeSet<u32> = SAMPLES
                .iter()
                .map(|&(sx, sy)| {
                    let p = &ds.camera.params;
                    let d = Vector3::new(
                        (i as f64 + sx - p[2]) / p[0],
                        (j as f64 + sy - p[3]) / p[1],
                        1.0,
                    );
                    ds.scene
                        .raycast(&f.pose.centre(), &(f.pose.rotation.inverse() * d))
                        .map_or(u32::MAX, |h| h.quad_id)
                })
                .collect();
            mixed += (ids.len() > 1) as usize;
        }
    }
    let frac = mixed as f64 / (640.0 * 480.0);
    assert!(frac > 0.001 && frac < 0.1, "{frac}");
}

#[test]
fn renders_have_sift_friendly_texture() {
    // Proxy for SIFT: extrema of a difference of Gaussians (sigma 1.6 vs 2.26) above a
    // contrast threshold, per frame; and no repeated patches (non-periodic texture).
    let ds = tiny();
    for fi in [0usize, 8, 17, 30] {
        let r = ds.render_frame(fi).unwrap();
        let g: Vec<f32> = r
            .rgb
            .pixels()
            .map(|p| {
                luma([
                    p[0] as f32 / 255.0,
                    p[1] as f32 / 255.0,
                    p[2] as f32 / 255.0,
                ])
            })
            .collect();
        let (w, h) = (640usize, 480usize);
        let b1 = blur(&g, w, h, 1.6);
        let b2 = blur(&g, w, h, 2.26);
        let dog: Vec<f32> = b1.iter().zip(&b2).map(|(a, b)| a - b).collect();
        let mut n = 0;
        for y in 4..h - 4 {
            for x in 4..w - 4 {
                let v = dog[y * w + x];
                if v.abs() < 0.01 {
                    continue;
                }
                let mut ext = true;
                for dy in -1i32..=1 {
                    for dx in -1i32..=1 {
                        if (dx, dy) != (0, 0) {
                            let u = dog[(y as i32 + dy) as usize * w + (x as i32 + dx) as usize];
                            ext &= if v > 0.0 { v > u } else { v < u };
                        }
                    }
                }
                n += ext as usize;
            }
        }
        assert!(n > 800, "frame {fi}: only {n} DoG extrema");
    }
}

#[test]
fn wall_textures_are_not_periodic() {
    // High-passed luma of a 384 x 384 texel crop of every wall: its normalised
    // autocorrelation at every shift beyond 12 texels stays low (no repeated pattern).
    let scene = &tiny().scene;
    for wall in 0..4u32 {
        let tex = scene.texture(wall).unwrap();
        let n = 384usize;
        let g: Vec<f32> = (0..n * n)
            .map(|k| luma(tex.texel(200 + k % n, 100 + k / n)))
            .collect();
        let box_blur = blur(&g, n, n, 3.0);
        let h: Vec<f32> = g.iter().zip(&box_blur).map(|(a, b)| a - b).collect();
        let m = 128usize;
        let energy: f32 = (0..m * m).map(|k| h[(k / m) * n + k % m].powi(2)).sum();
        let mut worst = 0f32;
        for dy in (0..=n - m).step_by(8) {
            for dx in (0..=n - m).step_by(8) {
                if dx * dx + dy * dy < 144 {
                    continue;
                }
                let c: f32 = (0..m * m)
                    .map(|k| h[(k / m) * n + k % m] * h[(k / m + dy) * n + k % m + dx])
                    .sum();
                let e2: f32 = (0..m * m)
                    .map(|k| h[(k / m + dy) * n + k % m + dx].powi(2))
                    .sum();
                worst = worst.max(c / (energy * e2).sqrt());
            }
        }
        assert!(
            worst < 0.25,
            "wall {wall}: autocorrelation {worst} at some shift"
        );
    }
}

fn blur(src: &[f32], w: usize, h: usize, sigma: f32) -> Vec<f32> {
    let r = (3.0 * sigma).ceil() as i32;
    let k: Vec<f32> = (-r..=r)
        .map(|i| (-(i * i) as f32 / (2.0 * sigma * sigma)).exp())
        .collect();
    let s: f32 = k.iter().sum();
    let k: Vec<f32> = k.iter().map(|v| v / s).collect();
    let mut tmp = vec![0f32; w * h];
    for y in 0..h {
        for x in 0..w {
            let mut a = 0.0;
            for (i, kv) in k.iter().enumerate() {
                let xx = (x as i32 + i as i32 - r).clamp(0, w as i32 - 1) as usize;
                a += kv * src[y * w + xx];
            }
            tmp[y * w + x] = a;
        }
    }
    let mut out = vec![0f32; w * h];
    for y in 0..h {
        for x in 0..w {
            let mut a = 0.0;
            for (i, kv) in k.iter().enumerate() {
                let yy = (y as i32 + i as i32 - r).clamp(0, h as i32 - 1) as usize;
                a += kv * tmp[yy * w + x];
            }
            out[y * w + x] = a;
        }
    }
    out
}

#[test]
fn scene_is_deterministic_per_seed() {
    // Built on one thread and on the default pool: same quads, edges and textures (the
    // textures are compared through a render, which reads every visible texel).
    let a = testkit::on_threads(2, || Scene::generate(3));
    let b = testkit::on_threads(1, || Scene::generate(3));
    assert_eq!(a.quads(), b.quads());
    assert_eq!(a.edges(), b.edges());
    let ds = tiny();
    for fi in [1usize, 12, 25] {
        let pose = &ds.frames[fi].pose;
        let (ra, rb) = (
            a.render(&ds.camera, pose).unwrap(),
            b.render(&ds.camera, pose).unwrap(),
        );
        assert_eq!(ra.rgb.as_raw(), rb.rgb.as_raw());
        assert_eq!(ra.depth_m, rb.depth_m);
    }
    let c = Scene::generate(4);
    assert_ne!(a.edges(), c.edges());
}
