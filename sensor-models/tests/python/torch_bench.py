#!/usr/bin/env python3
"""PyTorch eager timings of the two reference architectures, batch 1 at 224, on 2 threads, for
sensor-models/examples/model_bench.rs (the same run, the same machine)."""
import sys
import time

import torch

sys.path.insert(0, __file__.rsplit("/", 1)[0])
from model_fixtures import IsoNet, ResNetMultiTask  # noqa: E402


def main():
    n = int(sys.argv[1]) if len(sys.argv) > 1 else 50
    torch.set_num_threads(2)
    x = torch.rand(1, 3, 224, 224)
    for name, net in [("custom", IsoNet(3)), ("resnet18", ResNetMultiTask(3))]:
        net.eval()
        iters = min(n, 30) if name == "resnet18" else n
        with torch.no_grad():
            for _ in range(3):
                net(x)
            t = []
            for _ in range(iters):
                s = time.perf_counter()
                net(x)
                t.append((time.perf_counter() - s) * 1e3)
        t.sort()
        print(f"pytorch eager {name} batch 1 @224, 2 threads: {t[len(t) // 2]:.2f} / {sum(t) / len(t):.2f}")


if __name__ == "__main__":
    main()
