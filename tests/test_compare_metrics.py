"""The comparison's metrics on synthetic results with known errors.

No simulator runs here: netdae's side is a Result whose dense output is an
exact function, ngspice's side samples another function at irregular points,
and every expected error is computed by hand (a shifted sine, a jump at t0).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from netdae.comparison.analyses import (
    AC_DYNAMIC_RANGE,
    compare_ac,
    compare_dc,
    compare_op,
    compare_transient,
    select_signals,
)
from netdae.comparison.header import Tolerance, parse_header
from netdae.comparison.metrics import (
    ABSOLUTE_FLOOR,
    FLOOR_FRACTION,
    JUMP_WINDOW_FRACTION,
    ac_metrics,
    initial_jump,
    kind_floors,
    waveform_metrics,
)
from netdae.comparison.model import Comparison
from netdae.errors import NetdaeError
from netdae.metadata import TransientInfo
from netdae.results import Result

W = 2 * math.pi * 50.0  # 50 Hz
T_END = 0.1  # five periods
D = 1e-5  # time shift [s]
SHIFT_ERROR = 2 * math.sin(W * D / 2)  # max |sin(w(t - d)) - sin(w t)|


def irregular_times(n=4001, seed=1):
    """Increasing times from 0 to T_END with random spacing, like a step-size controller's."""
    rng = np.random.default_rng(seed)
    steps = rng.uniform(0.2, 1.8, n - 1)
    t = np.concatenate([[0.0], np.cumsum(steps)])
    return t / t[-1] * T_END


def netdae_result(funcs: dict, t_own: np.ndarray, transient=None, status=0) -> Result:
    """A transient Result whose dense output evaluates ``funcs`` exactly."""
    return Result(
        "tran",
        axes={"time": t_own},
        signals={name: f(t_own) for name, f in funcs.items()},
        dense=lambda t: {name: f(np.asarray(t)) for name, f in funcs.items()},
        transient=transient,
        status=status,
        message="" if status >= 0 else "step size too small at t=0.05",
    )


def ngspice_result(funcs: dict, t: np.ndarray) -> Result:
    return Result("tran", axes={"time": t}, signals={name: f(t) for name, f in funcs.items()})


# ---------------------------------------------------------------------------
# kernels
# ---------------------------------------------------------------------------


def test_shifted_sine_max_and_rms_errors_are_the_analytic_ones():
    # the error 2 sin(wd/2) cos(w(t - d/2)) peaks at t = d/2 + k pi/w: put grid points there
    t = np.union1d(np.linspace(0.0, T_END, 20001), D / 2 + np.arange(10) * math.pi / W)
    m = waveform_metrics(t, np.sin(W * (t - D)), np.sin(W * t), scale=2.0)
    assert m.max_abs == pytest.approx(SHIFT_ERROR, rel=1e-9)
    assert m.max_rel == pytest.approx(SHIFT_ERROR / 2.0, rel=1e-9)
    # over whole periods the mean of cos^2 is 1/2; trapezoid error O(dt^2 w^2)
    assert m.rms == pytest.approx(SHIFT_ERROR / math.sqrt(2), rel=1e-6)
    assert abs(np.cos(W * (t[m.worst] - D / 2))) == pytest.approx(1.0, abs=1e-12)


def test_rms_is_time_weighted_not_per_point():
    # error 1 on [0, 0.01], 0 afterwards, sampled 1000x more densely at the start
    t = np.concatenate([np.linspace(0.0, 0.01, 1001), np.linspace(0.011, 1.0, 100)])
    e = (t <= 0.01).astype(float)
    m = waveform_metrics(t, e, np.zeros_like(t), scale=1.0)
    # integral of e^2: 0.01 plus half a ramp of width 0.001 (trapezoid between 0.01 and 0.011)
    assert m.rms == pytest.approx(math.sqrt((0.01 + 0.0005) / 1.0), rel=1e-12)
    flat = waveform_metrics(t, e, np.zeros_like(t), scale=1.0, weighted=False)
    assert flat.rms == pytest.approx(math.sqrt(1001 / 1101), rel=1e-12)


def test_floors_per_kind():
    floors = kind_floors(["v(out)", "v(minus)", "i(v1)", "i(e1)"], [20.0, 2e-5, 1e-2, 0.0])
    assert floors == {"v": FLOOR_FRACTION * 20.0, "i": FLOOR_FRACTION * 1e-2}
    # a circuit whose every signal is zero falls back to the absolute floors
    assert kind_floors(["v(a)", "i(v1)"], [0.0, 0.0]) == {"v": ABSOLUTE_FLOOR["v"], "i": ABSOLUTE_FLOOR["i"]}


def test_ac_metrics_magnitude_and_phase_errors():
    f_count = 5
    b = np.exp(1j * np.linspace(-1.0, 1.0, f_count)) * np.logspace(0, -4, f_count)
    eps, phi = 2e-3, math.radians(0.3)
    a = b * (1 + eps) * np.exp(1j * phi)
    m = ac_metrics(a, b, floor=1e-12)
    assert m.max_db == pytest.approx(20 * math.log10(1 + eps), rel=1e-12)
    assert m.max_phase_deg == pytest.approx(0.3, rel=1e-10)
    expected_rel = abs((1 + eps) * np.exp(1j * phi) - 1) / (1 + eps)  # |A - B| / max(|A|, |B|)
    assert m.max_rel == pytest.approx(expected_rel, rel=1e-10)
    assert m.max_abs == pytest.approx(abs(a[0] - b[0]), rel=1e-12)


def test_ac_metrics_below_the_floor_are_not_relative():
    b = np.array([1.0, 1e-15])
    a = np.array([1.0, 2e-15])  # 100 % off, but far below the floor
    m = ac_metrics(a, b, floor=1e-9)
    assert m.max_rel == 0.0  # both below the floor: rounding noise on both sides, equal
    assert m.max_db == 0.0 and m.max_phase_deg == 0.0  # only points above the floor count
    # one side above the floor: measured against the floor
    assert ac_metrics(np.array([1.0, 2e-9]), b, floor=1e-9).max_rel == pytest.approx((2e-9 - 1e-15) / 2e-9)


def test_initial_jump_detected_and_its_settle_point():
    t = irregular_times()
    a = np.cos(W * t)
    b = np.where(t < t[3], 0.0, a)  # ngspice's first three points are off
    jump = initial_jump(t, a, b, scale=2.0, rel=1e-3)
    assert jump is not None
    assert (jump.netdae, jump.ngspice, jump.settle) == (1.0, 0.0, 3)


def test_a_lasting_difference_is_not_a_jump():
    t = irregular_times()
    a = np.cos(W * t)
    late = t[0] + 2 * JUMP_WINDOW_FRACTION * (t[-1] - t[0])
    b = np.where(t < late, 0.0, a)
    assert initial_jump(t, a, b, scale=2.0, rel=1e-3) is None
    assert initial_jump(t, a, a, scale=2.0, rel=1e-3) is None  # no jump at all


# ---------------------------------------------------------------------------
# transient comparisons
# ---------------------------------------------------------------------------


def test_transient_shifted_sine_at_ngspice_points():
    t_ng = irregular_times()
    nd = netdae_result({"v(out)": lambda t: np.sin(W * (t - D)), "i(v1)": lambda t: 1e-3 * np.sin(W * t)},
                       np.linspace(0.0, T_END, 301))
    ng = ngspice_result({"v(out)": lambda t: np.sin(W * t), "i(v1)": lambda t: 1e-3 * np.sin(W * t)}, t_ng)
    item = compare_transient(nd, ng, tol=Tolerance(1e-3))
    assert [s.name for s in item.signals] == ["v(out)", "i(v1)"]  # worst first
    v = item.signals[0]
    # the grid does not hit the peak of the error exactly: bound by the sampling
    dt = np.max(np.diff(t_ng))
    assert SHIFT_ERROR * math.cos(W * dt) <= v.max_abs <= SHIFT_ERROR
    assert v.scale == pytest.approx(2.0, rel=1e-6) and v.scale_from == "range"
    assert v.max_rel == pytest.approx(v.max_abs / v.scale)
    assert v.passed is (v.max_rel <= 1e-3)
    assert SHIFT_ERROR / 2 > 1e-3 and v.passed is False  # 0.0031 of the range: out of tolerance
    assert item.signals[1].max_abs == 0.0 and item.signals[1].passed is True
    assert item.window is None and item.points == t_ng.size


def test_transient_tolerance_decides_pass():
    t_ng = irregular_times()
    nd = netdae_result({"v(out)": lambda t: np.sin(W * (t - D))}, t_ng)
    ng = ngspice_result({"v(out)": lambda t: np.sin(W * t)}, t_ng)
    loose = compare_transient(nd, ng, tol=Tolerance(SHIFT_ERROR / 2 * 1.01))
    tight = compare_transient(nd, ng, tol=Tolerance(SHIFT_ERROR / 2 * 0.9))
    unjudged = compare_transient(nd, ng, tol=None)
    assert loose.passed is True and tight.passed is False and unjudged.passed is None
    absolute = compare_transient(nd, ng, tol=Tolerance(1e-9, abs=SHIFT_ERROR * 1.01))
    assert absolute.passed is True


def test_transient_initial_jump_excluded_and_reported():
    t_ng = irregular_times()
    consistent = lambda t: -0.628 * np.cos(W * t)  # noqa: E731
    nd = netdae_result({"v(out)": consistent, "v(in)": lambda t: np.sin(W * t)}, np.linspace(0, T_END, 201),
                       transient=TransientInfo(initial_correction={"reason": "hidden constraints",
                                                                   "changed": {"v(out)": [0.0, -0.628]}}))
    ng_out = lambda t: np.where(t == 0.0, 0.0, consistent(t))  # noqa: E731  ngspice starts at its op
    ng = ngspice_result({"v(out)": ng_out, "v(in)": lambda t: np.sin(W * t)}, t_ng)
    item = compare_transient(nd, ng, tol=Tolerance(1e-3))
    assert item.window["index"] == 1 and item.window["from"] == t_ng[1]
    assert "hidden constraints: v(out) 0 -> -0.628" in item.window["reason"]
    out = next(s for s in item.signals if s.name == "v(out)")
    assert out.jump == {"netdae": -0.628, "ngspice": 0.0, "settle_time": t_ng[1]}
    assert out.max_abs == 0.0 and out.passed is True
    assert out.whole["max_abs"] == pytest.approx(0.628) and out.whole["at"] == {"time": 0.0}
    assert out.whole["max_rel"] == pytest.approx(0.628 / out.scale)
    assert item.passed is True
    vin = next(s for s in item.signals if s.name == "v(in)")
    assert vin.jump is None  # only the jumping signal carries the jump


def test_transient_late_disagreement_fails():
    t_ng = irregular_times()
    good = lambda t: np.cos(W * t)  # noqa: E731
    nd = netdae_result({"v(out)": good}, t_ng)
    ng = ngspice_result({"v(out)": lambda t: np.where(t < 0.2 * T_END, 0.0, good(t))}, t_ng)
    item = compare_transient(nd, ng, tol=Tolerance(1e-3))
    assert item.window is None and item.passed is False
    assert item.signals[0].max_abs == pytest.approx(1.0)


def test_transient_points_outside_netdae_interval_are_listed():
    t_ng = irregular_times()
    t_nd = t_ng[t_ng <= 0.5 * T_END]
    nd = netdae_result({"v(out)": np.sin}, t_nd, status=-1)
    ng = ngspice_result({"v(out)": np.sin}, t_ng)
    item = compare_transient(nd, ng, tol=Tolerance(1e-3))
    assert item.points == t_nd.size
    assert any("outside netdae's interval" in note for note in item.notes)
    assert item.error.startswith("netdae's transient failed") and item.passed is False


def test_transient_without_dense_output_is_an_error():
    t = irregular_times()
    nd = Result("tran", axes={"time": t}, signals={"v(out)": np.sin(t)})
    item = compare_transient(nd, ngspice_result({"v(out)": np.sin}, t), tol=Tolerance(1e-3))
    assert "dense output" in item.error and item.passed is False


def test_virtual_ground_is_measured_against_the_circuit_swing():
    t = irregular_times()
    out = lambda t: 10 * np.sin(W * t)  # noqa: E731
    nd = netdae_result({"v(out)": out, "v(minus)": lambda t: 0 * t}, t)
    ng = ngspice_result({"v(out)": out, "v(minus)": lambda t: -out(t) / 1e6}, t)  # finite gain 1e6
    item = compare_transient(nd, ng, tol=Tolerance(1e-3))
    minus = next(s for s in item.signals if s.name == "v(minus)")
    assert minus.scale_from == "floor"
    assert minus.scale == pytest.approx(FLOOR_FRACTION * 20.0, rel=1e-6)
    assert minus.max_rel == pytest.approx(1e-5 / (FLOOR_FRACTION * 20.0) * 10 / 10, rel=1e-3)
    assert item.passed is True


# ---------------------------------------------------------------------------
# op, dc, ac
# ---------------------------------------------------------------------------


def test_operating_point_errors():
    nd = Result("op", signals={"v(a)": np.array([5.0]), "v(b)": np.array([1e-9]), "i(v1)": np.array([-1e-3])})
    ng = Result("op", signals={"v(a)": np.array([5.001]), "v(b)": np.array([0.0]), "i(v1)": np.array([-1e-3])})
    item = compare_op(nd, ng, tol=Tolerance(1e-6, abs=1e-9))
    by = {s.name: s for s in item.signals}
    assert by["v(a)"].max_abs == pytest.approx(1e-3) and by["v(a)"].max_rel == pytest.approx(1e-3 / 5.001)
    assert by["v(a)"].passed is False
    assert by["v(b)"].scale_from == "floor" and by["v(b)"].passed is True  # 1e-9 absolute
    assert by["i(v1)"].max_abs == 0.0 and by["i(v1)"].scale_from == "magnitude"
    assert item.signals[0].name == "v(a)" and item.passed is False


def test_dc_nested_sweep_point_and_location():
    v1 = np.tile(np.arange(0.0, 2.5, 0.5), 3)
    i1 = np.repeat([0.0, 1e-3, 2e-3], 5)
    axes = {"v1": v1, "i1": i1}
    exact = v1 / 2 + 500 * i1
    off = exact.copy()
    off[7] += 2e-4
    nd = Result("dc", axes=axes, signals={"v(b)": exact})
    ng = Result("dc", axes=dict(axes), signals={"v(b)": off})
    item = compare_dc(nd, ng, tol=Tolerance(1e-3))
    sig = item.signals[0]
    assert sig.at == {"v1": 1.0, "i1": 1e-3}
    assert sig.max_abs == pytest.approx(2e-4) and sig.scale == pytest.approx(np.ptp(off))
    assert sig.rms == pytest.approx(2e-4 / math.sqrt(15))
    moved = Result("dc", axes={"v1": v1 + 0.1, "i1": i1}, signals={"v(b)": exact})
    assert "differ" in compare_dc(moved, ng, tol=Tolerance(1e-3)).error


def test_dc_jump_at_a_point_ngspice_reached_by_adding_its_step_gets_a_note():
    """`.dc V1 -2 2 0.1` with B1 V=u(V(x)): ngspice's point near 0 is not 0 (it adds the step 20 times; it
    reported 1.64e-15), netdae's is (start + k step), so u() is 1 in ngspice, 0.5 in netdae, and the points
    around agree."""
    mine = -2.0 + np.arange(41) * 0.1
    theirs = np.empty(41)
    value = -2.0
    for k in range(41):
        theirs[k], value = value, value + 0.1
    assert theirs[20] != 0.0 and mine[20] == 0.0
    u = lambda x: np.where(x > 0, 1.0, np.where(x < 0, 0.0, 0.5))  # noqa: E731
    nd = Result("dc", axes={"v1": mine}, signals={"v(o)": u(mine), "v(x)": mine})
    ng = Result("dc", axes={"v1": theirs}, signals={"v(o)": u(theirs), "v(x)": theirs})
    item = compare_dc(nd, ng, tol=Tolerance(1e-3))
    assert item.passed is False
    (note,) = [n for n in item.notes if "adds the step" in n]
    assert note.startswith(f"v(o): at ngspice's point v1 = {theirs[20]:.17g} where netdae's is 0 ")
    smooth = Result("dc", axes={"v1": mine}, signals={"v(o)": u(theirs) + 0.01 * mine, "v(x)": mine})
    assert not any("adds the step" in n for n in compare_dc(smooth, ng, tol=Tolerance(1e-3)).notes)


def test_ac_needs_the_same_frequencies_and_floors_by_kind():
    f = np.logspace(1, 5, 9)
    h = 1 / (1 + 1j * f / 1e3)
    ng = Result("ac", axes={"frequency": f}, signals={"v(out)": h, "v(in)": np.ones_like(h)})
    nd = Result("ac", axes={"frequency": f.copy()}, signals={"v(out)": h * (1 + 1e-6), "v(in)": np.ones_like(h)})
    item = compare_ac(nd, ng, tol=Tolerance(1e-3))
    out = next(s for s in item.signals if s.name == "v(out)")
    assert out.max_rel == pytest.approx(1e-6 / (1 + 1e-6), rel=1e-9)
    assert out.max_db == pytest.approx(20 * math.log10(1 + 1e-6), rel=1e-6)
    assert out.max_phase_deg < 1e-12 and item.passed is True
    assert AC_DYNAMIC_RANGE < 1e-6
    shifted = Result("ac", axes={"frequency": f * (1 + 1e-12)}, signals=nd.signals)
    assert compare_ac(shifted, ng, tol=Tolerance(1e-3)).error is not None


def test_ac_values_below_the_dynamic_range_on_both_sides_agree():
    # a supply current that cancels exactly (a differential pair driven antisymmetrically): -2.1e-14 A in
    # netdae, +3.7e-16 A in ngspice, 4e-12 of the largest current: rounding on both sides, not a FAIL
    f = np.logspace(3, 6, 4)
    big = np.full(4, 5.3e-3 + 0j)
    nd = Result("ac", axes={"frequency": f}, signals={"i(vcc)": np.full(4, -2.07e-14 + 0j), "i(v1)": big})
    ng = Result("ac", axes={"frequency": f.copy()}, signals={"i(vcc)": np.full(4, 3.7e-16 + 0j), "i(v1)": big})
    item = compare_ac(nd, ng, tol=Tolerance(1e-3))
    assert item.passed is True
    assert next(s for s in item.signals if s.name == "i(vcc)").max_rel == 0.0
    # above the floor on one side it is measured as before
    ng_big = Result("ac", axes={"frequency": f.copy()}, signals={"i(vcc)": np.full(4, 1e-9 + 0j), "i(v1)": big})
    assert compare_ac(nd, ng_big, tol=Tolerance(1e-3)).passed is False


def test_signal_selection_lists_one_sided_signals_and_refuses_unknown_names():
    compared, only_nd, only_ng, excluded = select_signals(
        ["v(a)", "v(b)", "i(e1)"], ["v(a)", "v(b)", "i(v1)"], wanted=["v(a)", "i(e1)"])
    assert (compared, only_nd, only_ng, excluded) == (["v(a)"], ["i(e1)"], [], [])
    with pytest.raises(NetdaeError, match="v\\(nope\\)"):
        select_signals(["v(a)"], ["v(a)"], exclude=["v(nope)"])


def test_no_common_signal_is_an_error():
    t = irregular_times()
    item = compare_transient(netdae_result({"v(a)": np.sin}, t), ngspice_result({"v(b)": np.sin}, t),
                             tol=Tolerance(1e-3))
    assert item.error and item.only_netdae == ["v(a)"] and item.only_ngspice == ["v(b)"]


def test_comparison_verdict_and_json_has_no_nan():
    t = irregular_times()
    item = compare_transient(netdae_result({"v(a)": np.sin}, t), ngspice_result({"v(a)": np.sin}, t),
                             tol=Tolerance(1e-3))
    c = Comparison("x.cir", "x", analyses=[item], ngspice_version="ngspice-39")
    assert c.passed is True
    c.ngspice_error = "ngspice failed"
    assert c.passed is False
    doc = c.to_dict()
    assert doc["analyses"][0]["signals"][0]["signal"] == "v(a)"
    item.signals[0].rms = float("nan")
    assert c.to_dict()["analyses"][0]["signals"][0]["rms"] is None


# ---------------------------------------------------------------------------
# netlist headers
# ---------------------------------------------------------------------------


def test_header_forms():
    text = """t
* A circuit.
* expected index: 2   (why)
* compare tolerance: .op and .dc 1e-6 relative (or 1e-9 absolute) against
*   ngspice; transient: period and waveform, see the docs.
* compare options: tight
V1 a 0 1
"""
    h = parse_header(text)
    assert h.expected_index == 2 and h.tight and h.description == ["A circuit."]
    assert h.tolerance("op") == h.tolerance("dc") == Tolerance(1e-6, 1e-9)
    assert h.states("tran") and h.tolerance("tran") is None
    assert not h.states("ac")
    plain = parse_header("t\n* expected index: singular\n* compare tolerance: 5e-3 (ringing)\n")
    assert plain.expected_index == "singular"
    assert all(plain.tolerance(a) == Tolerance(5e-3) for a in ("op", "dc", "ac", "tran"))
    assert parse_header("t\nR1 a 0 1\n").tolerances == {}
    nested = parse_header("t\n* compare tolerance: .op 1e-6; transient 1e-3 (measured 6e-4; 27 periods)\n")
    assert nested.tolerance("tran") == Tolerance(1e-3) and nested.tolerance("op") == Tolerance(1e-6)
    with pytest.raises(NetdaeError, match="compare tolerance"):
        parse_header("t\n* compare tolerance: tight enough\n")


def test_ngspice_points_a_rounding_off_a_jump_take_the_closer_of_netdaes_two_values():
    # netdae records the step at tj twice (left value, right limit); its dense output gives the left value at
    # tj and the right one after. ngspice reports the left value both at tj and a rounding later (its breakpoint
    # time plus a few ulps): both are netdae's left value, not a disagreement of the whole step.
    tj = 2e-11
    after = np.nextafter(np.nextafter(tj, 1.0), 1.0)
    step = lambda t: np.where(np.asarray(t) > tj, 1.0, 0.0)  # noqa: E731
    t_own = np.concatenate([np.linspace(0.0, tj, 50), [tj], np.linspace(tj, 1e-10, 60)[1:]])
    x_own = np.where(np.arange(t_own.size) >= 50, 1.0, 0.0)  # the left value at tj first, then the right limit
    nd = Result("tran", axes={"time": t_own}, signals={"v(a)": x_own},
                dense=lambda t: {"v(a)": step(t)},
                transient=TransientInfo(jumps=[(tj, ["v(a)"])]))
    t_ng = np.concatenate([np.linspace(0.0, tj, 40), [after], np.linspace(tj, 1e-10, 45)[2:]])
    ng = ngspice_result({"v(a)": lambda t: np.where(t > after, 1.0, 0.0)}, t_ng)
    item = compare_transient(nd, ng, tol=Tolerance(1e-3))
    (m,) = item.signals
    assert m.max_abs == 0.0 and item.passed
