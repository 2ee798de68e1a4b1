#!/usr/bin/python3
"""Writes the TorchScript test modules for red_torch_tests.

Usage: export_modules.py OUTDIR

For each feature form the C++ loader supports (tuple, list, tensor) it exports a small
encoder and two heads (`mask`: a decoder to a 1-channel map; `value`: pooling and a
fully connected layer to one number), with torch.jit.script and, for the tuple form, also
with torch.jit.trace. It writes a manifest per variant and `reference_<variant>.pt`: a
scripted module whose buffers hold a fixed input batch and PyTorch's own outputs of every
head on it, so the C++ test can check that RED computes the same thing. It also writes a
state-dict file (a valid torch.save archive that is not TorchScript) for a negative test.
A `stamp` file is written last.
"""

import os
import sys
import warnings
from typing import List, Tuple

import torch
import torch.nn as nn
import torch.nn.functional as F

INPUT = [3, 64, 128]
BATCH = 2


def randomize_bn(bn: nn.BatchNorm2d) -> None:
    # Non-trivial running statistics, so eval-mode batch norm is really exercised.
    with torch.no_grad():
        bn.running_mean.uniform_(-0.2, 0.2)
        bn.running_var.uniform_(0.5, 1.5)
        bn.weight.uniform_(0.5, 1.5)
        bn.bias.uniform_(-0.1, 0.1)


class Backbone(nn.Module):
    def __init__(self) -> None:
        super().__init__()
        self.c1 = nn.Conv2d(INPUT[0], 8, 3, stride=2, padding=1, bias=False)
        self.bn1 = nn.BatchNorm2d(8)
        self.c2 = nn.Conv2d(8, 16, 3, stride=2, padding=1)
        randomize_bn(self.bn1)

    def scales(self, x: torch.Tensor) -> Tuple[torch.Tensor, torch.Tensor]:
        a = F.relu(self.bn1(self.c1(x)))
        b = F.relu(self.c2(a))
        return a, b


class TupleEncoder(Backbone):
    def forward(self, x: torch.Tensor) -> Tuple[torch.Tensor, torch.Tensor]:
        return self.scales(x)


class ListEncoder(Backbone):
    def forward(self, x: torch.Tensor) -> List[torch.Tensor]:
        a, b = self.scales(x)
        return [a, b]


class TensorEncoder(Backbone):
    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.scales(x)[1]


class MaskCore(nn.Module):
    def __init__(self) -> None:
        super().__init__()
        self.deep = nn.Conv2d(16, 4, 1)
        self.skip = nn.Conv2d(8, 4, 3, padding=1)
        self.out = nn.Conv2d(4, 1, 1)

    def mix(self, a: torch.Tensor, b: torch.Tensor) -> torch.Tensor:
        y = F.interpolate(self.deep(b), scale_factor=2.0, mode="bilinear", align_corners=False)
        return torch.sigmoid(self.out(F.relu(y + self.skip(a))))


class ValueCore(nn.Module):
    def __init__(self) -> None:
        super().__init__()
        self.fc1 = nn.Linear(16, 8)
        self.fc2 = nn.Linear(8, 1)

    def value(self, b: torch.Tensor) -> torch.Tensor:
        return self.fc2(F.relu(self.fc1(torch.flatten(F.adaptive_avg_pool2d(b, 1), 1))))


class TupleMask(MaskCore):
    def forward(self, f: Tuple[torch.Tensor, torch.Tensor]) -> torch.Tensor:
        return self.mix(f[0], f[1])


class TupleValue(ValueCore):
    def forward(self, f: Tuple[torch.Tensor, torch.Tensor]) -> torch.Tensor:
        return self.value(f[1])


class ListMask(MaskCore):
    def forward(self, f: List[torch.Tensor]) -> torch.Tensor:
        return self.mix(f[0], f[1])


class ListValue(ValueCore):
    def forward(self, f: List[torch.Tensor]) -> torch.Tensor:
        return self.value(f[1])


class TensorMask(nn.Module):
    def __init__(self) -> None:
        super().__init__()
        self.out = nn.Conv2d(16, 1, 3, padding=1)

    def forward(self, b: torch.Tensor) -> torch.Tensor:
        return torch.sigmoid(self.out(b))


class TensorValue(ValueCore):
    def forward(self, b: torch.Tensor) -> torch.Tensor:
        return self.value(b)


class Reference(nn.Module):
    """Holds the input and the expected outputs as buffers (readable from C++ via attr)."""

    def __init__(self, tensors: dict) -> None:
        super().__init__()
        for name, t in tensors.items():
            self.register_buffer(name, t)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return x


def write_manifest(out: str, name: str, encoder: str, heads: dict, outputs: str = "") -> None:
    lines = [
        f"# {name}: written by export_modules.py",
        f"encoder: {encoder}",
        "heads:",
    ]
    lines += [f"  {h}: {f}" for h, f in heads.items()]
    lines.append(f"input: [{INPUT[0]}, {INPUT[1]}, {INPUT[2]}]")
    if outputs:
        lines.append(f"outputs: {outputs}")
    with open(os.path.join(out, f"{name}.yaml"), "w") as f:
        f.write("\n".join(lines) + "\n")


def export(out: str, name: str, encoder: nn.Module, heads: dict, traced: bool,
           outputs: str, x: torch.Tensor) -> None:
    encoder.eval()
    with torch.no_grad():
        feats = encoder(x)
        expected = {h: m.eval()(feats) for h, m in heads.items()}
        if traced:
            enc_ts = torch.jit.trace(encoder, x)
            head_ts = {h: torch.jit.trace(m, (feats,)) for h, m in heads.items()}
        else:
            enc_ts = torch.jit.script(encoder)
            head_ts = {h: torch.jit.script(m) for h, m in heads.items()}
    enc_file = f"{name}_encoder.pt"
    enc_ts.save(os.path.join(out, enc_file))
    head_files = {}
    for h, m in head_ts.items():
        head_files[h] = f"{name}_{h}.pt"
        m.save(os.path.join(out, head_files[h]))
    write_manifest(out, name, enc_file, head_files, outputs)
    ref = {"input": x}
    ref.update({f"out_{h}": t for h, t in expected.items()})
    torch.jit.script(Reference(ref)).save(os.path.join(out, f"reference_{name}.pt"))


def main() -> int:
    if len(sys.argv) != 2:
        print(__doc__, file=sys.stderr)
        return 2
    out = sys.argv[1]
    os.makedirs(out, exist_ok=True)
    warnings.simplefilter("ignore")  # tracer warnings about shape-dependent code
    torch.manual_seed(20240501)
    x = torch.rand([BATCH] + INPUT)

    export(out, "scripted", TupleEncoder(), {"mask": TupleMask(), "value": TupleValue()},
           traced=False, outputs="tuple", x=x)
    export(out, "traced", TupleEncoder(), {"mask": TupleMask(), "value": TupleValue()},
           traced=True, outputs="", x=x)
    export(out, "list", ListEncoder(), {"mask": ListMask(), "value": ListValue()},
           traced=False, outputs="list", x=x)
    export(out, "tensor", TensorEncoder(), {"mask": TensorMask(), "value": TensorValue()},
           traced=False, outputs="tensor", x=x)

    torch.save(TupleEncoder().state_dict(), os.path.join(out, "state_dict.pt"))
    with open(os.path.join(out, "stamp"), "w") as f:
        f.write(torch.__version__ + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
