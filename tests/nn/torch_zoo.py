"""Exports torchvision topologies with seeded random weights for tests/nn/test_torch_zoo.cpp.

usage: torch_zoo.py OUT_DIR SIZE NAME...
For each NAME: OUT_DIR/NAME.onnx (opset 13, 10 classes, eval mode), OUT_DIR/NAME.input.npy
(1 x 3 x SIZE x SIZE float32, seeded) and OUT_DIR/NAME.logits.npy (torch's logits on it).
"""
import sys

import numpy as np
import torch
import torchvision

out, size, names = sys.argv[1], int(sys.argv[2]), sys.argv[3:]
for name in names:
    torch.manual_seed(0)
    model = getattr(torchvision.models, name)(num_classes=10).eval()
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
