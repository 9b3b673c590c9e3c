"""The package yields exactly the Rust reader's records: in reading order (ShardSet.read)
and in the seeded order (ShardDataset), every array bit for bit.

usage: same_records.py SHARD_DIR EXPECTED_JSON  (written by tests/python_package.rs)
"""

import hashlib
import json
import sys

import numpy as np

import pl2map_shards as ps


def as_bits(values):
    return np.asarray(values, dtype=np.uint64)


def f64_bits(array):
    a = np.ascontiguousarray(array, dtype=np.float64)
    return a.reshape(-1).view(np.uint64)


def check(frame, want, where):
    def same(key, got, expected):
        assert np.array_equal(got, expected), f"{where}, frame {want['frame_id']}: {key} differs"

    for key in ("frame_id", "name", "split", "image_format", "label_source", "endpoints_aligned"):
        same(key, frame[key], want[key])
    same("image", hashlib.sha256(frame["image"]).hexdigest(), want["image_sha256"])
    cam = frame["camera"]
    same("camera model", cam["model"], want["camera_model"])
    same("camera size", (cam["width"], cam["height"]), (want["width"], want["height"]))
    same("camera params", f64_bits(cam["params"]), as_bits(want["params"]))
    same("qvec", f64_bits(frame["pose"]["qvec"]), as_bits(want["qvec"]))
    same("tvec", f64_bits(frame["pose"]["tvec"]), as_bits(want["tvec"]))
    n, m = len(want["point_valid"]), len(want["line_valid"])
    shapes = {
        "keypoints": (n, 2),
        "keypoints_normalized": (n, 2),
        "points3d": (n, 3),
        "point3d_ids": (n,),
        "point_valid": (n,),
        "segments": (m, 4),
        "lines3d": (m, 6),
        "track_ids": (m,),
        "line_valid": (m,),
    }
    for key, shape in shapes.items():
        assert frame[key].shape == shape, f"{where}: {key} has shape {frame[key].shape}, not {shape}"
    for key in ("keypoints", "points3d", "segments", "lines3d"):
        assert frame[key].dtype == np.float64, key
        same(key, f64_bits(frame[key]), as_bits(want[key]))
    for key in ("point3d_ids", "track_ids"):
        assert frame[key].dtype == np.int64, key
        same(key, frame[key], np.asarray(want[key], dtype=np.int64))
    for key in ("point_valid", "line_valid"):
        assert frame[key].dtype == np.bool_, key
        same(key, frame[key], np.asarray(want[key], dtype=bool))
    # The rotation matrix agrees with the quaternion.
    w, x, y, z = frame["pose"]["qvec"]
    r = np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )
    assert np.allclose(frame["pose"]["R"], r, atol=1e-12), where


def main():
    folder, expected_path = sys.argv[1], sys.argv[2]
    with open(expected_path) as f:
        expected = json.load(f)
    counts = {}
    for split in ("train", "test"):
        want = expected[split]
        shards = ps.ShardSet(folder, split)
        assert len(shards) == len(want["reading_order"])
        assert list(shards.frame_ids) == [w["frame_id"] for w in want["reading_order"]]
        for i, w in enumerate(want["reading_order"]):
            check(shards.read(i), w, f"{split} reading order {i}")
            check(shards.read_id(w["frame_id"]), w, f"{split} frame {w['frame_id']}")

        ds = ps.ShardDataset(folder, split, seed=expected["seed"], rank=0, world_size=1)
        ds.set_epoch(expected["epoch"])
        got = list(ds)
        assert [g["frame_id"] for g in got] == [w["frame_id"] for w in want["shuffled"]], (
            f"{split}: order {[g['frame_id'] for g in got]}"
        )
        for i, (g, w) in enumerate(zip(got, want["shuffled"])):
            check(g, w, f"{split} shuffled position {i}")
        # The same seed and epoch give the same order again; another epoch another one.
        assert [g["frame_id"] for g in ds] == [g["frame_id"] for g in got]
        ds.set_epoch(expected["epoch"] + 1)
        if len(got) > 2:
            assert [g["frame_id"] for g in ds] != [g["frame_id"] for g in got]
        # Decoded pixels: the image's size, 8-bit.
        frame = shards.read(0, decode_image=True)
        px = frame["pixels"]
        assert px.dtype == np.uint8 and px.shape[:2] == (frame["camera"]["height"], frame["camera"]["width"]), px.shape
        counts[split] = len(got)
    print(f"same records: {counts['train']} train, {counts['test']} test")


if __name__ == "__main__":
    main()
