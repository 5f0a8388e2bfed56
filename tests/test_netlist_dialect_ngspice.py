"""The ngspice dialect as people write it: each construct read by netdae and by ngspice 39, same values.

Every netlist here is run by ngspice (``print`` with 12 digits in a control
block) and by netdae; operating points agree to 1e-9 relative, transient
values at ngspice's time points to a fraction of the signal's range.
"""

from __future__ import annotations

import math
import re
import subprocess
from pathlib import Path

import numpy as np
import pytest

import netdae
from netdae.errors import NetlistError
from netdae.netlist import load

pytestmark = pytest.mark.ngspice

RTOL = 1e-9


def ngspice_print(netlist: str, names: list[str], tmp_path: Path) -> dict[str, float]:
    """Run ``netlist`` (no control block) in ngspice and return the printed values of ``names``."""
    text = netlist.rstrip() + "\n.control\nset numdgt=12\nrun\nprint " + " ".join(names) + "\n.endc\n.end\n"
    cir = tmp_path / "d.cir"
    cir.write_text(text)
    proc = subprocess.run(["ngspice", "-b", str(cir)], capture_output=True, text=True, timeout=60, cwd=tmp_path)
    out: dict[str, float] = {}
    for line in proc.stdout.splitlines():
        m = re.match(r"\s*(\S+) = (\S+)\s*$", line)
        if m and m.group(1) in names:
            out[m.group(1)] = float(m.group(2))
    assert set(out) == set(names), proc.stdout + proc.stderr
    return out


def _op_agrees(netlist: str, names: list[str], tmp_path: Path) -> netdae.Circuit:
    ref = ngspice_print(netlist + ".op\n", names, tmp_path)
    circuit = load(netlist + ".op\n.end\n")
    result = netdae.run(circuit)[0]
    for name in names:
        got = float(result.signals[name][-1])
        assert abs(got - ref[name]) <= RTOL * abs(ref[name]) + 1e-14, (name, got, ref[name])
    return circuit


def _tran_agrees(netlist: str, signals: list[str], points: list[int], tmp_path: Path, rtol: float) -> None:
    names = [f"{s}[{k}]" for s in signals for k in points] + [f"time[{k}]" for k in points]
    ref = ngspice_print(netlist, names, tmp_path)
    result = [r for r in netdae.run(load(netlist + ".end\n")) if r.analysis == "tran"][0]
    for s in signals:
        span = float(np.ptp(result.signals[s])) or 1.0
        for k in points:
            got = float(np.ravel(result.dense(ref[f"time[{k}]"])[s])[0])
            assert abs(got - ref[f"{s}[{k}]"]) <= rtol * span, (s, k, got, ref[f"{s}[{k}]"])


def _warnings(circuit) -> list[str]:
    return [f"{d.location.line}:{d.location.column} {d.message}" for d in circuit.diagnostics
            if d.severity == "warning"]


# ---------------------------------------------------------------------------
def test_ground_as_a_subcircuit_port_stays_ground_inside(tmp_path):
    # ngspice 39: inside the body 0 is ground; the node the instance connects to port 0 is not
    # connected by the body (node 2 floats on R9 and I1: v(2) = 1 V)
    netlist = ("ground port\n.subckt sub a 0\nR1 a 0 1k\nR2 a b 1k\nR3 b gnd 1k\n.ends\n"
               "V1 1 0 1\nX1 1 2 sub\nR9 2 0 1k\nI1 0 2 1m\n")
    c = _op_agrees(netlist, ["v(1)", "v(2)", "v(x1.b)", "i(v1)"], tmp_path)
    assert any("2:15 .subckt: port '0' is ground" in w for w in _warnings(c))


SOURCES = """source value then a function
VIN 1 0 0v (PULSE 0 1 0 1n 1n 5n 10n)
V2 2 0 dc 0 pulse(0 2 0 1n 1n 5n 10n)
V3 3 0 DC PWL(0 2 1n 3)
V4 4 0 dc 0.5 PWL(0 1 1n 3)
R1 1 0 1k
R2 2 0 1k
R3 3 0 1k
R4 4 0 1k
"""


def test_source_value_followed_by_a_function(tmp_path):
    _op_agrees(SOURCES, ["v(1)", "v(2)", "v(3)", "v(4)"], tmp_path)  # DC PWL(...): a DC value of 0
    _tran_agrees(SOURCES + ".tran 0.1n 12n\n", ["v(1)", "v(2)", "v(3)", "v(4)"], [3, 7, 20, 40], tmp_path, 1e-9)


def test_parenthesised_node_pairs_as_ngspice_reads_them(tmp_path):
    # PySpice's small-signal-amplifier.cir: 'E1 (amp_out 0) (amp_in 0) -10' was refused
    # ("expected 4 nodes, found 0"); ngspice reads node names past '(' ')' ','
    _op_agrees("t\nV1 in 0 DC 0.3\nR1 (in a) 1k\nR2 a 0 2k\nE1 (out 0) (a, 0) -10\nRL out 0 1k\n"
               "G1 (g 0) a 0 1m\nRG g 0 1k\nE2 e 0 poly(1) (a, 0) 0.1 2\nRE e 0 1k\n"
               "V2 s 0 sin(0 1 1k)\nRS s 0 1k\n",
               ["v(out)", "v(g)", "v(e)", "v(a)"], tmp_path)


def test_repeated_model_parameter_and_param_values_with_blanks(tmp_path):
    netlist = ("blanks\n.param a = 1 + 2\n.param b = (a+1)*2 c=5\n.param d = 3 * 2\n"
               "V1 1 0 {a}\nV2 2 0 {b}\nV3 5 0 {c}\nV4 6 0 {d}\nD1 1 3 dm\nR3 3 0 1k\n"
               ".model dm d is=1e-12 is=1e-14 n=1\n")
    c = _op_agrees(netlist, ["v(1)", "v(2)", "v(5)", "v(6)", "v(3)", "i(v1)"], tmp_path)
    assert c.params == {"a": 3.0, "b": 8.0, "c": 5.0, "d": 6.0}
    assert any("11:22 .model: model parameter 'is' given twice: the last value is used" in w for w in _warnings(c))


def test_ends_name_resistor_model_before_value_and_tce(tmp_path):
    netlist = ("ends other name\n.subckt sub a b\nR1 a b 1k\n.ends lump\n.model rmod r tc1=0.01 tce=0.5 tnom=20\n"
               ".model rpoly r tc1=0.01 tc2=1e-4\nV1 1 0 1\nX1 1 0 sub\nR2 1 0 RMOD 2k\nV3 3 0 1\n"
               "R3 3 0 2k tce=0.3 dtemp=10\nV4 4 0 1\nR4 4 0 2k RMOD dtemp=10\nV5 5 0 1\nR5 5 0 rpoly 3k dtemp=-20\n"
               "V6 6 0 1\nR6 6 0 rpoly 3k tc1=0.02\n.temp 35\n")
    c = _op_agrees(netlist, ["i(v1)", "i(v3)", "i(v4)", "i(v5)", "i(v6)"], tmp_path)
    assert c.element("r2").value == 2e3 and c.element("r2").model == "rmod"
    assert any("4:7 .ends: '.ends lump' closes .subckt sub" in w for w in _warnings(c))


def test_ic_inside_a_subcircuit(tmp_path):
    netlist = ("ic in subckt\n.subckt rc a\nR1 a b 1k\nC1 b 0 1u\n.ic v(b)=2\n.ends\n"
               "V1 1 0 0\nX1 1 rc\nX2 1 rc\n.tran 10u 3m uic\n")
    assert load(netlist).ic == {"x1.b": 2.0, "x2.b": 2.0}
    _tran_agrees(netlist, ["v(x1.b)", "v(x2.b)"], [5, 30, 60], tmp_path, 2e-3)


def test_model_extras_ngspice_ignores_are_located_warnings(tmp_path):
    netlist = ("model extras\n.param isv=1e-14\n.model dm d (is={isv * 2} n = 1.5 rs= 10 mfg=\"acme\" iave=1 flag)\n"
               ".model qm npn (is=1e-15 bf=80 vceo=40 icrating=200m mfg=\"nxp\")\n"
               ".model mm nmos level=1 vto=0.8 kp=1e-4 delta=0.1 eta=0.2 kappa=0.3\n"
               "V1 1 0 1\nD1 1 2 dm\nR1 2 0 1k\nV2 c 0 5\nVb b 0 0.7\nQ1 c b 0 qm\n"
               "Vg g 0 3\nM1 c g 0 0 mm w=10u l=1u\n")
    c = _op_agrees(netlist, ["v(2)", "i(v1)", "i(v2)"], tmp_path)
    warnings = _warnings(c)
    expected = ["3:46 model dm: string parameter mfg=\"acme\"", "3:58 model dm: parameter 'iave'",
                "3:60 model dm: flag 'flag'", "4:36 model qm: parameter 'vceo'", "4:48 model qm: parameter 'icrating'",
                "4:57 model qm: string parameter mfg=\"nxp\"", "5:46 model mm: parameter 'delta'",
                "5:54 model mm: parameter 'eta'", "5:64 model mm: parameter 'kappa'"]
    assert [w.split(" is not")[0].split(" ignored")[0] for w in warnings] == expected
    for text in expected:
        assert sum(w.startswith(text) for w in warnings) == 1, (text, warnings)


@pytest.mark.parametrize("level, name", [(4, "BSIM1"), (5, "BSIM2"), (60, "SOI3"),
                                         (68, "HiSIM2")])
def test_unimplemented_mosfet_level_is_refused_by_name(level, name):
    text = f"t\n.model mm nmos level={level} vto=1 kappa=0.2\nV1 d 0 1\nM1 d d 0 0 mm\n.op\n.end\n"
    with pytest.raises(NetlistError, match=rf"m1: model mm: MOSFET level {level} \({name} in ngspice\) is not "
                                            "implemented by netdae") as exc:
        load(text)
    assert exc.value.location.line == 2 and "OSDI" in exc.value.hint and "parameter" not in exc.value.message


def test_temper_is_the_circuit_temperature(tmp_path):
    netlist = ("temper\n.param rt={1k*(1+0.01*(temper-27))}\n.temp 50\nV1 1 0 1\nR1 1 0 {rt}\n"
               "B1 2 0 V=temper\nR2 2 0 1\nR3 3 0 {1k + temper}\nV3 3 0 1\n")
    _op_agrees(netlist, ["i(v1)", "v(2)", "i(v3)"], tmp_path)


def test_a_perfect_coupling_runs_as_in_ngspice(tmp_path):
    """K with k = 1 (an ideal transformer's coupling): ngspice 39 takes it, and so does netdae (its singular
    inductance matrix makes one current combination algebraic)."""
    netlist = ("k1\nV1 in 0 PULSE(0 10 0.1m 1u 1u 1m 2m)\nR1 in a 10\nL1 a 0 10m\nL2 b 0 2.5m\nK1 L1 L2 1\n"
               "RL b 0 100\n.tran 10u 3m\n")
    _tran_agrees(netlist, ["v(a)", "v(b)", "i(l1)"], [50, 120, 200, 280], tmp_path, 1e-3)


def test_several_temperatures_run_at_27_degrees_as_in_ngspice(tmp_path):
    """ngspice 39 runs one temperature: ``.temp 0 27 100`` warns and runs at 27 degC, even with
    ``.options temp=50`` (netdae warns at the second value and does the same)."""
    netlist = "temps\nV1 a 0 1\nR1 a b 1k tc1=0.01\nD1 b 0 dd\n.model dd d is=1e-14\n.options temp=50\n.temp 0 27 100\n"
    circuit = _op_agrees(netlist, ["v(b)", "i(v1)"], tmp_path)
    assert circuit.options.temp == 27.0
    (warning,) = [d for d in circuit.diagnostics if "several temperatures" in d.message]
    assert warning.location.line == 7 and warning.location.column == 9


def test_a_temperature_sweep_evaluates_temper_at_every_point():
    """ngspice's regression tests temper-2/-3: values written with 'temper' follow a .dc temp sweep.

    Closed forms: r = 1000 + temper gives -v/i - 1000 = temper; two diodes at one voltage, one with
    is = 1e-12 * temper and one with is = 1e-12 (the same temperature scaling otherwise), carry
    currents whose ratio is temper, up to the gmin (1e-12 S) each junction has in parallel: a relative
    2 gmin v / i with v < 1 V.
    """
    (res,) = netdae.run(load("t\n.model rt r r='1000 + temper'\nV1 1 0 5\nR1 1 0 rt\n.dc temp 10 100 10\n.end\n"))
    temps = res.axis
    assert np.allclose(temps, np.arange(10.0, 101.0, 10.0), rtol=0, atol=1e-12)
    assert np.allclose(-res["v(1)"] / res["i(v1)"] - 1000.0, temps, rtol=1e-12)
    (res,) = netdae.run(load("t\n.model dt d is='1e-12 * temper'\n.model df d is=1e-12\nV1 1 0 5\nR1 1 2 5k\n"
                             "Dt 2 3 dt\nVt 3 0 0\nDf 2 4 df\nVf 4 0 0\n.dc temp 10 100 10\n.end\n"))
    bound = 2 * 1e-12 * 1.0 / np.abs(res["i(vf)"]).min()
    assert np.allclose(res["i(vt)"] / res["i(vf)"], res.axis, rtol=bound, atol=0)


POLY = """poly sources
V1 1 0 2
V2 2 0 3
V3 3 0 5
E1 a 0 POLY(2) (1,0) (2,0) 1 2 3 4 5 6
R1 a 0 1k
E2 b 0 POLY(2) 1 0 2 0 1 2 3 4 5 6
R2 b 0 1k
G3 c 0 POLY(3) 1 0 2 0 3 0 1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 16 17 18 19 20
R3 c 0 1
F4 d 0 POLY(2) V1 V2 0.5 1 2 3 4 5
R4 d 0 1
H5 e 0 POLY(1) V3 1 2 3 4
R5 e 0 1
R11 1 0 1
R12 2 0 2
R13 3 0 5
E6 f 0 POLY(1) 1 0 1 2 3 4
R6 f 0 1
G7 g 0 POLY(2) (1, 2) (3, 0) 0 0 0 0 1
R7 g 0 1
"""


def test_poly_sources_with_ngspice_coefficient_order(tmp_path):
    # non-symmetric coefficients: x1^2, x1 x2, x2^2 (and for n = 3 all 20 terms up to the cubes) in
    # ngspice's order; F/H controlled by V-source currents
    c = _op_agrees(POLY, ["v(a)", "v(b)", "v(c)", "v(d)", "v(e)", "v(f)", "v(g)"], tmp_path)
    assert {c.element(n).kind for n in ("e1", "f4", "h5")} == {"bvoltage", "bcurrent"}


OPAMP_MACRO = """741-style macromodel (POLY(2) of the supplies, gm stage, dominant pole, output buffer)
.subckt amp inp inn out vcc vee
rin inp inn 2meg
egnd 99 0 POLY(2) (vcc,0) (vee,0) 0 0.5 0.5
g1 99 2 inp inn 100u
r2 2 99 100meg
c1 2 99 30p
eout 5 99 POLY(1) (2,99) 0 1
vsense 5 out 0
rload out 99 100k
fsup vcc vee POLY(2) vsense vsense 1m 0 0 0 0.01
.ends
VCC vcc 0 15
VEE vee 0 -15
VIN in 0 dc 0.1 sin(0.1 0.2 1k)
R1 in n 10k
R2 n out 100k
X1 0 n out vcc vee amp
RL out 0 10k
"""


def test_opamp_macromodel_in_the_style_of_ua741(tmp_path):
    _op_agrees(OPAMP_MACRO, ["v(out)", "v(n)", "i(vcc)", "i(vee)", "v(x1.99)"], tmp_path)
    _tran_agrees(OPAMP_MACRO + ".tran 10u 2m\n", ["v(out)", "v(n)"], [10, 50, 100], tmp_path, 2e-3)


CONTROL = """control block
V1 in 0 dc 1 ac 1 sin(0 1 1k)
R1 in out 1k
C1 out 0 1u
R2 out 0 {rr}
.param rr=3k
.control
set numdgt=12
set reltol=1e-6
save v(out) i(v1)
op
print v(out) i(v1)
let x = 2
foreach v 1 2
  tran 1u 1m
end
alter r1 2k
tran 1u 1m
shell touch pwned
quit
.endc
.end
"""


def test_control_block_commands_are_read_as_cards(tmp_path):
    c = load(CONTROL)  # a script (foreach, alter): netdae's interpreter runs it
    assert [type(a).__name__ for a in c.analyses] == ["OpAnalysis"] + ["TranAnalysis"] * 3
    assert c.options.reltol == 1e-6
    assert [[x.command for x in a.alter] for a in c.analyses] == [[], [], [], ["alter r1 = 2000.0"]]
    assert c.saves == ["v(out)", "i(v1)"]
    notes = [(d.location.line, d.message.split(":", 1)[1].split(" skipped")[0].strip())
             for d in c.diagnostics if d.severity == "note"]
    assert notes == [(19, "'shell touch pwned'"), (20, "'quit'")]
    # the same values as ngspice running the block itself
    cir = tmp_path / "c.cir"
    cir.write_text(CONTROL)
    proc = subprocess.run(["ngspice", "-b", str(cir)], capture_output=True, text=True, timeout=60, cwd=tmp_path)
    printed = dict(re.findall(r"^(v\(out\)|i\(v1\)) = (\S+)$", proc.stdout, re.M))
    result = netdae.run(c)[0]
    assert float(result["v(out)"][0]) == pytest.approx(float(printed["v(out)"]), rel=RTOL)
    assert float(result["i(v1)"][0]) == pytest.approx(float(printed["i(v1)"]), rel=RTOL)


def test_the_bridge_gets_cards_never_a_control_block(tmp_path):
    from netdae.ngspice import run_ngspice, translate_for_ngspice

    text, notes = translate_for_ngspice(CONTROL)
    lines = text.splitlines()
    assert [ln for ln in lines if ln.startswith(".")] == [".param rr=3k", ".options reltol=1E-06",
                                                            ".save v(out) i(v1)", ".print v(out) i(v1)",
                                                            ".control", ".endc", ".end"]
    # the script's outcome as netdae's own block: analyses and alter commands with numbers, nothing else
    block = lines[lines.index(".control") + 1: lines.index(".endc")]
    assert block == ["* netdae: analyses and alter commands", "set appendwrite", "op", "write out.raw",
                     "tran 1u 1m", "write out.raw", "tran 1u 1m", "write out.raw", "alter r1 = 2000.0",
                     "tran 1u 1m", "write out.raw", "quit"]
    assert not any(w in text.lower() for w in ("shell", "pwned", "let ", "foreach"))
    run = run_ngspice(CONTROL, backend="subprocess", workdir=tmp_path)
    assert run.result("op")["v(out)"][0] == pytest.approx(0.75, rel=1e-9)
    assert not (tmp_path / "pwned").exists()


@pytest.mark.parametrize("command, what", [("disto dec 10 1 1k", "distortion"),
                                           ("fourier 1k v(out)", "Fourier")])
def test_analyses_netdae_lacks_are_refused_in_control_blocks(command, what):
    with pytest.raises(NetlistError, match=rf"\.control: '{command.split()[0]}' \({what} analysis\) is not "
                                           "supported") as exc:
        load(f"t\nV1 in 0 1\nR1 in out 1k\nR2 out 0 1k\n.control\nop\n  {command}\n.endc\n.end\n")
    assert (exc.value.location.line, exc.value.location.column) == (7, 3)


def test_pz_tf_and_noise_commands_are_read_as_cards():
    c = load("t\nV1 in 0 1 ac 1\nR1 in out 1k\nR2 out 0 1k\nC1 out 0 1u\n.control\nop\n  pz in 0 out 0 cur pol\n"
             "  tf v(out) v1\n  noise v(out) v1 dec 10 1 1k\n  sens v(out) dc\n.endc\n.end\n")
    assert [type(a).__name__ for a in c.analyses] == ["OpAnalysis", "PzAnalysis", "TfAnalysis", "NoiseAnalysis",
                                                      "SensAnalysis"]
    assert (c.analyses[1].location.line, c.analyses[1].location.column) == (8, 3)


def test_model_values_as_bare_expressions(tmp_path):
    netlist = ".model expressions\n.param isv=1e-14\n.model dm d is=isv*2 n={1 + 0.5}\nV1 1 0 1\nD1 1 2 dm\nR1 2 0 1k\n"
    c = _op_agrees(netlist, ["v(2)", "i(v1)"], tmp_path)
    assert c.models["dm"].params == {"is": 2e-14, "n": 1.5}
    # 'is = isv * 2': ngspice reads is=isv and ignores '* 2' with a warning; netdae refuses the trap
    with pytest.raises(NetlistError, match=r"the value of 'is' goes on after a blank \('\*'\)") as exc:
        load(netlist.replace("is=isv*2", "is = isv * 2") + ".end\n")
    assert (exc.value.location.line, exc.value.location.column) == (3, 22)


def test_ltspice_words_and_ngspice_outputs_on_model_cards(tmp_path):
    # ngspice ignores mfg (and stops at the undefined word OnSemi: netdae ignores both, with a warning);
    # 'type' is an output of ngspice's BJT model, which ngspice refuses on a .model card
    netlist = "ltspice\n.model qm npn(is=1e-15 bf=80 mfg=OnSemi vceo=40)\nV1 c 0 5\nVb b 0 0.7\nQ1 c b 0 qm\n"
    c = _op_agrees(netlist.replace("mfg=OnSemi", "mfg=\"OnSemi\""), ["i(v1)", "i(vb)"], tmp_path)
    c = load(netlist + ".op\n.end\n")
    assert [w.split(" ignored")[0] for w in _warnings(c)] == ["2:34 model qm: parameter mfg=OnSemi",
                                                               "2:46 model qm: parameter 'vceo' is not a parameter "
                                                               "of ngspice's bjt model:"]
    with pytest.raises(NetlistError, match=r"'type' is an output of ngspice's bjt model, not an input") as exc:
        load(netlist.replace("vceo=40", "type=1") + ".op\n.end\n")
    assert (exc.value.location.line, exc.value.location.column) == (2, 46)


# ---------------------------------------------------------------------------
# constructs of ngspice's own example and test netlists (scripts/corpus.py)

def test_width_and_csparam_cards_are_skipped_with_a_note(tmp_path):
    # .width shapes ngspice's printed output, .csparam feeds its control script: neither changes the circuit
    netlist = "output cards\n.width out=256\n.csparam rl=2k\nV1 1 0 2\nR1 1 2 1k\nR2 2 0 3k\n"
    c = _op_agrees(netlist, ["v(2)", "i(v1)"], tmp_path)
    notes = [(d.location.line, d.message.split(":")[0]) for d in c.diagnostics if d.severity == "note"]
    assert notes == [(2, ".width skipped"), (3, ".csparam skipped")]


def test_distortion_inputs_of_a_source_are_skipped(tmp_path):
    # DISTOF1/DISTOF2 [mag [phase]] only feed .disto; the DC, AC and SIN parts read as ngspice reads them
    netlist = ("distof\nV1 1 0 DC 0.5 AC 1 SIN 0 1 1K 0 0 DISTOF1 0.1 DISTOF2 0.2 90\nR1 1 2 1k\nC1 2 0 1u\n"
               ".tran 10u 2m\n")
    _tran_agrees(netlist, ["v(2)"], [50, 100], tmp_path, 2e-3)
    c = _op_agrees(netlist.replace(".tran 10u 2m\n", ""), ["v(2)", "i(v1)"], tmp_path)
    assert c.element("v1").source.ac_mag == 1.0
    assert [w.split(":", 2)[-1].strip().split(" skipped")[0] for w in _warnings(c)] == \
        ["'distof1'", "'distof2'"]


def test_print_functions_spice2_forms_and_branch_vectors_keep_the_signal(tmp_path):
    # .print ac vdb(2) db(v(2)) abs(i(v1)) and ngspice's vector name v1#branch: the signals inside are kept
    netlist = ("outputs\nV1 1 0 1\nR1 1 2 1k\nR2 2 0 1k\n.dc V1 0 1 0.5\n.print dc vdb(2) db(v(1)) abs(i(v1))\n"
               ".save v1#branch v(2)\n")
    ref = ngspice_print(netlist + ".op\n", ["v(2)", "v1#branch"], tmp_path)
    c = load(netlist + ".end\n")
    assert c.saves == ["v(2)", "v(1)", "i(v1)"]
    dc = netdae.run(c)[0]
    assert dc.names() == ["v(2)", "v(1)", "i(v1)"]
    assert abs(dc["v(2)"][-1] - ref["v(2)"]) <= RTOL * abs(ref["v(2)"])
    assert abs(dc["i(v1)"][-1] - ref["v1#branch"]) <= RTOL * abs(ref["v1#branch"])


def test_outputs_netdae_does_not_compute_are_left_out_and_the_analyses_run(tmp_path):
    # ngspice's device quantities, .probe vd()/p() and names that are no node: a warning each, not a refusal
    netlist = ("outputs\nV1 1 0 1\nR1 1 2 1k\nR2 2 0 1k\n.save @v1[dc] v(2)\n.probe vd(r1) p(r2) alli\n")
    c = _op_agrees(netlist, ["v(2)"], tmp_path)
    assert c.saves == ["v(2)"]
    assert [w.split(": ", 1)[0] for w in _warnings(c)] == ["5:7 .save @v1[dc]", "6:8 .probe vd(r1)",
                                                             "6:15 .probe p(r2)", "6:21 .probe alli"]
    assert all(w.endswith("(not kept)") for w in _warnings(c))
    assert netdae.run(c)[0].names() == ["v(2)"]


def test_a_printed_expression_is_left_out_with_a_warning_and_the_rest_runs(tmp_path):
    # ngspice prints par('v(1)*v(2)') as a column pa_00 (a B source it adds); netdae keeps no expression
    # outputs: a warning naming .meas ... par() instead, the other signals kept and equal to ngspice's
    netlist = "outputs\nV1 1 0 1\nR1 1 2 1k\nR2 2 0 1k\n.print dc v(2) par('v(1)*v(2)')\n"
    c = _op_agrees(netlist, ["v(2)"], tmp_path)
    assert c.saves == ["v(2)"]
    (warning,) = _warnings(c)
    assert warning.startswith("5:16 .print: par('v(1)*v(2)') left out") and ".meas tran NAME" in warning


def test_braces_and_quotes_inside_a_behavioural_expression(tmp_path):
    # ngspice reads {...} and '...' inside a B expression as groups, circuit references and time included
    netlist = ("groups\n.param k=3 td=1m\nV1 1 0 2\n.func f1(y) = {y*k}\nB1 2 0 V={v(1)*k} + 'k*2'\nR1 2 0 1k\n"
               "B2 3 0 I=v(1) > 1 ? {f1(v(1)-1)} : 0\nR2 3 0 1k\n"
               "B3 4 0 V=ternary_fcn(time < 'td', 0, {v(1)})\nR3 4 0 1k\n")
    _op_agrees(netlist, ["v(2)", "v(3)", "v(4)"], tmp_path)


def test_controlled_source_value_without_equals_sign(tmp_path):
    # E/G n+ n- VALUE {expr}: ngspice 39 reads the braces after VALUE without '='
    netlist = "value\nV1 1 0 2\nE1 2 0 VALUE { V(1)*3 }\nR1 2 0 1k\nG1 3 0 value {v(1)*1m}\nR3 3 0 1k\n"
    c = _op_agrees(netlist, ["v(2)", "v(3)", "i(e1)"], tmp_path)
    assert [c.element(n).kind for n in ("e1", "g1")] == ["bvoltage", "bcurrent"]


def test_resistance_from_the_model(tmp_path):
    # R n+ n- mname [l= w=]: (l - 2 short)/(w - 2 narrow) rsh, else the model's r, as ngspice 39 computes it
    netlist = ("model resistors\nV1 1 0 1\nR1 1 0 rt\n.model rt r r=1000 tc1=2m\nR2 1 0 rs l=11u w=2u\n"
               ".model rs r rsh=1000 narrow=0.5u short=1u\nR3 1 0 rs\n.temp 50\n")
    ref = ngspice_print(netlist + ".op\n", ["@r1[resistance]", "@r2[resistance]", "@r3[resistance]", "i(v1)"],
                        tmp_path)
    c = load(netlist + ".op\n.end\n")
    for name in ("r1", "r2", "r3"):
        assert abs(c.element(name).value - ref[f"@{name}[resistance]"]) <= RTOL * ref[f"@{name}[resistance]"]
    assert c.element("r1").params["tc1"] == 2e-3
    op = netdae.run(c)[0]
    assert abs(op["i(v1)"][0] - ref["i(v1)"]) <= RTOL * abs(ref["i(v1)"])
    with pytest.raises(NetlistError, match=r"r1: model rt gives the resistance as an instance parameter"):
        load(netlist.replace("r=1000", "resistance=1000") + ".op\n.end\n")


def test_resistance_of_zero_width_is_an_open_circuit(tmp_path):
    # w = 2 narrow: ngspice 39's resistance is infinite (showmod: inf) and the branch carries nothing
    netlist = "zero width\nV1 1 0 1\nVr 1 2 0\nR1 2 0 rn l=11u w=2u\n.model rn r rsh=1000 narrow=1u\nR2 1 0 1k\n"
    ref = ngspice_print(netlist + ".op\n", ["i(vr)", "i(v1)"], tmp_path)
    c = load(netlist + ".op\n.end\n")
    assert c.element("r1").value == math.inf
    assert any("leaves no width" in d.message and d.severity == "warning" for d in c.diagnostics)
    op = netdae.run(c)[0]
    assert op["i(vr)"][0] == ref["i(vr)"] == 0.0
    assert abs(op["i(v1)"][0] - ref["i(v1)"]) <= RTOL * abs(ref["i(v1)"])
    with pytest.raises(NetlistError, match=r"r1: model rn leaves a negative width"):
        load(netlist.replace("narrow=1u", "narrow=1.5u") + ".op\n.end\n")


def test_capacitance_from_the_model(tmp_path):
    # C n+ n- mname l= [w=]: cj (w - narrow)(l - short) + 2 cjsw ((l - short) + (w - narrow)), cj from di/thick,
    # narrow and short from del, the model's cap; ngspice's @c[capacitance] includes the tc1 factor
    netlist = ("model capacitors\nV1 1 0 DC 0 AC 1\nR1 1 2 1k\nC1 2 0 ca l=10u w=10u\nC2 2 0 cb l=20u w=5u\n"
               "C3 2 0 cc l=30u\nC4 2 0 cd\nC5 2 0 ca l=10u\n"
               ".model ca c cj=1e-4 cjsw=1e-10 defw=1u narrow=0.1u short=0.3u\n"
               ".model cb c thick=10n di=3.9 del=0.2u\n.model cc c cj=2e-4 cjsw=1e-10 w=2u tc1=0.01\n"
               ".model cd c cap=2p cj=1\n.temp 50\n")
    names = [f"@c{k}[capacitance]" for k in range(1, 6)]
    ref = ngspice_print(netlist + ".op\n", names, tmp_path)
    c = load(netlist + ".op\n.end\n")
    for k in range(1, 6):
        el = c.element(f"c{k}")
        factor = 1.0 + el.params.get("tc1", 0.0) * (50.0 - 27.0)
        want = ref[f"@c{k}[capacitance]"]
        assert abs(el.value * factor - want) <= RTOL * want, (k, el.value * factor, want)
        assert "l" not in el.params and "w" not in el.params
    with pytest.raises(NetlistError, match=r"c1: model ca gives the capacitance -"):
        load(netlist.replace("C1 2 0 ca l=10u w=10u", "C1 2 0 ca l=0.1u w=0.05u") + ".op\n.end\n")


def test_u2_and_the_comparisons_with_zero_in_b_sources(tmp_path):
    # ngspice's u2 (0, x, then 1) and eq0 ne0 gt0 lt0 ge0 le0 (1 when true), as its B sources read them
    lines = ["zero tests", "Va a 0 -0.5", "Vb b 0 0.5", "Vc c 0 2", "Vz z 0 0"]
    names = []
    for k, (fn, node) in enumerate([(f, n) for f in ("u2", "eq0", "ne0", "gt0", "lt0", "ge0", "le0")
                                    for n in ("a", "b", "c", "z")]):
        lines += [f"B{k} o{k} 0 V={fn}(v({node}))", f"R{k} o{k} 0 1k"]
        names.append(f"v(o{k})")
    _op_agrees("\n".join(lines) + "\n", names, tmp_path)


def test_ddt_in_a_b_source(tmp_path):
    # ddt(x): the exact derivative (a node holding it) where ngspice differentiates numerically; 0 at the
    # operating point in both
    netlist = ("ddt\nV1 1 0 SIN(0.5 1 1k)\nR1 1 2 1k\nC1 2 0 100n\nB1 3 0 V=ddt(V(2))*1m + 0.25\nR3 3 0 1k\n"
               "B2 4 0 I=2*ddt(V(1)*V(1))*1u\nR4 4 0 1k\n.tran 1u 2m 0 0.2u\n")
    _tran_agrees(netlist, ["v(3)", "v(4)"], [500, 2000, 4000], tmp_path, 5e-3)
    c = _op_agrees(netlist.replace(".tran 1u 2m 0 0.2u\n", ""), ["v(3)", "v(4)"], tmp_path)
    assert {el.name for el in c.elements} >= {"b1#ddt1#q", "b1#ddt1#r", "b2#ddt1#q"}


def test_temperature_coefficients_of_b_sources_and_behavioural_resistors(tmp_path):
    # B ... tc1= tc2=: the value times 1 + tc1 dT + tc2 dT^2; a resistor written R={expr} keeps its tc1, tc2
    # (ngspice 39 hands them to the B source it makes, which scales the resistance)
    netlist = ("tc\n.temp 77\n.options tnom=20\nV1 1 0 dc=10\nV9 9 0 0\nB2 2 0 I=v(1)*1m tc1=2m tc2=10u\nR2 2 0 1k\n"
               "B3 3 0 V=v(1) tc2=-30u\nR3 3 0 1k\nR4 1 4 R={1k + v(9)} tc1=1m\nV4 4 0 0\n")
    c = _op_agrees(netlist, ["v(2)", "v(3)", "i(v4)"], tmp_path)
    assert c.element("b2").params == {}


def test_mosfet_geometry_on_the_model_card_is_the_instances_default(tmp_path):
    # ngspice 39 reads l= w= (ad as pd ps nrd nrs) on a MOSFET .model card as the default of its instances
    netlist = ("geometry defaults\nVd d 0 2\nVg g 0 2\nM1 d g 0 0 nm\nM2 d g s2 0 nm w=20u\nVs2 s2 0 0\n"
               ".model nm nmos level=1 kp=50u vto=0.7 l=3u w=9u\n")
    c = _op_agrees(netlist, ["i(vd)", "i(vs2)"], tmp_path)
    got = (c.element("m1").params["w"], c.element("m1").params["l"], c.element("m2").params["w"])
    assert np.allclose(got, (9e-6, 3e-6, 20e-6), rtol=1e-12, atol=0)
    assert not _warnings(c)


def test_instance_values_replace_a_subcircuits_own_params(tmp_path):
    # ngspice 39: 'X ... rint=7' sets the body's '.param rint=5' too (examples/various/alterparam.sp)
    netlist = ("local params\n.subckt subr in out rint1=6\n.param rint=5\n.param rint2='rint+3'\n"
               "R0 in out 'rint'\nR1 in out 'rint1'\nR2 in out 'rint2'\n.ends\n"
               "Xr 2 0 subr rint=7 rint1=9\nV2 2 0 1\n")
    _op_agrees(netlist, ["i(v2)"], tmp_path)
    result = netdae.run(load(netlist + ".op\n.end\n"))[0]
    assert float(result.signals["i(v2)"][-1]) == pytest.approx(-(1 / 7 + 1 / 9 + 1 / 10), rel=1e-12)
    with pytest.raises(NetlistError, match=r"has no parameter 'rin' \(its parameters: rint, rint1, rint2\)"):
        load(netlist.replace("rint=7", "rin=7") + ".op\n.end\n")


def test_min_and_max_of_one_argument_compare_with_one(tmp_path):
    # ngspice 39's parameter evaluator reads a missing second operand of min/max as 1
    netlist = ("one argument\n.param a='max(-3)' b='min(7)' c='max(2.5)' d='min(-7)'\n"
               "V1 1 0 {a}\nR1 1 0 1\nV2 2 0 {b}\nR2 2 0 1\nV3 3 0 {c}\nR3 3 0 1\nV4 4 0 {d}\nR4 4 0 1\n")
    c = _op_agrees(netlist, ["v(1)", "v(2)", "v(3)", "v(4)"], tmp_path)
    assert c.params["a"] == 1.0 and c.params["b"] == 1.0 and c.params["c"] == 2.5 and c.params["d"] == -7.0
    assert sum("with one argument: read as" in w for w in _warnings(c)) == 4
    with pytest.raises(NetlistError, match=r"max\(\) takes 2 arguments, got 1"):
        load("b\nV1 1 0 1\nB1 2 0 V=max(v(1))\nR1 2 0 1\n.op\n.end\n")


def test_parenthesised_element_value_and_a_dos_end_of_file_mark(tmp_path):
    netlist = "paren\n.param rl=100\nV1 1 0 1\nR1 1 0 R = (rl*2)\n"
    _op_agrees(netlist, ["i(v1)"], tmp_path)
    circuit = load("paren\nV1 1 0 1\nR1 1 0 2k\n.op\n.end\n\x1a\n")
    assert [el.name for el in circuit.elements] == ["v1", "r1"]


def test_probe_entries_ngspice_cannot_read_are_warned_and_ignored():
    circuit = load("probes\nV1 1 0 1\nR1 1 2 1k\nR2 2 0 1k\n.probe (xyz) v(2)\n.probe i(r1)\n.op\n.end\n")
    assert circuit.saves == ["v(2)", "i(r1)"]
    assert any("5:8 .probe: entry ignored, as ngspice ignores it: expected a signal, found '('" in w
               for w in _warnings(circuit))


def test_an_unused_subcircuit_with_an_unreadable_card_is_ignored_as_ngspice_ignores_it(tmp_path):
    # ngspice reads the cards of the subcircuits it expands only: one never instantiated can hold a card
    # it (and netdae) cannot read; used, the same card is the error it always was
    text = ("unused\n.subckt bad a b\nR1 a b 1k 2k 3k\n.ends\n.subckt good a b\nR1 a b 1k\n.ends\n"
            "V1 1 0 1\nX1 1 0 {sub}\n.op\n.end\n")
    ok = tmp_path / "ok.cir"
    ok.write_text(text.format(sub="good"))
    assert subprocess.run(["ngspice", "-b", str(ok)], capture_output=True, text=True, timeout=60).returncode == 0
    c = load(str(ok))
    warned = [d for d in c.diagnostics if d.severity == "warning" and ".subckt bad is never used" in d.message]
    assert len(warned) == 1 and warned[0].location.line == 3
    assert netdae.run(c)[0]["i(v1)"][0] == pytest.approx(-1e-3, rel=1e-12)
    with pytest.raises(NetlistError, match=r"r1: expected a model name after the value, found '2k'") as info:
        load(text.format(sub="bad"))
    assert info.value.location.line == 3


# --------------------------------------------------------------------------- duplicate names
def _ngspice_bridge(text: str):
    """ngspice 39's results of ``text`` through netdae's bridge (``ngspice -b``)."""
    from netdae.ngspice import run_ngspice

    return run_ngspice(text, backend="subprocess").results


_SAME_NAME = ("same name\nV1 1 0 1\nxa 1 2 sa\nxa 1 3 sb\nR2 2 0 1k\nR3 3 0 1k\n"
              ".subckt sa p q\nr1 p n 1k\nr2 n q 1k\n.ends\n.subckt sb p q\n{sb}\n.ends\n.op\n.end\n")


def test_instances_of_one_name_whose_elements_differ_are_both_kept_as_in_ngspice():
    # ngspice 39 expands both xa cards (r.xa.r1, r.xa.r2, r.xa.r5, r.xa.r6): their internal nodes xa.n are one node
    text = _SAME_NAME.format(sb="r5 p n 3k\nr6 n q 2k")
    ref = next(r for r in _ngspice_bridge(text) if r.analysis == "op")
    got = netdae.run(load(text))[0]
    for name in ("v(2)", "v(3)", "v(xa.n)", "i(v1)"):
        assert float(got.signals[name][-1]) == pytest.approx(float(ref.signals[name][-1]), rel=RTOL), name
    # closed form: xa.n joins 1k and 3k from node 1 and 2k to ground (1k+1k) and 3k to ground (2k+1k)
    g_in, g_out = 1 / 1e3 + 1 / 3e3, 1 / 2e3 + 1 / 3e3
    assert float(got.signals["v(xa.n)"][-1]) == pytest.approx(g_in / (g_in + g_out), rel=1e-12)


@pytest.mark.parametrize("text, line, message", [
    (_SAME_NAME.format(sb="r1 p q 3k"), 4,
     r"xa: duplicate element name 'r.xa.r1': two subcircuit instances are named 'xa' \(at <string>:3, subcircuit "
     r"sa, and here, subcircuit sb\) and both contain an element 'r1'; ngspice 39 refuses it too"),
    ("dup\nV1 1 0 1\nR1 1 2 1k\nR1 2 0 3k\n.op\n.end\n", 4,
     r"r1: duplicate element name 'r1' \(first defined at <string>:3\); ngspice 39 refuses it too"),
    ("dup\nV1 1 0 1\nx1 1 0 s\n.subckt s a b\nr1 a b 1\nr1 a 0 2\n.ends\n.op\n.end\n", 6,
     r"r1: duplicate element name 'r.x1.r1' \(first defined at <string>:5\); ngspice 39 refuses it too"),
])
def test_duplicate_element_names_are_refused_as_ngspice_refuses_them(text, line, message):
    # ngspice 39 prints "device already exists, existing one being used" but then does not parse the circuit
    # ("Simulation interrupted due to error!", "circuit not parsed"): no analysis of it runs, in batch mode or not
    from netdae.errors import NgspiceError

    with pytest.raises(NgspiceError, match="device already exists"):
        _ngspice_bridge(text)
    with pytest.raises(NetlistError, match=message) as exc:
        load(text)
    assert exc.value.location.line == line and "does not parse the circuit" in exc.value.message


# --------------------------------------------------------------------------- ADMS levels and unread subcircuits
@pytest.mark.parametrize("nodes", ["c b 0", "c b 0 s", "c b 0 s dt"])
@pytest.mark.parametrize("level, name", [(7, "HICUM/L0"), (6, "Mextram 504")])
def test_adms_bjt_levels_are_refused_by_name_whatever_the_node_count(nodes, level, name):
    # ngspice's reader gives BJT levels 6 and 7 to its ADMS models (bjt504t, hicum0); ngspice 39's standard
    # build has neither and refuses the card ("Unable to find definition of given model")
    from netdae.errors import NgspiceError

    text = (f"adms\nV1 b 0 0.7\nV2 c 0 1\nV3 s 0 0\nX1 c b s dt sub\n.subckt sub c b s dt\nq1 {nodes} qm\n"
            f".model qm npn level={level} is=1e-16\n.ends\n.op\n.end\n")
    with pytest.raises(NgspiceError, match="Unable to find definition of given model"):
        _ngspice_bridge(text)
    with pytest.raises(NetlistError, match=rf"q\.x1\.q1: model x1:qm: bipolar transistor level {level} \({name}, "
                                           r"ngspice's ADMS model, which ngspice 39 does not include either\) is "
                                           "not implemented by netdae"):
        load(text)


def test_an_unused_subcircuit_whose_model_is_defined_nowhere_is_ignored_as_ngspice_ignores_it():
    # ngspice's hic0_gum.sp includes a library whose last subcircuit calls a model defined only inside the
    # other subcircuits; ngspice never expands it, so it never looks for the model
    text = ("unused\nV1 1 0 1\nR1 1 0 2k\n.subckt lone c b e s dt\nq1 c b e s dt qnowhere\n.ends\n"
            ".subckt used a b\nR1 a b 1k\n.ends\nX1 1 0 used\n.op\n.end\n")
    ref = next(r for r in _ngspice_bridge(text) if r.analysis == "op")
    circuit = load(text)
    got = netdae.run(circuit)[0]
    assert float(got.signals["i(v1)"][-1]) == pytest.approx(float(ref.signals["i(v1)"][-1]), rel=RTOL)
    assert float(got.signals["i(v1)"][-1]) == pytest.approx(-1.5e-3, rel=1e-12)
    assert any(w.startswith("5:10 .subckt lone is never used") and "no model 's', 'dt' or 'qnowhere' defined" in w
               for w in _warnings(circuit)), _warnings(circuit)
    with pytest.raises(NetlistError, match="no model 's', 'dt' or 'qnowhere' defined") as exc:
        load(text.replace("X1 1 0 used", "X2 1 0 1 0 0 lone"))
    assert exc.value.location.line == 5


# ---------------------------------------------------------------------------
def test_options_rshunt_and_rseries_change_the_circuit_as_in_ngspice(tmp_path):
    """``rshunt=R`` puts 1/R from every node to ground; ``rseries`` (alone: 1e-3 ohm) a resistor after
    every inductor, at ngspice's internal node ``<name>_intern__`` (an inductor loop then solves)."""
    _op_agrees("rshunt\nV1 in 0 1\nR1 in a 1k\nR2 a 0 1k\n.options rshunt=1k\n", ["v(a)", "i(v1)"], tmp_path)
    _op_agrees("rseries\nV1 in 0 1\nL1 in a 1u\nR1 a 0 1\nL2 a 0 1u\n.options rseries=1\n",
               ["v(a)", "v(l1_intern__)", "i(l1)", "i(l2)"], tmp_path)
    c = _op_agrees("rseries default\nV1 in 0 1\nX1 in a s\n.subckt s p q\nL1 p q 1u\n.ends\nR1 a 0 1\n"
                   ".options rseries\n", ["v(a)", "v(x1.l1_intern__)"], tmp_path)
    assert "r.x1.rl1_intern__" in [el.name for el in c.elements]


def test_options_cshunt_adds_a_capacitor_at_every_node(tmp_path):
    netlist = ("cshunt\nV1 in 0 pulse(0 1 0 1u 1u 1 2)\nR1 in a 1k\nR2 a b 1k\n.options cshunt=1n\n"
               ".tran 0.1u 5u\n")
    _tran_agrees(netlist, ["v(b)"], [20, 40], tmp_path, 2e-3)
    c = load(netlist + ".end\n")
    assert sorted(el.name for el in c.elements if el.name.startswith("cshunt")) == \
        ["cshunt(a)", "cshunt(b)", "cshunt(in)"]


def test_option_typo_and_options_that_change_the_circuit_warn_at_the_option():
    c = load("t\nV1 a 0 1\nR1 a 0 1k\n.options reltoll=1e-6 ramptime=1u foo trtol=7\n.op\n.end\n")
    warned = _warnings(c)
    assert warned[0] == "4:10 unknown option 'reltoll' (neither netdae nor ngspice 39 knows it; ngspice 39 " \
                        "ignores it): did you mean 'reltol'?"
    assert warned[1].startswith("4:23 option 'ramptime' is not applied by netdae: ngspice 39 ramps")
    assert warned[2].startswith("4:35 unknown option 'foo'") and "did you mean" not in warned[2]
    assert len(warned) == 3  # trtol: a tolerance, only noted as unused


def test_maxstep_is_warned_with_where_the_largest_step_goes():
    c = load("t\nV1 a 0 1\nR1 a 0 1k\n.options maxstep=1u\n.op\n.end\n")
    (warned,) = _warnings(c)
    assert "option 'maxstep' of other SPICEs is ignored" in warned and "fourth argument of .tran" in warned


def test_a_diode_with_ngspices_thermal_node_reads_as_ngspice_39_reads_it():
    # 'D a k t mname': ngspice 39's thermal node, unconnected without the instance flag 'thermal' (ngspice
    # 39: v(b) = 0.9534642 V, as the two-node diode); it was read as model 't' with the area 'dm'
    two = netdae.run(load("d\n.model dm d is=1e-14 n=1.5 rs=1\nV1 a 0 1\nR1 a b 100\nD3 b 0 dm\n.op\n.end\n"))
    three = netdae.run(load("d\n.model dm d is=1e-14 n=1.5 rs=1\nV1 a 0 1\nR1 a b 100\nD3 b 0 tj dm 2\n"
                            ".op\n.end\n"))
    area2 = netdae.run(load("d\n.model dm d is=1e-14 n=1.5 rs=1\nV1 a 0 1\nR1 a b 100\nD3 b 0 dm 2\n.op\n.end\n"))
    assert two[0]["v(b)"][0] == pytest.approx(0.9534642, abs=1e-7)
    assert three[0]["v(b)"][0] == area2[0]["v(b)"][0]  # the area after the model, as with two nodes
    with pytest.raises(NetlistError, match=r"d3: no model 'zz' or 'yy' defined") as info:
        load("d\nV1 a 0 1\nR1 a b 100\nD3 b 0 zz yy\n.op\n.end\n")
    assert (info.value.location.line, info.value.location.column) == (4, 8)
