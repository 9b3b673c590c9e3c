#!/usr/bin/env python3
"""Scratch study (a measurement, not part of the product): how fast a plain MLP learns the
descriptor -> xyz lookup of the synthetic scene, by depth and width.

Data: the arrays `nn_baseline` dumps (PL2MAP_NN_DUMP=DIR cargo run --release -p train
--example nn_baseline -- MODEL.ckpt SHARDS SCENE 20 400): every labelled training
descriptor with its 3D label, and test keypoints' descriptors with their depth ground truth.
Each step: 512 random labelled training descriptors, isotropic noise of norm `nz`,
renormalised, scaled by sqrt(128); L2-distance loss; Adam with a cosine learning rate from
`lr` to lr / 2^h. Prints the test and training medians four times.

  python3 mlp_depth.py DIR l=6 w=512 s=4000   (keys: w l b s lr nz h, defaults below)
"""
import math
import sys
import time

import numpy as np
import torch

torch.manual_seed(0)
folder = sys.argv[1]
load = lambda name, cols: torch.from_numpy(
    np.fromfile(f"{folder}/{name}", dtype=np.float32).reshape(-1, cols))
td, tx = load("train_desc.f32", 128), load("train_xyz.f32", 3)
qd, qg = load("test_desc.f32", 128), load("test_gt.f32", 3)
c = tx.mean(0)
tx, qg = tx - c, qg - c
args = dict(a.split("=") for a in sys.argv[2:])
W, L = int(args.get("w", 512)), int(args.get("l", 2))
B, S = int(args.get("b", 512)), int(args.get("s", 13000))
lr, nz, halv = float(args.get("lr", 1e-3)), float(args.get("nz", 0.15)), float(args.get("h", 5))
layers, d = [], 128
for _ in range(L):
    layers += [torch.nn.Linear(d, W), torch.nn.ReLU()]
    d = W
net = torch.nn.Sequential(*layers, torch.nn.Linear(d, 3))
opt = torch.optim.Adam(net.parameters(), lr=lr)
scale = math.sqrt(128)


def evaluate():
    with torch.no_grad():
        e = (net(qd * scale) - qg).norm(dim=1)
        i = torch.randint(0, len(td), (8000,), generator=torch.Generator().manual_seed(1))
        et = (net(td[i] * scale) - tx[i]).norm(dim=1)
    return e.median().item() * 100, (e < 0.05).float().mean().item(), et.median().item() * 100


t0 = time.time()
for s in range(S):
    end = lr / 2**halv
    for g in opt.param_groups:
        g["lr"] = end + (lr - end) * 0.5 * (1 + math.cos(math.pi * s / S))
    i = torch.randint(0, len(td), (B,))
    x = td[i]
    if nz > 0:
        n = torch.randn_like(x)
        x = x + n / n.norm(dim=1, keepdim=True) * nz
        x = x / x.norm(dim=1, keepdim=True)
    loss = (net(x * scale) - tx[i]).norm(dim=1).mean()
    opt.zero_grad()
    loss.backward()
    opt.step()
    if (s + 1) % max(S // 4, 1) == 0:
        print(s + 1, "test median %.2f cm, under 5 cm %.3f, training median %.2f cm" % evaluate(),
              "%.1f s" % (time.time() - t0), flush=True)
