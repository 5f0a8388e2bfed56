"""ngspice's uniform RC line (U elements, ``.model ... urc``) as the lumped network ngspice builds (netdae.netlist.urc).

Closed forms: the lumps' series resistances add up to ``l rperl`` (the DC resistance) and their
capacitances to ``l cperl`` (the line's admittance at low frequency is ``j w l cperl`` when both
ends are driven). Against ngspice 39: every node of the network, internal ones included (ngspice
names them as netdae does, ``u1#hi1``), in a transient and an AC sweep, in units of the relative
tolerance 1e-3 of each signal's scale.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import netdae
from netdae.analyses.tran import transient
from netdae.errors import NetlistError
from netdae.netlist import urc

#: The relative tolerance the comparisons are measured in.
TOL = 1e-3


@pytest.mark.parametrize("model, inst", [("rperl=10k cperl=1p", "l=1m"), ("k=2 rperl=50 cperl=3p fmax=100g", "l=2"),
                                         ("rperl=1k cperl=1n", "l=0.5 n=7")])
def test_dc_resistance_is_the_lines(model, inst):
    """At DC the line is its resistance l * rperl between its ends (a divider into a load)."""
    ckt = netdae.load(f"t\nV1 a 0 1\nU1 a b 0 um {inst}\nRl b 0 3k\n.model um urc {model}\n.op\n.end\n")
    params = dict(kv.split("=") for kv in model.split())
    length = netdae.netlist.numbers.parse_number(inst.split()[0][2:])
    r0 = length * netdae.netlist.numbers.parse_number(params["rperl"])
    (res,) = netdae.run(ckt)
    assert res["v(b)"][0] == pytest.approx(3e3 / (3e3 + r0), rel=1e-12)


def test_low_frequency_admittance_is_the_lines_capacitance():
    """Both ends driven: |I| = w l cperl (1 + O((w R0 C0)^2)), here w R0 C0 = 6e-5."""
    length, rperl, cperl, f = 0.01, 1e4, 1e-10, 1e2
    ckt = netdae.load(f"t\nV1 a 0 dc 0 ac 1\nU1 a a 0 um l={length}\n.model um urc rperl={rperl} cperl={cperl}\n"
                      f".ac lin 1 {f} {f}\n.end\n")
    (res,) = netdae.run(ckt)
    current = abs(res["i(v1)"][0])
    assert current == pytest.approx(2 * math.pi * f * length * cperl, rel=1e-8)


def test_the_lumps_sum_to_the_line():
    """ngspice's geometric lumps: series resistances sum to R0, capacitances to C0, in n lumps."""
    ckt = netdae.load("t\nV1 a 0 1\nU1 a b 0 um l=3m n=5\nRl b 0 1k\n.model um urc k=1.7 rperl=2k cperl=4p\n"
                      ".op\n.end\n")
    parts = [el for el in ckt.elements if el.name.startswith("u1#")]
    r = sum(el.value for el in parts if el.kind == "resistor")
    c = sum(el.value for el in parts if el.kind == "capacitor")
    assert r == pytest.approx(3e-3 * 2e3, rel=1e-14) and c == pytest.approx(3e-3 * 4e-12, rel=1e-14)
    assert sum(el.kind == "resistor" for el in parts) == 10 and sum(el.kind == "capacitor" for el in parts) == 9
    ratios = sorted(el.value for el in parts if el.name.startswith("u1#rlo"))
    assert np.allclose(np.diff(np.log(ratios)), math.log(1.7), rtol=1e-12)


def test_lumps_follow_fmax():
    """More lumps for a higher fmax (the normalised frequency 2 pi fmax R0 C0 grows), three at the least."""
    counts = [urc.lumps(1e-3, {"rperl": 1e4, "cperl": 1e-10, "fmax": f}) for f in (1e6, 1e9, 1e12, 1e15)]
    assert counts[0] == 3 and counts == sorted(counts) and counts[-1] > counts[1]


@pytest.mark.ngspice
@pytest.mark.parametrize("model, inst", [
    ("cperl=100p rperl=100k fmax=10g", "l=20m"),          # ngspice's example: 8 lumps from fmax
    ("k=2.5 rperl=3k cperl=2p", "l=5m n=4"),              # lumps given
    ("rperl=10k cperl=1p isperl=1e-15 rsperl=10", "l=2m"),  # diodes to the reference instead of capacitors
])
def test_transient_and_ac_against_ngspice(model, inst):
    """Every node of the network (ngspice's internal node names) within the tolerance of ngspice 39.

    Both simulators at tight settings (``compare(tight=True)``): at the defaults ngspice's trapezoidal
    steps at the pulse's corners are up to 46 tolerance units off on i(v1) (measured; netdae's and
    ngspice's AC results, which have no steps, agree to rounding).
    """
    text = (f"urc\nV1 a 0 dc 0 ac 1 pulse(0 1 1n 0.2n 0.2n 10n 40n)\nRs a in 50\nU1 in out 0 um {inst}\n"
            f"Cl out 0 0.1p\n.model um urc {model}\n.tran 0.05n 30n\n.ac dec 10 1meg 10g\n.end\n")
    cmp = netdae.compare(text, tight=True)
    assert cmp.ngspice_error is None
    for an in cmp.analyses:
        assert an.error is None, an.error
        names = {s.name for s in an.signals}
        assert {"v(u1#hi1)", "v(u1#lo1)", "v(out)"} <= names, names  # ngspice's internal nodes are netdae's
        assert not [n for n in an.only_ngspice if n.startswith("v(")], an.only_ngspice
        worst = max(s.max_abs / (TOL * s.scale) for s in an.signals if s.scale > 0)
        assert worst < 1.0, (an.analysis, worst)


def test_a_urc_line_in_a_subcircuit_names_its_nodes_as_ngspice():
    ckt = netdae.load("t\n.subckt line a b\nU1 a b 0 um l=1m n=3\n.ends\n.model um urc\nV1 i 0 1\nX1 i o line\n"
                      "Rl o 0 1k\n.op\n.end\n")
    assert "u.x1.u1#hi1" in ckt.nodes and "u.x1.u1#lo2" in ckt.nodes
    assert ckt.element("u.x1.u1#rlo1").kind == "resistor" and ckt.element("u.x1.u1#clo3").kind == "capacitor"


def test_a_transient_runs_through_the_lumps():
    ckt = netdae.load("t\nV1 a 0 pulse(0 1 0 1n 1n 5n 10n)\nU1 a b 0 um l=1m\nRl b 0 1meg\n"
                      ".model um urc rperl=1meg cperl=1n\n.tran 1n 20n\n.end\n")
    res = transient(ckt, ckt.analyses[0])
    assert res.ok and np.all(np.isfinite(res["v(b)"]))


# -- bad input -----------------------------------------------------------------------------------
@pytest.mark.parametrize("line, model, words", [
    ("U1 a b 0 um", ".model um urc", "l= is missing"),
    ("U1 a b 0 um l=0", ".model um urc", "length l=0 must be positive"),
    ("U1 a b 0 um l=1m n=2.5", ".model um urc", "whole number"),
    ("U1 a b 0 um l=1m", ".model um urc k=1", "propagation constant must be above 1"),
    ("U1 a b 0 um l=1m", ".model um urc rperl=-1", "rperl=-1 must be positive"),
    ("U1 a b 0 um l=1m w=3", ".model um urc", "unexpected parameter 'w'"),
    ("U1 a b um l=1m", ".model um urc", "expected 3 nodes and a model name"),
    ("U1 a b 0 dm l=1m", ".model dm d", "needs urc"),
    ("U1 a b 0 nomodel l=1m", ".model um urc", "undefined model 'nomodel'"),
    ("U1 NAND(2) a b c dly", ".model um urc", "PSpice digital primitive"),
    ("U1 a b 0 um l=1m", ".model um urc rperl=1k bogus=3", "bogus"),
])
def test_bad_urc_cards_are_located_errors(line, model, words):
    text = f"t\nV1 a 0 1\n{line}\nRl b 0 1k\n{model}\n.op\n.end\n"
    if "bogus" in words:  # a parameter ngspice does not know: ignored with a warning, as ngspice ignores it
        ckt = netdae.load(text)
        assert any("bogus" in d.message for d in ckt.diagnostics)
        return
    with pytest.raises(NetlistError) as err:
        netdae.load(text)
    assert words in str(err.value)
    assert err.value.location is not None and err.value.location.line in (3, 5)
