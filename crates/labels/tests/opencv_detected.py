"""Counts, with pycolmap and OpenCV's Python SIFT (independent of pl2map), what
`[import] point_labels = "detected"` should keep of a COLMAP model: the model keypoints
with an OpenCV SIFT detection within R px, and those of them with a 3D point.

Usage: opencv_detected.py MODEL_DIR IMAGE_ROOT R
Prints one JSON object: keypoints, keypoints_kept, labels, labels_kept.

Positions in COLMAP's convention (pixel centre at 0.5): OpenCV's keypoint + 0.5, minus
the 0.25 px that OpenCV's x2 upsampled first octave adds (crates/features/src/sift.rs,
UPSAMPLING_BIAS). Detection as the front-end's default: SIFT_create(0, 3, 0.04, 10, 1.6)
on the image read as grey by OpenCV; the front-end's top-K (4096) is above every count.
"""
import json
import sys

import cv2
import numpy as np
import pycolmap

model, root, radius = sys.argv[1], sys.argv[2], float(sys.argv[3])
rec = pycolmap.Reconstruction(model)
sift = cv2.SIFT_create(0, 3, 0.04, 10, 1.6)
out = dict(keypoints=0, keypoints_kept=0, labels=0, labels_kept=0)
for im in rec.images.values():
    grey = cv2.imread(f"{root}/{im.name}", cv2.IMREAD_GRAYSCALE)
    if grey is None:
        sys.exit(f"cannot read {root}/{im.name}")
    det = np.array([[k.pt[0] + 0.25, k.pt[1] + 0.25] for k in sift.detect(grey, None)])
    xy = np.array([p.xy for p in im.points2D]).reshape(-1, 2)
    has = np.array([p.has_point3D() for p in im.points2D], dtype=bool)
    if len(det) == 0 or len(xy) == 0:
        near = np.zeros(len(xy), dtype=bool)
    else:
        # Brute force: a few thousand points a side.
        d2 = ((xy[:, None, :] - det[None, :, :]) ** 2).sum(-1)
        near = d2.min(1) <= radius * radius
    out["keypoints"] += len(xy)
    out["keypoints_kept"] += int(near.sum())
    out["labels"] += int(has.sum())
    out["labels_kept"] += int((near & has).sum())
print(json.dumps(out))
