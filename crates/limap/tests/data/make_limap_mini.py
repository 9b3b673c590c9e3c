#!/usr/bin/env python3
"""Builds the `limap-mini/` fixture: a small LIMAP line-triangulation output folder.

The scene is synthetic (a table and a door frame seen by 6 pinhole cameras, 7-Scenes
intrinsics), but every file is laid out byte for byte the way LIMAP writes it:

- image_list.txt        `number of images, N` then `id, name` (util/io.py save_txt_imname_dict)
- metainfos.txt         neighbours and ranges (save_txt_metainfos); not read by the crate
- line_detections/lsd/segments/segments_<id>.txt
                        N, then `x1 y1 x2 y2` with Python's float repr (save_txt_segments)
- finaltracks/track_<i>.txt
                        C++ std::fixed, precision 10, every value followed by a space,
                        with node_id_list / score_list / line3d_list as the triangulator
                        and the bundle adjustment fill them (base/linetrack.cc Write)
- alltracks.txt         tracks seen in >= 4 images, renumbered, endpoint values separated
                        by one space + the 18-space continuation indent of LIMAP's f-string
                        (save_txt_linetracks)

It also writes limap-mini.expected.json: counts and statistics computed here, in Python,
for the Rust tests to compare against. Standard library only; deterministic.

    python3 make_limap_mini.py      # rewrites limap-mini/ and limap-mini.expected.json
"""

import json
import math
import os
import random
import shutil
import statistics

HERE = os.path.dirname(os.path.abspath(__file__))
OUT = os.path.join(HERE, "limap-mini")
WIDTH, HEIGHT = 640, 480
FOCAL, CX, CY = 525.0, 320.0, 240.0
rng = random.Random(20261122)

# 3D segments in metres: a table (top edges, legs) and a door frame behind it.
LINES = [
    ((-0.6, -0.4, 0.75), (0.6, -0.4, 0.75)),
    ((0.6, -0.4, 0.75), (0.6, 0.4, 0.75)),
    ((0.6, 0.4, 0.75), (-0.6, 0.4, 0.75)),
    ((-0.6, 0.4, 0.75), (-0.6, -0.4, 0.75)),
    ((-0.55, -0.35, 0.0), (-0.55, -0.35, 0.72)),
    ((0.55, -0.35, 0.0), (0.55, -0.35, 0.72)),
    ((-0.45, 1.5, 0.0), (-0.45, 1.5, 2.05)),
    ((0.45, 1.5, 0.0), (0.45, 1.5, 2.05)),
    ((-0.45, 1.5, 2.05), (0.45, 1.5, 2.05)),
    ((-1.8, 1.5, 2.4), (1.8, 1.5, 2.4)),
]


def sub(a, b):
    return [a[i] - b[i] for i in range(3)]


def cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def unit(a):
    n = math.sqrt(sum(x * x for x in a))
    return [x / n for x in a]


def look_at(centre, target):
    """World-to-camera rotation rows (x right, y down, z forward) and translation."""
    z = unit(sub(target, centre))
    x = unit(cross(z, [0.0, 0.0, 1.0]))
    y = cross(z, x)
    rot = [x, y, z]
    t = [-sum(rot[r][k] * centre[k] for k in range(3)) for r in range(3)]
    return rot, t


def project(cam, p):
    rot, t = cam
    q = [sum(rot[r][k] * p[k] for k in range(3)) + t[r] for r in range(3)]
    return q[2], FOCAL * q[0] / q[2] + CX, FOCAL * q[1] / q[2] + CY


def clip(a, b):
    """Liang-Barsky clip of the 2D segment ab to the image; None when outside."""
    t0, t1 = 0.0, 1.0
    d = (b[0] - a[0], b[1] - a[1])
    for p, q in ((-d[0], a[0]), (d[0], WIDTH - a[0]), (-d[1], a[1]), (d[1], HEIGHT - a[1])):
        if p == 0:
            if q < 0:
                return None
        else:
            r = q / p
            if p < 0:
                t0 = max(t0, r)
            else:
                t1 = min(t1, r)
    if t0 >= t1:
        return None
    return t0, t1


def detect(cam, line, lo=0.0, hi=1.0):
    """A noisy, slightly shortened detection of the part [lo, hi] of a 3D segment."""
    za, ua, va = project(cam, line[0])
    zb, ub, vb = project(cam, line[1])
    if za < 0.2 or zb < 0.2:
        return None
    span = clip((ua, va), (ub, vb))
    if span is None:
        return None
    s = max(span[0], lo) + rng.uniform(0.01, 0.06)
    e = min(span[1], hi) - rng.uniform(0.01, 0.06)
    if e <= s:
        return None
    seg = [ua + s * (ub - ua), va + s * (vb - va), ua + e * (ub - ua), va + e * (vb - va)]
    seg = [v + rng.gauss(0.0, 0.3) for v in seg]
    if math.hypot(seg[2] - seg[0], seg[3] - seg[1]) < 15.0:
        return None
    return seg


def fixed(x):
    # iostream std::fixed << setprecision(10) prints like printf("%.10f"); LIMAP writes
    # a NaN endpoint as 0.
    return "%.10f" % (0.0 if math.isnan(x) else x)


def main():
    centres = [
        [2.6, -2.2, 1.6],
        [1.4, -3.0, 1.5],
        [0.0, -3.3, 1.7],
        [-1.3, -3.0, 1.4],
        [-2.5, -2.3, 1.6],
        [-3.0, -0.6, 1.8],
    ]
    image_ids = [1, 2, 3, 4, 5, 6]
    names = {
        1: "stairs/seq-02/frame-000000.color.png",
        2: "stairs/seq-02/frame-000020.color.png",
        3: "stairs/seq-02/frame-000040.color.png",
        4: "stairs/seq-03/frame-000000.color.png",
        5: "stairs/seq-03/frame-000020.color.png",
        6: "stairs/seq-03/frame-000040.color.png",
    }
    cams = {i: look_at(c, [0.0, 0.6, 0.9]) for i, c in zip(image_ids, centres)}

    # Detections per image: (segment, source line index or None). Some lines are occluded
    # in some views, one is found in two pieces in image 3, a few are missed, and a few
    # clutter segments are added.
    occluded = {4: {1, 5, 6}, 8: {4, 5, 6}, 9: {1, 2, 3, 6}}
    detections = {}
    for img in image_ids:
        found = []
        for li, line in enumerate(LINES):
            if img in occluded.get(li, ()):
                continue
            if img == 3 and li == 2:
                pieces = [(0.0, 0.45), (0.55, 1.0)]
            elif rng.random() < 0.12:
                continue
            else:
                pieces = [(0.0, 1.0)]
            for lo, hi in pieces:
                seg = detect(cams[img], line, lo, hi)
                if seg is not None:
                    found.append((seg, li))
        for _ in range(4):
            x, y = rng.uniform(20, WIDTH - 20), rng.uniform(20, HEIGHT - 20)
            a, r = rng.uniform(0, math.pi), rng.uniform(20, 120)
            found.append(([x, y, x + r * math.cos(a), y + r * math.sin(a)], None))
        rng.shuffle(found)
        detections[img] = found

    # Graph node ids as the triangulator assigns them: one per (image, line) detection.
    node_id = {}
    for img in image_ids:
        for line_id in range(len(detections[img])):
            node_id[(img, line_id)] = len(node_id)

    tracks = []
    for li, line in enumerate(LINES):
        supports = [
            (img, line_id)
            for img in image_ids
            for line_id, (_, src) in enumerate(detections[img])
            if src == li
        ]
        if len({img for img, _ in supports}) < 2:
            continue
        endpoints = [[c + rng.gauss(0.0, 0.004) for c in p] for p in line]
        per_support = []
        for _ in supports:
            per_support.append([[c + rng.gauss(0.0, 0.01) for c in p] for p in line])
        tracks.append(
            {
                "line": endpoints,
                "supports": supports,
                "lines2d": [detections[img][lid][0] for img, lid in supports],
                "node_ids": [node_id[s] for s in supports],
                "scores": [rng.uniform(0.35, 1.0) for _ in supports],
                "lines3d": per_support,
            }
        )
    rng.shuffle(tracks)

    if os.path.exists(OUT):
        shutil.rmtree(OUT)
    seg_dir = os.path.join(OUT, "line_detections", "lsd", "segments")
    trk_dir = os.path.join(OUT, "finaltracks")
    os.makedirs(seg_dir)
    os.makedirs(trk_dir)

    with open(os.path.join(OUT, "image_list.txt"), "w") as f:
        f.write(f"number of images, {len(image_ids)}\n")
        for img in image_ids:
            f.write(f"{img}, {names[img]}\n")

    with open(os.path.join(OUT, "metainfos.txt"), "w") as f:
        f.write(f"number of images, {len(image_ids)}\n")
        for axis, (lo, hi) in zip("xyz", [(-1.9, 1.9), (-0.5, 1.6), (-0.1, 2.5)]):
            f.write(f"{axis}-range, {lo}, {hi}\n")
        for img in image_ids:
            others = sorted((o for o in image_ids if o != img), key=lambda o: abs(o - img))
            f.write(f"image {img}" + "".join(f", {o}" for o in others) + "\n")

    for img in image_ids:
        with open(os.path.join(seg_dir, f"segments_{img}.txt"), "w") as f:
            f.write(f"{len(detections[img])}\n")
            for seg, _ in detections[img]:
                f.write(f"{seg[0]} {seg[1]} {seg[2]} {seg[3]}\n")

    def n_images(t):
        return len({img for img, _ in t["supports"]})

    for k, t in enumerate(tracks):
        rows = []
        rows.append("".join(fixed(v) + " " for p in t["line"] for v in p))
        rows.append(f"{len(t['supports'])} {n_images(t)}")
        rows.append("image_id_list " + "".join(f"{img} " for img, _ in t["supports"]))
        rows.append("line_id_list " + "".join(f"{lid} " for _, lid in t["supports"]))
        rows.append("line2d_list")
        for s in t["lines2d"]:
            rows.append("".join(fixed(v) + " " for v in s))
        rows.append("node_id_list " + "".join(f"{n} " for n in t["node_ids"]))
        rows.append("score_list " + "".join(fixed(s) + " " for s in t["scores"]))
        rows.append("line3d_list")
        for l3 in t["lines3d"]:
            rows.append("".join(fixed(v) + " " for p in l3 for v in p))
        rows.append("END")
        with open(os.path.join(trk_dir, f"track_{k}.txt"), "w") as f:
            f.write("\n".join(rows) + "\n")

    kept = [t for t in tracks if n_images(t) >= 4]
    gap = " " + " " * 18
    with open(os.path.join(OUT, "alltracks.txt"), "w") as f:
        f.write(f"{len(kept)}\n")
        for k, t in enumerate(kept):
            f.write(f"{k} {len(t['supports'])} {n_images(t)}\n")
            for p in t["line"]:
                f.write(gap.join(f"{v:.10f}" for v in p) + "\n")
            f.write("".join(f"{img} " for img, _ in t["supports"]) + "\n")
            f.write("".join(f"{lid} " for _, lid in t["supports"]) + "\n")

    # Expected values, from the text as written (what a reader gets back).
    def written_length(t):
        a, b = ([float(fixed(v)) for v in p] for p in t["line"])
        return math.dist(a, b)

    def stats(values):
        return {
            "min": min(values),
            "mean": statistics.fmean(values),
            "median": statistics.median(values),
            "max": max(values),
        }

    first = tracks[0]
    expected = {
        "images": len(image_ids),
        "image_names": {str(i): names[i] for i in image_ids},
        "segments_per_image": {str(i): len(detections[i]) for i in image_ids},
        "finaltracks": len(tracks),
        "alltracks": len(kept),
        "tracks_with_4_images": len(kept),
        "supports_per_track": stats([len(t["supports"]) for t in tracks]),
        "images_per_track": stats([n_images(t) for t in tracks]),
        "length_3d": stats([written_length(t) for t in tracks]),
        "track_0": {
            "image_ids": [img for img, _ in first["supports"]],
            "line_ids": [lid for _, lid in first["supports"]],
            "node_ids": first["node_ids"],
            "line": [[float(fixed(v)) for v in p] for p in first["line"]],
        },
        "alltracks_to_finaltracks": [tracks.index(t) for t in kept],
    }
    with open(os.path.join(HERE, "limap-mini.expected.json"), "w") as f:
        json.dump(expected, f, indent=1, sort_keys=True)
        f.write("\n")


if __name__ == "__main__":
    main()
