"""Lossless transmission lines (T, ngspice's TRA): syntax, DC, AC and transients against closed forms and ngspice.

The transient closed forms are the lattice (bounce) diagram of a line of impedance z0 and
delay td between a source resistance rs and a load rl: the load sees the source's voltage
``vs`` as

    v_load(t) = z0 / (z0 + rs) (1 + gl) sum_k (gl gs)^k vs(t - (2k + 1) td),

with the reflection coefficients ``gl = (rl - z0) / (rl + z0)``, ``gs = (rs - z0) / (rs + z0)``
(the line starts at rest, the source at 0 before t = 0).
"""

from __future__ import annotations

import numpy as np
import pytest

import netdae
from netdae.errors import CircuitError, NetlistError
from netdae.netlist import load

Z0 = 50.0
TD = 2e-9

LINE = """line between {rs} and {rl}
V1 in 0 PWL(0 0 0.5n 0 1n 1 30n 1)
RS in a {rs}
T1 a 0 b 0 z0=50 td=2n
RL b 0 {rl}
.tran 0.01n 30n
.options reltol=1e-6 abstol=1e-12 vntol=1e-9
.end
"""


def _pwl(t):
    return np.interp(t, [0.0, 0.5e-9, 1e-9, 30e-9], [0.0, 0.0, 1.0, 1.0])


def _lattice(t, rs, rl, reflections=40):
    gl = (rl - Z0) / (rl + Z0) if np.isfinite(rl) else 1.0
    gs = (rs - Z0) / (rs + Z0)
    out = np.zeros_like(t)
    for k in range(reflections):
        out += (gl * gs) ** k * _pwl(t - (2 * k + 1) * TD) * (t >= (2 * k + 1) * TD)
    return Z0 / (Z0 + rs) * (1.0 + gl) * out


@pytest.mark.parametrize("rs, rl", [(50, 50), (50, 1e12), (10, 200), (150, 20)])
def test_a_pulse_through_a_line_follows_the_lattice_diagram(rs, rl):
    (res,) = netdae.run(LINE.format(rs=rs, rl=rl))
    assert res.ok, res.message
    t = np.linspace(0.0, 30e-9, 3001)
    got = res.dense(t)["v(b)"]
    want = _lattice(t, rs, 1e12 if rl == 1e12 else rl)
    assert np.max(np.abs(got - want)) < 1e-5


def test_the_source_side_sees_the_reflection_arrive_after_the_round_trip():
    (res,) = netdae.run(LINE.format(rs=10, rl=200))
    gl, gs = (200 - Z0) / (200 + Z0), (10 - Z0) / (10 + Z0)
    t = np.linspace(0.0, 30e-9, 3001)
    # v(a) = incident (z0 / (z0 + rs) vs(t)) plus what comes back: every return adds
    # (1 + gs) times the wave arriving
    inc = Z0 / (Z0 + 10) * _pwl(t)
    want = inc.copy()
    for k in range(1, 40):
        back = Z0 / (Z0 + 10) * gl ** k * gs ** (k - 1) * (1 + gs) * _pwl(t - 2 * k * TD) * (t >= 2 * k * TD)
        want += back
    got = res.dense(t)["v(a)"]
    assert np.max(np.abs(got - want)) < 1e-5


def test_port_currents_are_ngspices_branch_unknowns():
    (res,) = netdae.run(LINE.format(rs=50, rl=50))
    t = np.array([1.5e-9, 10e-9])
    i1 = res.dense(t)["i(t1#i1)"]
    i2 = res.dense(t)["i(t1#i2)"]
    # the incident wave: 0.5 V into 50 ohm enters port 1; at the load the current leaves port 2
    assert i1 == pytest.approx([_pwl(1.5e-9) * 0.5 / Z0, 0.5 / Z0], rel=1e-6, abs=1e-12)
    assert i2[1] == pytest.approx(-0.5 / Z0, rel=1e-6)


def test_at_dc_the_line_joins_its_ports():
    text = "dc line\nV1 in 0 1\nRS in a 30\nT1 a 0 b 0 z0=50 td=1n\nRL b 0 70\n.op\n.end\n"
    (op,) = netdae.run(text)
    assert op["v(b)"][0] == pytest.approx(0.7, rel=1e-12)
    assert op["v(a)"][0] == pytest.approx(0.7, rel=1e-12)
    assert op["i(t1#i1)"][0] == pytest.approx(0.01, rel=1e-12)
    assert op["i(t1#i2)"][0] == pytest.approx(-0.01, rel=1e-12)


def test_a_transient_from_a_dc_operating_point_stays_there():
    text = "steady\nV1 in 0 1\nRS in a 30\nT1 a 0 b 0 z0=50 td=1n\nRL b 0 70\n.tran 0.1n 10n\n.end\n"
    (res,) = netdae.run(text)
    assert np.max(np.abs(res["v(b)"] - 0.7)) < 1e-12


def test_uic_starts_the_line_from_its_ic_values():
    # a charged open line (1 V everywhere, no current) discharging into a matched load at t = 0:
    # ic= gives the waves at rest; the load sees half the voltage for a round trip, then nothing
    text = ("uic\nT1 a 0 b 0 z0=50 td=1n ic=1,0,1,0\nR1 a 0 50\nRopen b 0 1e12\n"
            ".ic v(a)=1 v(b)=1\n.tran 0.01n 5n uic\n.options reltol=1e-6\n.end\n")
    (res,) = netdae.run(text)
    va = res.dense(np.array([0.5e-9, 1.5e-9, 2.5e-9]))["v(a)"]
    assert va == pytest.approx([0.5, 0.5, 0.0], abs=1e-6)


def test_a_shorted_stub_has_the_input_impedance_j_z0_tan():
    text = ("stub\nI1 0 a DC 0 AC 1\nT1 a 0 b 0 z0=50 td=1n\nVshort b 0 0\nRbig a 0 1e15\n"
            ".ac lin 50 10meg 240meg\n.end\n")
    (res,) = netdae.run(text)
    f = res.axes["frequency"]
    want = 1j * Z0 * np.tan(2 * np.pi * f * 1e-9)
    np.testing.assert_allclose(res["v(a)"], want, rtol=1e-9, atol=1e-9)


def test_a_quarter_wave_line_given_by_frequency_and_length():
    # f=250meg with the default nl=0.25 is td = 1 ns: an open quarter-wave stub is a short there
    text = ("quarter\nI1 0 a DC 0 AC 1\nT1 a 0 b 0 z0=50 f=250meg\nRopen b 0 1e15\nR1 a 0 1k\n"
            ".ac lin 3 240meg 260meg\n.end\n")
    (res,) = netdae.run(text)
    assert abs(res["v(a)"][1]) < 1e-6


def test_index_sees_each_port_as_a_resistance_behind_its_delayed_wave():
    from netdae.analyses.index import analyze_index

    # index 1 with the capacitor; a voltage source straight at a port is still index 1 (z0 in series)
    report = analyze_index(load(LINE.format(rs=50, rl=50).replace("RL b 0 50", "RL b 0 50\nCL b 0 1p")))
    assert report.index == 1
    report = analyze_index(load("direct\nV1 a 0 SIN(0 1 1g)\nT1 a 0 b 0 z0=50 td=1n\nCL b 0 1p\n"
                                ".tran 1p 1n\n.end\n"))
    assert report.index == 1


@pytest.mark.parametrize("card, message", [
    ("T1 a 0 b 0 td=1n", "z0= is missing"),
    ("T1 a 0 b 0 z0=50", "delay is missing"),
    ("T1 a 0 b 0 z0=-50 td=1n", "must be positive"),
    ("T1 a 0 b 0 z0=50 td=0", "must be positive"),
    ("T1 a 0 b 0 z0=50 f=-1g", "must be positive"),
    ("T1 a 0 b 0 z0=50 td=1n ic=1,2,3,4,5", "at most 4 values"),
    ("T1 a 0 b z0=50 td=1n", "expected 4 nodes"),
    ("T1 a 0 b 0 z0=50 td=1n len=3", "unknown parameter 'len'"),
    ("T1 a 0 b 0 z0=50 zo=50 td=1n", "z0 given twice"),
])
def test_bad_lines_are_located_errors(card, message):
    with pytest.raises(NetlistError, match=message) as err:
        load(f"bad\nV1 a 0 1\n{card}\nR1 b 0 1\n.op\n.end\n")
    assert err.value.location.line == 3


def test_pz_refuses_a_line():
    with pytest.raises(CircuitError, match="transcendental"):
        netdae.run("pz\nV1 in 0 AC 1\nRS in a 50\nT1 a 0 b 0 z0=50 td=1n\nRL b 0 50\n.pz in 0 b 0 vol pz\n.end\n")


def test_the_python_integrator_refuses_lines(monkeypatch):
    monkeypatch.setenv("NETDAE_ENGINE", "python")
    with pytest.raises(CircuitError, match="compiled engine only"):
        netdae.run(LINE.format(rs=50, rl=50))


def test_td_wins_over_f_with_a_warning():
    c = load("w\nV1 a 0 1\nT1 a 0 b 0 z0=50 td=1n f=1g nl=0.5\nR1 b 0 50\n.op\n.end\n")
    (el,) = [e for e in c.elements if e.kind == "tline"]
    assert el.params["td"] == 1e-9
    assert any("f= ignored" in d.message for d in c.diagnostics)


# --- against ngspice ---------------------------------------------------------------------------------

NONLINEAR = """line into a diode clamp
V1 in 0 PULSE(0 5 1n 0.5n 0.5n 8n 20n)
RS in a 25
T1 a 0 b 0 z0=75 td=3n
D1 b c dclamp
VC c 0 2
RL b 0 1k
CL b 0 2p
.model dclamp D(is=1e-14 n=1.05 rs=2 cjo=1p)
.tran 0.02n 60n
.end
"""


@pytest.mark.ngspice
def test_a_line_into_a_diode_clamp_agrees_with_ngspice():
    from netdae.comparison import compare

    result = compare(NONLINEAR, tight=True)
    assert result.ngspice_error is None
    item = result.analysis("tran", 0)
    worst = max(s.max_rel for s in item.signals)
    assert item.passed and worst < 2e-3, [(s.name, s.max_rel) for s in item.signals]


@pytest.mark.ngspice
def test_stub_ac_agrees_with_ngspice():
    from netdae.ngspice import run_ngspice

    text = ("stub\nV1 in 0 DC 0 AC 1\nRS in a 50\nT1 a 0 b 0 z0=75 td=1.3n\nRL b 0 20\nCL b 0 3p\n"
            ".ac dec 20 1meg 1g\n.end\n")
    ref = run_ngspice(text).result("ac")
    (ours,) = netdae.run(text)
    np.testing.assert_allclose(ours["v(b)"], np.asarray(ref["v(b)"]), rtol=1e-6, atol=1e-9)


def test_the_right_limits_history_holds_the_last_wave_past_the_record():
    # the Python right limit reads the lines' recorded waves; at an impasse its implicit-Euler
    # steps grow tenfold each try and can ask for t + 2 eps - tau past the last recorded point:
    # the delayed input is then held at its latest value (a ValueError of the dense output before)
    from netdae.dae.compiled import bdf_loop as L
    from netdae.dae.compiled.driver import _history

    t = np.array([0.0, 1.0, 2.0, 3.0])
    buf_x = np.column_stack([np.zeros(4), 2.0 * t, t ** 2])  # a saved unknown, then two waves
    I = np.zeros(L.N_I, dtype=np.int64)
    I[L.I_M] = 4
    I[L.I_NSEGMENTS] = 1
    history = _history(t, np.array([0, 1, 2, 2], dtype=np.int8), buf_x, np.zeros(4, dtype=np.int64), I, 1)
    # inside the record: the interpolating polynomials (exact for these waves)
    assert np.allclose(history(np.array([1.5, 2.5])), [3.0, 6.25], rtol=0, atol=1e-12)
    # past it: the last recorded values, each row at its own time
    assert np.array_equal(history(np.array([3.5, 40.0])), [6.0, 9.0])
    assert np.allclose(history(np.array([3.5, 2.5])), [6.0, 6.25], rtol=0, atol=1e-12)
