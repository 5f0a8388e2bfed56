"""A behavioural source's comparison, or a switch, that changes exactly at the end of the transient.

``V1 in 0 PWL(0 0 1m 1)`` and ``B1 o 0 V=floor(v(in))`` over ``.tran 10u 1m``: the ramp reaches 1
at tstop, where ``floor`` changes from 0 to 1. The last step landed on tstop, found the change
at its end and finished before the event was recorded or the value after it solved: the run ended
at v(o) = 0, the left limit, where the expression at the point is 1 (ngspice: 1). Both integrators
now record the event and the right limit at tstop (two points there, as at any jump), then finish.
Oracle: the expressions' values at the point.
"""

from __future__ import annotations

import numpy as np
import pytest

import netdae

RAMP = "V1 in 0 PWL(0 0 1m 1)\n"


def _run(body: str, engine: str, monkeypatch):
    monkeypatch.setenv("NETDAE_ENGINE", engine)
    r = netdae.simulate(netdae.load("change at tstop\n" + body + "R1 o 0 1k\n.tran 10u 1m\n.end\n"))
    assert r.ok, r.message
    return r


@pytest.mark.parametrize("engine", ["compiled", "python"])
@pytest.mark.parametrize("law, before, after", [("floor(v(in))", 0.0, 1.0),
                                                ("v(in) >= 1 ? 5 : 0", 0.0, 5.0)])
def test_a_comparison_that_changes_at_tstop_ends_on_its_new_value(engine, law, before, after, monkeypatch):
    r = _run(RAMP + f"B1 o 0 V={law}\n", engine, monkeypatch)
    t, v = r.t, r["v(o)"]
    assert t[-1] == 1e-3
    assert v[-1] == pytest.approx(after, abs=1e-9)
    # both limits at tstop: the value before the change, then after it
    assert t[-2] == 1e-3 and v[-2] == pytest.approx(before, abs=1e-6)
    # and nowhere before tstop did it change
    np.testing.assert_allclose(v[t < 1e-3], before, atol=1e-6)
    assert any(abs(t_event - 1e-3) <= 1e-12 for t_event, _ in r.transient.events), r.transient.events


@pytest.mark.parametrize("engine", ["compiled", "python"])
def test_a_comparison_that_changes_before_tstop_is_unchanged(engine, monkeypatch):
    """The same law crossing mid-run (v(in) = 1 at 2/3 ms): both limits there, the run goes on to tstop."""
    r = _run("V1 in 0 PWL(0 0 1m 1.5)\nB1 o 0 V=floor(v(in))\n", engine, monkeypatch)
    t, v = r.t, r["v(o)"]
    assert t[-1] == 1e-3 and t[-2] < 1e-3 and v[-1] == pytest.approx(1.0, abs=1e-9)
    at = np.flatnonzero(np.isclose(t, 1e-3 / 1.5, rtol=1e-9, atol=0))
    assert at.size == 2 and v[at[0]] == pytest.approx(0.0, abs=1e-6) and v[at[1]] == pytest.approx(1.0, abs=1e-6)
