"""A PyTorch PL2Map with the reference implementation's parameter names and shapes,
written for the tests from reading the reference's module (docs/method.md section 2,
docs/formats.md "Importing the reference's checkpoints"), to check
`pl2map checkpoint import` against.

  pl2map_reference_torch.py OUT_DIR SEED N M [nested|bare] [drop:KEY|shape:KEY]
      random weights (torch.manual_seed(SEED): PyTorch's default init, then every
      parameter shifted by N(0, 0.05) so that no weight or bias is a constant) saved as
      OUT_DIR/reference.pth: under "model_state_dict" next to an "epoch" (`nested`, as the
      reference's training script saves) or as the bare state dict (`bare`).
      `drop:KEY` leaves KEY out, `shape:KEY` cuts its first dimension (refusal tests).
      Also writes float32 little-endian files: points.f32 (N x 256, L2-normalised rows),
      lines.f32 (M x 12 x 256), and the network's outputs points_out.f32 (N x 4: x, y,
      z, u) and lines_out.f32 (M x 7: start, end, u).

What must match the reference: the graph's attention reshapes each projection to
(D / heads, heads), so channel c is head c % heads (interleaved); the line encoder's
attention reshapes to (heads, D / heads) (contiguous); heads are kernel-1 convolutions.
"""
import sys

import numpy as np
import torch
import torch.nn.functional as F
from torch import nn

D, HEADS, FFN, T = 256, 4, 1024, 12
LAYERS = ["self", "cross", "self", "cross", "self"]
HIDDEN = [512, 1024, 512]


class SelfAttention(nn.Module):
    """The line encoder's attention: post-LayerNorm, contiguous heads."""

    def __init__(self):
        super().__init__()
        self.w_qs = nn.Linear(D, D)
        self.w_ks = nn.Linear(D, D)
        self.w_vs = nn.Linear(D, D)
        self.fc = nn.Linear(D, D)
        self.layer_norm = nn.LayerNorm(D, eps=1e-6)

    def forward(self, x):  # x: [M, T, D]
        m, t, _ = x.shape
        dk = D // HEADS
        split = lambda y: y.reshape(m, t, HEADS, dk).permute(0, 2, 1, 3)  # [M, H, T, dk]
        q, k, v = split(self.w_qs(x)), split(self.w_ks(x)), split(self.w_vs(x))
        w = torch.softmax(q @ k.transpose(2, 3) / dk ** 0.5, dim=-1)
        ctx = (w @ v).permute(0, 2, 1, 3).reshape(m, t, D)
        return self.layer_norm(self.fc(ctx) + x)


class FeedForward(nn.Module):
    def __init__(self):
        super().__init__()
        self.w_1 = nn.Linear(D, FFN)
        self.w_2 = nn.Linear(FFN, D)
        self.layer_norm = nn.LayerNorm(D, eps=1e-6)

    def forward(self, x):
        return self.layer_norm(self.w_2(F.gelu(self.w_1(x))) + x)


class LineLayer(nn.Module):
    def __init__(self):
        super().__init__()
        self.slf_attn = SelfAttention()
        self.pos_ffn = FeedForward()

    def forward(self, x):
        return self.pos_ffn(self.slf_attn(x))


class LineEncoder(nn.Module):
    def __init__(self):
        super().__init__()
        self.desc_layers = nn.ModuleList([LineLayer()])

    def forward(self, x):  # [M, T, D] -> [D, M] (token 0)
        return self.desc_layers[0](x)[:, 0, :].t()


def conv_mlp(widths):
    mods = []
    for i in range(1, len(widths)):
        mods.append(nn.Conv1d(widths[i - 1], widths[i], kernel_size=1))
        if i < len(widths) - 1:
            mods.append(nn.ReLU())
    return nn.Sequential(*mods)


class GraphAttention(nn.Module):
    """Interleaved heads: channel c belongs to head c % HEADS."""

    def __init__(self):
        super().__init__()
        self.merge = nn.Conv1d(D, D, kernel_size=1)
        self.proj = nn.ModuleList([nn.Conv1d(D, D, kernel_size=1) for _ in range(3)])

    def forward(self, x, src):  # [D, N], [D, S]
        dk = D // HEADS
        q, k, v = [p(y[None]).reshape(dk, HEADS, -1) for p, y in zip(self.proj, (x, src, src))]
        # scores[h, n, s] = sum_j q[j, h, n] k[j, h, s] / sqrt(dk)
        scores = torch.einsum("jhn,jhs->hns", q, k) / dk ** 0.5
        ctx = torch.einsum("hns,jhs->jhn", torch.softmax(scores, dim=-1), v)
        return self.merge(ctx.reshape(1, D, -1))[0]


class Propagation(nn.Module):
    def __init__(self):
        super().__init__()
        self.attn = GraphAttention()
        self.mlp = conv_mlp([2 * D, 2 * D, D])

    def forward(self, x, src):
        msg = self.attn(x, src)
        return self.mlp(torch.cat([x, msg], dim=0)[None])[0]


class Graph(nn.Module):
    def __init__(self):
        super().__init__()
        self.layers = nn.ModuleList([Propagation() for _ in LAYERS])

    def forward(self, p, l):
        for layer, kind in zip(self.layers, LAYERS):
            sp, sl = (l, p) if kind == "cross" else (p, l)
            p, l = p + layer(p, sp), l + layer(l, sl)
        return p, l


class Reference(nn.Module):
    def __init__(self):
        super().__init__()
        self.line_encoder = LineEncoder()
        self.gnn = Graph()
        self.mapping_p = conv_mlp([D] + HIDDEN + [4])
        self.mapping_l = conv_mlp([D] + HIDDEN + [7])

    def forward(self, points, lines):  # [N, D], [M, T, D] -> [N, 4], [M, 7]
        p, l = self.gnn(points.t(), self.line_encoder(lines))
        return self.mapping_p(p[None])[0].t(), self.mapping_l(l[None])[0].t()


def main():
    out, seed, n, m = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4])
    layout = sys.argv[5] if len(sys.argv) > 5 else "nested"
    edit = sys.argv[6] if len(sys.argv) > 6 else ""
    torch.manual_seed(seed)
    net = Reference()
    with torch.no_grad():
        for p in net.parameters():
            p.add_(0.05 * torch.randn_like(p))
    net.eval()
    points = F.normalize(torch.randn(n, D), dim=1)
    lines = F.normalize(torch.randn(m, T, D), dim=2)
    with torch.no_grad():
        po, lo = net(points, lines)
    sd = net.state_dict()
    if edit.startswith("drop:"):
        del sd[edit[5:]]
    elif edit.startswith("shape:"):
        key = edit[6:]
        sd[key] = sd[key][1:].clone()
    obj = {"epoch": 7, "model_state_dict": sd} if layout == "nested" else sd
    torch.save(obj, f"{out}/reference.pth")
    for name, t in [("points", points), ("lines", lines), ("points_out", po), ("lines_out", lo)]:
        t.numpy().astype("<f4").tofile(f"{out}/{name}.f32")


if __name__ == "__main__":
    main()
