"""xbarsim.torch (issue 27): a torch model's Conv2d and Linear layers on crossbars. Skipped
where Debian's python3-torch is absent."""
import warnings

import numpy as np
import pytest

torch = pytest.importorskip("torch", reason="python3-torch not installed")
import xbarsim  # noqa: E402
import xbarsim.torch as xtorch  # noqa: E402


def small_net():
    torch.manual_seed(0)
    return torch.nn.Sequential(
        torch.nn.Conv2d(3, 8, 3, padding=1), torch.nn.ReLU(),
        torch.nn.Conv2d(8, 8, 3, stride=2, padding=2, dilation=2, groups=8, bias=False), torch.nn.ReLU(),
        torch.nn.Conv2d(8, 6, (1, 3), groups=2), torch.nn.Flatten(),
        torch.nn.LazyLinear(5)).eval()


def test_an_ideal_crossbar_gives_torchs_outputs():
    # Near-ideal circuit and converters: the crossbars compute X W to ~1e-9, so the converted
    # model's outputs are torch's. This checks the layouts (im2col order, grouped blocks,
    # dilation, the Linear transposition) against torch itself.
    net = small_net()
    x = torch.rand(4, 3, 9, 10)
    with torch.no_grad():
        want = net(x)
    cfg = xbarsim.Config(overrides={"crossbar.r_wire": 1e-6, "crossbar.r_in": 1e-6, "crossbar.r_out": 1e-6,
                                    "converters.dac_bits": "none", "converters.adc_bits": "none",
                                    "mitigation.method": "none"})
    analog = xtorch.convert(net, cfg, calibration=x)
    with torch.no_grad():
        got = analog(x)
    np.testing.assert_allclose(got.numpy(), want.numpy(), rtol=0, atol=1e-5 * float(want.abs().max()))
    assert isinstance(analog[0], xtorch.AnalogConv2d) and isinstance(analog[6], xtorch.AnalogLinear)
    assert isinstance(net[0], torch.nn.Conv2d)  # the original is left as it was


def test_the_default_design_runs_and_records_per_layer_errors():
    net = small_net()
    x = torch.rand(8, 3, 9, 10)
    with torch.no_grad():
        net(x)
    analog = xtorch.convert(net, xbarsim.Config(), calibration=x)
    labels = torch.zeros(8, dtype=torch.long)
    r = xtorch.evaluate(analog, [(x, labels)], reference=net)
    assert r["images"] == 8
    assert 0 <= r["agreeing_predictions"] <= 8
    errors = r["layer_mean_relative_error"]
    assert len(errors) == 4
    assert all(0 < e < 0.5 for e in errors.values()), errors  # the parasitics show, but bounded


def test_calibration_from_a_loader_and_progress():
    # Batches of (inputs, labels), as a DataLoader gives them, calibrate as their concatenation.
    net = small_net()
    x = torch.rand(6, 3, 9, 10)
    with torch.no_grad():
        net(x)
    cfg = xbarsim.Config()
    seen = []
    one = xtorch.convert(net, cfg, calibration=x)
    loader = [(x[:3], torch.zeros(3)), (x[3:], torch.zeros(3)), (torch.full((3, 3, 9, 10), 1e3), torch.zeros(3))]
    two = xtorch.convert(net, cfg, calibration=loader, max_calibration_batches=2,
                         progress=lambda name, done, total: seen.append((name, done, total)))
    with torch.no_grad():
        np.testing.assert_array_equal(one(x).numpy(), two(x).numpy())  # the third batch was not read
    assert seen == [("0", 1, 4), ("2", 2, 4), ("4", 3, 4), ("6", 4, 4)]


def test_crossbar_matvec_errors():
    xb = xbarsim.Crossbar(np.random.default_rng(0).normal(size=(20, 4)), xbarsim.Config())
    assert (xb.inputs, xb.outputs) == (20, 4) and xb.crossbars >= 1
    with pytest.raises(ValueError, match="20 inputs"):
        xb.matvec(np.zeros((2, 3)))
    with pytest.raises(ValueError, match="x_max"):
        xbarsim.Crossbar(np.ones((2, 2)), xbarsim.Config(), x_max=0)


def test_signed_layers_must_name_layers_of_the_model():
    net = small_net()
    x = torch.rand(2, 3, 9, 10)
    with pytest.raises(ValueError, match="signed_layers names no Conv2d or Linear of the model: nope"):
        xtorch.convert(net, xbarsim.Config(), calibration=x, signed_layers=["nope"])
    # The first Conv2d sees only x >= 0 (torch.rand): unsigned from the data, signed when named.
    assert not xtorch.convert(net, xbarsim.Config(), calibration=x)[0].crossbar.signed_inputs
    analog = xtorch.convert(net, xbarsim.Config(), calibration=x, signed_layers=["0"])
    assert analog[0].crossbar.signed_inputs
    assert analog[0].crossbar.x_max == pytest.approx(float(x.max()), rel=1e-6)


IDEAL = {"crossbar.r_wire": 1e-6, "crossbar.r_in": 1e-6, "crossbar.r_out": 1e-6, "converters.dac_bits": "none",
         "converters.adc_bits": "none", "mitigation.method": "none"}


@pytest.mark.parametrize("conv", [
    dict(padding=1, padding_mode="reflect"),
    dict(padding=(2, 1), padding_mode="replicate"),
    dict(padding=(1, 2), padding_mode="circular", stride=2),
    dict(padding="same", kernel_size=(2, 4)),  # even kernels: asymmetric, the extra row/column after
    dict(padding="same", kernel_size=3, dilation=2, padding_mode="reflect"),
    dict(padding="valid", groups=3),
])
def test_padding_modes_and_same_give_torchs_outputs(conv):
    # Issue 38: reflect/replicate/circular padding became zero padding and padding='same'
    # converted but failed on forward. The padding is data movement before the crossbar, so on an
    # ideal circuit the converted layer gives torch's own Conv2d outputs.
    torch.manual_seed(1)
    args = dict(kernel_size=3)
    args.update(conv)
    net = torch.nn.Sequential(torch.nn.Conv2d(3, 6, **args)).eval()
    x = torch.rand(2, 3, 7, 8)
    with torch.no_grad():
        want = net(x)
    analog = xtorch.convert(net, xbarsim.Config(overrides=IDEAL), calibration=x)
    with torch.no_grad():
        got = analog(x)
    assert got.shape == want.shape
    np.testing.assert_allclose(got.numpy(), want.numpy(), rtol=0, atol=1e-5 * float(want.abs().max()))


# Issue 39, items 3 and 4.
def normalised_net():
    torch.manual_seed(1)
    return torch.nn.Sequential(torch.nn.Conv2d(3, 8, 3, padding=1), torch.nn.ReLU(),
                               torch.nn.Conv2d(8, 8, 3, padding=1), torch.nn.ReLU(), torch.nn.Flatten(),
                               torch.nn.Linear(8 * 8 * 8, 10)).eval()


def test_convert_refuses_without_calibration():
    # Before: programmed for inputs in [0, 1] and clipped the rest (1 of 8 argmax agreed on
    # normalised inputs).
    with pytest.raises(ValueError, match="convert needs calibration="):
        xtorch.convert(normalised_net(), xbarsim.Config())


def test_normalised_inputs_agree_with_torch_when_calibrated():
    net = normalised_net()
    torch.manual_seed(2)
    x = torch.randn(32, 3, 8, 8)  # mean 0, std 1
    analog = xtorch.convert(net, xbarsim.Config(), calibration=x[:16])
    r = xtorch.evaluate(analog, [(x[16:], torch.zeros(16, dtype=torch.long))], reference=net)
    assert r["agreeing_predictions"] >= 14, r


def test_evaluate_reports_eval_errors_and_warns_about_large_ones():
    net = normalised_net()
    torch.manual_seed(3)
    x = torch.randn(8, 3, 8, 8)
    labels = torch.zeros(8, dtype=torch.long)
    r = xtorch.evaluate(xtorch.convert(net, xbarsim.Config(), calibration=x), [(x, labels)])
    assert set(r["layer_mean_relative_error"]) == {"0", "2", "5"}
    assert all(0 < e < 0.1 for e in r["layer_mean_relative_error"].values()), r
    assert all(w >= r["layer_mean_relative_error"][n] for n, w in r["layer_worst_relative_error"].items())
    assert r["warnings"] == []
    # An ideal circuit with 1-bit ADCs: errors far above the threshold, each such layer named.
    coarse = xbarsim.Config(overrides={"converters.adc_bits": 1})
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        r = xtorch.evaluate(xtorch.convert(net, coarse, calibration=x), [(x, labels)])
    big = [n for n, e in r["layer_mean_relative_error"].items() if e > 0.1]
    assert big and len(r["warnings"]) == len(big)
    assert any(f"layer {big[0]}: mean error" in str(w.message) for w in caught)


READ_NOISE = {"device.model": "constant", "device.read_sigma_us": 2.0}


def test_converted_layers_read_afresh_per_image_and_reproducibly():
    # Issue 40: each analog layer counts the images it sees; image k reads with its own read noise
    # (eval's image k), so a batch reads as its images one by one and a rerun reads the same.
    net = small_net()
    x = torch.rand(4, 3, 9, 10)
    with torch.no_grad():
        net(x)
    analog = xtorch.convert(net, xbarsim.Config(overrides=READ_NOISE), calibration=x)
    with torch.no_grad():
        first, second = analog(x), analog(x)
        assert not torch.equal(first, second)  # images 4..7 read afresh
        xtorch.set_image(analog, 0)
        np.testing.assert_array_equal(analog(x).numpy(), first.numpy())
        xtorch.set_image(analog, 0)
        one_by_one = torch.cat([analog(x[k:k + 1]) for k in range(4)])
    np.testing.assert_array_equal(one_by_one.numpy(), first.numpy())
    again = xtorch.convert(net, xbarsim.Config(overrides=READ_NOISE), calibration=x)
    with torch.no_grad():
        np.testing.assert_array_equal(again(x).numpy(), first.numpy())
    assert analog[0].crossbar.next_image == 4 and analog[6].crossbar.next_image == 4


def test_set_time_moves_a_converted_model_as_converting_at_that_time():
    net = small_net()
    x = torch.rand(3, 3, 9, 10)
    with torch.no_grad():
        net(x)
    pcm = {"device.model": "pcm-joshi2020"}
    analog = xtorch.convert(net, xbarsim.Config(overrides=pcm), calibration=x)
    later = xtorch.convert(net, xbarsim.Config(overrides=dict(pcm, **{"device.time_s": 86400.0})), calibration=x)
    with torch.no_grad():
        y0 = analog(x)
        xtorch.set_time(analog, 86400.0)
        xtorch.set_image(analog, 0)  # images 0.. again: the read noise of `later`'s first call
        np.testing.assert_array_equal(analog(x).numpy(), later(x).numpy())
        assert not torch.equal(analog(x), y0)
    assert all(m.crossbar.time_s == 86400.0 for m in analog if isinstance(m, xtorch.AnalogConv2d))
    with pytest.raises(ValueError, match="no analog layer"):
        xtorch.set_time(net, 1.0)


def test_image_bits_program_the_layer_that_reads_the_input():
    """converters.image_bits: torch.convert programs the layer reading the model's input as a
    crossbar of input_bits = image_bits (and a DAC that wide), the next at input_bits."""
    torch.manual_seed(5)
    model = torch.nn.Sequential(torch.nn.Conv2d(3, 4, 3), torch.nn.ReLU(), torch.nn.Conv2d(4, 2, 3)).float()
    x = torch.randn(3, 3, 8, 8)
    base = {"converters.input_bits": 3, "converters.dac_bits": 3, "converters.adc_bits": "none"}
    image = xtorch.convert(model, xbarsim.Config(overrides=dict(base, **{"converters.image_bits": 5})), calibration=x)
    wide = xtorch.convert(model, xbarsim.Config(overrides=dict(base, **{"converters.input_bits": 5,
                                                                    "converters.dac_bits": 5})), calibration=x)
    narrow = xtorch.convert(model, xbarsim.Config(overrides=base), calibration=x)
    v = np.random.default_rng(1).standard_normal((20, 27))
    m = [dict(a.named_modules()) for a in (image, wide, narrow)]
    assert np.array_equal(m[0]["0"].crossbar.matvec(v, image=0), m[1]["0"].crossbar.matvec(v, image=0))
    assert not np.array_equal(m[0]["0"].crossbar.matvec(v, image=0), m[2]["0"].crossbar.matvec(v, image=0))
    u = np.abs(np.random.default_rng(2).standard_normal((20, 36)))
    assert np.array_equal(m[0]["2"].crossbar.matvec(u, image=0), m[2]["2"].crossbar.matvec(u, image=0))
