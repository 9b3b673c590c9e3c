//! Small datasets written in the 7-Scenes and Cambridge Landmarks layouts (for the
//! datasets crate's ingest tests), with the pose text formats those datasets use.

use crate::images::{write_depth, write_rgb};
use geometry::{Matrix4, Pose, UnitQuaternion, Vector3};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// A 4x4 matrix as 7-Scenes writes pose.txt: 7 significant digits, tab separated, CRLF.
pub fn pose_txt(m: &Matrix4<f64>) -> String {
    let mut s = String::new();
    for r in 0..4 {
        for c in 0..4 {
            let _ = write!(s, " {:15.7e}\t", m[(r, c)]);
        }
        s.push_str("\r\n");
    }
    s
}

/// A world-to-camera pose for frame `k`: a few degrees apart, a few cm apart.
pub fn fixture_pose(k: usize) -> Pose {
    let a = k as f64;
    Pose::new(
        UnitQuaternion::from_euler_angles(0.1 + 0.05 * a, -0.2, 0.3 * a),
        Vector3::new(0.5 - 0.1 * a, 0.2, 1.0 + 0.03 * a),
    )
}

/// A 7-Scenes scene: TrainSplit `sequence1`, TestSplit `sequence2`; seq-01 has frames 0
/// and 1 (.color.png), seq-02 frame 0 (.color.jpg); images `w` x `h`, depth 640x480
/// (the Kinect depth camera's size) at 1.5 m with a hole. Returns the scene folder.
pub fn seven_scenes(root: &Path, w: u32, h: u32) -> PathBuf {
    let scene = root.join("scene");
    std::fs::create_dir_all(&scene).unwrap();
    std::fs::write(scene.join("TrainSplit.txt"), "sequence1\r\n").unwrap();
    std::fs::write(scene.join("TestSplit.txt"), "sequence2\r\n\r\n").unwrap();
    let frames = [
        ("seq-01", 0, "png"),
        ("seq-01", 1, "png"),
        ("seq-02", 0, "jpg"),
    ];
    for (k, (seq, i, ext)) in frames.iter().enumerate() {
        let stem = scene.join(seq).join(format!("frame-{i:06}"));
        let colour = PathBuf::from(format!("{}.color.{ext}", stem.display()));
        write_rgb(&colour, w, h, k as u32);
        let c2w = fixture_pose(k).inverse().to_matrix();
        std::fs::write(format!("{}.pose.txt", stem.display()), pose_txt(&c2w)).unwrap();
        write_depth(
            Path::new(&format!("{}.depth.png", stem.display())),
            640,
            480,
            |x, y| {
                if x < 10 && y < 10 {
                    65535
                } else {
                    1500 + (x % 3) as u16
                }
            },
        );
    }
    scene
}

pub const CAMBRIDGE_HEADER: &str =
    "Visual Landmark Dataset V1\nImageFile, Camera Position [X Y Z W P Q R]\n\n";

/// A Cambridge row `name X Y Z W P Q R` for a world-to-camera pose (centre + quaternion).
pub fn cambridge_row(name: &str, pose: &Pose) -> String {
    let c = pose.centre();
    let q = pose.qvec();
    format!(
        "{name} {} {} {} {} {} {} {}\n",
        c.x, c.y, c.z, q[0], q[1], q[2], q[3]
    )
}

/// An NVM camera line `name f qw qx qy qz Cx Cy Cz k 0`.
pub fn nvm_camera(name: &str, f: f64, pose: &Pose) -> String {
    let c = pose.centre();
    let q = pose.qvec();
    format!(
        "{name} {f} {} {} {} {} {} {} {} 0 0\n",
        q[0], q[1], q[2], q[3], c.x, c.y, c.z
    )
}

/// A Cambridge scene: train seq1/frame00001.png, seq1/frame00002.png; test
/// seq2/frame00001.png (a portrait image) and seq2/frame00002.png, an outlier pose with
/// no image; an NVM naming every image `.jpg`, with a point block.
pub fn cambridge(root: &Path) -> PathBuf {
    let scene = root.join("ShopFacade");
    let frames = [
        ("seq1/frame00001", 32, 24, 1670.0),
        ("seq1/frame00002", 32, 24, 1671.5),
        ("seq2/frame00001", 24, 32, 1400.25),
    ];
    let mut train = CAMBRIDGE_HEADER.to_string();
    let mut test = CAMBRIDGE_HEADER.to_string();
    let mut nvm = format!("NVM_V3\n\n{}\n", frames.len() + 1);
    for (k, (stem, w, h, f)) in frames.iter().enumerate() {
        write_rgb(&scene.join(format!("{stem}.png")), *w, *h, k as u32);
        let pose = fixture_pose(k);
        let row = cambridge_row(&format!("{stem}.png"), &pose);
        if k < 2 {
            train.push_str(&row);
        } else {
            test.push_str(&row);
        }
        nvm.push_str(&nvm_camera(&format!("{stem}.jpg"), *f, &pose));
    }
    let outlier = Pose::new(UnitQuaternion::identity(), Vector3::new(0.0, 2e4, 0.0));
    test.push_str(&cambridge_row("seq2/frame00002.png", &outlier));
    nvm.push_str(&nvm_camera("seq2/frame00002.jpg", 1500.0, &outlier));
    nvm.push_str("\n1\n0.5 0.25 3 255 0 0 1 0 0 1.5 -2.5\n\n0\n");
    std::fs::write(scene.join("dataset_train.txt"), train).unwrap();
    std::fs::write(scene.join("dataset_test.txt"), test).unwrap();
    std::fs::write(scene.join("reconstruction.nvm"), nvm).unwrap();
    scene
}
