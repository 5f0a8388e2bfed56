"""The validation netlists are what their headers say: closed forms against both simulators.

Each header of the validation set states a closed form (a step, ramp or sine
response, a transfer function, a DC transfer curve). Here the closed forms are
written out by hand and checked against ngspice at tight tolerances (the
reference the comparison trusts) and against netdae (its AC and DC now, its
transient once ``netdae.analyses.tran`` exists). Errors are in units of the
signal's range.

Where a pulse has a finite rise time ``tr``, the ideal-step closed form is
evaluated at ``t - tr/2``: a linear ramp of length tr delays the response by
tr/2 up to O(tr^2) terms, below the tolerances here.
"""

from __future__ import annotations

import importlib.util
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from netdae.comparison.run import TIGHT_NETDAE, TIGHT_NGSPICE, TIGHT_OPAMP_GAIN, TIGHT_STEPS_PER_INTERVAL
from netdae.netlist import load

pytestmark = pytest.mark.ngspice

NETLISTS = Path(__file__).resolve().parent.parent / "netlists"
HAVE_TRAN = importlib.util.find_spec("netdae.analyses.tran") is not None
PI = math.pi
W1K = 2 * PI * 1e3
#: Both simulators at tight tolerances reproduce the closed forms to this
#: fraction of the signal's range (ngspice measured at 2e-5 at worst, on the
#: underdamped RLC).
CLOSED_FORM_TOL = 1e-4


def _highpass(t, w, tau, gain=1.0):
    """First-order high-pass response to gain * sin(w t) from rest: v' + v/tau = gain * d/dt sin(w t)."""
    a = w * tau
    return gain * (a / math.sqrt(1 + a * a) * np.sin(w * t + PI / 2 - math.atan(a)) - a / (1 + a * a) * np.exp(-t / tau))


def _rl_lowpass(t):
    R, L, w = 100.0, 10e-3, W1K
    z, th = math.hypot(R, w * L), math.atan(w * L / R)
    return (np.sin(w * t - th) + math.sin(th) * np.exp(-t * R / L)) / z


def _underdamped(t):
    w0, z = 1e4, 0.1
    wd = w0 * math.sqrt(1 - z * z)
    return 1 - np.exp(-z * w0 * t) * (np.cos(wd * t) + z / math.sqrt(1 - z * z) * np.sin(wd * t))


def _overdamped(t):
    w0, z, current, c = 1e4, 2.0, 1e-3, 1e-6
    s1, s2 = w0 * (-z + math.sqrt(z * z - 1)), w0 * (-z - math.sqrt(z * z - 1))
    return current / (c * (s1 - s2)) * (np.exp(s1 * t) - np.exp(s2 * t))


def _finite_gain(t):
    a_gain, tau, w = 10.0, 10e-3 / (100 * 11), W1K
    k = a_gain * w * tau / (1 + (w * tau) ** 2)
    return -k * (np.cos(w * t) + w * tau * np.sin(w * t)) + k * np.exp(-t / tau)


def _cv_loop_capacitors(t):
    return _highpass(t, W1K, 3e-3, gain=1 / 3)


def _cv_loop_current(t):
    tau, k, w = 3e-3, 1 / 3, W1K
    a = w * tau
    dvb = k * a / math.sqrt(1 + a * a) * w * np.cos(w * t + PI / 2 - math.atan(a)) + k * a / (1 + a * a) / tau * np.exp(-t / tau)
    return -1e-6 * (w * np.cos(w * t) - dvb)


#: netlist -> list of (signal, closed form f(t), first time it applies, last time it applies)
TRANSIENTS = {
    "rc_lowpass_pulse": [("v(out)", lambda t: 1 - np.exp(-(t - 0.5e-6) / 1e-3), 1e-6, 2e-3)],
    "rc_highpass_sin": [("v(out)", lambda t: _highpass(t, 2 * PI * 500, 1e-3), 0.0, 6e-3)],
    "rl_lowpass_sin": [("i(l1)", _rl_lowpass, 0.0, 3e-3), ("v(out)", lambda t: 100 * _rl_lowpass(t), 0.0, 3e-3)],
    "rl_highpass_pulse": [("v(out)", lambda t: np.exp(-(t - 0.5e-6) / 1e-4), 1e-6, 0.5e-3),
                          ("i(l1)", lambda t: (1 - np.exp(-(t - 0.5e-6) / 1e-4)) / 100, 1e-6, 0.5e-3)],
    "rlc_series_underdamped": [("v(out)", _underdamped, 0.0, 5e-3)],
    "rlc_series_critical": [("v(out)", lambda t: 1 - (1 + 1e4 * t) * np.exp(-1e4 * t), 0.0, 2e-3),
                            ("i(l1)", lambda t: 1e-6 * 1e8 * t * np.exp(-1e4 * t), 0.0, 2e-3)],
    "rlc_parallel_overdamped": [("v(top)", _overdamped, 0.0, 2e-3)],
    "pwl_rc": [("v(out)", lambda t: (t - 1e-3 * (1 - np.exp(-t / 1e-3))) / 1e-3, 0.0, 1e-3)],
    "inverting_amplifier": [("v(out)", lambda t: -10 * np.sin(W1K * t), 0.0, 2e-3),
                            ("i(e1)", lambda t: np.sin(W1K * t) / 1e3, 0.0, 2e-3)],
    "controlled_sources": [(f"v({n})", (lambda k: lambda t: k * (0.05 + 0.1 * np.sin(W1K * t)))(k), 0.0, 3e-3)
                           for n, k in (("e", 5.0), ("h", 0.5), ("f", 3.0))],
    "cv_loop_sin": [("i(v1)", lambda t: -1e-6 * W1K * np.cos(W1K * t) - np.sin(W1K * t) / 1e3, 1e-5, 3e-3)],
    "cv_loop_capacitors": [("v(b)", _cv_loop_capacitors, 0.0, 3e-3), ("i(v1)", _cv_loop_current, 1e-5, 3e-3)],
    "li_cutset": [("v(a)", lambda t: 10e-3 * 1e-3 * W1K * np.cos(W1K * t) + 0.1 * np.sin(W1K * t), 1e-5, 3e-3),
                  ("i(l1)", lambda t: 1e-3 * np.sin(W1K * t), 0.0, 3e-3)],
    "rc_differentiator": [("v(out)", lambda t: -1e-4 * W1K * np.cos(W1K * t), 1e-5, 3e-3),
                          ("i(v1)", lambda t: -1e-7 * W1K * np.cos(W1K * t), 1e-5, 3e-3)],
    "differentiator_finite_gain": [("v(out)", _finite_gain, 0.0, 3e-3)],
}


def _ngspice_tight(name: str, analysis: str):
    from netdae.ngspice import run_ngspice_file

    path = NETLISTS / f"{name}.cir"
    options = dict(TIGHT_NGSPICE)
    if analysis == "tran":
        card = next(c for c in load(path).analyses if hasattr(c, "tstop"))
        options["maxstep"] = (card.tstop - card.tstart) / TIGHT_STEPS_PER_INTERVAL
    return run_ngspice_file(path, options=options, opamp_gain=TIGHT_OPAMP_GAIN).result(analysis)


def _netdae(name: str, analysis: str):
    from netdae.analyses.runner import analysis_name, run

    circuit = load(NETLISTS / f"{name}.cir")
    card = next(c for c in circuit.analyses if analysis_name(c) == analysis)
    (result,) = run(replace(circuit, analyses=[card]), **TIGHT_NETDAE)
    return result


def _range_error(t, got, want, t_first, t_last) -> float:
    sel = (t >= t_first) & (t <= t_last)
    assert np.count_nonzero(sel) > 10
    return float(np.max(np.abs(got[sel] - want[sel])) / np.ptp(want[sel]))


@pytest.mark.parametrize("name", sorted(TRANSIENTS))
def test_ngspice_transient_matches_the_closed_form(name):
    result = _ngspice_tight(name, "tran")
    for signal, form, t_first, t_last in TRANSIENTS[name]:
        err = _range_error(result.t, result[signal], form(result.t), t_first, t_last)
        assert err < CLOSED_FORM_TOL, (signal, err)


@pytest.mark.skipif(not HAVE_TRAN, reason="netdae's transient analysis (netdae.analyses.tran) is not built yet")
@pytest.mark.parametrize("name", sorted(TRANSIENTS))
def test_netdae_transient_matches_the_closed_form(name):
    result = _netdae(name, "tran")
    t = np.linspace(result.t[0], result.t[-1], 20001)
    values = result.dense(t)
    for signal, form, t_first, t_last in TRANSIENTS[name]:
        err = _range_error(t, values[signal], form(t), t_first, t_last)
        assert err < CLOSED_FORM_TOL, (signal, err)


def _sallen_key(f):
    s = 2j * PI * f
    w0 = 1 / math.sqrt(10e3 * 10e3 * 20e-9 * 10e-9)
    return 1 / (1 + s / (w0 / math.sqrt(2)) + (s / w0) ** 2)


def _transformer(f, signal):
    w = 2 * PI * f
    m = 0.99 * math.sqrt(10e-3 * 40e-3)
    z1, z2 = 10 + 1j * w * 10e-3, 1e3 + 1j * w * 40e-3
    den = z1 * z2 + (w * m) ** 2
    return 1j * w * m * 1e3 / den if signal == "v(s)" else z2 / den


#: netlist -> list of (signal, H(f), relative tolerance): magnitude-only forms compare |H|.
AC_FORMS = {
    "bode_rc_rlc": [("v(lp)", lambda f: 1 / (1 + 2j * PI * f * 1e-4), 1e-12),
                    ("v(bp)", lambda f: 50 / (50 + 2j * PI * f * 1e-2 + 1 / (2j * PI * f * 1e-6)), 1e-12)],
    "transformer": [("v(s)", lambda f: _transformer(f, "v(s)"), 1e-12), ("i(l1)", lambda f: _transformer(f, "i"), 1e-12)],
    # the ideal op-amp is a VCVS of gain 1e9 in ngspice: model error 1e-9
    "sallen_key_lowpass": [("v(out)", _sallen_key, 1e-8)],
    # the component values are the prototype's to 6 digits
    "lc_ladder_butterworth5": [("|v(out)|", lambda f: 2 * 0.5 / np.sqrt(1 + (f / 1e4) ** 10), 1e-5)],
}


@pytest.mark.parametrize("simulator", ["ngspice", "netdae"])
@pytest.mark.parametrize("name", sorted(AC_FORMS))
def test_ac_matches_the_transfer_function(name, simulator):
    result = _ngspice_tight(name, "ac") if simulator == "ngspice" else _netdae(name, "ac")
    f = result.axis
    for signal, form, tol in AC_FORMS[name]:
        want = form(f)
        if signal.startswith("|"):
            got, want = np.abs(result[signal.strip("|")]), np.abs(want)
        else:
            got = result[signal]
        err = np.max(np.abs(got - want) / np.abs(want))
        assert err < tol, (signal, err)


@pytest.mark.parametrize("simulator", ["ngspice", "netdae"])
def test_bridge_transfer_curves(simulator):
    result = _ngspice_tight("bridge_dc", "dc") if simulator == "ngspice" else _netdae("bridge_dc", "dc")
    v1, i1 = result.axes["v1"], result.axes["i1"]
    assert v1.size == 21 * 3 and sorted(set(i1.tolist())) == [0.0, 5e-4, 1e-3]
    va = v1 / 2
    vb = (v1 / 1e3 + i1) / (1 / 1e3 + 1 / 1.2e3)
    np.testing.assert_allclose(result["v(a)"], va, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(result["v(b)"], vb, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(result["v(d)"], 10 * (va - vb), rtol=1e-11, atol=1e-11)
