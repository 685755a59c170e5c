"""``python -m fringe.train RUN... --arch custom|resnet18 --out FILE.safetensors``: trains one of
fringe's networks on runs with fringe's split by press, on PyTorch (DistributedDataParallel under
``torchrun``: NCCL on GPUs, gloo on CPUs), and saves it as fringe reads it.

    python -m fringe.train runs/a runs/b --arch custom --epochs 10 --out model.safetensors
    torchrun --nproc_per_node 4 -m fringe.train runs/* --arch resnet18 --out model.safetensors

The loss is fringe's (MSE on Fz, cross-entropy on the shape, MSE on the contact over the frames in
contact, equal weights), the optimiser Adam. Every process sees its share of each global batch
(``--batch``, split evenly; a ``DistributedSampler`` over the training side's frames), so N
processes train the weights one process would with the same global batch. A checkpoint
(``FILE.checkpoint.pt``) is written every ``--checkpoint-every`` steps and at each epoch's end;
``--resume`` goes on from it. The weights of the epoch with the lowest validation loss (fringe's
loss over the validation side, as ``fringe train`` reports it) are saved. The targets are
``fringe train``'s (``--targets rounded``: |Fz| to 0.1 N, contact to 0.1 mm, as the paper's
reference rounds them); ``--targets recorded`` trains to the labels as recorded.
"""

import argparse
import json
import math
import os
import sys
import time

import torch
import torch.distributed as dist
import torch.nn.functional as F
from torch.nn.parallel import DistributedDataParallel
from torch.utils.data import DataLoader
from torch.utils.data.distributed import DistributedSampler

from .nets import ARCHITECTURES, build
from .torch import Dataset, Source, card, classes_of, save_model


def arguments(argv=None):
    p = argparse.ArgumentParser(prog="python -m fringe.train", description=__doc__.split("\n\n")[0])
    p.add_argument("runs", nargs="+",
                   help="run directories, or reference-layout datasets (fringe export, fringe sim dataset)")
    p.add_argument("--arch", choices=[a for a in ARCHITECTURES if a != "keypoint"] + ["keypoint"],
                   default="custom")
    p.add_argument("--out", required=True, help="the model file to write (.safetensors)")
    p.add_argument("--epochs", type=int, default=10)
    p.add_argument("--max-steps", type=int, default=None,
                   help="stop after this many optimiser steps in all")
    p.add_argument("--batch", type=int, default=32, help="the global batch (over all processes)")
    p.add_argument("--lr", type=float, default=1e-3)
    p.add_argument("--init", default=None, metavar="FILE.safetensors",
                   help="start from these weights (a model of the same architecture and classes)")
    p.add_argument("--size", type=int, default=112, help="input side, px")
    p.add_argument("--colour", choices=["grey", "rgb"], default="grey")
    p.add_argument("--augment", choices=["gray10", "rgb3", "rgb3-clean"], default=None,
                   help="one of the paper's augmentation pipelines on the training side (sets the colour)")
    p.add_argument("--targets", choices=["rounded", "recorded"], default="rounded",
                   help="Fz and contact targets: rounded as fringe train rounds them (0.1 N, 0.1 mm), "
                        "or as recorded")
    p.add_argument("--seed", type=int, default=0, help="initial weights and batch order")
    p.add_argument("--split-seed", type=int, default=42, help="fringe's split by press")
    p.add_argument("--workers", type=int, default=2, help="DataLoader workers per process")
    p.add_argument("--checkpoint-every", type=int, default=200, metavar="STEPS")
    p.add_argument("--resume", action="store_true", help="go on from FILE.checkpoint.pt")
    p.add_argument("--amp", choices=["auto", "on", "off"], default="auto",
                   help="mixed precision (bfloat16) on CUDA; auto: on when training on CUDA")
    p.add_argument("--log-every", type=int, default=20, metavar="STEPS")
    a = p.parse_args(argv)
    if not a.out.endswith(".safetensors"):
        p.error(f"--out {a.out}: fringe reads trained weights as .safetensors")
    return a


def log(*parts):
    print(*parts, flush=True)


class Processes:
    """This process's place among the ones torchrun started (one process without torchrun)."""

    def __init__(self):
        self.world = int(os.environ.get("WORLD_SIZE", "1"))
        self.rank = int(os.environ.get("RANK", "0"))
        self.local = int(os.environ.get("LOCAL_RANK", "0"))
        self.cuda = torch.cuda.is_available()
        self.device = torch.device(f"cuda:{self.local}" if self.cuda else "cpu")
        if self.world > 1:
            dist.init_process_group("nccl" if self.cuda else "gloo")
        if self.cuda:
            torch.cuda.set_device(self.device)

    @property
    def main(self):
        return self.rank == 0

    def sum(self, value):
        if self.world == 1:
            return value
        t = torch.tensor(float(value), dtype=torch.float64)
        dist.all_reduce(t)
        return t.item()

    def close(self):
        if self.world > 1:
            dist.destroy_process_group()


def losses(out, batch, contact_rows_in_global_batch, world):
    """fringe's loss of this process's share of a global batch, scaled so that the processes'
    gradients, averaged by DDP, are those of the whole batch's loss."""
    force, logits, contact = out
    fz = F.mse_loss(force[:, 2].float(), batch["fz"])
    shape = F.cross_entropy(logits.float(), batch["shape"])
    on = batch["in_contact"]
    if contact_rows_in_global_batch > 0:
        sq = ((contact.float()[on] - batch["contact"][on]) ** 2).sum() / 2.0
        point = sq * world / contact_rows_in_global_batch
    else:
        point = force.sum() * 0.0
    return fz + shape + point, (fz.item(), shape.item(), point.item() / world)


def evaluate(net, loader, device):
    """Fz RMSE (N), contact RMSE (mm) and shape accuracy over a side, and its loss as ``fringe
    train`` computes it: each batch's loss (batches of 64) weighted by its frames."""
    net.eval()
    n = n_contact = correct = 0
    sq_fz = sq_c = loss_sum = 0.0
    with torch.no_grad():
        for b in loader:
            b = {k: v.to(device) for k, v in b.items()}
            force, logits, contact = net(b["input"])
            rows = len(b["fz"])
            n += rows
            sq_fz += ((force[:, 2].float() - b["fz"]) ** 2).sum().item()
            correct += (logits.argmax(1) == b["shape"]).sum().item()
            on = b["in_contact"]
            n_contact += int(on.sum())
            sq_on = ((contact.float()[on] - b["contact"][on]) ** 2).sum().item()
            sq_c += sq_on / 2.0
            batch_loss = F.mse_loss(force[:, 2].float(), b["fz"]).item() + \
                F.cross_entropy(logits.float(), b["shape"]).item()
            if int(on.sum()):
                batch_loss += sq_on / (2.0 * int(on.sum()))
            loss_sum += batch_loss * rows
    net.train()
    if n == 0:
        return None
    fz_rmse = math.sqrt(sq_fz / n)
    c_rmse = math.sqrt(sq_c / n_contact) if n_contact else float("nan")
    return {"frames": n, "loss": loss_sum / n, "fz_rmse_n": fz_rmse, "contact_rmse_mm": c_rmse,
            "shape_accuracy": correct / n}


def initial_weights(net, path, arch, classes):
    """Loads ``path``'s weights into ``net``, refusing a model of another architecture or
    classes (its card says)."""
    from safetensors import safe_open
    from safetensors.torch import load_file

    if not os.path.exists(path):
        raise SystemExit(f"--init {path}: no such file")
    with safe_open(path, "pt") as f:
        meta = f.metadata() or {}
    card_text = meta.get("fringe.model_card")
    stem = os.path.splitext(path)[0]
    if card_text is None and os.path.exists(stem + ".json"):
        with open(stem + ".json") as f:
            card_text = f.read()
    if card_text is not None:
        c = json.loads(card_text)
        if c.get("architecture", arch) != arch or c.get("classes", classes) != classes:
            raise SystemExit(f"--init {path}: a {c.get('architecture')} on classes "
                             f"{c.get('classes')}, not {arch} on {classes}")
    missing, unexpected = net.load_state_dict(load_file(path), strict=False)
    if missing or unexpected:
        raise SystemExit(f"--init {path}: its weights are not those of {arch} "
                         f"(missing {missing[:3]}, unexpected {unexpected[:3]})")


def main(argv=None):
    a = arguments(argv)
    procs = Processes()
    if a.batch % procs.world:
        raise SystemExit(f"--batch {a.batch} does not share evenly over {procs.world} processes")
    runs = [Source(r) for r in a.runs]
    classes = classes_of(runs)
    if a.augment is not None:
        a.colour = "grey" if a.augment == "gray10" else "rgb"
    train = Dataset(runs, "train", size=a.size, colour=a.colour, split_seed=a.split_seed,
                    classes=classes, augment=a.augment, augment_seed=a.split_seed,
                    targets=a.targets)
    val = Dataset(runs, "val", size=a.size, colour=a.colour, split_seed=a.split_seed,
                  classes=classes, targets=a.targets)
    if len(train) < a.batch:
        raise SystemExit(f"{len(train)} training frames, fewer than one batch of {a.batch}")
    per = a.batch // procs.world
    sampler = DistributedSampler(train, num_replicas=procs.world, rank=procs.rank, shuffle=True,
                                 seed=a.seed, drop_last=True)
    loader = DataLoader(train, batch_size=per, sampler=sampler, drop_last=True,
                        num_workers=a.workers, persistent_workers=a.workers > 0)
    val_loader = DataLoader(val, batch_size=64, num_workers=0)
    torch.manual_seed(a.seed)
    net = build(a.arch, len(classes))
    if a.init is not None and not a.resume:
        initial_weights(net, a.init, a.arch, classes)
    net = net.to(procs.device)
    model = DistributedDataParallel(net, device_ids=[procs.local] if procs.cuda else None) \
        if procs.world > 1 else net
    opt = torch.optim.Adam(model.parameters(), lr=a.lr)
    amp = procs.cuda and a.amp != "off"
    if a.amp == "on" and not procs.cuda:
        log("warning: --amp on: no CUDA device, training in float32")
    checkpoint = os.path.splitext(a.out)[0] + ".checkpoint.pt"
    epoch, step, history, best = 0, 0, [], None
    if a.resume:
        if not os.path.exists(checkpoint):
            raise SystemExit(f"--resume: no checkpoint {checkpoint}: train without --resume first")
        state = torch.load(checkpoint, map_location=procs.device, weights_only=False)
        if state["arch"] != a.arch or state["classes"] != classes:
            raise SystemExit(f"{checkpoint} is of {state['arch']} on classes {state['classes']}, "
                             f"not {a.arch} on {classes}: give the same runs and --arch")
        net.load_state_dict(state["net"])
        opt.load_state_dict(state["opt"])
        epoch, step, history, best = state["epoch"], state["step"], state["history"], state["best"]
        if procs.main:
            log(f"resumed from {checkpoint}: epoch {epoch + 1}, step {step}")
    steps_per_epoch = len(loader)
    total = a.epochs * steps_per_epoch if a.max_steps is None else min(a.max_steps, a.epochs * steps_per_epoch)
    if procs.main:
        log(f"training {a.arch} on {len(train)} inputs ({len(train.frame)} frames of "
            f"{len(set(train.presses))} presses{'' if a.augment is None else ', ' + a.augment}; "
            f"{len(val)} validation frames) from {len(runs)} run(s), classes {classes}, "
            f"{procs.world} process(es) on {procs.device.type}, global batch {a.batch}, "
            f"{steps_per_epoch} steps an epoch, {total} steps")

    def save_checkpoint(epoch_done):
        if not procs.main:
            return
        tmp = checkpoint + ".partial"
        torch.save({"arch": a.arch, "classes": classes, "net": net.state_dict(),
                    "opt": opt.state_dict(), "epoch": epoch_done, "step": step,
                    "history": history, "best": best, "args": vars(a)}, tmp)
        os.replace(tmp, checkpoint)

    started = time.monotonic()
    images = 0
    while epoch < a.epochs and step < total:
        sampler.set_epoch(epoch)
        skip = step - epoch * steps_per_epoch
        for k, batch in enumerate(loader):
            if k < skip:
                continue
            batch = {key: v.to(procs.device) for key, v in batch.items()}
            contact_rows = procs.sum(int(batch["in_contact"].sum()))
            with torch.autocast("cuda", dtype=torch.bfloat16, enabled=amp):
                out = model(batch["input"])
            loss, parts = losses(out, batch, contact_rows, procs.world)
            opt.zero_grad(set_to_none=True)
            loss.backward()
            opt.step()
            step += 1
            images += len(batch["fz"]) * procs.world
            if procs.main and (step % a.log_every == 0 or step == total):
                rate = images / max(time.monotonic() - started, 1e-9)
                log(f"epoch {epoch + 1}/{a.epochs} step {step}/{total}: loss {loss.item():.4f} "
                    f"(Fz {parts[0]:.4f}, shape {parts[1]:.4f}, contact {parts[2]:.4f}), "
                    f"{rate:.0f} images/s")
            if step % a.checkpoint_every == 0:
                save_checkpoint(epoch)
            if step >= total:
                break
        finished_epoch = step >= (epoch + 1) * steps_per_epoch
        figures = evaluate(net, val_loader, procs.device) if procs.main else None
        if procs.main and figures is not None:
            log(f"epoch {epoch + 1}: validation loss {figures['loss']:.4f}, Fz RMSE "
                f"{figures['fz_rmse_n']:.4f} N, contact "
                f"RMSE {figures['contact_rmse_mm']:.4f} mm, shape {figures['shape_accuracy']:.4f}")
        if procs.main:
            history.append({"epoch": epoch + 1, "step": step, "validation": figures})
            score = None if figures is None else figures["loss"]
            if best is None or score is None or best.get("loss") is None or score <= best["loss"]:
                best = {"epoch": epoch + 1, "loss": score, "state": {
                    k: v.detach().cpu().clone() for k, v in net.state_dict().items()}}
        if finished_epoch:
            epoch += 1
        save_checkpoint(epoch)
        if not finished_epoch:
            break
    if procs.main:
        if best is not None and len(val) > 0:
            net.load_state_dict(best["state"])
        made = {"what": f"python -m fringe.train {' '.join(sys.argv[1:] if argv is None else argv)}",
                "processes": procs.world, "device": procs.device.type}
        c = card(a.arch, classes, a.size, a.colour, runs,
                 training={"runs": [r.name for r in runs], "steps": step, "init": a.init, "batch": a.batch,
                           "lr": a.lr, "seed": a.seed, "pipeline": a.augment,
                           "targets": a.targets,
                           "split": {"seed": a.split_seed, "by": "press",
                                     "fractions": list(train.fractions)},
                           "history": history,
                           "kept_epoch": None if best is None else best["epoch"]},
                 made_by=made)
        save_model(net, a.out, c)
        log(f"model: {a.out} (card beside it and inside it); checkpoint {checkpoint}")
    procs.close()


if __name__ == "__main__":
    main()
