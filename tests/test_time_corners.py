"""Behavioural expressions that jump or kink in time: their corners are breakpoints.

``B1 0 1 I = time < 1m ? 1 : 2`` steps its current at 1 ms. Without a breakpoint
there the step control meets a jump it cannot resolve (an algebraic unknown
follows it: every step across 1 ms fails the error test down to the rounding
of t). The corners are found structurally (:func:`netdae.netlist.expr.time_corners`)
where the quantities that meet are affine in ``time``; a step landing on one
evaluates the equations just before it (the left value), and the restart
takes the right value. Checked against the closed forms of the waveforms and
against ngspice 39, in both integrators.
"""

from __future__ import annotations

import numpy as np
import pytest

import netdae
from netdae.netlist import load
from netdae.netlist.expr import BEHAVIOURAL, parse_expression, time_corners


def corners(text, t0=0.0, t1=1.0):
    return sorted(set(round(c, 15) for c in time_corners(parse_expression(text, context=BEHAVIOURAL), t0, t1)))


@pytest.mark.parametrize("text, expected", [
    ("time < 1m ? 1 : 2", [1e-3]),
    ("(time*2 >= 0.5) * 3", [0.25]),
    ("(0.2 - time)/2 > 0 && time > 0.1", [0.1, 0.2]),
    ("u(time - 0.3) + sgn(time - 0.4)", [0.3, 0.4]),
    ("abs(time - 0.5) + uramp(0.6 - time)", [0.5, 0.6]),
    ("max(time, 0.7) + min(0.25, time) + limit(time, 0.1, 0.9)", [0.1, 0.25, 0.7, 0.9]),
    ("pwl(time, 0, 0, 0.2, 1, 0.8, 1)", [0.0, 0.2, 0.8]),
    ("floor(time/0.25)", [0.0, 0.25, 0.5, 0.75, 1.0]),
    ("nint(4*time)", [0.125, 0.375, 0.625, 0.875]),
    ("time % 0.5", [0.0, 0.5, 1.0]),
    ("time > 2 ? 1 : 0", []),                      # outside the interval
    ("v(a) > 1 ? time : 0", []),                   # a corner of the circuit, not of time
    ("sin(time) > 0.5", []),                       # not affine: the step control meets it
    ("time*time < 0.25", []),
])
def test_corners_of_expressions(text, expected):
    assert corners(text) == pytest.approx(expected, abs=1e-15)


def test_a_periodic_function_contributes_at_most_the_limit():
    tree = parse_expression("floor(time/1n)", context=BEHAVIOURAL)
    assert time_corners(tree, 0.0, 1.0, limit=100) == []
    assert len(time_corners(tree, 0.0, 100.5e-9, limit=1000)) == 101


STEP = """time step into an RC
B1 0 1 I = time < 1m ? 1m : 2m
R1 1 0 1k
C1 1 0 1u
R2 2 0 R = (time < 1.5m ? {rl} : {rl/2})
V2 2 0 1
.param rl=100
.tran 10u 3m
.end
"""


@pytest.mark.parametrize("engine", ["compiled", "python"])
def test_steps_in_time_follow_the_closed_form(engine, monkeypatch):
    if engine == "python":
        monkeypatch.setenv("NETDAE_ENGINE", "python")
    res = netdae.simulate(load(STEP), reltol=1e-6)
    t = np.linspace(0.0, 3e-3, 301)
    tau = 1e-3
    # the operating point holds v(1) = 1 V until the current steps to 2 mA at 1 ms
    v_exact = np.where(t < 1e-3, 1.0, 2.0 - np.exp(-(t - 1e-3) / tau))
    dense = res.dense(t)
    v = dense["v(1)"]
    assert np.max(np.abs(v - v_exact)) < 1e-4
    i2 = dense["i(v2)"]
    assert i2[t < 1.49e-3] == pytest.approx(-0.01, rel=1e-9)
    assert i2[t > 1.51e-3] == pytest.approx(-0.02, rel=1e-9)
    assert 1.5e-3 in res.axes["time"] and 1e-3 in res.axes["time"]


@pytest.mark.ngspice
def test_steps_in_time_agree_with_ngspice():
    from netdae.comparison import compare

    result = compare(STEP, tight=True)
    assert result.ngspice_error is None
    item = result.analysis("tran", 0)
    assert item.passed, [(s.name, s.max_rel) for s in item.signals]
