"""AC small-signal and DC sweep analyses against closed forms."""

from __future__ import annotations

import numpy as np
import pytest

from netdae.analyses.ac import ac_analysis, frequencies, solve_ac
from netdae.analyses.dc import dc_sweep
from netdae.circuit import AcAnalysis, DcAnalysis, DcSweep, Element, SourceSpec
from netdae.errors import NetdaeError

from helpers import circuit, mk


def ac_source(name, nodes, mag=1.0, phase=0.0):
    return Element(name, "vsource", tuple(nodes), source=SourceSpec(dc=0.0, ac_mag=mag, ac_phase=phase))


def test_frequency_grids_match_spice_conventions():
    f = frequencies(AcAnalysis("dec", 10, 1.0, 1e3))
    assert f.size == 31 and f[0] == 1.0 and f[-1] == pytest.approx(1e3, rel=1e-12)
    np.testing.assert_allclose(np.diff(np.log10(f)), 0.1, rtol=1e-12)
    f = frequencies(AcAnalysis("oct", 4, 100.0, 800.0))
    assert f.size == 13 and f[-1] == pytest.approx(800.0, rel=1e-12)
    with pytest.raises(NetdaeError):
        frequencies(AcAnalysis("dec", 10, 0.0, 1e3))


def test_rc_lowpass_corner_and_phase():
    R, C = 1e3, 1e-6
    fc = 1 / (2 * np.pi * R * C)
    ckt = circuit(ac_source("v1", ("in", "0")), mk("r1", "resistor", ("in", "out"), R),
                  mk("c1", "capacitor", ("out", "0"), C))
    res = ac_analysis(ckt, AcAnalysis("lin", 5, fc / 2, fc * 1.5))
    f = res.axis
    h = res["v(out)"]
    expected = 1 / (1 + 1j * f / fc)
    np.testing.assert_allclose(h, expected, rtol=1e-12)
    k = np.argmin(abs(f - fc))
    assert abs(h[k]) == pytest.approx(1 / np.sqrt(2), rel=1e-12)
    assert np.angle(h[k], deg=True) == pytest.approx(-45.0, rel=1e-12)
    # the source current phasor: i(v1) = -(V - Vout)/R
    np.testing.assert_allclose(res["i(v1)"], -(1 - h) / R, rtol=1e-10)


def test_series_rlc_bandpass_peak_and_bandwidth():
    R, L, C = 50.0, 1e-3, 1e-9
    f0 = 1 / (2 * np.pi * np.sqrt(L * C))
    bw = R / (2 * np.pi * L)
    ckt = circuit(ac_source("v1", ("in", "0")), mk("l1", "inductor", ("in", "a"), L),
                  mk("c1", "capacitor", ("a", "out"), C), mk("r1", "resistor", ("out", "0"), R))
    res = ac_analysis(ckt, AcAnalysis("lin", 2001, f0 - 2 * bw, f0 + 2 * bw))
    mag = abs(res["v(out)"])
    f = res.axis
    assert f[np.argmax(mag)] == pytest.approx(f0, abs=(f[1] - f[0]))
    assert mag.max() == pytest.approx(1.0, rel=1e-6)
    above = f[mag >= 1 / np.sqrt(2)]
    assert above[-1] - above[0] == pytest.approx(bw, abs=2 * (f[1] - f[0]))


def test_ideal_opamp_active_lowpass():
    Rin, Rf, Cf = 1e3, 10e3, 10e-9
    ckt = circuit(ac_source("v1", ("in", "0"), 2.0, 30.0), mk("r1", "resistor", ("in", "m"), Rin),
                  mk("r2", "resistor", ("m", "out"), Rf), mk("c2", "capacitor", ("m", "out"), Cf),
                  mk("e1", "opamp", ("out", "0", "0", "m")))
    res = ac_analysis(ckt, AcAnalysis("dec", 5, 10.0, 1e6))
    w = 2 * np.pi * res.axis
    u = 2.0 * np.exp(1j * np.deg2rad(30.0))
    np.testing.assert_allclose(res["v(out)"], -(Rf / Rin) / (1 + 1j * w * Rf * Cf) * u, rtol=1e-10)


def test_sparse_path_with_reused_ordering_matches_dense():
    rng = np.random.default_rng(3)
    n = 120
    import scipy.sparse as sp

    E = sp.diags(rng.uniform(1e-9, 1e-6, n)).tocsc()
    H = (sp.diags(-rng.uniform(1.0, 2.0, n)) + sp.random(n, n, density=0.03, random_state=4) * 0.1).tocsc()
    b = rng.normal(size=n) + 1j * rng.normal(size=n)
    f = np.logspace(1, 7, 9)
    X = solve_ac(E, H, b, f)
    for k, fk in enumerate(f):
        A = 2j * np.pi * fk * E.toarray() - H.toarray()
        np.testing.assert_allclose(X[k], np.linalg.solve(A, b), rtol=1e-9, atol=1e-12)


def test_sparse_path_names_the_frequency_where_the_matrix_is_singular():
    """Above the dense limit a singular ``j w E - H`` is refused at its frequency (a cutset of
    capacitors only: no DC path; here H has an empty row and E none at it, singular everywhere)."""
    import scipy.sparse as sp

    from netdae.errors import CircuitError

    n = 40
    H = sp.diags(np.r_[-np.ones(n - 1), 0.0]).tocsc()
    E = sp.diags(np.r_[np.full(n - 1, 1e-9), 0.0]).tocsc()
    with pytest.raises(CircuitError, match=r"singular at f = 10 Hz"):
        solve_ac(E, H, np.ones(n, dtype=complex), np.array([10.0, 100.0]))


def test_dc_sweep_divider_nested_and_reverse():
    ckt = circuit(mk("v1", "vsource", ("a", "0"), 0.0), mk("r1", "resistor", ("a", "b"), 1e3),
                  mk("r2", "resistor", ("b", "0"), 3e3), mk("i1", "isource", ("0", "b"), 0.0))
    res = dc_sweep(ckt, DcAnalysis([DcSweep("v1", 0.0, 4.0, 1.0), DcSweep("i1", 0.0, 1e-3, 5e-4)]))
    v1, i1 = res.axes["v1"], res.axes["i1"]
    assert v1.size == 15 and list(res.axes) == ["v1", "i1"]
    assert v1[:5].tolist() == [0.0, 1.0, 2.0, 3.0, 4.0] and np.all(i1[:5] == 0.0)
    # superposition: v(b) = 3/4 v1 + (1k || 3k) i1  (i1 flows from ground into b)
    np.testing.assert_allclose(res["v(b)"], 0.75 * v1 + 750.0 * i1, rtol=1e-12, atol=1e-15)
    rev = dc_sweep(ckt, DcAnalysis([DcSweep("v1", 2.0, -2.0, -0.5)]))
    np.testing.assert_allclose(rev["v(b)"], 0.75 * np.arange(2.0, -2.01, -0.5), rtol=1e-12, atol=1e-15)


def test_dc_sweep_rejects_unknown_and_non_source():
    from netdae.errors import CircuitError

    ckt = circuit(mk("v1", "vsource", ("a", "0"), 1.0), mk("r1", "resistor", ("a", "0"), 1e3))
    with pytest.raises(CircuitError, match="no source named 'vx'"):
        dc_sweep(ckt, DcAnalysis([DcSweep("vx", 0.0, 1.0, 0.5)]))
    with pytest.raises(CircuitError, match="resistance sweep of r1 from 0 to 1 reaches 0 ohm"):
        dc_sweep(ckt, DcAnalysis([DcSweep("r1", 0.0, 1.0, 0.5)]))
    ckt = circuit(mk("v1", "vsource", ("a", "0"), 1.0), mk("c1", "capacitor", ("a", "0"), 1e-9))
    with pytest.raises(CircuitError, match="'c1' is a capacitor"):
        dc_sweep(ckt, DcAnalysis([DcSweep("c1", 1e-9, 2e-9, 1e-9)]))
