#!/usr/bin/env python3
"""Exports two robot backbones with four heads each as TorchScript model manifests, for the
robot-workload profiles (tests/data/profiles/robot-*.json, issue 37).

torchvision is not packaged with Debian's python3-torch here, so the backbones are written
by hand with the same structure as torchvision's, at random weights (timing only):
  mnv3s  - MobileNetV3-small-like: inverted residuals (depthwise 3x3/5x5, squeeze-excite,
           hardswish), features at strides 8, 16, 32 (24, 48, 96 channels)
  r18    - ResNet18-like: 7x7 stem, four stages of two basic blocks (64, 128, 256, 512),
           features at strides 8, 16, 32
Heads (named as the built-in MIMONet's, so scenarios need no change): lane (1x1 + upsample
to the input), seg (FPN-like merge of two levels, 8 classes, upsample), steer (pool + MLP),
det (YOLO-like grid on stride 16).

    /usr/bin/python3 export_robot_models.py OUTDIR
    red profile --model OUTDIR/mnv3s/model.yaml --threads 1 --no-separate --out robot-mnv3s.json
"""
import os
import sys
from typing import Tuple

import torch
import torch.nn as nn
import torch.nn.functional as F

Feats = Tuple[torch.Tensor, torch.Tensor, torch.Tensor]


def cbr(i, o, k=3, s=1, g=1, act=nn.ReLU):
    return nn.Sequential(nn.Conv2d(i, o, k, s, k // 2, groups=g, bias=False), nn.BatchNorm2d(o), act())


class SE(nn.Module):
    def __init__(self, c):
        super().__init__()
        self.a = nn.Conv2d(c, max(8, c // 4), 1)
        self.b = nn.Conv2d(max(8, c // 4), c, 1)

    def forward(self, x):
        s = F.adaptive_avg_pool2d(x, 1)
        return x * F.hardsigmoid(self.b(F.relu(self.a(s))))


class InvRes(nn.Module):
    def __init__(self, i, e, o, k, s, se, act):
        super().__init__()
        self.use_res = s == 1 and i == o
        layers = []
        if e != i:
            layers.append(cbr(i, e, 1, act=act))
        layers.append(cbr(e, e, k, s, g=e, act=act))
        if se:
            layers.append(SE(e))
        layers += [nn.Conv2d(e, o, 1, bias=False), nn.BatchNorm2d(o)]
        self.body = nn.Sequential(*layers)

    def forward(self, x):
        y = self.body(x)
        return x + y if self.use_res else y


class MobileNetV3Small(nn.Module):
    def __init__(self):
        super().__init__()
        R, H = nn.ReLU, nn.Hardswish
        self.stem = cbr(3, 16, 3, 2, act=H)
        self.s8 = nn.Sequential(InvRes(16, 16, 16, 3, 2, True, R), InvRes(16, 72, 24, 3, 2, False, R),
                                InvRes(24, 88, 24, 3, 1, False, R))
        self.s16 = nn.Sequential(InvRes(24, 96, 40, 5, 2, True, H), InvRes(40, 240, 40, 5, 1, True, H),
                                 InvRes(40, 240, 40, 5, 1, True, H), InvRes(40, 120, 48, 5, 1, True, H),
                                 InvRes(48, 144, 48, 5, 1, True, H))
        self.s32 = nn.Sequential(InvRes(48, 288, 96, 5, 2, True, H), InvRes(96, 576, 96, 5, 1, True, H),
                                 InvRes(96, 576, 96, 5, 1, True, H))

    def forward(self, x: torch.Tensor) -> Feats:
        a = self.s8(self.stem(x))
        b = self.s16(a)
        return a, b, self.s32(b)


class Basic(nn.Module):
    def __init__(self, i, o, s):
        super().__init__()
        self.c1 = cbr(i, o, 3, s)
        self.c2 = nn.Sequential(nn.Conv2d(o, o, 3, 1, 1, bias=False), nn.BatchNorm2d(o))
        self.down = (nn.Sequential(nn.Conv2d(i, o, 1, s, bias=False), nn.BatchNorm2d(o))
                     if s != 1 or i != o else nn.Identity())

    def forward(self, x):
        return F.relu(self.c2(self.c1(x)) + self.down(x))


class ResNet18(nn.Module):
    def __init__(self):
        super().__init__()
        self.stem = nn.Sequential(cbr(3, 64, 7, 2), nn.MaxPool2d(3, 2, 1))
        self.l1 = nn.Sequential(Basic(64, 64, 1), Basic(64, 64, 1))
        self.l2 = nn.Sequential(Basic(64, 128, 2), Basic(128, 128, 1))
        self.l3 = nn.Sequential(Basic(128, 256, 2), Basic(256, 256, 1))
        self.l4 = nn.Sequential(Basic(256, 512, 2), Basic(512, 512, 1))

    def forward(self, x: torch.Tensor) -> Feats:
        a = self.l2(self.l1(self.stem(x)))
        b = self.l3(a)
        return a, b, self.l4(b)


class Lane(nn.Module):
    def __init__(self, c):
        super().__init__()
        self.r = cbr(c[0], 32, 3)
        self.o = nn.Conv2d(32, 1, 1)

    def forward(self, f: Feats) -> torch.Tensor:
        return F.interpolate(self.o(self.r(f[0])), scale_factor=8.0, mode="bilinear", align_corners=False)


class Seg(nn.Module):
    def __init__(self, c):
        super().__init__()
        self.top = cbr(c[1], 64, 1)
        self.lat = cbr(c[0], 64, 1)
        self.m = cbr(64, 64, 3)
        self.o = nn.Conv2d(64, 8, 1)

    def forward(self, f: Feats) -> torch.Tensor:
        t = F.interpolate(self.top(f[1]), scale_factor=2.0, mode="nearest")
        y = self.o(self.m(t + self.lat(f[0])))
        return F.interpolate(y, scale_factor=8.0, mode="bilinear", align_corners=False)


class Steer(nn.Module):
    def __init__(self, c):
        super().__init__()
        self.fc = nn.Sequential(nn.Linear(c[2], 100), nn.ReLU(), nn.Linear(100, 50), nn.ReLU(), nn.Linear(50, 1))

    def forward(self, f: Feats) -> torch.Tensor:
        return self.fc(torch.flatten(F.adaptive_avg_pool2d(f[2], 1), 1))


class Det(nn.Module):
    def __init__(self, c):
        super().__init__()
        self.b = nn.Sequential(cbr(c[1], 128, 3), cbr(128, 128, 1))
        self.o = nn.Conv2d(128, 24, 1)

    def forward(self, f: Feats) -> torch.Tensor:
        return self.o(self.b(f[1]))


def export(out, name, enc, chans, shape=(3, 192, 384)):
    d = os.path.join(out, name)
    os.makedirs(d, exist_ok=True)
    torch.manual_seed(1)
    enc = enc.eval()
    heads = {"lane": Lane(chans), "seg": Seg(chans), "steer": Steer(chans), "det": Det(chans)}
    with torch.no_grad():
        x = torch.rand(1, *shape)
        f = enc(x)
        torch.jit.trace(enc, x).save(os.path.join(d, "encoder.pt"))
        for h, m in heads.items():
            m = m.eval()
            m(f)
            torch.jit.script(m).save(os.path.join(d, h + ".pt"))
    with open(os.path.join(d, "model.yaml"), "w") as y:
        y.write("encoder: encoder.pt\nheads: {lane: lane.pt, seg: seg.pt, steer: steer.pt, det: det.pt}\n")
        y.write("input: [%d, %d, %d]\noutputs: tuple\n" % shape)
    print(name, [tuple(t.shape) for t in f])


if __name__ == "__main__":
    out = sys.argv[1] if len(sys.argv) > 1 else "models"
    export(out, "mnv3s", MobileNetV3Small(), (24, 48, 96))
    export(out, "r18", ResNet18(), (128, 256, 512))
