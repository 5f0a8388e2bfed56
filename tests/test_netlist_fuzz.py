"""Fuzzing the reader: whatever the text, only NetlistError may come out of ``load``.

Four generators: random characters, random SPICE tokens arranged in cards,
valid netlists truncated at a random point, and valid netlists mutated
(characters and tokens deleted, inserted, replaced, lines swapped).
"""

from __future__ import annotations

from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, seed, settings
from hypothesis import strategies as st

from netdae.circuit import Circuit
from netdae.errors import NetlistError
from netdae.netlist import load

NETLISTS = Path(__file__).resolve().parent.parent / "netlists"

#: Examples per generator: enough to cover every card type, a few seconds in all.
EXAMPLES = 300
SETTINGS = settings(max_examples=EXAMPLES, deadline=None, database=None,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])

SEEDS = [
    "seed rc\nV1 in 0 PULSE(0 1 0 1u 1u 1m 2m) AC 1\nR1 in out 1k\nC1 out 0 1u ic=0\n.tran 1u 5m\n.end\n",
    "seed sub\n.param a=2 b={a*3}\n.func f(x)={x*a}\n.subckt s p q params: r=1k\nR1 p m {r*f(1)}\n"
    "+ tc1=1m\nL1 m q 1m ic=0\n.model dm d (is=1e-14)\nD1 m q dm\n.ends s\nX1 1 0 s r=2k\nX2 1 2 s\n"
    "V1 1 0 dc 1 sin(0 1 1k)\nK1 l.x1.l1 l.x2.l1 0.5\n.ic v(1)=0\n.options reltol=1e-4 method=gear\n"
    ".save v(1) i(v1)\n.dc v1 0 1 0.1\n.end\n",
    "seed controlled\nV1 a 0 1\nE1 b 0 a 0 2\nG1 c 0 a b 1m\nF1 d 0 v1 3\nH1 e 0 v1 1k\n"
    "B1 f 0 V=V(a)*time+I(v1)\nEop g 0 a g OPAMP\nE2 h 0 POLY(1) a 0 0 1 2\nQ1 c b e qm\n.model qm npn\n"
    "M1 d g s b nm w=1u l=1u\n.model nm nmos level=1\nI1 0 a pwl(0 0 1m 1 2m 0)\nR9 a 0 1\n.op\n"
    ".ac dec 10 1 1meg\n.end\n",
    "seed lines\n* comment\nR1 a b 1k ; inline\n+ tc1=0\nC1 a 0 1u $ c\n.control\nrun\n.endc\n"
    ".lib corner\n.param x=1\n.endl\n.param x=2\n.title New\nR2 b 0 {x}\n.end\n",
] + [p.read_text() for p in sorted(NETLISTS.glob("*.cir"))[:6]]

VOCAB = [
    "R1", "r2", "C1", "L1", "L2", "K1", "V1", "I1", "E1", "G1", "F1", "H1", "B1", "D1", "Q1", "M1", "X1", "S1",
    "a", "b", "0", "gnd", "out", "in", "1k", "1u", "1meg", "1mil", "-1", "1e99", "1e999", "4k7", "{", "}",
    "{a*2}", "'b+1'", "(", ")", "=", ",", "+", "*", "$", ";", "//", "params:", "ic=1", "tc=1,2", "dc", "ac",
    "pulse(0 1)", "sin(0 1 1k)", "pwl(0 0 1 1)", "r=0", "td=1", "exp(0", "poly(2)", "value={v(a)}", "V=",
    "I(v1)", "V(a,b)", "opamp", "off", "area", "dm", "qm", "nm", "s", ".subckt", ".ends", ".param", ".func",
    ".model", "d", "npn", "nmos", "level=1", ".tran", ".ac", "dec", ".dc", ".op", ".ic", ".nodeset", "v(a)=1",
    ".options", "reltol=1e-3", "method=gear", ".temp", ".save", ".print", ".probe", ".plot", ".global",
    ".include", ".lib", ".endl", ".control", ".endc", ".end", ".title", ".four", "temp", "uic", "time",
    "f(1)", "sqrt(-1)", "1/0", "((((", "))))", "?", ":", "&&", "!", "**", "^", '"', "''",
    # numbers ngspice reads in part or with the micro sign; unicode digits
    "2\u00b5", "3\u03bc", "{2\u00b5}", "1.2.3k", "1e3e4", "\u00b2", "{\u00b2}", "\u0663",
    # instance parameters of R, C, L and temperatures
    "ac=2k", "ac=0", "scale=2", "scale=0", "dtemp=10", "temp=-300", "temp=27", "tc1=0.01", "m=2",
    ".temp -300", ".options temp=-300", "tnom=-300", "is=-1", "n=0", "rs=-1", "C1 2 0 0", "0",
    # file names and odd characters
    '"a\x00b"', "\x00", "\ufeff", "\u00ff",
]

token = st.sampled_from(VOCAB)
card = st.lists(token, min_size=1, max_size=9).map(" ".join)
token_netlists = st.lists(card, min_size=0, max_size=12).map(lambda cards: "fuzz\n" + "\n".join(cards) + "\n")
char_netlists = st.text(alphabet=st.sampled_from(list("RCLVIEXBKdq01ab .+-*/(){}'=,;$*\n\tkmunpgtMEG^?:!&|<>\"")),
                        max_size=300).map(lambda s: "fuzz\n" + s + "\n")


@st.composite
def truncated(draw):
    text = draw(st.sampled_from(SEEDS))
    cut = draw(st.integers(min_value=0, max_value=len(text)))
    return text[:cut] + "\n"


@st.composite
def mutated(draw):
    text = draw(st.sampled_from(SEEDS))
    for _ in range(draw(st.integers(min_value=1, max_value=4))):
        op = draw(st.sampled_from(["delete", "insert", "replace", "token", "swap", "duplicate"]))
        pos = draw(st.integers(min_value=0, max_value=max(len(text) - 1, 0)))
        if op == "delete":
            text = text[:pos] + text[pos + draw(st.integers(1, 8)):]
        elif op == "insert":
            text = text[:pos] + draw(st.text(max_size=6)) + text[pos:]
        elif op == "replace":
            text = text[:pos] + draw(st.characters()) + text[pos + 1:]
        elif op == "token":
            text = text[:pos] + " " + draw(token) + " " + text[pos:]
        else:
            lines = text.split("\n")
            i = draw(st.integers(0, len(lines) - 1))
            j = draw(st.integers(0, len(lines) - 1))
            if op == "swap":
                lines[i], lines[j] = lines[j], lines[i]
            else:
                lines.insert(j, lines[i])
            text = "\n".join(lines)
    return text + "\n"


@st.composite
def hierarchies(draw):
    """Nested subcircuits: random depth and fan-out (sizes up to millions), sometimes recursive."""
    depth = draw(st.integers(0, 130))
    lines = ["hierarchy"]
    for i in range(depth):
        fan = draw(st.integers(1, 3))
        target = draw(st.sampled_from([i + 1, i + 1, i + 1, 0, i]))
        lines.append(f".subckt s{i} a b")
        lines += [f"X{k} a b s{target}" for k in range(fan)]
        lines.append(".ends")
    lines += [f".subckt s{depth} a b", "R1 a b 1k", draw(st.sampled_from(["", "C1 b c 0", "C1 a b 0"])), ".ends",
              "X0 1 0 s0", "V1 1 0 1", draw(st.sampled_from(["", ".op", ".tran 1u 1m"]))]
    return "\n".join(lines) + "\n"


@st.composite
def overrides(draw):
    """A valid netlist with random parameter overrides (names known or not, values of any type)."""
    text = draw(st.sampled_from(SEEDS[:2]))
    names = st.sampled_from(["a", "b", "r", "x", "A", "nope", ""])
    values = st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.integers(-10, 10), st.text(max_size=3),
                       st.none(), st.booleans())
    return text, draw(st.dictionaries(names, values, max_size=3))


@pytest.fixture(scope="module")
def where(tmp_path_factory):
    """An empty directory: relative .include names resolve there and find nothing."""
    return str(tmp_path_factory.mktemp("fuzz") / "fuzz.cir")


def _check(text: str, where: str) -> None:
    try:
        circuit = load(text, path=where)
    except NetlistError as exc:
        assert exc.location is None or exc.location.line >= 1
        str(exc)
    else:
        assert isinstance(circuit, Circuit)


@SETTINGS
@given(text=char_netlists)
def test_random_characters(text, where):
    _check(text, where)


@SETTINGS
@given(text=token_netlists)
def test_random_tokens(text, where):
    _check(text, where)


@SETTINGS
@given(text=truncated())
def test_truncated_netlists(text, where):
    _check(text, where)


@SETTINGS
@given(text=mutated())
def test_mutated_netlists(text, where):
    _check(text, where)


@SETTINGS
@given(text=hierarchies())
def test_hierarchies(text, where):
    _check(text, where)


@SETTINGS
@given(case=overrides())
def test_parameter_overrides(case, where):
    text, params = case
    try:
        circuit = load(text, path=where, params=params)
    except NetlistError as exc:
        str(exc)
    else:
        assert isinstance(circuit, Circuit)


#: The longer run: every generator, ten times the examples, a fixed seed (reproducible).
LONG = settings(SETTINGS, max_examples=10 * EXAMPLES)


@pytest.mark.fuzz
@pytest.mark.parametrize("strategy", [char_netlists, token_netlists, truncated(), mutated(), hierarchies()],
                         ids=["characters", "tokens", "truncated", "mutated", "hierarchies"])
def test_long_fixed_seed_run(strategy, where):
    @seed(20240601)
    @LONG
    @given(text=strategy)
    def run(text):
        _check(text, where)

    run()


def test_seeds_are_valid(where):
    for text in SEEDS:
        assert isinstance(load(text, path=where), Circuit)


def test_deep_nesting_is_an_error_not_a_crash():
    with pytest.raises(NetlistError, match="nested deeper"):
        load("t\nR1 a 0 {" + "(" * 2000 + "1" + ")" * 2000 + "}\n")
    with pytest.raises(NetlistError, match="nested deeper"):
        load("t\nB1 a 0 V=" + "*".join(["v(a)"] * 2000) + "\n")


def test_a_long_flat_sum_is_not_nesting():
    # a generated netlist's sum of hundreds of terms was refused as 'nested deeper than 300 levels' (ngspice
    # computes it): beyond 64 terms a chain of + and - is a balanced tree
    c = load("t\nV1 in 0 1\nR1 in 0 {" + "+".join(["1"] * 350) + "-1}\nB1 a 0 V=" + "+".join(["v(in)"] * 2000)
             + "\nR2 a 0 1k\n.op\n.end\n")
    assert next(el for el in c.elements if el.name == "r1").value == 349.0
    from netdae.netlist.expr import depth

    assert depth(next(el for el in c.elements if el.name == "b1").expr) < 20


def test_end_card_followed_by_a_comment():
    """Found by the long run: '.end;' reached the parser as a card it has no handler for."""
    assert [e.name for e in load("t\nR1 1 0 1k\n.end;\nR2 1 0 1\n").elements] == ["r1"]
    assert [e.name for e in load("t\nR1 1 0 1k\n.end $ done\nR2 1 0 1\n").elements] == ["r1"]
