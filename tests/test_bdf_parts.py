"""The integrator's correctors and start-up alone, on small linear systems with known answers."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from netdae.dae.bdf import integrate
from netdae.dae.bdf.corrector import LinearCorrector, RoundingFloor
from netdae.dae.bdf.failures import Failure, failure_record, worst_unknown
from netdae.dae.bdf.startup import jump_of, probe
from netdae.dae.bdf.statistics import new_statistics
from netdae.dae.newton import LuCache
from netdae.dae.system import LinearDae


def _rc():
    """C v' = -v/R + i_s, C = 1e-6, R = 1e3, i_s = 1e-3 (v' = 1000 (1 - v))."""
    return LinearDae([[1e-6]], [[-1e-3]], lambda t, derivative=0: np.array([1e-3 if derivative == 0 else 0.0]))


def test_linear_corrector_solves_the_backward_euler_step_exactly():
    system = _rc()
    ev = system.evaluate(np.zeros(1), 0.0, jacobian=True)
    stats = new_statistics()
    lu = LuCache(system.pattern)
    corr = LinearCorrector(system, lu, ev, stats)
    h, v0 = 1e-4, 0.25
    cj = 1.0 / h
    pred = np.array([[v0], [0.0]])  # x_pred = v0, x'_pred = 0: the implicit Euler step
    ok, x = corr.solve(h, pred, cj, np.ones(1), True)
    assert ok
    assert x[0] == pytest.approx((v0 + 1000.0 * h) / (1.0 + 1000.0 * h), rel=1e-13)
    assert stats["newton_iterations"] == 1 and lu.factorizations == 1
    corr.solve(2 * h, pred, cj, np.ones(1), True)
    assert lu.factorizations == 1  # same cj: no new factorisation


def test_rounding_floor_leaves_attainable_weights_alone():
    system = _rc()
    ev = system.evaluate(np.zeros(1), 0.0, jacobian=True)
    lu = LuCache(system.pattern)
    floor = RoundingFloor(system.pattern, lu)
    w, w_err = np.array([1e6]), np.array([1e6])
    assert floor.weights(w, w_err, np.ones(1), np.ones(1), 1e4) == (w, w_err)  # no factorisation yet
    floor.keep(ev.dq)
    lu.factor(1e4 * ev.dq - ev.dphi, tag=1e4)
    got = floor.weights(w, w_err, np.ones(1), np.ones(1), 1e4)
    assert got[0] is w and got[1] is w_err
    # a tolerance of 1e-30 V is below the rounding level: raised to it
    tiny = np.array([1e30])
    w2, e2 = floor.weights(tiny, tiny, np.ones(1), np.ones(1), 1e4)
    assert w2[0] < 1e20 and e2[0] == w2[0] and tiny[0] == 1e30


def test_probe_measures_the_derivatives_from_the_right():
    system = _rc()
    lu = LuCache(system.pattern)
    floor = RoundingFloor(system.pattern, lu)
    stats = new_statistics()

    def evaluate(x, t, jacobian=False):
        stats["evaluations"] += 1
        return system.evaluate(x, t, jacobian=jacobian)

    v0, eps = 0.25, 1e-9
    p = probe(evaluate, lu, floor, system.names, 0.0, np.array([v0]), eps, np.zeros(1, bool), np.ones(1), np.ones(1))
    assert p.xp[0] == pytest.approx(1000.0 * (1.0 - v0), rel=1e-5)
    assert p.xpp[0] == pytest.approx(-1000.0 * 1000.0 * (1.0 - v0), rel=1e-4)
    assert p.x_right[0] == pytest.approx(v0, abs=1e-12)
    assert p.qp[0] == pytest.approx(1e-6 * 1000.0 * (1.0 - v0))
    assert stats["evaluations"] == 2


def test_probe_reports_a_singular_matrix_as_a_failure():
    system = LinearDae([[0.0]], [[0.0]])
    lu = LuCache(system.pattern)
    with pytest.raises(Failure, match="singular"):
        probe(lambda x, t, j=False: system.evaluate(x, t, jacobian=j), lu, RoundingFloor(system.pattern, lu),
              system.names, 0.0, np.zeros(1), 1e-9, np.zeros(1, bool), np.ones(1), np.ones(1))


def test_jump_of_takes_the_second_euler_step_for_index2_unknowns_only_on_a_value_jump():
    x = np.zeros(3)
    high = np.array([False, False, True])
    w = np.ones(3)
    assert jump_of(x, np.full(3, 0.5), np.full(3, 0.5), w, high)[0] is False
    jumped, value, xr = jump_of(x, np.array([0.0, 0.0, 9.0]), np.array([0.0, 0.0, 7.0]), w, high)
    assert jumped and not value and xr[2] == 9.0  # only an index-2 unknown moved (a corner)
    jumped, value, xr = jump_of(x, np.array([2.0, 0.0, 9.0]), np.array([2.0, 0.0, 7.0]), w, high)
    assert jumped and value and xr.tolist() == [2.0, 0.0, 7.0]


def test_failure_words():
    message, record = failure_record(1.5, 1e-9, "error test failed 10 times", "v(out)", "loosen")
    assert message == "BDF failed: error test failed 10 times at t=1.5, h=1e-09, worst unknown v(out) (hint: loosen)"
    assert record.as_dict() == {"t": 1.5, "h": 1e-9, "worst": "v(out)", "hint": "loosen",
                                "what": "error test failed 10 times", "runaway_order": 0, "runaway": "",
                                "runaway_value": 0.0, "cause": ""}
    assert record.message == message
    err = record.error()
    assert (err.t, err.h, err.worst, err.hint) == (1.5, 1e-9, "v(out)", "loosen")
    names = ("a", "b", "c")
    assert worst_unknown(names, np.array([1.0, -3.0, 2.0]), np.ones(3), np.ones(3)) == "b"
    assert worst_unknown(names, np.array([1.0, 2.0, 3.0]), np.zeros(3), np.array([1.0, 0.0, 0.0])) == "a"
    assert worst_unknown(names, np.array([1.0, np.nan, 3.0]), np.ones(3), np.ones(3)) == "b"


def test_a_function_dae_runs_through_the_parts():
    """A user DAE (no MNA, no compiled engine): Van der Pol in first-order form."""
    from netdae.dae.system import FunctionDae

    mu = 1.0

    def phi(x, t):
        return np.array([x[1], mu * (1.0 - x[0] ** 2) * x[1] - x[0]])

    def dphi(x, t):
        return np.array([[0.0, 1.0], [-2.0 * mu * x[0] * x[1] - 1.0, mu * (1.0 - x[0] ** 2)]])

    system = FunctionDae(2, lambda x: x.copy(), lambda x: np.eye(2), phi, dphi)
    res = integrate(system, (0.0, 2.0), np.array([2.0, 0.0]), rtol=1e-6, atol=1e-9)
    assert res.ok and res.stats["steps"] > 10
    assert res.stats["factorizations"] <= res.stats["newton_iterations"]


_MIXED = """mixed rows: a diode with a junction charge among linear capacitors and an inductor
V1 in 0 SIN(0 1 1k)
R1 in a 1k
C1 a b 1u
D1 b 0 dj
C2 b 0 2u
L1 b c 1m
R2 c 0 100
.model dj d(is=1e-14 cjo=10p)
.tran 10u 1m
.end
"""


def _mixed_system():
    from netdae import load
    from netdae.mna import MODE_TRAN, assemble

    return assemble(load(_MIXED), mode=MODE_TRAN, tstep=1e-5, tstop=1e-3)


def test_charge_history_only_for_the_rows_a_device_stores_charge_in():
    from netdae.dae.bdf.arguments import charge_columns

    system = _mixed_system()
    b = system.index_of("v(b)")
    # the diode's junction charge sits between b and ground: only row b; C1, C2 and L1 are E alone
    assert system.nonlinear_charge_rows().tolist() == [b]
    rows, column = charge_columns(system, linear=False)
    assert rows.tolist() == [b] and column[b] == 0 and np.count_nonzero(column >= 0) == 1
    # every other row's dq/dx is E's, wherever x is (the integrator relies on it)
    x = np.random.default_rng(3).normal(size=system.n)
    dq = system.evaluate(x, 0.0, jacobian=True).dq
    e = system.pattern.data_of(system.E)
    other = np.asarray(system.pattern.rows) != b
    assert np.array_equal(dq[other], e[other])
    assert charge_columns(system, linear=True)[0].size == 0


@pytest.mark.parametrize("path", sorted((Path(__file__).resolve().parent.parent / "netlists").glob("*.cir")),
                         ids=lambda p: p.stem)
def test_rows_outside_the_charge_rows_have_the_constant_dq_of_e(path):
    # what the correction form relies on, for every device family of the example netlists: a row
    # no family names keeps dq/dx = E at any x (and q = E x)
    from netdae import load
    from netdae.mna import MODE_TRAN, assemble

    system = assemble(load(path), mode=MODE_TRAN, tstep=1e-6, tstop=1e-3)
    if system.linear:
        return
    rows = system.nonlinear_charge_rows()
    other = ~np.isin(np.asarray(system.pattern.rows), rows)
    keep = np.ones(system.n, dtype=bool)
    keep[rows] = False
    e = system.pattern.data_of(system.E)
    rng = np.random.default_rng(11)
    for _ in range(3):
        x = rng.uniform(-2.0, 2.0, size=system.n)
        ev = system.evaluate(x, 1e-4, jacobian=True)
        assert np.array_equal(ev.dq[other], e[other])
        assert np.allclose(ev.q[keep], (system.E @ x)[keep], rtol=1e-12, atol=1e-300)


def test_correction_form_rows_solve_the_same_corrector_as_the_charge_form():
    # cj E (x - x_pred) + E x'_pred in the rows without device charge equals
    # cj (E x - q_pred) + q'_pred when the charge history is E times the unknowns'
    from netdae.dae.bdf.corrector import NonlinearCorrector

    system = _mixed_system()
    n = system.n
    rng = np.random.default_rng(7)
    x_pred = 0.1 * rng.normal(size=n)
    xp_pred = 100.0 * rng.normal(size=n)
    ev = system.evaluate(x_pred, 0.0, jacobian=True)
    E = system.pattern.matrix(np.array(system.pattern.data_of(system.E)))
    q_pred = ev.q.copy()
    qp_pred = E @ xp_pred
    rows = system.nonlinear_charge_rows()
    qp_pred[rows] += 1e-9 * rng.normal(size=rows.size)  # the device charge's own derivative
    h = 1e-6
    out = {}
    for name, keep in (("charge", None), ("mixed", rows)):
        lu = LuCache(system.pattern)
        corr = NonlinearCorrector(system, lu, RoundingFloor(system.pattern, lu), new_statistics(), 10, "rms", keep)
        take = np.arange(n) if keep is None else keep
        pred = np.vstack([np.concatenate([x_pred, q_pred[take]]), np.concatenate([xp_pred, qp_pred[take]])])
        ok, (x_new, q_new) = corr.solve(h, pred, 1.0 / h, 0.0, True, None, np.full(n, 1e6))
        assert ok and q_new.shape == (take.size,)
        out[name] = x_new
    assert np.allclose(out["mixed"], out["charge"], rtol=1e-9, atol=1e-12)


def test_rounding_floor_of_correction_form_rows_is_the_resolution_of_x():
    # a source v = u(t) driving C = 10 uF: its current i = C v' is fixed by the capacitor's row only.
    # In correction form, i = cj C (v - v_pred) + C v'_pred with v known to eps |v|: the floor is
    # the charge form's with |E| |x'_pred| for |q'_pred|, growing like 1/h (cj)
    system = LinearDae([[1e-5, 0.0], [0.0, 0.0]], [[0.0, -1.0], [1.0, 0.0]])
    ev = system.evaluate(np.zeros(2), 0.0, jacobian=True)
    w = np.array([1e6, 1e12])  # 1 uV, 1 pA
    x, xp = np.array([1.0, 1e-5]), np.array([-3.0, 0.0])
    for cj in (1e4, 1e12):
        lu = LuCache(system.pattern)
        floor = RoundingFloor(system.pattern, lu)
        floor.keep(ev.dq)
        lu.factor(cj * ev.dq - ev.dphi, tag=cj)
        charge = floor.weights(w, w, x, np.abs(1e-5 * xp), cj)[0]
        correction = floor.weights(w, w, x, np.zeros(0), cj, xp, np.array([-1, -1]))[0]
        mixed = floor.weights(w, w, x, np.array([0.0]), cj, xp, np.array([-1, 0]))[0]
        assert np.array_equal(correction, charge) and np.array_equal(mixed, charge)
        if cj == 1e4:
            assert charge is w  # 10 eps cj C |v| = 2e-17 A
        else:
            assert 0.0 < charge[1] < 1e9  # 2e-8 A at h = 1e-12 s, above the 1 pA asked for
