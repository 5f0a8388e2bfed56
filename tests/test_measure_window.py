"""``.meas`` on the window a transient measures: from its ``tstart`` on, not from its first kept point.

An RC low-pass (tau = 0.1 ms) driven by ``0.2 + sin(2 pi 1k t)`` from rest has the closed form
``v(out) = 0.2 (1 - e^(-t/tau)) + A sin(w t - phi) + A sin(phi) e^(-t/tau)`` with
``A = 1/sqrt(1 + (w tau)^2)`` and ``phi = atan(w tau)``. ngspice's values converge to these
integrals over ``[tstart, tstop]`` as its steps shrink (``.tran 1u 3m 1m 5n``, reltol 1e-7:
``INTEG`` 4.00003e-04, ``AVG`` 2.000017e-01, ``RMS`` 6.31252e-01).
"""

from __future__ import annotations

import math

import pytest

from netdae.analyses.runner import run

TAU, W = 1e-4, 2 * math.pi * 1e3
A, PHI = 1 / math.sqrt(1 + (W * TAU) ** 2), math.atan(W * TAU)
K = A * math.sin(PHI)


def _integral(t0: float, t1: float) -> float:
    """The closed-form integral of v(out) over [t0, t1]."""
    def prim(t):
        e = math.exp(-t / TAU)
        return 0.2 * (t + TAU * e) - A / W * math.cos(W * t - PHI) - K * TAU * e
    return prim(t1) - prim(t0)


NETLIST = """rc from tstart
V1 in 0 SIN(0.2 1 1k)
R1 in out 1k
C1 out 0 100n
.tran 1u 3m 1m
.meas tran area INTEG v(out)
.meas tran mean AVG v(out)
.meas tran area2 INTEG v(out) FROM=0.5m TO=2m
.meas tran start FIND v(out) AT=1m
.end
"""


def test_window_starts_at_tstart():
    (res,) = run(NETLIST)
    m = {x.name: x for x in res.measures}
    assert all(x.ok for x in m.values()), [x.reason for x in m.values()]
    # the first kept point lies a part of a step after tstart; the window is from tstart itself
    assert res.axis[0] > 1e-3
    assert m["area"].value == pytest.approx(_integral(1e-3, 3e-3), rel=2e-5)
    assert m["mean"].value == pytest.approx(_integral(1e-3, 3e-3) / 2e-3, rel=2e-5)
    assert m["area2"].value == pytest.approx(_integral(1e-3, 2e-3), rel=2e-5)
    assert m["area"].extra["from"] == 1e-3
    t = 1e-3
    exact = 0.2 * (1 - math.exp(-t / TAU)) + A * math.sin(W * t - PHI) + K * math.exp(-t / TAU)
    assert m["start"].value == pytest.approx(exact, abs=1e-4)


TRIANGLE = """trig and targ windows
V1 in 0 PWL(0 0 1m 1 2m 0 3m 1 4m 0 5m 1 6m 0)
R1 in 0 1k
.tran 10u 6m
.meas tran a TRIG v(in) VAL=0.5 RISE=1 FROM=2m TARG v(in) VAL=0.5 FALL=1
.meas tran b TRIG v(in) VAL=0.5 RISE=1 TARG v(in) VAL=0.5 FALL=1 FROM=2m
.meas tran c TRIG v(in) VAL=0.5 RISE=LAST TARG v(in) VAL=0.5 FALL=1 TO=4m
.meas tran d TRIG v(in) VAL=0.5 RISE=LAST TO=4m TARG v(in) VAL=0.5 FALL=LAST
.meas tran e TRIG v(in) VAL=0.5 RISE=1 FROM=1m TD=3m TARG v(in) VAL=0.5 FALL=1 FROM=2m TO=3m
.meas tran f TRIG v(in) VAL=0.5 RISE=2 TARG v(in) VAL=0.5 FALL=1 FROM=4m
.end
"""


def test_trig_targ_from_to():
    """FROM= and TO= in TRIG and TARG clauses, as ngspice 39 reads them (measured: a clause without
    FROM= takes the other clause's FROM=, TO= is the clause's own, TD= and FROM= both hold).

    The triangle rises through 0.5 at 0.5, 2.5 and 4.5 ms and falls through it at 1.5, 3.5 and 5.5 ms.
    """
    (res,) = run(TRIANGLE)
    m = {x.name: x for x in res.measures}
    expect = {"a": (2.5e-3, 3.5e-3), "b": (2.5e-3, 3.5e-3), "c": (4.5e-3, 1.5e-3), "d": (2.5e-3, 5.5e-3)}
    for name, (trig, targ) in expect.items():
        assert m[name].ok, (name, m[name].reason)
        assert m[name].extra["trig"] == pytest.approx(trig, abs=1e-12), name
        assert m[name].extra["targ"] == pytest.approx(targ, abs=1e-12), name
        assert m[name].value == pytest.approx(targ - trig, abs=1e-12), name
    # TD=3m and FROM=1m: the trigger's window starts at 3 ms; no fall in the target's [2m, 3m]
    assert not m["e"].ok and "TARG" in m["e"].reason and "[0.002, 0.003]" in m["e"].reason
    # the trigger counts its rises from the target's FROM=4m: one, the second asked
    assert not m["f"].ok and "TRIG" in m["f"].reason and "the second was asked" in m["f"].reason


PLATEAU = """extremes on a plateau
V1 in 0 PULSE(0 1 1u 1u 1u 5u 12u)
R1 in out 1k
C1 out 0 1n
.tran 0.05u 40u
.meas tran top MAX_AT v(in)
.meas tran top2 MAX v(in) FROM=10u
.meas tran low MIN_AT v(in) FROM=9u
.end
"""


def test_extreme_on_a_plateau_is_where_it_begins():
    """A pulse's plateau is one value to rounding; the interpolant's last bits there used to pick
    an arbitrary point of it (15.2 us, in the second pulse). The extreme is where the stretch begins."""
    (res,) = run(PLATEAU)
    m = {x.name: x for x in res.measures}
    assert m["top"].value == pytest.approx(2e-6, abs=1e-15)      # the first plateau starts at 2 us
    assert m["top2"].value == pytest.approx(1.0, abs=1e-12)
    assert m["top2"].at == pytest.approx(14e-6, abs=1e-15)       # the first at or after FROM=10u
    assert m["low"].value == pytest.approx(9e-6, abs=1e-15)      # the fall ends at 8 us: the window's start


SWEEPS = """td in sweeps
V1 in 0 0 AC 1
R1 in a 1k
R2 a 0 1k
C1 a 0 100n
.dc V1 5 -5 -0.5
.ac dec 20 10 1meg
.meas dc w1 WHEN v(a)=1 TD=3
.meas dc w2 TRIG v(a) VAL=-1 FALL=1 TD=-4 TARG v(a) VAL=-2 FALL=1
.meas dc w3 WHEN v(a)=1 FROM=3
.meas ac f3 WHEN vdb(a)=-9 TD=100k
.end
"""


def test_td_is_not_read_in_ac_and_dc_measurements():
    """ngspice 39 reads TD= in a transient's measurements only (measured: ``.dc V1 -5 5 0.5``,
    ``WHEN v(a)=1 TD=3`` gives 2, and ``.meas ac ... TD=10k`` the crossing at 1.6 kHz); netdae
    ignores it there too, with a warning at TD= that names FROM=."""
    from netdae.netlist import load

    circuit = load(SWEEPS)
    warned = [d.message for d in circuit.diagnostics if "TD= has no effect on a .meas" in d.message]
    assert len(warned) == 3 and "FROM=" in warned[0]
    results = run(circuit)
    m = {x.name: x for r in results for x in r.measures}
    assert m["w1"].value == pytest.approx(2.0, rel=1e-12)         # v(a) = v1/2 falls through 1 at v1 = 2
    assert m["w2"].value == pytest.approx(-4.0 - -2.0, rel=1e-12)  # trig at v1 = -2, targ at -4: TD=-4 not read
    assert not m["w3"].ok                                        # FROM= holds: [3, 5] has no crossing of 1
    # 1/(1 + j w R C/2) / 2 at -9 dB (|.| = 0.3548): w RC/2 = sqrt((0.5/0.3548)^2 - 1)
    f = ((0.5 / 10 ** (-9 / 20)) ** 2 - 1) ** 0.5 / (3.141592653589793 * 1e3 * 100e-9)
    assert m["f3"].value == pytest.approx(f, rel=2e-3)


def test_peak_to_peak_of_a_plateau_is_zero():
    """The interpolant's last bits wander on a pulse's plateau (1 +- 2 ulps): PP read 1.1e-15 there,
    ngspice 0; extremes within 32 roundings of each other are one value."""
    (res,) = run(PLATEAU.replace(".end", ".meas tran flat PP v(in) FROM=2u TO=6u\n"
                                          ".meas tran edge PP v(in) FROM=1.5u TO=6u\n.end"))
    m = {x.name: x for x in res.measures}
    assert m["flat"].value == 0.0
    assert m["edge"].value == pytest.approx(0.5, abs=1e-12)  # from 0.5 at 1.5 us up to the plateau


def test_a_window_beside_find_at_is_not_read_as_in_ngspice():
    """ngspice 39 accepts ``FIND sig AT=x`` followed by ``FROM=``, ``TO=`` or ``TD=`` and gives the value at x
    whatever the window (measured: all equal to the card without it); with both ``FROM=`` and ``TO=`` it prints
    no value. netdae reads the same value with a warning at the keyword, and refuses both together."""
    from netdae.errors import NetlistError
    from netdae.netlist import load

    text = NETLIST.replace(".meas tran start FIND v(out) AT=1m",
                           ".meas tran start FIND v(out) AT=1m\n.meas tran s1 FIND v(out) AT=1m FROM=2m\n"
                           ".meas tran s2 FIND v(out) AT=1m TD=2m\n.meas tran s3 DERIV v(out) AT=1m TO=0.5m")
    circuit = load(text)
    warned = [d.message for d in circuit.diagnostics if "has no effect on" in d.message and "AT=" in d.message]
    assert len(warned) == 3 and warned[0].startswith(".meas: FROM=") and warned[2].startswith(".meas: TO=")
    (res,) = run(circuit)
    m = {x.name: x for x in res.measures}
    assert m["s1"].value == m["start"].value and m["s2"].value == m["start"].value and m["s3"].ok
    with pytest.raises(NetlistError, match=r"AT= with both FROM= and TO=") as info:
        load(NETLIST.replace("AT=1m", "AT=1m FROM=0.5m TO=2m"))
    assert info.value.location is not None and info.value.location.line == 9
