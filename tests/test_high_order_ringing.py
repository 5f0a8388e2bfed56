"""BDF orders 3-5 can grow a lightly damped resonance that the steps follow; orders 1-2 cannot.

A 60 Hz centre-tapped rectifier (K = 0.999, diodes with transit time and junction capacitance):
at 20.69 ms a diode's reverse recovery snaps off and rings with the leakage inductance at
about 16 MHz. At the default orders (up to 5) the ringing grew in the integration and the run
failed with "the solution ran away". The circuit is passive (its pencil at the start has no
eigenvalue in the right half-plane), so the growth is the integrator's: netdae runs such a
transient again at orders 1-2 and says so, and that run agrees with ngspice's converged values
(docs/integrator.md, "Known limitations"). A maximum order the user set is kept.

Reference: ngspice 39 at ``reltol=1e-7`` on the same netlist (``.meas`` in a ``.control`` block):
average 15.45278 V, ripple 2.444196 V over 30-40 ms.
"""

from __future__ import annotations

import numpy as np
import pytest

import netdae
from netdae.dae.bdf.failures import runaway

RINGING = """Full-wave rectifier, centre-tapped transformer, diodes with tt and cjo
Vac ac 0 SIN(0 170 60)
Rp ac p 1
Lp p 0 1
Ls1 s1 0 0.01
Ls2 0 s2 0.01
K1 Lp Ls1 0.999
K2 Lp Ls2 0.999
K3 Ls1 Ls2 0.999
D1 s1 out dr
D2 s2 out dr
C1 out 0 2200u
Rl out 0 20
.model dr d is=1e-9 rs=0.02 cjo=200p tt=5u
.options maxord=2
.tran 10u 40m
.meas tran vavg avg v(out) from=30m to=40m
.meas tran vpp pp v(out) from=30m to=40m
.end
"""


def _tran(text: str):
    return next(r for r in netdae.run(netdae.load(text)) if r.analysis == "tran")


def _has_ngspice_ripple(tran) -> None:
    assert tran.ok, tran.message
    m = {x.name: x.value for x in tran.measures}
    assert m["vavg"] == pytest.approx(15.45278, rel=3e-4)
    assert m["vpp"] == pytest.approx(2.444196, rel=2e-3)


def test_a_ringing_rectifier_at_the_a_stable_orders_gives_the_converged_ripple():
    _has_ngspice_ripple(_tran(RINGING))


def test_a_circuit_without_gain_that_ran_away_at_high_orders_is_run_again_at_orders_1_2():
    tran = _tran(RINGING.replace(".options maxord=2\n", ""))
    assert any("run again from the start at orders 1-2" in n for n in tran.notes), tran.notes
    assert tran.tolerances["maxord"] == 2
    _has_ngspice_ripple(tran)


def test_a_maximum_order_the_user_set_is_kept():
    tran = _tran(RINGING.replace(".options maxord=2", ".options maxord=5"))
    assert not tran.ok
    assert "the solution ran away" in tran.message and "maxord=2" in tran.message


def test_the_runaway_message_names_the_high_orders():
    names, kinds = ["v(a)", "i(l1)"], np.array([0, 1])
    start, end = np.array([1.0, 1e-3]), np.array([3e18, 2e12])
    assert "maxord=2" in runaway(names, kinds, start, end, max_order=5)
    assert "maxord=2" not in runaway(names, kinds, start, end, max_order=2)


def test_a_file_streamed_by_the_run_that_ran_away_holds_the_second_run(tmp_path):
    """``netdae run --out`` streams the first run's points to the file as they come; the run again replaces
    them: the file ends at tstop and agrees with the second run's result."""
    from netdae.cli import main
    from netdae.io.csv import read_csv

    net = tmp_path / "ringing.cir"
    net.write_text(RINGING.replace(".options maxord=2\n", ""))
    assert main(["run", str(net), "--out", str(tmp_path / "o"), "-q"]) == 0
    res = read_csv(tmp_path / "o" / "tran.csv")
    t, v = np.asarray(res.axis), np.asarray(res["v(out)"])
    assert t[-1] == pytest.approx(40e-3) and np.all(np.diff(t) >= 0)
    late = t >= 30e-3
    assert np.ptp(v[late]) == pytest.approx(2.444196, rel=5e-3)
