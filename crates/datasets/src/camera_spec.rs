//! Cameras given on the command line or in a pipeline file, as COLMAP's cameras.txt
//! writes them without the id: `MODEL WIDTH HEIGHT PARAMS...`.

use geometry::{Camera, CameraModel};

/// Parses `"SIMPLE_PINHOLE 640 480 525 320 240"`.
pub fn parse_camera(spec: &str) -> Result<Camera, String> {
    let tokens: Vec<&str> = spec.split_whitespace().collect();
    let [model, w, h, params @ ..] = tokens.as_slice() else {
        return Err(format!(
            "camera {spec:?}: expected \"MODEL WIDTH HEIGHT PARAMS...\""
        ));
    };
    let model = CameraModel::from_name(model).map_err(|e| format!("camera {spec:?}: {e}"))?;
    let size = |t: &str, what: &str| {
        t.parse::<u32>()
            .ok()
            .filter(|&v| v > 0)
            .ok_or_else(|| format!("camera {spec:?}: {what} must be a positive integer, got {t:?}"))
    };
    let (w, h) = (size(w, "width")?, size(h, "height")?);
    let params = params
        .iter()
        .map(|t| {
            t.parse::<f64>()
                .map_err(|_| format!("camera {spec:?}: parameter {t:?} is not a number"))
        })
        .collect::<Result<Vec<f64>, String>>()?;
    Camera::new(model, w as u64, h as u64, params).map_err(|e| format!("camera {spec:?}: {e}"))
}

/// The camera as `MODEL W H p1 p2 ...` (shortest round-trip floats).
pub fn format_camera(c: &Camera) -> String {
    let mut s = format!("{} {} {}", c.model.name(), c.width, c.height);
    for p in &c.params {
        s.push(' ');
        s.push_str(&p.to_string());
    }
    s
}

/// The camera as `MODEL p1 p2 ...`, without the size (how the frames table's notes name
/// the depth camera).
pub fn format_model_and_params(c: &Camera) -> String {
    let mut s = c.model.name().to_string();
    for p in &c.params {
        s.push(' ');
        s.push_str(&p.to_string());
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_and_formats() {
        let c = parse_camera("SIMPLE_PINHOLE 640 480 525 320 240").unwrap();
        assert_eq!(c.model, CameraModel::SimplePinhole);
        assert_eq!((c.width, c.height), (640, 480));
        assert_eq!(c.params, vec![525.0, 320.0, 240.0]);
        assert_eq!(format_camera(&c), "SIMPLE_PINHOLE 640 480 525 320 240");
        assert_eq!(format_model_and_params(&c), "SIMPLE_PINHOLE 525 320 240");
        let c = parse_camera("  PINHOLE\t1920 1080 1670.5 1671 960 540 ").unwrap();
        assert_eq!(c.params.len(), 4);
    }

    #[test]
    fn rejects_bad_specs() {
        for bad in [
            "",
            "SIMPLE_PINHOLE 640",
            "PINHOLEX 640 480 1 2 3 4",
            "SIMPLE_PINHOLE 0 480 525 320 240",
            "SIMPLE_PINHOLE 640 -480 525 320 240",
            "SIMPLE_PINHOLE 640 480 525 320",
            "SIMPLE_PINHOLE 640 480 525 320 240 1",
            "SIMPLE_PINHOLE 640 480 525 x 240",
            "SIMPLE_PINHOLE 640 480 NaN 320 240",
        ] {
            assert!(parse_camera(bad).is_err(), "{bad:?} accepted");
        }
    }
}
