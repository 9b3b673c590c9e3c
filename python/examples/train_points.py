#!/usr/bin/env python3
"""Train a small PyTorch regression of 3D points from pl2map shards.

Each valid point label of a training frame gives one sample: the input is the camera
centre and the keypoint's viewing ray in world coordinates (from the frame's camera and
pose), the target the labelled 3D point. A small MLP learns where the rays meet the
scene, the way a scene-coordinate network does with image features instead. The frames
come from pl2map_shards.ShardDataset through a torch DataLoader with workers, in the
seeded order every rank and worker agrees on.

usage: train_points.py SHARD_DIR [--steps 300] [--batch 4] [--workers 2] [--seed 0]
Prints the loss every 50 steps and, last, one JSON line: steps, first and last loss.
"""

import argparse
import json

import numpy as np
import torch
from torch.utils.data import DataLoader

import pl2map_shards as ps


def rays(frame):
    """Camera centre and unit viewing rays (world frame) of the frame's valid points,
    and their 3D labels: run in the DataLoader worker."""
    valid = frame["point_valid"]
    r = frame["pose"]["R"]  # world-to-camera
    t = frame["pose"]["tvec"]
    centre = -r.T @ t
    xy = frame["keypoints_normalized"][valid]
    d = np.concatenate([xy, np.ones((len(xy), 1))], axis=1) @ r  # = (R^T d_cam^T)^T
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    inputs = np.concatenate([np.broadcast_to(centre, d.shape), d], axis=1)
    return inputs.astype(np.float32), frame["points3d"][valid].astype(np.float32)


def collate(batch):
    """One batch: every valid point of the batch's frames."""
    x = torch.from_numpy(np.concatenate([b[0] for b in batch]))
    y = torch.from_numpy(np.concatenate([b[1] for b in batch]))
    return x, y


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("shards", help="a shard folder (<work>/shard) or an s3:// / https:// URL")
    ap.add_argument("--steps", type=int, default=300)
    ap.add_argument("--batch", type=int, default=4, help="frames per step")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--lr", type=float, default=3e-3)
    args = ap.parse_args()

    torch.manual_seed(args.seed)
    dataset = ps.ShardDataset(
        args.shards, "train", seed=args.seed, batch_size=args.batch, transform=rays
    )
    loader = DataLoader(
        dataset, batch_size=args.batch, num_workers=args.workers, collate_fn=collate
    )
    # Targets relative to the scene's centre (the mean of the first batch's points).
    first_x, first_y = next(iter(loader))
    centre = first_y.mean(dim=0)
    model = torch.nn.Sequential(
        torch.nn.Linear(6, 128),
        torch.nn.ReLU(),
        torch.nn.Linear(128, 128),
        torch.nn.ReLU(),
        torch.nn.Linear(128, 3),
    )
    opt = torch.optim.Adam(model.parameters(), lr=args.lr)
    losses, step, epoch = [], 0, 0
    while step < args.steps:
        dataset.set_epoch(epoch)
        for x, y in loader:
            if step == args.steps:
                break
            x = torch.cat([x[:, :3] - centre, x[:, 3:]], dim=1)
            loss = torch.nn.functional.l1_loss(model(x), y - centre)
            opt.zero_grad()
            loss.backward()
            opt.step()
            losses.append(loss.item())
            step += 1
            if step % 50 == 0:
                print(f"step {step:4d}  epoch {epoch:3d}  L1 {np.mean(losses[-50:]):.4f} m", flush=True)
        epoch += 1
    k = min(10, len(losses))
    print(
        json.dumps(
            {
                "steps": step,
                "epochs": epoch,
                "frames": dataset.frames,
                "first_loss": float(np.mean(losses[:k])),
                "last_loss": float(np.mean(losses[-k:])),
            }
        )
    )


if __name__ == "__main__":
    main()
