//! Endpoint order of a 3D line label relative to its 2D segment (docs/method.md
//! section 3): LIMAP stores a track's endpoints in its own order, which says nothing
//! about the direction of each supporting 2D segment. The label's first endpoint must be
//! the one seen at the segment's (x1, y1), so that the line losses compare like with like.

use geometry::{Camera, Pose, Vector2, Vector3};

/// How the order was decided.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AlignedBy {
    /// Both endpoints project into the image plane: the order whose projections lie
    /// nearer to the segment's endpoints (sum of both distances) wins.
    Projection,
    /// An endpoint is behind the camera: the order whose endpoints lie nearer to the
    /// viewing rays through the segment's endpoints (sum of both 3D distances) wins.
    Rays,
    /// Neither works (the camera cannot lift the segment's endpoints): track order kept.
    Undecided,
}

/// Returns the endpoints in segment order, whether they were swapped, and how.
pub fn align_endpoints(
    camera: &Camera,
    pose: &Pose,
    segment: &[f64; 4],
    line: &[[f64; 3]; 2],
) -> ([[f64; 3]; 2], bool, AlignedBy) {
    let s = Vector2::new(segment[0], segment[1]);
    let e = Vector2::new(segment[2], segment[3]);
    let a = pose.transform_point(&Vector3::from(line[0]));
    let b = pose.transform_point(&Vector3::from(line[1]));
    let decide = |keep: f64, swap: f64| swap < keep;
    let (swapped, by) = match (camera.project(&a), camera.project(&b)) {
        (Some(pa), Some(pb)) if a.z > 0.0 && b.z > 0.0 => {
            let keep = (pa - s).norm() + (pb - e).norm();
            let swap = (pb - s).norm() + (pa - e).norm();
            (decide(keep, swap), AlignedBy::Projection)
        }
        _ => match (camera.unproject(&s), camera.unproject(&e)) {
            (Some(rs), Some(re)) if rs.norm() > 0.0 && re.norm() > 0.0 => {
                let (rs, re) = (rs.normalize(), re.normalize());
                let off = |p: &Vector3<f64>, r: &Vector3<f64>| (p - r * p.dot(r)).norm();
                let keep = off(&a, &rs) + off(&b, &re);
                let swap = off(&b, &rs) + off(&a, &re);
                (decide(keep, swap), AlignedBy::Rays)
            }
            _ => (false, AlignedBy::Undecided),
        },
    };
    let out = if swapped {
        [line[1], line[0]]
    } else {
        [line[0], line[1]]
    };
    (out, swapped, by)
}

#[cfg(test)]
mod tests {
    use super::*;
    use geometry::CameraModel;

    fn setup() -> (Camera, Pose) {
        let cam = Camera::new(
            CameraModel::SimplePinhole,
            640,
            480,
            vec![500.0, 320.0, 240.0],
        )
        .unwrap();
        (cam, Pose::identity())
    }

    #[test]
    fn swaps_when_the_segment_runs_the_other_way() {
        let (cam, pose) = setup();
        // A at x = -0.5 (pixel 195), B at x = +0.5 (pixel 445), both at z = 2.
        let line = [[-0.5, 0.0, 2.0], [0.5, 0.0, 2.0]];
        let forward = [195.0, 240.0, 445.0, 240.0];
        let backward = [445.0, 240.0, 195.0, 240.0];
        assert_eq!(
            align_endpoints(&cam, &pose, &forward, &line),
            (line, false, AlignedBy::Projection)
        );
        assert_eq!(
            align_endpoints(&cam, &pose, &backward, &line),
            ([line[1], line[0]], true, AlignedBy::Projection)
        );
    }

    #[test]
    fn falls_back_to_rays_behind_the_camera() {
        let (cam, pose) = setup();
        // B is behind the camera; the segment starts where A is seen.
        let line = [[0.0, 0.0, 2.0], [-1.0, 0.0, -1.0]];
        let a_px = [320.0, 240.0];
        // The end pixel lies on the side B's ray-distance favours (x < 0).
        let seg = [a_px[0], a_px[1], 100.0, 240.0];
        let (out, swapped, by) = align_endpoints(&cam, &pose, &seg, &line);
        assert_eq!(by, AlignedBy::Rays);
        assert!(!swapped);
        assert_eq!(out, line);
        let rev = [100.0, 240.0, a_px[0], a_px[1]];
        let (out, swapped, _) = align_endpoints(&cam, &pose, &rev, &line);
        assert!(swapped);
        assert_eq!(out, [line[1], line[0]]);
    }
}
