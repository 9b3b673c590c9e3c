//! Reading pycolmap's reference output (see gen_pycolmap_reference.py for the format)
//! and comparing the geometry crate's cameras against it.

use geometry::{Camera, CameraModel, Vector2, Vector3};

/// Agreement required: 1e-7 px, or 1e-9 relative for values far from the origin.
const PX_TOL: f64 = 1e-7;
const REL_TOL: f64 = 1e-9;
/// How far pycolmap's own inverse may miss before its answer counts as not being a
/// projection / lifting at all (its Newton iteration stops at ~2e-8 px).
const SELF_CONSISTENT_PX: f64 = 1e-6;
const SELF_CONSISTENT_RAD: f64 = 1e-6;

pub enum Entry {
    /// A point, pycolmap's pixel, and pycolmap's ray back from that pixel.
    Project {
        x: Vector3<f64>,
        px: Option<Vector2<f64>>,
        back: Option<Vector3<f64>>,
    },
    /// A pixel, pycolmap's `cam_from_img` (u, v) or `cam_ray_from_img` bearing, and
    /// pycolmap's projection of that ray.
    Lift {
        px: Vector2<f64>,
        ray: Option<Vector3<f64>>,
        back: Option<Vector2<f64>>,
        unit: bool,
        line: usize,
    },
}

pub struct Case {
    pub camera: Camera,
    pub line: usize,
    pub entries: Vec<(usize, Entry)>,
}

fn numbers(tokens: &[&str], n: usize, line: usize) -> Result<Vec<f64>, String> {
    if tokens.len() < n {
        return Err(format!(
            "line {line}: expected {n} numbers, found {}",
            tokens.len()
        ));
    }
    tokens[..n]
        .iter()
        .map(|t| {
            t.parse::<f64>()
                .map_err(|e| format!("line {line}: `{t}` is not a number: {e}"))
        })
        .collect()
}

/// A group of `n` numbers or the word `none`; returns the values and the rest.
fn group<'a>(
    tokens: &'a [&'a str],
    n: usize,
    line: usize,
) -> Result<(Option<Vec<f64>>, &'a [&'a str]), String> {
    match tokens.first() {
        None => Err(format!("line {line}: missing value group")),
        Some(&"none") => Ok((None, &tokens[1..])),
        Some(_) => Ok((
            Some(numbers(tokens, n, line)?),
            &tokens[n.min(tokens.len())..],
        )),
    }
}

pub fn parse(text: &str) -> Result<Vec<Case>, String> {
    let mut cases: Vec<Case> = Vec::new();
    for (i, raw) in text.lines().enumerate() {
        let line = i + 1;
        let tokens: Vec<&str> = raw.split_whitespace().collect();
        let Some((&kind, rest)) = tokens.split_first() else {
            continue;
        };
        if kind.starts_with('#') {
            continue;
        }
        if kind == "camera" {
            let [name, w, h, params @ ..] = rest else {
                return Err(format!("line {line}: camera line too short"));
            };
            let model = CameraModel::from_name(name).map_err(|e| format!("line {line}: {e}"))?;
            let size = |t: &str| {
                t.parse::<u64>()
                    .map_err(|e| format!("line {line}: bad image size `{t}`: {e}"))
            };
            let params = numbers(params, params.len(), line)?;
            let camera = Camera::new(model, size(w)?, size(h)?, params)
                .map_err(|e| format!("line {line}: {e}"))?;
            cases.push(Case {
                camera,
                line,
                entries: Vec::new(),
            });
            continue;
        }
        let case = cases
            .last_mut()
            .ok_or_else(|| format!("line {line}: `{kind}` before any camera"))?;
        let entry = match kind {
            "project" => {
                let x = numbers(rest, 3, line)?;
                let (px, rest) = group(&rest[3..], 2, line)?;
                let back = match px {
                    Some(_) => group(rest, 3, line)?.0,
                    None => None,
                };
                Entry::Project {
                    x: Vector3::new(x[0], x[1], x[2]),
                    px: px.map(|p| Vector2::new(p[0], p[1])),
                    back: back.map(|r| Vector3::new(r[0], r[1], r[2])),
                }
            }
            "lift" | "ray" => {
                let unit = kind == "ray";
                let px = numbers(rest, 2, line)?;
                let (ray, rest) = group(&rest[2..], if unit { 3 } else { 2 }, line)?;
                let back = match ray {
                    Some(_) => group(rest, 2, line)?.0,
                    None => None,
                };
                Entry::Lift {
                    px: Vector2::new(px[0], px[1]),
                    ray: ray.map(|r| {
                        if unit {
                            Vector3::new(r[0], r[1], r[2])
                        } else {
                            Vector3::new(r[0], r[1], 1.0)
                        }
                    }),
                    back: back.map(|b| Vector2::new(b[0], b[1])),
                    unit,
                    line,
                }
            }
            other => return Err(format!("line {line}: unknown record `{other}`")),
        };
        case.entries.push((line, entry));
    }
    Ok(cases)
}

fn finite2(v: &Vector2<f64>) -> bool {
    v.x.is_finite() && v.y.is_finite()
}

fn finite3(v: &Vector3<f64>) -> bool {
    v.iter().all(|c| c.is_finite())
}

fn angle(a: &Vector3<f64>, b: &Vector3<f64>) -> f64 {
    a.cross(b).norm().atan2(a.dot(b))
}

/// What a comparison found; `failures` must be empty.
#[derive(Default)]
pub struct Report {
    pub projections: usize,
    pub liftings: usize,
    pub both_fail: usize,
    /// We differ from pycolmap where pycolmap's answer is not consistent with its own
    /// inverse (not a valid projection / lifting): (model, line, reason).
    pub justified: Vec<(CameraModel, usize, &'static str)>,
    pub failures: Vec<String>,
    pub max_project_px: f64,
    pub max_project_rel: f64,
    pub max_lift_px: f64,
}

pub fn compare(cases: &[Case]) -> Report {
    let mut r = Report::default();
    for case in cases {
        let cam = &case.camera;
        let (mut projected, mut lifted) = (0, 0);
        for (line, entry) in &case.entries {
            match entry {
                Entry::Project { x, px, back } => match (cam.project(x), px) {
                    (Some(ours), Some(theirs)) => {
                        let err = (ours - theirs).norm();
                        if theirs.norm() <= 1e4 {
                            r.max_project_px = r.max_project_px.max(err);
                        }
                        r.max_project_rel = r.max_project_rel.max(err / theirs.norm());
                        if !(err <= PX_TOL || err <= REL_TOL * theirs.norm()) {
                            r.failures.push(format!(
                                "line {line} ({}): project {x:?}: ours {ours:?}, pycolmap \
                                 {theirs:?}, |diff| {err:e}",
                                cam.model
                            ));
                        }
                        r.projections += 1;
                        projected += 1;
                    }
                    (None, None) => r.both_fail += 1,
                    (None, Some(theirs)) => {
                        let reason = if !finite2(theirs) {
                            Some("we return None, pycolmap a non-finite pixel")
                        } else {
                            match back {
                                None => Some("we return None, pycolmap a pixel it cannot lift"),
                                Some(b) if angle(b, x) > SELF_CONSISTENT_RAD => Some(
                                    "we return None, pycolmap a pixel that lifts to another direction",
                                ),
                                Some(_) => None,
                            }
                        };
                        match reason {
                            Some(why) => r.justified.push((cam.model, *line, why)),
                            None => r.failures.push(format!(
                                "line {line} ({}): project {x:?}: ours None, pycolmap {theirs:?}",
                                cam.model
                            )),
                        }
                    }
                    (Some(ours), None) => r.failures.push(format!(
                        "line {line} ({}): project {x:?}: ours {ours:?}, pycolmap None",
                        cam.model
                    )),
                },
                Entry::Lift {
                    px,
                    ray,
                    back,
                    unit,
                    line,
                } => {
                    let ours = cam.unproject(px);
                    match (ours, ray) {
                        (Some(ours), Some(theirs)) => {
                            let ok = compare_rays(cam, &ours, theirs, *unit, &mut r);
                            // A different answer is right when pycolmap's ray does not
                            // project back to the pixel and ours does (pycolmap's
                            // iteration ended on a folded branch of the lens polynomial,
                            // beyond 90 degrees).
                            let theirs_wrong =
                                back.is_none_or(|b| (b - px).norm() > SELF_CONSISTENT_PX);
                            let ours_right = cam
                                .project(&ours)
                                .is_some_and(|b| (b - px).norm() <= PX_TOL);
                            if !ok && theirs_wrong && ours_right {
                                r.justified.push((
                                    cam.model,
                                    *line,
                                    "pycolmap returns a ray that projects to another pixel, we one that projects to this one",
                                ));
                            } else if !ok {
                                r.failures.push(format!(
                                    "line {line} ({}): lift {px:?}: ours {ours:?}, pycolmap \
                                     {theirs:?}",
                                    cam.model
                                ));
                            }
                            r.liftings += 1;
                            lifted += 1;
                        }
                        (None, None) => r.both_fail += 1,
                        (None, Some(theirs)) => {
                            let reason = if !finite3(theirs) {
                                Some("we return None, pycolmap a non-finite ray")
                            } else {
                                match back {
                                    None => {
                                        Some("we return None, pycolmap a ray it cannot project")
                                    }
                                    Some(b) if (b - px).norm() > SELF_CONSISTENT_PX => Some(
                                        "we return None, pycolmap a ray that projects to another pixel",
                                    ),
                                    Some(_) => None,
                                }
                            };
                            match reason {
                                Some(why) => r.justified.push((cam.model, *line, why)),
                                None => r.failures.push(format!(
                                    "line {line} ({}): lift {px:?}: ours None, pycolmap {theirs:?}",
                                    cam.model
                                )),
                            }
                        }
                        // `cam_from_img` can only express rays in front of the camera:
                        // EQUIRECTANGULAR pixels of the back hemisphere have none.
                        (Some(ours), None) if !unit && ours.z <= f64::EPSILON * ours.norm() => {
                            r.both_fail += 1
                        }
                        (Some(ours), None) => r.failures.push(format!(
                            "line {line} ({}): lift {px:?}: ours {ours:?}, pycolmap None",
                            cam.model
                        )),
                    }
                }
            }
        }
        // Every camera must have been compared somewhere in both directions, or the
        // test proves nothing about it.
        if projected == 0 || lifted == 0 {
            r.failures.push(format!(
                "camera at line {}: {projected} projections and {lifted} liftings compared",
                case.line
            ));
        }
    }
    r
}

/// Our ray against pycolmap's: equal to 1e-9 relative, or indistinguishable in the
/// image (1e-7 px apart after projecting both with our camera).
fn compare_rays(
    cam: &Camera,
    ours: &Vector3<f64>,
    theirs: &Vector3<f64>,
    unit: bool,
    r: &mut Report,
) -> bool {
    // pycolmap's `ray` is a unit bearing, its `cam_from_img` a point (u, v, 1); we lift
    // to (u, v, 1) for perspective models and to a unit bearing for EQUIRECTANGULAR.
    let ours_cmp = if unit {
        ours.normalize()
    } else {
        ours / ours.z
    };
    let rel = (ours_cmp - theirs).norm() / theirs.norm().max(1.0);
    let px = match (cam.project(ours), cam.project(theirs)) {
        (Some(a), Some(b)) => (a - b).norm(),
        _ => f64::INFINITY,
    };
    let ok = rel <= REL_TOL || px <= PX_TOL;
    if ok {
        r.max_lift_px = r.max_lift_px.max(px.min(rel * cam.mean_focal_length()));
    }
    ok
}
