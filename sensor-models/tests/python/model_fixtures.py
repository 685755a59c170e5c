#!/usr/bin/env python3
"""Model-file fixtures for fringe-sensor-models, written by real PyTorch.

The two reference architectures (docs: reference-pipeline.md, "Networks") and fringe's keypoint
CNN (sensor-models/src/arch.rs), with seeded weights, saved in every form users have them:

  state_dict.pth         torch.save(model.state_dict())            (zip format)
  legacy.pth             the same, _use_new_zipfile_serialization=False
  checkpoint.pth         {epoch, model_state_dict ("module." keys), optimizer_state_dict (Adam
                         after one step), train_loss, val_loss}
  compiled.pth           state dict with "_orig_mod." keys (torch.compile's wrapper)
  state_dict_f16.pth     floating tensors as float16
  state_dict_bf16.pth    floating tensors as bfloat16
  model.safetensors      safetensors.torch.save_file
  model.onnx             input "image" [N,3,224,224], outputs force, shape_logits, contact
  views.pth              non-contiguous views sharing one storage (transpose, offset slice)
  scripted.pt            torch.jit.save(torch.jit.script(model))   (TorchScript: torch backend)
  traced.pt              torch.jit.save(torch.jit.trace(model, x))
  inputs.f32             fixed seeded inputs, raw little-endian f32, shape [2,3,224,224]
  expected.json          eval-mode outputs on inputs.f32 for each file's weights (f16 / bf16
                         weights cast back to f32 first), the same for the TorchScript files
                         (under "torchscript"), and the values of views.pth

Usage: model_fixtures.py --arch custom|resnet18|keypoint --out DIR
"""

import argparse
import copy
import json
import os
import sys
from collections import OrderedDict

import numpy as np
import torch
from torch import nn

N_CLASSES = 3
INPUT_SHAPE = (2, 3, 224, 224)
SEEDS = {"custom": 1234, "resnet18": 5678, "keypoint": 4321}
INPUT_SEED = 42


class ConvBlock(nn.Module):
    """conv 3x3 pad 1, ReLU, maxpool 2 as `block` (keys cnn.N.block.0.*)."""

    def __init__(self, c_in, c_out):
        super().__init__()
        self.block = nn.Sequential(
            nn.Conv2d(c_in, c_out, kernel_size=3, padding=1),
            nn.ReLU(),
            nn.MaxPool2d(2),
        )

    def forward(self, x):
        return self.block(x)


class IsoNet(nn.Module):
    """The paper's custom CNN: 4 blocks 3->16->32->64->128, global average pool, 3 heads."""

    def __init__(self, n_classes=N_CLASSES):
        super().__init__()
        channels = [3, 16, 32, 64, 128]
        self.cnn = nn.Sequential(
            *[ConvBlock(a, b) for a, b in zip(channels[:-1], channels[1:])]
        )
        self.pool = nn.AdaptiveAvgPool2d(1)
        self.force_head = nn.Linear(128, 7)
        self.class_head = nn.Linear(128, n_classes)
        self.point_head = nn.Linear(128, 2)

    def forward(self, x):
        features = torch.flatten(self.pool(self.cnn(x)), 1)
        return (
            self.force_head(features),
            self.class_head(features),
            self.point_head(features),
        )


class KeypointBlock(nn.Module):
    """conv 3x3 pad 1 as `conv` (keys kp.N.conv.*), ReLU, then max-pool 2 unless last."""

    def __init__(self, c_in, c_out, pool):
        super().__init__()
        self.conv = nn.Conv2d(c_in, c_out, kernel_size=3, padding=1)
        self.pool = pool

    def forward(self, x):
        x = torch.relu(self.conv(x))
        if self.pool:
            x = nn.functional.max_pool2d(x, 2)
        return x


class KeypointNet(nn.Module):
    """fringe's keypoint CNN: the custom CNN's convolutions without the last pool, the pooled
    128 features and 16 spatial soft-argmax keypoints (x, y from -1 to 1 over the feature map,
    x right, y down) under the 3 heads."""

    def __init__(self, n_classes=N_CLASSES, maps=16):
        super().__init__()
        channels = [3, 16, 32, 64, 128]
        self.kp = nn.ModuleList(
            [KeypointBlock(channels[i], channels[i + 1], i < 3) for i in range(4)]
        )
        self.keypoints = nn.Conv2d(128, maps, kernel_size=1)
        features = 128 + 2 * maps
        self.force_head = nn.Linear(features, 7)
        self.class_head = nn.Linear(features, n_classes)
        self.point_head = nn.Linear(features, 2)

    def forward(self, x):
        for block in self.kp:
            x = block(x)
        pooled = torch.flatten(nn.functional.adaptive_avg_pool2d(x, 1), 1)
        m = self.keypoints(x)
        n, k, h, w = m.shape
        p = torch.softmax(m.reshape(n, k, h * w), dim=-1).reshape(n, k, h, w)
        xs = (torch.arange(w, dtype=x.dtype) * 2.0 + 1.0) / w - 1.0
        ys = (torch.arange(h, dtype=x.dtype) * 2.0 + 1.0) / h - 1.0
        ex = (p.sum(2) * xs).sum(-1, keepdim=True)
        ey = (p.sum(3) * ys).sum(-1, keepdim=True)
        features = torch.cat([pooled, torch.cat([ex, ey], -1).flatten(1)], 1)
        return (
            self.force_head(features),
            self.class_head(features),
            self.point_head(features),
        )


class ResNetMultiTask(nn.Module):
    """torchvision ResNet-18 without fc as `backbone`, the 3 heads on its 512 features."""

    def __init__(self, n_classes=N_CLASSES):
        super().__init__()
        from torchvision.models import resnet18

        resnet = resnet18(weights=None)
        self.backbone = nn.Sequential(*list(resnet.children())[:-1])
        self.force_head = nn.Linear(512, 7)
        self.class_head = nn.Linear(512, n_classes)
        self.point_head = nn.Linear(512, 2)

    def forward(self, x):
        features = torch.flatten(self.backbone(x), 1)
        return (
            self.force_head(features),
            self.class_head(features),
            self.point_head(features),
        )


def build(arch):
    torch.manual_seed(SEEDS[arch])
    if arch == "custom":
        model = IsoNet()
    elif arch == "keypoint":
        model = KeypointNet()
        # Peaked maps, so the positions read out are far from the centre and the test sees them.
        with torch.no_grad():
            model.keypoints.weight.mul_(400.0)
            model.point_head.weight.mul_(10.0)
    else:
        model = ResNetMultiTask()
        # Non-trivial BatchNorm statistics and affine parameters, so eval-mode BN is exercised.
        gen = torch.Generator().manual_seed(SEEDS[arch] + 1)
        for m in model.modules():
            if isinstance(m, nn.BatchNorm2d):
                n = m.num_features
                with torch.no_grad():
                    m.running_mean.copy_(torch.randn(n, generator=gen) * 0.1)
                    m.running_var.copy_(torch.rand(n, generator=gen) * 1.5 + 0.5)
                    m.weight.copy_(torch.rand(n, generator=gen) * 0.5 + 0.75)
                    m.bias.copy_(torch.randn(n, generator=gen) * 0.1)
                    m.num_batches_tracked.fill_(int(torch.randint(1, 1000, (1,), generator=gen)))
    return model.eval()


def inputs():
    gen = torch.Generator().manual_seed(INPUT_SEED)
    # Like normalised images: values in [-1, 1].
    return torch.rand(INPUT_SHAPE, generator=gen) * 2.0 - 1.0


def outputs(model, x):
    with torch.no_grad():
        force, logits, contact = model.eval()(x)
    return {
        "force": force.tolist(),
        "shape_logits": logits.tolist(),
        "contact": contact.tolist(),
    }


def cast(state, dtype):
    return OrderedDict(
        (k, v.to(dtype) if v.is_floating_point() else v) for k, v in state.items()
    )


def with_weights(model, state):
    """A copy of `model` holding `state` (cast back to f32)."""
    other = copy.deepcopy(model)
    other.load_state_dict(cast(state, torch.float32))
    return other.eval()


def adam_after_one_step(model, x):
    """A real Adam state: one training step on a copy of the model."""
    trained = copy.deepcopy(model).train()
    opt = torch.optim.Adam(trained.parameters(), lr=1e-3)
    force, logits, contact = trained(x)
    loss = (
        force[:, 2].pow(2).mean()
        + nn.functional.cross_entropy(logits, torch.tensor([1, 2]))
        + contact.pow(2).mean()
    )
    opt.zero_grad()
    loss.backward()
    opt.step()
    return opt.state_dict(), loss.item()


def compiled_state_dict(model):
    """state_dict() of torch.compile's wrapper ("_orig_mod." keys); compiling is lazy."""
    try:
        return torch.compile(model).state_dict()
    except Exception:  # torch.compile unavailable: the same keys by hand
        return OrderedDict(("_orig_mod." + k, v) for k, v in model.state_dict().items())


def export_onnx(model, x, path):
    kwargs = dict(
        input_names=["image"],
        output_names=["force", "shape_logits", "contact"],
        dynamic_axes={
            "image": {0: "batch"},
            "force": {0: "batch"},
            "shape_logits": {0: "batch"},
            "contact": {0: "batch"},
        },
        opset_version=17,
    )
    try:
        # The TorchScript exporter: needs nothing beyond torch and onnx.
        torch.onnx.export(model, (x,), path, dynamo=False, **kwargs)
    except TypeError:  # a torch without the dynamo switch
        torch.onnx.export(model, (x,), path, **kwargs)


def check_onnx(path, x, expected):
    import onnxruntime as ort

    session = ort.InferenceSession(path, providers=["CPUExecutionProvider"])
    got = session.run(None, {"image": x.numpy()})
    names = [o.name for o in session.get_outputs()]
    assert names == ["force", "shape_logits", "contact"], names
    for name, value in zip(names, got):
        np.testing.assert_allclose(value, np.array(expected[name]), rtol=1e-4, atol=1e-4)


def views():
    """Tensors that are views of one storage: a transpose and a slice with an offset."""
    base = torch.arange(24, dtype=torch.float32).reshape(4, 6) * 0.5 - 3.0
    tensors = OrderedDict(
        [
            ("base", base),
            ("transposed", base.t()),
            ("sliced", base[1:, 2:5]),
            ("column", base[:, 3]),
        ]
    )
    for name in ("transposed", "sliced", "column"):
        assert tensors[name].untyped_storage().data_ptr() == base.untyped_storage().data_ptr()
    assert not tensors["transposed"].is_contiguous()
    return tensors


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--arch", choices=sorted(SEEDS), required=True)
    parser.add_argument("--out", required=True)
    args = parser.parse_args()
    out = args.out
    os.makedirs(out, exist_ok=True)

    def at(name):
        return os.path.join(out, name)

    model = build(args.arch)
    x = inputs()
    x.numpy().astype("<f4").tofile(at("inputs.f32"))
    state = model.state_dict()
    reference = outputs(model, x)
    expected = OrderedDict()

    torch.save(state, at("state_dict.pth"))
    expected["state_dict.pth"] = reference

    torch.save(state, at("legacy.pth"), _use_new_zipfile_serialization=False)
    expected["legacy.pth"] = outputs(with_weights(model, torch.load(at("legacy.pth"))), x)

    optimizer_state, train_loss = adam_after_one_step(model, x)
    parallel_state = nn.DataParallel(model).state_dict()
    assert all(k.startswith("module.") for k in parallel_state)
    torch.save(
        {
            "epoch": 2,
            "model_state_dict": parallel_state,
            "optimizer_state_dict": optimizer_state,
            "train_loss": train_loss,
            "val_loss": train_loss * 1.1,
        },
        at("checkpoint.pth"),
    )
    expected["checkpoint.pth"] = reference

    compiled = compiled_state_dict(model)
    assert all(k.startswith("_orig_mod.") for k in compiled)
    torch.save(compiled, at("compiled.pth"))
    expected["compiled.pth"] = reference

    for name, dtype in (("state_dict_f16.pth", torch.float16), ("state_dict_bf16.pth", torch.bfloat16)):
        low = cast(state, dtype)
        torch.save(low, at(name))
        expected[name] = outputs(with_weights(model, low), x)

    from safetensors.torch import save_file

    save_file({k: v.contiguous() for k, v in state.items()}, at("model.safetensors"))
    expected["model.safetensors"] = reference

    export_onnx(model, x, at("model.onnx"))
    check_onnx(at("model.onnx"), x, reference)
    expected["model.onnx"] = reference

    torchscript = OrderedDict()
    torch.jit.save(torch.jit.script(model), at("scripted.pt"))
    torch.jit.save(torch.jit.trace(model, x), at("traced.pt"))
    for name in ("scripted.pt", "traced.pt"):
        torchscript[name] = outputs(torch.jit.load(at(name)), x)

    view_tensors = views()
    torch.save(view_tensors, at("views.pth"))

    manifest = OrderedDict(
        [
            ("arch", args.arch),
            ("seed", SEEDS[args.arch]),
            ("torch", torch.__version__),
            ("inputs", {"file": "inputs.f32", "shape": list(INPUT_SHAPE), "seed": INPUT_SEED}),
            ("outputs", expected),
            ("torchscript", torchscript),
            (
                "views",
                OrderedDict(
                    (k, {"shape": list(v.shape), "data": v.contiguous().flatten().tolist()})
                    for k, v in view_tensors.items()
                ),
            ),
        ]
    )
    with open(at("expected.json"), "w") as f:
        json.dump(manifest, f, indent=1)
        f.write("\n")
    print(f"wrote {args.arch} fixtures to {out}", file=sys.stderr)


if __name__ == "__main__":
    main()
