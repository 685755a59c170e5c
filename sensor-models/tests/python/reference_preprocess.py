#!/usr/bin/env python3
"""The reference pipeline's preprocessing of one sensor frame, with PIL and torchvision, for the
comparison test of fringe's reference mode (sensor-models/tests/preprocess_torchvision.rs).

Steps as the reference pipeline does them (shared/docs/reference-pipeline.md): circular mask of
the crop diameter about the image centre (black outside), centre crop to that diameter, Resize
to the network input (PIL bilinear, antialiased), optional Grayscale(3), ToTensor, Normalize(0.5,
0.5). Writes the tensor as raw little-endian float32, shape [3, S, S].

usage: reference_preprocess.py IMAGE OUT.f32 --diameter 980 --size 224 [--rgb]
"""
import argparse

import numpy as np
from PIL import Image
import torchvision.transforms as T


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("image")
    ap.add_argument("out")
    ap.add_argument("--diameter", type=int, default=980)
    ap.add_argument("--size", type=int, default=224)
    ap.add_argument("--rgb", action="store_true")
    a = ap.parse_args()

    img = np.asarray(Image.open(a.image).convert("RGB")).copy()
    h, w = img.shape[:2]
    # Pixel centres at i + 0.5; the circle about the image centre.
    ys, xs = np.mgrid[0:h, 0:w]
    r = a.diameter / 2.0
    outside = (xs + 0.5 - w / 2.0) ** 2 + (ys + 0.5 - h / 2.0) ** 2 > r * r
    img[outside] = 0
    steps = [T.CenterCrop(a.diameter), T.Resize((a.size, a.size))]
    if not a.rgb:
        steps.append(T.Grayscale(num_output_channels=3))
    steps += [T.ToTensor(), T.Normalize([0.5] * 3, [0.5] * 3)]
    tensor = T.Compose(steps)(Image.fromarray(img))
    tensor.numpy().astype("<f4").tofile(a.out)


if __name__ == "__main__":
    main()
