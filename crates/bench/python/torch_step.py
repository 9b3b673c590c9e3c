#!/usr/bin/env python3
"""One PL2Map training step (forward + loss + backward + Adam) in PyTorch, for comparison
with the burn implementation of crates/model (`cargo run --release -p bench --example
step_bench`). Written from docs/method.md sections 2 and 4, like the Rust crate:

- line encoder: one post-LN transformer block over T tokens (4 heads, contiguous split,
  LayerNorm eps 1e-6, FFN D->4D->D exact GELU, dropout 0.1 on attention weights, attention
  output and FFN output), line descriptor = token 0. With --token0-only, queries and
  everything after the attention are computed for token 0 only (as the Rust crate does;
  same function), otherwise for all tokens (as the reference does).
- graph: attentional propagation layers self, cross, self, cross, self; message MLP
  2D->2D->D with ReLU; one layer's weights serve both streams.
- heads D->512->1024->512->4 / ->7; r = 1/(1+|100 u|).
- losses: L_m (summed L2), L_r (L2 norm), L_pi on labelled elements weighted by the
  detached reliability, tau(t) tanh(e/tau(t)) averaged over valid elements.

Prints one JSON line: torch version, parameter count, step times, peak RSS.
"""
import argparse
import json
import math
import time

import torch
import torch.nn as nn
import torch.nn.functional as F


def status_bytes(key):
    try:
        with open("/proc/self/status") as f:
            for line in f:
                if line.startswith(key):
                    return int(line.split()[1]) * 1024
    except OSError:
        return None
    return None


def reset_peak():
    try:
        with open("/proc/self/clear_refs", "w") as f:
            f.write("5")
        return True
    except OSError:
        return False


def split_heads(x, h):
    # [..., L, D] -> [..., h, L, D/h], channels of head i contiguous
    *lead, L, D = x.shape
    return x.view(*lead, L, h, D // h).transpose(-3, -2)


def merge_heads(x):
    *lead, h, L, dk = x.shape
    return x.transpose(-3, -2).reshape(*lead, L, h * dk)


class LineEncoder(nn.Module):
    def __init__(self, d, heads, ffn, dropout, token0_only):
        super().__init__()
        self.q, self.k, self.v, self.o = (nn.Linear(d, d) for _ in range(4))
        self.norm1 = nn.LayerNorm(d, eps=1e-6)
        self.ffn1, self.ffn2 = nn.Linear(d, ffn), nn.Linear(ffn, d)
        self.norm2 = nn.LayerNorm(d, eps=1e-6)
        self.drop = nn.Dropout(dropout)
        self.heads = heads
        self.token0_only = token0_only

    def forward(self, x):  # [M, T, D] -> [M, D]
        h = self.heads
        dk = x.shape[-1] // h
        xq = x[:, :1] if self.token0_only else x
        q = split_heads(self.q(xq), h) / math.sqrt(dk)
        k = split_heads(self.k(x), h)
        v = split_heads(self.v(x), h)
        w = self.drop(torch.softmax(q @ k.transpose(-1, -2), dim=-1))
        a = self.norm1(self.drop(self.o(merge_heads(w @ v))) + xq)
        y = self.norm2(self.drop(self.ffn2(F.gelu(self.ffn1(a)))) + a)
        return y[:, 0]


class Propagation(nn.Module):
    def __init__(self, d, heads):
        super().__init__()
        self.q, self.k, self.v, self.merge = (nn.Linear(d, d) for _ in range(4))
        self.mlp1, self.mlp2 = nn.Linear(2 * d, 2 * d), nn.Linear(2 * d, d)
        nn.init.zeros_(self.mlp2.bias)
        self.heads = heads

    def forward(self, x, src):
        h = self.heads
        dk = x.shape[-1] // h
        q = split_heads(self.q(x), h) / math.sqrt(dk)
        k = split_heads(self.k(src), h)
        v = split_heads(self.v(src), h)
        msg = self.merge(merge_heads(torch.softmax(q @ k.transpose(-1, -2), dim=-1) @ v))
        return self.mlp2(F.relu(self.mlp1(torch.cat([x, msg], dim=-1))))


def mlp(widths):
    layers = []
    for i in range(len(widths) - 1):
        layers.append(nn.Linear(widths[i], widths[i + 1]))
        if i < len(widths) - 2:
            layers.append(nn.ReLU())
    return nn.Sequential(*layers)


class PL2Map(nn.Module):
    def __init__(self, d, token0_only, heads=4, layers=("self", "cross", "self", "cross", "self")):
        super().__init__()
        self.line_encoder = LineEncoder(d, heads, 4 * d, 0.1, token0_only)
        self.layers = nn.ModuleList(Propagation(d, heads) for _ in layers)
        self.kinds = layers
        self.point_head = mlp([d, 512, 1024, 512, 4])
        self.line_head = mlp([d, 512, 1024, 512, 7])

    def forward(self, points, lines):
        p, l = points, self.line_encoder(lines)
        for layer, kind in zip(self.layers, self.kinds):
            sp, sl = (l, p) if kind == "cross" else (p, l)
            p, l = p + layer(p, sp), l + layer(l, sl)
        return self.point_head(p), self.line_head(l)


def reliability(u):
    return 1.0 / (1.0 + (100.0 * u).abs())


def robust_mean(err, ok, weight, tau):
    ok = ok & (err < 1000.0)
    mask = ok.float()
    rho = tau * torch.tanh(err / tau) * mask * weight
    return rho.sum() / mask.sum().clamp_min(1.0)


def project(xyz, R, t, f, c):
    cam = xyz @ R.T + t
    z = cam[:, 2:3]
    ok = (z >= 0.1) & (z <= 1000.0)
    z = torch.where(ok, z, torch.ones_like(z))
    return cam[:, :2] / z * f + c, ok[:, 0]


def loss_fn(pp, lp, data, tau):
    kp, seg, plab, pval, llab, lval, eq, R, t, f, c = data
    lp_ = pp[pval]
    l_m = ((lp_[:, :3] - plab[pval]).pow(2).sum(1).clamp_min(1e-12).sqrt().sum()
           + (lp[lval][:, :6] - llab[lval]).pow(2).sum(1).clamp_min(1e-12).sqrt().sum())
    l_r = ((pval.float() - reliability(pp[:, 3])).pow(2).sum().clamp_min(1e-12).sqrt()
           + (lval.float() - reliability(lp[:, 6])).pow(2).sum().clamp_min(1e-12).sqrt())
    uv, ok = project(lp_[:, :3], R, t, f, c)
    e = (uv - kp[pval]).pow(2).sum(1).clamp_min(1e-12).sqrt()
    l_pi = robust_mean(e, ok, reliability(lp_[:, 3]).detach(), tau)
    ll = lp[lval]
    ua, oka = project(ll[:, :3], R, t, f, c)
    ub, okb = project(ll[:, 3:6], R, t, f, c)
    eqv = eq[lval]
    dist = lambda uv: ((uv * eqv[:, :2]).sum(1) + eqv[:, 2]).abs()
    l_pi = l_pi + robust_mean(dist(ua) + dist(ub), oka & okb, reliability(ll[:, 6]).detach(), tau)
    return l_m + l_r + l_pi


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--dim", type=int, default=256)
    ap.add_argument("--points", type=int, default=1024)
    ap.add_argument("--lines", type=int, default=128)
    ap.add_argument("--tokens", type=int, default=12)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--warmup", type=int, default=2)
    ap.add_argument("--iters", type=int, default=7)
    ap.add_argument("--progress", type=float, default=0.9)
    ap.add_argument("--seed", type=int, default=7)
    ap.add_argument("--token0-only", action="store_true")
    # cpu, or cuda for the GPU side by side with `step_bench --backend cuda` (times then
    # wait for the GPU to finish the step).
    ap.add_argument("--device", default="cpu")
    a = ap.parse_args()

    torch.set_num_threads(a.threads)
    torch.manual_seed(a.seed)
    rss_before = status_bytes("VmRSS:")
    peak_ok = reset_peak()

    d, n, m = a.dim, a.points, a.lines
    dev = torch.device(a.device)
    model = PL2Map(d, a.token0_only).to(dev)
    params = sum(p.numel() for p in model.parameters())
    opt = torch.optim.Adam(model.parameters(), lr=1e-4, eps=1e-8)
    model.train()

    points = F.normalize(torch.rand(n, d) - 0.5, dim=-1)
    lines = F.normalize(torch.rand(m, a.tokens, d) - 0.5, dim=-1)
    f = torch.tensor([525.0, 525.0])
    c = torch.tensor([320.0, 240.0])
    kp = torch.rand(n, 2) * torch.tensor([640.0, 480.0])
    seg = torch.rand(m, 4) * torch.tensor([640.0, 480.0, 640.0, 480.0])
    back = lambda uv, z: torch.cat([(uv - c) / f * z, z], dim=1)
    plab = back(kp, 1 + 5 * torch.rand(n, 1))
    llab = torch.cat([back(seg[:, :2], 1 + 5 * torch.rand(m, 1)),
                      back(seg[:, 2:], 1 + 5 * torch.rand(m, 1))], dim=1)
    pval = torch.rand(n) < 0.8
    lval = torch.rand(m) < 0.8
    dvec = seg[:, 2:] - seg[:, :2]
    nrm = torch.stack([dvec[:, 1], -dvec[:, 0]], 1) / dvec.norm(dim=1, keepdim=True)
    eq = torch.cat([nrm, -(nrm * seg[:, :2]).sum(1, keepdim=True)], 1)
    data = (kp, seg, plab, pval, llab, lval, eq, torch.eye(3), torch.zeros(3), f, c)
    data = tuple(x.to(dev) for x in data)
    points, lines = points.to(dev), lines.to(dev)
    tau = math.sqrt(1 - a.progress ** 2) * 50.0 + 1.0

    times, cpu = [], []
    for i in range(a.warmup + a.iters):
        cpu_start = time.process_time()
        start = time.perf_counter()
        opt.zero_grad(set_to_none=True)
        pp, lp = model(points, lines)
        loss = loss_fn(pp, lp, data, tau)
        loss.backward()
        opt.step()
        if dev.type == "cuda":
            torch.cuda.synchronize()
        elapsed = time.perf_counter() - start
        cpu_used = time.process_time() - cpu_start
        if not math.isfinite(loss.item()):
            raise SystemExit(f"non-finite loss at step {i}")
        if i >= a.warmup:
            times.append(elapsed)
            cpu.append(cpu_used)
    def median(v):
        s = sorted(v)
        k = len(s)
        return s[k // 2] if k % 2 else 0.5 * (s[k // 2 - 1] + s[k // 2])
    print(json.dumps({
        "torch_version": torch.__version__,
        "params": params,
        "times_s": times,
        "median_s": median(times),
        "cpu_median_s": median(cpu),
        "rss_before_bytes": rss_before,
        "peak_rss_bytes": status_bytes("VmHWM:") if peak_ok else None,
        "token0_only": a.token0_only,
    }))


if __name__ == "__main__":
    main()
