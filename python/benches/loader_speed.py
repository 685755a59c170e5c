"""Training inputs a second from fringe.torch.Dataset through a PyTorch DataLoader (BENCHMARKS.md,
"Training from Python: the loader").

    python python/benches/loader_speed.py RUN [--size 112] [--augment gray10] [--workers 2]
        [--batch 32] [--epochs 2] [--no-cache]

Times every batch of each epoch over the training side after the workers have started (the
first epoch makes the inputs, the later ones read them from the dataset's cache), and prints one
JSON line an epoch: inputs, seconds, inputs a second, time to the first batch.
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
    p.add_argument("--epochs", type=int, default=2)
    p.add_argument("--no-cache", action="store_true")
    a = p.parse_args()
    augment = None if a.augment == "none" else a.augment
    data = Dataset([a.run], "train", size=a.size, augment=augment, cache=not a.no_cache)
    loader = torch.utils.data.DataLoader(data, batch_size=a.batch, shuffle=True,
                                         num_workers=a.workers, drop_last=False,
                                         persistent_workers=a.workers > 0,
                                         generator=torch.Generator().manual_seed(0))
    for epoch in range(a.epochs):
        started = time.monotonic()
        first = None
        n = 0
        for batch in loader:
            if first is None:
                first = time.monotonic() - started
            n += len(batch["fz"])
        seconds = time.monotonic() - started
        print(json.dumps({"epoch": epoch + 1, "inputs": n, "frames": len(data.frame),
                          "seconds": round(seconds, 2), "inputs_per_second": round(n / seconds, 1),
                          "first_batch_s": round(first or 0.0, 2), "workers": a.workers,
                          "augment": a.augment, "size": a.size, "cache": not a.no_cache}),
              flush=True)


if __name__ == "__main__":
    main()
