//! Hand-held-like camera paths through the room, 7-Scenes style: several sequences, each
//! a smooth stretch of an elliptic loop around the room centre, looking outwards at the
//! walls and furniture with slow yaw sweeps and mild pitch and roll. Test sequences run on
//! other loops (other radii, heights, direction) through the same viewing directions as
//! a training sequence, so they see the same room from different positions.

use super::elements::ROOM;
use super::error::{Result, SynthError};
use super::scene::Scene;
use geometry::{Camera, CameraModel, Pose};
use nalgebra::{Matrix3, Rotation3, UnitQuaternion, Vector3};
use rand::Rng;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};
use std::f64::consts::TAU;

/// Minimum distance of every camera centre from walls, floor, ceiling and objects.
pub const CLEARANCE_M: f64 = 0.6;
/// Camera heights are kept in this range.
pub const HEIGHT_RANGE_M: (f64, f64) = (1.0, 1.9);
/// Target distance between consecutive frames along a path.
pub const STEP_M: f64 = 0.04;

/// Largest advance along a loop per frame (radians): the heading follows the loop angle.
const MAX_DPHI: f64 = 0.06;

/// Default frame count: 200 training + 100 test.
pub const DEFAULT_FRAMES: usize = 300;
const TRAIN_SEQS: usize = 4;
const TEST_SEQS: usize = 2;
/// Frames per sequence of the tiny scene (24 training + 8 test).
const TINY_TRAIN: usize = 6;
const TINY_TEST: usize = 4;

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Split {
    Train,
    Test,
}

/// One sequence of the dataset: its 1-based number (`seq-0N`, `seqN`), split and length.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct SequencePlan {
    pub number: u32,
    pub split: Split,
    pub frames: usize,
}

/// One frame: where it belongs and the world-to-camera pose.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct FrameSpec {
    pub split: Split,
    /// 1-based sequence number.
    pub sequence: u32,
    /// 0-based index inside the sequence.
    pub index: usize,
    pub pose: Pose,
}

/// The 7-Scenes-like RGB camera: PINHOLE 640 x 480, f = 525, principal point at the centre.
pub fn default_camera() -> Camera {
    Camera::new(
        CameraModel::Pinhole,
        640,
        480,
        vec![525.0, 525.0, 320.0, 240.0],
    )
    .expect("4 finite parameters")
}

/// Splits `total` frames into 4 training and 2 test sequences (2/3 training), or the
/// fixed tiny plan (4 x 6 training + 2 x 4 test). Sequences are numbered so that training
/// and test interleave as in 7-Scenes: 1, 2 train, 3 test, 4, 5 train, 6 test.
pub fn plan_sequences(total: usize, tiny: bool) -> Result<Vec<SequencePlan>> {
    let (train, test) = if tiny {
        (vec![TINY_TRAIN; TRAIN_SEQS], vec![TINY_TEST; TEST_SEQS])
    } else {
        if total < 2 * (TRAIN_SEQS + TEST_SEQS) {
            return Err(SynthError::InvalidConfig(format!(
                "--frames {total}: need at least {} frames (2 per sequence)",
                2 * (TRAIN_SEQS + TEST_SEQS)
            )));
        }
        if total > 200_000 {
            return Err(SynthError::InvalidConfig(format!(
                "--frames {total}: at most 200000"
            )));
        }
        let n_train = ((total as f64) * 2.0 / 3.0).round() as usize;
        let n_test = total - n_train;
        let spread = |n: usize, k: usize| {
            (0..k)
                .map(|i| n / k + usize::from(i < n % k))
                .collect::<Vec<_>>()
        };
        (spread(n_train, TRAIN_SEQS), spread(n_test, TEST_SEQS))
    };
    let order = [
        (Split::Train, 0),
        (Split::Train, 1),
        (Split::Test, 0),
        (Split::Train, 2),
        (Split::Train, 3),
        (Split::Test, 1),
    ];
    Ok(order
        .iter()
        .enumerate()
        .map(|(k, &(split, i))| SequencePlan {
            number: k as u32 + 1,
            split,
            frames: if split == Split::Train {
                train[i]
            } else {
                test[i]
            },
        })
        .collect())
}

/// Parameters of one sequence's path.
#[derive(Clone, Copy, Debug)]
struct Loop {
    centre: [f64; 2],
    radii: [f64; 2],
    phase0: f64,
    dir: f64,
    dphi: f64,
    height: f64,
    height_amp: f64,
    height_period: f64,
    height_phase: f64,
    yaw_bias: f64,
    yaw_amp: f64,
    yaw_period: f64,
    yaw_phase: f64,
    pitch: f64,
    pitch_amp: f64,
    roll_amp: f64,
    wobble: f64,
    wobble_phase: f64,
}

impl Loop {
    fn random(rng: &mut ChaCha8Rng, radii: [f64; 2], n: usize) -> Loop {
        let mean_r = 0.5 * (radii[0] + radii[1]);
        // A few centimetres per frame; long sequences sample the loop more densely
        // instead of going round it again.
        let dphi = (STEP_M / mean_r).min(MAX_DPHI).min(5.2 / n.max(1) as f64);
        Loop {
            centre: [
                ROOM[0] * 0.5 + rng.random_range(-0.1..0.1),
                ROOM[1] * 0.5 + rng.random_range(-0.08..0.08),
            ],
            radii,
            phase0: 0.0,
            dir: 1.0,
            dphi,
            height: rng.random_range(1.25..1.65),
            height_amp: rng.random_range(0.05..0.2),
            height_period: rng.random_range(30.0..60.0),
            height_phase: rng.random_range(0.0..TAU),
            yaw_bias: rng.random_range(-0.25..0.25),
            yaw_amp: rng.random_range(0.1..0.2),
            yaw_period: rng.random_range(45.0..70.0),
            yaw_phase: rng.random_range(0.0..TAU),
            pitch: rng.random_range(-0.35..-0.1),
            pitch_amp: rng.random_range(0.03..0.1),
            roll_amp: rng.random_range(0.01..0.06),
            wobble: rng.random_range(0.01..0.03),
            wobble_phase: rng.random_range(0.0..TAU),
        }
    }

    fn phase(&self, k: usize) -> f64 {
        self.phase0 + self.dir * self.dphi * k as f64
    }

    /// Camera centre and camera-to-world rotation of frame `k`.
    fn frame(&self, k: usize, shrink: f64) -> (Vector3<f64>, Matrix3<f64>) {
        let kf = k as f64;
        let phi = self.phase(k);
        let rx = self.radii[0] * shrink;
        let ry = self.radii[1] * shrink;
        let wob = self.wobble * (kf * TAU / 17.0 + self.wobble_phase).sin();
        let x = self.centre[0] + rx * phi.cos() + wob;
        let y = self.centre[1] + ry * phi.sin() + wob * 0.7;
        let z = (self.height
            + self.height_amp * (kf * TAU / self.height_period + self.height_phase).sin())
        .clamp(HEIGHT_RANGE_M.0, HEIGHT_RANGE_M.1);
        // Heading follows the loop angle (outwards for a circle, close to it on the ellipse).
        let yaw = phi
            + self.yaw_bias
            + self.yaw_amp * (kf * TAU / self.yaw_period + self.yaw_phase).sin();
        let pitch = self.pitch + self.pitch_amp * (kf * TAU / 47.0 + self.yaw_phase * 0.5).sin();
        let roll = self.roll_amp * (kf * TAU / 29.0 + self.height_phase).sin();
        (Vector3::new(x, y, z), look_rotation(yaw, pitch, roll))
    }
}

/// Camera-to-world rotation (columns: camera x right, y down, z forward in world
/// coordinates) for a heading `yaw` about world z, `pitch` up from the horizon and `roll`.
pub fn look_rotation(yaw: f64, pitch: f64, roll: f64) -> Matrix3<f64> {
    let f = Vector3::new(
        yaw.cos() * pitch.cos(),
        yaw.sin() * pitch.cos(),
        pitch.sin(),
    );
    let right0 = f.cross(&Vector3::z()).normalize();
    let down0 = f.cross(&right0);
    let (s, c) = roll.sin_cos();
    let right = right0 * c + down0 * s;
    let down = down0 * c - right0 * s;
    Matrix3::from_columns(&[right, down, f])
}

/// World-to-camera pose of a camera at `centre` with camera-to-world rotation `r_cw`.
pub fn pose_from_centre(centre: &Vector3<f64>, r_cw: &Matrix3<f64>) -> Pose {
    let r = Rotation3::from_matrix_unchecked(r_cw.transpose());
    let q = UnitQuaternion::from_rotation_matrix(&r);
    Pose::new(q, -(q * centre))
}

/// The frames of all sequences, in sequence order. Paths that would come closer than
/// [`CLEARANCE_M`] to anything are shrunk towards the room centre.
pub fn plan_frames(scene: &Scene, plans: &[SequencePlan], seed: u64) -> Result<Vec<FrameSpec>> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x7A11_C0DE_5EED_0001);
    // Training loops alternate between a wide and a narrow ellipse; test loops lie between.
    let train_radii = [[0.78, 0.45], [0.52, 0.3], [0.7, 0.4], [0.45, 0.26]];
    let test_radii = [[0.64, 0.37], [0.6, 0.34]];
    let mut loops: Vec<(SequencePlan, Loop)> = Vec::new();
    let train: Vec<&SequencePlan> = plans.iter().filter(|p| p.split == Split::Train).collect();
    let n_train = train.len().max(1);
    for (i, p) in train.iter().enumerate() {
        let mut l = Loop::random(&mut rng, train_radii[i % train_radii.len()], p.frames);
        l.dir = if i % 2 == 0 { 1.0 } else { -1.0 };
        // Middle of the arc at evenly spread headings.
        let mid = i as f64 * TAU / n_train as f64 + rng.random_range(-0.2..0.2);
        l.phase0 = mid - l.dir * l.dphi * (p.frames.saturating_sub(1)) as f64 * 0.5;
        loops.push((**p, l));
    }
    let test: Vec<&SequencePlan> = plans.iter().filter(|p| p.split == Split::Test).collect();
    let n_test = test.len().max(1);
    for (j, p) in test.iter().enumerate() {
        // Aligned with the middle of a training arc, run the other way, at another height.
        let m = j * n_train / n_test;
        let (tp, tl) = loops[m];
        let mid = tl.phase(tp.frames.saturating_sub(1)) * 0.5 + tl.phase(0) * 0.5;
        let mut l = Loop::random(&mut rng, test_radii[j % test_radii.len()], p.frames);
        l.dir = -tl.dir;
        l.height = if tl.height > 1.45 {
            tl.height - 0.2
        } else {
            tl.height + 0.2
        };
        l.phase0 = mid - l.dir * l.dphi * (p.frames.saturating_sub(1)) as f64 * 0.5;
        loops.push((**p, l));
    }
    loops.sort_by_key(|(p, _)| p.number);

    let mut frames = Vec::new();
    for (p, l) in &loops {
        let mut shrink = 1.0;
        let mut best = f64::NEG_INFINITY;
        let mut ok = false;
        for _ in 0..25 {
            let worst = (0..p.frames)
                .map(|k| scene.clearance(&l.frame(k, shrink).0))
                .fold(f64::INFINITY, f64::min);
            best = best.max(worst);
            if worst >= CLEARANCE_M {
                ok = true;
                break;
            }
            shrink *= 0.9;
        }
        if !ok {
            return Err(SynthError::Trajectory {
                sequence: p.number,
                clearance_m: CLEARANCE_M,
                best_m: best,
            });
        }
        for k in 0..p.frames {
            let (c, r) = l.frame(k, shrink);
            frames.push(FrameSpec {
                split: p.split,
                sequence: p.number,
                index: k,
                pose: pose_from_centre(&c, &r),
            });
        }
    }
    Ok(frames)
}

/// Angle in radians between two rotations (for step-size checks).
pub fn rotation_angle(a: &Pose, b: &Pose) -> f64 {
    a.rotation.angle_to(&b.rotation)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn look_rotation_axes() {
        // Looking along +x, level: right is -y, down is -z.
        let r = look_rotation(0.0, 0.0, 0.0);
        assert!((r.column(0) - Vector3::new(0.0, -1.0, 0.0)).norm() < 1e-12);
        assert!((r.column(1) - Vector3::new(0.0, 0.0, -1.0)).norm() < 1e-12);
        assert!((r.column(2) - Vector3::new(1.0, 0.0, 0.0)).norm() < 1e-12);
        assert!((r.determinant() - 1.0).abs() < 1e-12);
        // A point straight ahead projects to the principal point.
        let c = Vector3::new(1.0, 1.0, 1.5);
        let pose = pose_from_centre(&c, &look_rotation(0.3, -0.1, 0.05));
        let ahead = c + look_rotation(0.3, -0.1, 0.05).column(2) * 2.0;
        let pc = pose.transform_point(&ahead);
        assert!(pc.x.abs() < 1e-12 && pc.y.abs() < 1e-12 && (pc.z - 2.0).abs() < 1e-12);
        assert!((pose.centre() - c).norm() < 1e-12);
    }

    #[test]
    fn plans() {
        let p = plan_sequences(DEFAULT_FRAMES, false).unwrap();
        let train: usize = p
            .iter()
            .filter(|s| s.split == Split::Train)
            .map(|s| s.frames)
            .sum();
        let test: usize = p
            .iter()
            .filter(|s| s.split == Split::Test)
            .map(|s| s.frames)
            .sum();
        assert_eq!((train, test), (200, 100));
        let t = plan_sequences(0, true).unwrap();
        let train: usize = t
            .iter()
            .filter(|s| s.split == Split::Train)
            .map(|s| s.frames)
            .sum();
        let test: usize = t
            .iter()
            .filter(|s| s.split == Split::Test)
            .map(|s| s.frames)
            .sum();
        assert_eq!((train, test), (24, 8));
        let odd = plan_sequences(61, false).unwrap();
        assert_eq!(odd.iter().map(|s| s.frames).sum::<usize>(), 61);
        assert!(plan_sequences(5, false).is_err());
    }
}
