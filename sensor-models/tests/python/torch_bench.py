#!/usr/bin/env python3
"""PyTorch eager timings of the two reference architectures, batch 1 at 224 (ResNet-18 at 112 and
160 too), on 2 threads, for sensor-models/examples/model_bench.rs (the same run, the same
machine)."""
import sys
import time

import torch

sys.path.insert(0, __file__.rsplit("/", 1)[0])
from model_fixtures import IsoNet, ResNetMultiTask  # noqa: E402


def main():
    n = int(sys.argv[1]) if len(sys.argv) > 1 else 50
    torch.set_num_threads(2)
    networks = [("custom", IsoNet(3), [224]), ("resnet18", ResNetMultiTask(3), [112, 160, 224])]
    for name, net, sizes in networks:
        net.eval()
        iters = min(n, 30) if name == "resnet18" else n
        for size in sizes:
            x = torch.rand(1, 3, size, size)
            with torch.no_grad():
                for _ in range(3):
                    net(x)
                t = []
                for _ in range(iters):
                    s = time.perf_counter()
                    net(x)
                    t.append((time.perf_counter() - s) * 1e3)
            t.sort()
            median, mean = t[len(t) // 2], sum(t) / len(t)
            print(f"pytorch eager {name} batch 1 @{size}, 2 threads: {median:.2f} / {mean:.2f}")


if __name__ == "__main__":
    main()
