//! Order statistics for reports.

use serde::{Deserialize, Serialize};

/// Median, 90th percentile and maximum of non-negative values (metres or degrees).
/// The percentile is the nearest-rank one: the smallest value with at least 90 % of
/// the values at or below it. All NaN when there are no values (JSON: null).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Spread {
    pub count: usize,
    #[serde(with = "nullable")]
    pub median: f64,
    #[serde(with = "nullable")]
    pub p90: f64,
    #[serde(with = "nullable")]
    pub max: f64,
}

impl Spread {
    pub fn of(values: &[f64]) -> Spread {
        if values.is_empty() {
            return Spread {
                count: 0,
                median: f64::NAN,
                p90: f64::NAN,
                max: f64::NAN,
            };
        }
        let mut v = values.to_vec();
        v.sort_by(f64::total_cmp);
        let n = v.len();
        let rank = (0.9 * n as f64).ceil() as usize;
        Spread {
            count: n,
            median: geometry::metrics::median(&v),
            p90: v[rank.clamp(1, n) - 1],
            max: v[n - 1],
        }
    }
}

/// Serialises NaN as JSON null (serde_json would fail on NaN) and reads null back as NaN.
pub(crate) mod nullable {
    use serde::{Deserialize, Deserializer, Serializer};

    pub fn serialize<S: Serializer>(v: &f64, s: S) -> Result<S::Ok, S::Error> {
        if v.is_finite() {
            s.serialize_f64(*v)
        } else {
            s.serialize_none()
        }
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
        Ok(Option::<f64>::deserialize(d)?.unwrap_or(f64::NAN))
    }
}

/// Coordinate-wise median of 3D points (None when empty).
pub(crate) fn median3(points: &[[f64; 3]]) -> Option<[f64; 3]> {
    if points.is_empty() {
        return None;
    }
    let mut out = [0.0; 3];
    for (k, o) in out.iter_mut().enumerate() {
        let axis: Vec<f64> = points.iter().map(|p| p[k]).collect();
        *o = geometry::metrics::median(&axis);
    }
    Some(out)
}

pub(crate) fn dist3(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spread_by_hand() {
        let s = Spread::of(&[5.0, 1.0, 3.0, 2.0, 4.0, 6.0, 7.0, 8.0, 9.0, 10.0]);
        assert_eq!((s.count, s.median, s.p90, s.max), (10, 5.5, 9.0, 10.0));
        let s = Spread::of(&[2.0]);
        assert_eq!((s.median, s.p90, s.max), (2.0, 2.0, 2.0));
        let e = Spread::of(&[]);
        assert!(e.median.is_nan());
        let json = serde_json::to_string(&e).unwrap();
        assert_eq!(json, r#"{"count":0,"median":null,"p90":null,"max":null}"#);
        let back: Spread = serde_json::from_str(&json).unwrap();
        assert!(back.max.is_nan());
    }

    #[test]
    fn coordinate_median() {
        let m = median3(&[[0.0, 5.0, 1.0], [1.0, 4.0, 100.0], [2.0, 3.0, 2.0]]).unwrap();
        assert_eq!(m, [1.0, 4.0, 2.0]);
        assert!(median3(&[]).is_none());
    }
}
