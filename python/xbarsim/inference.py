"""Inference on the exact circuit, over time: a torch model whose Conv2d and Linear layers compute
through xbarsim's crossbars, programmed as `xbarsim eval` programs them (wires, mitigation,
converters, the device model) and read at any time after programming.

    import xbarsim, xbarsim.inference as inf
    analog = inf.convert(model, xbarsim.Config(overrides={"device.model": "rram-wan2022"}), calibration=images)
    logits = analog(images)           # Conv2d/Linear on crossbars, the rest in torch (a copy)
    for t in [1, 86400, 3.15e7]:
        inf.set_time(analog, t, compensation="global")
        result = inf.evaluate(analog, loader, reference=model)

`calibration` is required: the crossbars' input ranges come from it (a model fed normalised
inputs, mean 0 and std 1, would otherwise be programmed for [0, 1] and clip the rest).

Each Conv2d (any stride, padding -- 'same' and 'valid' too -- padding_mode, dilation and
groups) and Linear becomes an xbarsim.Crossbar (the layer classes AnalogConv2d and AnalogLinear,
also named CrossbarConv2d and CrossbarLinear) programmed as eval programs the same layer of the
model's ONNX export: the same matrix rows on the crossbars (eval's im2col order; grouped and
dilated convolutions as the ONNX import maps them), the same input range [0, x_max] (or signed)
and calibration vectors (eval's picks from the calibration images, by calibration.seed) and the
same salt. The values cross between torch and xbarsim as NumPy arrays (no libtorch link); any
torch model works, exportable or not.

The device model (device.* of the config; `Device` applies it to NumPy arrays of conductances)
programs every layer as eval's; each layer counts the images it has seen, and image k of that
count reads with the read noise of eval's image k (`set_image` restarts the count).
`set_time(model, t)` reads the model t seconds after programming without programming it again.

This is the package's place for inference, beside `xbarsim.nn` (training); `xbarsim.torch`, its
first name, is this module's functions and classes under that name.
"""
import copy
import warnings

import numpy as np
import torch
import torch.nn.functional as F

from . import (Config, Crossbar, Device, calibration_row_picks, calibration_rows_per_image,  # noqa: F401
               layer_output_range, output_errors)
from . import _core

__all__ = ["Device", "convert", "evaluate", "set_time", "set_image", "AnalogConv2d", "AnalogLinear", "CrossbarConv2d",
           "CrossbarLinear"]


def _span(module):
    """A convolution's kernel as eval maps it: (k - 1) * dilation + 1 on a side."""
    return tuple((k - 1) * d + 1 for k, d in zip(module.kernel_size, module.dilation))


def _weight_matrix(module):
    """The layer's weight as inputs x outputs, rows in eval's im2col order (kernel column, then
    kernel row, then input channel: the row a weight has on the crossbar, which the wire
    resistances see). A grouped convolution's matrix is zero where an input channel is outside
    an output's group, and a dilated one is the dense kernel its taps span, zero between the
    taps: both as the ONNX import maps them."""
    w = module.weight.detach().double().cpu().numpy()
    if isinstance(module, torch.nn.Linear):
        return w.T.copy()
    out_c, in_per_group = w.shape[:2]
    kh, kw = _span(module)
    dense = np.zeros((out_c, in_per_group, kh, kw))
    dense[:, :, ::module.dilation[0], ::module.dilation[1]] = w
    w = dense
    groups = module.groups
    per_out = out_c // groups
    full = np.zeros((in_per_group * groups, kh, kw, out_c))
    for g in range(groups):
        full[g * in_per_group:(g + 1) * in_per_group, :, :, g * per_out:(g + 1) * per_out] = \
            w[g * per_out:(g + 1) * per_out].transpose(1, 2, 3, 0)
    return np.ascontiguousarray(full.transpose(2, 1, 0, 3).reshape(kw * kh * in_per_group * groups, out_c))


def _pads(module):
    """A convolution's padding as F.pad takes it, (left, right, top, bottom): its padding on
    each side, or for padding='same' the kernel's span less one, split as torch splits it
    (the odd one after)."""
    if module.padding == "valid":
        return (0, 0, 0, 0)
    if module.padding == "same":
        out = []
        for d, k in reversed(list(zip(module.dilation, module.kernel_size))):
            total = d * (k - 1)
            out += [total // 2, total - total // 2]
        return tuple(out)
    ph, pw = module.padding
    return (pw, pw, ph, ph)


def _padded(module, x):
    """A convolution's input padded as the layer pads it (padding_mode zeros, reflect,
    replicate or circular): data movement before the crossbar, done in torch."""
    pads = _pads(module)
    if not any(pads):
        return x
    if module.padding_mode == "zeros":
        return F.pad(x, pads)
    return F.pad(x, pads, mode=module.padding_mode)


def _columns(module, x):
    """The layer's input vectors, one per row, in eval's im2col order: a convolution's windows
    (one per output position, row-major) of its padded input, with values ordered as
    _weight_matrix's rows."""
    if isinstance(module, torch.nn.Linear):
        return x.reshape(-1, x.shape[-1])
    kh, kw = _span(module)
    cols = F.unfold(_padded(module, x), (kh, kw), stride=module.stride)
    n, _, positions = cols.shape
    cols = cols.reshape(n, -1, kh, kw, positions).permute(0, 4, 3, 2, 1)
    return cols.reshape(n * positions, -1)


class _Analog(torch.nn.Module):
    def __init__(self, module, crossbar, output_range):
        super().__init__()
        self.software = module  # the original layer: its bias, shape arguments and reference output
        self.crossbar = crossbar
        # The range of the layer's outputs over the calibration data (all channels: eval's
        # layer_output_range), which its errors are relative to; None: calibration never reached it.
        self.output_range = output_range
        self._software_mode = False  # evaluate(): the layer computes in torch, as the reference network
        self._keep = None  # evaluate(): a list the layer appends its output to

    def _matmul(self, cols, images):
        # float32 vectors compute in single precision, as eval's network inference; others in double.
        # The rows are `images` images' input vectors, each image's together: image k of the batch
        # reads as image crossbar.next_image + k (its read noise, as eval's dataset index), and the
        # crossbar's counter advances by the batch.
        cols = cols.detach().cpu()
        per_image = cols.shape[0] // images if images else 1
        y = self.crossbar.matvec((cols if cols.dtype == torch.float32 else cols.double()).numpy(),
                                 rows_per_image=per_image)
        return torch.from_numpy(y)

    def _out(self, y):
        if self._keep is not None:
            self._keep.append(y.detach())
        return y


class AnalogConv2d(_Analog):
    def forward(self, x):
        m = self.software
        if self._software_mode:
            return self._out(m(x))
        n, _, h, w = x.shape
        left, right, top, bottom = _pads(m)
        oh = (h + top + bottom - m.dilation[0] * (m.kernel_size[0] - 1) - 1) // m.stride[0] + 1
        ow = (w + left + right - m.dilation[1] * (m.kernel_size[1] - 1) - 1) // m.stride[1] + 1
        y = self._matmul(_columns(m, x), n).to(x.dtype).reshape(n, oh * ow, -1).transpose(1, 2).reshape(n, -1, oh, ow)
        if m.bias is not None:
            y = y + m.bias.detach().reshape(1, -1, 1, 1)
        return self._out(y)


class AnalogLinear(_Analog):
    def forward(self, x):
        m = self.software
        if self._software_mode:
            return self._out(m(x))
        y = self._matmul(_columns(m, x), x.shape[0] if x.dim() > 1 else 1).to(x.dtype).reshape(*x.shape[:-1], -1)
        if m.bias is not None:
            y = y + m.bias.detach()
        return self._out(y)


CrossbarConv2d = AnalogConv2d  # the names xbarsim.inference gave them first
CrossbarLinear = AnalogLinear


def _calibration_statistics(modules, inputs, seed, samples):
    """Per layer, as eval gathers them from its calibration images: the largest |input|, whether
    an input was negative, and the calibration vectors (eval's picks: the layer's share of each
    image's draws, kept in image order up to `samples`). `inputs[l]`: the layer's inputs, one
    tensor per batch, images in calibration-set order."""
    stats = []
    for l, (m, batches) in enumerate(zip(modules, inputs)):
        images = sum(len(b) for b in batches)
        if images == 0:
            stats.append((1.0, False, None))
            continue
        per_image = calibration_rows_per_image(samples, images)
        keep = min(per_image * images, samples)
        x_max, signed, rows, k = 0.0, False, [], 0
        for batch in batches:
            for image in batch:
                cols = _columns(m, image.unsqueeze(0))  # this image's input vectors (im2col rows)
                x_max = max(x_max, float(cols.abs().max()))
                signed = signed or bool(cols.min() < 0)
                if k * per_image < keep:
                    picks = calibration_row_picks(seed, k, l, cols.shape[0], per_image)
                    rows.append(cols[torch.as_tensor(picks, dtype=torch.long)].double())
                k += 1
        calib = torch.cat(rows)[:keep].numpy() if rows else None
        stats.append((x_max if x_max > 0 else 1.0, signed, calib))
    return stats


def convert(model, config=None, calibration=None, calibration_samples=None, max_calibration_batches=None,
            signed_layers=(), progress=None):
    """A copy of `model` whose Conv2d and Linear layers run on crossbars.

    `calibration` (required): a batch of inputs (a tensor), or an iterable of batches (a DataLoader of
    tensors or of (inputs, labels)), at most `max_calibration_batches` of them, run through
    the model (in its dtype; float32 computes as eval) to find each layer's input range and
    calibration vectors exactly as eval does from its calibration images: the same ranges and,
    with the same `calibration.seed`, the same vectors, at most `calibration_samples`
    (default: the config's eval.calibration_samples) per layer. Layers count in the order
    `model.named_modules()` lists them (eval: the ONNX graph's order); the l-th is programmed
    with salt l + 1, as eval's. A layer is programmed for signed inputs when its calibration
    inputs had a negative value, or when its name is in `signed_layers`: eval also makes signed
    every layer whose inputs the graph can make negative (not after a ReLU, say), which a torch
    model does not say; a layer whose inputs are never negative in the data (after a sigmoid)
    matches eval only when named here. The calibration images are counted by the layer's calls
    (one per image batch), as a network that calls each layer once per forward does.
    `calibration` is required (ValueError without it): a model whose inputs are normalised
    (mean 0, std 1) programmed for [0, 1] would clip every negative input. The calibration
    outputs also give each layer's output range, which evaluate()'s errors are relative to.
    `progress(name, done, total)` is called after each layer is programmed.
    """
    if calibration is None:
        raise ValueError(
            "convert needs calibration=: a batch of inputs (a tensor) or a loader of batches, preprocessed as "
            "the model's inputs will be; each layer's input range and calibration vectors come from it "
            "(without it every layer would be programmed for inputs in [0, 1] and clip the rest)")
    config = config if config is not None else Config()
    samples = int(config.get("eval.calibration_samples") if calibration_samples is None else calibration_samples)
    if samples < 1:
        raise ValueError("calibration_samples must be >= 1")
    model = copy.deepcopy(model).eval()
    layers = [(name, m) for name, m in model.named_modules() if isinstance(m, (torch.nn.Conv2d, torch.nn.Linear))]
    seen = [[] for _ in layers]
    lo = [None] * len(layers)  # per layer and output channel: the calibration outputs' extremes
    hi = [None] * len(layers)
    reads_image = [False] * len(layers)  # the layer's input is the model's input itself, as eval's
    current = [None]

    def keep(l):
        def hook(module, inputs, output):  # returns None: the output stays the layer's
            reads_image[l] = reads_image[l] or inputs[0] is current[0]
            seen[l].append(inputs[0].detach())
            per_channel = output.detach().double().transpose(0, 1).reshape(output.shape[1], -1)
            a, b = per_channel.amin(dim=1), per_channel.amax(dim=1)
            lo[l] = a if lo[l] is None else torch.minimum(lo[l], a)
            hi[l] = b if hi[l] is None else torch.maximum(hi[l], b)
        return hook

    hooks = [m.register_forward_hook(keep(l)) for l, (_, m) in enumerate(layers)]
    batches = [calibration] if torch.is_tensor(calibration) else calibration
    try:
        with torch.no_grad():
            for k, batch in enumerate(batches):
                if max_calibration_batches is not None and k >= max_calibration_batches:
                    break
                current[0] = batch[0] if isinstance(batch, (tuple, list)) else batch
                model(current[0])
    finally:
        for h in hooks:
            h.remove()
    if not any(seen):
        raise ValueError("convert: the calibration data holds no batch")
    stats = _calibration_statistics([m for _, m in layers], seen, int(config.get("calibration.seed")), samples)
    unused = [name for (name, _), s in zip(layers, seen) if not s]
    if unused:  # an auxiliary head, say: programmed for inputs in [0, 1], random calibration
        warnings.warn("the calibration batches never reached layer(s) " + ", ".join(unused) +
                      ": they are programmed for inputs in [0, 1]")
    unknown = set(signed_layers) - {name for name, _ in layers}
    if unknown:
        raise ValueError("signed_layers names no Conv2d or Linear of the model: " + ", ".join(sorted(unknown)))
    for l, (name, m) in enumerate(layers):
        x_max, signed, calib = stats[l]
        signed = signed or name in signed_layers
        grouping = {} if isinstance(m, torch.nn.Linear) else {"groups": m.groups, "channels": m.in_channels}
        xb = Crossbar(_weight_matrix(m), config, x_max=x_max, signed_inputs=signed, calibration=calib, salt=l + 1,
                      reads_image=reads_image[l], **grouping)
        out_range = None if lo[l] is None else layer_output_range(lo[l].numpy(), hi[l].numpy())
        analog = (AnalogLinear if isinstance(m, torch.nn.Linear) else AnalogConv2d)(m, xb, out_range)
        parent = model
        *path, last = name.split(".")
        for part in path:
            parent = getattr(parent, part)
        setattr(parent, last, analog)
        if progress is not None:
            progress(name, l + 1, len(layers))
    return model


def _analog_layers(model):
    return [(name, m) for name, m in model.named_modules() if isinstance(m, _Analog)]


def set_time(model, t, compensation=None):
    """Reads every analog layer of `model` (a converted one) t seconds after programming
    (device.time_s; and device.compensation when given) without programming it again: the same
    cells and draws, as a model converted with that device.time_s (Crossbar.set_time). A sweep
    over time is a loop over set_time on one converted model."""
    layers = _analog_layers(model)
    if not layers:
        raise ValueError("set_time: the model has no analog layer (convert it first)")
    for _, m in layers:
        m.crossbar.set_time(t, compensation)
    return model


def set_image(model, image=0):
    """The index the next image the model runs reads as (every analog layer's
    Crossbar.next_image): each image's reads draw their read noise from it, as eval's reads from
    the image's index in the dataset. Layers count the images they see (the first batch after
    convert reads as images 0, 1, ...); set it to repeat a run's noise."""
    for _, m in _analog_layers(model):
        m.crossbar.next_image = image
    return model


def evaluate(model, loader, reference=None):
    """Accuracy of `model` (a converted one) over (inputs, labels) batches of `loader`; with
    `reference` (the original), its accuracy too and how many predictions agree.

    Per-layer errors as eval reports them: each analog layer's output in the converted network
    against the same layer's output when the whole network computes in torch (the analog layers'
    `software` modules) on the same inputs, so errors propagate from layer to layer; each
    |difference| relative to the layer's output range over the calibration data
    (xbarsim.output_errors, docs/physics.md). A layer whose mean error passes
    xbarsim._core.layer_error_warning is named in "warnings" (and warned about).
    """
    analog = _analog_layers(model)
    tally = {name: [0.0, 0.0, 0] for name, m in analog if m.output_range is not None}  # sum, worst, count
    correct = ref_correct = agree = total = 0
    with torch.no_grad():
        for x, labels in loader:
            outputs = []
            for software in (False, True):
                for _, m in analog:
                    m._software_mode, m._keep = software, []
                try:
                    logits = model(x)
                finally:
                    kept = {name: m._keep for name, m in analog}
                    for _, m in analog:
                        m._software_mode, m._keep = False, None
                outputs.append((logits, kept))
            (logits, crossbar), (_, software) = outputs
            for name, m in analog:
                if name not in tally:
                    continue
                for y, ref in zip(crossbar[name], software[name]):
                    mean, worst, count = output_errors(y.double().numpy(), ref.double().numpy(), m.output_range)
                    t = tally[name]
                    t[0] += mean * count
                    t[1] = max(t[1], worst)
                    t[2] += count
            pred = logits.argmax(dim=1)
            correct += int((pred == labels).sum())
            if reference is not None:
                ref = reference(x).argmax(dim=1)
                ref_correct += int((ref == labels).sum())
                agree += int((ref == pred).sum())
            total += len(labels)
    out = {"images": total, "accuracy": correct / max(total, 1)}
    if reference is not None:
        out.update(software_accuracy=ref_correct / max(total, 1), agreeing_predictions=agree)
    out["layer_mean_relative_error"] = {name: t[0] / t[2] for name, t in tally.items() if t[2]}
    out["layer_worst_relative_error"] = {name: t[1] for name, t in tally.items() if t[2]}
    out["warnings"] = [_core.layer_error_warning_text(name, mean)
                       for name, mean in out["layer_mean_relative_error"].items()
                       if mean > _core.layer_error_warning]
    for w in out["warnings"]:
        warnings.warn(w)
    return out
