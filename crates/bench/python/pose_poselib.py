"""The poselib side of `pl2map bench pose`: solves each problem of the JSON file argv[1]
and prints one JSON object per line (run by crates/bench/src/cli/pose.rs)."""
import json, sys, time
import numpy as np
import poselib
assert poselib.__version__ == "2.0.5", poselib.__version__
data = json.load(open(sys.argv[1]))
out = open(sys.argv[2], "w")
for pb in data["problems"]:
    cam = pb["camera"]
    p2 = np.array(pb["points2D"], dtype=np.float64).reshape(-1, 2)
    p3 = np.array(pb["points3D"], dtype=np.float64).reshape(-1, 3)
    l2 = np.array(pb["lines2D"], dtype=np.float64).reshape(-1, 4)
    l3 = np.array(pb["lines3D"], dtype=np.float64).reshape(-1, 6)
    ransac = dict(data["ransac"], seed=pb["seed"])
    bundle = dict(data["bundle"])
    l2a, l2b = np.ascontiguousarray(l2[:, :2]), np.ascontiguousarray(l2[:, 2:])
    l3a, l3b = np.ascontiguousarray(l3[:, :3]), np.ascontiguousarray(l3[:, 3:])
    dt = float("inf")
    for _ in range(data["repeats"]):
        if len(l2) == 0:
            t0 = time.perf_counter()
            pose, info = poselib.estimate_absolute_pose(p2, p3, cam, ransac, bundle)
            dt = min(dt, time.perf_counter() - t0)
        else:
            t0 = time.perf_counter()
            pose, info = poselib.estimate_absolute_pose_pnpl(p2, p3, l2a, l2b, l3a, l3b, cam, ransac, bundle)
            dt = min(dt, time.perf_counter() - t0)
    out.write(json.dumps({"q": list(map(float, pose.q)), "t": list(map(float, pose.t)),
                          "seconds": dt, "iterations": int(info["iterations"])}) + "\n")
out.close()
