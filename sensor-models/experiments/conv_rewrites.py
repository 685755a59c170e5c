"""Timing experiment for issue 30 (BENCHMARKS.md, "ResNet-18 on a Zen 4 machine: three rewrites of
the convolutions"): can a ResNet-18 graph written differently run faster on tract 0.23.9 than the
plain one? Rewrites the convolutions of a graph that `model_bench --export DIR` wrote, checks the
rewrite against the original with ONNX Runtime, and leaves the timing to `model_bench --profile`:

    model_bench --export DIR
    python conv_rewrites.py DIR/resnet18.onnx
    model_bench --profile DIR/resnet18.onnx DIR/resnet18.winograd.onnx DIR/resnet18.mmi.onnx DIR/resnet18.qlc.onnx

- `.winograd.onnx`: every 3x3 stride-1 convolution as Winograd F(2x2, 3x3) in plain ONNX
  operators: the input transform as a 4x4 stride-2 convolution with fixed weights, the 16
  products as one batched MatMul (2.25 times fewer multiply-adds), the output transform as a 1x1
  convolution and DepthToSpace;
- `.mmi.onnx`: every convolution in int8 as MatMulInteger over an explicit im2col (the 9
  shifted slices of the padded int8 input, concatenated), zero points 0 (symmetric int8 weights
  per output channel and activations), the scale, bias and ReLU in float after it;
- `.qlc.onnx`: the same im2col into QLinearConv with a 1x1 kernel (the requantisation in the
  operator, int8 in and out between convolutions).

Batch norm is folded into the convolutions first. The int8 ranges are calibrated on noise, so the
int8 outputs say nothing about accuracy: this times the plans, nothing else. Needs onnx and
onnxruntime (sensor-models/tests/python/requirements-models.txt).
"""
import sys

import numpy as np
import onnx
import onnxruntime as ort
from onnx import TensorProto, helper, numpy_helper, shape_inference

SIZE = 224
# Winograd F(2x2, 3x3) (Lavin and Gray, 2015): Y = A^T [(G g G^T) . (B^T d B)] A.
BT = np.array([[1, 0, -1, 0], [0, 1, 1, 0], [0, -1, 1, 0], [0, 1, 0, -1]], np.float32)
G = np.array([[1, 0, 0], [0.5, 0.5, 0.5], [0.5, -0.5, 0.5], [0, 0, 1]], np.float32)
AT = np.array([[1, 1, 1, 0], [0, 1, -1, -1]], np.float32)


def attributes(node):
    return {a.name: helper.get_attribute_value(a) for a in node.attribute}


class Rewrite:
    """The graph at a fixed 1 x 3 x SIZE x SIZE input, with what every rewrite needs to know."""

    def __init__(self, path):
        model = onnx.load(path)
        dims = model.graph.input[0].type.tensor_type.shape.dim
        dims[0].dim_value, dims[2].dim_value, dims[3].dim_value = 1, SIZE, SIZE
        self.model = shape_inference.infer_shapes(model)
        g = self.model.graph
        self.shapes = {v.name: [d.dim_value for d in v.type.tensor_type.shape.dim]
                       for v in list(g.value_info) + list(g.input)}
        self.weights = {i.name: numpy_helper.to_array(i) for i in g.initializer}
        self.consumers = {}
        for n in g.node:
            for i in n.input:
                self.consumers.setdefault(i, []).append(n)
        self.nodes, self.initializers, self.absorbed = [], [], set()

    def const(self, name, value):
        self.initializers.append(numpy_helper.from_array(np.asarray(value), name))
        return name

    def node(self, op, inputs, output, **attrs):
        self.nodes.append(helper.make_node(op, inputs, [output], **attrs))
        return output

    def folded(self, conv, with_relu):
        """The convolution's weights and bias with a following batch norm folded in, the name of
        the float tensor the rewrite must produce, and whether a ReLU was absorbed."""
        w = self.weights[conv.input[1]]
        b = self.weights[conv.input[2]] if len(conv.input) > 2 else np.zeros(w.shape[0], np.float32)
        out = conv.output[0]
        after = self.consumers.get(out, [])
        if len(after) == 1 and after[0].op_type == "BatchNormalization":
            bn = after[0]
            gamma, beta, mean, var = (self.weights[x] for x in bn.input[1:5])
            s = gamma / np.sqrt(var + attributes(bn).get("epsilon", 1e-5))
            w, b = w * s[:, None, None, None], (b - mean) * s + beta
            out = bn.output[0]
            self.absorbed.add(id(bn))
            after = self.consumers.get(out, [])
        relu = with_relu and len(after) == 1 and after[0].op_type == "Relu"
        if relu:
            self.absorbed.add(id(after[0]))
            out = after[0].output[0]
        return w.astype(np.float32), b.astype(np.float32), out, relu

    def run(self, rewrite_conv):
        count = 0
        for n in self.model.graph.node:
            if id(n) in self.absorbed:
                continue
            if n.op_type == "Conv" and attributes(n).get("group", 1) == 1 and rewrite_conv(n, f"r{count}_"):
                count += 1
            else:
                self.nodes.append(n)
        g = self.model.graph
        del g.node[:]
        g.node.extend(self.nodes)
        g.initializer.extend(self.initializers)
        del g.value_info[:]
        return count


def winograd(rw):
    k = np.zeros((16, 1, 4, 4), np.float32)
    for i in range(4):
        for j in range(4):
            k[4 * i + j, 0] = np.outer(BT[i], BT[j])
    rw.const("winograd_input", k)
    a = np.zeros((4, 16, 1, 1), np.float32)
    for p in range(2):
        for q in range(2):
            a[2 * p + q, :, 0, 0] = np.outer(AT[p], AT[q]).reshape(16)
    rw.const("winograd_output", a)

    def conv(n, p):
        at = attributes(n)
        if at.get("kernel_shape") != [3, 3] or at.get("strides", [1, 1]) != [1, 1] or at.get("pads") != [1, 1, 1, 1]:
            return False
        w, b, out, _ = rw.folded(n, with_relu=False)
        co, ci = w.shape[:2]
        _, h, wd = rw.shapes[n.input[0]][1:]
        eh, ew = h % 2, wd % 2
        th, tw = (h + eh) // 2, (wd + ew) // 2
        u = np.einsum("ka,ocab,lb->kloc", G, w, G).reshape(16, co, ci)
        x = rw.node("Pad", [n.input[0], rw.const(p + "pads", np.array([0, 0, 1, 1, 0, 0, 1 + eh, 1 + ew], np.int64))], p + "pad")
        x = rw.node("Reshape", [x, rw.const(p + "s1", np.array([ci, 1, h + eh + 2, wd + ew + 2], np.int64))], p + "r1")
        x = rw.node("Conv", [x, "winograd_input"], p + "v", kernel_shape=[4, 4], strides=[2, 2])
        x = rw.node("Reshape", [x, rw.const(p + "s2", np.array([ci, 16, th * tw], np.int64))], p + "v2")
        x = rw.node("Transpose", [x], p + "vt", perm=[1, 0, 2])
        x = rw.node("MatMul", [rw.const(p + "u", u), x], p + "m")
        x = rw.node("Transpose", [x], p + "mt", perm=[1, 0, 2])
        x = rw.node("Reshape", [x, rw.const(p + "s3", np.array([co, 16, th, tw], np.int64))], p + "m2")
        x = rw.node("Conv", [x, "winograd_output"], p + "y", kernel_shape=[1, 1])
        x = rw.node("Reshape", [x, rw.const(p + "s4", np.array([1, 4 * co, th, tw], np.int64))], p + "y2")
        x = rw.node("DepthToSpace", [x], p + "y3", blocksize=2, mode="CRD")
        if eh or ew:
            x = rw.node("Slice", [x, rw.const(p + "st", np.array([0, 0], np.int64)), rw.const(p + "en", np.array([h, wd], np.int64)),
                                  rw.const(p + "ax", np.array([2, 3], np.int64))], p + "crop")
        rw.node("Add", [x, rw.const(p + "b", b.reshape(1, co, 1, 1))], out)
        return True

    return conv


def ranges(rw, path):
    """Largest magnitude of every float tensor on one noise image (the int8 scales)."""
    probe = onnx.load(path)
    dims = probe.graph.input[0].type.tensor_type.shape.dim
    dims[0].dim_value, dims[2].dim_value, dims[3].dim_value = 1, SIZE, SIZE
    names = ["image"] + [o for n in probe.graph.node for o in n.output]
    kept = {o.name for o in probe.graph.output}
    for name in names:
        if name not in kept:
            probe.graph.output.append(helper.make_tensor_value_info(name, TensorProto.FLOAT, None))
    image = np.random.default_rng(1).random((1, 3, SIZE, SIZE), dtype=np.float32)
    values = ort.InferenceSession(probe.SerializeToString()).run(names, {"image": image})
    return {k: max(float(np.abs(v).max()), 1e-6) for k, v in zip(names, values)}


def int8(rw, path, qlinearconv):
    amax = ranges(rw, path)
    quantised = {}  # float tensor -> (int8 tensor, scale)

    def conv(n, p):
        at = attributes(n)
        w, b, out, relu = rw.folded(n, with_relu=True)
        co, ci, kh, kw = w.shape
        st, pad = at.get("strides", [1, 1])[0], at.get("pads", [0, 0, 0, 0])[0]
        _, h, wd = rw.shapes[n.input[0]][1:]
        ho, wo = (h + 2 * pad - kh) // st + 1, (wd + 2 * pad - kw) // st + 1
        if n.input[0] in quantised:
            x, sx = quantised[n.input[0]]
        else:
            sx = amax[n.input[0]] / 127.0
            x = rw.node("QuantizeLinear", [n.input[0], rw.const(p + "sx", np.float32(sx)), rw.const(p + "zx", np.int8(0))], p + "xq")
            quantised[n.input[0]] = (x, sx)
        sw = np.maximum(np.abs(w).reshape(co, -1).max(1), 1e-8) / 127.0
        wq = np.clip(np.round(w / sw[:, None, None, None]), -127, 127).astype(np.int8)
        wq = wq.transpose(0, 2, 3, 1).reshape(co, kh * kw * ci)  # (ky, kx, c): the slices' order
        if pad:
            x = rw.node("Pad", [x, rw.const(p + "pads", np.array([0, 0, pad, pad, 0, 0, pad, pad], np.int64))], p + "xp")
        if kh * kw > 1 or st > 1:
            parts = []
            for ky in range(kh):
                for kx in range(kw):
                    s = f"{p}sl{ky}{kx}"
                    parts.append(rw.node("Slice", [x, rw.const(s + "b", np.array([ky, kx], np.int64)),
                                                   rw.const(s + "e", np.array([ky + st * (ho - 1) + 1, kx + st * (wo - 1) + 1], np.int64)),
                                                   rw.const(s + "a", np.array([2, 3], np.int64)), rw.const(s + "t", np.array([st, st], np.int64))], s))
            x = parts[0] if len(parts) == 1 else rw.node("Concat", parts, p + "cols", axis=1)
        if qlinearconv:
            sy = amax[out] / 127.0
            bias = np.clip(np.round(b / (sx * sw)), -2**31, 2**31 - 1).astype(np.int32)
            y = rw.node("QLinearConv", [x, rw.const(p + "sx2", np.float32(sx)), rw.const(p + "zx2", np.int8(0)),
                                        rw.const(p + "w", wq.reshape(co, -1, 1, 1)), rw.const(p + "sw", sw.astype(np.float32)),
                                        rw.const(p + "zw", np.zeros(co, np.int8)), rw.const(p + "sy", np.float32(sy)),
                                        rw.const(p + "zy", np.int8(0)), rw.const(p + "b", bias)], p + "y", kernel_shape=[1, 1])
            if relu:
                y = rw.node("Relu", [y], p + "yr")
            quantised[out] = (y, sy)
            rw.node("DequantizeLinear", [y, rw.const(p + "sy2", np.float32(sy)), rw.const(p + "zy2", np.int8(0))], out)
        else:
            x = rw.node("Reshape", [x, rw.const(p + "r", np.array([kh * kw * ci, ho * wo], np.int64))], p + "cols2")
            y = rw.node("MatMulInteger", [rw.const(p + "w", wq), x], p + "acc")
            y = rw.node("Cast", [y], p + "f", to=TensorProto.FLOAT)
            y = rw.node("Mul", [y, rw.const(p + "scale", (sw * sx).reshape(co, 1).astype(np.float32))], p + "scaled")
            y = rw.node("Add", [y, rw.const(p + "b", b.reshape(co, 1))], p + "biased")
            if relu:
                y = rw.node("Relu", [y], p + "relu")
            rw.node("Reshape", [y, rw.const(p + "r2", np.array([1, co, ho, wo], np.int64))], out)
        return True

    return conv


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    src = sys.argv[1]
    stem = src[: -len(".onnx")] if src.endswith(".onnx") else src
    image = np.random.default_rng(2).random((1, 3, SIZE, SIZE), dtype=np.float32)
    options = ort.SessionOptions()
    options.log_severity_level = 3
    reference = ort.InferenceSession(src, options).run(None, {"image": image})
    for suffix, make in [("winograd", winograd), ("mmi", lambda rw: int8(rw, src, False)),
                         ("qlc", lambda rw: int8(rw, src, True))]:
        rw = Rewrite(src)
        count = rw.run(make(rw))
        dst = f"{stem}.{suffix}.onnx"
        onnx.save(rw.model, dst)
        out = ort.InferenceSession(dst, options).run(None, {"image": image})
        error = max(float(np.abs(a - b).max() / (np.abs(a).max() + 1e-9)) for a, b in zip(reference, out))
        print(f"wrote {dst}: {count} convolutions rewritten, largest output error {error:.1e} of the output's range")


if __name__ == "__main__":
    main()
