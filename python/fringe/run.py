"""``fringe.Run``: one run directory, as fringe reads it."""

import json
import os
import warnings

import numpy as np

from . import _native

# The label columns every run has, in the order ``labels()`` gives them.
LABEL_COLUMNS = (
    "index", "frame_id", "point", "valid",
    "fx", "fy", "fz", "mx", "my", "mz",
    "contact_x_mm", "contact_y_mm", "shape",
    "shear_x_n", "shear_y_n", "slip",
    "exposure_start_ns", "exposure_end_ns", "exposure_error_ns",
    "exposure_start_tick", "exposure_end_tick",
    "host_arrival_ns", "device_timestamp",
    "commanded_x_mm", "commanded_y_mm", "commanded_z_mm",
    "measured_x_mm", "measured_y_mm", "measured_z_mm",
    "file", "notes",
)

_ON_DAMAGED = ("raise", "skip")


class IncompleteRunWarning(UserWarning):
    """A run that was not closed: still being written, or cut off by a crash."""


def _skip(on_damaged):
    if on_damaged not in _ON_DAMAGED:
        raise ValueError(f"on_damaged={on_damaged!r}: give 'raise' or 'skip'")
    return on_damaged == "skip"


class Run:
    """A run directory of fringe (``fringe scan``, ``fringe calibrate``, a commissioning's
    rounds), read through fringe's own run reader.

    ``len(run)`` is the number of frame records; ``run.frame(i)`` is frame ``i`` exactly as
    stored (NumPy ``uint8``: rows x columns for Mono8 and the raw BayerRG8 mosaic, rows x
    columns x 3 for RGB8; the stored cutout for a run that keeps only the disc).
    ``run.labels()`` is one row per frame with every label. A run of a newer layout than this
    fringe reads is refused (``RunError``); a run not closed is read as far as it was recorded,
    with an ``IncompleteRunWarning``.
    """

    def __init__(self, path):
        self._path = os.fspath(path)
        self._native = _native.Run(self._path)
        self.metadata = json.loads(self._native.start_json())
        if not self._native.closed:
            warnings.warn(
                f"{self._path}: the run was not closed (it is being written, or a crash cut it "
                f"off): reading the {len(self)} frames recorded so far",
                IncompleteRunWarning,
                stacklevel=2,
            )

    def __len__(self):
        return len(self._native)

    def __reduce__(self):
        # Opened again where it is unpickled (a DataLoader worker started by spawn).
        return (Run, (self._path,))

    def __repr__(self):
        return f"fringe.Run({self._path!r}: {len(self)} frames, sensor {self.sensor_id})"

    def __getitem__(self, index):
        return self.frame(index)

    def __iter__(self):
        for i in range(len(self)):
            yield self.frame(i)

    # What the run is.
    @property
    def path(self):
        return self._path

    @property
    def closed(self):
        """Whether the run was closed whole (stop document and manifest written)."""
        return self._native.closed

    @property
    def run_id(self):
        return self.metadata["run_id"]

    @property
    def sensor_id(self):
        return self.metadata["sensor_id"]

    @property
    def variant(self):
        """The sensor's design (``layered``, ``integrated``), when the run says."""
        return self.metadata.get("variant")

    @property
    def plan(self):
        """The scan plan as given (TOML text)."""
        return self.metadata["plan"]

    @property
    def rig(self):
        """The rig configuration as used (TOML text)."""
        return self.metadata["rig"]

    @property
    def sync_method(self):
        """How frames were placed on the force stream: ``strobe``, ``clock-fit`` or ``host``."""
        return self.metadata["sync_method"]

    @property
    def frame_storage(self):
        """How the frames are stored: pixel format, cutout (the crop kept), encoding."""
        return self.metadata["frame_storage"]

    @property
    def pixel_format(self):
        return self.frame_storage["pixel_format"]

    @property
    def crop(self):
        """The part of each camera frame stored (``x``, ``y``, ``width``, ``height`` in the
        camera's frame of ``frame_width`` x ``frame_height``), or ``None`` for whole frames."""
        return self.frame_storage.get("cutout")

    @property
    def profile(self):
        """The calibration profile the run was labelled with (a dict), or ``None``."""
        return self.metadata.get("profile")

    @property
    def frame_size(self):
        """The camera's frame size (width, height) in px."""
        crop = self.crop
        if crop is not None:
            return (crop["frame_width"], crop["frame_height"])
        if len(self) == 0:
            return None
        f = self.frame(0)
        return (f.shape[1], f.shape[0])

    # Frames.
    def frame(self, index):
        """Frame ``index`` as stored (NumPy ``uint8``); raises ``FrameError`` naming the file when
        it is missing or damaged."""
        return self._native.frame(int(index))

    def frames(self, indices=None, on_damaged="raise"):
        """Frames ``indices`` (all when ``None``) as a list, decoded in Rust with the interpreter
        released. ``on_damaged="skip"`` leaves damaged frames out and returns ``(frames,
        indices kept)``."""
        skip = _skip(on_damaged)
        idx = range(len(self)) if indices is None else indices
        frames, kept = self._native.frames([int(i) for i in idx], skip)
        return (frames, kept) if skip else frames

    # Labels.
    def label_arrays(self):
        """Every label as a NumPy array (or a list of strings), one entry per frame record:
        forces and moments as recorded (signed, N and N m, averaged over the frame's exposure;
        NaN where none), contact point (mm from the sensor centre; NaN without contact), shape,
        shear (the push on the surface in the sensor's frame, N, signed; NaN where the run does
        not know the F/T's axes), slip state (``stick``, ``partial_slip``, ``gross_slip``, or
        ``None`` without contact or where it cannot be told), exposure window (host ns, and in the F/T stream's sample index under strobe sync),
        arrival time, stage positions, validity and notes."""
        return self._native.label_columns()

    def labels(self):
        """``label_arrays()`` as a pandas ``DataFrame``, one row per frame, indexed by frame."""
        import pandas as pd

        columns = self.label_arrays()
        frame = pd.DataFrame({k: columns[k] for k in LABEL_COLUMNS})
        return frame.set_index("index", drop=False).rename_axis("frame")

    def training_labels(self):
        """The frames fringe trains and evaluates on and their labels under fringe's label rules
        (force magnitudes ``[Fx Fy Fz Mx My Mz |F|]``, no contact under the noise floor): a dict
        with ``index`` (frame), ``force`` (n x 7), ``contact_mm`` (n x 2, NaN without contact),
        ``stage_mm``, ``shape``, ``press`` (frames of one press never land on two sides of a
        split), ``shear_n`` (n x 2, signed, sensor frame; NaN where unknown) and ``slip``."""
        return self._native.training_labels()

    def events(self):
        """The run's events (pauses, resumes, re-presses, checkpoints...), as dicts."""
        return json.loads(self._native.events_json())

    def stop(self):
        """The stop document (how the run ended, counts), or ``None`` while it has not."""
        s = self._native.stop_json()
        return None if s is None else json.loads(s)

    # Network inputs.
    def inputs(self, model=None, *, size=None, colour="grey", indices=None,
               on_damaged="raise", return_indices=False):
        """What a network sees of frames ``indices`` (all when ``None``): float32, frames x 3 x
        size x size, made by fringe's one preprocessing with the run's calibration profile.

        Give ``model`` (a ``fringe.Model``, a model file or a built-in name) for exactly what
        ``fringe eval`` feeds that model, or ``size`` (px) and ``colour`` (``grey`` or ``rgb``)
        for a network of your own. ``on_damaged="skip"`` leaves damaged frames out;
        ``return_indices`` gives ``(inputs, indices kept)``."""
        skip = _skip(on_damaged)
        idx = None if indices is None else [int(i) for i in indices]
        if model is not None:
            from .model import Model

            if not isinstance(model, Model):
                model = Model(model)
            inputs, kept = model._native.inputs_of(self._native, idx, skip)
        elif size is not None:
            inputs, kept = self._native.inputs_at(int(size), colour, idx, skip)
        else:
            raise TypeError("give a model, or the input size (size=...) of a network of your own")
        return (inputs, np.asarray(kept, dtype=np.int64)) if return_indices else inputs
