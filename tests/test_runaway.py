"""A mode growing without bound, named as such; the index-2 labels of a macromodel circuit's capacitor loops.

ngspice's transimpedance amplifier (``examples/TransImpedanceAmp/output.net``) has two OP177A macromodels
whose "negative zero" (``C4 = -39.75 nF`` across ``R9 = 1 ohm`` into ``R10 = 1e-6 ohm``) is a pole at
``+2.5157e13 1/s``. Its dense pencil found index 2 and labelled no unknown of index 2, so the transient tested
i(v3)'s error (a derivative of the input) and the compiled engine's restart at the input corner collapsed to
a probe whose Newton matrix was singular (t = 1 ns, h = 0). Past the corner both engines follow the growing
mode until Newton fails on its rounding, which the failure now says.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

import netdae

TIA = Path("/work/corpus/examples/TransImpedanceAmp/output.net")  # ngspice's example: op-amp macromodels


def _tia() -> str:
    if not TIA.exists():
        pytest.skip("the ngspice corpus is not here")
    return TIA.read_text()


def _loop_circuit(tmp_path) -> Path:
    """One OP177A (the example's macromodel) with a capacitor loop through V3 at its input."""
    found = re.search(r"^\.SUBCKT OP177A.*?^\.ENDS", _tia(), flags=re.M | re.S | re.I)
    assert found is not None
    (tmp_path / "op177a.lib").write_text(found.group(0) + "\n")
    netlist = tmp_path / "loop.cir"
    netlist.write_text("""OP177A inverting amplifier with a capacitor loop at its input
.options gmin=1e-9 method=gear abstol=1e-11
.include op177a.lib
V1 vp 0 DC 5
V2 vn 0 DC -5
XU 0 inm vp vn out OP177A
Rf out inm 10k
Rin b inm 1k
Cp 0 a 1p
V3 b a DC 0
Cb b 0 1p
I1 0 a PWL(0 0 1n 0 1.01n 1u)
.tran 0.05n 5n
.end
""")
    return netlist


def test_the_current_of_a_source_on_a_capacitor_loop_is_index_2_in_a_macromodel_circuit(tmp_path):
    # V3 closes a loop of capacitors (Cp, Cb): i(v3) = C d(v)/dt of the input, index 2 for any element values.
    # The pencil's classification missed it (one OP177A: seven input-stage unknowns labelled, not i(v3); the
    # example, 245 infinite directions: none labelled, i(v3) at 4.8e-4 of the threshold).
    report = netdae.analyze_index(netdae.load(str(_loop_circuit(tmp_path))))
    assert report.index == 2 and report.method == "kronecker"
    assert report.derivative_order["i(v3)"] == 1 and report.unknowns["i(v3)"] == "index2"
    tia = tmp_path / "tia.net"
    tia.write_text(_tia())
    report = netdae.analyze_index(netdae.load(str(tia)))
    assert report.index == 2 and report.method == "kronecker"
    for name in ("i(v3)", "i(e.xu1.eref)", "i(e.xu2.eref)"):  # the example's loops through V3 and the AD8009s
        assert report.derivative_order[name] == 1, name
