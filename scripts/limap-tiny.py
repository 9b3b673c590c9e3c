#!/usr/bin/env python3
"""Runs the real SfM tools on a synthetic scene with known poses and writes their outputs.

Usage: limap-tiny.py [--pairs-from-poses N] SCENE OUT
       (run with the LIMAP venv's python, scripts/setup-python.sh)

SCENE is a scene folder of `pl2map synth OUT --tiny` (or without --tiny): its
`sfm_gt/colmap/` model gives the training images, cameras and known poses (its points are
not used). OUT receives:

  colmap/database.db, colmap/sparse/   pycolmap SIFT extraction, exhaustive matching (or
                                       --pairs-from-poses N: pairs.txt) and
                                       point triangulation with the known poses;
  limap/                               LIMAP 2.0's output folder: final_model/ (the point
                                       model and structures/*.bin), frontend/ (the LSD
                                       segments; LIMAP's clean-up is off), metainfos.txt,
                                       structure_database.db;
  report.json                          what the tools report through their Python API
                                       (points, 3D lines with their supports, 2D lines per
                                       image) and the time of each step.

LIMAP's own runners import hloc (not on the package index), so its line steps are called
one by one as its structure triangulation runner calls them with
`use_exhaustive_line_matching` and without groups: LSD detection (pytlsd), the structure
database, neighbours from the triangulated points (metainfos.txt), then global line
triangulation pairing each line with every line of the neighbouring images.
"""

import argparse
import json
import math
import shutil
import sys
import time
from pathlib import Path

import pycolmap

import limap.geometry
import limap.image.line
import limap.runners
import limap.scene
import limap.sfm
from limap.image.line import LineDetectionOptions
from limap.runners.pipeline_steps import MetaInfoComputerOptions
from limap.sfm.pipelines import global_line_triangulation

LSD = "lsd"


def log(msg):
    print(f"[limap-tiny] {msg}", file=sys.stderr, flush=True)


def known_poses(scene: Path) -> pycolmap.Reconstruction:
    model = scene / "sfm_gt" / "colmap"
    if not (model / "images.bin").is_file():
        sys.exit(f"{model}: no COLMAP model (render the scene with `pl2map synth`)")
    return pycolmap.Reconstruction(model)


def write_database(recon: pycolmap.Reconstruction, path: Path):
    """An empty database holding the model's cameras, rigs, frames and images with their
    ids, so that the features and the triangulated model keep the model's image ids."""
    with pycolmap.Database.open(path) as db:
        for camera_id in sorted(recon.cameras):
            db.write_camera(recon.cameras[camera_id], use_camera_id=True)
        for rig_id in sorted(recon.rigs):
            db.write_rig(recon.rigs[rig_id], use_rig_id=True)
        for frame_id in sorted(recon.frames):
            db.write_frame(recon.frames[frame_id], use_frame_id=True)
        for image_id in sorted(recon.images):
            db.write_image(recon.images[image_id], use_image_id=True)


def nearest_pairs(known: pycolmap.Reconstruction, n: int, max_angle_deg: float = 30.0):
    """Like hloc's pairs_from_poses: each image with its n nearest camera centres among
    the images whose viewing direction is within max_angle_deg; unordered pairs, sorted."""
    ids = sorted(known.images)
    centres = {i: known.images[i].projection_center() for i in ids}
    axes = {i: known.images[i].viewing_direction() for i in ids}
    cos_max = math.cos(math.radians(max_angle_deg))
    pairs = set()
    for i in ids:
        near = sorted(
            (float(((centres[i] - centres[j]) ** 2).sum()), j)
            for j in ids
            if j != i and float(axes[i] @ axes[j]) >= cos_max
        )
        for _, j in near[:n]:
            a, b = known.images[i].name, known.images[j].name
            pairs.add((min(a, b), max(a, b)))
    return sorted(pairs)


def point_triangulation(
    scene: Path, known: pycolmap.Reconstruction, out: Path, times, pairs_from_poses=None
):
    colmap_dir = out / "colmap"
    if colmap_dir.exists():
        shutil.rmtree(colmap_dir)
    colmap_dir.mkdir(parents=True)
    db_path = colmap_dir / "database.db"
    names = [known.images[i].name for i in sorted(known.images)]

    t = time.monotonic()
    write_database(known, db_path)
    extraction = pycolmap.FeatureExtractionOptions()
    extraction.num_threads = 2
    pycolmap.extract_features(
        db_path,
        scene,
        image_names=names,
        extraction_options=extraction,
        device=pycolmap.Device.cpu,
    )
    times["sift_extraction_s"] = time.monotonic() - t

    t = time.monotonic()
    matching = pycolmap.FeatureMatchingOptions()
    matching.num_threads = 2
    if pairs_from_poses is None:
        pycolmap.match_exhaustive(
            db_path, matching_options=matching, device=pycolmap.Device.cpu
        )
        times["exhaustive_matching_s"] = time.monotonic() - t
    else:
        pairs = colmap_dir / "pairs.txt"
        pairs.write_text(
            "".join(f"{a} {b}\n" for a, b in nearest_pairs(known, pairs_from_poses))
        )
        pycolmap.match_image_pairs(
            db_path,
            matching_options=matching,
            pairing_options=pycolmap.ImportedPairingOptions(match_list_path=pairs),
            device=pycolmap.Device.cpu,
        )
        times["pairs_from_poses_matching_s"] = time.monotonic() - t

    t = time.monotonic()
    sparse = colmap_dir / "sparse"
    sparse.mkdir()
    recon = pycolmap.Reconstruction(known)
    options = pycolmap.IncrementalPipelineOptions()
    options.num_threads = 2
    options.min_num_matches = 1
    recon = pycolmap.triangulate_points(
        recon, db_path, scene, sparse, clear_points=True, options=options
    )
    times["point_triangulation_s"] = time.monotonic() - t
    return recon, db_path, sparse


def restore_keypoints(recon: pycolmap.Reconstruction, db_path: Path):
    """Images the triangulator left without keypoints get theirs from the database, as
    LIMAP's runner does, so that each structure's keypoint count matches the model."""
    restored = 0
    with pycolmap.Database.open(db_path) as db:
        for image_id, image in recon.images.items():
            if image.num_points2D() > 0:
                continue
            keypoints = db.read_keypoints(image_id)
            if len(keypoints) == 0:
                continue
            points = pycolmap.Point2DList()
            for row in keypoints:
                p = pycolmap.Point2D()
                p.xy = row[:2]
                points.append(p)
            image.points2D = points
            restored += 1
    return restored


def line_triangulation(scene: Path, recon, sparse: Path, out: Path, times):
    limap_dir = out / "limap"
    if limap_dir.exists():
        shutil.rmtree(limap_dir)
    limap_dir.mkdir(parents=True)

    # Neighbours and depth ranges from the triangulated points, cached where LIMAP keeps
    # them (COLMAPMVSModel reads <dir>/sparse and <dir>/images).
    t = time.monotonic()
    mvs = limap_dir / "point_triangulation"
    mvs.mkdir()
    (mvs / "sparse").symlink_to(sparse.resolve())
    (mvs / "images").symlink_to(scene.resolve())
    meta = MetaInfoComputerOptions()
    meta.cache_file = limap_dir / "metainfos.txt"
    neighbors, _ranges = limap.runners.compute_metainfos(mvs, meta)
    times["metainfos_s"] = time.monotonic() - t

    # LSD (pytlsd) on every image, segments saved under frontend/line_detections/lsd/.
    t = time.monotonic()
    detection = LineDetectionOptions()
    detection.detector_method = LSD
    detection.extractor_method = None
    detection.compute_descinfo = False
    detection.skip_exists = False
    image_paths = {i: scene / img.name for i, img in recon.images.items()}
    all_segs, _ = limap.image.line.line_detection(
        image_paths, limap_dir / "frontend" / "line_detections", detection
    )
    times["lsd_s"] = time.monotonic() - t

    t = time.monotonic()
    structure_db_path = limap_dir / "structure_database.db"
    limap.scene.create_structure_db(structure_db_path)
    with limap.scene.StructureDatabase.open(structure_db_path) as structure_db:
        limap.scene.initialize_structures_from_reconstruction(structure_db, recon)
        limap.scene.import_line_detections(
            structure_db, limap.geometry.get_all_lines_2d(all_segs)
        )

    options = limap.sfm._sfm.GlobalLineTriangulationOptions()
    options.var2d = limap.image.line.get_uncertainty2d(LSD)
    holistic = global_line_triangulation(
        recon, structure_db_path, options, exhaustive_match_neighbors=neighbors
    )
    final = limap_dir / "final_model"
    final.mkdir()
    holistic.write(final)
    times["line_triangulation_s"] = time.monotonic() - t
    shutil.rmtree(mvs)
    return limap_dir, holistic, all_segs


def report(recon, holistic, all_segs, limap_dir: Path, times):
    """The counts through LIMAP's and pycolmap's own API, read back from final_model/."""
    back = limap.scene.HolisticReconstruction()
    back.read(limap_dir / "final_model")
    structure = back.structure_recon
    lines = []
    for line_id in sorted(structure.line3D_ids()):
        line = structure.line(line_id)
        supports = [[int(e.image_id), int(e.point2D_idx)] for e in line.track.elements]
        lines.append(
            {
                "id": int(line_id),
                "supports": supports,
                "n_images": len({s[0] for s in supports}),
            }
        )
    in_memory = holistic.structure_recon.num_lines3D()
    assert in_memory == len(lines), (in_memory, len(lines))
    structures2d = structure.structures2d
    point_model = back.point_recon
    return {
        "images": {
            str(i): point_model.images[i].name for i in sorted(point_model.images)
        },
        "points3d": point_model.num_points3D(),
        "observations": point_model.compute_num_observations(),
        "mean_track_length": point_model.compute_mean_track_length(),
        "lines2d_per_image": {
            str(i): structures2d[i].num_lines() for i in sorted(structures2d)
        },
        "segments_per_image": {str(i): int(len(s)) for i, s in sorted(all_segs.items())},
        "lines3d": lines,
        "tracks_in_4_images": sum(1 for line in lines if line["n_images"] >= 4),
        "versions": {
            "pycolmap": pycolmap.__version__,
            "limap": getattr(limap, "__version__", "unknown"),
        },
        "times_s": times,
    }


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("scene", type=Path)
    parser.add_argument("out", type=Path)
    parser.add_argument(
        "--pairs-from-poses",
        type=int,
        metavar="N",
        help="match each image with its N nearest (camera centre, viewing directions "
        "within 30 deg, like hloc's pairs_from_poses) instead of every other image",
    )
    args = parser.parse_args()
    times = {}
    known = known_poses(args.scene)
    log(f"{known.num_images()} images with known poses")
    recon, db_path, sparse = point_triangulation(
        args.scene, known, args.out, times, args.pairs_from_poses
    )
    restored = restore_keypoints(recon, db_path)
    log(
        f"points: {recon.num_points3D()} (mean track length "
        f"{recon.compute_mean_track_length():.2f}), keypoints restored in {restored} images"
    )
    limap_dir, holistic, all_segs = line_triangulation(
        args.scene, recon, sparse, args.out, times
    )
    result = report(recon, holistic, all_segs, limap_dir, times)
    result["matching"] = (
        "exhaustive"
        if args.pairs_from_poses is None
        else f"pairs_from_poses {args.pairs_from_poses}"
    )
    log(
        f"3D lines: {len(result['lines3d'])}, in >= 4 images: "
        f"{result['tracks_in_4_images']}"
    )
    (args.out / "report.json").write_text(json.dumps(result, indent=1) + "\n")


if __name__ == "__main__":
    main()
