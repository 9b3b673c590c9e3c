use super::*;

mod behaviour;
mod cameras;
mod domain;
mod roundtrip;
mod scaling;

#[test]
fn model_table_matches_colmap_counts() {
    let counts = [3, 4, 4, 5, 8, 8, 12, 5, 4, 5, 12, 16, 4, 5, 3, 4, 6, 2];
    for (m, n) in CameraModel::ALL.iter().zip(counts) {
        assert_eq!(m.num_params(), n, "{m}");
        assert_eq!(CameraModel::from_id(m.id() as i64).unwrap(), *m);
        assert_eq!(CameraModel::from_name(m.name()).unwrap(), *m);
    }
    assert!(CameraModel::from_id(18).is_err());
    assert!(CameraModel::from_id(-1).is_err());
}

/// Cameras that cannot exist are refused by `Camera::new` (and `validate`), the message
/// naming the parameter and what was expected (docs/errors.md).
#[test]
fn impossible_cameras_are_refused_naming_the_parameter() {
    use CameraModel::*;
    let err = |m, w, h, p: &[f64]| Camera::new(m, w, h, p.to_vec()).unwrap_err().to_string();
    assert_eq!(
        err(Pinhole, 640, 480, &[-525.0, 525.0, 320.0, 240.0]),
        "focal length fx = -525 must be positive and finite"
    );
    assert_eq!(
        err(Pinhole, 640, 480, &[525.0, 0.0, 320.0, 240.0]),
        "focal length fy = 0 must be positive and finite"
    );
    assert_eq!(
        err(SimplePinhole, 640, 480, &[0.0, 320.0, 240.0]),
        "focal length f = 0 must be positive and finite"
    );
    assert_eq!(
        err(SimplePinhole, 640, 480, &[525.0, 1e12, 240.0]),
        "principal point cx = 1000000000000 lies more than an image size outside the \
         640x480 image (expected -640 <= cx <= 1280)"
    );
    assert!(
        err(SimpleRadial, 640, 480, &[525.0, 320.0, -481.0, 0.0]).contains("cy = -481"),
        "cy"
    );
    assert_eq!(
        err(SimplePinhole, 0, 480, &[525.0, 320.0, 240.0]),
        "camera size 0x480 is invalid: width and height must be positive"
    );
    assert!(err(SimplePinhole, 640, 480, &[f64::NAN, 320.0, 240.0]).contains("not finite"));
    assert!(err(SimplePinhole, 640, 480, &[525.0, f64::INFINITY, 240.0]).contains("not finite"));
    assert_eq!(
        err(Equirectangular, 100, 50, &[0.0, 50.0]),
        "sphere size w = 0 must be positive and finite"
    );
    // The edges of what is accepted: a principal point up to one image size outside
    // (crops), any positive focal length.
    Camera::new(SimplePinhole, 640, 480, vec![1e-3, -640.0, 960.0]).unwrap();
    Camera::new(Pinhole, 640, 480, vec![1e9, 1e9, 1280.0, -480.0]).unwrap();
    // Every model's realistic cameras pass.
    for c in cameras::all() {
        c.validate().unwrap();
    }
}
