"""Timing experiment for issue 30 (BENCHMARKS.md, "ResNet-18 on a Sapphire Rapids machine"): is
an int8 ResNet-18 faster on tract than the f32 one? Writes int8 versions of a graph that
`model_bench --export DIR` wrote, with ONNX Runtime's quantiser, for `model_bench --profile`:

    model_bench --export DIR
    python int8_graphs.py DIR/resnet18.onnx
    model_bench --profile DIR/resnet18.onnx DIR/resnet18.qop.onnx DIR/resnet18.qdq.onnx DIR/resnet18.dyn.onnx

- `.qop.onnx`: QLinearConv (the operator format), int8 weights per output channel, uint8
  activations calibrated on random images;
- `.qdq.onnx`: float Conv between QuantizeLinear/DequantizeLinear pairs, the same ranges;
- `.dyn.onnx`: ConvInteger with activations quantised at run time.

The static formats quantise the convolutions, their ReLUs (folded into the output's range) and the
max pool, the dynamic one the convolutions; batch norm is folded into them first. The calibration images
are noise, so the outputs say nothing about accuracy: this times the plans, nothing else. Needs
onnx and onnxruntime (sensor-models/tests/python/requirements-models.txt).
"""
import sys
from collections import Counter

import numpy as np
import onnx
from onnxruntime.quantization import (CalibrationDataReader, QuantFormat, QuantType,
                                      quantize_dynamic, quantize_static)
from onnxruntime.quantization.shape_inference import quant_pre_process


class NoiseImages(CalibrationDataReader):
    def __init__(self, name, size):
        rng = np.random.default_rng(0)
        self.images = iter([{name: rng.random((1, 3, size, size), dtype=np.float32)} for _ in range(8)])

    def get_next(self):
        return next(self.images, None)


def fixed_batch(path, size):
    """One image of `size` px: the quantiser's calibration and tract's plan need fixed shapes, and
    the intermediate shapes the pre-processing wrote would name a symbolic batch."""
    m = onnx.load(path)
    del m.graph.value_info[:]
    for vi in list(m.graph.input) + list(m.graph.output):
        for d in vi.type.tensor_type.shape.dim:
            if d.dim_param:
                d.dim_value = 1 if d.dim_param == "batch" else size
    onnx.save(m, path)


def main():
    if len(sys.argv) != 2 or not sys.argv[1].endswith(".onnx"):
        sys.exit("usage: python int8_graphs.py DIR/NAME.onnx (written by model_bench --export DIR)")
    src, size = sys.argv[1], 224
    stem = src[: -len(".onnx")]
    folded = f"{stem}.folded.onnx"
    quant_pre_process(src, folded, skip_symbolic_shape=True)
    fixed_batch(folded, size)
    name = onnx.load(folded).graph.input[0].name
    common = dict(op_types_to_quantize=["Conv", "Relu", "MaxPool"], per_channel=True,
                  activation_type=QuantType.QUInt8, weight_type=QuantType.QInt8)
    quantize_static(folded, f"{stem}.qop.onnx", NoiseImages(name, size), quant_format=QuantFormat.QOperator, **common)
    quantize_static(folded, f"{stem}.qdq.onnx", NoiseImages(name, size), quant_format=QuantFormat.QDQ, **common)
    quantize_dynamic(folded, f"{stem}.dyn.onnx", op_types_to_quantize=["Conv"], weight_type=QuantType.QUInt8)
    for kind in ["qop", "qdq", "dyn"]:
        out = f"{stem}.{kind}.onnx"
        fixed_batch(out, size)
        ops = Counter(n.op_type for n in onnx.load(out).graph.node)
        print(out, dict(ops.most_common(6)))


if __name__ == "__main__":
    main()
