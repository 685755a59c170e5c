"""fringe's networks in PyTorch, with the parameter names fringe reads (sensor-models/src/arch.rs):
a network trained here and saved with ``fringe.torch.save_model`` runs in ``fringe eval``,
``validate``, ``commission --base`` and ``stream``.

Every network maps a batch of inputs (N x 3 x S x S, as ``run.inputs`` makes them) to three heads:
``force`` (N x 7: Fx Fy Fz Mx My Mz |F| magnitudes, N and N m), ``logits`` (N x classes, "None"
first) and ``contact`` (N x 2, mm from the sensor centre).
"""

import torch
from torch import nn

ARCHITECTURES = ("custom", "resnet18", "keypoint")


class _ConvBlock(nn.Module):
    """3x3 convolution (padding 1), ReLU, 2x2 max-pool: ``block.0`` holds the convolution."""

    def __init__(self, c_in, c_out):
        super().__init__()
        self.block = nn.Sequential(nn.Conv2d(c_in, c_out, 3, padding=1), nn.ReLU(), nn.MaxPool2d(2))

    def forward(self, x):
        return self.block(x)


class _Heads(nn.Module):
    """The three heads on a feature vector."""

    def __init__(self, features, classes):
        super().__init__()
        self.force_head = nn.Linear(features, 7)
        self.class_head = nn.Linear(features, classes)
        self.point_head = nn.Linear(features, 2)

    def heads(self, f):
        return self.force_head(f), self.class_head(f), self.point_head(f)


class Custom(_Heads):
    """The paper's custom CNN: four blocks 3-16-32-64-128, global average pool, three heads."""

    def __init__(self, classes=3):
        super().__init__(128, classes)
        widths = (3, 16, 32, 64, 128)
        self.cnn = nn.Sequential(*(_ConvBlock(a, b) for a, b in zip(widths, widths[1:])))
        self.pool = nn.AdaptiveAvgPool2d(1)

    def forward(self, x):
        return self.heads(torch.flatten(self.pool(self.cnn(x)), 1))


class Resnet18(_Heads):
    """torchvision's ResNet-18 without its classifier (``backbone``), three heads on its 512
    features."""

    def __init__(self, classes=3):
        super().__init__(512, classes)
        from torchvision.models import resnet18

        layers = list(resnet18(weights=None).children())[:-1]
        self.backbone = nn.Sequential(*layers)

    def forward(self, x):
        return self.heads(torch.flatten(self.backbone(x), 1))


class _KeypointConv(nn.Module):
    def __init__(self, c_in, c_out, pool):
        super().__init__()
        self.conv = nn.Conv2d(c_in, c_out, 3, padding=1)
        self.pool = pool

    def forward(self, x):
        x = torch.relu(self.conv(x))
        return nn.functional.max_pool2d(x, 2) if self.pool else x


class Keypoint(_Heads):
    """fringe's keypoint CNN: the custom CNN's convolutions without the last pool; the heads read
    the pooled 128 features and 16 spatial soft-argmax keypoints (x, y from -1 to 1 over the
    feature map, x right, y down)."""

    def __init__(self, classes=3, maps=16):
        super().__init__(128 + 2 * maps, classes)
        widths = (3, 16, 32, 64, 128)
        self.kp = nn.ModuleList(_KeypointConv(widths[i], widths[i + 1], i < 3) for i in range(4))
        self.keypoints = nn.Conv2d(128, maps, 1)

    def forward(self, x):
        for block in self.kp:
            x = block(x)
        pooled = torch.flatten(nn.functional.adaptive_avg_pool2d(x, 1), 1)
        maps = self.keypoints(x)
        n, k, h, w = maps.shape
        p = torch.softmax(maps.reshape(n, k, h * w), dim=-1).reshape(n, k, h, w)
        xs = (torch.arange(w, dtype=x.dtype, device=x.device) * 2.0 + 1.0) / w - 1.0
        ys = (torch.arange(h, dtype=x.dtype, device=x.device) * 2.0 + 1.0) / h - 1.0
        ex = (p.sum(2) * xs).sum(-1, keepdim=True)
        ey = (p.sum(3) * ys).sum(-1, keepdim=True)
        return self.heads(torch.cat([pooled, torch.cat([ex, ey], -1).flatten(1)], 1))


def build(arch, classes=3):
    """A network of fringe's architecture ``arch`` (``custom``, ``resnet18``, ``keypoint``)."""
    nets = {"custom": Custom, "resnet18": Resnet18, "keypoint": Keypoint}
    if arch not in nets:
        raise ValueError(f"architecture {arch!r}: give one of {', '.join(ARCHITECTURES)}")
    return nets[arch](classes)
