"""xbarsim.nn (hardware-aware training layers), xbarsim.data, xbarsim.onnx and `python3 -m
xbarsim.hwa` on tiny data: gradients against straight-through references (torch's own layers,
hand-written quantizers, finite differences), the injected noise against closed forms of the
device model, and the command's handling of bad input and Ctrl-C."""
import math
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

torch = pytest.importorskip("torch")
onnx = pytest.importorskip("onnx")
import torch.nn.functional as F  # noqa: E402

import xbarsim  # noqa: E402
import xbarsim.data as xdata  # noqa: E402
import xbarsim.nn as xnn  # noqa: E402
import xbarsim.onnx as xonnx  # noqa: E402

SHARED = os.path.join(os.path.dirname(__file__), "..", "..", "..", "shared")
RESNET20 = os.path.join(SHARED, "models", "resnet20_cifar10.onnx")
G_SPAN = 6.6666666666666667e-5 * 0.8 - 3.3333333333333333e-6  # default g_max (1 - headroom) - g_min: 50 uS
# The seed paper's ranging (max|W| per crossbar, 20 % headroom), which the closed forms below
# assume; under a device model the defaults are the mse clip per column without headroom.
MAX_RANGING = {"ranging.weights": "max", "ranging.weight_scale": "crossbar", "mapping.g_headroom": 0.2}


def _conv(seed=0, cin=3, cout=4, k=3):
    torch.manual_seed(seed)
    return torch.nn.Conv2d(cin, cout, k, padding=1, bias=True).double()


def _quiet(overrides, **kw):
    """Hardware with everything off unless asked for."""
    kw.setdefault("converters", False)
    kw.setdefault("read_noise", False)
    return xnn.Hardware(overrides, **kw)


# --- gradients ---------------------------------------------------------------------------------

def test_noise_off_forward_and_backward_equal_torch():
    conv = _conv()
    analog = xnn.convert(conv, _quiet({}))
    assert isinstance(analog, xnn.AnalogConv2d)
    analog.x_max.fill_(1e9)  # no DAC clipping
    x = torch.randn(2, 3, 6, 6, dtype=torch.float64, requires_grad=True)
    x2 = x.detach().clone().requires_grad_(True)
    g = torch.randn(2, 4, 6, 6, dtype=torch.float64)
    (conv(x) * g).sum().backward()
    (analog(x2) * g).sum().backward()
    assert torch.equal(conv.weight.grad, analog.weight.grad)
    assert torch.equal(conv.bias.grad, analog.bias.grad)
    assert torch.equal(x.grad, x2.grad)
    lin = torch.nn.Linear(5, 3).double()
    a_lin = xnn.convert(lin, _quiet({}))
    a_lin.x_max.fill_(1e9)
    v = torch.randn(4, 5, dtype=torch.float64)
    assert torch.equal(lin(v), a_lin(v))


@pytest.mark.parametrize("read_noise", [False, True])
def test_straight_through_gradient_with_noise_and_converters(read_noise):
    """Device noise, 4-bit DAC and ADC (and read noise): the weight gradient is torch's conv
    gradient for the quantized input and the grad output, whatever the weight's noise; the input
    gradient is the conv's through the programmed weight, straight through the DAC's rounding and
    clipping (a hand-written quantizer, not the layer's)."""
    conv = _conv(1)
    x = torch.randn(3, 3, 6, 6, dtype=torch.float64)
    hw = xnn.Hardware({"device.model": "rram-wan2022", "mapping.negative": "differential",
                       "converters.dac_bits": 4, "converters.adc_bits": 4}, read_noise=read_noise)
    analog = xnn.convert(conv, hw, calibration=x[:2].clamp(min=0))  # unsigned inputs: negatives clip
    hw.new_batch()
    xin = x.clone().requires_grad_(True)
    g = torch.randn(3, 4, 6, 6, dtype=torch.float64)
    (analog(xin) * g).sum().backward()
    x_max = float(analog.x_max)
    step = x_max / 15
    xq = torch.round(x.clamp(0, x_max) / step) * step  # eval's unsigned 4-bit code grid
    w_noisy = analog.weight.detach() + analog._delta
    ref_w = torch.nn.grad.conv2d_weight(xq, conv.weight.shape, g, padding=1)
    ref_x = torch.nn.grad.conv2d_input(x.shape, w_noisy, g, padding=1)
    assert torch.allclose(analog.weight.grad, ref_w, rtol=1e-10, atol=1e-12)
    if not read_noise:  # with it, the weight the input's gradient goes through holds one read's draw
        assert torch.allclose(xin.grad, ref_x, rtol=1e-10, atol=1e-12)
    assert torch.allclose(analog.bias.grad, g.sum(dim=(0, 2, 3)))


def test_finite_differences_where_the_forward_is_smooth():
    """Programming noise fixed for the step, no converters, no read noise: the forward is smooth
    in the weight and in inputs inside the DAC's range; central differences match autograd."""
    torch.manual_seed(3)
    lin = torch.nn.Linear(6, 3).double()
    hw = _quiet({"device.model": "constant", "device.program_sigma_us": 2.0, "mapping.negative": "differential",
                 "mitigation.method": "none"})
    x = torch.rand(5, 6, dtype=torch.float64) * 0.8 + 0.1
    analog = xnn.convert(lin, hw, calibration=torch.ones(1, 6, dtype=torch.float64))
    hw.new_batch()
    r = torch.randn(5, 3, dtype=torch.float64)
    xin = x.clone().requires_grad_(True)
    (analog(xin) * r).sum().backward()
    eps = 1e-6
    for i, j in [(0, 0), (1, 4), (2, 5)]:
        with torch.no_grad():
            analog.weight[i, j] += eps
            up = float((analog(x) * r).sum())
            analog.weight[i, j] -= 2 * eps
            down = float((analog(x) * r).sum())
            analog.weight[i, j] += eps
        assert (up - down) / (2 * eps) == pytest.approx(float(analog.weight.grad[i, j]), rel=1e-6)
    for n, k in [(0, 1), (4, 5)]:
        with torch.no_grad():
            xp, xm = x.clone(), x.clone()
            xp[n, k] += eps
            xm[n, k] -= eps
            fd = (float((analog(xp) * r).sum()) - float((analog(xm) * r).sum())) / (2 * eps)
        assert fd == pytest.approx(float(xin.grad[n, k]), rel=1e-6)


# --- the injected noise against the device model's closed forms ----------------------------------

def _clipped_normal(a):
    """Mean and mean square of max(z, -a), z ~ N(0, 1): a cell a sigmas above g_min whose
    programming error is clipped at g_min (the constant model clips to [g_min, g_max])."""
    phi = math.exp(-a * a / 2) / math.sqrt(2 * math.pi)
    cdf = 0.5 * (1 + math.erf(a / math.sqrt(2)))
    return phi - a * (1 - cdf), cdf - a * phi + a * a * (1 - cdf)


def test_programming_noise_in_weight_units():
    """Constant model, differential pairs, no calibration: weight w is a cell at g_min + s max(w, 0)
    and one at g_min + s max(-w, 0), s = g_span / max|W| (one crossbar), each with an independent
    N(0, sigma) error clipped at g_min; the weight's error is their difference over s. Mean and
    mean square over every weight from the clipped normal's closed form."""
    torch.manual_seed(4)
    lin = torch.nn.Linear(100, 60, bias=False).double()
    sigma = 1e-6
    hw = _quiet({"device.model": "constant", "device.program_sigma_us": 1.0, "mapping.negative": "differential",
                 "mitigation.method": "none", **MAX_RANGING})
    analog = xnn.convert(lin, hw)
    w = lin.weight.detach().numpy().ravel()
    s = G_SPAN / np.abs(w).max()
    mean, square = np.zeros_like(w), np.zeros_like(w)
    for k, v in enumerate(w):
        m1, q1 = _clipped_normal(s * max(v, 0) / sigma)
        m2, q2 = _clipped_normal(s * max(-v, 0) / sigma)
        mean[k] = (m1 - m2) * sigma / s
        square[k] = (q1 + q2 - 2 * m1 * m2) * (sigma / s) ** 2
    errors = []
    for _ in range(20):
        hw.new_batch()
        analog._draw()
        errors.append(analog._delta.numpy().ravel())
    e = np.array(errors)
    assert np.mean(e) == pytest.approx(mean.mean(), abs=4 * math.sqrt(square.mean() / e.size))
    assert np.mean(e * e) == pytest.approx(square.mean(), rel=0.03)
    assert (e[1] != e[0]).mean() > 0.5  # a new batch draws afresh (both cells clipped: no error either time)


def test_read_noise_of_the_outputs():
    """Constant read noise sigma_r per cell, differential: output j of input x fluctuates by
    sqrt(sum_i x_i^2 * 2 sigma_r^2) / s per read, fresh on every forward."""
    torch.manual_seed(5)
    lin = torch.nn.Linear(40, 8, bias=False).double()
    hw = _quiet({"device.model": "constant", "device.read_sigma_us": 1.5, "mapping.negative": "differential",
                 "mitigation.method": "none", **MAX_RANGING}, read_noise=True)
    x = torch.rand(1, 40, dtype=torch.float64)
    analog = xnn.convert(lin, hw)
    analog.x_max.fill_(1.0)
    with torch.no_grad():
        ys = torch.cat([analog(x) for _ in range(4000)])
    s = G_SPAN / float(lin.weight.abs().max())
    expected = math.sqrt(float((x ** 2).sum()) * 2 * (1.5e-6) ** 2) / s
    assert ys.std(dim=0).numpy() == pytest.approx(np.full(8, expected), rel=0.06)
    assert ys.mean(dim=0).numpy() == pytest.approx(lin(x).detach().numpy().ravel(), abs=4 * expected / math.sqrt(4000) * 1.5)


def test_drift_with_global_compensation_restores_the_scale():
    """PCM a year after programming: without compensation the weights shrink by the drift
    (G(t) = G (t/t0)^-nu, a median of ~0.4 at nu ~ 0.06-0.1); with global compensation their
    least-squares scale is 1 again (the gain is the readout's)."""
    torch.manual_seed(6)
    lin = torch.nn.Linear(120, 30, bias=False).double()
    common = {"device.model": "pcm-joshi2020", "mapping.negative": "differential", "mitigation.method": "none",
              "device.time_s": 3.156e7}
    w = lin.weight.detach().numpy()
    scales = {}
    for comp in ("none", "global"):
        hw = _quiet({**common, "device.compensation": comp})
        analog = xnn.convert(lin, hw)
        hw.new_batch()
        analog._draw()
        held = w + analog._delta.numpy()
        scales[comp] = float((held * w).sum() / (w * w).sum())
    assert scales["none"] < 0.7
    assert scales["global"] == pytest.approx(1.0, abs=0.08)


def test_calibration_gains_are_the_least_squares_fit_of_the_crossbar():
    """One crossbar, programming error, mitigation.method calibration: on the calibration vectors
    X the calibrated outputs X (W + delta) + offset satisfy the normal equations of a per-column
    least-squares fit of gain and offset to the ideal X W: the residual has zero mean and is
    orthogonal to the uncalibrated outputs."""
    torch.manual_seed(8)
    lin = torch.nn.Linear(30, 6, bias=False).double()
    hw = _quiet({"device.model": "constant", "device.program_sigma_us": 2.0, "mapping.negative": "differential",
                 "mitigation.method": "calibration", "calibration.samples": 80, **MAX_RANGING})
    calib = torch.rand(200, 30, dtype=torch.float64)
    analog = xnn.convert(lin, hw, calibration=calib)
    hw.new_batch()
    analog._draw()
    x = analog._calib_rows
    assert x.shape == (80, 30)
    w = lin.weight.detach().numpy().T
    held = w + analog._delta.numpy().T
    ideal, calibrated = x @ w, x @ held + analog._offset.numpy()
    residual = calibrated - ideal
    assert np.abs(residual.mean(axis=0)).max() < 1e-10 * np.abs(ideal).max()
    # the calibrated outputs are gain x the raw ones + offset: orthogonal to the calibrated ones too
    raw = calibrated - calibrated.mean(axis=0)
    assert np.abs((residual * raw).sum(axis=0)).max() < 1e-9 * (ideal ** 2).sum()
    assert np.abs(residual).max() > 0  # the device's error is not all calibrated away


def test_calibration_rows_gathered_as_unfolded():
    """calibrate() gathers only the picked input vectors: the same rows as unfolding every
    position, for strides, paddings and 1x1 kernels."""
    for args in (dict(kernel_size=3, padding=1, stride=1), dict(kernel_size=3, padding=1, stride=2),
                 dict(kernel_size=1, padding=0, stride=2), dict(kernel_size=(3, 1), padding=(1, 0), stride=1)):
        torch.manual_seed(9)
        conv = xnn.AnalogConv2d.from_module(torch.nn.Conv2d(5, 7, **args), xnn.Hardware(), 0)
        x = torch.randn(4, 5, 9, 8)
        rows = conv._rows(x)
        assert conv._row_count(x) == rows.shape[0]
        idx = torch.randperm(rows.shape[0])[:60]
        assert torch.equal(conv._rows_at(x, idx), rows[idx]), args


def test_parallel_draw_equals_each_layer_drawing_alone():
    """xbarsim.nn.draw draws a step's layers on every thread: the same state as each layer
    drawing in its own forward, one thread."""
    model = torch.nn.Sequential(torch.nn.Conv2d(3, 8, 3, padding=1), torch.nn.ReLU(), torch.nn.Flatten(),
                                torch.nn.Linear(8 * 6 * 6, 10))
    calib = torch.rand(20, 3, 6, 6)
    states = []
    for threads in (1, 2):
        hw = xnn.Hardware({"device.model": "rram-wan2022", "mapping.negative": "differential"})
        net = xnn.convert(model, hw, calibration=calib)
        was = torch.get_num_threads()
        torch.set_num_threads(threads)
        try:
            for _ in range(3):
                hw.new_batch()
                xnn.draw(net)
        finally:
            torch.set_num_threads(was)
        states.append([m._delta.clone() for m in xnn.analog_layers(net)])
    hw = xnn.Hardware({"device.model": "rram-wan2022", "mapping.negative": "differential"})
    net = xnn.convert(model, hw, calibration=calib)
    for _ in range(3):
        hw.new_batch()
        with torch.no_grad():
            net(calib)
    states.append([m._delta.clone() for m in xnn.analog_layers(net)])
    for other in states[1:]:
        assert all(torch.equal(a, b) for a, b in zip(states[0], other))


def test_adc_outputs_on_the_calibrated_grid():
    """One crossbar, a 3-bit ADC: every output (less the bias) is one of the 8 levels of its
    column's range, the calibration outputs' span widened by adc_margin on each side."""
    torch.manual_seed(7)
    lin = torch.nn.Linear(10, 4).double()
    hw = xnn.Hardware({"converters.adc_bits": 3, "converters.dac_bits": "none", "mitigation.method": "none"},
                      read_noise=False)
    calib = torch.rand(50, 10, dtype=torch.float64)
    analog = xnn.convert(lin, hw, calibration=calib)
    with torch.no_grad():
        ideal = calib @ lin.weight.t()
        lo, hi = ideal.min(dim=0).values, ideal.max(dim=0).values
        lo, hi = lo - 0.05 * (hi - lo), hi + 0.05 * (hi - lo)
        y = analog(torch.rand(30, 10, dtype=torch.float64)) - lin.bias
    codes = (y - lo) / ((hi - lo) / 7)
    assert torch.allclose(codes, codes.round(), atol=1e-9)
    assert codes.min() >= -1e-9 and codes.max() <= 7 + 1e-9


def test_to_software_keeps_the_trained_weights():
    conv = _conv(8)
    analog = xnn.convert(conv, _quiet({}))
    with torch.no_grad():
        analog.weight.add_(0.5)
    plain = xnn.to_software(analog)
    assert type(plain) is torch.nn.Conv2d
    assert torch.equal(plain.weight, analog.weight)


def test_bad_hardware_values():
    with pytest.raises(ValueError, match="weight_noise"):
        xnn.Hardware({}, weight_noise=-0.1)
    with pytest.raises(ValueError, match="time_s"):
        xnn.Hardware({}, time_s=(10, 1))
    with pytest.raises(ValueError, match="device.model"):
        xnn.Hardware({"device.model": "unobtainium"})
    with pytest.raises(ValueError, match="calibration"):
        xnn.convert(torch.nn.Linear(3, 2), xnn.Hardware({}))


# --- data ----------------------------------------------------------------------------------------

def _cifar_file(path, n, seed=0):
    rng = np.random.default_rng(seed)
    labels = rng.integers(0, 10, n).astype(np.uint8)
    pixels = rng.integers(0, 256, (n, 3 * 32 * 32)).astype(np.uint8)
    np.concatenate([labels[:, None], pixels], axis=1).tofile(path)
    return labels, pixels.reshape(n, 3, 32, 32)


def test_cifar10_reader_preprocessing_and_augmentation(tmp_path):
    labels, pixels = _cifar_file(tmp_path / "data_batch_1.bin", 6)
    plain = xdata.Cifar10(tmp_path, train=True, preprocessing=(1 / 255, [0.5, 0.4, 0.3], [0.2, 0.25, 0.3]),
                          augment=False)
    x, y = next(plain.batches(6, shuffle=False))
    assert y.tolist() == labels.tolist()
    expect = (pixels[2, 1, 3, 4] / 255 - 0.4) / 0.25
    assert float(x[2, 1, 3, 4]) == pytest.approx(expect, rel=1e-6)
    aug = xdata.Cifar10(tmp_path, train=True, seed=3)
    a1 = [b[0] for b in aug.batches(6, epoch=1)]
    a2 = [b[0] for b in aug.batches(6, epoch=1)]
    a3 = [b[0] for b in aug.batches(6, epoch=2)]
    assert torch.equal(a1[0], a2[0]) and not torch.equal(a1[0], a3[0])
    # every augmented image is a crop (offsets 0..8 of the 4-padded image), maybe flipped, of one image
    xa, ya = next(aug.batches(6, epoch=1))
    for k in range(6):
        src = pixels[np.flatnonzero(labels == int(ya[k]))] / 255.0
        padded = np.zeros((len(src), 3, 40, 40))
        padded[:, :, 4:36, 4:36] = src
        found = any(np.allclose(c, xa[k].numpy(), atol=1e-6) for im in padded for dy in range(9) for dx in range(9)
                    for c in (im[:, dy:dy + 32, dx:dx + 32], im[:, dy:dy + 32, dx:dx + 32][:, :, ::-1]))
        assert found


def test_cifar10_bad_files(tmp_path):
    with pytest.raises(ValueError, match="no such directory"):
        xdata.Cifar10(tmp_path / "nowhere")
    with pytest.raises(ValueError, match="data_batch"):
        xdata.Cifar10(tmp_path)
    (tmp_path / "data_batch_1.bin").write_bytes(b"\x00" * 100)
    with pytest.raises(ValueError, match="whole number"):
        xdata.Cifar10(tmp_path)
    with pytest.raises(ValueError, match="missing.bin.*No such file"):
        xdata.Cifar10(files=[tmp_path / "missing.bin"])
    (tmp_path / "data_batch_1.bin").write_bytes(b"\x0a" + b"\x00" * 3072)
    with pytest.raises(ValueError, match="data_batch_1.bin.*label > 9"):
        xdata.Cifar10(tmp_path)


# --- ONNX ----------------------------------------------------------------------------------------

class _Tiny(torch.nn.Module):
    def __init__(self):
        super().__init__()
        self.conv = torch.nn.Conv2d(3, 4, 3, padding=1)
        self.fc = torch.nn.Linear(4, 10)

    def forward(self, x):
        return self.fc(F.adaptive_avg_pool2d(F.relu(self.conv(x)), 1).flatten(1))


def _tiny_onnx(path):
    torch.manual_seed(9)
    model = _Tiny().eval()
    xonnx.export(model, path, metadata={"dataset": "cifar10", "input_scale": "1/255",
                                        "input_mean": "0.5", "input_std": "0.25"},
                 sample=torch.randn(1, 3, 32, 32))
    return model


def test_export_and_load_round_trip(tmp_path):
    model = _tiny_onnx(tmp_path / "tiny.onnx")
    loaded = xonnx.load(tmp_path / "tiny.onnx")
    assert loaded.preprocessing == (pytest.approx(1 / 255), [0.5], [0.25])
    x = torch.randn(4, 3, 32, 32)
    with torch.no_grad():
        assert torch.allclose(loaded(x), model(x), rtol=1e-5, atol=1e-6)
        for layer in loaded.layers:
            layer.weight.mul_(1.5)
        want = loaded(x)
    xonnx.export(loaded, tmp_path / "tuned.onnx")
    again = xonnx.load(tmp_path / "tuned.onnx")
    with torch.no_grad():
        got = again(x)
    assert torch.allclose(got, want, rtol=1e-4, atol=1e-6)
    assert [f for f in os.listdir(tmp_path) if f.startswith(".xbarsim_export_")] == []


@pytest.mark.skipif(not os.path.exists(RESNET20), reason="the shared ResNet-20 is absent (../shared/models)")
def test_shared_resnet20_logits_match_the_reference():
    model = xonnx.load(RESNET20)
    ref = np.loadtxt(RESNET20.replace(".onnx", ".ref.csv"), delimiter=",", skiprows=1)[:20]
    test = xdata.Cifar10(os.path.join(SHARED, "data", "cifar10"), train=False, preprocessing=model.preprocessing,
                         limit=20)
    x, y = next(test.batches(20))
    assert y.tolist() == ref[:, 1].astype(int).tolist()
    with torch.no_grad():
        logits = model(x).numpy()
    assert np.abs(logits - ref[:, 2:]).max() < 1e-3 * np.abs(ref[:, 2:]).max()


def test_load_refuses_what_it_cannot_read(tmp_path):
    (tmp_path / "junk.onnx").write_text("not a model")
    with pytest.raises(ValueError, match="junk.onnx"):
        xonnx.load(tmp_path / "junk.onnx")
    with pytest.raises(ValueError, match="no such file"):
        xonnx.load(tmp_path / "missing.onnx")


# --- python3 -m xbarsim.hwa ----------------------------------------------------------------------

def _hwa(*args, timeout=120):
    env = dict(os.environ)
    return subprocess.run([sys.executable, "-m", "xbarsim.hwa", *map(str, args)], capture_output=True, text=True,
                          env=env, timeout=timeout)


@pytest.fixture
def tiny_setup(tmp_path):
    _tiny_onnx(tmp_path / "tiny.onnx")
    data = tmp_path / "data"
    data.mkdir()
    _cifar_file(data / "data_batch_1.bin", 64)
    return tmp_path, data


def test_hwa_command_fine_tunes_and_writes(tiny_setup):
    tmp, data = tiny_setup
    r = _hwa("--model", tmp / "tiny.onnx", "--train", data, "--epochs", 2, "--batch-size", 16,
             "--set", "device.model=rram-wan2022", "--set", "mapping.negative=differential", "--out", tmp / "out.onnx")
    assert r.returncode == 0, r.stderr
    assert "epoch 2/2" in r.stderr and "left" in r.stderr and "train acc" in r.stderr
    before, after = xonnx.load(tmp / "tiny.onnx"), xonnx.load(tmp / "out.onnx")
    assert after.metadata["input_mean"] == "0.5" and "xbarsim_hwa" in after.metadata
    assert not torch.equal(before.layers[0].weight, after.layers[0].weight)


def test_hwa_help_documents_every_option():
    r = _hwa("--help")
    assert r.returncode == 0
    for option in ("--model", "--train", "--epochs", "--out", "--config", "--set", "--weight-noise", "--time",
                   "--batch-size", "--lr", "--images", "--seed", "--software"):
        assert option in r.stdout


@pytest.mark.parametrize("case", ["missing data", "unknown key", "bad model", "bad value", "sweep", "out is model",
                                  "out dir missing"])
def test_hwa_refuses_bad_input(tiny_setup, case):
    tmp, data = tiny_setup
    args = {"model": tmp / "tiny.onnx", "train": data, "set": "device.model=rram-wan2022"}
    if case == "missing data":
        args["train"] = tmp / "nowhere"
    elif case == "unknown key":
        args["set"] = "device.modle=rram-wan2022"
    elif case == "bad model":
        (tmp / "junk.onnx").write_text("junk")
        args["model"] = tmp / "junk.onnx"
    elif case == "bad value":
        args["set"] = "device.program_sigma_us=-1"
    elif case == "sweep":
        args["set"] = "device.time_s=[1,10]"
    out = tmp / "out.onnx"
    if case == "out is model":
        out = args["model"]
    elif case == "out dir missing":
        out = tmp / "nowhere" / "out.onnx"
    before = (tmp / "tiny.onnx").read_bytes()
    r = _hwa("--model", args["model"], "--train", args["train"], "--epochs", 1, "--set", args["set"], "--out", out)
    assert r.returncode == 2
    lines = [l for l in r.stderr.splitlines() if l.strip()]
    assert len(lines) == 1 and lines[0].startswith("xbarsim.hwa: error: "), r.stderr
    assert "Traceback" not in r.stderr
    assert not (tmp / "out.onnx").exists()
    assert (tmp / "tiny.onnx").read_bytes() == before  # the input model is never changed


def test_hwa_ctrl_c_leaves_no_output(tiny_setup):
    tmp, data = tiny_setup
    proc = subprocess.Popen([sys.executable, "-m", "xbarsim.hwa", "--model", str(tmp / "tiny.onnx"), "--train",
                             str(data), "--epochs", "1000", "--batch-size", "8", "--set",
                             "device.model=rram-wan2022", "--out", str(tmp / "out.onnx")],
                            stderr=subprocess.PIPE, text=True)
    for line in proc.stderr:  # wait until it trains
        if "epoch 1/1000" in line:
            break
    proc.send_signal(signal.SIGINT)
    try:
        rest = proc.communicate(timeout=30)[1]
    except subprocess.TimeoutExpired:
        proc.kill()
        raise
    assert proc.returncode == 130, rest
    assert "not written" in rest
    # no output and no partial file: at most the last whole epoch's checkpoint
    left = sorted(os.listdir(tmp))
    assert left in (["data", "tiny.onnx"], ["data", "out.onnx.ckpt", "tiny.onnx"]), left
    if "out.onnx.ckpt" in left:
        assert "--resume goes on from it" in rest
        assert torch.load(tmp / "out.onnx.ckpt")["epoch"] >= 1


def test_clip_weights_to_sigmas_of_the_layer():
    import xbarsim.hwa as hwa
    torch.manual_seed(10)
    model = torch.nn.Sequential(torch.nn.Conv2d(3, 8, 3), torch.nn.Flatten(), torch.nn.Linear(8, 2))
    with torch.no_grad():
        model[0].weight[0, 0, 0, 0] = 5.0  # an outlier
    before = [model[0].weight.detach().numpy().copy(), model[2].weight.detach().numpy().copy()]
    hwa.clip_weights(model, 2.0)
    for w0, w in zip(before, (model[0].weight, model[2].weight)):
        bound = 2.0 * w0.std(ddof=1)
        assert np.allclose(w.detach().numpy(), np.clip(w0, -bound, bound), rtol=1e-6)
    hwa.clip_weights(model, 0)  # 0: no clipping


# --- recipes, schedules, checkpoints (issue 51) ---------------------------------------------------

def test_learning_rate_warms_up_then_follows_its_schedule():
    import xbarsim.hwa as hwa
    # 10 steps of warm-up of 110: (k + 1) / 10, then a cosine over the other 100 (by hand)
    assert hwa._lr_factor(0, 110, 10, "cosine") == pytest.approx(0.1)
    assert hwa._lr_factor(9, 110, 10, "cosine") == pytest.approx(1.0)
    assert hwa._lr_factor(10, 110, 10, "cosine") == pytest.approx(1.0)
    assert hwa._lr_factor(60, 110, 10, "cosine") == pytest.approx(0.5)
    assert hwa._lr_factor(85, 110, 10, "cosine") == pytest.approx(0.5 * (1 + math.cos(math.pi * 0.75)))
    assert [hwa._lr_factor(k, 110, 10, "step") for k in (59, 60, 84, 85)] == [1.0, 0.1, 0.1, 0.01]
    with pytest.raises(ValueError, match="cosine or step"):
        hwa._lr_factor(0, 10, 0, "linear")


def test_a_recipe_is_overridden_option_by_option():
    import xbarsim.hwa as hwa
    args = hwa._parser().parse_args(["--model", "m", "--train", "d", "--out", "o", "--recipe", "neurram",
                                     "--lr", "1e-3"])
    s = hwa._settings(args)
    assert s["lr"] == 1e-3  # the user's
    assert s["epochs"] == hwa.RECIPES["neurram"]["epochs"] and s["weight_noise"] == 0.05  # the recipe's
    assert hwa._settings(hwa._parser().parse_args(["--model", "m", "--train", "d", "--out", "o"]))["epochs"] == 1


def test_a_resumed_run_ends_where_the_whole_run_ends(tiny_setup):
    import xbarsim.hwa as hwa
    tmp, data = tiny_setup

    def run(checkpoint, resume=None, stop_at=None):
        model = xonnx.load(tmp / "tiny.onnx")
        train = xdata.Cifar10(data, train=True, preprocessing=model.preprocessing, seed=3)
        hw = xnn.Hardware({"device.model": "rram-wan2022"}, seed=3, weight_noise=0.02)
        net = xnn.convert(model, hw, calibration=train.preprocess(train.images[:16]))

        def progress(line):
            if stop_at and line.startswith(stop_at):
                raise KeyboardInterrupt
        hwa.fine_tune(net, hw, train, epochs=3, batch_size=16, lr=1e-3, warmup=1, calibration=None,
                      checkpoint=checkpoint, resume=resume, signature="s", progress=progress, seed=3)
        return [p.detach().clone() for p in net.parameters()]

    whole = run(tmp / "whole.ckpt")
    with pytest.raises(KeyboardInterrupt):
        run(tmp / "part.ckpt", stop_at="epoch 3/3")
    assert torch.load(tmp / "part.ckpt")["epoch"] == 2 and not (tmp / "part.ckpt.tmp").exists()
    resumed = run(tmp / "part.ckpt", resume=tmp / "part.ckpt")
    assert all(torch.equal(a, b) for a, b in zip(whole, resumed))
    with pytest.raises(ValueError, match="another model"):
        model = xonnx.load(tmp / "tiny.onnx")
        train = xdata.Cifar10(data, train=True, preprocessing=model.preprocessing)
        hwa.fine_tune(model, None, train, epochs=3, resume=tmp / "part.ckpt", signature="other")


def test_distillation_from_itself_leaves_the_model_as_it_was(tiny_setup):
    """distill = 1 with the model's own copy as the teacher: KL(p || p) = 0 and its gradient is 0,
    so SGD takes no step (no clipping; Adam would blow up the rounding's gradient to a full step);
    with distill = 0.5 the cross-entropy moves it."""
    import xbarsim.hwa as hwa
    tmp, data = tiny_setup
    for distill, moves in ((1.0, False), (0.5, True)):
        model = xonnx.load(tmp / "tiny.onnx")
        train = xdata.Cifar10(data, train=True, preprocessing=model.preprocessing, seed=1)
        teacher = xonnx.load(tmp / "tiny.onnx")
        before = [p.detach().clone() for p in model.parameters()]
        hwa.fine_tune(model, None, train, epochs=1, batch_size=16, lr=1e-2, optimizer="sgd", clip_sigma=0,
                      teacher=teacher, distill=distill, temperature=3.0)
        same = all(torch.allclose(a, b, atol=1e-6) for a, b in zip(before, model.parameters()))
        assert same != moves, distill
    with pytest.raises(ValueError, match="teacher"):
        hwa.fine_tune(model, None, train, epochs=1, distill=0.5)


@pytest.mark.parametrize("case", ["epochs 0", "lr 0", "lr nan", "warmup too long", "checkpoint is out",
                                  "resume without checkpoint", "resume other config", "distill 2", "temperature 0"])
def test_hwa_refuses_bad_training_settings(tiny_setup, case):
    tmp, data = tiny_setup
    out = tmp / "out.onnx"
    extra = {"epochs 0": ["--epochs", 0], "lr 0": ["--lr", 0], "lr nan": ["--lr", "nan"],
             "warmup too long": ["--epochs", 1, "--warmup", 2], "checkpoint is out": ["--checkpoint", out],
             "resume without checkpoint": ["--resume"], "resume other config": ["--resume"],
             "distill 2": ["--distill", 2], "temperature 0": ["--distill", 0.5, "--temperature", 0]}[case]
    if case == "resume other config":
        torch.save({"signature": "not this run"}, f"{out}.ckpt")
    r = _hwa("--model", tmp / "tiny.onnx", "--train", data, "--out", out, *extra)
    assert r.returncode == 2, r.stderr
    lines = [l for l in r.stderr.splitlines() if l.strip()]
    assert len(lines) == 1 and lines[0].startswith("xbarsim.hwa: error: "), r.stderr
    assert not out.exists()


def test_hwa_refuses_an_unknown_recipe(tiny_setup):
    tmp, data = tiny_setup
    r = _hwa("--model", tmp / "tiny.onnx", "--train", data, "--out", tmp / "out.onnx", "--recipe", "magic")
    assert r.returncode == 2 and "invalid choice: 'magic'" in r.stderr
    assert not (tmp / "out.onnx").exists()


def test_hwa_keeps_the_best_validation_epoch_and_removes_its_checkpoint(tiny_setup):
    tmp, data = tiny_setup
    r = _hwa("--model", tmp / "tiny.onnx", "--train", data, "--epochs", 2, "--batch-size", 16,
             "--validation-images", 16, "--set", "device.model=rram-wan2022", "--out", tmp / "out.onnx")
    assert r.returncode == 0, r.stderr
    assert "48 images" in r.stderr and "16 held out for validation" in r.stderr
    assert "differential mapping" in r.stderr  # mapping.negative auto, as resolved under the device
    assert r.stderr.count("validation ") >= 2 and "images/s" in r.stderr
    assert "kept" in xonnx.load(tmp / "out.onnx").metadata["xbarsim_hwa"]
    assert sorted(os.listdir(tmp)) == ["data", "out.onnx", "tiny.onnx"]


def test_image_bits_quantize_the_layer_that_reads_the_input():
    """converters.image_bits: the layer that reads the model's input codes it at 5 bits (signed: a
    sign and 4 magnitude bits, 15 steps of x_max), the next at input_bits 3 (after a ReLU: 7 steps)."""
    torch.manual_seed(3)
    model = torch.nn.Sequential(torch.nn.Conv2d(3, 4, 3, padding=1), torch.nn.ReLU(),
                                torch.nn.Conv2d(4, 2, 3, padding=1)).double()
    hw = xnn.Hardware({"converters.input_bits": 3, "converters.dac_bits": 3, "converters.image_bits": 5,
                       "converters.adc_bits": "none"}, read_noise=False)
    x = torch.randn(4, 3, 6, 6, dtype=torch.float64)
    analog = xnn.convert(model, hw, calibration=x)
    first, second = xnn.analog_layers(analog)
    assert bool(first.reads_image) and not bool(second.reads_image)
    assert bool(first.signed_inputs) and not bool(second.signed_inputs)
    for layer, v, steps in ((first, x, 15), (second, torch.relu(model[0](x)), 7)):
        x_max = float(layer.x_max)
        codes = layer._dac(v) / (x_max / steps)
        assert torch.allclose(codes, codes.round(), atol=1e-9)
        assert codes.abs().max() <= steps + 1e-9
        assert len(torch.unique(codes.round())) > steps  # the grid is this fine, not coarser


def test_a_state_from_before_image_bits_loads():
    """A state dict without the reads_image buffer (written before converters.image_bits) loads,
    the layer keeping its own."""
    analog = xnn.convert(_conv(), _quiet({}))
    state = {k: v for k, v in analog.state_dict().items() if not k.endswith("reads_image")}
    analog.load_state_dict(state)
    assert not bool(analog.reads_image)
