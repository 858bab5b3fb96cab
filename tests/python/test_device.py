"""xbarsim.Device and the device model through Crossbar (issue 40, item 6). Expectations come
from the published formulas and closed forms written out here, never from the binding: the
constant model's sigma, binomial bounds of stuck cells, and the PCM model of Nandakumar et al.
(ICECS 2019) / Joshi et al. (Nat. Commun. 2020) with aihwkit's PCMLikeNoiseModel coefficients."""
import math

import numpy as np
import pytest

import xbarsim

G_MIN, G_MAX = 1 / 300e3, 1 / 15e3  # crossbar.g_min, g_max defaults (S)


def sampling_bound(n, p, sigmas=5.0):
    """The largest deviation of a count of n Bernoulli(p) draws from n p at `sigmas` standard deviations."""
    return sigmas * math.sqrt(n * p * (1 - p))


def test_ideal_is_the_identity():
    d = xbarsim.Device()
    assert (d.model, d.kind) == ("ideal", "ideal")
    assert (d.g_min, d.g_max) == (G_MIN, G_MAX)
    g = np.random.default_rng(0).uniform(G_MIN, G_MAX, size=(17, 9))
    np.testing.assert_array_equal(d.program(g), g)
    gp, faults = d.program(g, return_faults=True)
    np.testing.assert_array_equal(gp, g)
    assert faults.dtype == np.int8 and faults.shape == g.shape and not faults.any()
    np.testing.assert_array_equal(d.at_time(g, g, 1e7), g)
    np.testing.assert_array_equal(d.read(g), g)
    np.testing.assert_array_equal(d.read_sigma(g), np.zeros_like(g))
    assert not d.moves and not d.has_read_noise
    # 1-D arrays are one column and come back 1-D.
    assert d.program(g[:, 0]).shape == (17,)


def test_constant_programming_and_read_sigma_match_within_sampling_error():
    sigma = 0.5e-6
    d = xbarsim.Device({"device.model": "constant", "device.program_sigma_us": 0.5, "device.read_sigma_us": 0.25})
    n = 200_000
    g = np.full((400, n // 400), 30e-6)  # 30 uS: 50 sigma inside [g_min, g_max], nothing clipped
    err = d.program(g) - g
    # The sample standard deviation of n normal draws has a relative sd of 1/sqrt(2 (n - 1)).
    assert abs(err.std() / sigma - 1) < 5 / math.sqrt(2 * (n - 1))
    assert abs(err.mean()) < 5 * sigma / math.sqrt(n)
    np.testing.assert_array_equal(d.read_sigma(g), np.full(g.shape, 0.25e-6))
    r1, r2 = d.read(g), d.read(g)
    assert not np.array_equal(r1, r2)  # a fresh read per call
    for r in (r1, r2):
        assert abs((r - g).std() / 0.25e-6 - 1) < 5 / math.sqrt(2 * (n - 1))
    # The two reads are independent: their difference has sqrt(2) the sigma.
    assert abs((r1 - r2).std() / (math.sqrt(2) * 0.25e-6) - 1) < 5 / math.sqrt(2 * (n - 1))
    # States beyond the range are clipped to it (the constant model writes within [g_min, g_max]).
    wide = xbarsim.Device({"device.model": "constant", "device.program_sigma_us": 30.0})
    gw = wide.program(np.full((100, 100), G_MAX))
    assert gw.max() == G_MAX and gw.min() >= G_MIN


def test_stuck_fractions_within_binomial_bounds_and_stuck_cells_never_move():
    p_lo, p_hi = 0.03, 0.01
    d = xbarsim.Device({"device.model": "pcm-joshi2020", "device.stuck_at_gmin": p_lo, "device.stuck_at_gmax": p_hi})
    rows, cols = 250, 400
    n = rows * cols
    target = np.full((rows, cols), 12e-6)
    gp, faults = d.program(target, return_faults=True)
    lo, hi = faults == -1, faults == 1
    assert abs(lo.sum() - n * p_lo) < sampling_bound(n, p_lo)
    assert abs(hi.sum() - n * p_hi) < sampling_bound(n, p_hi)
    assert set(np.unique(faults)) <= {-1, 0, 1}
    assert np.all(gp[lo] == d.g_min) and np.all(gp[hi] == d.g_max)
    assert (d.g_min, d.g_max) == pytest.approx((0.1e-6, 25e-6), rel=1e-12)  # the model's range, not the crossbar's
    # faults() places the same cells; another crossbar others.
    np.testing.assert_array_equal(d.faults(rows, cols), faults)
    assert not np.array_equal(d.faults(rows, cols, crossbar=1), faults)
    # A year later the free cells have drifted, the stuck ones are where they were.
    later = d.at_time(target, gp, 3.15e7)
    np.testing.assert_array_equal(later[faults != 0], gp[faults != 0])
    assert np.median(later[faults == 0] / gp[faults == 0]) < 0.6


# The PCM model's figures as published (aihwkit PCMLikeNoiseModel; x = G_target / g_max):
# nu ~ |N(mu(x), sd(x))|, mu = clip(-0.0155 ln x + 0.0244, 0.049, 0.1), sd = clip(-0.0125 ln x - 0.0059,
# 0.008, 0.045), G(t) = G_prog ((t + t0) / t0)^-nu with t0 = 20 s; accumulated 1/f noise
# sigma = G(t) min(0.0088 / x^0.65, 0.2) sqrt(ln((t + t0 + t_read) / (2 t_read))), t_read = 250 ns.
PCM_G_MAX, T0, T_READ = 25e-6, 20.0, 250e-9


def pcm_nu(x):
    return (np.clip(-0.0155 * np.log(x) + 0.0244, 0.049, 0.1), np.clip(-0.0125 * np.log(x) - 0.0059, 0.008, 0.045))


def pcm_median_ratio(x, t, n=1_000_000, seed=5):
    """The median of G(t) / G_prog by a Monte Carlo of the published model (numpy's own draws)."""
    rng = np.random.default_rng(seed)
    mu, sd = pcm_nu(x)
    nu = np.abs(rng.normal(mu, sd, n))
    q = min(0.0088 / x ** 0.65, 0.2)
    band = math.log((t + T0 + T_READ) / (2 * T_READ))
    drift = ((t + T0) / T0) ** -nu
    return float(np.median(drift * (1 + q * math.sqrt(band) * rng.normal(size=n))))


@pytest.mark.parametrize("x", [0.1, 0.5, 1.0])
@pytest.mark.parametrize("t", [86400.0, 3.15e7])
def test_pcm_drift_median_follows_the_published_formula(x, t):
    d = xbarsim.Device({"device.model": "pcm-joshi2020"})
    target = np.full((500, 400), x * PCM_G_MAX)  # 2 x 10^5 cells
    ratio = d.at_time(target, target, t) / target  # programmed exactly: drift and 1/f noise only
    got = float(np.median(ratio))
    mu, _ = pcm_nu(x)
    # Roughly the power law at the mean exponent (the spread of nu and the 1/f noise move the median
    # by under 1 % here) ...
    assert got == pytest.approx(((t + T0) / T0) ** -mu, rel=0.02)
    # ... and within sampling error of the published model's median: the median of n draws has a
    # sd of about 1.25 sd(ratio) / sqrt(n), and the reference's 10^6 draws add a fifth of the variance.
    se = 1.2533 * ratio.std() / math.sqrt(ratio.size)
    assert abs(got - pcm_median_ratio(x, t)) < 5 * se * math.sqrt(1.2)


def test_pcm_programming_sigma_and_read_sigma_follow_the_published_polynomials():
    d = xbarsim.Device({"device.model": "pcm-joshi2020"})
    x = 0.6
    target = np.full((400, 500), x * PCM_G_MAX)
    sigma = (0.26348 + 1.9650 * x - 1.1731 * x * x) * 1e-6  # Nandakumar 2019, uS
    err = d.program(target) - target
    assert abs(err.std() / sigma - 1) < 5 / math.sqrt(2 * target.size)
    # One read: sigma = 0.0175 sqrt(G g_max) (aihwkit's PCM read noise).
    np.testing.assert_allclose(d.read_sigma(target[:1]), 0.0175 * np.sqrt(target[:1] * PCM_G_MAX), rtol=1e-12)


def test_the_same_seed_draws_the_same_arrays():
    cfg = {"device.model": "pcm-joshi2020", "device.stuck_at_gmin": 0.02}
    target = np.random.default_rng(3).uniform(1e-6, 24e-6, size=(64, 32))
    runs = []
    for _ in range(2):
        d = xbarsim.Device(xbarsim.Config(overrides=cfg))
        gp, f = d.program(target, return_faults=True)
        runs.append((gp, f, d.at_time(target, gp, 3600.0), d.read(gp), d.read(gp)))
    for a, b in zip(*runs):
        np.testing.assert_array_equal(a, b)
    a = runs[0]
    assert not np.array_equal(a[3], a[4])  # successive reads differ
    d = xbarsim.Device(cfg)
    np.testing.assert_array_equal(d.read(a[0], read=1), a[4])  # read= names a read of the counter
    other = xbarsim.Device(dict(cfg, **{"device.seed": 12}))
    assert not np.array_equal(other.program(target), a[0])
    assert not np.array_equal(d.program(target, crossbar=1), a[0])
    assert not np.array_equal(d.program(target, layer=1), a[0])


def test_bad_device_input_raises_naming_the_key():
    with pytest.raises(ValueError, match="device.model.*'bogus'"):
        xbarsim.Device({"device.model": "bogus"})
    with pytest.raises(ValueError, match="device.model.*'bogus'"):
        xbarsim.Crossbar(np.ones((4, 2)), {"device.model": "bogus"})
    with pytest.raises(ValueError, match="device.program_sigma_us"):
        xbarsim.Device({"device.model": "pcm-joshi2020", "device.program_sigma_us": 1.0})
    with pytest.raises(ValueError, match="device.stuck_at_gmin"):
        xbarsim.Device({"device.stuck_at_gmin": 0.7, "device.stuck_at_gmax": 0.7})
    with pytest.raises(ValueError, match="device.time_s"):
        xbarsim.Device({"device.time_s": -1.0})
    d = xbarsim.Device({"device.model": "pcm-joshi2020"})
    g = np.full((2, 2), 1e-6)
    with pytest.raises(ValueError, match="t must be a time"):
        d.at_time(g, g, float("nan"))
    with pytest.raises(ValueError, match="negative"):
        d.program(-g)
    with pytest.raises(ValueError, match="shape"):
        d.at_time(g, g[:1])
    with pytest.raises(ValueError, match="faults holds"):
        d.at_time(g, g, 1.0, faults=np.full((2, 2), 3, dtype=np.int8))


READ_NOISE = {"device.model": "constant", "device.read_sigma_us": 2.0, "converters.adc_bits": "none",
              "converters.dac_bits": "none"}


def test_crossbar_reads_afresh_on_every_call_and_reproducibly():
    rng = np.random.default_rng(0)
    w = rng.uniform(-1, 1, size=(24, 6))
    x = rng.uniform(0, 1, size=(5, 24))
    xb = xbarsim.Crossbar(w, READ_NOISE)
    first, second = xb.matvec(x), xb.matvec(x)
    assert xb.next_image == 2
    assert not np.array_equal(first, second)  # a fresh read per call
    again = xbarsim.Crossbar(w, xbarsim.Config(overrides=READ_NOISE))
    np.testing.assert_array_equal(again.matvec(x), first)  # the same seed: the same reads
    np.testing.assert_array_equal(again.matvec(x), second)
    np.testing.assert_array_equal(xb.matvec(x, image=0), first)  # image= names a call's reads
    assert xb.next_image == 2  # an explicit image leaves the counter
    xb.next_image = 1
    np.testing.assert_array_equal(xb.matvec(x), second)
    # Vector r of a call is read r % R of image + r // R: two images in one call read as in two calls.
    both = xb.matvec(np.vstack([x, x]), image=7, rows_per_image=5)
    np.testing.assert_array_equal(both[:5], xb.matvec(x, image=7))
    np.testing.assert_array_equal(both[5:], xb.matvec(x, image=8))
    with pytest.raises(ValueError, match="rows_per_image"):
        xb.matvec(x, rows_per_image=2)
    # Without read noise every call reads alike.
    quiet = xbarsim.Crossbar(w, {"converters.adc_bits": "none"})
    np.testing.assert_array_equal(quiet.matvec(x), quiet.matvec(x))


def test_every_vector_of_a_long_call_reads_afresh():
    # matvec runs long calls in blocks; each block's reads must continue the image's numbering, not
    # restart it (the 4097th vector read like the first before blocks followed images).
    rng = np.random.default_rng(1)
    xb = xbarsim.Crossbar(rng.uniform(-1, 1, size=(8, 3)), READ_NOISE)
    y = xb.matvec(np.tile(rng.uniform(0, 1, size=(1, 8)), (4097, 1)))
    spread = y.std(axis=0).max()  # the read noise on the outputs
    assert spread > 0
    # Every vector away from the first by far more than rounding (a block of one vector sums in
    # another order than one of 4096).
    assert np.abs(y[1:] - y[0]).max(axis=1).min() > 1e-3 * spread


def test_crossbar_under_a_drifting_model_and_set_time():
    rng = np.random.default_rng(2)
    w = rng.uniform(-1, 1, size=(32, 8))
    x = rng.uniform(0, 1, size=(4, 32))
    pcm = {"device.model": "pcm-joshi2020", "converters.adc_bits": "none"}
    xb = xbarsim.Crossbar(w, pcm)
    assert xb.time_s == 0
    g0 = xb.conductances(0)
    assert g0.max() < 30e-6  # the model's range (25 uS and its programming error), not the crossbar's 66.7 uS
    y0 = xb.matvec(x, image=0)
    year = 3.15e7
    xb.set_time(year)
    assert xb.time_s == year and xb.config.get("device.time_s") == year
    g1 = xb.conductances(0)
    # Every cell drifts down: the median ratio near the power law of the cells' exponents (0.049 to 0.1).
    r = float(np.median(g1 / g0))
    assert ((year + T0) / T0) ** -0.1 < r < ((year + T0) / T0) ** -0.049
    # Equal to a crossbar programmed with device.time_s set (the same cells and draws).
    fresh = xbarsim.Crossbar(w, dict(pcm, **{"device.time_s": year}))
    np.testing.assert_array_equal(fresh.conductances(0), g1)
    np.testing.assert_array_equal(fresh.matvec(x, image=0), xb.matvec(x, image=0))
    assert not np.allclose(xb.matvec(x, image=0), y0)
    xb.set_time(0.0)
    np.testing.assert_array_equal(xb.conductances(0), g0)
    with pytest.raises(ValueError, match="device.time_s"):
        xb.set_time(-1.0)
    with pytest.raises(ValueError, match="device.compensation"):
        xb.set_time(1.0, "sometimes")
    assert xb.time_s == 0  # a refused time leaves the crossbar as it was


def test_crossbar_reports_its_stuck_cells():
    p = 0.05
    xb = xbarsim.Crossbar(np.random.default_rng(4).uniform(-1, 1, size=(100, 40)), {"device.stuck_at_gmax": p})
    cells = sum(r["rows"] * r["physical_cols"] for r in xb.reports())
    stuck = sum(r["stuck_cells"] for r in xb.reports())
    assert abs(stuck - cells * p) < sampling_bound(cells, p)
    g = xb.conductances(0)
    assert np.count_nonzero(g == G_MAX) >= xb.reports()[0]["stuck_cells"]


def test_device_read_draws_a_nonlinear_crossbars_reads():
    # A nonlinear crossbar solves every read with its own fluctuating conductances; Device.read with
    # the crossbar's salt, image and read gives those conductances. Without converters or mitigation
    # each output is affine in its column current with one slope for every column and vector, so the
    # outputs of four images follow the currents xbarsim.solve computes from Device.read's arrays.
    # Differential pairs (mapping.negative: auto under a device): an output is affine in its pair's
    # current difference (physical columns 2j and 2j + 1).
    cfg = {"crossbar.memristor.model": "sinh", "device.model": "constant", "device.read_sigma_us": 3.0,
           "ranging.weight_scale": "crossbar",  # one slope for every column
           "converters.adc_bits": "none", "converters.dac_bits": "none", "mitigation.method": "none"}
    rng = np.random.default_rng(0)
    x = rng.uniform(0, 1, size=(2, 16))
    xb = xbarsim.Crossbar(rng.uniform(-1, 1, size=(16, 4)), cfg, salt=3)
    g = xb.conductances(0)
    config, d = xbarsim.Config(overrides=cfg), xbarsim.Device(cfg)
    volts = x * config.get("crossbar.v_in_max")  # no DAC, x_max = 1
    y = np.array([xb.matvec(x, image=i) for i in range(4)])
    i = np.array([[xbarsim.solve(d.read(g, image=k, read=r, layer=3), volts[r:r + 1], config)[0] for r in range(2)]
                  for k in range(4)])
    i = i[..., 0::2] - i[..., 1::2]
    dy, di = y - y.mean(axis=0), i - i.mean(axis=0)  # each output's and current's change over the reads
    slope = (dy * di).sum() / (di * di).sum()
    assert np.ptp(y, axis=0).min() > 0  # the reads did differ
    assert np.abs(dy - slope * di).max() < 1e-9 * np.abs(dy).max()
