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


def test_crossings_solve_only_the_one_asked_for_and_a_quantity_is_sampled_once():
    circuit = load(SINE)
    (res,) = run(dataclasses.replace(circuit, measures=[]))
    calls = []

    def counted(t, _dense=res.dense):
        calls.append(1)
        return _dense(t)

    measures = evaluate_measures(circuit.measures, {"tran": dataclasses.replace(res, dense=counted)})
    assert all(m.ok for m in measures), [m.reason for m in measures]
    # 50 periods: 50 rises through 0.3 and 80 crossings of 0.1 and 0.2 up to the 40th rise; solving
    # each on the interpolant took thousands of evaluations. Now: one sampling of v(out), its
    # extremes refined, and the root of each crossing asked for (a few dozen evaluations each).
    assert len(calls) < 120, len(calls)  # (1,820 before)
