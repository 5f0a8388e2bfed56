"""Switch quantities @s1[i], @s1[p], @w1[i], @w1[p]: the current by the switch's state at each point.

The state is the one the analysis used (hysteresis along a sweep, the integrator's events in a
transient), so the switch's current equals what Kirchhoff's current law gives from the circuit's
own solution, to rounding.
"""

from __future__ import annotations

import numpy as np
import pytest

import netdae

SERIES = 100.0  # the resistor feeding each switch from a 1 V source


def _kcl(res, switch_current, node):
    """The switch current KCL gives: the 1 V source through 100 ohm into ``node``."""
    return (1.0 - res[node]) / SERIES, res[switch_current]


def test_operating_point_closed_form():
    deck = """op
vc c 0 2
vs s 0 1
rs s ss 100
s1 ss 0 c 0 swm
.model swm sw vt=1 ron=10 roff=1meg
rw s ww 100
w1 ww 0 vs wm
.model wm csw it=1 ron=5 roff=1meg
.op
.end
"""
    op = netdae.run(deck, save=["@s1[i]", "@s1[p]", "@w1[i]", "@w1[p]"])[0]
    i_on = 1.0 / (SERIES + 10.0)  # s1 on (2 V > vt)
    i_off = 1.0 / (SERIES + 1e6)  # w1 off (its control current is far below 1 A)
    assert op["@s1[i]"][0] == pytest.approx(i_on, rel=1e-12)
    assert op["@s1[p]"][0] == pytest.approx(i_on**2 * 10.0, rel=1e-12)
    assert op["@w1[i]"][0] == pytest.approx(i_off, rel=1e-12)
    assert op["@w1[p]"][0] == pytest.approx(i_off**2 * 1e6, rel=1e-12)


@pytest.mark.parametrize("direction", ["up", "down"])
def test_dc_sweep_follows_the_hysteresis(direction):
    """Inside the band (0.8 .. 1.2 V) the state depends on where the sweep came from."""
    sweep = "0 2 0.05" if direction == "up" else "2 0 -0.05"
    deck = f"""dc
vc c 0 0
vs s 0 1
rs s ss 100
s1 ss 0 c 0 swm
.model swm sw vt=1 vh=0.2 ron=10 roff=1meg
.dc vc {sweep}
.end
"""
    res = netdae.run(deck, save=["@s1[i]", "v(ss)", "v(c)"])[0]
    expected, got = _kcl(res, "@s1[i]", "v(ss)")
    assert np.max(np.abs(got - expected)) < 1e-12
    band = (res["v(c)"] > 0.85) & (res["v(c)"] < 1.15)
    on = got[band] > 1e-3
    assert on.all() if direction == "down" else not on.any()


def test_transient_events():
    """Through the switching events (left and right limits at one time) the current is KCL's at every point."""
    deck = """tran
vc c 0 pulse(0 2 1u 10n 10n 2u 5u)
vs s 0 1
rs s ss 100
s1 ss 0 c 0 swm
.model swm sw vt=1 vh=0.2 ron=10 roff=1meg
vw w 0 sin(0 2 100k)
rw w 0 1k
rp s pp 100
w1 pp 0 vw wm
.model wm csw it=0.5m ih=0.1m ron=5 roff=1meg
.tran 10n 20u
.end
"""
    res = netdae.run(deck, save=["@s1[i]", "@s1[p]", "v(ss)", "@w1[i]", "@w1[p]", "v(pp)"])[0]
    for switch, node in (("@s1[i]", "v(ss)"), ("@w1[i]", "v(pp)")):
        expected, got = _kcl(res, switch, node)
        assert np.max(np.abs(got - expected)) < 1e-12, switch
    names = {name for _, names in res.transient.events for name in names}
    assert names == {"s1", "w1"}
    on = res["@s1[i]"] > 1e-3
    changes = int(np.count_nonzero(on[1:] != on[:-1]))
    assert changes == sum("s1" in names for _, names in res.transient.events)
    assert np.allclose(res["@s1[p]"], res["@s1[i]"] * res["v(ss)"], rtol=1e-14, atol=0)
