"""Exports torchvision topologies with seeded random weights for tests/nn/test_torch_zoo.cpp.

usage: torch_zoo.py OUT_DIR SIZE NAME...
For each NAME: OUT_DIR/NAME.onnx (opset 13, 10 classes, eval mode), OUT_DIR/NAME.input.npy
(1 x 3 x SIZE x SIZE float32, seeded) and OUT_DIR/NAME.logits.npy (torch's logits on it).
NAME is a torchvision model, or silu_se: a block of SiLU, squeeze-excitation, Sub and Div.
"""
import sys

import numpy as np
import torch
import torchvision
from torch import nn


class SiluSE(nn.Module):
    """Conv-BN-SiLU, a squeeze-excitation (SiLU inside, Sigmoid scale times the map), the map
    less its spatial mean (Sub of an N x C x 1 x 1), divided by 1 + its sigmoid (Div of two
    maps), then a strided Conv, ReLU, global pooling and a Linear: the element-wise operators
    of two computed tensors that EfficientNet-style networks export (SiLU is Sigmoid then Mul)."""

    def __init__(self, num_classes=10):
        super().__init__()
        self.stem = nn.Sequential(nn.Conv2d(3, 16, 3, padding=1, bias=False), nn.BatchNorm2d(16), nn.SiLU())
        self.squeeze = nn.Sequential(nn.AdaptiveAvgPool2d(1), nn.Conv2d(16, 4, 1), nn.SiLU(), nn.Conv2d(4, 16, 1),
                                     nn.Sigmoid())
        self.head = nn.Sequential(nn.Conv2d(16, 24, 3, stride=2, padding=1), nn.ReLU(), nn.AdaptiveAvgPool2d(1),
                                  nn.Flatten(), nn.Linear(24, num_classes))

    def forward(self, x):
        x = self.stem(x)
        x = x * self.squeeze(x)
        x = x - x.mean((2, 3), keepdim=True)
        x = x / (1 + torch.sigmoid(x))
        return self.head(x)


out, size, names = sys.argv[1], int(sys.argv[2]), sys.argv[3:]
for name in names:
    torch.manual_seed(0)
    make = SiluSE if name == "silu_se" else getattr(torchvision.models, name)
    model = make(num_classes=10).eval()
    # Batch-norm statistics that are not the identity, so that folding them is tested.
    for m in model.modules():
        if isinstance(m, torch.nn.BatchNorm2d):
            m.running_mean.uniform_(-0.5, 0.5)
            m.running_var.uniform_(0.5, 2.0)
    x = torch.randn(1, 3, size, size, generator=torch.Generator().manual_seed(1))
    with torch.no_grad():
        logits = model(x)
    torch.onnx.export(model, x, f"{out}/{name}.onnx", opset_version=13, input_names=["input"],
                      output_names=["logits"])
    np.save(f"{out}/{name}.input.npy", x.numpy().astype(np.float32))
    np.save(f"{out}/{name}.logits.npy", logits.numpy().astype(np.float32))
