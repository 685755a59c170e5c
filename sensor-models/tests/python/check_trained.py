#!/usr/bin/env python3
"""Loads a checkpoint that `fringe train` wrote into the reference classes (defined in
model_fixtures.py) with PyTorch's own readers: `safetensors.torch.load_file` and a strict
`load_state_dict`, then writes the eval-mode outputs on fixed seeded inputs, for the Rust test to
compare with the default backend's.

usage: check_trained.py MODEL.safetensors custom|resnet18 OUT_DIR
  writes OUT_DIR/inputs.f32 ([2,3,S,S] little-endian f32, S from --size, default 64) and
  OUT_DIR/expected.json {"shape": [...], "force": ..., "shape_logits": ..., "contact": ...}
"""
import json
import os
import sys

import torch
from safetensors.torch import load_file

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from model_fixtures import IsoNet, ResNetMultiTask  # noqa: E402


def main():
    path, arch, out = sys.argv[1:4]
    size = int(sys.argv[4]) if len(sys.argv) > 4 else 64
    state = load_file(path)
    classes = state["class_head.weight"].shape[0]
    model = IsoNet(classes) if arch == "custom" else ResNetMultiTask(classes)
    model.load_state_dict(state, strict=True)
    model.eval()
    gen = torch.Generator().manual_seed(7)
    x = torch.rand((2, 3, size, size), generator=gen) * 2.0 - 1.0
    with torch.no_grad():
        force, logits, contact = model(x)
    os.makedirs(out, exist_ok=True)
    x.numpy().astype("<f4").tofile(os.path.join(out, "inputs.f32"))
    with open(os.path.join(out, "expected.json"), "w") as f:
        json.dump(
            {
                "shape": list(x.shape),
                "force": force.tolist(),
                "shape_logits": logits.tolist(),
                "contact": contact.tolist(),
            },
            f,
        )


if __name__ == "__main__":
    main()
