"""``.meas`` of expressions, ngspice's ``par('...')``: closed forms, errors, and ngspice itself.

A divider fed by a sine, ``v(in) = sin(2 pi 1k t)``, ``v(out) = v(in) / 2``: the power in R1 is
``v(in)^2 / 4k``, ``v(in) * v(out) = sin^2 / 2`` and so on, known at every time. netdae
evaluates an expression on its interpolant at every point a measurement reads.
"""

from __future__ import annotations

import math
import random

import numpy as np
import pytest

from netdae.analyses.runner import run
from netdae.errors import NetlistError
from netdae.netlist import expr as ex
from netdae.netlist import load

DIVIDER = """sine into a divider
.param k=3
V1 in 0 SIN(0 1 1k)
R1 in out 1k
R2 out 0 1k
.options reltol=1e-6
.tran 1u 3m
.meas tran prod FIND par('v(in)*v(out)') AT=0.125m
.meas tran power AVG par('(v(in)-v(out))*(v(in)-v(out))/1k') FROM=1m TO=3m
.meas tran pcur AVG par('v(in,out)*i(v1)') FROM=1m TO=3m
.meas tran scaled MAX par('k*abs(v(out))') FROM=1m TO=1.5m
.meas tran t8 WHEN par('v(in)*v(in)')=0.5 RISE=1
.meas tran tout WHEN v(out)=par('v(in)*v(in)') CROSS=2
.meas tran tramp FIND par('time*1k + v(out)') AT=0.5m
.meas tran half PARAM='power*2'
.end
"""

DC = """dc
V1 in 0 0
R1 in out 1k
R2 out 0 1k
.dc V1 0 2 0.1
.meas dc p FIND par('v(out)*v(out)/1k') AT=1.5
.meas dc vwhen WHEN par('v(in)-v(out)')=0.4
.end
"""


def _measures(text: str) -> dict:
    return {m.name: m for r in run(text) for m in r.measures}


def test_expressions_of_signals_measured_on_the_interpolant():
    got = _measures(DIVIDER)
    for m in got.values():
        assert m.ok, (m.name, m.reason)
    assert got["prod"].value == pytest.approx(math.sin(math.pi / 4) ** 2 / 2, rel=1e-6)
    # sin^2/4k averaged over whole periods
    assert got["power"].value == pytest.approx(0.5 / 4e3, rel=1e-6)
    # the same power from the source current: i(v1) = -v(in)/2k flows into the + terminal
    assert got["pcur"].value == pytest.approx(-0.5 / 4e3, rel=1e-6)
    assert got["scaled"].value == pytest.approx(1.5, rel=1e-6)
    assert got["scaled"].at == pytest.approx(1.25e-3, rel=1e-4)
    assert got["t8"].value == pytest.approx(0.125e-3, rel=1e-6)  # sin^2 = 1/2 first at T/8
    # sin/2 = sin^2: sin = 1/2 at T/12 (rising through sin^2) and 5T/12 (falling through it)
    assert got["tout"].value == pytest.approx(5e-3 / 12, rel=1e-6)
    assert got["tramp"].value == pytest.approx(0.5, abs=1e-9)  # sin(pi)/2 = 0
    assert got["half"].value == pytest.approx(2 * got["power"].value, rel=1e-14)


def test_dc_expressions_on_the_sweep_points():
    got = _measures(DC)
    assert got["p"].value == pytest.approx(0.75 ** 2 / 1e3, rel=1e-12)
    assert got["vwhen"].value == pytest.approx(0.8, rel=1e-12)


def test_an_expression_undefined_on_the_way_fails_with_the_time():
    got = _measures(DIVIDER.replace(".meas tran prod FIND par('v(in)*v(out)') AT=0.125m",
                                    ".meas tran prod MAX par('sqrt(v(out))')"))
    assert not got["prod"].ok
    assert "par('sqrt(v(out))') is not finite at time=" in got["prod"].reason
    at = float(got["prod"].reason.rsplit("=", 1)[1])
    assert 0.5e-3 <= at <= 0.51e-3  # where the sine first goes negative


@pytest.mark.parametrize("card, message", [
    ("FIND par('v(nope)*2') AT=1m", "unknown node 'nope'"),
    ("FIND par('v(out)*kk') AT=1m", "'kk' is not a top-level .param"),
    ("FIND par('ddt(v(out))') AT=1m", "ddt() in a par() expression"),
    ("FIND par('foo(v(out))') AT=1m", "unknown function 'foo'"),
    ("FIND par('i(nope)') AT=1m", "'nope' is no element"),
    ("FIND par(v(out)) AT=1m", "par() takes one quoted expression"),
])
def test_bad_expressions_are_located_errors(card, message):
    text = DIVIDER.split(".meas")[0] + f".meas tran x {card}\n.end\n"
    with pytest.raises(NetlistError) as info:
        load(text)
    assert message in str(info.value)
    assert info.value.location.line == 8


def test_time_outside_a_transient_and_par_in_ac_are_refused():
    with pytest.raises(NetlistError, match="'time' in a .meas dc"):
        load(DC.replace("par('v(out)*v(out)/1k')", "par('time*v(out)')"))
    ac = "ac\nV1 in 0 AC 1\nR1 in out 1k\nC1 out 0 1u\n.ac dec 10 1 1k\n.meas ac x MAX par('v(out)*2')\n.end\n"
    with pytest.raises(NetlistError, match="par\\(\\) expressions are measured on tran and dc results"):
        load(ac)


def test_measured_expressions_keep_the_signals_they_read():
    text = DIVIDER.replace(".options reltol=1e-6", ".options reltol=1e-6\n.save v(out)")
    got = _measures(text)
    assert got["pcur"].ok and got["pcur"].value == pytest.approx(-0.5 / 4e3, rel=1e-6)


_OPS = ["+", "-", "*", "/", "**", "%", "&&", "||", "==", "!=", "<", "<=", ">", ">="]


def test_array_evaluation_is_the_scalar_evaluation_at_every_point():
    rng = random.Random(7)
    a = np.array([rng.choice([-2.5, -1.0, 0.0, 0.3, 1.0, 2.0, 7.5]) for _ in range(40)])
    b = np.array([rng.choice([-3.0, -0.5, 0.0, 0.5, 1.0, 2.0]) for _ in range(40)])
    texts = [f"v(a) {op} v(b)" for op in _OPS]
    texts += [f"{name}(v(a))" for name, (arity, _) in ex.FUNCTIONS.items() if arity == 1]
    texts += [f"{name}(v(a), v(b))" for name, (arity, _) in ex.FUNCTIONS.items() if arity == 2]
    texts += ["limit(v(a), v(b), 1)", "v(a) > 0 ? sqrt(v(a)) : -v(b)", "!(v(a)) + -v(b)", "pwl(v(a), -1, 0, 1, 2)"]
    for text in texts:
        tree = ex.parse_expression(text, context=ex.BEHAVIOURAL)
        got = ex.evaluate_arrays(tree, lambda leaf: a if leaf.pos == "a" else b)
        for k in range(a.size):
            values = {"a": float(a[k]), "b": float(b[k])}
            point = ex.transform(tree, lambda n: ex.Const(values[n.pos]) if isinstance(n, ex.Voltage) else None)
            try:
                want = ex.evaluate(point, None)
            except ValueError:
                assert not math.isfinite(got[k]), (text, values, got[k])
                continue
            assert got[k] == want, (text, values)


# -- against ngspice ------------------------------------------------------------------------
@pytest.mark.ngspice
def test_ngspice_measures_the_same_expressions():
    from netdae.ngspice import run_ngspice

    # ngspice 39 does not read par() on the right of WHEN ...= (its substitution garbles the card)
    text = "\n".join(line for line in DIVIDER.splitlines() if not line.startswith(".meas tran tout"))
    ours = _measures(text)
    ng = {m.name: m for m in run_ngspice(text).measures}
    # ngspice: lines between its points, 7 printed digits; AVG over its points inside the window
    # (its 'to' is the first point past TO: 1.4e-4 of the average here)
    for name in ("prod", "power", "pcur", "scaled", "t8"):
        assert ng[name].ok, (name, ng[name].reason)
        assert ng[name].value == pytest.approx(ours[name].value, rel=3e-4), name
