//! One training sample (one image) on the host, its validation, and its tensors.

use crate::config::ModelConfig;
use crate::error::ModelError;
use crate::init::tensor_from;
use crate::network::NetworkInput;
use burn::tensor::{Int, Tensor, TensorData, backend::Backend};
use serde::{Deserialize, Serialize};

/// Pinhole intrinsics in pixels, with the pixel convention of the keypoints
/// (COLMAP: the centre of the top-left pixel is (0.5, 0.5)).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Pinhole {
    pub fx: f64,
    pub fy: f64,
    pub cx: f64,
    pub cy: f64,
}

/// Tolerance on `max |R^T R - I|` of the sample's rotation.
pub const ROTATION_TOLERANCE: f64 = 1e-3;

/// Everything the network and the losses need about one image.
#[derive(Clone, Debug, PartialEq)]
pub struct Sample {
    /// N x D descriptors, row-major.
    pub point_descriptors: Vec<f32>,
    /// M x T x D descriptors, row-major (line, token, channel).
    pub line_descriptors: Vec<f32>,
    /// N keypoints in pixels.
    pub keypoints: Vec<[f32; 2]>,
    /// M segments (x1, y1, x2, y2) in pixels; the 3D label's first endpoint belongs to (x1, y1).
    pub segments: Vec<[f32; 4]>,
    /// N point labels (world xyz), meaningful where `point_valid`.
    pub point_labels: Vec<[f32; 3]>,
    pub point_valid: Vec<bool>,
    /// M line labels (start xyz, end xyz), meaningful where `line_valid`.
    pub line_labels: Vec<[f32; 6]>,
    pub line_valid: Vec<bool>,
    /// Ground-truth world-to-camera pose: X_cam = R X_world + t; R row-major.
    pub rotation: [[f64; 3]; 3],
    pub translation: [f64; 3],
    pub camera: Pinhole,
}

fn check_len(field: &'static str, expected: usize, found: usize) -> Result<(), ModelError> {
    if expected == found {
        Ok(())
    } else {
        Err(ModelError::Length {
            field,
            expected,
            found,
        })
    }
}

fn check_finite<'a>(
    field: &'static str,
    width: usize,
    values: impl IntoIterator<Item = &'a f32>,
) -> Result<(), ModelError> {
    match values.into_iter().position(|v| !v.is_finite()) {
        None => Ok(()),
        Some(i) => Err(ModelError::NonFinite {
            field,
            index: i / width,
        }),
    }
}

impl Sample {
    pub fn num_points(&self) -> usize {
        self.keypoints.len()
    }

    pub fn num_lines(&self) -> usize {
        self.segments.len()
    }

    /// Checks sizes against the network configuration and that every value used is finite.
    pub fn validate(&self, config: &ModelConfig) -> Result<(), ModelError> {
        let n = self.num_points();
        let m = self.num_lines();
        let d = config.descriptor_dim;
        let t = config.line_tokens;
        check_len("point_descriptors", n * d, self.point_descriptors.len())?;
        check_len("line_descriptors", m * t * d, self.line_descriptors.len())?;
        check_len("point_labels", n, self.point_labels.len())?;
        check_len("point_valid", n, self.point_valid.len())?;
        check_len("line_labels", m, self.line_labels.len())?;
        check_len("line_valid", m, self.line_valid.len())?;
        check_finite("point_descriptors", d, &self.point_descriptors)?;
        check_finite("line_descriptors", t * d, &self.line_descriptors)?;
        check_finite("keypoints", 2, self.keypoints.iter().flatten())?;
        check_finite("segments", 4, self.segments.iter().flatten())?;
        for (i, (label, valid)) in self.point_labels.iter().zip(&self.point_valid).enumerate() {
            if *valid && !label.iter().all(|v| v.is_finite()) {
                return Err(ModelError::NonFinite {
                    field: "point_labels",
                    index: i,
                });
            }
        }
        for (i, (label, valid)) in self.line_labels.iter().zip(&self.line_valid).enumerate() {
            if *valid && !label.iter().all(|v| v.is_finite()) {
                return Err(ModelError::NonFinite {
                    field: "line_labels",
                    index: i,
                });
            }
        }
        let c = &self.camera;
        if ![c.fx, c.fy, c.cx, c.cy].iter().all(|v| v.is_finite()) || c.fx <= 0.0 || c.fy <= 0.0 {
            return Err(ModelError::Intrinsics(format!(
                "need finite values and positive focal lengths, got {c:?}"
            )));
        }
        let r = &self.rotation;
        if !r
            .iter()
            .flatten()
            .chain(&self.translation)
            .all(|v| v.is_finite())
        {
            return Err(ModelError::Pose(
                "rotation and translation must be finite".into(),
            ));
        }
        let mut deviation: f64 = 0.0;
        for i in 0..3 {
            for j in 0..3 {
                let dot: f64 = (0..3).map(|k| r[k][i] * r[k][j]).sum();
                deviation = deviation.max((dot - if i == j { 1.0 } else { 0.0 }).abs());
            }
        }
        if deviation > ROTATION_TOLERANCE {
            return Err(ModelError::Pose(format!(
                "rotation is not orthonormal (max |R^T R - I| = {deviation:.2e})"
            )));
        }
        Ok(())
    }

    /// Validates the sample and builds its tensors on `device`.
    pub fn to_tensors<B: Backend>(
        &self,
        config: &ModelConfig,
        device: &B::Device,
    ) -> Result<SampleTensors<B>, ModelError> {
        self.to_tensors_padded(config, None, device)
    }

    /// [`Sample::to_tensors`] padded to `padded` = (N, M) rows where given (a shape
    /// bucket, `buckets.rs`): zero descriptors, zero keypoints and zero-length segments,
    /// invalid labels; the targets then hold masks ([`TargetMasks`]) instead of index
    /// lists, so every tensor of the step has a bucket's shape.
    pub fn to_tensors_padded<B: Backend>(
        &self,
        config: &ModelConfig,
        padded: Option<(usize, usize)>,
        device: &B::Device,
    ) -> Result<SampleTensors<B>, ModelError> {
        self.validate(config)?;
        let input = NetworkInput::from_host_padded(
            config,
            &self.point_descriptors,
            &self.line_descriptors,
            padded,
            device,
        )?;
        let targets = match padded {
            None => Targets::from_sample(self, device),
            Some(rows) => Targets::from_sample_padded(self, rows, device),
        };
        Ok(SampleTensors { input, targets })
    }
}

/// Indices (into the image's points or lines) of one subset, with their count on the host.
#[derive(Clone, Debug)]
pub struct Subset<B: Backend> {
    pub indices: Option<Tensor<B, 1, Int>>,
    pub len: usize,
}

impl<B: Backend> Subset<B> {
    /// A subset known by its size only (padded targets use masks instead of indices).
    fn counted(len: usize) -> Self {
        Subset { indices: None, len }
    }

    fn new(indices: Vec<i64>, device: &B::Device) -> Self {
        let len = indices.len();
        Subset {
            indices: (len > 0).then(|| Tensor::from_data(TensorData::new(indices, [len]), device)),
            len,
        }
    }

    /// The rows of `x` in this subset, or None when it is empty.
    pub fn rows(&self, x: &Tensor<B, 2>) -> Option<Tensor<B, 2>> {
        self.indices
            .as_ref()
            .map(|i| x.clone().select(0, i.clone()))
    }
}

/// The loss targets of one image as tensors. For an image padded to a shape bucket the
/// subsets carry their sizes only (no indices), the per-row tensors have the padded
/// rows (validity 0, zero keypoints and line equations) and `masks` says which rows
/// each term takes.
#[derive(Clone, Debug)]
pub struct Targets<B: Backend> {
    /// Real points and lines (padding excluded).
    pub num_points: usize,
    pub num_lines: usize,
    /// Labelled points (v = 1) and their labels [K, 3].
    pub labelled_points: Subset<B>,
    pub point_labels: Option<Tensor<B, 2>>,
    pub unlabelled_points: Subset<B>,
    /// v for every point, [N, 1].
    pub point_validity: Option<Tensor<B, 2>>,
    /// Keypoints [N, 2].
    pub keypoints: Option<Tensor<B, 2>>,
    pub labelled_lines: Subset<B>,
    pub line_labels: Option<Tensor<B, 2>>,
    /// Lines of the reprojection term's candidate sets: segments of non-zero length only.
    pub reprojectable_labelled_lines: Subset<B>,
    pub reprojectable_unlabelled_lines: Subset<B>,
    pub line_validity: Option<Tensor<B, 2>>,
    /// Normalised 2D line equations (a, b, c) with a^2 + b^2 = 1, one per segment [M, 3];
    /// the distance of pixel (u, v) to the infinite line is |a u + b v + c|.
    pub line_equations: Option<Tensor<B, 2>>,
    /// R^T [3, 3] (so that row vectors map as X R^T) and t [1, 3].
    pub rotation_t: Tensor<B, 2>,
    pub translation: Tensor<B, 2>,
    /// [fx, fy] and [cx, cy], both [1, 2].
    pub focal: Tensor<B, 2>,
    pub principal: Tensor<B, 2>,
    /// Padded targets only.
    pub masks: Option<TargetMasks<B>>,
}

/// The row masks of a padded image's targets: 1 where a row belongs to the set, else 0,
/// each [rows, 1]; the labels of every row (zero where invalid or padded).
#[derive(Clone, Debug)]
pub struct TargetMasks<B: Backend> {
    pub real_points: Option<Tensor<B, 2>>,
    pub labelled_points: Option<Tensor<B, 2>>,
    pub unlabelled_points: Option<Tensor<B, 2>>,
    /// [N, 3]
    pub point_labels: Option<Tensor<B, 2>>,
    pub real_lines: Option<Tensor<B, 2>>,
    pub labelled_lines: Option<Tensor<B, 2>>,
    /// [M, 6]
    pub line_labels: Option<Tensor<B, 2>>,
    pub reprojectable_labelled_lines: Option<Tensor<B, 2>>,
    pub reprojectable_unlabelled_lines: Option<Tensor<B, 2>>,
}

/// The normalised equation of the line through a segment, or None for a degenerate one.
pub fn line_equation(s: &[f32; 4]) -> Option<[f32; 3]> {
    let (x1, y1, x2, y2) = (s[0] as f64, s[1] as f64, s[2] as f64, s[3] as f64);
    let (dx, dy) = (x2 - x1, y2 - y1);
    let len = dx.hypot(dy);
    // Below a thousandth of a pixel the direction is noise.
    if len.is_nan() || len <= 1e-3 {
        return None;
    }
    let (a, b) = (dy / len, -dx / len);
    Some([a as f32, b as f32, (-(a * x1 + b * y1)) as f32])
}

impl<B: Backend> Targets<B> {
    fn from_sample(s: &Sample, device: &B::Device) -> Self {
        let n = s.num_points();
        let m = s.num_lines();
        let split = |valid: &[bool], want: bool| -> Vec<i64> {
            valid
                .iter()
                .enumerate()
                .filter(|(_, v)| **v == want)
                .map(|(i, _)| i as i64)
                .collect()
        };
        let labelled_points = Subset::new(split(&s.point_valid, true), device);
        let unlabelled_points = Subset::new(split(&s.point_valid, false), device);
        let labelled_lines = Subset::new(split(&s.line_valid, true), device);
        let equations: Vec<Option<[f32; 3]>> = s.segments.iter().map(line_equation).collect();
        let reprojectable = |want: bool| -> Vec<i64> {
            (0..m)
                .filter(|&j| s.line_valid[j] == want && equations[j].is_some())
                .map(|j| j as i64)
                .collect()
        };
        let reprojectable_labelled_lines = Subset::new(reprojectable(true), device);
        let reprojectable_unlabelled_lines = Subset::new(reprojectable(false), device);

        let gather = |values: Vec<f32>, k: usize, w: usize| {
            (k > 0).then(|| tensor_from::<B, 2>(values, [k, w], device))
        };
        let point_labels = gather(
            s.point_labels
                .iter()
                .zip(&s.point_valid)
                .filter(|(_, v)| **v)
                .flat_map(|(l, _)| *l)
                .collect(),
            labelled_points.len,
            3,
        );
        let line_labels = gather(
            s.line_labels
                .iter()
                .zip(&s.line_valid)
                .filter(|(_, v)| **v)
                .flat_map(|(l, _)| *l)
                .collect(),
            labelled_lines.len,
            6,
        );
        let (rotation_t, translation, focal, principal) = camera_tensors(s, device);
        Targets {
            num_points: n,
            num_lines: m,
            labelled_points,
            point_labels,
            unlabelled_points,
            point_validity: gather(flags(&s.point_valid), n, 1),
            keypoints: gather(s.keypoints.iter().flatten().copied().collect(), n, 2),
            labelled_lines,
            line_labels,
            reprojectable_labelled_lines,
            reprojectable_unlabelled_lines,
            line_validity: gather(flags(&s.line_valid), m, 1),
            line_equations: gather(equation_values(&equations), m, 3),
            rotation_t,
            translation,
            focal,
            principal,
            masks: None,
        }
    }

    /// The targets of `s` padded to `(rows_n, rows_m)` rows (at least its own).
    fn from_sample_padded(
        s: &Sample,
        (rows_n, rows_m): (usize, usize),
        device: &B::Device,
    ) -> Self {
        let n = s.num_points();
        let m = s.num_lines();
        let column = |rows: usize, f: &dyn Fn(usize) -> bool| -> Option<Tensor<B, 2>> {
            (rows > 0).then(|| {
                let v = (0..rows).map(|i| if f(i) { 1.0 } else { 0.0 }).collect();
                tensor_from::<B, 2>(v, [rows, 1], device)
            })
        };
        let wide = |rows: usize, w: usize, values: Vec<f32>| -> Option<Tensor<B, 2>> {
            (rows > 0).then(|| {
                let mut values = values;
                values.resize(rows * w, 0.0);
                tensor_from::<B, 2>(values, [rows, w], device)
            })
        };
        let point_valid = |i: usize| i < n && s.point_valid[i];
        let line_valid = |j: usize| j < m && s.line_valid[j];
        let equations: Vec<Option<[f32; 3]>> = s.segments.iter().map(line_equation).collect();
        let reprojectable = |j: usize| j < m && equations[j].is_some();
        let count = |rows: usize, f: &dyn Fn(usize) -> bool| (0..rows).filter(|&i| f(i)).count();
        let labelled_points = count(n, &point_valid);
        let labelled_lines = count(m, &line_valid);
        let masks = TargetMasks {
            real_points: column(rows_n, &|i| i < n),
            labelled_points: column(rows_n, &point_valid),
            unlabelled_points: column(rows_n, &|i| i < n && !s.point_valid[i]),
            point_labels: wide(
                rows_n,
                3,
                s.point_labels
                    .iter()
                    .zip(&s.point_valid)
                    .flat_map(|(l, v)| if *v { *l } else { [0.0; 3] })
                    .collect(),
            ),
            real_lines: column(rows_m, &|j| j < m),
            labelled_lines: column(rows_m, &line_valid),
            line_labels: wide(
                rows_m,
                6,
                s.line_labels
                    .iter()
                    .zip(&s.line_valid)
                    .flat_map(|(l, v)| if *v { *l } else { [0.0; 6] })
                    .collect(),
            ),
            reprojectable_labelled_lines: column(rows_m, &|j| reprojectable(j) && s.line_valid[j]),
            reprojectable_unlabelled_lines: column(rows_m, &|j| {
                reprojectable(j) && !s.line_valid[j]
            }),
        };
        let (rotation_t, translation, focal, principal) = camera_tensors(s, device);
        Targets {
            num_points: n,
            num_lines: m,
            labelled_points: Subset::counted(labelled_points),
            point_labels: None,
            unlabelled_points: Subset::counted(n - labelled_points),
            point_validity: wide(rows_n, 1, flags(&s.point_valid)),
            keypoints: wide(rows_n, 2, s.keypoints.iter().flatten().copied().collect()),
            labelled_lines: Subset::counted(labelled_lines),
            line_labels: None,
            reprojectable_labelled_lines: Subset::counted(count(m, &|j| {
                reprojectable(j) && s.line_valid[j]
            })),
            reprojectable_unlabelled_lines: Subset::counted(count(m, &|j| {
                reprojectable(j) && !s.line_valid[j]
            })),
            line_validity: wide(rows_m, 1, flags(&s.line_valid)),
            line_equations: wide(rows_m, 3, equation_values(&equations)),
            rotation_t,
            translation,
            focal,
            principal,
            masks: Some(masks),
        }
    }
}

/// 1.0 where set, 0.0 elsewhere: a validity column of [`Targets`].
fn flags(v: &[bool]) -> Vec<f32> {
    v.iter().map(|&b| if b { 1.0 } else { 0.0 }).collect()
}

/// The line equations of [`Targets`], row by row; zeros where a segment has none.
fn equation_values(equations: &[Option<[f32; 3]>]) -> Vec<f32> {
    equations
        .iter()
        .flat_map(|e| e.unwrap_or([0.0; 3]))
        .collect()
}

/// R^T [3, 3], t [1, 3], [fx, fy] and [cx, cy] of a sample ([`Targets`]).
type CameraTensors<B> = (Tensor<B, 2>, Tensor<B, 2>, Tensor<B, 2>, Tensor<B, 2>);

fn camera_tensors<B: Backend>(s: &Sample, device: &B::Device) -> CameraTensors<B> {
    let r = &s.rotation;
    let rt: Vec<f32> = (0..3)
        .flat_map(|i| (0..3).map(move |j| r[j][i] as f32))
        .collect();
    let c = &s.camera;
    (
        tensor_from(rt, [3, 3], device),
        tensor_from(
            s.translation.iter().map(|&v| v as f32).collect(),
            [1, 3],
            device,
        ),
        tensor_from(vec![c.fx as f32, c.fy as f32], [1, 2], device),
        tensor_from(vec![c.cx as f32, c.cy as f32], [1, 2], device),
    )
}

/// A sample's network input and loss targets.
#[derive(Clone, Debug)]
pub struct SampleTensors<B: Backend> {
    pub input: NetworkInput<B>,
    pub targets: Targets<B>,
}
