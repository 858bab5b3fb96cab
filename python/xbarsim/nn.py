"""Analog layers for hardware-aware training (HWA): torch modules whose forward injects the
non-idealities of an xbarsim configuration and whose backward is straight-through.

    import xbarsim, xbarsim.nn
    hw = xbarsim.nn.Hardware(xbarsim.Config(overrides={"device.model": "rram-wan2022",
                                                        "mapping.negative": "differential"}))
    model = xbarsim.nn.convert(model, hw, calibration=images)   # Conv2d/Linear -> analog layers (a copy)
    for x, y in loader:
        hw.new_batch()                  # fresh programming error, faults (and drift) for this step
        loss = F.cross_entropy(model(x), y); loss.backward(); ...
    model = xbarsim.nn.to_software(model)   # plain Conv2d/Linear with the trained weights

This is the *fast training path*: the weights as the configuration maps them (per crossbar:
scale, shift or differential pairs, weight codes and cell slices -- `xbarsim._core.weight_cells`,
the same mapping eval uses), the cells' programming error, stuck cells and drift drawn by the same
device model (`xbarsim.Device`), one read's noise per forward (the device's read sigma, first
order in dG as eval's linear path, and the readout noise), DAC and ADC quantization and clipping
at calibrated ranges. It does not solve the wired circuit and has no conversion or calibration:
the exact evaluation is `xbarsim eval` on the exported model (xbarsim.onnx.export) or
`xbarsim.inference.convert`. docs/python.md, "Hardware-aware training", says what each part
models and where it approximates.

The backward is straight-through: the gradient of the layer with respect to its weight and input
is that of the same torch layer computing with the quantized input and the noisy weight
(quantization, noise and clipping pass the gradient unchanged).
"""
import copy
import math

import numpy as np
import torch
import torch.nn.functional as F

from . import Config, Device, _core

__all__ = ["Hardware", "AnalogConv2d", "AnalogLinear", "convert", "calibrate", "to_software", "analog_layers", "draw"]


def _bits(config, key):
    v = config.get(key)
    return None if v is None or v == "none" else int(v)


class Hardware:
    """What the training forward injects, read once from an xbarsim configuration.

    `config`: a Config, a dict of {"dotted.key": value} or None (the defaults). From it:
    mapping.* (crossbar size, shift/differential, weight_bits, g_headroom), crossbar.cell_bits,
    the device model (device.*: programming error, stuck cells, drift at device.time_s with
    device.compensation, read noise), converters.* (DAC/input bits, ADC bits and margin, the
    readout noise). Switches: `device` (draw the device's non-idealities), `converters` (DAC and
    ADC quantization), `read_noise`. `weight_noise`: NeuRRAM's training noise, Gaussian with a
    standard deviation of this fraction of each layer's largest |weight|, drawn per batch (0:
    none). `time_s`: the time after programming each batch reads at: None (device.time_s), a
    number, or a pair (t0, t1): drawn log-uniformly per batch. `seed`: every draw's stream, with
    the batch counter and the layer. `noise_scale`: the held weights' deviation from the trained
    ones (programming error, drift, calibration's residue, read noise) times this in training (1:
    as the device; more trains for a noisier device). `exact_adc`: see _readout. `range_every`:
    under ranging.weights mse (the default under a device model) each layer's weight ranges are
    searched again every this many steps and after every calibrate(), and kept in between (the
    search costs more than the rest of a step's draw; 1: every step, as eval maps the final weights).
    """

    def __init__(self, config=None, weight_noise=0.0, device=True, converters=True, read_noise=True, time_s=None,
                 seed=0, exact_adc=False, noise_scale=1.0, range_every=16):
        self.exact_adc = bool(exact_adc)
        if not (isinstance(range_every, int) and range_every >= 1):
            raise ValueError(f"range_every must be an integer >= 1, got {range_every}")
        if not (noise_scale >= 0 and math.isfinite(noise_scale)):
            raise ValueError(f"noise_scale must be a number >= 0, got {noise_scale}")
        self.noise_scale = float(noise_scale)
        self.config = config if isinstance(config, Config) else Config(overrides=config or {})
        cfg = self.config
        # the configuration's device model (validating device.*; its range is the cells'), its seed
        # mixed with the training seed: the training's draws are its own
        device_keys = {f"device.{k}": v for k, v in cfg.to_dict()["device"].items()}
        device_keys.update({k: cfg.get(k) for k in ("crossbar.g_min", "crossbar.g_max")})
        device_keys["device.seed"] = (cfg.get("device.seed") * 1000003 + int(seed)) % (2 ** 62)
        self.device_model = Device(device_keys)
        self.g_min = self.device_model.g_min
        self.compensation = cfg.get("device.compensation")
        self.use_device = bool(device) and (self.device_model.kind != "ideal" or
                                            cfg.get("device.stuck_at_gmin") > 0 or cfg.get("device.stuck_at_gmax") > 0)
        self.use_read_noise = bool(read_noise) and (self.device_model.has_read_noise or
                                                    cfg.get("converters.readout_noise_na") > 0)
        self.readout_noise_a = cfg.get("converters.readout_noise_na") * 1e-9
        weights = cfg.get("ranging.weights")
        searched = weights == "mse" or (weights == "auto" and self.device_model.kind != "ideal")
        self.range_every = int(range_every) if searched else 1
        self.v_in_max = cfg.get("crossbar.v_in_max")
        self.converters = bool(converters)
        self.dac_bits = _bits(cfg, "converters.input_bits") or _bits(cfg, "converters.dac_bits")
        # the layers that read the model's input itself take converters.image_bits (as eval's)
        self.image_bits = _bits(cfg, "converters.image_bits") or self.dac_bits
        self.adc_bits = _bits(cfg, "converters.adc_bits")
        self.adc_margin = cfg.get("converters.adc_margin")
        self.calibrates = "calibration" in cfg.get("mitigation.method")
        self.calibration_samples = int(cfg.get("calibration.samples"))
        self.ranging_samples = max(int(cfg.get("eval.calibration_samples")), self.calibration_samples)
        if not weight_noise >= 0 or not math.isfinite(weight_noise):
            raise ValueError(f"weight_noise must be a number >= 0, got {weight_noise}")
        self.weight_noise = float(weight_noise)
        if time_s is None:
            time_s = cfg.get("device.time_s")
        times = tuple(time_s) if isinstance(time_s, (tuple, list)) else (time_s, time_s)
        if len(times) != 2 or not all(math.isfinite(t) and t >= 0 for t in times) or times[0] > times[1]:
            raise ValueError(f"time_s must be a time >= 0 (s) or a pair t0 <= t1, got {time_s}")
        if times[0] != times[1] and times[0] <= 0:
            raise ValueError("time_s: a range of times is drawn log-uniformly, so it must start above 0 s")
        self.times = times
        self.seed = int(seed)
        self.step = 0
        self.enabled = True
        self.mapper = _core.TrainingMapper(cfg)
        self._quantizes = (_bits(cfg, "mapping.weight_bits") is not None or
                           _bits(cfg, "crossbar.cell_bits") is not None)

    def __deepcopy__(self, memo):
        return self  # a model's copy shares its hardware (a description, and its step counter)

    def new_batch(self):
        """The next training step: every layer draws its programming error, faults, drift and
        weight noise afresh (read noise is fresh on every forward anyway)."""
        self.step += 1

    def time_of_step(self):
        t0, t1 = self.times
        if t0 == t1:
            return t0
        u = np.random.default_rng([self.seed, self.step, 0x7]).random()
        return math.exp(math.log(t0) + u * (math.log(t1) - math.log(t0)))

    def device_key(self, layer_index, crossbar):
        """(layer, crossbar) keys of this step's draws for crossbar `crossbar` of a layer: the
        step in the crossbar key's high bits, so each step programs afresh."""
        return layer_index + 1, (self.step << 20) + crossbar

    @property
    def active(self):
        return self.enabled and (self.use_device or self.use_read_noise or self.weight_noise > 0 or
                                 (self.converters and (self.dac_bits or self.image_bits or self.adc_bits)) or
                                 self._quantizes)

    def input_bits(self, layer):
        """The bits of `layer`'s input codes: converters.image_bits for a layer that reads the
        model's input (calibrate() finds them), else the activations' (None: no DAC)."""
        return self.image_bits if bool(layer.reads_image) else self.dac_bits


def _quantize(v, lo, hi, levels):
    """v clamped to [lo, hi] and rounded to `levels` evenly spaced values (lo, hi tensors that
    broadcast; v is not changed)."""
    step = (hi - lo) / (levels - 1)
    step = torch.where(step > 0, step, torch.ones_like(step))
    return torch.maximum(torch.minimum(v, hi), lo).sub_(lo).div_(step).round_().mul_(step).add_(lo)


_UNIFORM = {}
_NO_ROWS = np.zeros((0, 1 << 20))  # no calibration vectors (a view of 0 rows of any width)


def _uniform(shape, gen, dtype):
    """Uniform values on [-1/2, 1/2) of `shape`: a window, at an offset drawn from `gen`, of a table
    of 2^22 drawn once (a fresh draw per element cost more than the rest of the ADC's model)."""
    n = math.prod(shape)
    size = max(1 << 22, 2 * n)
    table = _UNIFORM.get(dtype)
    if table is None or table.numel() < size:
        table = torch.rand(size, generator=torch.Generator().manual_seed(0x5eed), dtype=dtype).sub_(0.5)
        _UNIFORM[dtype] = table
    offset = int(torch.randint(0, table.numel() - n + 1, (1,), generator=gen))
    return table[offset:offset + n].view(shape)


class _Dac(torch.autograd.Function):
    """Clip to [lo, hi] and round to lo + k step (step None: no rounding); the backward is
    straight through, clipping included (no mask to form or keep)."""

    @staticmethod
    def forward(ctx, x, lo, hi, step):
        q = x.clamp(lo, hi)
        if step is not None:
            if lo:
                q.sub_(lo)
            q.div_(step).round_().mul_(step)
            if lo:
                q.add_(lo)
        return q

    @staticmethod
    def backward(ctx, grad):
        return grad, None, None, None


class _Replace(torch.autograd.Function):
    """The value of `value` with the gradient of `through`: the readout's output (noise, ADC)
    passed straight through to the layer's product."""

    @staticmethod
    def forward(ctx, through, value):
        return value

    @staticmethod
    def backward(ctx, grad):
        return grad, None


class _AnalogMixin:
    """What the analog Conv2d and Linear share: the weight as a matrix in eval's row order, the
    per-step noise drawn through the mapping and the device model, DAC and readout."""

    def _take(self, m, hw, index):
        """This layer with `m`'s weight and bias (copies), injecting `hw` as layer `index`."""
        self.weight = torch.nn.Parameter(m.weight.detach().clone())
        if m.bias is not None:
            self.bias = torch.nn.Parameter(m.bias.detach().clone())
        self._setup(hw, index)
        return self

    def _load_from_state_dict(self, state_dict, prefix, *args, **kwargs):
        key = prefix + "reads_image"
        if key not in state_dict:  # a state from before converters.image_bits: this layer's own
            state_dict[key] = self.reads_image.clone()
        super()._load_from_state_dict(state_dict, prefix, *args, **kwargs)

    def _setup(self, hw, index):
        self.hw = hw
        self.index = index  # the layer's place among the model's Conv2d/Linear: its stream and salt
        self.register_buffer("x_max", torch.ones(()))
        self.register_buffer("signed_inputs", torch.zeros((), dtype=torch.bool))
        self.register_buffer("reads_image", torch.zeros((), dtype=torch.bool))  # set by calibrate()
        self._adc = None  # per crossbar block: (lo, hi) per column of its partial sums
        self._delta_step = None
        self._delta = None
        self._sigma2 = None
        self._blocks = None
        self._single_row_block = True
        self._ro_var = None
        self._reads = 0  # forwards so far: each reads with noise of its own
        self._offset = None
        self._calib_rows = None  # calibration vectors (eval's row order), float64 NumPy
        self._adc_lohi = None  # one block of rows: (lo, hi) per output column
        self._adc_var = None  # several: the quantization's variance per output column, summed over blocks
        self._ranges = None  # the weight ranges of the last search, per block (lo, hi), and its step
        self._ranges_step = None

    # --- the weight as eval's matrix (inputs x outputs) and back --------------------------------
    def _to_matrix(self, w):
        if isinstance(self, torch.nn.Linear):
            return w.t()
        o, c, kh, kw = w.shape
        return w.permute(3, 2, 1, 0).reshape(kw * kh * c, o)  # rows: kernel column, kernel row, channel

    def _from_matrix(self, m):
        if isinstance(self, torch.nn.Linear):
            return m.t()
        o, c, kh, kw = self.weight.shape
        return m.reshape(kw, kh, c, o).permute(3, 2, 1, 0)

    # --- per-step weight noise --------------------------------------------------------------
    def _draw(self):
        """This step's weight as the cells hold it, less the weight (delta, weight units) and
        the variance of one read's weight per weight (sigma2), both in eval's matrix layout:
        eval's mapping, the device's programming and drift, the compensation's and calibration's
        gains per crossbar column (xbarsim._core.TrainingMapper.draw, which releases the GIL:
        draw() runs a step's layers on every core)."""
        hw = self.hw
        w = self._to_matrix(self.weight.detach()).double().cpu().numpy()
        reuse = (self._ranges is not None and hw.range_every > 1 and 0 <= hw.step - self._ranges_step < hw.range_every)
        calib = self._calib_rows if hw.calibrates and self._calib_rows is not None else _NO_ROWS[:, :w.shape[0]]
        layer, _ = hw.device_key(self.index, 0)
        r = hw.mapper.draw(hw.device_model, w, self._ranges if reuse else None, calib, layer, hw.step,
                           hw.use_device, hw.time_of_step() if hw.use_device else 0.0, hw.compensation,
                           hw.use_read_noise, hw.readout_noise_a, hw.v_in_max, hw.noise_scale)
        if not reuse:
            self._ranges, self._ranges_step = r["ranges"], hw.step
        delta, sigma2 = r["delta"], r["sigma2"]
        if hw.weight_noise > 0:
            rng = np.random.default_rng([hw.seed, hw.step, self.index, 0x4e])
            delta += hw.weight_noise * np.abs(w).max() * rng.standard_normal(w.shape)
        dev = self.weight.device
        self._delta = self._from_matrix(torch.from_numpy(delta).to(dev, self.weight.dtype))
        self._sigma2 = None if sigma2 is None else torch.from_numpy(sigma2).to(dev, self.weight.dtype)
        self._blocks = [(r0, rows, c0, cols, None if ro is None else torch.from_numpy(ro))
                        for r0, rows, c0, cols, ro in r["blocks"]]
        self._single_row_block = len({b[0] for b in self._blocks}) == 1  # the layer's output is its crossbars' sums
        self._ro_var = torch.from_numpy(r["readout_var"]) if hw.readout_noise_a and sigma2 is not None else None
        offset = r["offset"]
        self._offset = torch.from_numpy(offset).to(dev, self.weight.dtype) if offset.any() else None
        self._delta_step = hw.step

    # --- the forward --------------------------------------------------------------------------
    def _dac(self, x):
        """eval's input codes: unsigned 0 .. 2^B - 1 over [0, x_max]; signed a sign and B - 1
        magnitude bits, -(2^m - 1) .. 2^m - 1 over [-x_max, x_max] (sw/analog/input_slicing.h).
        Straight through, clipping included."""
        hw = self.hw
        hi = float(self.x_max)
        signed = bool(self.signed_inputs)
        lo = -hi if signed else 0.0
        step = None
        bits = hw.input_bits(self)
        if hw.converters and bits:
            step = hi / (2 ** max(bits - 1, 1) - 1) if signed else hi / (2 ** bits - 1)
        return _Dac.apply(x, lo, hi, step)

    def _needs_readout(self):
        hw = self.hw
        noisy = hw.use_read_noise and self._sigma2 is not None
        exact_blocks = hw.exact_adc and not self._single_row_block
        return (noisy and (self._ro_var is not None or exact_blocks)) or bool(hw.converters and hw.adc_bits and
                                                                              self._adc)

    def _analog_forward(self, x):
        hw = self.hw
        if not hw.active:
            return self._plain(x, self.weight)
        if self._delta_step != hw.step or self._delta is None:
            self._draw()
        xq = self._dac(x)
        # one read's noise: fresh on every forward, from (seed, step, layer, forward)
        self._reads += 1
        gen = torch.Generator().manual_seed(int(np.random.SeedSequence(
            [hw.seed, hw.step, self.index, self._reads]).generate_state(1, np.uint64)[0]) >> 1)
        w = self.weight + self._delta
        if hw.use_read_noise and self._sigma2 is not None:
            # the cells' read fluctuation as the weights' (aihwkit's forward noise): one draw per
            # forward, shared by the batch's vectors (eval draws one per vector)
            w = w + self._from_matrix(self._sigma2.sqrt() * torch.randn(self._sigma2.shape, generator=gen,
                                                                        dtype=self._sigma2.dtype))
        y = self._plain(xq, w, bias=False)
        if self._needs_readout():
            with torch.no_grad():
                out = self._readout(xq.detach(), y.detach(), gen)
            y = _Replace.apply(y, out)  # straight through: the readout passes the gradient unchanged
        shift = self.bias
        if self._offset is not None:
            shift = self._offset if shift is None else shift + self._offset
        if shift is not None:
            y = y + shift.reshape((1, -1) + (1,) * (y.dim() - 2))
        return y

    def _readout(self, xq, y, gen):
        """The crossbars' outputs summed over the row blocks, with one read's noise (the device's
        and the readout's, fresh per forward), through the ADCs at their calibrated ranges.

        One block of rows (the layer's output is the crossbars' partial sums): each column's ADC
        quantizes and clips exactly. Several: the blocks' quantization errors are added as their
        statistical equivalent, a uniform error of their summed variance (step^2 / 12 per block
        and column; no clipping), unless Hardware(exact_adc=True), which forms every block's partial
        sums (slower: an unfolded matrix product per block)."""
        hw = self.hw
        noisy = hw.use_read_noise and self._sigma2 is not None
        adc = hw.converters and hw.adc_bits and self._adc is not None
        single = self._single_row_block
        shape = (1, -1) + (1,) * (y.dim() - 2)
        if single or not hw.exact_adc:
            var = None
            if noisy and self._ro_var is not None:
                var = (self._ro_var * float(self.x_max) ** 2).to(y.dtype).reshape(shape)
            part = y if var is None else y + var.sqrt() * torch.randn(y.shape, generator=gen, dtype=y.dtype)
            if adc and not single:
                # the crossbars' quantization errors as one uniform error of their summed variance
                width = (12 * self._adc_var).sqrt().to(y.dtype).reshape(shape)
                part = part + _uniform(y.shape, gen, y.dtype).mul(width)
            if adc and single:
                lo, hi = (v.to(y.dtype).reshape(shape) for v in self._adc_lohi)
                part = _quantize(part, lo, hi, 2 ** hw.adc_bits)
            return part
        rows = self._rows(xq)  # (vectors, K), eval's row order
        w = self._to_matrix(self.weight.detach() + self._delta)
        out = torch.zeros_like(y)
        for k, (r0, nr, c0, nc, ro) in enumerate(self._blocks):
            x_b = rows[:, r0:r0 + nr]
            part = self._to_layout(x_b @ w[r0:r0 + nr, c0:c0 + nc], y)
            if noisy:
                var = self._to_layout((x_b * x_b) @ self._sigma2[r0:r0 + nr, c0:c0 + nc], y).clamp(min=0)
                if ro is not None:
                    var = var + (ro * float(self.x_max) ** 2).to(y.dtype).reshape(shape)
                part = part + var.sqrt() * torch.randn(var.shape, generator=gen, dtype=y.dtype)
            if adc:
                lo, hi = (v.to(y.dtype).reshape(shape) for v in self._adc[k])
                part = _quantize(part, lo, hi, 2 ** hw.adc_bits)
            out.narrow(1, c0, nc).add_(part)
        return out


class AnalogConv2d(_AnalogMixin, torch.nn.Conv2d):
    """A Conv2d whose forward injects Hardware's non-idealities (module docstring)."""

    @classmethod
    def from_module(cls, m, hw, index):
        if m.groups != 1:
            raise ValueError("xbarsim.nn: a grouped convolution (groups > 1) is not supported for training")
        if m.padding_mode != "zeros" or isinstance(m.padding, str):
            raise ValueError("xbarsim.nn: a convolution with padding_mode other than zeros or string padding "
                             "is not supported for training")
        if tuple(m.dilation) != (1, 1):
            raise ValueError("xbarsim.nn: a dilated convolution is not supported for training")
        return cls(m.in_channels, m.out_channels, m.kernel_size, stride=m.stride, padding=m.padding,
                   bias=m.bias is not None)._take(m, hw, index)

    def _plain(self, x, w, bias=True):
        return F.conv2d(x, w, self.bias if bias else None, self.stride, self.padding, self.dilation)

    def _rows(self, x):
        """The input vectors (one per image and output position) in eval's row order."""
        cols = F.unfold(x, self.kernel_size, dilation=self.dilation, padding=self.padding, stride=self.stride)
        n, _, positions = cols.shape
        c, (kh, kw) = self.in_channels, self.kernel_size
        # torch's rows: channel, kernel row, kernel column; eval's: kernel column, kernel row, channel
        return cols.reshape(n, c, kh, kw, positions).permute(0, 4, 3, 2, 1).reshape(n * positions, kw * kh * c)

    def _out_size(self, x):
        (kh, kw), (sh, sw), (ph, pw), (dh, dw) = self.kernel_size, self.stride, self.padding, self.dilation
        return ((x.shape[2] + 2 * ph - dh * (kh - 1) - 1) // sh + 1, (x.shape[3] + 2 * pw - dw * (kw - 1) - 1) // sw + 1)

    def _row_count(self, x):
        oh, ow = self._out_size(x)
        return x.shape[0] * oh * ow

    def _rows_at(self, x, idx):
        """_rows(x)[idx]: the input vectors `idx` (image-major, then output position), gathered."""
        (kh, kw), (sh, sw), (ph, pw), (dh, dw) = self.kernel_size, self.stride, self.padding, self.dilation
        oh, ow = self._out_size(x)
        img, pos = idx // (oh * ow), idx % (oh * ow)
        xp = F.pad(x, (pw, pw, ph, ph))
        iy = ((pos // ow) * sh)[:, None, None] + (torch.arange(kh) * dh)[None, :, None]
        ix = ((pos % ow) * sw)[:, None, None] + (torch.arange(kw) * dw)[None, None, :]
        patch = xp[img[:, None, None], :, iy, ix]  # (vectors, kh, kw, channels)
        return patch.permute(0, 2, 1, 3).reshape(len(idx), kw * kh * self.in_channels)

    def _to_layout(self, v, y):
        """(vectors, columns) -> N x columns x H x W, as y."""
        n, _, h, wd = y.shape
        return v.reshape(n, h * wd, -1).transpose(1, 2).reshape(n, -1, h, wd)

    def forward(self, x):
        return self._analog_forward(x)


class AnalogLinear(_AnalogMixin, torch.nn.Linear):
    """A Linear whose forward injects Hardware's non-idealities (module docstring)."""

    @classmethod
    def from_module(cls, m, hw, index):
        return cls(m.in_features, m.out_features, bias=m.bias is not None)._take(m, hw, index)

    def _plain(self, x, w, bias=True):
        return F.linear(x, w, self.bias if bias else None)

    def _rows(self, x):
        return x.reshape(-1, x.shape[-1])

    def _row_count(self, x):
        return x.numel() // x.shape[-1]

    def _rows_at(self, x, idx):
        return self._rows(x)[idx]

    def _to_layout(self, v, y):
        return v.reshape(*y.shape[:-1], -1)

    def forward(self, x):
        return self._analog_forward(x)


_POOL = None


def draw(model):
    """Draws this step's device state of every analog layer of `model` now, the layers in
    parallel on torch's threads (each layer's draw is its own: the same for any thread count);
    the forward otherwise draws each layer when it first meets a new step."""
    layers = [m for m in analog_layers(model) if m.hw.active and (m._delta_step != m.hw.step or m._delta is None)]
    threads = min(torch.get_num_threads(), len(layers))
    if threads <= 1:
        for m in layers:
            m._draw()
        return
    global _POOL
    if _POOL is None or _POOL._max_workers < threads:
        import concurrent.futures
        _POOL = concurrent.futures.ThreadPoolExecutor(max_workers=threads)
    # the largest first, so that the last to finish is a small one
    for f in [_POOL.submit(m._draw) for m in sorted(layers, key=lambda m: -m.weight.numel())]:
        f.result()


def analog_layers(model):
    """The model's analog layers (AnalogConv2d, AnalogLinear), in named_modules() order."""
    return [m for m in model.modules() if isinstance(m, _AnalogMixin)]


def _replace(model, make):
    layers = [(name, m) for name, m in model.named_modules()
              if isinstance(m, (torch.nn.Conv2d, torch.nn.Linear)) and not isinstance(m, _AnalogMixin)]
    for l, (name, m) in enumerate(layers):
        new = make(m, l)
        if not name:  # the model is the layer itself
            return new
        parent = model
        *path, last = name.split(".")
        for part in path:
            parent = getattr(parent, part)
        setattr(parent, last, new)
    return model


def convert(model, hardware, calibration=None):
    """A copy of `model` whose Conv2d and Linear layers are analog layers injecting `hardware`
    (a Hardware). Layers count in named_modules() order (eval's Conv/Gemm order for a model
    read by xbarsim.onnx.load); the l-th draws with layer index l. `calibration` (a batch of
    inputs, preprocessed as the model's) sets each layer's DAC range (the largest |input|, signed
    when an input is negative, as eval) and ADC ranges; required when the configuration has
    converters or read noise (calibrate() sets them again later)."""
    if not isinstance(hardware, Hardware):
        raise TypeError("convert needs a xbarsim.nn.Hardware")
    model = copy.deepcopy(model)
    model = _replace(model, lambda m, l: (AnalogLinear if isinstance(m, torch.nn.Linear) else AnalogConv2d)
                     .from_module(m, hardware, l))
    if calibration is not None:
        calibrate(model, calibration)
    elif hardware.converters and (hardware.dac_bits or hardware.image_bits or hardware.adc_bits):
        raise ValueError("convert needs calibration= (a batch of inputs) when the configuration has DAC or ADC "
                         "bits: their ranges come from it")
    return model


def calibrate(model, inputs, adc=True):
    """Sets every analog layer's DAC range (largest |input|, signed when an input is negative),
    calibration vectors and ADC ranges (each crossbar column's partial sums over
    eval.calibration_samples of the layer's input vectors, widened by converters.adc_margin of
    their span on each side, as eval) from one forward of `inputs` with noise off."""
    layers = analog_layers(model)
    if not layers:
        raise ValueError("calibrate: the model has no analog layer (xbarsim.nn.convert it first)")
    hw = layers[0].hw
    seen, image = {}, set()

    def pre_hook(mod, args):
        if args[0] is inputs:  # the layer reads the model's input itself: converters.image_bits
            image.add(id(mod))
        seen.setdefault(id(mod), args[0].detach())

    hooks = [m.register_forward_pre_hook(pre_hook) for m in layers]
    was_enabled, was_training = hw.enabled, model.training
    hw.enabled = False
    try:
        with torch.no_grad():
            model.eval()
            model(inputs)
    finally:
        for h in hooks:
            h.remove()
        hw.enabled = was_enabled
        model.train(was_training)
    for m in layers:
        x = seen.get(id(m))
        if x is None:
            continue
        m.signed_inputs.fill_(bool((x < 0).any()))
        m.reads_image.fill_(id(m) in image)
        m._adc = None
        with torch.no_grad():
            # eval keeps eval.calibration_samples input vectors of a layer for its DAC and ADC
            # ranges (the DAC's by ranging.inputs, never above the largest input) and picks
            # calibration.samples of them for the calibration fit
            keep = np.random.default_rng([hw.seed, m.index, 0xca1]).permutation(m._row_count(x))[:hw.ranging_samples]
            raw = m._rows_at(x, torch.as_tensor(keep))  # = m._rows(x)[keep], without unfolding every position
            top = float(x.abs().max()) or 1.0
            m.x_max.fill_(_core.input_full_scale(raw.double().numpy(), bool(m.signed_inputs), hw.config, top,
                                                 bool(m.reads_image))
                          if hw.converters and hw.input_bits(m) else top)
            rows = m._dac(raw).double()  # the DAC is elementwise and keeps 0 (the padding): rows of _dac(x)
            m._calib_rows = rows[:hw.calibration_samples].numpy()
        m._delta_step = None  # the next forward draws (and calibrates) afresh
        m._ranges = None  # and searches the weight ranges again
        if adc and hw.converters and hw.adc_bits:
            with torch.no_grad():
                w = m._to_matrix(m.weight.detach()).double()
                ranges = []
                for c in _core.weight_cells(w.cpu().numpy(), hw.config):
                    r0, nr, c0, nc = c["r0"], c["rows"], c["c0"], c["cols"]
                    part = (rows[:, r0:r0 + nr] @ w[r0:r0 + nr, c0:c0 + nc]).t()
                    lo, hi = part.min(dim=1).values, part.max(dim=1).values
                    span = (hi - lo).clamp(min=1e-12)
                    ranges.append((c0, nc, lo - hw.adc_margin * span, hi + hw.adc_margin * span))
                m._adc = [(lo, hi) for _, _, lo, hi in ranges]
                n_out = w.shape[1]
                lo_all = torch.zeros(n_out, dtype=torch.float64)
                hi_all = torch.zeros(n_out, dtype=torch.float64)
                var = torch.zeros(n_out, dtype=torch.float64)
                for c0, nc, lo, hi in ranges:
                    lo_all[c0:c0 + nc], hi_all[c0:c0 + nc] = lo, hi
                    var[c0:c0 + nc] += ((hi - lo) / (2 ** hw.adc_bits - 1)) ** 2 / 12
                m._adc_lohi, m._adc_var = (lo_all, hi_all), var
    return model


def to_software(model):
    """A copy of `model` with every analog layer back to a plain Conv2d / Linear of its weights."""
    model = copy.deepcopy(model)
    layers = [(name, m) for name, m in model.named_modules() if isinstance(m, _AnalogMixin)]
    for name, m in layers:
        if isinstance(m, torch.nn.Linear):
            plain = torch.nn.Linear(m.in_features, m.out_features, bias=m.bias is not None)
        else:
            plain = torch.nn.Conv2d(m.in_channels, m.out_channels, m.kernel_size, stride=m.stride, padding=m.padding,
                                    dilation=m.dilation, bias=m.bias is not None)
        plain.weight = torch.nn.Parameter(m.weight.detach().clone())
        if m.bias is not None:
            plain.bias = torch.nn.Parameter(m.bias.detach().clone())
        parent = model
        *path, last = name.split(".")
        for part in path:
            parent = getattr(parent, part)
        if not name:
            return plain
        setattr(parent, last, plain)
    return model
