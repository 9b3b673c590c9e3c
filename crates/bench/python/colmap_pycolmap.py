"""The pycolmap side of `pl2map bench colmap`: reads the COLMAP model given as argv[1]
argv[2] times and prints the best wall and CPU seconds (run by crates/bench/src/cli/colmap.rs)."""
import sys, time
import pycolmap
path, repeats = sys.argv[1], int(sys.argv[2])
best, best_cpu = float("inf"), float("inf")
for _ in range(repeats):
    t0, c0 = time.perf_counter(), time.process_time()
    rec = pycolmap.Reconstruction(path)
    best = min(best, time.perf_counter() - t0)
    best_cpu = min(best_cpu, time.process_time() - c0)
    counts = (rec.num_points3D(), rec.num_reg_images(), rec.compute_num_observations())
    del rec
print(best, best_cpu, *counts, pycolmap.__version__)
