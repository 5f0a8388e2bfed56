"""Numbers, lines and cards, expressions: the reader's lowest layers."""

from __future__ import annotations

import math

import pytest

from netdae.errors import NetlistError
from netdae.netlist.expr import (BEHAVIOURAL, Binary, Call, Const, Current, Param, Ternary, Time, Unary,
                                 Voltage, evaluate, fold_constants, parse_expression, to_text)
from netdae.netlist.lines import split_cards
from netdae.netlist.numbers import parse_number, scan_param_number


# -- numbers ------------------------------------------------------------------------
@pytest.mark.parametrize("token, value", [
    ("1", 1.0), ("-1.5", -1.5), ("+2", 2.0), (".5", 0.5), ("1.", 1.0), ("1e-3", 1e-3), ("1E3", 1e3),
    ("1.5d2", 150.0), ("1e3k", 1e6), ("1e", 1.0),
    ("1k", 1e3), ("1K", 1e3), ("1m", 1e-3), ("1M", 1e-3), ("1meg", 1e6), ("1MEG", 1e6), ("1Meg", 1e6),
    ("1mil", 25.4e-6), ("1MIL", 25.4e-6), ("1u", 1e-6), ("1n", 1e-9), ("1p", 1e-12), ("1f", 1e-15),
    ("1g", 1e9), ("1t", 1e12), ("10kOhm", 1e4), ("1uF", 1e-6), ("2.2nH", 2.2e-9), ("1F", 1e-15),
    ("1Farad", 1e-15), ("4k7", 4e3), ("3a", 3.0), ("5V", 5.0), ("1megohm", 1e6), ("1.5.3", 1.5),
])
def test_spice_numbers(token, value):
    assert parse_number(token) == pytest.approx(value, rel=1e-15)


@pytest.mark.parametrize("token", ["abc", "", "-", "+", ".", "k1", "e3", "-x"])
def test_not_numbers(token):
    assert parse_number(token) is None


def test_numbers_are_ngspices_doubles():
    # ngspice computes mantissa * 10**exponent: 2.2n is 22 * 1e-10
    assert parse_number("2.2n") == 22 * 10.0**-10
    assert parse_number("12345678901234567890") == pytest.approx(1.2345678901234567e19, rel=1e-15)


@pytest.mark.parametrize("text, value, end", [
    ("1mil", 1e-3, 4), ("10kOhm+1", 1e4, 6), ("1meg", 1e6, 4), ("2.5e-3*x", 2.5e-3, 6), ("3", 3.0, 1),
    ("1e3k", 1e6, 4), (".5u", 0.5e-6, 3),
])
def test_param_numbers(text, value, end):
    assert scan_param_number(text, 0) == (pytest.approx(value), end)


# -- lines -----------------------------------------------------------------------------
def test_cards_comments_continuations_and_end():
    text = ("Title line * not a comment\n"
            "* a comment\n"
            "R1 a b 1k ; inline\n"
            "\n"
            "C1 a 0 $ comment after a blank\n"
            "* comment between\n"
            "+ 1u\n"
            "  L1 a 0 1m // c++ style\n"
            "V1 a 0 dc 1$ is not a comment here\n"
            ".END\n"
            "R9 never read\n")
    title, cards, notes = split_cards(text, "f.cir")
    assert title == "Title line * not a comment"
    assert [c.text for c in cards] == ["r1 a b 1k", "c1 a 0 1u", "l1 a 0 1m", "v1 a 0 dc 1$ is not a comment here"]
    assert str(cards[1].location(cards[1].text.index("1u"))) == "f.cir:7:3"
    assert str(cards[2].location(0)) == "f.cir:8:3"
    # ngspice 39 reads on past .end: a warning at .end says that netdae does not
    assert [(d.severity, str(d.location)) for d in notes] == [("warning", "f.cir:10:1")]
    assert notes[0].message.startswith("1 line(s) after .end are not read by netdae (the first: 'R9 never read')")


def test_case_folding_keeps_raw_text():
    _, cards, _ = split_cards("t\n.include 'Sub/File.CIR'\nR1 A B 1K\n", "f.cir")
    assert cards[1].text == "r1 a b 1k"
    assert cards[0].raw == ".include 'Sub/File.CIR'"


def test_control_blocks_become_cards_or_located_notes():
    text = "t\nR1 a 0 1\n.control\nrun\n+ not a card\nplot v(a)\n.endc\nR2 a 0 2\n"
    _, cards, notes = split_cards(text, "f.cir")
    assert [c.text for c in cards] == ["r1 a 0 1", ".plot v(a)", "r2 a 0 2"]
    assert str(cards[1].location(1)) == "f.cir:6:1"
    assert len(notes) == 1 and "'+ not a card' skipped" in notes[0].message and notes[0].location.line == 5


def test_included_files_have_no_title_and_ignore_end():
    title, cards, notes = split_cards("R1 a 0 1\n.end\nR2 a 0 2\n", "inc.cir", title=False)
    assert title is None and [c.text for c in cards] == ["r1 a 0 1", "r2 a 0 2"]
    assert "ignored" in notes[0].message


@pytest.mark.parametrize("first, warned", [
    ("V1 in 0 1", "reads as an element card (v1)"),
    (".op", "reads as a .op card"),
    ("RC filter test", None),  # an R card without a value: a title
    ("Diode test circuit", None),
    # cards that parse but connect to nothing the circuit names: titles
    ("Ring oscillator 5 stages", None),
    ("V1 step response", None),
    ("Q1 amplifier", None),
    ("R9 a 0 2k", "reads as an element card (r9)"),
])
def test_a_title_line_that_reads_as_a_card_is_warned_about(first, warned):
    from netdae.netlist import load

    c = load(f"{first}\nV1 in 0 1\nR1 in a 1k\nR2 a 0 1k\n.op\n.end\n", path="t.cir")
    titles = [d for d in c.diagnostics if d.severity == "warning" and "the first line is the title" in d.message]
    if warned is None:
        assert not titles
    else:
        (w,) = titles
        assert warned in w.message and "add a title line above it" in w.message
        assert (w.location.file, w.location.line, w.location.column) == ("t.cir", 1, 1)


def test_tokens_keep_expressions_and_strings():
    _, cards, _ = split_cards("t\nR1 a b {x * 2} tc=1, 2\n.include \"My File.cir\"\n", "f.cir")
    toks = cards[0].tokens()
    assert [(t.text, t.kind) for t in toks] == [
        ("r1", "word"), ("a", "word"), ("b", "word"), ("x * 2", "expr"), ("tc", "word"), ("=", "punct"),
        ("1", "word"), (",", "punct"), ("2", "word")]
    assert cards[1].tokens()[1].text == "My File.cir"


@pytest.mark.parametrize("text, message, column", [
    ("t\n+ R1 a b 1\n", "continuation line", 1),
    ("t\n.control\nrun\n", ".control block without .endc", 1),
    ("t\n.endc\n", ".endc without", 1),
])
def test_line_errors(text, message, column):
    with pytest.raises(NetlistError, match=message) as exc:
        split_cards(text, "f.cir")
    assert exc.value.location.line == 2 and exc.value.location.column == column


# -- expressions -----------------------------------------------------------------------------
def ev(text, **params):
    return evaluate(parse_expression(text), params.__getitem__)


@pytest.mark.parametrize("text, value", [
    ("1+2*3", 7.0), ("(1+2)*3", 9.0), ("-2**2", -4.0), ("2**3**2", 64.0), ("2^3^2", 64.0), ("(-2)**3", 8.0),
    ("2**-1", 0.5), ("2*-3", -6.0), ("--2", 2.0), ("!0", 1.0), ("!3", 0.0), ("1?2:3", 2.0), ("0?2:3", 3.0),
    ("0?1:0?2:3", 3.0), ("0?2:3||1", 1.0), ("1<2", 1.0), ("2<=2", 1.0), ("3>=4", 0.0), ("1==1", 1.0),
    ("1!=1", 0.0), ("1<>2", 1.0), ("1&&0", 0.0), ("0||2", 1.0), ("5%3", 2.0), ("-5%3", -2.0),
    ("pow(-2,3)", -8.0), ("pwr(-2,3)", 8.0), ("sqr(-3)", 9.0), ("nint(2.5)", 2.0), ("nint(3.5)", 4.0),
    ("int(-2.7)", -2.0), ("floor(-2.5)", -3.0), ("ceil(-2.5)", -2.0), ("log(100)", math.log(100)),
    ("ln(1)", 0.0), ("log10(1000)", 3.0), ("u(0)", 0.5), ("u(-1)", 0.0), ("uramp(-2)+uramp(3)", 3.0),
    ("sgn(-4)", -1.0), ("limit(5,0,2)", 2.0), ("limit(-5,2,0)", 0.0), ("if(1>0,4,5)", 4.0),
    ("ternary_fcn(0,4,5)", 5.0), ("min(3,4)+max(3,4)", 7.0), ("atan(1)*4", math.pi), ("arctan(1)", math.pi / 4),
    ("pi", math.pi), ("1k*2", 2000.0), ("{1+1}*2", 4.0),
])
def test_expression_values(text, value):
    assert ev(text) == pytest.approx(value, rel=1e-15)


def test_contexts_differ_where_ngspice_differs():
    beh = parse_expression("pow(-2,3) + pwr(-2,3)*10 + 1mil*1e6", context=BEHAVIOURAL)
    assert evaluate(beh, None) == pytest.approx(8 - 80 + 25.4)
    assert ev("pow(-2,3) + pwr(-2,3)*10 + 1mil*1e3") == pytest.approx(-8 + 80 + 1)


def test_tree_of_a_behavioural_expression():
    e = parse_expression("V(a, b)*2 + I(Vx) - time ? sin(time) : -v(c)", context=BEHAVIOURAL)
    assert e == Ternary(
        Binary("-", Binary("+", Binary("*", Voltage("a", "b"), Const(2.0)), Current("vx")), Time()),
        Call("sin", (Time(),)), Unary("-", Voltage("c")))


def test_parameters_and_user_calls_stay_symbolic():
    e = parse_expression("f(a, 2) + b")
    assert e == Binary("+", Call("f", (Param("a"), Const(2.0))), Param("b"))
    assert ev("a*b + c", a=2.0, b=3.0, c=1.0) == 7.0


def test_round_trip_through_text():
    for text in ["-x**2", "a ? b : c ? d : e", "!(a && b) || c", "2**3**2", "(a - b) - (c - d)",
                 "pow(a, b) * sgn(a)", "limit(x, 1, 2) % 3"]:
        e = parse_expression(text)
        assert parse_expression(to_text(e)) == e


def test_constant_folding():
    e = fold_constants(parse_expression("v(a) * (2 + 3) + 1 ? 4 : 5", context=BEHAVIOURAL))
    assert e == Ternary(Binary("+", Binary("*", Voltage("a"), Const(5.0)), Const(1.0)), Const(4.0), Const(5.0))
    assert fold_constants(parse_expression("1 ? v(a) : 2", context=BEHAVIOURAL)) == Voltage("a")


@pytest.mark.parametrize("text, message, column", [
    ("1 + * 2", "unexpected '\\*'", 5),
    ("(1 + 2", "expected '\\)'", 7),
    ("1 2", "unexpected '2'", 3),
    ("sin(1, 2)", "takes 1 argument", 1),
    ("v(a)", "only allowed in behavioural", 1),
    ("time", "only available in behavioural", 1),
    ("gauss(1, 0.1)", r"gauss\(\) takes 3 arguments, got 2", 1),
    ("limit(1)", r"limit\(\) takes 2 arguments, got 1", 1),
    ("ddt(x)", "not supported", 1),
    ("hertz", "not supported", 1),
    ("1 # 2", "unexpected character '#'", 3),
    ("", "empty expression", 1),
])
def test_expression_errors_point_at_the_problem(text, message, column):
    from netdae.errors import SourceLocation
    with pytest.raises(NetlistError, match=message) as exc:
        parse_expression(text, locate=lambda o: SourceLocation("e", 1, o + 1))
    assert exc.value.location.column == column


@pytest.mark.parametrize("text, message", [
    ("1/0", "division by zero"), ("sqrt(-1)", "sqrt\\(-1\\) is undefined"), ("ln(0)", "undefined"),
    ("exp(1000)", "overflow"), ("pow(-2, 0.5)", "undefined"), ("0**-1", "division by zero"),
])
def test_evaluation_errors(text, message):
    with pytest.raises(ValueError, match=message):
        ev(text)


def test_a_dangling_exponent_is_warned_about_as_other_ignored_text():
    from netdae.netlist import load

    c = load("t\nV1 a 0 1\nR1 a 0 1e\nR2 a 0 1E+\nR3 a 0 1e3\n.op\n.end\n")
    assert [(d.location.line, d.message) for d in c.diagnostics if d.severity == "warning"] == [
        (3, "r1: value '1e' read as 1: 'e' ignored, as ngspice ignores what follows a number and its scale suffix"),
        (4, "r2: value '1e+' read as 1: 'e+' ignored, as ngspice ignores what follows a number and its scale "
            "suffix")]
