"""fringe's runs for PyTorch: a ``Dataset`` with fringe's split by press, and models saved as
fringe reads them.

    from fringe.torch import Dataset
    train = Dataset(["runs/a", "runs/b"], "train", size=112, colour="grey")
    val = Dataset(["runs/a", "runs/b"], "val", size=112, colour="grey")
    loader = torch.utils.data.DataLoader(train, batch_size=32, shuffle=True, num_workers=2)

The split is the one ``fringe train`` makes (the same seed gives the same sides): every frame of a
press is on one side, so no press is trained on and tested on. Frames are decoded and
preprocessed by fringe's Rust code with the interpreter released, a batch at a time
(``__getitems__``), in each ``DataLoader`` worker.
"""

import json
import os

import numpy as np
import torch

from . import _native
from .run import Run

SIDES = ("train", "val", "test")
NO_CONTACT = "None"


def classes_of(runs):
    """The shape classes ``fringe train`` gives data: "None", then the shapes it holds, sorted."""
    names = set()
    for run in runs:
        names.update(s for s in run.training_labels()["shape"] if s != NO_CONTACT)
    return [NO_CONTACT] + sorted(names)


class Dataset(torch.utils.data.Dataset):
    """The labelled frames of ``runs`` on one side (``train``, ``val``, ``test``) of fringe's split
    by press.

    Each item is a dict: ``input`` (3 x size x size float32, fringe's one preprocessing with the
    run's calibration profile), ``force`` (7 magnitudes, N and N m), ``fz``, ``shape`` (the class
    index in ``classes``), ``contact`` (mm; zeros without contact), ``in_contact``, and where it
    came from (``run``, ``frame``). Give ``model`` (a ``fringe.Model``) to preprocess as that
    model's card says, or ``size`` and ``colour``.

    ``augment`` names one of the paper's augmentation pipelines, as ``fringe train --pipeline``
    makes them: ``gray10`` (grey, 10 copies of each frame, 5 grey levels of noise), ``rgb3``
    (RGB, 3 copies, noise), ``rgb3-clean`` (RGB, 3 copies). Each copy is the frame turned by
    a uniform angle about its optical centre, its contact label turned with it; the angles
    and noise come from ``augment_seed``, the frame and the copy alone, so every epoch and every
    process sees the same copies. The pipeline sets the colour.
    """

    def __init__(self, runs, side="train", *, model=None, size=None, colour="grey",
                 split_seed=42, fractions=(0.8, 0.1, 0.1), classes=None, augment=None,
                 augment_seed=42):
        if side not in SIDES:
            raise ValueError(f"side {side!r}: give train, val or test")
        self.runs = [r if isinstance(r, Run) else Run(r) for r in runs]
        if not self.runs:
            raise ValueError("no runs given")
        if model is not None:
            size, colour = model.input_size, model.colour
        if size is None:
            raise TypeError("give the input size (size=...) or a model")
        self.augment, self.augment_seed = augment, int(augment_seed)
        self.copies = {None: 1, "gray10": 10, "rgb3": 3, "rgb3-clean": 3}.get(augment)
        if self.copies is None:
            raise ValueError(f"augment={augment!r}: give gray10, rgb3 or rgb3-clean")
        if augment is not None:
            colour = "grey" if augment == "gray10" else "rgb"
        self.size, self.colour, self.side = int(size), colour, side
        self.split_seed, self.fractions = split_seed, tuple(fractions)
        self.classes = list(classes) if classes is not None else classes_of(self.runs)
        sides = _native.split_runs([r._native for r in self.runs], split_seed, self.fractions)
        want = SIDES.index(side)
        run_of, frame, force, shape, contact, press = [], [], [], [], [], []
        for k, (run, s) in enumerate(zip(self.runs, sides)):
            t = run.training_labels()
            on = np.asarray(s, dtype=np.int64) == want
            for j in np.flatnonzero(on):
                if t["shape"][j] not in self.classes:
                    raise ValueError(
                        f"{run.path}: frame {int(t['index'][j])} shows {t['shape'][j]!r}, which "
                        f"is none of the classes {self.classes}"
                    )
                run_of.append(k)
                frame.append(int(t["index"][j]))
                force.append(t["force"][j])
                shape.append(self.classes.index(t["shape"][j]))
                contact.append(t["contact_mm"][j])
                press.append(t["press"][j])
        self.run_of = np.asarray(run_of, dtype=np.int64)
        self.frame = np.asarray(frame, dtype=np.int64)
        self.force = np.asarray(force, dtype=np.float32).reshape(-1, 7)
        self.shape = np.asarray(shape, dtype=np.int64)
        c = np.asarray(contact, dtype=np.float64).reshape(-1, 2)
        self.in_contact = ~np.isnan(c).any(axis=1)
        self.contact = np.nan_to_num(c).astype(np.float32)
        self.presses = press

    def __len__(self):
        return len(self.frame) * self.copies

    def _items(self, positions, inputs, contacts=None):
        out = []
        for k, (p, x) in enumerate(zip(positions, inputs)):
            contact = self.contact[p] if contacts is None else np.nan_to_num(contacts[k]).astype(np.float32)
            out.append({
                "input": torch.from_numpy(np.ascontiguousarray(x)),
                "force": torch.from_numpy(self.force[p]),
                "fz": torch.tensor(self.force[p][2]),
                "shape": torch.tensor(self.shape[p]),
                "contact": torch.from_numpy(contact),
                "in_contact": torch.tensor(bool(self.in_contact[p])),
                "run": torch.tensor(self.run_of[p]),
                "frame": torch.tensor(self.frame[p]),
            })
        return out

    def __getitem__(self, position):
        return self.__getitems__([position])[0]

    def __getitems__(self, positions):
        """A batch: its frames decoded and preprocessed in Rust, run by run, the interpreter
        released."""
        positions = [int(p) for p in positions]
        if self.augment is not None:
            return self._augmented(positions)
        inputs = [None] * len(positions)
        by_run = {}
        for slot, p in enumerate(positions):
            by_run.setdefault(int(self.run_of[p]), []).append(slot)
        for k, slots in by_run.items():
            frames = [int(self.frame[positions[s]]) for s in slots]
            x, _ = self.runs[k]._native.inputs_at(self.size, self.colour, frames, False)
            for s, xi in zip(slots, x):
                inputs[s] = xi
        return self._items(positions, inputs)

    def _augmented(self, positions):
        bases = [p // self.copies for p in positions]
        inputs, contacts = [None] * len(positions), [None] * len(positions)
        by_run = {}
        for slot, p in enumerate(positions):
            by_run.setdefault(int(self.run_of[bases[slot]]), []).append(slot)
        for k, slots in by_run.items():
            wanted = [(int(self.frame[bases[s]]), bases[s], positions[s] % self.copies) for s in slots]
            x, c = self.runs[k]._native.augmented(self.size, self.augment, self.augment_seed, wanted)
            for j, s in enumerate(slots):
                inputs[s], contacts[s] = x[j], c[j]
        return self._items(bases, inputs, contacts)


def card(arch, classes, size, colour, runs, **other):
    """A model card for a network trained on ``runs``: what fringe reads to run it (architecture,
    classes, input size, colour, preprocessing from the sensor's profile, the sensor's design and
    scale) and ``other`` (training record, split, figures)."""
    c = {
        "architecture": arch,
        "classes": list(classes),
        "input_size": int(size),
        "colour": colour,
        "preprocessing": "profile",
    }
    ids = {r.sensor_id for r in runs}
    variants = {r.variant for r in runs}
    if len(ids) == 1:
        c["sensor_id"] = ids.pop()
    if len(variants) == 1 and None not in variants:
        c["variant"] = variants.pop()
    profile = runs[0].profile if runs else None
    if profile is not None:
        c["crop_diameter_px"] = 2.0 * float(profile["optical"]["crop_radius_px"])
        c["frame_size"] = [int(profile["image"]["width"]), int(profile["image"]["height"])]
    c.update(other)
    return c


def save_model(net, path, model_card):
    """Writes ``net``'s weights as safetensors at ``path`` with ``model_card`` inside the file
    (``__metadata__["fringe.model_card"]``) and beside it (``<stem>.json``), as ``fringe train``
    writes a model."""
    from safetensors.torch import save_file

    net = getattr(net, "module", net)
    state = {k: v.detach().cpu().contiguous() for k, v in net.state_dict().items()}
    text = json.dumps(model_card, indent=1)
    path = os.fspath(path)
    tmp = path + ".partial"
    save_file(state, tmp, metadata={"fringe.model_card": text})
    os.replace(tmp, path)
    stem = os.path.splitext(path)[0]
    with open(stem + ".json.partial", "w") as f:
        f.write(text + "\n")
    os.replace(stem + ".json.partial", stem + ".json")
