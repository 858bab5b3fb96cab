#!/usr/bin/env python3
# Fraction of magnitude bits that pulse in ResNet-20's crossbar inputs on CIFAR-10 (issue 42):
# each Conv/Gemm input quantized sign-magnitude to m magnitude bits over the layer's largest
# |input| on 200 calibration images, counted on 500 test images; and the weights' mean |w|/max
# per layer at 4 bits (sign + 3 magnitude bits, clipped at 3 sigma as HWA does, or at max).
# Usage: /usr/bin/python3 scripts/neurram_bit_density.py [DATA_DIR (../shared/data)] [BUILD_DIR (build)]
# (docs/results.md, "NeuRRAM, a measured chip": the range of the input pulses' workload).
import os, sys, numpy as np, torch, onnx
root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
data = sys.argv[1] if len(sys.argv) > 1 else os.path.join(root, "..", "shared", "data")
sys.path.insert(0, os.path.join(sys.argv[2] if len(sys.argv) > 2 else os.path.join(root, "build"), "python"))
import xbarsim.onnx as xo, xbarsim.data as xd
path = os.path.join(data, "..", "models", "resnet20_cifar10.onnx")
meta = {p.key: p.value for p in onnx.load(path).metadata_props}
m = xo.load(path).eval()
def prep(x):
    x = torch.tensor(x, dtype=torch.float32) / 255.0
    mean = torch.tensor([float(v) for v in meta["input_mean"].split(",")]).view(1, 3, 1, 1)
    std = torch.tensor([float(v) for v in meta["input_std"].split(",")]).view(1, 3, 1, 1)
    return (x - mean) / std
calib, _ = xd.read_cifar10([os.path.join(data, "cifar10", "calib_batch.bin")])
test, _ = xd.read_cifar10([os.path.join(data, "cifar10", "test_batch.bin")])
inputs = {}
def hook(name):
    def f(mod, inp, out): inputs.setdefault(name, []).append(inp[0].detach())
    return f
mods = [(n, mm) for n, mm in m.named_modules() if isinstance(mm, (torch.nn.Conv2d, torch.nn.Linear))]
for n, mm in mods: mm.register_forward_hook(hook(n))
with torch.no_grad(): m(prep(calib[:200]))
cal = {n: torch.cat(v).abs().max().item() for n, v in inputs.items()}
inputs.clear()
with torch.no_grad(): m(prep(test[:500]))
for mbits in (1, 2, 3, 4, 5, 6, 7):
    ones = total = 0
    for n, v in inputs.items():
        x = torch.cat(v)
        if x.dim() == 4:  # what the rows see: im2col of the kernel window
            mod = dict(mods)[n]
            x = torch.nn.functional.unfold(x, mod.kernel_size, padding=mod.padding, stride=mod.stride)
        q = torch.clamp(torch.round(x.abs() / cal[n] * (2 ** mbits - 1)), 0, 2 ** mbits - 1).long()
        for b in range(mbits):
            ones += ((q >> b) & 1).sum().item()
        total += q.numel() * mbits
    print(f"magnitude bits {mbits}: fraction of bits pulsing {ones / total:.3f}")
for clip in ("3sigma", "max"):
    vals = []
    for n, mm in mods:
        w = mm.weight.detach().flatten()
        top = 3 * w.std().item() if clip == "3sigma" else w.abs().max().item()
        q = torch.clamp(torch.round(w.abs() / top * 7), 0, 7)
        vals.append((q / 7).mean().item())
    print(f"weights clipped at {clip}: mean |code|/7 = {np.mean(vals):.3f} (layers {min(vals):.3f}..{max(vals):.3f})")
