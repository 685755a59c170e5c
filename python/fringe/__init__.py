"""fringe from Python: runs, the one preprocessing and the models of fringe.

Runs are read by fringe's own run reader and frame codecs (the Rust code, through the
``fringe._native`` extension), so a frame, a label or a network input read here is the one
``fringe eval`` and ``fringe train`` read, bit for bit.

    import fringe
    run = fringe.Run("runs/2026-12-01T10-00-00Z-short-grid")
    len(run), run.frame(0).shape, run.labels().head()
    model = fringe.Model.for_run(run)            # the model `fringe eval` would pick
    predicted = model.predict_run(run)           # dict of NumPy arrays keyed like the labels

``fringe.torch`` has a PyTorch ``Dataset`` with fringe's split by press, and
``python -m fringe.train`` trains fringe's networks with PyTorch's distributed engine.
"""

from ._native import (
    LAYOUT_VERSION,
    FrameError,
    FringeError,
    ModelError,
    RunError,
    __version__,
)
from .model import Model
from .run import IncompleteRunWarning, Run

__all__ = [
    "Run",
    "Model",
    "FringeError",
    "RunError",
    "FrameError",
    "ModelError",
    "IncompleteRunWarning",
    "LAYOUT_VERSION",
    "__version__",
]
