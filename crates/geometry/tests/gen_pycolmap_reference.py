#!/usr/bin/env python3
"""Prints pycolmap's projection and lifting for every COLMAP camera model.

Its output is committed as data/pycolmap_camera_reference.txt and read by
pycolmap_reference.rs, which compares the geometry crate against it; the same test
re-runs this script when PL2MAP_PYTHON names a Python with pycolmap 4.2.1.

    python gen_pycolmap_reference.py > data/pycolmap_camera_reference.txt

Line format (whitespace separated, floats as Python repr, which round-trips):
    camera MODEL_NAME WIDTH HEIGHT PARAMS...
    project X Y Z  x y  rx ry rz          Camera.img_from_cam(X) (cheirality checked),
                                          then cam_ray_from_img of that pixel
    lift x y  u v  xr yr                  Camera.cam_from_img(x), then img_from_cam of
                                          the ray (u, v, 1)
    ray x y  rx ry rz  xr yr              Camera.cam_ray_from_img(x), then img_from_cam
                                          of that ray
where a group is the single word `none` when pycolmap returned None (and the groups
after it are left out). The second group records whether pycolmap's answer is
consistent with pycolmap's own inverse; the Rust test uses it to tell a pycolmap
answer that is not a valid projection / lifting from a disagreement.
Every line after a `camera` line belongs to that camera.
"""

import math
import sys

try:
    import numpy as np
    import pycolmap
except ImportError as err:  # the Rust test skips on this exit code
    print(f"cannot import numpy/pycolmap: {err}", file=sys.stderr)
    sys.exit(3)

# (model, width, height, params): for each model a mild and a strong set of realistic
# parameters; some put the edge of the model's valid domain inside the image.
CAMERAS = [
    ("SIMPLE_PINHOLE", 640, 480, [500.0, 320.0, 240.0]),
    ("SIMPLE_PINHOLE", 1024, 768, [1200.0, 510.5, 390.25]),
    ("PINHOLE", 640, 480, [500.0, 520.0, 320.0, 240.0]),
    ("PINHOLE", 640, 480, [300.0, 280.0, 330.0, 230.0]),
    ("SIMPLE_RADIAL", 640, 480, [500.0, 320.0, 240.0, -0.05]),
    ("SIMPLE_RADIAL", 640, 480, [300.0, 320.0, 240.0, -0.35]),
    ("SIMPLE_RADIAL", 640, 480, [500.0, 320.0, 240.0, 0.2]),
    ("RADIAL", 640, 480, [500.0, 320.0, 240.0, -0.08, 0.01]),
    ("RADIAL", 640, 480, [280.0, 320.0, 240.0, -0.45, 0.03]),
    ("OPENCV", 640, 480, [500.0, 505.0, 320.0, 240.0, -0.1, 0.02, 0.001, -0.0015]),
    ("OPENCV", 640, 480, [300.0, 305.0, 322.0, 238.0, -0.35, 0.09, 0.004, -0.003]),
    ("OPENCV_FISHEYE", 640, 480, [320.0, 320.0, 320.0, 240.0, 0.02, -0.01, 0.003, -0.0005]),
    ("OPENCV_FISHEYE", 640, 480, [250.0, 252.0, 318.0, 242.0, 0.25, -0.15, 0.06, -0.01]),
    ("FULL_OPENCV", 640, 480,
     [500.0, 505.0, 320.0, 240.0, -0.1, 0.02, 0.001, -0.0015, 0.001, 0.05, 0.01, 0.001]),
    ("FULL_OPENCV", 640, 480,
     [300.0, 300.0, 320.0, 240.0, -0.3, 0.1, 0.002, 0.003, -0.01, 0.2, 0.02, 0.001]),
    ("FOV", 640, 480, [400.0, 400.0, 320.0, 240.0, 0.6]),
    ("FOV", 640, 480, [250.0, 252.0, 320.0, 240.0, 1.2]),
    ("SIMPLE_RADIAL_FISHEYE", 640, 480, [300.0, 320.0, 240.0, 0.05]),
    ("SIMPLE_RADIAL_FISHEYE", 640, 480, [230.0, 320.0, 240.0, -0.12]),
    ("RADIAL_FISHEYE", 640, 480, [300.0, 320.0, 240.0, 0.05, -0.01]),
    ("RADIAL_FISHEYE", 640, 480, [230.0, 320.0, 240.0, -0.15, 0.02]),
    ("THIN_PRISM_FISHEYE", 640, 480,
     [300.0, 302.0, 320.0, 240.0, 0.05, -0.01, 0.001, -0.002, 0.003, -0.001, 0.002, -0.001]),
    ("THIN_PRISM_FISHEYE", 640, 480,
     [240.0, 241.0, 321.0, 239.0, 0.2, -0.08, 0.004, 0.003, 0.02, -0.004, -0.003, 0.002]),
    ("RAD_TAN_THIN_PRISM_FISHEYE", 640, 480,
     [300.0, 300.0, 320.0, 240.0, 0.02, -0.005, 0.001, 0.0, 0.0, 0.0,
      0.0005, -0.0004, 0.0003, -0.0001, -0.0002, 0.0001]),
    ("RAD_TAN_THIN_PRISM_FISHEYE", 640, 480,
     [241.0, 241.5, 318.5, 241.5, 0.39, -0.38, 0.05, 0.12, -0.1, 0.02,
      0.0005, -0.0004, -0.0007, 0.0002, 0.0003, -0.0001]),
    ("RAD_TAN_THIN_PRISM_FISHEYE", 640, 480,
     [200.0, 200.5, 321.5, 238.5, 0.12, -0.05, 0.012, -0.002, 0.0003, -0.00002,
      0.0004, -0.0003, -0.0006, 0.0001, 0.0002, -0.0001]),
    ("SIMPLE_DIVISION", 640, 480, [500.0, 320.0, 240.0, -0.1]),
    ("SIMPLE_DIVISION", 640, 480, [300.0, 320.0, 240.0, -0.5]),
    ("SIMPLE_DIVISION", 640, 480, [300.0, 320.0, 240.0, 0.8]),
    ("DIVISION", 640, 480, [500.0, 510.0, 320.0, 240.0, -0.15]),
    ("DIVISION", 640, 480, [280.0, 285.0, 320.0, 240.0, -0.6]),
    ("SIMPLE_FISHEYE", 640, 480, [300.0, 320.0, 240.0]),
    ("SIMPLE_FISHEYE", 640, 480, [200.0, 320.0, 240.0]),
    ("FISHEYE", 640, 480, [300.0, 305.0, 320.0, 240.0]),
    ("FISHEYE", 640, 480, [190.0, 195.0, 322.0, 238.0]),
    ("EUCM", 640, 480, [400.0, 402.0, 320.0, 240.0, 0.5, 1.0]),
    ("EUCM", 640, 480, [250.0, 250.0, 320.0, 240.0, 0.65, 1.2]),
    ("EQUIRECTANGULAR", 1000, 500, [1000.0, 500.0]),
    ("EQUIRECTANGULAR", 640, 320, [640.0, 320.0]),
]

# Points that probe where projection fails: on the axis, behind the camera, in the
# camera plane, just above COLMAP's depth threshold (eps = 2.2e-16) and just below it.
SPECIAL_POINTS = [
    (0.0, 0.0, 1.0),
    (0.0, 0.0, -1.0),
    (1.0, 0.0, -0.5),
    (0.1, 0.0, -0.5),
    (-0.4, 0.3, -2.0),
    (1.0, -1.0, 0.0),
    (0.3, -0.2, 1e-17),
    (0.3, -0.2, 3e-16),
    (0.0, 0.0, 0.0),
]


def fmt(values):
    return " ".join(repr(float(v)) for v in values)


def groups(first, inverse):
    """`first` and `inverse(first)` as output groups (see the module docstring)."""
    if first is None:
        return "none"
    second = inverse(first) if np.all(np.isfinite(first)) else None
    return fmt(first) + " " + ("none" if second is None else fmt(second))


def main():
    print(f"# pycolmap {pycolmap.__version__} camera reference; generated by "
          "gen_pycolmap_reference.py, do not edit")
    rng = np.random.default_rng(20261122)
    for model, width, height, params in CAMERAS:
        cam = pycolmap.Camera(model=model, width=width, height=height, params=params)
        print(f"camera {model} {width} {height} {fmt(params)}")

        points = list(SPECIAL_POINTS)
        for _ in range(16):
            # Angle off axis up to 100 degrees (past the 90 degree limit of most
            # models), uniform azimuth, depth 0.3..30.
            theta = math.radians(rng.uniform(0.0, 100.0))
            phi = rng.uniform(-math.pi, math.pi)
            depth = rng.uniform(0.3, 30.0)
            points.append((depth * math.sin(theta) * math.cos(phi),
                           depth * math.sin(theta) * math.sin(phi),
                           depth * math.cos(theta)))
        for x in points:
            xy = cam.img_from_cam(np.array(x, dtype=np.float64))
            print(f"project {fmt(x)} " + groups(xy, lambda xy: cam.cam_ray_from_img(xy)))

        pixels = [(params[-2], params[-1]) if model != "EQUIRECTANGULAR"
                  else (width / 2.0, height / 2.0)]
        # A jittered grid over the image and its surroundings, so the edge of each
        # model's domain is crossed.
        for i in range(6):
            for j in range(5):
                pixels.append(((i + rng.uniform(0.1, 0.9)) / 6.0 * 1.3 * width - 0.15 * width,
                               (j + rng.uniform(0.1, 0.9)) / 5.0 * 1.3 * height - 0.15 * height))
        for xy in pixels:
            xy = np.array(xy, dtype=np.float64)
            uv = cam.cam_from_img(xy)
            print(f"lift {fmt(xy)} "
                  + groups(uv, lambda uv: cam.img_from_cam(np.array([uv[0], uv[1], 1.0]))))
            ray = cam.cam_ray_from_img(xy)
            print(f"ray {fmt(xy)} " + groups(ray, cam.img_from_cam))


if __name__ == "__main__":
    main()
