"""``fringe.Model``: a model as fringe opens and runs it."""

import json
import os
import warnings

import numpy as np

from . import _native


def _warn(notes):
    for n in notes:
        if n.startswith("warning: "):
            warnings.warn(n[len("warning: "):], stacklevel=3)


class Model:
    """A model as the command line takes it: a ``.pth`` / ``.pt``, ``.safetensors`` or ``.onnx``
    file with its card, ``"default"``, or ``"builtin:NAME"``; run on fringe's inference backend
    (``tract``; ``onnxruntime`` and ``torch`` when fringe was built with them) with its card's
    preprocessing.

    Predictions are dicts of NumPy arrays keyed like the labels: ``fx fy fz mx my mz ft`` (the
    magnitudes the networks are trained on), ``contact_x_mm contact_y_mm`` (NaN where no contact
    is predicted), ``shape``, ``probabilities`` (frames x classes, in ``model.classes`` order).
    """

    def __init__(self, name_or_path="default", *, backend="tract", threads=2):
        self._native = _native.Model(os.fspath(name_or_path), backend, int(threads))
        _warn(self._native.notes)

    @classmethod
    def _wrap(cls, native):
        m = cls.__new__(cls)
        m._native = native
        _warn(native.notes)
        return m

    @classmethod
    def for_run(cls, run, *, profiles=None, backend="tract", threads=2):
        """The model ``fringe eval`` runs on ``run`` without ``--model``: its sensor's newest
        passing commissioned model under ``profiles`` (default: the rig file's profiles, as for
        the command), else the model that ships for the sensor's design."""
        from .run import Run

        if not isinstance(run, Run):
            run = Run(run)
        native = _native.Model.for_run(
            run._native, None if profiles is None else os.fspath(profiles), backend, int(threads)
        )
        return cls._wrap(native)

    def __repr__(self):
        return f"fringe.Model({str(self.path)!r}: {self.arch or 'network'}, {self.input_size} px {self.colour})"

    @property
    def path(self):
        return self._native.path

    @property
    def notes(self):
        """What choosing the model said (the commissioned model taken, warnings)."""
        return list(self._native.notes)

    @property
    def classes(self):
        return list(self._native.classes)

    @property
    def input_size(self):
        return self._native.input_size

    @property
    def colour(self):
        return self._native.colour

    @property
    def arch(self):
        return self._native.arch

    @property
    def card(self):
        """The model card (a dict), or ``None`` for a model without one."""
        c = self._native.card_json()
        return None if c is None else json.loads(c)

    def inputs(self, run, indices=None, on_damaged="raise", return_indices=False):
        """What this model sees of ``run``'s frames: ``run.inputs(model)``."""
        return run.inputs(self, indices=indices, on_damaged=on_damaged,
                          return_indices=return_indices)

    def predict(self, frames, *, pixel_format=None, profile=None):
        """Predictions on ``frames``.

        - Network inputs (float32, frames x 3 x size x size, as ``run.inputs(model)`` gives
          them) run as they are (one-network models).
        - Camera frames (``uint8``; one frame or a batch; rows x columns x 3 RGB8, or rows x
          columns with ``pixel_format`` ``"mono8"`` or ``"bayerrg8"``) are preprocessed with
          the calibration profile in file ``profile``, else as the model's card says.
        """
        if isinstance(frames, np.ndarray) and frames.dtype == np.float32:
            if frames.ndim == 3:
                frames = frames[None]
            return self._native.predict_inputs(np.ascontiguousarray(frames))
        if isinstance(frames, np.ndarray):
            if frames.dtype != np.uint8:
                raise TypeError(
                    f"frames of dtype {frames.dtype}: give camera frames as uint8, or network "
                    "inputs as float32"
                )
            one = frames.ndim == 2 or (frames.ndim == 3 and frames.shape[-1] == 3 and pixel_format in (None, "rgb8"))
            batch = [frames] if one else list(frames)
        else:
            batch = list(frames)
        if not batch:
            raise ValueError("no frames given")
        if pixel_format is None:
            if batch[0].ndim == 3 and batch[0].shape[-1] == 3:
                pixel_format = "rgb8"
            else:
                raise ValueError(
                    "one-channel frames: say what they hold, pixel_format=\"mono8\" or "
                    "\"bayerrg8\" (a run's run.pixel_format)"
                )
        batch = [np.ascontiguousarray(f, dtype=np.uint8) for f in batch]
        return self._native.predict_frames(
            batch, pixel_format, None if profile is None else os.fspath(profile)
        )

    def predict_run(self, run, indices=None, on_damaged="raise"):
        """Predictions on ``run``'s frames ``indices`` (all when ``None``), each preprocessed
        with the run's calibration profile as ``fringe eval`` does; ``index`` says which frame
        each row is (``on_damaged="skip"`` leaves damaged frames out)."""
        from .run import Run, _skip

        if not isinstance(run, Run):
            run = Run(run)
        skip = _skip(on_damaged)
        idx = None if indices is None else [int(i) for i in indices]
        return self._native.predict_run(run._native, idx, skip)
