"""Run torchvision's ResNet-18 (random weights, 32 x 32 inputs) with its Conv2d and Linear
layers on xbarsim's crossbars, and compare with torch.

    PYTHONPATH=build/python /usr/bin/python3 examples/python/convert_torchvision.py
"""
import time

import torch
import torchvision

import xbarsim
import xbarsim.torch

torch.manual_seed(0)
model = torchvision.models.resnet18(num_classes=10).eval()
images = torch.rand(4, 3, 32, 32)

t = time.perf_counter()
analog = xbarsim.torch.convert(model, xbarsim.Config(), calibration=images, calibration_samples=64)
print(f"programmed {sum(isinstance(m, xbarsim.torch.AnalogConv2d) for m in analog.modules())} layers "
      f"in {time.perf_counter() - t:.1f} s")
result = xbarsim.torch.evaluate(analog, [(images, torch.zeros(4, dtype=torch.long))], reference=model)
print(f"{result['agreeing_predictions']} of {result['images']} predictions agree with torch's")
for name, error in list(result["layer_mean_relative_error"].items())[:5]:
    print(f"  {name}: mean error {100 * error:.2f} % of the layer's output range")
