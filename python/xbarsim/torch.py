"""PyTorch bridge: a model whose Conv2d and Linear layers compute through xbarsim's crossbars.

    import xbarsim, xbarsim.torch
    analog = xbarsim.torch.convert(model, xbarsim.Config(), calibration=images)  # a copy
    logits = analog(images)           # Conv2d/Linear on crossbars, the rest in torch
    result = xbarsim.torch.evaluate(analog, loader, reference=model)

Each Conv2d (any stride, padding, dilation and groups) and Linear becomes an xbarsim.Crossbar
programmed as eval programs a layer: its weight matrix (inputs x outputs; grouped convolutions
as one block-diagonal matrix, as the ONNX import maps them), its inputs' range [0, x_max] (or
signed) taken from the calibration batch, and that batch's vectors for calibration. The
values cross between torch and xbarsim as NumPy arrays (no libtorch link); any torch model
works, exportable or not.
"""
import copy

import numpy as np
import torch
import torch.nn.functional as F

from . import Config, Crossbar

__all__ = ["convert", "evaluate", "AnalogConv2d", "AnalogLinear"]


def _weight_matrix(module):
    """The layer's weight as inputs x outputs (im2col order: channel, then kernel row, column)."""
    w = module.weight.detach().double().cpu().numpy()
    if isinstance(module, torch.nn.Linear):
        return w.T.copy()
    out_c, in_per_group = w.shape[0], w.shape[1]
    kk = w.shape[2] * w.shape[3]
    groups = module.groups
    in_c = in_per_group * groups
    m = np.zeros((in_c * kk, out_c))
    per_out = out_c // groups
    for g in range(groups):
        block = w[g * per_out:(g + 1) * per_out].reshape(per_out, in_per_group * kk).T
        m[g * in_per_group * kk:(g + 1) * in_per_group * kk, g * per_out:(g + 1) * per_out] = block
    return m


def _columns(module, x):
    """The layer's input vectors, one per row: unfolded windows for a convolution."""
    if isinstance(module, torch.nn.Linear):
        return x.reshape(-1, x.shape[-1])
    cols = F.unfold(x, module.kernel_size, dilation=module.dilation, padding=module.padding, stride=module.stride)
    return cols.transpose(1, 2).reshape(-1, cols.shape[1])


class _Analog(torch.nn.Module):
    def __init__(self, module, crossbar):
        super().__init__()
        self.software = module  # the original layer: its bias, shape arguments and reference output
        self.crossbar = crossbar
        self.errors = []  # per forward: mean |analog - software| / the software output's range

    def _matmul(self, cols):
        y = self.crossbar.matvec(cols.detach().double().cpu().numpy())
        return torch.from_numpy(y)


class AnalogConv2d(_Analog):
    def forward(self, x):
        m = self.software
        n, _, h, w = x.shape
        oh = (h + 2 * m.padding[0] - m.dilation[0] * (m.kernel_size[0] - 1) - 1) // m.stride[0] + 1
        ow = (w + 2 * m.padding[1] - m.dilation[1] * (m.kernel_size[1] - 1) - 1) // m.stride[1] + 1
        y = self._matmul(_columns(m, x)).to(x.dtype).reshape(n, oh * ow, -1).transpose(1, 2).reshape(n, -1, oh, ow)
        if m.bias is not None:
            y = y + m.bias.detach().reshape(1, -1, 1, 1)
        self._record(y, m(x))
        return y

    def _record(self, y, ref):
        rng = (ref.amax() - ref.amin()).item()
        self.errors.append(float((y - ref).abs().mean().item() / rng) if rng > 0 else 0.0)


class AnalogLinear(AnalogConv2d):
    def forward(self, x):
        m = self.software
        y = self._matmul(_columns(m, x)).to(x.dtype).reshape(*x.shape[:-1], -1)
        if m.bias is not None:
            y = y + m.bias.detach()
        self._record(y, m(x))
        return y


def convert(model, config=None, calibration=None, max_calibration_vectors=512, max_calibration_batches=None,
            progress=None):
    """A copy of `model` whose Conv2d and Linear layers run on crossbars.

    `calibration`: a batch of inputs (a tensor), or an iterable of batches (a DataLoader of
    tensors or of (inputs, labels)), at most `max_calibration_batches` of them, run through
    the model to find each layer's input range and calibration vectors (at most
    `max_calibration_vectors` per layer, evenly spread). Without it the ranges are [0, 1] and
    calibration uses random vectors. `progress(name, done, total)` is called after each layer
    is programmed.
    """
    config = config if config is not None else Config()
    model = copy.deepcopy(model).eval()
    layers = [(name, m) for name, m in model.named_modules() if isinstance(m, (torch.nn.Conv2d, torch.nn.Linear))]
    seen = {}
    if calibration is not None:
        def keep(name):
            def hook(module, inputs, output):  # returns None: the output stays the layer's
                seen.setdefault(name, []).append(inputs[0].detach())
            return hook

        hooks = [m.register_forward_hook(keep(name)) for name, m in layers]
        batches = [calibration] if torch.is_tensor(calibration) else calibration
        with torch.no_grad():
            for k, batch in enumerate(batches):
                if max_calibration_batches is not None and k >= max_calibration_batches:
                    break
                model(batch[0] if isinstance(batch, (tuple, list)) else batch)
        for h in hooks:
            h.remove()
        seen = {name: torch.cat(inputs) for name, inputs in seen.items()}
    for salt, (name, m) in enumerate(layers):
        calib, x_max, signed = None, 1.0, False
        if name in seen:
            cols = _columns(m, seen[name]).double().cpu().numpy()
            step = max(1, len(cols) // max_calibration_vectors)
            calib = np.ascontiguousarray(cols[::step][:max_calibration_vectors])
            x_max = float(np.abs(cols).max()) or 1.0
            signed = bool(cols.min() < 0)
        xb = Crossbar(_weight_matrix(m), config, x_max=x_max, signed_inputs=signed, calibration=calib, salt=salt)
        analog = (AnalogLinear if isinstance(m, torch.nn.Linear) else AnalogConv2d)(m, xb)
        parent = model
        *path, last = name.split(".")
        for part in path:
            parent = getattr(parent, part)
        setattr(parent, last, analog)
        if progress is not None:
            progress(name, salt + 1, len(layers))
    return model


def evaluate(model, loader, reference=None):
    """Accuracy of `model` (a converted one) over (inputs, labels) batches of `loader`; with
    `reference` (the original), its accuracy too and how many predictions agree."""
    correct = ref_correct = agree = total = 0
    with torch.no_grad():
        for x, labels in loader:
            pred = model(x).argmax(dim=1)
            correct += int((pred == labels).sum())
            if reference is not None:
                ref = reference(x).argmax(dim=1)
                ref_correct += int((ref == labels).sum())
                agree += int((ref == pred).sum())
            total += len(labels)
    out = {"images": total, "accuracy": correct / max(total, 1)}
    if reference is not None:
        out.update(software_accuracy=ref_correct / max(total, 1), agreeing_predictions=agree)
    errors = {name: float(np.mean(m.errors)) for name, m in model.named_modules() if isinstance(m, _Analog) and m.errors}
    out["layer_mean_relative_error"] = errors
    return out
