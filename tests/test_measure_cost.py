"""What a transient's measurements cost: dense evaluations, counted (the values are tested elsewhere)."""

from __future__ import annotations

import dataclasses

from netdae.analyses.measure import evaluate_measures
from netdae.analyses.runner import run
from netdae.netlist import load

SINE = """many crossings
V1 in 0 SIN(0 1 10k)
R1 in out 1k
C1 out 0 10n
.tran 1u 5m
.meas tran last WHEN v(out)=0.3 RISE=LAST
.meas tran far TRIG v(out) VAL=0.1 RISE=40 TARG v(out) VAL=0.2 RISE=40
.meas tran top MAX v(out)
.meas tran bottom MIN v(out)
.meas tran swing PP v(out)
.end
"""


def _counting(circuit):
    """The circuit's transient without its measures, its dense output counting its calls: ``(result, calls)``."""
    (res,) = run(dataclasses.replace(circuit, measures=[]))
    calls = []

    def counted(t, _dense=res.dense):
        calls.append(1)
        return _dense(t)

    return dataclasses.replace(res, dense=counted), calls


def test_crossings_solve_only_the_one_asked_for_and_a_quantity_is_sampled_once():
    circuit = load(SINE)
    res, calls = _counting(circuit)
    measures = evaluate_measures(circuit.measures, {"tran": res})
    assert all(m.ok for m in measures), [m.reason for m in measures]
    # 50 periods: 50 rises through 0.3 and 80 crossings of 0.1 and 0.2 up to the 40th rise; solving
    # each on the interpolant took thousands of evaluations. Now: one sampling of v(out), its
    # extremes refined, and the root of each crossing asked for (a few dozen evaluations each).
    assert len(calls) < 120, len(calls)  # (1,820 before)


def test_a_windows_ends_come_with_its_steps_inner_points_and_have_their_own_values():
    """A window inside the run samples its steps' inner points and its two ends in one dense evaluation,
    and gets the values two separate evaluations give, bit for bit."""
    import numpy as np

    from netdae.analyses.measure import _Trace

    circuit = load(SINE)
    res, calls = _counting(circuit)
    probe = circuit.measures[2].probe
    trace = _Trace(res, probe)
    x, y = trace.samples(1.03e-3, 3.57e-3)
    assert len(calls) == 1
    alone = _Trace(res, probe)
    assert x[0] == 1.03e-3 and x[-1] == 3.57e-3
    assert np.array_equal(y[[0, -1]], alone.at([1.03e-3, 3.57e-3]))
    inner = ~np.isin(x[1:-1], alone.x)  # the steps' inner points (the steps' own points are the results')
    assert inner.sum() > 100 and np.array_equal(y[1:-1][inner], alone.dense(x[1:-1][inner]))
