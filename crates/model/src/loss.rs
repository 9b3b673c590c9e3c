//! Losses of docs/method.md section 4, per image:
//! L = delta_m L_m + delta_r L_r + delta_pi L_pi.
//!
//! Choices this crate makes where the method (docs/method.md section 4) leaves room
//! (recorded in `LossConfig`):
//! - L_pi averages the robust errors over the valid elements of its target set (points and
//!   lines separately, then added), as the reference does; L_m sums, as section 4 says.
//! - In the paper's variant each labelled element's robust error is weighted by its
//!   predicted reliability r_i, taken as a constant (detached): the weight says how much
//!   the element is trusted, and letting this term push r_i down (its gradient with respect
//!   to r_i is always positive) would fight L_r.
//! - A segment shorter than 1e-3 px has no direction and is left out of L_pi.
//!
//! An image padded to a shape bucket (crates/model/src/buckets.rs) has row masks in its
//! targets (`TargetMasks`) instead of index lists: each term then runs over all rows,
//! masked, so its tensors keep the bucket's shape, and the padded rows add nothing to
//! any term or gradient.

use crate::error::ModelError;
use crate::network::{Prediction, reliability};
use crate::sample::{Subset, TargetMasks, Targets};
use burn::tensor::{Bool, Tensor, backend::Backend};
use serde::{Deserialize, Serialize};

/// Squared-distance floor under a square root: keeps the gradient finite when a
/// prediction hits its target exactly (1e-12 m^2 = 1 um; 1e-12 px^2).
const SQRT_FLOOR: f64 = 1e-12;

/// Which elements the reprojection term L_pi applies to.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ReprojectionTargets {
    /// The paper: labelled elements, each weighted by its (detached) reliability r_i.
    LabelledWeighted,
    /// The released reference code: unlabelled elements only, unweighted.
    Unlabelled,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LossConfig {
    /// delta_m, delta_r, delta_pi.
    pub weight_map: f64,
    pub weight_reliability: f64,
    pub weight_reprojection: f64,
    pub reprojection_targets: ReprojectionTargets,
    /// Training progress t in [0, 1] from which L_pi is on (reference: 0.8).
    pub reprojection_start: f64,
    /// tau(t) = sqrt(1 - t^2) tau_max + tau_min, in pixels.
    pub tau_max: f64,
    pub tau_min: f64,
    /// A reprojection counts only for depths in [min_depth, max_depth] (metres, camera
    /// frame, for every projected point) and errors below max_error (pixels).
    pub min_depth: f64,
    pub max_depth: f64,
    pub max_error: f64,
}

impl LossConfig {
    /// Reference values for indoor scenes (tau_max 50 px).
    pub fn indoor() -> Self {
        LossConfig {
            weight_map: 1.0,
            weight_reliability: 1.0,
            weight_reprojection: 1.0,
            reprojection_targets: ReprojectionTargets::LabelledWeighted,
            reprojection_start: 0.8,
            tau_max: 50.0,
            tau_min: 1.0,
            min_depth: 0.1,
            max_depth: 1000.0,
            max_error: 1000.0,
        }
    }

    /// Reference values for outdoor scenes (tau_max 100 px).
    pub fn outdoor() -> Self {
        LossConfig {
            tau_max: 100.0,
            ..Self::indoor()
        }
    }

    pub fn validate(&self) -> Result<(), ModelError> {
        let bad = |m: String| Err(ModelError::InvalidLossConfig(m));
        for (name, w) in [
            ("weight_map", self.weight_map),
            ("weight_reliability", self.weight_reliability),
            ("weight_reprojection", self.weight_reprojection),
            ("tau_max", self.tau_max),
        ] {
            if !(w.is_finite() && w >= 0.0) {
                return bad(format!("{name} must be finite and >= 0, got {w}"));
            }
        }
        if !(self.tau_min.is_finite() && self.tau_min > 0.0) {
            return bad(format!("tau_min must be positive, got {}", self.tau_min));
        }
        if !(0.0..=1.0).contains(&self.reprojection_start) {
            return bad(format!(
                "reprojection_start must be in [0, 1], got {}",
                self.reprojection_start
            ));
        }
        if !(self.min_depth.is_finite()
            && self.max_depth.is_finite()
            && self.min_depth < self.max_depth)
        {
            return bad(format!(
                "need finite min_depth < max_depth, got {} and {}",
                self.min_depth, self.max_depth
            ));
        }
        if self.max_error.is_nan() || self.max_error <= 0.0 {
            return bad(format!(
                "max_error must be positive, got {}",
                self.max_error
            ));
        }
        Ok(())
    }

    /// The robust scale tau(t) in pixels; `progress` is clamped to [0, 1].
    pub fn tau(&self, progress: f64) -> f64 {
        let t = progress.clamp(0.0, 1.0);
        (1.0 - t * t).sqrt() * self.tau_max + self.tau_min
    }

    pub fn reprojection_active(&self, progress: f64) -> bool {
        self.weight_reprojection > 0.0 && progress >= self.reprojection_start
    }
}

impl Default for LossConfig {
    fn default() -> Self {
        Self::indoor()
    }
}

/// The loss terms of one image as tensors of shape [1] (zero where a set is empty).
#[derive(Clone, Debug)]
pub struct LossTerms<B: Backend> {
    pub total: Tensor<B, 1>,
    pub map_points: Tensor<B, 1>,
    pub map_lines: Tensor<B, 1>,
    pub reliability_points: Tensor<B, 1>,
    pub reliability_lines: Tensor<B, 1>,
    pub reprojection_points: Tensor<B, 1>,
    pub reprojection_lines: Tensor<B, 1>,
    /// How many elements of each reprojection target set passed the validity rules.
    pub reprojection_valid_points: Tensor<B, 1>,
    pub reprojection_valid_lines: Tensor<B, 1>,
    /// Sizes of the reprojection target sets (0 when L_pi is off).
    pub reprojection_candidates_points: usize,
    pub reprojection_candidates_lines: usize,
    pub reprojection_active: bool,
    pub tau: f64,
    /// Whether any term depends on the network (false for an image with nothing in it).
    pub has_gradient: bool,
}

/// The same terms on the host.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct LossValues {
    pub total: f64,
    pub map_points: f64,
    pub map_lines: f64,
    pub reliability_points: f64,
    pub reliability_lines: f64,
    pub reprojection_points: f64,
    pub reprojection_lines: f64,
    pub reprojection_valid_points: usize,
    pub reprojection_valid_lines: usize,
    pub reprojection_candidates_points: usize,
    pub reprojection_candidates_lines: usize,
    pub reprojection_active: bool,
    pub tau: f64,
}

impl LossValues {
    /// Means of the loss terms over several images; counts are summed, the
    /// reprojection term is active when it was for any image, tau is the first's.
    pub fn mean(all: &[LossValues]) -> LossValues {
        let Some(first) = all.first() else {
            return LossValues::default();
        };
        if all.len() == 1 {
            return *first;
        }
        let n = all.len() as f64;
        let avg = |f: fn(&LossValues) -> f64| all.iter().map(f).sum::<f64>() / n;
        let sum = |f: fn(&LossValues) -> usize| all.iter().map(f).sum::<usize>();
        LossValues {
            total: avg(|l| l.total),
            map_points: avg(|l| l.map_points),
            map_lines: avg(|l| l.map_lines),
            reliability_points: avg(|l| l.reliability_points),
            reliability_lines: avg(|l| l.reliability_lines),
            reprojection_points: avg(|l| l.reprojection_points),
            reprojection_lines: avg(|l| l.reprojection_lines),
            reprojection_valid_points: sum(|l| l.reprojection_valid_points),
            reprojection_valid_lines: sum(|l| l.reprojection_valid_lines),
            reprojection_candidates_points: sum(|l| l.reprojection_candidates_points),
            reprojection_candidates_lines: sum(|l| l.reprojection_candidates_lines),
            reprojection_active: all.iter().any(|l| l.reprojection_active),
            tau: first.tau,
        }
    }

    /// Fraction of the point reprojection target set that passed the validity rules
    /// (None when the set is empty or L_pi is off).
    pub fn valid_fraction_points(&self) -> Option<f64> {
        (self.reprojection_candidates_points > 0).then(|| {
            self.reprojection_valid_points as f64 / self.reprojection_candidates_points as f64
        })
    }

    pub fn valid_fraction_lines(&self) -> Option<f64> {
        (self.reprojection_candidates_lines > 0).then(|| {
            self.reprojection_valid_lines as f64 / self.reprojection_candidates_lines as f64
        })
    }
}

impl<B: Backend> LossTerms<B> {
    /// Reads every term back in one transfer.
    pub fn values(&self) -> LossValues {
        let all = Tensor::cat(
            vec![
                self.total.clone(),
                self.map_points.clone(),
                self.map_lines.clone(),
                self.reliability_points.clone(),
                self.reliability_lines.clone(),
                self.reprojection_points.clone(),
                self.reprojection_lines.clone(),
                self.reprojection_valid_points.clone(),
                self.reprojection_valid_lines.clone(),
            ],
            0,
        );
        let v: Vec<f64> = all
            .into_data()
            .convert::<f64>()
            .to_vec::<f64>()
            .unwrap_or_else(|_| vec![f64::NAN; 9]);
        let get = |i: usize| v.get(i).copied().unwrap_or(f64::NAN);
        LossValues {
            total: get(0),
            map_points: get(1),
            map_lines: get(2),
            reliability_points: get(3),
            reliability_lines: get(4),
            reprojection_points: get(5),
            reprojection_lines: get(6),
            reprojection_valid_points: get(7).round() as usize,
            reprojection_valid_lines: get(8).round() as usize,
            reprojection_candidates_points: self.reprojection_candidates_points,
            reprojection_candidates_lines: self.reprojection_candidates_lines,
            reprojection_active: self.reprojection_active,
            tau: self.tau,
        }
    }
}

fn safe_norm_rows<B: Backend>(diff: Tensor<B, 2>) -> Tensor<B, 2> {
    diff.powi_scalar(2).sum_dim(1).clamp_min(SQRT_FLOOR).sqrt()
}

/// sum_i ||pred_i - label_i||_2 over the labelled rows.
fn map_term<B: Backend>(
    pred: &Tensor<B, 2>,
    width: usize,
    subset: &Subset<B>,
    labels: &Option<Tensor<B, 2>>,
) -> Option<Tensor<B, 1>> {
    let rows = subset.rows(pred)?.narrow(1, 0, width);
    let labels = labels.clone()?;
    Some(safe_norm_rows(rows - labels).sum())
}

/// [`map_term`] of a padded image: sum_i mask_i ||pred_i - label_i||_2 over all rows
/// (`count` labelled rows; None when there are none).
fn masked_map_term<B: Backend>(
    pred: &Tensor<B, 2>,
    width: usize,
    count: usize,
    mask: &Option<Tensor<B, 2>>,
    labels: &Option<Tensor<B, 2>>,
) -> Option<Tensor<B, 1>> {
    if count == 0 {
        return None;
    }
    let rows = pred.clone().narrow(1, 0, width);
    Some((safe_norm_rows(rows - labels.clone()?) * mask.clone()?).sum())
}

/// ||v - r||_2 over all rows (of a padded image: over its `real` rows, None when it has
/// none).
fn reliability_term<B: Backend>(
    u: Tensor<B, 2>,
    validity: &Option<Tensor<B, 2>>,
    real: Option<(usize, &Option<Tensor<B, 2>>)>,
    beta: f64,
) -> Option<Tensor<B, 1>> {
    let v = validity.clone()?;
    let mut squares = (v - reliability(u, beta)).powi_scalar(2);
    if let Some((count, mask)) = real {
        if count == 0 {
            return None;
        }
        squares = squares * mask.clone()?;
    }
    Some(squares.sum().clamp_min(SQRT_FLOOR).sqrt())
}

/// Camera-frame projection of world points [K, 3]: pixels [K, 2] and whether the depth is
/// in range [K, 1]. Out-of-range depths are replaced by 1 before the division so that no
/// infinity or NaN enters the graph; those rows are masked out by the caller.
fn project<B: Backend>(
    xyz: Tensor<B, 2>,
    t: &Targets<B>,
    cfg: &LossConfig,
) -> (Tensor<B, 2>, Tensor<B, 2, Bool>) {
    let cam = xyz.matmul(t.rotation_t.clone()) + t.translation.clone();
    let z = cam.clone().narrow(1, 2, 1);
    let ok = z
        .clone()
        .greater_equal_elem(cfg.min_depth)
        .bool_and(z.clone().lower_equal_elem(cfg.max_depth));
    let z_safe = z.mask_fill(ok.clone().bool_not(), 1.0);
    let uv = cam.narrow(1, 0, 2) / z_safe * t.focal.clone() + t.principal.clone();
    (uv, ok)
}

/// Distance of pixels [K, 2] to normalised lines [K, 3].
fn line_distance<B: Backend>(uv: Tensor<B, 2>, eq: Tensor<B, 2>) -> Tensor<B, 2> {
    ((uv * eq.clone().narrow(1, 0, 2)).sum_dim(1) + eq.narrow(1, 2, 1)).abs()
}

struct Reprojection<B: Backend> {
    loss: Tensor<B, 1>,
    valid: Tensor<B, 1>,
}

/// Mean over valid rows of w * tau * tanh(e / tau).
fn robust_mean<B: Backend>(
    error: Tensor<B, 2>,
    ok: Tensor<B, 2, Bool>,
    weight: Option<Tensor<B, 2>>,
    tau: f64,
    cfg: &LossConfig,
) -> Reprojection<B> {
    let ok = ok.bool_and(error.clone().lower_elem(cfg.max_error));
    let mask = ok.float();
    let mut rho = error.div_scalar(tau).tanh().mul_scalar(tau) * mask.clone();
    if let Some(w) = weight {
        rho = rho * w;
    }
    let valid = mask.sum();
    Reprojection {
        loss: rho.sum() / valid.clone().clamp_min(1.0),
        valid,
    }
}

/// How a reprojection target set picks its rows: an index list, or (padded image) a
/// row mask over all rows.
enum Pick<B: Backend> {
    Subset(Subset<B>),
    Mask(Tensor<B, 2>),
}

impl<B: Backend> Pick<B> {
    /// The set's rows of `x` (all rows for a mask).
    fn rows(&self, x: &Tensor<B, 2>) -> Option<Tensor<B, 2>> {
        match self {
            Pick::Subset(s) => s.rows(x),
            Pick::Mask(_) => Some(x.clone()),
        }
    }

    /// `ok` restricted to the set's rows.
    fn restrict(&self, ok: Tensor<B, 2, Bool>) -> Tensor<B, 2, Bool> {
        match self {
            Pick::Subset(_) => ok,
            Pick::Mask(m) => ok.bool_and(m.clone().greater_elem(0.5)),
        }
    }
}

/// The predicted rows of a reprojection target set, how it picks them, its size and
/// its weights (paper's variant only).
type TargetRows<B> = (Tensor<B, 2>, Pick<B>, usize, Option<Tensor<B, 2>>);

/// The row masks of a padded image's labelled and unlabelled reprojection sets.
type SetMasks<'a, B> = (&'a Option<Tensor<B, 2>>, &'a Option<Tensor<B, 2>>);

/// The reprojection target set's rows and, for the paper's variant, its weights.
/// `masks`: the labelled and unlabelled sets' row masks of a padded image.
fn target_rows<B: Backend>(
    pred: &Tensor<B, 2>,
    u_column: usize,
    beta: f64,
    (labelled, unlabelled): (&Subset<B>, &Subset<B>),
    masks: Option<SetMasks<'_, B>>,
    mode: ReprojectionTargets,
) -> Option<TargetRows<B>> {
    let labelled_set = mode == ReprojectionTargets::LabelledWeighted;
    let subset = if labelled_set { labelled } else { unlabelled };
    if subset.len == 0 {
        return None;
    }
    let pick = match masks {
        None => Pick::Subset(subset.clone()),
        Some((l, u)) => Pick::Mask(if labelled_set { l } else { u }.clone()?),
    };
    let rows = pick.rows(pred)?;
    let weight =
        labelled_set.then(|| reliability(rows.clone().narrow(1, u_column, 1), beta).detach());
    Some((rows, pick, subset.len, weight))
}

/// L_pi of the points and the size of its target set; None when the set is empty.
fn point_reprojection<B: Backend>(
    pred: &Prediction<B>,
    t: &Targets<B>,
    cfg: &LossConfig,
    tau: f64,
) -> Option<(Reprojection<B>, usize)> {
    let (p, kp) = (pred.points.as_ref()?, t.keypoints.as_ref()?);
    let (rows, pick, len, weight) = target_rows(
        p,
        3,
        pred.reliability_beta,
        (&t.labelled_points, &t.unlabelled_points),
        t.masks
            .as_ref()
            .map(|m: &TargetMasks<B>| (&m.labelled_points, &m.unlabelled_points)),
        cfg.reprojection_targets,
    )?;
    let kp = pick.rows(kp)?;
    let (uv, ok) = project(rows.narrow(1, 0, 3), t, cfg);
    let error = safe_norm_rows(uv - kp);
    Some((robust_mean(error, pick.restrict(ok), weight, tau, cfg), len))
}

/// L_pi of the lines: psi = the distances of both projected endpoints to the detected
/// segment's infinite line; both endpoints must be at a valid depth.
fn line_reprojection<B: Backend>(
    pred: &Prediction<B>,
    t: &Targets<B>,
    cfg: &LossConfig,
    tau: f64,
) -> Option<(Reprojection<B>, usize)> {
    let (l, eq) = (pred.lines.as_ref()?, t.line_equations.as_ref()?);
    let (rows, pick, len, weight) = target_rows(
        l,
        6,
        pred.reliability_beta,
        (
            &t.reprojectable_labelled_lines,
            &t.reprojectable_unlabelled_lines,
        ),
        t.masks.as_ref().map(|m: &TargetMasks<B>| {
            (
                &m.reprojectable_labelled_lines,
                &m.reprojectable_unlabelled_lines,
            )
        }),
        cfg.reprojection_targets,
    )?;
    let eq = pick.rows(eq)?;
    let (uv_a, ok_a) = project(rows.clone().narrow(1, 0, 3), t, cfg);
    let (uv_b, ok_b) = project(rows.narrow(1, 3, 3), t, cfg);
    let error = line_distance(uv_a, eq.clone()) + line_distance(uv_b, eq);
    Some((
        robust_mean(error, pick.restrict(ok_a.bool_and(ok_b)), weight, tau, cfg),
        len,
    ))
}

/// All loss terms of one image at training progress `progress` in [0, 1].
pub fn compute_loss<B: Backend>(
    pred: &Prediction<B>,
    t: &Targets<B>,
    cfg: &LossConfig,
    progress: f64,
) -> LossTerms<B> {
    let device = t.rotation_t.device();
    let zero = || Tensor::<B, 1>::zeros([1], &device);
    let beta = pred.reliability_beta;
    let mut has_gradient = false;
    let mut take = |x: Option<Tensor<B, 1>>| match x {
        Some(x) => {
            has_gradient = true;
            x
        }
        None => zero(),
    };

    let masks = t.masks.as_ref();
    let map_points = take(pred.points.as_ref().and_then(|p| match masks {
        None => map_term(p, 3, &t.labelled_points, &t.point_labels),
        Some(mk) => masked_map_term(
            p,
            3,
            t.labelled_points.len,
            &mk.labelled_points,
            &mk.point_labels,
        ),
    }));
    let map_lines = take(pred.lines.as_ref().and_then(|l| match masks {
        None => map_term(l, 6, &t.labelled_lines, &t.line_labels),
        Some(mk) => masked_map_term(
            l,
            6,
            t.labelled_lines.len,
            &mk.labelled_lines,
            &mk.line_labels,
        ),
    }));
    let reliability_points = take(pred.points.as_ref().and_then(|p| {
        reliability_term(
            p.clone().narrow(1, 3, 1),
            &t.point_validity,
            masks.map(|mk| (t.num_points, &mk.real_points)),
            beta,
        )
    }));
    let reliability_lines = take(pred.lines.as_ref().and_then(|l| {
        reliability_term(
            l.clone().narrow(1, 6, 1),
            &t.line_validity,
            masks.map(|mk| (t.num_lines, &mk.real_lines)),
            beta,
        )
    }));

    let tau = cfg.tau(progress);
    let active = cfg.reprojection_active(progress);
    let mut candidates_points = 0;
    let mut candidates_lines = 0;
    let mut reprojection_points = None;
    let mut reprojection_lines = None;
    let mut valid_points = zero();
    let mut valid_lines = zero();
    if active {
        if let Some((r, candidates)) = point_reprojection(pred, t, cfg, tau) {
            candidates_points = candidates;
            valid_points = r.valid;
            reprojection_points = Some(r.loss);
        }
        if let Some((r, candidates)) = line_reprojection(pred, t, cfg, tau) {
            candidates_lines = candidates;
            valid_lines = r.valid;
            reprojection_lines = Some(r.loss);
        }
    }
    let reprojection_points = take(reprojection_points);
    let reprojection_lines = take(reprojection_lines);

    let mut total = (map_points.clone() + map_lines.clone()).mul_scalar(cfg.weight_map)
        + (reliability_points.clone() + reliability_lines.clone())
            .mul_scalar(cfg.weight_reliability);
    if active {
        total = total
            + (reprojection_points.clone() + reprojection_lines.clone())
                .mul_scalar(cfg.weight_reprojection);
    }
    LossTerms {
        total,
        map_points,
        map_lines,
        reliability_points,
        reliability_lines,
        reprojection_points,
        reprojection_lines,
        reprojection_valid_points: valid_points,
        reprojection_valid_lines: valid_lines,
        reprojection_candidates_points: candidates_points,
        reprojection_candidates_lines: candidates_lines,
        reprojection_active: active,
        tau,
        has_gradient,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sample::{Pinhole, Sample};
    use crate::testing::{AD, B, tensor, tiny_config, values};

    const CAMERA: Pinhole = Pinhole {
        fx: 100.0,
        fy: 100.0,
        cx: 50.0,
        cy: 40.0,
    };
    const IDENTITY: [[f64; 3]; 3] = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];

    fn sample(
        keypoints: Vec<[f32; 2]>,
        point_labels: Vec<[f32; 3]>,
        point_valid: Vec<bool>,
        segments: Vec<[f32; 4]>,
        line_labels: Vec<[f32; 6]>,
        line_valid: Vec<bool>,
    ) -> Sample {
        let c = tiny_config();
        let (n, m) = (keypoints.len(), segments.len());
        Sample {
            point_descriptors: vec![0.0; n * c.descriptor_dim],
            line_descriptors: vec![0.0; m * c.line_tokens * c.descriptor_dim],
            keypoints,
            segments,
            point_labels,
            point_valid,
            line_labels,
            line_valid,
            rotation: IDENTITY,
            translation: [0.0; 3],
            camera: CAMERA,
        }
    }

    fn prediction<Bk: Backend>(points: Vec<[f32; 4]>, lines: Vec<[f32; 7]>) -> Prediction<Bk> {
        let (n, m) = (points.len(), lines.len());
        Prediction {
            points: (n > 0).then(|| tensor(points.concat(), [n, 4])),
            lines: (m > 0).then(|| tensor(lines.concat(), [m, 7])),
            reliability_beta: 100.0,
        }
    }

    fn targets(s: &Sample) -> Targets<B> {
        s.to_tensors::<B>(&tiny_config(), &Default::default())
            .unwrap()
            .targets
    }

    /// Three points and two lines whose loss terms are worked out by hand in the comments.
    fn case() -> (Sample, Prediction<B>) {
        let s = sample(
            vec![[58.0, 54.0], [50.0, 43.0], [50.0, 40.0]],
            vec![[0.0, 0.0, 2.0], [1e6, 1e6, 1e6], [0.0, 0.0, 0.35]],
            vec![true, false, true],
            // y = 50 and x = 0.
            vec![[0.0, 50.0, 100.0, 50.0], [0.0, 0.0, 0.0, 100.0]],
            vec![[-0.1, -0.27, 2.0, 0.6, 0.22, 2.0], [0.0; 6]],
            vec![true, false],
        );
        let p = prediction(
            vec![
                // projects to (55, 50): 5 px from (58, 54); r = 1 / (1 + 1) = 0.5
                [0.1, 0.2, 2.0, 0.01],
                // projects to (50, 40): 3 px from (50, 43); r = 1
                [0.0, 0.0, 1.0, 0.0],
                // 5 cm in front of the camera: no reprojection; r = 1 / (1 + 3) = 0.25
                [0.0, 0.0, 0.05, -0.03],
            ],
            vec![
                // (60, 46.5) and (80, 51): 3.5 + 1 px from y = 50; r = 1
                [0.2, 0.13, 2.0, 0.6, 0.22, 2.0, 0.0],
                // (25, 40) and (25, 50): 25 + 25 px from x = 0; r = 0.5
                [-0.5, 0.0, 2.0, -0.5, 0.2, 2.0, 0.01],
            ],
        );
        (s, p)
    }

    fn close(a: f64, b: f64) {
        assert!((a - b).abs() <= 1e-5 * (1.0 + b.abs()), "{a} vs {b}");
    }

    #[test]
    fn tau_schedule() {
        let c = LossConfig::indoor();
        close(c.tau(0.0), 51.0);
        close(c.tau(0.6), 0.8 * 50.0 + 1.0);
        close(c.tau(1.0), 1.0);
        close(c.tau(2.0), 1.0);
        close(LossConfig::outdoor().tau(0.0), 101.0);
        assert!(!c.reprojection_active(0.79));
        assert!(c.reprojection_active(0.8));
    }

    #[test]
    fn hand_computed_terms_paper_variant() {
        let (s, p) = case();
        let cfg = LossConfig::indoor();
        let v = compute_loss(&p, &targets(&s), &cfg, 0.8).values();
        let tau = 0.6 * 50.0 + 1.0;
        // L_m: |(0.1, 0.2, 0)| + |(0, 0, -0.3)|; lines |(0.3, 0.4, 0, ...)|.
        close(v.map_points, 0.05f64.sqrt() + 0.3);
        close(v.map_lines, 0.5);
        // L_r: |(1, 0, 1) - (0.5, 1, 0.25)| and |(1, 0) - (1, 0.5)|.
        close(v.reliability_points, (0.25f64 + 1.0 + 0.5625).sqrt());
        close(v.reliability_lines, 0.5);
        // L_pi over the labelled: point 0 (weight r = 0.5; point 2 is too near), line 0.
        close(v.reprojection_points, 0.5 * tau * (5.0f64 / tau).tanh());
        close(v.reprojection_lines, tau * (4.5f64 / tau).tanh());
        assert_eq!(
            (
                v.reprojection_valid_points,
                v.reprojection_candidates_points
            ),
            (1, 2)
        );
        assert_eq!(
            (v.reprojection_valid_lines, v.reprojection_candidates_lines),
            (1, 1)
        );
        assert!(v.reprojection_active);
        let total = v.map_points
            + v.map_lines
            + v.reliability_points
            + v.reliability_lines
            + v.reprojection_points
            + v.reprojection_lines;
        close(v.total, total);
    }

    #[test]
    fn hand_computed_terms_released_code_variant() {
        let (s, p) = case();
        let cfg = LossConfig {
            reprojection_targets: ReprojectionTargets::Unlabelled,
            weight_map: 2.0,
            ..LossConfig::indoor()
        };
        let v = compute_loss(&p, &targets(&s), &cfg, 1.0).values();
        // tau(1) = tau_min = 1; unlabelled point 1 (3 px) and line 1 (50 px), unweighted.
        close(v.reprojection_points, (3.0f64).tanh());
        close(v.reprojection_lines, (50.0f64).tanh());
        close(
            v.total,
            2.0 * (v.map_points + v.map_lines)
                + v.reliability_points
                + v.reliability_lines
                + v.reprojection_points
                + v.reprojection_lines,
        );
    }

    #[test]
    fn reprojection_waits_for_its_start() {
        let (s, p) = case();
        let cfg = LossConfig::indoor();
        let v = compute_loss(&p, &targets(&s), &cfg, 0.5).values();
        assert!(!v.reprojection_active);
        assert_eq!(v.reprojection_points, 0.0);
        assert_eq!(v.reprojection_candidates_points, 0);
        close(
            v.total,
            v.map_points + v.map_lines + v.reliability_points + v.reliability_lines,
        );
    }

    #[test]
    fn validity_rules() {
        // All labelled with r = 1; only the first passes: then too near, behind the
        // camera, too far, and 2000 px off.
        let s = sample(
            vec![
                [55.0, 44.0],
                [50.0, 40.0],
                [50.0, 40.0],
                [50.0, 40.0],
                [50.0, 40.0],
            ],
            vec![[0.0; 3]; 5],
            vec![true; 5],
            vec![],
            vec![],
            vec![],
        );
        let p = prediction(
            vec![
                [0.0, 0.0, 1.0, 0.0],
                [0.0, 0.0, 0.099, 0.0],
                [0.0, 0.0, -2.0, 0.0],
                [0.0, 0.0, 1000.5, 0.0],
                [20.0, 0.0, 1.0, 0.0],
            ],
            vec![],
        );
        let cfg = LossConfig::indoor();
        let v = compute_loss(&p, &targets(&s), &cfg, 1.0).values();
        assert_eq!(v.reprojection_valid_points, 1);
        assert_eq!(v.reprojection_candidates_points, 5);
        assert_eq!(v.valid_fraction_points(), Some(0.2));
        // Mean over the valid element only: (50, 40) is sqrt(41) px from (55, 44); tau(1) = 1.
        close(v.reprojection_points, ((25.0f64 + 16.0).sqrt()).tanh());
        // Lines need both endpoints in range.
        let s = sample(
            vec![],
            vec![],
            vec![],
            vec![[0.0, 50.0, 100.0, 50.0]; 2],
            vec![[0.0; 6]; 2],
            vec![true; 2],
        );
        let p = prediction(
            vec![],
            vec![
                [0.0, 0.1, 1.0, 0.0, 0.2, 2.0, 0.0],
                [0.0, 0.1, 1.0, 0.0, 0.2, 0.05, 0.0],
            ],
        );
        let v = compute_loss(&p, &targets(&s), &cfg, 1.0).values();
        assert_eq!(v.reprojection_valid_lines, 1);
        // (50, 50) and (50, 50): on the line.
        assert!(v.reprojection_lines.abs() < 1e-4);
    }

    #[test]
    fn degenerate_segments_leave_the_reprojection_set() {
        let s = sample(
            vec![],
            vec![],
            vec![],
            vec![[10.0, 10.0, 10.0, 10.0], [0.0, 50.0, 100.0, 50.0]],
            vec![[0.0; 6]; 2],
            vec![true; 2],
        );
        let p = prediction(vec![], vec![[0.0, 0.1, 1.0, 0.0, 0.1, 1.0, 0.0]; 2]);
        let v = compute_loss(&p, &targets(&s), &LossConfig::indoor(), 1.0).values();
        assert_eq!(v.reprojection_candidates_lines, 1);
        assert!(v.total.is_finite());
    }

    #[test]
    fn pose_is_world_to_camera() {
        // R = 90 deg about z, t = (0.1, 0, 1): X = (0.2, 0.1, 1) -> (0, 0.2, 2) -> (50, 50).
        let mut s = sample(
            vec![[53.0, 54.0]],
            vec![[0.0; 3]],
            vec![true],
            vec![],
            vec![],
            vec![],
        );
        s.rotation = [[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]];
        s.translation = [0.1, 0.0, 1.0];
        let p = prediction(vec![[0.2, 0.1, 1.0, 0.0]], vec![]);
        let v = compute_loss(&p, &targets(&s), &LossConfig::indoor(), 1.0).values();
        close(v.reprojection_points, (5.0f64).tanh());
    }

    #[test]
    fn reprojection_gradient_matches_finite_differences() {
        // Differentiates: not beside another thread's graphs (autodiff_lock.rs).
        let _autodiff = kernels::autodiff_lock::exclusive();
        let (s, _) = case();
        let cfg = LossConfig::indoor();
        let points = vec![
            0.1f32, 0.2, 2.0, 0.01, 0.0, 0.0, 1.0, 0.0, 0.3, -0.1, 1.5, -0.03,
        ];
        let lines = vec![
            0.2f32, 0.13, 2.0, 0.6, 0.22, 2.1, 0.0, -0.5, 0.0, 2.0, -0.5, 0.2, 2.0, 0.01,
        ];
        let t_ad = s
            .to_tensors::<AD>(&tiny_config(), &Default::default())
            .unwrap()
            .targets;
        let pt = tensor::<AD, 2>(points.clone(), [3, 4]).require_grad();
        let ln = tensor::<AD, 2>(lines.clone(), [2, 7]).require_grad();
        let pred = Prediction {
            points: Some(pt.clone()),
            lines: Some(ln.clone()),
            reliability_beta: 100.0,
        };
        let terms = compute_loss(&pred, &t_ad, &cfg, 0.9);
        let grads = terms.total.backward();
        let gp = values(&pt.grad(&grads).unwrap());
        let gl = values(&ln.grad(&grads).unwrap());

        let t = targets(&s);
        let f = |p: &[f32], l: &[f32]| -> f64 {
            let pred = Prediction::<B> {
                points: Some(tensor(p.to_vec(), [3, 4])),
                lines: Some(tensor(l.to_vec(), [2, 7])),
                reliability_beta: 100.0,
            };
            compute_loss(&pred, &t, &cfg, 0.9).values().total
        };
        let h = 1e-3f32;
        // Coordinates only: u enters through |u|, and the detached weights make its
        // derivative differ from the full one by design.
        for i in [0usize, 1, 2, 8, 9, 10] {
            let (mut a, mut b) = (points.clone(), points.clone());
            a[i] += h;
            b[i] -= h;
            let fd = (f(&a, &lines) - f(&b, &lines)) / (2.0 * h as f64);
            assert!(
                (fd - gp[i] as f64).abs() < 2e-2 * (1.0 + fd.abs()),
                "point {i}: fd {fd} vs {}",
                gp[i]
            );
        }
        for i in [0usize, 1, 2, 3, 4, 5] {
            let (mut a, mut b) = (lines.clone(), lines.clone());
            a[i] += h;
            b[i] -= h;
            let fd = (f(&points, &a) - f(&points, &b)) / (2.0 * h as f64);
            assert!(
                (fd - gl[i] as f64).abs() < 2e-2 * (1.0 + fd.abs()),
                "line {i}: fd {fd} vs {}",
                gl[i]
            );
        }
    }

    #[test]
    fn rejects_bad_configuration() {
        let mut c = LossConfig::indoor();
        c.tau_min = 0.0;
        assert!(c.validate().is_err());
        let mut c = LossConfig::indoor();
        c.reprojection_start = 1.5;
        assert!(c.validate().is_err());
        assert!(LossConfig::outdoor().validate().is_ok());
    }
}
