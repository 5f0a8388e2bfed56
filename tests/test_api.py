"""The public Python API: static names, cheap import, explicit keywords, option ranges, signal names."""

from __future__ import annotations

import ast
import inspect
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import netdae
from netdae.analyses.runner import check_options, option_problem, unused_options
from netdae.circuit import Options
from netdae.signals import Signal, canonical, parse_signal, split_signals

from conftest import NETLISTS, ROOT

INIT = ROOT / "netdae" / "__init__.py"


def _python(code: str) -> str:
    done = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=120,
                          check=True)
    return done.stdout.strip()


def test_every_public_name_resolves_and_is_statically_imported():
    tree = ast.parse(INIT.read_text())
    static: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            static.update(alias.asname or alias.name for alias in node.names)
    for name in netdae.__all__:
        assert getattr(netdae, name) is not None, name
        assert name == "__version__" or name in static, f"{name} is not visible to type checkers"
    assert netdae.Result.__module__ == "netdae.results" and netdae.load.__module__ == "netdae.netlist"
    assert issubclass(netdae.NetlistError, netdae.NetdaeError)


def test_import_netdae_loads_no_numerics():
    out = _python("import sys, netdae; print(sorted(m for m in ('numpy', 'scipy', 'numba') if m in sys.modules))")
    assert out == "[]"


def test_py_typed_marker():
    assert (ROOT / "netdae" / "py.typed").is_file()


@pytest.mark.parametrize("func", [netdae.simulate, netdae.run])
def test_simulate_and_run_take_explicit_keywords(func):
    params = inspect.signature(func).parameters
    assert not any(p.kind is inspect.Parameter.VAR_KEYWORD for p in params.values())
    assert {"save", "reltol", "abstol", "vntol", "progress"} <= set(params)
    assert "Parameters" in func.__doc__ and "reltol" in func.__doc__
    with pytest.raises(TypeError):
        func(NETLISTS / "rc_lowpass.cir", rtol=1e-4)  # a misspelt option is no longer swallowed


@pytest.mark.parametrize("option, value", [("reltol", 2.0), ("reltol", 1.0), ("reltol", 0.0), ("abstol", -1.0),
                                           ("vntol", 0.0), ("maxord", 7), ("maxord", 2.5), ("max_step", -1e-6)])
def test_bad_keyword_values_are_value_errors(option, value):
    with pytest.raises(ValueError, match=option):
        netdae.simulate(NETLISTS / "rc_lowpass.cir", **{option: value})


@pytest.mark.parametrize("card, pattern", [
    ("reltol=2", r"\.options reltol.*out of range"), ("reltol=1", r"\.options reltol.*out of range"),
    # temperatures are refused by the reader, located at the value
    ("temp=-300", r":5:15: \.options: option temp = -300 degC is not above absolute zero"),
    ("tnom=-274", r":5:15: \.options: option tnom = -274 degC is not above absolute zero"),
    ("maxord=7", r"\.options maxord.*out of range")])
def test_bad_netlist_options_are_netlist_errors(card, pattern):
    text = f"rc\nV1 in 0 1\nR1 in out 1k\nC1 out 0 1u\n.options {card}\n.op\n.tran 1u 10u\n.end\n"
    with pytest.raises(netdae.NetlistError, match=pattern):
        netdae.run(text)


def test_option_ranges():
    assert option_problem("reltol", 1e-6) is None and option_problem("temp", -273.0) is None
    assert option_problem("reltol", float("nan")) and option_problem("abstol", float("inf"))
    assert option_problem("temp", -273.15) and option_problem("itl1", 0)
    check_options(netdae.load(NETLISTS / "rc_lowpass.cir"), reltol=1e-6)  # valid: no exception


def test_unused_options_leaves_out_the_mosfet_defaults():
    c = netdae.Circuit("t", options=Options(extra={"defl": 2e-6, "defw": 1e-5, "trtol": 7.0}, itl4=20))
    assert unused_options(c) == "options not used by netdae: itl4, trtol"


def test_a_division_by_zero_in_a_b_source_is_warned_about_after_the_operating_point():
    # ngspice's fudge (a zero denominator is 1e-32) gives v(b) = 3e32 V, "converged": kept, and warned about
    (op,) = netdae.run("b\nV1 in 0 3\nR1 in a 1k\nB1 b 0 V=v(a)/0\nR2 b 0 1k\n.op\n.end\n")
    assert float(op["v(b)"][0]) == pytest.approx(3e32)
    (note,) = [n for n in op.notes if "beyond any physical circuit" in n]
    assert note.startswith("warning: v(b) reaches 3e+32, i(b1) reaches 3e+29, beyond any physical circuit")
    assert "divides in b1 (<string>:4:1)" in note
    (fine,) = netdae.run("b\nV1 in 0 3\nR1 in a 1k\nB1 b 0 V=v(a)/2\nR2 b 0 1k\n.op\n.end\n")
    assert not [n for n in fine.notes if "beyond" in n]
    # the transient of netdae.simulate says the same
    tran = netdae.simulate("b\nV1 in 0 3\nR1 in a 1k\nB1 b 0 V=v(a)/0\nR2 b 0 1k\n.tran 1u 10u\n.end\n")
    assert [n for n in tran.notes if "beyond any physical circuit" in n]


def test_simulate_accepts_a_path():
    r = netdae.simulate(Path(NETLISTS / "rc_lowpass.cir"), save=["v(out)"])
    assert r.names() == ["v(out)"] and r.ok


def test_analyze_index_accepts_a_path_and_the_netlist_text():
    # the user guide: `circuit` may be a Circuit or anything load takes; analyze_index failed on a path with
    # "'str' object has no attribute 'analyses'"
    path = NETLISTS / "cv_loop_sin.cir"
    by_circuit = netdae.analyze_index(netdae.load(str(path)))
    for given in (path, str(path), path.read_text()):
        rep = netdae.analyze_index(given)
        assert rep.index == by_circuit.index == 2 and rep.unknowns == by_circuit.unknowns
        assert rep.unknowns["i(v1)"] == "index2"


# -- signal names -----------------------------------------------------------------------
@pytest.mark.parametrize("text, kind, args, name", [
    ("v(out)", "v", ("out",), "v(out)"),
    (" V( In , Minus ) ", "v", ("in", "minus"), "v(in,minus)"),
    ("v(a,0)", "v", ("a",), "v(a)"),
    ("v(a,GND)", "v", ("a",), "v(a)"),
    ("v(0,a)", "v", ("0", "a"), "v(0,a)"),
    ("v(x1.mid)", "v", ("x1.mid",), "v(x1.mid)"),
    ("I(V1)", "i", ("v1",), "i(v1)"),
    ("i(l.xa.x1.l1)", "i", ("l.xa.x1.l1",), "i(l.xa.x1.l1)"),
    ("out", "v", ("out",), "v(out)"),
    ("gnd", "v", ("0",), "v(0)"),
    ("@R1[i]", "@", ("r1", "i"), "@r1[i]"),
])
def test_parse_signal(text, kind, args, name):
    sig = parse_signal(text)
    assert sig == Signal(kind, args) and sig.name == name == canonical(text)


@pytest.mark.parametrize("text", ["", "v()", "v(a,b,c)", "i(a,b)", "vdb(out)", "v(a", "x(a)", "@r1", "a b"])
def test_parse_signal_rejects(text):
    with pytest.raises(ValueError, match="expected v\\(node\\)"):
        parse_signal(text)


def test_split_signals():
    assert split_signals("v(a,b), @r1[i] ,,i(v1)") == ["v(a,b)", "@r1[i]", "i(v1)"]
    assert split_signals(None) is None
    with pytest.raises(ValueError, match="unbalanced"):
        split_signals("v(a,b")


_DIVIDER = "divider\nV1 in 0 1\nR1 in out 1k\nR2 out 0 1k\nC1 out 0 1n\n.op\n.tran 1u 10u\n.end\n"


def test_api_arguments_of_the_wrong_kind_are_said_so():
    """Misused API arguments raise TypeError or ValueError naming the argument, not an error from inside."""
    circuit = netdae.load(_DIVIDER)
    with pytest.raises(TypeError, match="card must be a TranAnalysis"):
        netdae.simulate(circuit, card=".ac dec 10 1 1k")
    op = netdae.run(circuit)[0]
    with pytest.raises(TypeError, match="a signal is named by a string"):
        op[5]
    assert op["v(out)"][0] == pytest.approx(0.5)
    with pytest.raises(ValueError, match="backend must be one of 'auto', 'shared', 'subprocess', not 'x'"):
        netdae.compare(_DIVIDER, backend="x")
    with pytest.raises(ValueError, match=r"x must hold one value per unknown, shape \(3,\)"):
        netdae.analyze_index(circuit, x=[0.0, 1.0])
    with pytest.raises(netdae.NetdaeError, match="analyses= is empty"):
        netdae.sweep(circuit, params={"r": [1.0]}, analyses=[])


def test_compare_takes_one_signal_name_as_one_signal():
    from netdae.analyses.runner import string_entries

    assert string_entries("v(out)", "signals") == ("v(out)",)
    pytest.importorskip("PySpice")
    c = netdae.compare(_DIVIDER, signals="v(out)", analyses="op")
    assert c.passed, c.report()
    names = [s.name for a in c.analyses for s in a.signals]
    assert names == ["v(out)"]


def test_dense_output_refuses_a_time_that_is_not_a_number():
    r = netdae.simulate(netdae.load(_DIVIDER))
    with pytest.raises(ValueError, match="dense output times must be finite numbers, not nan"):
        r.dense([1e-6, float("nan")])
    assert r.dense(5e-6)["v(out)"][0] == pytest.approx(0.5, rel=1e-9)


def test_maxord_6_which_ngspice_takes_runs_as_5_with_a_warning():
    """ngspice 39's gear takes ``.options maxord=6`` without a word; netdae refused the netlist ("out of
    range"). It runs with netdae's highest order, 5, and says so at the option."""
    text = "rc\nV1 in 0 PULSE(0 1 0 1u 1u 1m 2m)\nR1 in out 1k\nC1 out 0 1u\n.options method=gear maxord=6\n.tran 1u 2m\n.end\n"
    c = netdae.load(text)
    assert c.options.maxord == 5
    (w,) = [d for d in c.diagnostics if "maxord" in d.message]
    assert w.severity == "warning" and (w.location.line, w.location.column) == (5, 29)
    assert "runs with maxord=5" in w.message
    r = netdae.simulate(c)
    t = np.asarray(r.t)
    exact = np.where(t < 1e-3, 1 - np.exp(-t / 1e-3), np.nan)  # the RC's rise (the 1 us ramp aside)
    inside = (t > 0.1e-3) & (t < 1e-3)
    np.testing.assert_allclose(np.asarray(r["v(out)"])[inside], exact[inside], atol=2e-3)
