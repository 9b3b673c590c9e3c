"""An independent PyTorch SuperPoint, written for the tests from the SuperPoint paper
(DeTone, Malisiewicz, Rabinovich, CVPRW 2018) and docs/method.md section 2b, to check the
burn implementation in crates/superpoint against.

  superpoint_torch.py weights OUT.pth SEED [legacy]
      random weights (PyTorch's default convolution init, torch.manual_seed(SEED)) saved
      as a state dict in the released file's key layout (conv1a.weight ... convDb.bias);
      `legacy` writes PyTorch's pre-1.6 (non-zip) format, as the released file has;
      `drop:KEY` leaves KEY out and `shape:KEY` cuts its first dimension (refusal tests).
  superpoint_torch.py run WEIGHTS JOB.json OUT_DIR
      JOB.json: {"image": grey PNG, "resize_max", "nms_radius", "threshold", "border",
      "max_keypoints", "keypoints": [[x, y], ...] COLMAP pixels,
      "segments": [[x1, y1, x2, y2], ...] COLMAP pixels, "samples_per_line"}.
      Writes float32 little-endian files scores.f32 (H x W), dense.f32 (256 x Hc x Wc),
      keypoints.f32 (N x 2 COLMAP pixels of the original image), kp_scores.f32,
      kp_desc.f32 (N x 256), at_points.f32 (given keypoints, K x 256),
      at_lines.f32 (M x T x 256) and meta.json (shapes).
  superpoint_torch.py bench WEIGHTS WIDTH HEIGHT REPEATS THREADS
      prints the median seconds of forward + keypoints + descriptor sampling of one
      image (random grey) on the CPU.
"""
import json
import sys
import time

import numpy as np
import torch
import torch.nn.functional as F

LAYERS = [
    ("conv1a", 64, 1, 3), ("conv1b", 64, 64, 3),
    ("conv2a", 64, 64, 3), ("conv2b", 64, 64, 3),
    ("conv3a", 128, 64, 3), ("conv3b", 128, 128, 3),
    ("conv4a", 128, 128, 3), ("conv4b", 128, 128, 3),
    ("convPa", 256, 128, 3), ("convPb", 65, 256, 1),
    ("convDa", 256, 128, 3), ("convDb", 256, 256, 1),
]


class Net(torch.nn.Module):
    def __init__(self):
        super().__init__()
        for name, cout, cin, k in LAYERS:
            setattr(self, name, torch.nn.Conv2d(cin, cout, k, padding=k // 2))

    def forward(self, x):
        for i, block in enumerate(["1", "2", "3", "4"]):
            x = F.relu(getattr(self, "conv" + block + "a")(x))
            x = F.relu(getattr(self, "conv" + block + "b")(x))
            if i < 3:
                x = F.max_pool2d(x, 2, 2)
        p = self.convPb(F.relu(self.convPa(x)))
        n, _, hc, wc = p.shape
        p = torch.softmax(p, 1)[:, :64]
        # channel 8*dy + dx of a cell -> pixel (8*i + dy, 8*j + dx)
        scores = p.reshape(n, 8, 8, hc, wc).permute(0, 3, 1, 4, 2).reshape(n, hc * 8, wc * 8)
        d = self.convDb(F.relu(self.convDa(x)))
        d = F.normalize(d, p=2, dim=1)
        return scores, d


def nms(scores, r):
    pool = lambda s: F.max_pool2d(s[None], 2 * r + 1, 1, r)[0]
    keep = scores == pool(scores)
    for _ in range(2):
        supp = pool(keep.float()) > 0
        rest = torch.where(supp, torch.zeros_like(scores), scores)
        keep = keep | ((rest == pool(rest)) & ~supp)
    return torch.where(keep, scores, torch.zeros_like(scores))


def sample(dense, xy_idx):
    """Bilinear samples of dense [C, Hc, Wc] at pixel-index positions [K, 2]."""
    c, hc, wc = dense.shape
    s = 8
    g = xy_idx.clone().float()
    g[:, 0] = (g[:, 0] - s / 2 + 0.5) / (wc * s - s / 2 - 0.5)
    g[:, 1] = (g[:, 1] - s / 2 + 0.5) / (hc * s - s / 2 - 0.5)
    g = g * 2 - 1
    out = F.grid_sample(dense[None], g[None, None], mode="bilinear", align_corners=True)
    return F.normalize(out[0, :, 0].t(), p=2, dim=1)


def prepare(gray_u8, resize_max):
    import cv2
    img = gray_u8.astype(np.float32) / 255.0
    h, w = img.shape
    scale = (1.0, 1.0)
    if resize_max and max(w, h) > resize_max:
        f = resize_max / max(w, h)
        nw, nh = max(int(round(w * f)), 8), max(int(round(h * f)), 8)
        img = cv2.resize(img, (nw, nh), interpolation=cv2.INTER_AREA)
        scale = (w / nw, h / nh)
    return img, scale


def detect(net, img, job):
    with torch.no_grad():
        scores, dense = net(torch.from_numpy(img)[None, None])
    scores, dense = scores[0], dense[0]
    s = nms(scores, job["nms_radius"])
    b = job["border"]
    h, w = s.shape
    ys, xs = torch.nonzero(s > job["threshold"], as_tuple=True)
    keep = (ys >= b) & (ys < h - b) & (xs >= b) & (xs < w - b)
    ys, xs = ys[keep], xs[keep]
    vals = s[ys, xs]
    k = min(job["max_keypoints"], len(vals))
    vals, order = torch.topk(vals, k)
    kp = torch.stack([xs[order], ys[order]], 1).float()
    return scores, dense, kp, vals


def write(path, arr):
    np.ascontiguousarray(arr, dtype="<f4").tofile(path)


def run(weights, job_path, out):
    import cv2
    job = json.load(open(job_path))
    net = Net()
    net.load_state_dict(torch.load(weights, map_location="cpu"))
    net.eval()
    gray = cv2.imread(job["image"], cv2.IMREAD_UNCHANGED)
    img, scale = prepare(gray, job["resize_max"])
    scores, dense, kp, vals = detect(net, img, job)
    with torch.no_grad():
        kp_desc = sample(dense, kp)
        sx, sy = scale
        to_idx = lambda p: torch.stack([p[:, 0] / sx - 0.5, p[:, 1] / sy - 0.5], 1)
        given = torch.tensor(job["keypoints"], dtype=torch.float64).reshape(-1, 2)
        at_points = sample(dense, to_idx(given).float())
        t = job["samples_per_line"]
        segs = torch.tensor(job["segments"], dtype=torch.float64).reshape(-1, 4)
        k = torch.arange(t, dtype=torch.float64) / (t - 1)
        pts = segs[:, None, :2] + k[None, :, None] * (segs[:, None, 2:] - segs[:, None, :2])
        at_lines = sample(dense, to_idx(pts.reshape(-1, 2)).float())
    kp_colmap = torch.stack([(kp[:, 0] + 0.5) * sx, (kp[:, 1] + 0.5) * sy], 1)
    write(f"{out}/scores.f32", scores.numpy())
    write(f"{out}/dense.f32", dense.numpy())
    write(f"{out}/keypoints.f32", kp_colmap.numpy())
    write(f"{out}/kp_scores.f32", vals.numpy())
    write(f"{out}/kp_desc.f32", kp_desc.numpy())
    write(f"{out}/at_points.f32", at_points.numpy())
    write(f"{out}/at_lines.f32", at_lines.numpy())
    json.dump({"scores": list(scores.shape), "dense": list(dense.shape),
               "keypoints": int(kp.shape[0]), "network_size": [img.shape[1], img.shape[0]]},
              open(f"{out}/meta.json", "w"))


def bench(weights, width, height, repeats, threads):
    torch.set_num_threads(threads)
    net = Net()
    net.load_state_dict(torch.load(weights, map_location="cpu"))
    net.eval()
    rng = np.random.default_rng(0)
    img = rng.random((height, width), dtype=np.float32)
    job = {"nms_radius": 3, "threshold": 0.005, "border": 4, "max_keypoints": 2048}
    times = []
    for _ in range(repeats + 1):
        t = time.perf_counter()
        _, dense, kp, _ = detect(net, img, job)
        with torch.no_grad():
            sample(dense, kp)
        times.append(time.perf_counter() - t)
    times = sorted(times[1:])
    print(json.dumps({"median_s": times[len(times) // 2], "torch": torch.__version__,
                      "threads": torch.get_num_threads()}))


def main():
    cmd = sys.argv[1]
    if cmd == "weights":
        torch.manual_seed(int(sys.argv[3]))
        net = Net()
        # A little more contrast than the default init, so that the random network's
        # score maps have peaks above the detection threshold.
        with torch.no_grad():
            for name, *_ in LAYERS:
                getattr(net, name).weight.mul_(2.0)
        opt = sys.argv[4] if len(sys.argv) > 4 else ""
        state = net.state_dict()
        if opt.startswith("drop:"):
            del state[opt[5:]]
        if opt.startswith("shape:"):
            state[opt[6:]] = state[opt[6:]][:-1]
        torch.save(state, sys.argv[2], _use_new_zipfile_serialization=opt != "legacy")
    elif cmd == "run":
        run(sys.argv[2], sys.argv[3], sys.argv[4])
    elif cmd == "bench":
        bench(sys.argv[2], int(sys.argv[3]), int(sys.argv[4]), int(sys.argv[5]), int(sys.argv[6]))
    else:
        sys.exit(f"unknown command {cmd}")


if __name__ == "__main__":
    main()
