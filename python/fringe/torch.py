"""fringe's runs for PyTorch: a ``Dataset`` with fringe's split by press, and models saved as
fringe reads them.

    from fringe.torch import Dataset
    train = Dataset(["runs/a", "runs/b"], "train", size=112, colour="grey")
    val = Dataset(["runs/a", "runs/b"], "val", size=112, colour="grey")
    loader = torch.utils.data.DataLoader(train, batch_size=32, shuffle=True, num_workers=2)

The split is the one ``fringe train`` makes (the same seed gives the same sides): every frame of a
press is on one side, so no press is trained on and tested on. The inputs are the ones ``fringe
train`` trains on, made by its Rust code with the interpreter released, a batch at a time
(``__getitems__``), in each ``DataLoader`` worker; each frame is decoded once for all its
augmented copies, and what is made is kept for the next epochs, shared by the workers.
"""

import json
import os
import random
import time

import numpy as np
import torch

from . import _native

SIDES = ("train", "val", "test")
NO_CONTACT = "None"


class Source:
    """A run or a reference-layout dataset (``0.images/`` + ``0.labels.csv``, as ``fringe export``
    and ``fringe sim dataset`` write it), its labelled frames read as ``fringe train`` reads them:
    the same samples, label rules, frame reader and calibration profile."""

    def __init__(self, path):
        self.path = os.fspath(getattr(path, "path", path))
        self._native = _native.Source(self.path)
        profile = self._native.profile_json()
        self.profile = json.loads(profile) if profile is not None else None

    def __len__(self):
        return len(self._native)

    def __reduce__(self):
        # Opened again where it is unpickled (a DataLoader worker started by spawn).
        return (Source, (self.path,))

    def __repr__(self):
        return f"fringe.torch.Source({self.path!r}: {len(self)} labelled frames)"

    @property
    def name(self):
        """The run's id (its directory's name), or the dataset directory's name."""
        return os.path.basename(os.path.normpath(self.path))

    @property
    def sensor_id(self):
        return self._native.sensor_id

    @property
    def variant(self):
        return self._native.variant

    def training_labels(self):
        """The labelled frames with the labels ``fringe train`` trains them to (``index``: the
        frame's record in a run, its row in a dataset), and the press of each."""
        return self._native.training_labels()


def _source(data):
    return data if isinstance(data, Source) else Source(data)


def classes_of(sources):
    """The shape classes ``fringe train`` gives data: "None", then the shapes it holds, sorted."""
    names = set()
    for source in sources:
        names.update(s for s in _source(source).training_labels()["shape"] if s != NO_CONTACT)
    return [NO_CONTACT] + sorted(names)


class Dataset(torch.utils.data.Dataset):
    """The labelled frames of ``runs`` on one side (``train``, ``val``, ``test``) of fringe's split
    by press. ``runs`` are run directories, ``fringe.Run``s, reference-layout datasets (as
    ``fringe export`` and ``fringe sim dataset`` write) or ``Source``s, read as ``fringe train``
    reads them.

    Each item is a dict: ``input`` (3 x size x size float32: what ``fringe train`` trains on,
    fringe's one preprocessing with the run's calibration profile, kept as 8-bit grey levels),
    ``force`` (7 magnitudes, N and N m), ``fz``, ``shape`` (the class
    index in ``classes``), ``contact`` (mm; zeros without contact), ``in_contact``, and where it
    came from (``run``, ``frame``). Give ``model`` (a ``fringe.Model``) to preprocess as that
    model's card says, or ``size`` and ``colour``.

    ``augment`` names one of the paper's augmentation pipelines, as ``fringe train --pipeline``
    makes them: ``gray10`` (grey, 10 copies of each frame, 5 grey levels of noise), ``rgb3``
    (RGB, 3 copies, noise), ``rgb3-clean`` (RGB, 3 copies). Each copy is the frame turned by
    a uniform angle about its optical centre, its contact label turned with it; the angles
    and noise come from ``augment_seed``, the frame and the copy alone, so every epoch and every
    process sees the same copies. The pipeline sets the colour.

    ``targets`` says what ``fz`` and ``contact`` hold: ``"recorded"`` (the default), the labels
    as recorded; ``"rounded"``, the targets ``fringe train`` trains to, as the paper's reference
    rounds them: |Fz| to 0.1 N and the (turned) contact to 0.1 mm, half away from zero.
    ``force`` is always as recorded.

    ``cache`` (on by default) keeps every input once made, as ``fringe train`` keeps its
    training set: in shared memory, so the ``DataLoader``'s workers share it, ``len(dataset)``
    x size x size bytes for grey inputs (three times that for RGB). A frame asked for is
    decoded once and all its copies made at once, so the first epoch does ``fringe train``'s
    preparation and the later ones read memory. With ``cache=False`` each item is made when
    asked (its frame decoded for each copy), for sets larger than memory.
    """

    def __init__(self, runs, side="train", *, model=None, size=None, colour="grey",
                 split_seed=42, fractions=(0.8, 0.1, 0.1), classes=None, augment=None,
                 augment_seed=42, cache=True, targets="recorded"):
        if side not in SIDES:
            raise ValueError(f"side {side!r}: give train, val or test")
        if targets not in ("recorded", "rounded"):
            raise ValueError(f"targets={targets!r}: give recorded or rounded")
        self.targets = targets
        self.sources = [_source(r) for r in runs]
        if not self.sources:
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
        self.classes = list(classes) if classes is not None else classes_of(self.sources)
        sides = _native.split_sources([r._native for r in self.sources], split_seed, self.fractions)
        want = SIDES.index(side)
        run_of, sample, frame, force, shape, contact, press = [], [], [], [], [], [], []
        for k, (run, s) in enumerate(zip(self.sources, sides)):
            t = run.training_labels()
            on = np.asarray(s, dtype=np.int64) == want
            for j in np.flatnonzero(on):
                if t["shape"][j] not in self.classes:
                    raise ValueError(
                        f"{run.path}: frame {int(t['index'][j])} shows {t['shape'][j]!r}, which "
                        f"is none of the classes {self.classes}"
                    )
                run_of.append(k)
                sample.append(int(j))
                frame.append(int(t["index"][j]))
                force.append(t["force"][j])
                shape.append(self.classes.index(t["shape"][j]))
                contact.append(t["contact_mm"][j])
                press.append(t["press"][j])
        self.run_of = np.asarray(run_of, dtype=np.int64)
        self.sample = np.asarray(sample, dtype=np.int64)
        self.frame = np.asarray(frame, dtype=np.int64)
        self.force = np.asarray(force, dtype=np.float32).reshape(-1, 7)
        self._fz64 = np.asarray(force, dtype=np.float64).reshape(-1, 7)[:, 2]
        self.shape = np.asarray(shape, dtype=np.int64)
        c = np.asarray(contact, dtype=np.float64).reshape(-1, 2)
        self.in_contact = ~np.isnan(c).any(axis=1)
        self.contact = np.nan_to_num(c).astype(np.float32)
        self.presses = press
        self.cache = bool(cache)
        if self.cache:
            n, s = len(self.frame), self.size
            planes = 1 if self.colour == "grey" else 3
            self._levels = torch.zeros((n, self.copies, planes, s, s), dtype=torch.uint8)
            self._contacts = torch.zeros((n, self.copies, 2), dtype=torch.float64)
            self._made = torch.zeros(n, dtype=torch.uint8)
            # The process making each frame (its pid; 0: none yet), so two workers do not
            # make one frame twice.
            self._maker = torch.zeros(n, dtype=torch.int64)
            for t in (self._levels, self._contacts, self._made, self._maker):
                t.share_memory_()

    def __len__(self):
        return len(self.frame) * self.copies

    def _items(self, bases, inputs, contacts):
        out = []
        contacts = np.nan_to_num(contacts)
        if self.targets == "rounded":
            contacts = _round1(contacts)
        for k, (p, x) in enumerate(zip(bases, inputs)):
            fz = self.force[p][2]
            if self.targets == "rounded":
                fz = _round1(self._fz64[p])
            out.append({
                "input": torch.from_numpy(np.ascontiguousarray(x)),
                "force": torch.from_numpy(self.force[p]),
                "fz": torch.tensor(np.float32(fz)),
                "shape": torch.tensor(self.shape[p]),
                "contact": torch.from_numpy(contacts[k].astype(np.float32)),
                "in_contact": torch.tensor(bool(self.in_contact[p])),
                "run": torch.tensor(self.run_of[p]),
                "frame": torch.tensor(self.frame[p]),
            })
        return out

    def __getitem__(self, position):
        return self.__getitems__([position])[0]

    def __getitems__(self, positions):
        """A batch: the inputs made in Rust, run by run, the interpreter released (or read from
        the cache)."""
        positions = [int(p) for p in positions]
        for p in positions:
            if not 0 <= p < len(self):
                raise IndexError(f"item {p} of a dataset of {len(self)}")
        bases = [p // self.copies for p in positions]
        copies = [p % self.copies for p in positions]
        if self.cache:
            self._make(sorted({b for b in bases if not self._made[b]}))
            levels = self._levels[bases, copies].numpy()
            contacts = self._contacts[bases, copies].numpy()
        else:
            levels, contacts = self._made_now(list(zip(bases, copies)))
        return self._items(bases, _native.expand_inputs(levels), contacts)

    def _made_now(self, wanted):
        """The inputs and contact labels of (item, copy) pairs ``wanted``, made in Rust run by
        run, in their order."""
        levels, contacts = [None] * len(wanted), [None] * len(wanted)
        by_run = {}
        for slot, (b, _) in enumerate(wanted):
            by_run.setdefault(int(self.run_of[b]), []).append(slot)
        for k, slots in by_run.items():
            # A frame's copies one after another: the Rust side decodes it once for them.
            slots.sort(key=lambda s: wanted[s])
            asked = [(int(self.sample[wanted[s][0]]), wanted[s][0], wanted[s][1]) for s in slots]
            x, c = self.sources[k]._native.training_inputs(
                self.size, self.augment, self.colour, self.augment_seed, asked)
            for j, s in enumerate(slots):
                levels[s], contacts[s] = x[j], c[j]
        return np.stack(levels), np.stack(contacts)

    def _make(self, items):
        """Every copy of ``items`` made and kept in the cache (a frame decoded once for all).
        A frame another live process is making is waited for instead of made again; while
        waiting, this process makes a frame no one has made yet (an epoch asks for them all)."""
        if not items:
            return
        me = os.getpid()
        mine = [b for b in items if not self._made[b] and not _alive(int(self._maker[b]), me)]
        for b in mine:
            self._maker[b] = me
        if mine:
            wanted = [(b, c) for b in mine for c in range(self.copies)]
            levels, contacts = self._made_now(wanted)
            n = self.copies
            for k, b in enumerate(mine):
                self._levels[b] = torch.from_numpy(levels[k * n:(k + 1) * n])
                self._contacts[b] = torch.from_numpy(contacts[k * n:(k + 1) * n])
                # Flagged after its copies are written: another worker reads it only then (two
                # workers that claimed one frame at once write the same bytes).
                self._made[b] = 1
        waiting = [b for b in items if not self._made[b]]
        while waiting:
            spare = torch.nonzero((self._made == 0) & (self._maker == 0)).flatten()
            if len(spare):
                # At random, so two waiting workers seldom pick the same frame; not torch's
                # generator, which the caller's own random transforms draw from.
                self._make([int(spare[_picker().randrange(len(spare))])])
            else:
                time.sleep(0.002)
            gone = [b for b in waiting if not self._made[b] and not _alive(int(self._maker[b]), me)]
            if gone:
                # Its maker ended before it was done (a worker stopped mid-epoch): make it here.
                self._make(gone)
            waiting = [b for b in waiting if not self._made[b]]


def _round1(v):
    """``v`` rounded to 0.1, half away from zero (Rust's ``f64::round``, as ``fringe train``
    rounds its targets), from the recorded float64 value."""
    x = np.asarray(v, dtype=np.float64) * 10.0
    whole = np.trunc(x)
    # x - trunc(x) is exact, so halves are found exactly.
    return (whole + np.where(np.abs(x - whole) >= 0.5, np.sign(x), 0.0)) / 10.0


_pick = {}


def _picker():
    """This process's own generator (forked workers would share a module-level one's state)."""
    me = os.getpid()
    if me not in _pick:
        _pick.clear()
        _pick[me] = random.Random(me)
    return _pick[me]


def _alive(pid, me):
    """Whether another process ``pid`` is running (0: none)."""
    if pid in (0, me):
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def card(arch, classes, size, colour, runs, **other):
    """A model card for a network trained on ``runs`` (``Source``s or ``fringe.Run``s): what
    fringe reads to run it (architecture,
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
