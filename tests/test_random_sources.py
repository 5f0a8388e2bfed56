"""TRNOISE and TRRANDOM sources: statistics against closed forms, reproducibility, both engines, ngspice.

The realisations come from fixed seeds, so every check here is deterministic;
the bounds are those a correct generator passes with probability 1 - 1e-6
(chi-square and normal quantiles, Kolmogorov-Smirnov p-values), so a wrong
variance, distribution, spectrum or dwell time fails them.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from scipy import stats

import netdae
from netdae.comparison.run import compare
from netdae.dae.compiled.sources import pack_sources, source_values
from netdae.errors import NetdaeError, NetlistError
from netdae.mna import assemble
from netdae.mna.sources import MODE_TRAN
from netdae.netlist.waveforms import MAX_RANDOM_POINTS, Pwl, Trnoise, Trrandom, flicker_noise

#: Two-sided probability of a false failure each statistical bound allows.
P_FALSE = 1e-6
#: The matching normal quantile.
Z = stats.norm.isf(P_FALSE / 2)


def _load(body: str, seed: int | None = 3):
    options = f".options seed={seed}\n" if seed is not None else ""
    return netdae.load(f"random sources\n{body}\n{options}.end\n")


def _realisation(body: str, name: str, tstep: float, tstop: float, seed: int = 3) -> Pwl:
    return _load(body, seed).element(name).source.tran.resolved(tstep, tstop)


def _chi2_bounds(n: int) -> tuple[float, float]:
    """Bounds of the sample variance over the true variance for n normal samples."""
    return stats.chi2.ppf(P_FALSE / 2, n - 1) / (n - 1), stats.chi2.isf(P_FALSE / 2, n - 1) / (n - 1)


# -- white noise ------------------------------------------------------------------------------------------
def test_white_noise_samples_have_the_rms_na_and_zero_mean():
    na, nt, tstop = 2e-3, 1e-6, 0.05
    pwl = _realisation(f"V1 a 0 trnoise({na} {nt})\nR1 a 0 1", "v1", nt, tstop)
    n = int(math.floor(tstop / nt)) + 2
    assert pwl.times.size == n
    assert np.allclose(pwl.times, np.arange(n) * nt, rtol=0, atol=1e-9 * nt)
    assert pwl.values[0] == 0.0  # the first sample is deterministic, as in ngspice
    x = pwl.values[1:]
    lo, hi = _chi2_bounds(x.size)
    assert lo < np.var(x, ddof=1) / na**2 < hi
    assert abs(np.mean(x)) < Z * na / math.sqrt(x.size)
    assert stats.kstest(x / na, "norm").pvalue > P_FALSE
    # successive samples are independent: lag-1 correlation within its normal bound
    r1 = np.corrcoef(x[:-1], x[1:])[0, 1]
    assert abs(r1) < Z / math.sqrt(x.size)


def test_noise_is_linear_between_samples_and_the_samples_are_breakpoints():
    nt, tstop = 1e-6, 2e-4
    pwl = _realisation(f"V1 a 0 trnoise(1 {nt})\nR1 a 0 1", "v1", nt, tstop)
    grid = np.arange(int(tstop / nt) + 2) * nt
    samples = pwl.value(grid)
    for frac in (0.25, 0.5, 0.9):
        inner = pwl.value(grid[:-1] + frac * nt)
        expected = samples[:-1] + frac * (samples[1:] - samples[:-1])
        assert np.max(np.abs(inner - expected)) <= 1e-12 * np.max(np.abs(samples))
    slopes = pwl.derivative(grid[:-1] + 0.5 * nt)
    assert np.allclose(slopes, np.diff(samples) / nt, rtol=1e-9)
    bps = pwl.breakpoints(0.0, tstop)
    assert np.all(np.min(np.abs(bps[:, None] - grid[grid <= tstop][None, :]), axis=0) <= 1e-12 * tstop)


def test_dc_value_is_added_and_the_operating_point_sees_it():
    c = _load("V1 a 0 dc 0.5 trnoise(1m 1u)\nI2 b 0 dc 2 trrandom(2 10u 5u 1 0.25)\nR1 a 0 1\nR2 b 0 1")
    v1, i2 = c.element("v1").source, c.element("i2").source
    # .op: the DC value (ngspice's rule for a source with a DC value)
    assert v1.dc_value() == 0.5 and i2.dc_value() == 2.0
    # the transient's start: the function at t = 0 plus the DC value (TRRANDOM holds PARAM2 until TD)
    assert v1.tran_value_at_zero() == 0.5 and i2.tran_value_at_zero() == 2.25
    assert i2.tran.value(4e-6) == 2.25
    with pytest.raises(ValueError, match="random, drawn for a transient"):
        v1.tran.value(1e-6)
    pwl = v1.tran.resolved(1e-6, 1e-2)
    assert pwl.value(0.0) == 0.5
    assert abs(np.mean(pwl.values[1:]) - 0.5) < Z * 1e-3 / math.sqrt(pwl.values.size - 1)
    op = netdae.run(netdae.load("t\nV1 a 0 dc 0.5 trnoise(1m 1u)\nR1 a 0 1\n.op\n.end\n"))[0]
    assert op.signals["v(a)"][0] == pytest.approx(0.5, abs=1e-12)
    # without a DC value, .op takes the function at t = 0: 0 for TRNOISE, PARAM2 for TRRANDOM
    c = _load("V1 a 0 trnoise(1m 1u)\nV2 b 0 trrandom(1 1u 0 1 0.3)\nR1 a 0 1\nR2 b 0 1")
    assert c.element("v1").source.dc_value() == 0.0 and c.element("v2").source.dc_value() == pytest.approx(0.3)


# -- 1/f noise --------------------------------------------------------------------------------------------
@pytest.mark.parametrize("alpha", [0.5, 1.0, 1.5])
def test_flicker_noise_spectrum_has_the_slope_minus_alpha(alpha):
    rng = np.random.default_rng(11)
    n, runs = 1 << 14, 8
    window = np.hanning(n)
    power = np.zeros(n // 2 + 1)
    for _ in range(runs):
        x = flicker_noise(rng, n, alpha, 1.0)
        power += np.abs(np.fft.rfft((x - x.mean()) * window)) ** 2
    f = np.fft.rfftfreq(n)
    band = (f > 2e-3) & (f < 0.1)
    # Kasdin's spectrum is 1/|2 sin(pi f)|^alpha: the slope against log(2 sin(pi f)) is -alpha
    slope = np.polyfit(np.log(2 * np.sin(np.pi * f[band])), np.log(power[band]), 1)[0]
    assert slope == pytest.approx(-alpha, abs=0.1)


def test_flicker_noise_level_is_namp_squared_over_the_filter():
    """Well inside the band the spectral level is NAMP^2 / |2 sin(pi f)|^alpha (per sample)."""
    rng = np.random.default_rng(5)
    n, runs, alpha, amp = 1 << 13, 32, 1.0, 3e-3
    window = np.hanning(n)
    power = np.zeros(n // 2 + 1)
    for _ in range(runs):
        x = flicker_noise(rng, n, alpha, amp)
        power += np.abs(np.fft.rfft((x - x.mean()) * window)) ** 2 / np.sum(window**2)
    f = np.fft.rfftfreq(n)
    band = (f > 0.01) & (f < 0.2)
    ratio = power[band] / runs * np.abs(2 * np.sin(np.pi * f[band])) ** alpha / amp**2
    assert np.mean(ratio) == pytest.approx(1.0, rel=0.05)


def test_trnoise_adds_flicker_noise_from_its_first_sample():
    pwl = _realisation("V1 a 0 trnoise(0 1u 1 1m)\nR1 a 0 1", "v1", 1e-6, 1e-3)
    assert pwl.values[0] == 0.0 and np.std(pwl.values) > 0
    # NAMP is read only with a non-zero NALPHA (ngspice): no noise at all here
    pwl = _realisation("V1 a 0 trnoise(0 1u 0 1m)\nR1 a 0 1", "v1", 1e-6, 1e-3)
    assert np.all(pwl.values == 0.0)


# -- random telegraph noise -------------------------------------------------------------------------------
def test_telegraph_dwell_times_are_exponential_with_the_given_means():
    capt, emt, amp, tstop = 1e-6, 3e-6, 5e-3, 0.02
    pwl = _realisation(f"V1 a 0 trnoise(0 0 0 0 {amp} {capt} {emt})\nR1 a 0 1", "v1", 1e-6, tstop)
    t, v = pwl.times, pwl.values
    jumps = np.flatnonzero(np.diff(t) == 0)  # a jump: its time twice
    assert np.all(v[jumps] != v[jumps + 1])
    s = t[jumps]
    assert s[-1] > tstop and s[-2] <= tstop
    assert set(np.unique(v)) == {0.0, amp}
    assert v[0] == 0.0 and v[jumps[0] + 1] == amp  # starts low, first switch is a capture
    dwell = np.diff(np.concatenate([[0.0], s]))
    low, high = dwell[0::2], dwell[1::2]
    for d, mean in ((low, capt), (high, emt)):
        assert abs(np.mean(d) / mean - 1) < Z / math.sqrt(d.size)
        assert stats.kstest(d / mean, "expon").pvalue > P_FALSE
    # breakpoints: every switching instant
    assert np.all(np.isin(s[s <= tstop], pwl.breakpoints(0.0, tstop)))


def test_telegraph_adds_to_the_white_noise_without_moving_its_samples():
    body = "V1 a 0 trnoise(1m 1u 0 0 2m 5u 5u)\nR1 a 0 1"
    pwl = _realisation(body, "v1", 1e-6, 2e-4)
    white = _realisation("V1 a 0 trnoise(1m 1u)\nR1 a 0 1", "v1", 1e-6, 2e-4)
    jumps = np.flatnonzero(np.diff(pwl.times) == 0)
    assert jumps.size > 10
    assert np.allclose(np.abs(pwl.values[jumps + 1] - pwl.values[jumps]), 2e-3, rtol=0, atol=1e-15)
    # the white part is drawn first from the stream: at the samples the sum is white + 0 or RTSAM
    grid = white.times[white.times <= 2e-4]
    level = pwl.value(grid) - white.value(grid)
    assert np.all(np.isclose(level, 0.0, atol=1e-15) | np.isclose(level, 2e-3, rtol=0, atol=1e-15))
    assert np.any(level > 1e-3) and np.any(level < 1e-3)
    # between a switch and the samples around it, the white part stays linear
    s = pwl.times[jumps]
    s = s[s < 2e-4]
    assert np.allclose(pwl.value(s), white.value(s) + np.where(np.arange(s.size) % 2 == 0, 0.0, 2e-3), atol=1e-15)


# -- TRRANDOM ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize("kind, p1, p2, dist", [
    (1, 0.5, 1.0, stats.uniform(loc=0.5, scale=1.0)),
    (2, 2.0, -1.0, stats.norm(loc=-1.0, scale=2.0)),
    (3, 3.0, 0.5, stats.expon(loc=0.5, scale=3.0)),
])
def test_trrandom_continuous_distributions(kind, p1, p2, dist):
    ts, td, tstop = 1e-6, 2e-6, 5e-3
    pwl = _realisation(f"V1 a 0 trrandom({kind} {ts} {td} {p1} {p2})\nR1 a 0 1", "v1", ts, tstop)
    draws = pwl.value(td + (np.arange(int((tstop - td) / ts)) + 0.5) * ts)
    assert stats.kstest(draws, dist.cdf).pvalue > P_FALSE


def test_trrandom_poisson_counts():
    lam, ts, tstop = 2.5, 1e-6, 5e-3
    pwl = _realisation(f"V1 a 0 trrandom(4 {ts} 0 {lam} 10)\nR1 a 0 1", "v1", ts, tstop)
    draws = pwl.value((np.arange(int(tstop / ts)) + 0.5) * ts) - 10
    assert np.all(draws == np.round(draws)) and draws.min() >= 0
    k = np.arange(8)
    observed = np.array([np.sum(draws == j) for j in k[:-1]] + [np.sum(draws >= k[-1])])
    expected = np.append(stats.poisson.pmf(k[:-1], lam), stats.poisson.sf(k[-1] - 1, lam)) * draws.size
    assert stats.chisquare(observed, expected).pvalue > P_FALSE


def test_trrandom_holds_each_value_for_ts_after_td():
    ts, td = 1e-6, 3.5e-6
    pwl = _realisation(f"V1 a 0 trrandom(2 {ts} {td} 1 0.5)\nR1 a 0 1", "v1", ts, 2e-5)
    assert pwl.value(0.0) == 0.5 and pwl.value(td) == 0.5  # PARAM2 up to TD; a jump's value is its left one
    starts = td + np.arange(16) * ts
    for a, b in zip(starts[:-1], starts[1:]):
        inside = pwl.value(np.linspace(a, b, 7)[1:])
        assert np.all(inside == inside[0])
    assert np.all(np.isin(starts[starts <= 2e-5], pwl.breakpoints(0.0, 2e-5)))


# -- seeds and memory -------------------------------------------------------------------------------------
def test_realisations_are_reproducible_and_keyed_by_seed_and_name():
    body = "V1 a 0 trnoise(1m 1u 1 1m 1m 3u 3u)\nV2 b 0 trnoise(1m 1u 1 1m 1m 3u 3u)\nR1 a 0 1\nR2 b 0 1"
    a = _realisation(body, "v1", 1e-6, 1e-4, seed=3)
    b = _realisation(body, "v1", 1e-6, 1e-4, seed=3)
    assert np.array_equal(a.times, b.times) and np.array_equal(a.values, b.values)
    assert not np.array_equal(a.values, _realisation(body, "v1", 1e-6, 1e-4, seed=4).values)
    assert not np.array_equal(a.values[:50], _realisation(body, "v2", 1e-6, 1e-4, seed=3).values[:50])
    # another source or a Monte Carlo draw does not change V1's noise
    more = body + "\nV3 c 0 trrandom(1 1u)\nR3 c 0 {agauss(1, 0.1, 1)}"
    c = _realisation(more, "v1", 1e-6, 1e-4, seed=3)
    assert np.array_equal(a.values, c.values)
    # a Monte Carlo sample draws its own noise
    circuit = _load(body, 3)
    other = circuit.variant(sample=1).element("v1").source.tran.resolved(1e-6, 1e-4)
    assert not np.array_equal(a.values, other.values)


def test_too_many_samples_are_refused_where_the_source_is_written():
    # at load, for the netlist's own .tran cards (so netdae check says it too)
    with pytest.raises(NetlistError, match=r"<string>:3:13: v1: TRNOISE NT=1e-12 s up to TSTOP=0.001 s needs "
                                           r"1,000,000,002 points.*hint: NT = 1e-12 s is 1e\+09 times smaller"):
        netdae.load("t\nR1 a 0 1\nV1 a 0 dc 0 trnoise(1m 1p)\n.tran 1n 1m\n.end\n")
    with pytest.raises(NetlistError, match=r"<string>:2:8: v1: TRRANDOM TS=1e-15 s up to TSTOP=1 s"):
        netdae.load("t\nV1 a 0 trrandom(1 1f)\nR1 a 0 1\n.tran 1n 1\n.end\n")
    with pytest.raises(NetlistError, match=r"<string>:2:8: i1: TRNOISE RTSCAPT=1e-12 s, RTSEMT=1e-12 s"):
        netdae.load("t\nI1 a 0 trnoise 0 0 0 0 1 1p 1p\nR1 a 0 1\n.tran 1n 1\n.end\n")
    # and for a transient run with another card
    circuit = netdae.load("t\nR1 a 0 1\nV1 a 0 dc 0 trnoise(1m 1p)\n.tran 1n 1n\n.end\n")
    card = dataclasses.replace(circuit.analyses[0], tstop=1e-3)
    with pytest.raises(NetlistError, match=r"<string>:3:13: v1: TRNOISE NT=1e-12 s up to TSTOP=0.001 s"):
        netdae.simulate(circuit, card=card)
    with pytest.raises(NetlistError, match=f"more than the {MAX_RANDOM_POINTS:,}"):
        Trrandom(1, 1e-12).resolved(1e-9, 1.0)
    with pytest.raises(NetlistError, match="RTSCAPT=1e-12 s, RTSEMT=1e-12 s"):
        Trnoise(0, 0, 0, 0, 1.0, 1e-12, 1e-12).resolved(1e-9, 1.0)


# -- both engines, transients ------------------------------------------------------------------------------
def test_compiled_sources_equal_the_reference_on_noise_sources():
    circuit = _load("V1 a 0 dc 0.1 trnoise(1m 1u 1 1m 2m 4u 9u)\nI2 b 0 trrandom(2 3u 1u 1 0)\n"
                    "V3 c 0 trrandom(4 2u 0 3)\nR1 a 0 1\nR2 b 0 1\nR3 c 0 1\n.tran 1u 1e-4")
    system = assemble(circuit, mode=MODE_TRAN, tstep=1e-6, tstop=1e-4)
    src = system.sources
    packed = pack_sources(src)
    rng = np.random.default_rng(1)
    times = np.concatenate([rng.uniform(0, 1.2e-4, 500), src.breakpoints(0, 1e-4), [0.0, 1e-4]])
    out = np.empty(src.m)
    for t in times:
        source_values(*packed, float(t), out)
        ref = src.values(float(t))
        assert np.max(np.abs(out - ref) / np.maximum(np.abs(ref), 1.0)) <= 8 * np.finfo(float).eps, t


def _rc_variance_factor(a: float) -> tuple[float, np.ndarray]:
    """Var(y)/NA^2 at the sample instants of an RC low-pass (tau = NT/a) driven by linearly interpolated white
    samples, and the output's correlation by lag.

    y(nT) = sum_m c_m x_(n-m) with c_0 = 1 - (1 - e^-a)/a and c_m = K e^(-m a), K = (e^a + e^-a - 2)/a
    (the hat functions of the interpolation integrated against the impulse response e^(-t/tau)/tau).
    """
    c0 = 1.0 - (1.0 - math.exp(-a)) / a
    k = (math.exp(a) + math.exp(-a) - 2.0) / a
    m = np.arange(1, 200)
    c = np.concatenate([[c0], k * np.exp(-m * a)])
    var = c0**2 + k**2 * math.exp(-2 * a) / (1 - math.exp(-2 * a))
    rho = np.array([np.dot(c[: c.size - j], c[j:]) for j in range(60)]) / np.dot(c, c)
    return var, rho


RC_NOISE = """RC low-pass driven by white transient noise
V1 in 0 dc 0 trnoise({na} {nt})
R1 in out 1k
C1 out 0 1n
.tran {nt} {tstop}
"""


def _variance_bound(var: float, rho: np.ndarray, n: int) -> float:
    """Z standard deviations of the sample variance of n correlated gaussian samples, relative."""
    return Z * math.sqrt(2.0 / n * (1.0 + 2.0 * np.sum(rho[1:] ** 2)))


def test_rc_output_variance_matches_the_closed_form():
    na, nt, tstop = 1e-3, 1e-6, 0.02  # tau = 1 us = NT
    text = RC_NOISE.format(na=na, nt=nt, tstop=tstop) + ".options seed=7\n.end\n"
    result = netdae.simulate(netdae.load(text))
    grid = np.arange(1, int(tstop / nt) + 1) * nt
    # the integrator lands on every sample instant (they are breakpoints)
    near = np.abs(result.t[np.searchsorted(result.t, grid).clip(max=result.t.size - 1)] - grid)
    assert np.max(near) <= 1e-9 * tstop
    y = result.dense(grid)["v(out)"][20:]  # the filter forgets the start after 20 tau
    var, rho = _rc_variance_factor(1.0)
    assert abs(np.var(y) / (var * na**2) - 1) < _variance_bound(var, rho, y.size)
    # the input is the source's realisation: v(in) at the samples is the drawn sequence
    pwl = netdae.load(text).element("v1").source.tran.resolved(nt, tstop)
    assert np.allclose(result.dense(grid)["v(in)"], pwl.value(grid), rtol=0, atol=1e-12)


def test_random_steps_in_a_transient_are_jumps_the_engines_take():
    text = ("TRRANDOM into an RC\nV1 in 0 trrandom(1 10u 0 1 0.5)\nR1 in out 1k\nC1 out 0 1n\n.tran 1u 100u\n"
            ".options seed=2\n.end\n")
    circuit = netdae.load(text)
    result = netdae.simulate(circuit)
    assert result.ok
    pwl = circuit.element("v1").source.tran.resolved(1e-6, 1e-4)
    assert result.signals["v(in)"][0] == 0.5  # PARAM2 at t = 0, the first draw just after
    t = np.array([5e-6, 15e-6, 55e-6, 95e-6])
    assert np.allclose(result.dense(t)["v(in)"], pwl.value(t), rtol=0, atol=1e-9)
    # the RC output relaxes towards each held value: after 10 tau it is within 1e-3 of it
    end_of_hold = np.arange(1, 10) * 1e-5
    assert np.allclose(result.dense(end_of_hold)["v(out)"], pwl.value(end_of_hold), rtol=0, atol=1e-3)


def test_compare_refuses_the_transient_of_a_random_source():
    text = RC_NOISE.format(na=1e-3, nt=1e-6, tstop=1e-4) + ".end\n"
    with pytest.raises(NetdaeError, match=r"v1 draw\(s\) random values \(TRNOISE, TRRANDOM\): ngspice draws "
                                          "another sequence"):
        compare(text)


# -- ngspice --------------------------------------------------------------------------------------------
@pytest.mark.ngspice
def test_ngspice_reads_the_sources_and_its_variance_agrees_with_the_closed_form():
    """ngspice 39 draws other values at every run (it is not seeded by the netlist): its statistics are tested."""
    from netdae.ngspice import run_ngspice

    na, nt, tstop = 1e-3, 1e-6, 0.01
    text = (RC_NOISE.format(na=na, nt=nt, tstop=tstop)
            + "V2 r 0 trrandom(2 1u 0 0.5 0)\nR2 r 0 1\n.end\n")
    run = run_ngspice(text, backend="subprocess")
    ng = run.result("tran")
    grid = np.arange(20, int(tstop / nt) + 1) * nt
    var, rho = _rc_variance_factor(1.0)
    y = np.interp(grid, ng.t, ng.signals["v(out)"])
    assert abs(np.var(y) / (var * na**2) - 1) < _variance_bound(var, rho, y.size)
    x = np.interp(grid, ng.t, ng.signals["v(in)"])
    lo, hi = _chi2_bounds(x.size)
    assert lo < np.var(x, ddof=1) / na**2 < hi
    held = np.interp(grid[:-1] + 0.5 * nt, ng.t, ng.signals["v(r)"])
    lo, hi = _chi2_bounds(held.size)
    assert lo < np.var(held, ddof=1) / 0.5**2 < hi


def test_a_noise_current_source_reports_its_realisation_as_its_current():
    text = "t\nI1 0 a dc 1m trnoise(1m 1u)\nR1 a 0 1k\n.tran 1u 20u\n.save v(a) @i1[current]\n.end\n"
    result = netdae.simulate(netdae.load(text))
    current = result.signals["@i1[current]"]
    assert np.std(current) > 1e-4
    assert np.allclose(result.signals["v(a)"], 1e3 * current, rtol=0, atol=1e-9)


def test_a_long_realisation_alone_in_its_bank_takes_the_scalar_kernel_exactly():
    from netdae.netlist.waveforms import SourceBank

    pwl = _realisation("V1 a 0 trnoise(1m 1u 0 0 1m 5u 5u)\nR1 a 0 1", "v1", 1e-6, 1e-2)
    assert pwl.times.size > 4096
    bank = SourceBank([pwl])
    assert bank._scalar  # one PWL: the scalar kernel, reading the points as arrays
    rng = np.random.default_rng(4)
    times = np.concatenate([rng.uniform(0, 1.1e-2, 300), pwl.times[::97]])
    assert np.array_equal(np.array([bank.values(float(t))[0] for t in times]), pwl.value(times))


def test_both_engines_take_the_same_steps_on_noise(monkeypatch):
    text = ("rc\nV1 in 0 dc 0 trnoise(1m 1u 1 1m 1m 5u 5u)\nR1 in out 1k\nC1 out 0 1n\nI2 0 out trrandom(2 3u 0 1u)\n"
            ".tran 1u 100u\n.end\n")
    runs = {}
    for engine in ("compiled", "python"):
        monkeypatch.setenv("NETDAE_ENGINE", engine)
        runs[engine] = netdae.simulate(netdae.load(text))
    a, b = runs["compiled"], runs["python"]
    assert a.stats.integrator.steps == b.stats.integrator.steps > 100
    t = np.linspace(0, 1e-4, 1001)
    va, vb = a.dense(t)["v(out)"], b.dense(t)["v(out)"]
    assert np.max(np.abs(va - vb)) <= 1e-6 * np.max(np.abs(va))
