"""Netlist dialect details found by comparing netdae with ngspice 39 card by card.

Each test names the ngspice behaviour it pins down; those that need ngspice run the
same netlist in ``ngspice -b`` (``print`` with 12 digits) and in netdae.
"""

from __future__ import annotations

import math
import re
import subprocess

import numpy as np
import pytest

import netdae
from netdae.errors import NetlistError
from netdae.netlist import load
from test_netlist_dialect_ngspice import ngspice_print


def op_values(netlist: str, names: list[str]) -> dict[str, float]:
    """netdae's operating point values of ``names`` (``v(n)``, ``i(v1)``)."""
    result = netdae.run(load(netlist))[0]
    return {name: float(result.signals[name][-1]) for name in names}


# -- nested conditionals in parameter expressions ---------------------------------------------

NESTED = "c1 ? c2 ? a : b : e"


@pytest.mark.parametrize("card", [
    ".param p={1 ? 0 ? 10 : 20 : 30}\nV1 n 0 {p}",
    "V1 n 0 {1 ? 0 ? 10 : 20 : 30}",
    "V1 n 0 '(7 > 1) ? 7 < 5 ? 10 : 20 : 30'",
    ".func h(x) = {x > 1 ? x < 5 ? 10 : 20 : 30}\nV1 n 0 {h(7)}",
    ".model dd d is={1 ? 0 ? 1e-14 : 2e-14 : 3e-14}\nD1 n 0 dd\nV1 n 0 0.6",
])
def test_unparenthesised_conditional_in_a_true_branch_is_refused_in_parameters(card):
    # ngspice 39's parameter evaluator gives 10 for 1 ? 0 ? 10 : 20 : 30 (the first value
    # whenever the outer condition holds), where C reads 20: netdae refuses the form
    with pytest.raises(NetlistError, match="unparenthesised in the true branch") as info:
        load(f"t\n{card}\nR1 n 0 1k\n.op\n")
    assert "c1 ? (c2 ? a : b) : e" in (info.value.hint or info.value.message)


def test_conditionals_that_both_read_alike_are_accepted():
    values = op_values("t\n.param x=7\n"
                       "V1 n1 0 {x > 1 ? (x < 5 ? 10 : 20) : 30}\n"   # parenthesised: 20
                       "V2 n2 0 {x < 1 ? 10 : x < 5 ? 20 : 30}\n"     # chained in the false branch: 30
                       "V3 n3 0 {1 ? max(0 ? 1 : 2, 0) : 3}\n"       # inside a call's parentheses: 2
                       "B1 n4 0 V={v(n1) > 1 ? v(n1) < 5 ? 10 : 20 : 30}\n"  # B source: C's reading, 20
                       "R1 n4 0 1k\n.op\n", ["v(n1)", "v(n2)", "v(n3)", "v(n4)"])
    assert values == {"v(n1)": 20.0, "v(n2)": 30.0, "v(n3)": 2.0, "v(n4)": 20.0}


@pytest.mark.ngspice
def test_ngspice_reads_the_nested_conditional_otherwise_and_the_parenthesised_one_as_c(tmp_path):
    ref = ngspice_print("t\nV1 n1 0 {1 ? 0 ? 10 : 20 : 30}\nV2 n2 0 {1 ? (0 ? 10 : 20) : 30}\n"
                        "V3 n3 0 {0 ? 2 : 0 ? 4 : 5}\nR1 n1 0 1\nR2 n2 0 1\nR3 n3 0 1\n.op",
                        ["v(n1)", "v(n2)", "v(n3)"], tmp_path)
    assert ref == {"v(n1)": 10.0, "v(n2)": 20.0, "v(n3)": 5.0}
    got = op_values("t\nV2 n2 0 {1 ? (0 ? 10 : 20) : 30}\nV3 n3 0 {0 ? 2 : 0 ? 4 : 5}\n"
                    "R2 n2 0 1\nR3 n3 0 1\n.op\n", ["v(n2)", "v(n3)"])
    assert got == {"v(n2)": 20.0, "v(n3)": 5.0}


# -- instance parameters are evaluated in the instance's scope, in ngspice's order ----------------

SCOPE = """instance parameter scope
.param r1=5k r2=7k g=100 rint=1k
.subckt s a params: {defaults}
.param rint={body}
Ra a 0 {{r1}}
Rb a 0 {{r2}}
Rc a 0 {{rint}}
.ends
V1 x 0 1
X1 x s {inst}
.op
"""

# (defaults, body rint, instance parameters, ngspice 39's resistances Ra, Rb, Rc)
SCOPE_CASES = [
    ("r1=1k r2=1k", "4k", "r1=2k r2={r1}", 2e3, 2e3, 4e3),        # the instance's r1, not the caller's 5k
    ("r1=1k r2=1k", "4k", "r1={r2} r2=3k", 3e3, 3e3, 4e3),        # a number is assigned first
    ("r1=1k r2=1k", "4k", "r1={r1*2}", 10e3, 1e3, 4e3),           # its own name: the caller's r1
    ("r1=1k r2=1k", "4k", "r1={rint}", 4e3, 1e3, 4e3),            # the body's .param, not the caller's rint
    ("r1=1k r2=1k", "4k", "rint={r1*3}", 1e3, 1e3, 3e3),          # an instance value replacing a body .param
    ("r1=1k r2=1k", "4k", "r1={r2} r2={r2*2}", 7e3, 14e3, 4e3),   # r2 is assigned after r1: the caller's
    ("r2=1k r1=1k", "4k", "r1={r2} r2={r2*2}", 14e3, 14e3, 4e3),  # ... before it: the instance's
    ("r1={r2} r2={g*20}", "4k", "", 2e3, 2e3, 4e3),               # defaults sorted by what they read
    ("r1=1k r2={g*20}", "4k", "r1={r2}", 7e3, 2e3, 4e3),          # ... an instance's value keeps the place
    ("r1={rint*2} r2=1k", "{g*20}", "", 4e3, 1e3, 2e3),           # body .params sorted with the defaults
]


@pytest.mark.parametrize("defaults, body, inst, ra, rb, rc", SCOPE_CASES)
def test_instance_values_follow_ngspice_assignment_order(defaults, body, inst, ra, rb, rc):
    value = op_values(SCOPE.format(defaults=defaults, body=body, inst=inst), ["i(v1)"])["i(v1)"]
    assert value == pytest.approx(-(1 / ra + 1 / rb + 1 / rc), rel=1e-12)


@pytest.mark.ngspice
@pytest.mark.parametrize("defaults, body, inst, ra, rb, rc", SCOPE_CASES)
def test_instance_scope_cases_are_ngspice_s(defaults, body, inst, ra, rb, rc, tmp_path):
    ref = ngspice_print(SCOPE.format(defaults=defaults, body=body, inst=inst), ["i(v1)"], tmp_path)["i(v1)"]
    assert ref == pytest.approx(-(1 / ra + 1 / rb + 1 / rc), rel=1e-9)


@pytest.mark.parametrize("defaults, body", [("r1={r1*3} r2=1k", ""), ("r1=1k r2=1k", ".param r1={r1*3}")])
def test_a_default_or_body_param_reading_its_own_name_reads_the_caller(defaults, body):
    # ngspice 39: 3 * the caller's r1 (5k); netdae called this a cycle
    text = (f"t\n.param r1=5k\n.subckt s a params: {defaults}\n{body}\nRa a 0 {{r1}}\nRb a 0 {{r2}}\n.ends\n"
            "V1 x 0 1\nX1 x s\n.op\n")
    assert op_values(text, ["i(v1)"])["i(v1)"] == pytest.approx(-(1 / 15e3 + 1 / 1e3), rel=1e-12)


@pytest.mark.parametrize("inst", ["r2={r2*3}", "r1={r2} r2={g*2}"])
def test_a_name_read_before_assignment_without_a_caller_value_is_an_error(inst):
    # the message named the caller's value as "parameter 'r2'", as if the instance's own r2 were unknown
    with pytest.raises(NetlistError, match="unknown parameter 'r2' in the value of 'r2' where the subcircuit is "
                                           "called \\(the instance's own 'r2' is not assigned before the parameter "
                                           "that reads it\\)"):
        load(f"t\n.param g=1\n.subckt s a params: r1=1 r2=1k\nRb a 0 {{r2}}\n.ends\nV1 x 0 1\nX1 x s {inst}\n.op\n")


def test_nested_instances_pass_formals_and_caller_values():
    text = """nested
.param p=1k
.subckt inner a params: r=1 p=1
Ra a 0 {r}
Rb a 0 {p}
.ends
.subckt outer a params: p=3k q=2
X1 a inner r={p} p={p*q}
X2 a inner r={p+q}
.ends
V1 x 0 1
X1 x outer
X2 x outer p={p*5}
.op
"""
    # inner's r is assigned before its p: r={p} reads outer's p; in X2 inner's p is the number 1
    x1 = 1 / 3e3 + 1 / 6e3 + 1 / 3 + 1
    x2 = 1 / 5e3 + 1 / 10e3 + 1 / 3 + 1
    assert op_values(text, ["i(v1)"])["i(v1)"] == pytest.approx(-(x1 + x2), rel=1e-12)


# -- .nodeset under uic ---------------------------------------------------------------------------

NODESET_UIC = """nodeset with uic
R1 0 a 10k
C1 a 0 1n
R2 0 b 10k
C2 b 0 1n
.nodeset v(a)=0.2 v(b)=0.3
.ic v(b)=0.5
.tran 1u 20u uic
"""


def test_a_nodeset_is_the_initial_voltage_of_a_uic_transient():
    # ngspice (CKTic) starts a uic transient from the .nodeset values, .ic overriding them:
    # C1 starts at 0.2 V, C2 at its .ic 0.5 V, and both decay with tau = 10 us
    (result,) = netdae.run(load(NODESET_UIC))
    t = result.axis
    for node, v0 in (("v(a)", 0.2), ("v(b)", 0.5)):
        assert result.signals[node][0] == pytest.approx(v0, abs=1e-12)
        expected = v0 * np.exp(-t / 1e-5)
        assert np.max(np.abs(result.signals[node] - expected)) < 2e-3 * v0


@pytest.mark.ngspice
def test_nodeset_under_uic_is_ngspice_s(tmp_path):
    text = NODESET_UIC.replace(".tran 1u 20u uic", ".tran 1u 20u 0 0.1u uic")
    cir = tmp_path / "u.cir"
    cir.write_text(text + ".control\nset numdgt=12\nrun\nmeas tran va find v(a) at=10u\n"
                   "meas tran vb find v(b) at=10u\n.endc\n.end\n")
    proc = subprocess.run(["ngspice", "-b", str(cir)], capture_output=True, text=True, timeout=60, cwd=tmp_path)
    ref = {m.group(1): float(m.group(2)) for m in re.finditer(r"^(va|vb)\s*=\s*(\S+)", proc.stdout, re.M)}
    assert ref["va"] == pytest.approx(0.2 * np.exp(-1), rel=2e-3), proc.stdout
    assert ref["vb"] == pytest.approx(0.5 * np.exp(-1), rel=2e-3), proc.stdout


# -- a definition repeated identically (a library section included twice) ---------------------------

LIBRARY = """.lib tt
.model dlib d is=1e-14
.subckt clamp a
D1 a 0 dlib
.ends
.endl tt
"""


def test_a_library_section_included_twice_is_read_once_with_warnings(tmp_path):
    # ngspice 39 keeps the first .subckt ("redefinition of .subckt clamp, ignored") and the first .model
    (tmp_path / "m.lib").write_text(LIBRARY)
    text = "t\n.lib m.lib tt\n.lib m.lib tt\nV1 in 0 0.6\nX1 in clamp\n.op\n"
    circuit = load(text, path=tmp_path / "t.cir")
    warnings = [d.message for d in circuit.diagnostics if d.severity == "warning"]
    assert any("model 'dlib' is defined again, identically" in w for w in warnings)
    assert any("subcircuit 'clamp' is defined again, identically" in w for w in warnings)
    assert [e.name for e in circuit.elements] == ["v1", "d.x1.d1"]


@pytest.mark.parametrize("text, message", [
    ("t\n.subckt s a\nR1 a 0 1k\n.ends\n.subckt s a\nR1 a 0 2k\n.ends\nX1 n s\n", "subcircuit 's' is defined twice"),
    ("t\n.subckt s a\nR1 a 0 1k\n.ends\n.subckt s b\nR1 b 0 1k\n.ends\nX1 n s\n", "subcircuit 's' is defined twice"),
    ("t\n.model dm d is=1e-14\n.model dm d is=1e-13\nD1 a 0 dm\n", "model 'dm' is defined twice"),
])
def test_a_different_repetition_is_still_an_error_naming_ngspice_s_choice(text, message):
    with pytest.raises(NetlistError, match=message) as info:
        load(text)
    assert "first definition" in info.value.hint


@pytest.mark.ngspice
def test_ngspice_reads_an_identical_repetition_as_one_definition(tmp_path):
    (tmp_path / "m.lib").write_text(LIBRARY)
    text = "t\n.lib m.lib tt\n.lib m.lib tt\nV1 in 0 0.6\nX1 in clamp\n.op"
    ref = ngspice_print(text, ["i(v1)"], tmp_path)["i(v1)"]
    (result,) = netdae.run(load(text + "\n", path=tmp_path / "t.cir"))
    assert float(result.signals["i(v1)"][-1]) == pytest.approx(ref, rel=1e-6)


# -- ngspice's other names of R, C and L instance parameters ----------------------------------------

OTHER_NAMES = """other names
V1 in 0 1
R1 in 0 resistance=2k
R2 in 0 1k noise=0 bv_max=10
C1 in 0 cap=3u bv_max=5
C2 in 0 capacitance=4u
L1 in x inductance=5m
R3 x 0 100
.op
"""


def test_other_names_of_instance_parameters_are_read():
    circuit = load(OTHER_NAMES)
    got = {e.name: e.value for e in circuit.elements}
    assert got["r1"] == 2e3 and got["c1"] == 3e-6 and got["c2"] == 4e-6 and got["l1"] == 5e-3
    assert next(e for e in circuit.elements if e.name == "r2").params["noisy"] == 0.0
    notes = [d.message for d in circuit.diagnostics if d.severity == "note" and "bv_max" in d.message]
    assert len(notes) == 2


@pytest.mark.ngspice
def test_other_names_agree_with_ngspice(tmp_path):
    ref = ngspice_print(OTHER_NAMES, ["i(v1)"], tmp_path)["i(v1)"]
    assert op_values(OTHER_NAMES, ["i(v1)"])["i(v1)"] == pytest.approx(ref, rel=1e-9)


# -- a coupling factor written k= or coefficient= ---------------------------------------------------

COUPLED = """coupling by name
V1 in0 0 AC 1
R1 in0 in 1
L1 in 0 1m
L2 s 0 1m
R2 s 0 10
K1 L1 L2 {key}0.5
.ac lin 1 1k 1k
"""


@pytest.mark.parametrize("key", ["k=", "coefficient=", "K = "])
def test_a_coupling_factor_may_be_named(key):
    (k1,) = [e for e in load(COUPLED.format(key=key)).elements if e.name == "k1"]
    assert k1.value == 0.5


@pytest.mark.ngspice
@pytest.mark.parametrize("key", ["k=", "coefficient="])
def test_a_named_coupling_factor_is_ngspice_s(key, tmp_path):
    text = COUPLED.format(key=key)
    ref = ngspice_print(text, ["mag(i(v1))"], tmp_path)["mag(i(v1))"]
    (result,) = netdae.run(load(text))
    assert abs(complex(result.signals["i(v1)"][0])) == pytest.approx(ref, rel=1e-6)


# -- the constant e of behavioural expressions ----------------------------------------------------

CONSTANT_E = """constant e
.param e=4
V1 x 0 1
B1 n1 0 V=e*v(x)
R1 n1 0 1k
E1 n2 0 value={e*v(x)}
R2 n2 0 1k
R3 n3 0 {e}
V3 n3 0 1
.op
"""


def test_e_is_the_constant_in_behavioural_expressions_and_a_name_in_parameters():
    # ngspice 39's B-source parser reads e as 2.71828... even where a .param e exists; numparam reads the .param
    values = op_values(CONSTANT_E, ["v(n1)", "v(n2)", "i(v3)"])
    assert values["v(n1)"] == pytest.approx(math.e, rel=1e-12)
    assert values["v(n2)"] == pytest.approx(math.e, rel=1e-12)
    assert values["i(v3)"] == pytest.approx(-0.25, rel=1e-12)
    assert op_values("t\nV1 x 0 1\nB1 n1 0 V=2*e*v(x)\nR1 n1 0 1\n.op\n", ["v(n1)"])["v(n1)"] == \
        pytest.approx(2 * math.e, rel=1e-12)


@pytest.mark.ngspice
def test_constant_e_is_ngspice_s(tmp_path):
    ref = ngspice_print(CONSTANT_E, ["v(n1)", "v(n2)", "i(v3)"], tmp_path)
    got = op_values(CONSTANT_E, ["v(n1)", "v(n2)", "i(v3)"])
    for name in ref:
        assert got[name] == pytest.approx(ref[name], rel=1e-9)


PDK_LIKE = """a wrapper subcircuit whose instance values read each other
.param w=10u wtot=8u
.subckt rwrap a b params: w=1u l=1u nf=1
.param weff={w/nf}
.param rsq={l/weff}
R1 a b {rsq*1k}
.ends
.subckt cell a b params: w=4u
X1 a m rwrap w={w} l={w/2} nf=2
X2 m b rwrap w={wtot} l=2u nf={1+1}
.ends
V1 in 0 1
X1 in 0 cell
X2 in 0 rwrap w=3u l={w*2}
.op
"""


def test_instance_values_reading_each_other_in_a_wrapper():
    # top X2: l = 2 * its own w (3u) -> 2k; cell's X1: w = cell's w (4u), l = that w / 2 -> 1k;
    # cell's X2: w = wtot (8u), nf = 2 -> 500 ohm; as ngspice 39 computes it (netdae read l={w*2} with the
    # caller's w=10u before)
    value = op_values(PDK_LIKE, ["i(v1)"])["i(v1)"]
    assert value == pytest.approx(-(1 / 2e3 + 1 / 1.5e3), rel=1e-12)


@pytest.mark.ngspice
def test_wrapper_is_ngspice_s(tmp_path):
    ref = ngspice_print(PDK_LIKE, ["i(v1)"], tmp_path)["i(v1)"]
    assert op_values(PDK_LIKE, ["i(v1)"])["i(v1)"] == pytest.approx(ref, rel=1e-9)


# -- a .func body expanded into a behavioural expression is read by the behavioural rules -------------

FUNC_IN_B = """func bodies in B sources
.func fp(x) {pwr(x, 2)}
.func fm(x) {x*1mil}
.func h(x) = {x > 1 ? x < 5 ? 10 : 20 : 30}
.param p={fp(-2)}
V1 x 0 -2
B1 n1 0 V=fp(v(x))
R1 n1 0 1k
B2 n2 0 V=fm(1)
R2 n2 0 1k
B3 n3 0 V=h(7)
R3 n3 0 1k
V4 n4 0 {p}
R4 n4 0 1k
.op
"""


def test_a_func_body_in_a_behavioural_expression_follows_the_behavioural_rules():
    # ngspice expands the call textually: its B-source parser reads pwr(x, 2) as sgn(x) |x|**2 and 1mil as
    # 25.4e-6, and the nested conditional as C does; a parameter expression reads pwr as |x|**2 (numparam)
    values = op_values(FUNC_IN_B, ["v(n1)", "v(n2)", "v(n3)", "v(n4)"])
    assert values == pytest.approx({"v(n1)": -4.0, "v(n2)": 25.4e-6, "v(n3)": 20.0, "v(n4)": 4.0}, rel=1e-12)


def test_a_func_with_a_nested_conditional_is_refused_where_a_parameter_calls_it():
    with pytest.raises(NetlistError, match=r"unparenthesised in the true branch.*\.func at"):
        load("t\n.func h(x) = {x > 1 ? x < 5 ? 10 : 20 : 30}\nR1 a 0 {h(7)}\nV1 a 0 1\n.op\n")


@pytest.mark.ngspice
def test_func_bodies_in_b_sources_are_ngspice_s(tmp_path):
    names = ["v(n1)", "v(n2)", "v(n3)", "v(n4)"]
    ref = ngspice_print(FUNC_IN_B, names, tmp_path)
    got = op_values(FUNC_IN_B, names)
    for name in names:
        assert got[name] == pytest.approx(ref[name], rel=1e-6)


FUNC_ARGUMENT_E = """a .func whose argument is named e, called in B sources
.func f(e) {e*2}
.func g(x) {x*e}
B1 n1 0 V=f(3)
R1 n1 0 1k
B2 n2 0 V=g(2)
R2 n2 0 1k
.op
.end
"""


def test_a_func_argument_named_e_is_the_argument_in_a_behavioural_expression():
    # ngspice substitutes the arguments as text before its B-source parser reads e as the constant: f(3) = 6;
    # a body's e that is no argument stays the constant: g(2) = 2e
    values = op_values(FUNC_ARGUMENT_E, ["v(n1)", "v(n2)"])
    assert values == pytest.approx({"v(n1)": 6.0, "v(n2)": 2 * math.e}, rel=1e-12)


@pytest.mark.ngspice
def test_a_func_argument_named_e_is_ngspice_s(tmp_path):
    names = ["v(n1)", "v(n2)"]
    ref = ngspice_print(FUNC_ARGUMENT_E, names, tmp_path)
    got = op_values(FUNC_ARGUMENT_E, names)
    for name in names:
        assert got[name] == pytest.approx(ref[name], rel=1e-6)
