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

import numpy as np
import pytest

import netdae
from netdae.analyses.tran import transient
from netdae.dae.bdf.failures import RUNAWAY_FACTOR, runaway
from test_tran_start import op177a_loop

TIA = Path("/work/corpus/examples/TransImpedanceAmp/output.net")  # ngspice's example: op-amp macromodels


def _tia() -> str:
    if not TIA.exists():
        pytest.skip("the ngspice corpus is not here")
    return TIA.read_text()


def test_the_current_of_a_source_on_a_capacitor_loop_is_index_2_in_a_macromodel_circuit(tmp_path):
    # V3 closes a loop of capacitors (Cp, Cb): i(v3) = C d(v)/dt of the input, index 2 for any element values.
    # The pencil's classification missed it (one OP177A: seven input-stage unknowns labelled, not i(v3); the
    # example, 245 infinite directions: none labelled, i(v3) at 4.8e-4 of the threshold).
    report = netdae.analyze_index(netdae.load(str(op177a_loop(tmp_path))))
    assert report.index == 2 and report.method == "kronecker"
    assert report.derivative_order["i(v3)"] == 1 and report.unknowns["i(v3)"] == "index2"
    tia = tmp_path / "tia.net"
    tia.write_text(_tia())
    report = netdae.analyze_index(netdae.load(str(tia)))
    assert report.index == 2 and report.method == "kronecker"
    for name in ("i(v3)", "i(e.xu1.eref)", "i(e.xu2.eref)"):  # the example's loops through V3 and the AD8009s
        assert report.derivative_order[name] == 1, name


def _loop_among_stages(stages: int) -> str:
    """A capacitor loop through V3 (Cp, V3, Cb) driving an open chain of VCVS stages of gain 1e6, each into 1e-6 ohm
    and 1 nF, each stage's node also fed from its own DC source through 1 Gohm: i(v3) is index 2 (it carries the
    derivative of V3's voltage) for any values. Not a circuit to build (its DC values grow by 1e6 a stage): a
    linear pencil whose infinite directions and scales grow with the chain, as the classification's threshold
    does (closed-loop stages of the same gain keep i(v3) above it)."""
    lines = ["cv loop at the input of a chain of stages", "Cp 0 a 1p", "V3 b a DC 0", "Cb b 0 1p", "Rb b 0 1k",
             "I1 0 a PWL(0 0 1n 0 1.01n 1u)"]
    prev = "b"
    for j in range(stages):
        lines += [f"E{j} o{j} 0 {prev} 0 1e6", f"R{j} o{j} m{j} 1e-6", f"C{j} m{j} 0 1n", f"V{j}x s{j} 0 DC 1",
                  f"RS{j} s{j} m{j} 1e9"]
        prev = f"m{j}"
    return "\n".join(lines + [".tran 0.05n 5n", ".end"]) + "\n"


@pytest.mark.parametrize("stages", [5, 40])
def test_the_loop_current_is_index_2_however_many_stages_follow(stages):
    # with 40 stages (203 unknowns) the pencil's classification weighs i(v3)'s dependence on V3's derivative at
    # 5e-8 of its threshold (with 5 stages, 7e6 times above it): the topology's loop labels it
    report = netdae.analyze_index(netdae.load(_loop_among_stages(stages)))
    assert report.index == 2 and report.method == "kronecker"
    assert report.derivative_order["i(v3)"] == 1 and report.unknowns["i(v3)"] == "index2"


NEGATIVE_C = """negative capacitance across a divider: a pole at +(1/R1 + 1/R2)/|C1| = +2e9 1/s
V1 a 0 DC 1
R1 a b 1
C1 a b -1n
R2 b 0 1
V2 c 0 DC 1
D1 c d DX
R3 d 0 1k
.model DX D(IS=1e-15)
.ic v(a)=1 v(b)=0.51
.tran 1n 400n uic
.end
"""


@pytest.mark.parametrize("engine", ["compiled", "python"])
def test_an_unstable_mode_is_followed_and_its_runaway_named(engine, monkeypatch):
    # v(b) = 1/2 + (v(b)(0) - 1/2) exp(lambda t), lambda = 2e9 1/s: followed (the rate within 2 %) until the
    # values overflow; the failure names the mode's growth instead of the Newton iterates it spoiled: v(b), or
    # i(v1) = (v(a) - v(b)) / R1 + C1 d(v(a) - v(b))/dt, 3 (v(b) - 1/2) as the mode grows (the larger against
    # its kind's start values once both are far beyond them)
    monkeypatch.setenv("NETDAE_ENGINE", engine)
    r = netdae.simulate(NEGATIVE_C, save=["v(b)"])
    assert not r.ok
    assert re.search(r"the solution ran away: (v\(b\)|i\(v1\)) = ", r.message), r.message
    t, v = np.asarray(r.axis), np.asarray(r["v(b)"]) - 0.5
    grown = (np.abs(v) > 0.1) & (np.abs(v) < 1e3)
    assert grown.sum() >= 10
    rate = np.polyfit(t[grown], np.log(np.abs(v[grown])), 1)[0]
    assert rate == pytest.approx(2e9, rel=0.02)


def test_runaway_is_measured_against_the_start_values_of_its_kind():
    names, kinds = ["v(a)", "v(b)", "i(v1)"], np.array([0, 0, 1])
    start = np.array([100.0, 1.0, 1e-3])
    assert runaway(names, kinds, start, np.array([100.0, 0.5 * RUNAWAY_FACTOR * 100, 1e-3])) is None
    text = runaway(names, kinds, start, np.array([100.0, 2 * RUNAWAY_FACTOR * 100, 1e-3]))
    assert text.startswith("the solution ran away: v(b) = 2e+08 V")
    text = runaway(names, kinds, start, np.array([100.0, 1.0, np.inf]))
    assert text.startswith("the solution ran away: i(v1) = inf A")


@pytest.mark.parametrize("engine", ["compiled", "python"])
def test_the_transimpedance_amplifier_passes_its_input_corner_and_names_the_runaway(engine, monkeypatch, tmp_path):
    # Before: the compiled engine stopped at the corner (t = 1e-9, h = 0, a singular probe), the Python one at
    # 1.0021 ns naming v(xu200.38). The DAE's solution diverges past the corner: the OP177As' pole at
    # +2.5e13 1/s grows (i(e.xu100.e3) from 5.8e4 A to 1e15-1e16 A) once the steps fall below 2/lambda = 8e-14 s;
    # ngspice's steps stay above 1.4e-13 s, and with steps of at most 2e-14 s ngspice diverges too.
    monkeypatch.setenv("NETDAE_ENGINE", engine)
    net = tmp_path / "tia.net"
    net.write_text(_tia())
    r = transient(netdae.load(str(net)))
    assert not r.ok
    failure = r.transient.failure
    assert failure.t > 1.0001e-9
    assert re.search(r"the solution ran away: i\(e\.xu[12]00\.e3\)", r.message), r.message


def _inverting_stages(stages: int, gain: float) -> str:
    """The capacitor loop through V3 before a chain of inverting amplifiers (VCVS of ``gain``, 1k in, 1k back,
    1 pF at each output): index 2 for any finite gain (v_o = -gain/(gain + 2) v_in, no second derivative)."""
    lines = ["cv loop before inverting stages", "Cp 0 a 1p", "V3 b a DC 0", "Cb b 0 1p", "Rb b 0 1k",
             "I1 0 a PWL(0 0 1n 0 1.01n 1u)"]
    prev = "b"
    for j in range(stages):
        lines += [f"Rin{j} {prev} n{j} 1k", f"Rf{j} o{j} n{j} 1k", f"E{j} o{j} 0 0 n{j} {gain:g}", f"C{j} o{j} 0 1p"]
        prev = f"o{j}"
    return "\n".join(lines + [".tran 0.05n 5n", ".end"]) + "\n"


def test_a_structure_double_precision_cannot_decide_is_decided_in_exact_arithmetic():
    # 40 stages of gain 1e9: the balanced pencil says index 3, the unbalanced one a singular pencil, each with a
    # kept singular value far within what rounding in H can leak into its block; 5 stages of gain 1e6: the
    # balanced pencil says index 3 (blocks [3, 2, 2, 2, 2, 1, ...]). The exact pencil has index 2 with one block
    # of size 2 per capacitor loop (V3's and each VCVS's): ranks over prime fields decide it, the staircase
    # follows them, and the report says so instead of calling the structure uncertain.
    for stages, gain in ((40, 1e9), (5, 1e6), (5, 1e9)):
        rep = netdae.analyze_index(netdae.load(_inverting_stages(stages, gain)))
        assert rep.pencil.decided_exactly and not rep.pencil.disputed
        assert rep.index == 2 and rep.pencil.regular
        assert rep.pencil.infinite_blocks == (2,) * (stages + 1) + (1,) * stages
        assert rep.pencil.n_dynamic == 1
        assert any(m.startswith("decided exactly") for m in rep.messages)
        doc = rep.to_dict()
        assert doc["exact"]["changed"] and doc["exact"]["index"] == 2 and not doc["disputed"]
        assert not any(m.startswith("uncertain") for m in rep.messages)
        labels = rep.unknowns
        assert {nm for nm, lb in labels.items() if lb == "index2"} == {"i(v3)"} | {f"i(e{j})" for j in range(stages)}
    # decided in double precision: index 2 (where a decision is close, exact arithmetic confirms it)
    for text in (_inverting_stages(2, 1e6), _inverting_stages(5, 1e3), _inverting_stages(40, 1e6)):
        rep = netdae.analyze_index(netdae.load(text))
        assert rep.index == 2 and not rep.pencil.disputed and not rep.pencil.decided_exactly
        assert not any(m.startswith(("uncertain", "decided exactly")) for m in rep.messages)
