"""The reader's limits and edges: sizes, nesting, empty circuits, parameter overrides.

Each case once ended in an internal error (a Python exception other than
NetlistError, or memory exhaustion); each must now be a located
NetlistError, or work.
"""

from __future__ import annotations

import time
from pathlib import Path

import pytest

from netdae.circuit import Params
from netdae.errors import NetlistError
from netdae.netlist import load, parse
from netdae.netlist.size import MAX_SUBCKT_DEPTH, flat_element_count

NETLISTS = Path(__file__).resolve().parent.parent / "netlists"


def doubling(levels: int) -> str:
    """Nested subcircuits, each instantiating the next twice: 2**levels resistors plus V1."""
    defs = "".join(f".subckt s{i} a b\nX1 a m s{i + 1}\nX2 m b s{i + 1}\n.ends\n" for i in range(levels))
    return f"doubling\n{defs}.subckt s{levels} a b\nR1 a b 1k\n.ends\nX0 1 0 s0\nV1 1 0 1\n.op\n"


def test_a_million_elements_is_refused_before_expansion():
    start = time.perf_counter()
    with pytest.raises(NetlistError) as info:
        load(doubling(20))
    elapsed = time.perf_counter() - start
    err = info.value
    assert elapsed < 2.0  # counted, not expanded (expanding takes tens of seconds and gigabytes)
    assert "1,048,577 elements" in err.message and "limit of 500,000" in err.message
    assert "1 x s0" in err.message and "2 x s1" in err.message and "2 x s20" in err.message
    assert (err.location.line, err.location.column) == (doubling(20).split("\n").index("X0 1 0 s0") + 1, 8)
    assert "max_elements" in err.hint


def test_max_elements_raises_and_lowers_the_limit():
    with pytest.raises(NetlistError, match="4,097 elements, more than the limit of 4,000"):
        load(doubling(12), max_elements=4000)
    c = load(doubling(12), max_elements=5000)
    assert len(c.elements) == 4097
    assert c.with_params().elements[-1].name == "v1"  # the limit travels with the circuit


@pytest.mark.parametrize("path", sorted(NETLISTS.glob("*.cir")), ids=lambda p: p.name)
def test_flat_count_matches_the_expansion(path):
    assert flat_element_count(parse(path).top) == len(load(path).elements)


def test_flat_count_with_local_and_shadowing_definitions():
    text = ("t\n.subckt leaf a b\nR1 a b 1\n.ends\n.subckt outer a b\n.subckt leaf a b\nR1 a m 1\nR2 m b 1\n"
            ".ends\nX1 a m leaf\nX2 m b leaf\nR3 a b 1\n.ends\nX1 1 0 outer\nX2 1 0 leaf\nV1 1 0 1\n")
    assert flat_element_count(parse(text).top) == len(load(text).elements) == 5 + 1 + 1


def test_deep_subcircuit_chain_is_located():
    n = 3 * MAX_SUBCKT_DEPTH
    text = "t\n" + "".join(f".subckt s{i} a b\nX1 a b s{i + 1}\n.ends\n" for i in range(n))
    text += f".subckt s{n} a b\nR1 a b 1k\n.ends\nX0 1 0 s0\nV1 1 0 1\n"
    with pytest.raises(NetlistError, match=f"nested deeper than {MAX_SUBCKT_DEPTH} levels") as info:
        load(text)
    assert info.value.location.line > 1


def test_deeply_nested_definitions_are_located():
    n = 3 * MAX_SUBCKT_DEPTH
    text = "t\n" + "".join(f".subckt n{i} a b\n" for i in range(n)) + "R1 a b 1k\n" + ".ends\n" * n
    with pytest.raises(NetlistError, match="definitions nested deeper") as info:
        load(text + "X0 1 0 n0\nV1 1 0 1\n")
    assert info.value.location.line == MAX_SUBCKT_DEPTH + 2  # the title, then 100 definitions allowed


def test_deep_include_chain_is_located(tmp_path):
    for i in range(300):
        (tmp_path / f"f{i}.cir").write_text(f".include f{i + 1}.cir\n")
    (tmp_path / "f300.cir").write_text("R1 1 0 1k\n")
    with pytest.raises(NetlistError, match="included deeper than 64 levels") as info:
        load("t\n.include f0.cir\nV1 1 0 1\n", path=str(tmp_path / "main.cir"))
    assert info.value.location.file.endswith(".cir")


def test_nul_character_in_an_include_name():
    with pytest.raises(NetlistError, match="NUL character") as info:
        load('t\n.include "a\x00b.cir"\n')
    assert (info.value.location.line, info.value.location.column) == (2, 10)
    with pytest.raises(NetlistError, match="NUL character"):
        load("bad\x00name.cir")


def test_zero_capacitance_on_an_otherwise_unused_node():
    with pytest.raises(NetlistError, match="node '2' is connected only through zero capacitances") as info:
        load("t\nV1 1 0 1\nR1 1 0 1k\nC1 2 1 0\n.op\n")
    assert info.value.location.line == 4
    # a zero capacitance beside another element is fine (ngspice leaves it out too)
    assert len(load("t\nV1 1 0 1\nR1 1 2 1k\nC1 2 0 0\nR2 2 0 1k\n.op\n").elements) == 4


@pytest.mark.parametrize("text, what", [("t\n.tran 1u 10u\n", "no elements"),
                                        ("t\nR1 0 0 1k\n.op\n", "no node other than ground")])
def test_analysis_of_an_empty_circuit_is_located(text, what):
    # ngspice 39 stops (exit status 1, or an assertion failure) on these
    with pytest.raises(NetlistError, match=what) as info:
        load(text)
    assert info.value.location.line == text.count("\n")
    assert load("t\n").elements == []  # nothing to simulate is fine when nothing is asked


# -- parameters changed without editing the text ----------------------------------
DIVIDER = "divider\n.param r=1k ratio={2*r} unused=5\nV1 a 0 1\nR1 a b {r}\nR2 b 0 {ratio}\n.op\n"


def test_load_with_params_overrides_top_level_values():
    c = load(DIVIDER, params={"R": 2e3})
    assert [el.value for el in c.elements[1:]] == [2e3, 4e3]
    assert dict(c.params) == {"r": 2e3, "ratio": 4e3, "unused": 5.0}


def test_with_params_reelaborates_and_keeps_earlier_overrides():
    c = load(DIVIDER, params={"unused": 1.0})
    d = c.with_params(r=10.0)
    e = d.with_params({"ratio": 7.0})
    assert [el.value for el in c.elements[1:]] == [1e3, 2e3]
    assert [el.value for el in d.elements[1:]] == [10.0, 20.0]
    assert [el.value for el in e.elements[1:]] == [10.0, 7.0]
    assert e.params["unused"] == 1.0


def test_params_reach_subcircuits_through_dynamic_scoping():
    text = "t\n.param g=1\n.subckt s a\nR1 a 0 {1k*g}\n.ends\nX1 a s\nV1 a 0 1\n"
    assert load(text, params={"g": 3}).element("r.x1.r1").value == 3e3


@pytest.mark.parametrize("params, match", [({"nope": 1.0}, "no top-level .param defines 'nope'"),
                                           ({"r": "1k"}, "must be a finite number"),
                                           ({"r": float("nan")}, "must be a finite number"),
                                           ({"r": True}, "must be a finite number")])
def test_bad_overrides_are_errors(params, match):
    with pytest.raises(NetlistError, match=match):
        load(DIVIDER, params=params)


def test_subcircuit_parameters_cannot_be_overridden():
    text = "t\n.subckt s a params: r=1k\nR1 a 0 {r}\n.ends\nX1 a s\nV1 a 0 1\n"
    with pytest.raises(NetlistError, match="no top-level .param defines 'r'"):
        load(text, params={"r": 2.0})


def test_circuit_params_are_read_only():
    c = load(DIVIDER)
    assert isinstance(c.params, Params)
    with pytest.raises(TypeError):
        c.params["r"] = 5.0
    assert not hasattr(c.params, "update")


def test_with_params_needs_a_netlist():
    from netdae.circuit import Circuit

    with pytest.raises(ValueError, match="read from a netlist"):
        Circuit("hand made").with_params(r=1.0)


# -- impossible temperatures and model values: at the value, not a later convergence failure --------
DIODE = "t\nV1 1 0 0.7\nR1 1 2 1k\nD1 2 0 dm\n.model dm d ({model})\n{extra}\n.op\n"


@pytest.mark.parametrize("extra, line, column, match", [
    (".temp -300", 6, 7, ".temp = -300 degC is not above absolute zero"),
    (".options temp=-273.15", 6, 15, "option temp = -273.15 degC"),
    (".options tnom=-300", 6, 15, "option tnom = -300 degC"),
    ("R9 1 0 1k temp=-280", 6, 16, "instance temperature = -280 degC"),
    (".dc temp 27 -300 -10", 6, 13, "sweep stop temperature = -300 degC"),
])
def test_temperature_below_absolute_zero_is_located(extra, line, column, match):
    with pytest.raises(NetlistError, match=match) as info:
        load(DIODE.format(model="", extra=extra))
    assert (info.value.location.line, info.value.location.column) == (line, column)


@pytest.mark.parametrize("model, column, match", [
    ("is=-1e-14", 17, "is must be >= 0"), ("n=0", 16, "n must be > 0"), ("rs=-1", 17, "rs must be >= 0"),
    ("cjo=-1p", 18, "cjo must be >= 0"), ("tnom=-300", 19, "not above absolute zero"),
])
def test_impossible_model_value_is_located(model, column, match):
    import netdae

    with pytest.raises(NetlistError, match=match) as info:
        netdae.run(load(DIODE.format(model=model, extra="")))
    assert (info.value.location.line, info.value.location.column) == (5, column)


def test_zero_saturation_current_is_allowed():
    import netdae

    assert netdae.run(load(DIODE.format(model="is=0", extra="")))[0].status == 0


def _chain(n: int, body: str = "{{p{j}+1}}", first: str = "1") -> str:
    lines = [f".param p0={first}"] + [f".param p{i}=" + body.format(j=i - 1) for i in range(1, n)]
    return "chain\n" + "\n".join(lines) + f"\nV1 a 0 1\nR1 a 0 {{p{n - 1}}}\n.op\n.end\n"


@pytest.mark.parametrize("body", ["{{p{j}+1}}", "{{-(-p{j}) + 1}}", "{{max(p{j}, 0) + 1}}",
                                  "{{p{j} > 0 ? p{j} + 1 : 0}}", "{{f(p{j})}}"])
def test_a_chain_of_2000_dependent_params_is_evaluated(body):
    """Each parameter's evaluation nested the one before: 'expression nested deeper than 300 levels' at
    about 123 cards (ngspice 39 runs 400 and more)."""
    text = _chain(2000, body).replace("chain\n", "chain\n.func f(x)={x+1}\n")
    assert load(text).element("r1").value == 2000.0
    reverse = "\n".join(reversed(text.split("\n")[2:2002]))  # defined after their use
    assert load("chain\n.func f(x)={x+1}\n" + reverse + "\nV1 a 0 1\nR1 a 0 {p1999}\n.op\n").element("r1").value \
        == 2000.0


def test_a_cycle_through_2000_params_is_named_and_deep_expressions_stay_refused():
    with pytest.raises(NetlistError, match=r"parameter cycle: p1999 -> p1998 -> .* \(2000 parameters\) \.\.\. "
                                           r"-> p3 -> p2 -> p1 -> p0 -> p1999") as info:
        load(_chain(2000, first="{p1999+1}"))
    assert info.value.location.line == 2001
    with pytest.raises(NetlistError, match="nested deeper than 300 levels"):
        load("t\n.param a={" + "(" * 400 + "1" + ")" * 400 + "}\nR1 x 0 {a}\n")


def _func_chain(n: int, use: str) -> str:
    """``n`` distinct functions, each calling the next, the last the identity; ``use`` applies the first."""
    funcs = "".join(f".func f{j}(x) {{f{j + 1}(x)}}\n" for j in range(n - 1)) + f".func f{n - 1}(x) {{x}}\n"
    return f"chain of functions\n{funcs}V1 a 0 1\n{use}\n.op\n.end\n"


@pytest.mark.parametrize("use", ["R1 a 0 {f0(1)}", "B1 b 0 V={f0(v(a))}\nR1 b 0 1k"])
def test_a_deep_chain_of_distinct_functions_is_not_called_recursive(use):
    """2,000 functions each calling the next nest deeper than the limit without any recursion: the refusal
    said 'recursive .func?'; it says how deep, and names recursion only where a name repeats in the chain."""
    from netdae.netlist.params import MAX_CALL_DEPTH

    with pytest.raises(NetlistError, match=f"function calls nested deeper than {MAX_CALL_DEPTH}") as info:
        load(_func_chain(2000, use))
    assert "recursive" not in str(info.value)
    assert f"f0 -> f1 -> f2" in str(info.value)
    recursive = "t\n.func f(x) {g(x)}\n.func g(x) {h(x)}\n.func h(x) {g(x)}\nV1 a 0 1\n" + use.replace("f0", "f")
    with pytest.raises(NetlistError, match=f"function calls nested deeper than {MAX_CALL_DEPTH}") as info:
        load(recursive)
    assert "recursive .func 'g'" in str(info.value) and "g -> h -> g" in str(info.value)
