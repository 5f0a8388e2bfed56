"""Device quantities (``i(r1)``, ``@r1[p]``, ``@c1[i]``, ``@i1[v]`` ...) against hand values and ngspice."""

from __future__ import annotations

import numpy as np
import pytest

import netdae
from netdae.errors import CircuitError
from netdae.signals import DEVICE_QUANTITIES, device_quantity, parse_signal

V1, R1, R2, C1, I1 = 2.0, 1e3, 3e3, 1e-6, 1e-3

DECK = f"""quantities
v1 in 0 dc {V1} ac 1
r1 in out {R1}
c1 out 0 {C1}
r2 out 0 {R2}
i1 0 out {I1}
.op
.dc v1 0 2 0.5
.ac dec 3 10 10k
.end
"""

QUANTITIES = ["@r1[i]", "@r1[p]", "@r2[i]", "@r2[p]", "@c1[i]", "@v1[i]", "@v1[p]", "@i1[v]", "@i1[p]"]


def test_operating_point_by_hand():
    op = netdae.run(DECK, save=["v(out)", "i(r1)", "i(c1)", "i(v1)", *QUANTITIES])[0]
    v = (V1 / R1 + I1) / (1 / R1 + 1 / R2)  # node out: KCL
    i_r1 = (V1 - v) / R1
    assert op["v(out)"][0] == pytest.approx(v, rel=1e-12)
    assert op["i(r1)"][0] == op["@r1[i]"][0] == pytest.approx(i_r1, rel=1e-12)
    assert op["@r1[p]"][0] == pytest.approx(i_r1**2 * R1, rel=1e-12)
    assert op["@r2[i]"][0] == pytest.approx(v / R2, rel=1e-12)
    assert op["i(c1)"][0] == 0.0 and op["@c1[i]"][0] == 0.0
    assert op["@v1[i]"][0] == op["i(v1)"][0] == pytest.approx(-i_r1, rel=1e-12)
    assert op["@v1[p]"][0] == pytest.approx(-V1 * i_r1, rel=1e-12)  # absorbed
    assert op["@i1[v]"][0] == pytest.approx(v, rel=1e-12)  # v(n-) - v(n+), as ngspice
    assert op["@i1[p]"][0] == pytest.approx(-v * I1, rel=1e-12)  # it delivers v I1
    # the powers balance
    total = sum(op[f"@{d}[p]"][0] for d in ("r1", "r2", "v1", "i1"))
    assert abs(total) <= 1e-15 * op["@r2[p]"][0] * 10


def test_dc_sweep_and_ac_currents():
    _, dc, ac = netdae.run(DECK, save=["v(out)", "v(in)", "@r1[i]", "@i1[p]", "@c1[i]", "@r1[p]"])
    np.testing.assert_allclose(dc["@r1[i]"], (dc["v(in)"] - dc["v(out)"]) / R1, rtol=1e-13)
    np.testing.assert_allclose(dc["@i1[p]"], -dc["v(out)"] * I1, rtol=1e-13)
    w = 2 * np.pi * ac.axis
    np.testing.assert_allclose(ac["@c1[i]"], 1j * w * C1 * ac["v(out)"], rtol=1e-13)
    np.testing.assert_allclose(ac["@r1[i]"], (ac["v(in)"] - ac["v(out)"]) / R1, rtol=1e-13)
    np.testing.assert_allclose(ac["@r1[i]"], ac["@c1[i]"] + ac["v(out)"] / R2, rtol=1e-10)  # KCL at out
    assert "@r1[p]" not in ac and any("@r1[p]" in n for n in ac.notes)


@pytest.mark.ngspice
def test_operating_point_and_dc_against_ngspice():
    from netdae.ngspice import run_ngspice

    saves = ".save v(out) " + " ".join(QUANTITIES)
    deck = DECK.replace(".ac dec 3 10 10k\n", "").replace(".end", saves + "\n.end")
    ng = run_ngspice(deck, backend="subprocess")
    ours = netdae.run(deck)
    for kind, mine in zip(("op", "dc"), ours):
        theirs = ng.result(kind)
        for name in QUANTITIES:
            scale = np.max(np.abs(theirs[name])) + 1e-12
            np.testing.assert_allclose(mine[name], theirs[name], atol=1e-9 * scale, err_msg=f"{kind} {name}")


@pytest.mark.ngspice
def test_transient_capacitor_current_against_closed_form_and_ngspice():
    from netdae.ngspice import run_ngspice

    deck = ("rc\nv1 in 0 dc 0 pulse(0 1 0 1n)\nr1 in out 1k\nc1 out 0 1u\n"
            ".save v(out) @r1[i] @c1[i] @c1[p]\n.tran 20u 3m\n.end\n")
    tran = netdae.run(deck)[0]
    t = tran.t
    late = t > 5e-6
    tau = 1e3 * 1e-6
    ref = 1e-3 * np.exp(-t[late] / tau)
    # the capacitor's current equals the resistor's (series) and the closed form, in the tolerances
    assert np.max(np.abs(tran["@c1[i]"][late] - tran["@r1[i]"][late])) <= 2e-3 * 1e-3
    assert np.max(np.abs(tran["@c1[i]"][late] - ref)) <= 5e-3 * 1e-3
    np.testing.assert_allclose(tran["@c1[p]"], tran["@c1[i]"] * tran["v(out)"], rtol=1e-12)
    ng = run_ngspice(deck, backend="subprocess").result("tran")
    mine = np.interp(ng.t, t, tran["@c1[i]"])
    sel = ng.t > 5e-5
    assert np.max(np.abs(mine[sel] - ng["@c1[i]"][sel])) <= 1e-2 * 1e-3
    # the dense output carries the quantity (for .meas)
    mid = tran.dense(np.array([1e-3]))
    assert mid["@c1[i]"][0] == pytest.approx(1e-3 * np.exp(-1.0), rel=5e-3)


def test_bad_names_are_located_errors():
    with pytest.raises(CircuitError, match=r"'r1' is a resistor, which has no quantity 'q'.*@r1\[i\].*@r1\[p\]"):
        netdae.run(DECK, save=["@r1[q]"])
    with pytest.raises(CircuitError, match="cannot save '@r9\\[i\\]': no element 'r9' in the circuit"):
        netdae.run(DECK, save=["@r9[i]"])


def test_vocabulary():
    assert device_quantity(parse_signal("i(c1)"), "capacitor") == "i"
    assert device_quantity(parse_signal("i(l1)"), "inductor") is None
    for kind, quantities in DEVICE_QUANTITIES.items():
        for q in quantities:
            assert device_quantity(parse_signal(f"@x[{q}]"), kind) == q


@pytest.mark.ngspice
@pytest.mark.parametrize("backend", ["subprocess", "shared"])
def test_compare_asks_ngspice_for_the_quantities(backend):
    from netdae.comparison.run import compare
    from netdae.ngspice.shared import library_path

    if backend == "shared" and library_path() is None:
        pytest.skip("ngspice's shared library is not installed")
    deck = ("rc\nv1 in 0 dc 1 pulse(1 2 1m 1u)\nr1 in out 1k\nc1 out 0 1u\nr2 out 0 2k\n"
            ".save v(out) i(r1) i(c1) @r2[p] @v1[p]\n.op\n.tran 20u 3m\n.end\n")
    cmp = compare(deck, backend=backend)
    for item in cmp.analyses:
        names = {s.name for s in item.signals}
        assert {"i(r1)", "@r2[p]", "@v1[p]"} <= names, (item.analysis, names)
        if item.analysis == "tran":
            assert "i(c1)" in names
        assert item.passed, item.analysis


def test_simulate_and_sweep_keep_quantities():
    deck = "rc\nv1 in 0 dc 1\nr1 in out 1k\nc1 out 0 1u ic=0\n.param rr=1k\nr2 out 0 {rr}\n.tran 20u 2m uic\n.end\n"
    r = netdae.simulate(deck, save=["v(out)", "i(c1)", "@r2[p]"])
    assert r.names() == ["v(out)", "i(c1)", "@r2[p]"]
    np.testing.assert_allclose(r["@r2[p]"], r["v(out)"] ** 2 / 1e3, rtol=1e-12)
    sw = netdae.sweep(deck.replace(".tran 20u 2m uic", ".op"), params={"rr": [1e3, 3e3]}, save=["@r2[i]"])
    np.testing.assert_allclose(np.ravel(sw.waveform("@r2[i]")[1]), [0.5e-3, 0.25e-3], rtol=1e-12)


@pytest.mark.ngspice
def test_savecurrents_gives_ngspice_vectors():
    from netdae.ngspice import run_ngspice

    deck = ("sc\nv1 in 0 2\nr1 in out 1k\nc1 out 0 1u\nl1 out mid 1m\nr2 mid 0 3k\ni1 out 0 1m\n"
            ".options savecurrents\n.op\n.end\n")
    ours = netdae.run(deck)[0]
    theirs = run_ngspice(deck, backend="subprocess").result("op")
    at = sorted(n for n in theirs.names() if n.startswith("@"))
    assert at == sorted(n for n in ours.names() if n.startswith("@"))
    assert at == ["@c1[i]", "@i1[current]", "@l1[i]", "@r1[i]", "@r2[i]"]
    assert ours["@l1[i]"][0] == pytest.approx(ours["v(mid)"][0] / 3e3, rel=1e-12)
    for name in at:
        assert ours[name][0] == pytest.approx(theirs[name][0], rel=1e-9, abs=1e-15), name
    assert not any("savecurrents" in n for n in ours.notes)


def test_measurements_of_quantities():
    deck = ("rc\nv1 in 0 dc 0 pulse(0 1 0 1n)\nr1 in out 1k\nc1 out 0 1u\n.tran 20u 3m\n"
            ".meas tran pmax max @r1[p] from=0.1m\n.meas tran ic find i(c1) at=1m\n.end\n")
    for save in (None, ["v(out)"]):
        tran = netdae.run(deck, save=save)[0]
        got = {m.name: m.value for m in tran.measures}
        assert got["ic"] == pytest.approx(1e-3 * np.exp(-1.0), rel=2e-3)
        assert got["pmax"] == pytest.approx(1e-3 * np.exp(-0.2), rel=2e-3)  # i^2 R at t = 0.1 ms
    with pytest.raises(netdae.NetlistError, match=r"'r1' is a resistor, which has no quantity 'zz'"):
        netdae.load(deck.replace("@r1[p]", "@r1[zz]"))


@pytest.mark.parametrize("read", ["avg v(in)", "integ i(c1)"])
def test_the_saved_note_says_what_the_result_holds_when_a_measurement_reads_more(read):
    """A .meas reading a signal outside ``save`` (a node, a device current computed after the run):
    the run keeps it for the measurement, the result holds the selection, and its note says so;
    without a selection the note says every unknown is kept. Closed form: the RC's charge current
    over the first millisecond integrates to C (1 - e^-1)."""
    text = ("rc\nv1 in 0 pulse(0 1 0 1n 1n 1m 2m)\nr1 in out 1k\nc1 out 0 1u\n.tran 1u 2m\n"
            f".meas tran m {read} from=0 to=1m\n.end\n")
    r = netdae.run(netdae.load(text), save=["v(out)"])[0]
    assert r.names() == ["v(out)"]
    assert [n for n in r.notes if n.startswith("saved: ")] == ["saved: v(out)"]
    expected = 1e-6 * (1 - np.exp(-1)) if read.startswith("integ") else 1.0
    assert r.measures[0].value == pytest.approx(expected, rel=1e-3)
    every = netdae.run(netdae.load(text))[0]
    assert [n for n in every.notes if n.startswith("saved: ")] == ["saved: all unknowns"]
