#!/usr/bin/env python3
"""Checks an ONNX file that `fringe model export` wrote: onnx.checker accepts it (full check,
with shape inference) and onnxruntime runs it on the fixture inputs with the outputs PyTorch
computed (expected.json beside the inputs), within 1e-4.

usage: check_onnx.py MODEL.onnx EXPECTED.json WEIGHTS_KEY
"""
import json
import os
import sys

import numpy as np
import onnx
import onnxruntime as ort


def main():
    path, expected_path, key = sys.argv[1:4]
    model = onnx.load(path)
    onnx.checker.check_model(model, full_check=True)
    expected = json.load(open(expected_path))
    inputs = expected["inputs"]
    x = np.fromfile(os.path.join(os.path.dirname(expected_path), inputs["file"]), dtype="<f4")
    x = x.reshape(inputs["shape"])
    session = ort.InferenceSession(path, providers=["CPUExecutionProvider"])
    names = [o.name for o in session.get_outputs()]
    assert names == ["force", "shape_logits", "contact"], names
    got = dict(zip(names, session.run(None, {session.get_inputs()[0].name: x})))
    want = expected["outputs"][key]
    worst = 0.0
    for name in names:
        d = float(np.max(np.abs(got[name] - np.asarray(want[name], dtype=np.float32))))
        print(f"{name}: max |onnxruntime - torch| {d:.2e}")
        worst = max(worst, d)
    if worst > 1e-4:
        sys.exit(f"outputs differ by {worst}")


if __name__ == "__main__":
    main()
