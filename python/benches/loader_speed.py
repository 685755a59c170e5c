"""Training inputs a second from fringe.torch.Dataset through a PyTorch DataLoader (BENCHMARKS.md,
"Training from Python: the loader").

    python python/benches/loader_speed.py RUN [--size 112] [--augment gray10] [--workers 2]
        [--batch 32] [--inputs N]

Times every batch of one pass over the training side (or its first N inputs) after the workers
have started, and prints one JSON line: inputs, seconds, inputs a second, time to the first batch.
"""
import argparse
import json
import time

import torch

from fringe.torch import Dataset


def main():
    p = argparse.ArgumentParser()
    p.add_argument("run")
    p.add_argument("--size", type=int, default=112)
    p.add_argument("--augment", default="gray10")
    p.add_argument("--workers", type=int, default=2)
    p.add_argument("--batch", type=int, default=32)
    p.add_argument("--inputs", type=int, default=None)
    a = p.parse_args()
    augment = None if a.augment == "none" else a.augment
    data = Dataset([a.run], "train", size=a.size, augment=augment)
    loader = torch.utils.data.DataLoader(data, batch_size=a.batch, shuffle=True,
                                         num_workers=a.workers, drop_last=False,
                                         generator=torch.Generator().manual_seed(0))
    started = time.monotonic()
    first = None
    n = 0
    for batch in loader:
        if first is None:
            first = time.monotonic() - started
        n += len(batch["fz"])
        if a.inputs is not None and n >= a.inputs:
            break
    seconds = time.monotonic() - started
    print(json.dumps({"inputs": n, "frames": len(data.frame), "seconds": round(seconds, 2),
                      "inputs_per_second": round(n / seconds, 1),
                      "first_batch_s": round(first or 0.0, 2), "workers": a.workers,
                      "augment": a.augment, "size": a.size}))


if __name__ == "__main__":
    main()
