"""The command line's edges: python -m netdae, --version, a fast --help, usage errors, -q/-v, logging."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time

import pytest

import netdae
from netdae.cli import COMMANDS, main

from conftest import NETLISTS, ROOT

RC = NETLISTS / "rc_lowpass.cir"
DIFF = NETLISTS / "differentiator.cir"


def cli(capsys, *argv):
    status = main([*map(str, argv)])
    out, err = capsys.readouterr()
    return status, out, err


def _run(*argv, **kw):
    return subprocess.run([sys.executable, *argv], cwd=ROOT, capture_output=True, text=True, timeout=120, **kw)


def test_python_m_netdae_version():
    done = _run("-m", "netdae", "--version")
    assert done.returncode == 0 and done.stdout.strip() == f"netdae {netdae.__version__}"


def test_help_loads_no_numerics():
    code = ("import sys; from netdae.cli import main, COMMANDS\n"
            "codes = [main(['--help'])] + [main([c, '--help']) for c in COMMANDS]\n"
            "print(codes, sorted(m for m in ('numpy', 'scipy', 'numba', 'matplotlib') if m in sys.modules))")
    done = _run("-c", code)
    assert done.stdout.strip().splitlines()[-1] == f"{[0] * (1 + len(COMMANDS))} []"


def test_check_and_index_of_a_linear_circuit_load_no_compiled_engine():
    """The structure of a circuit is read without numba (every family's module is imported)."""
    code = ("import sys; from netdae.cli import main\n"
            f"codes = [main(['check', {str(RC)!r}, '-q']), main(['index', {str(RC)!r}, '-q'])]\n"
            "print(codes, 'numba' in sys.modules)")
    done = _run("-c", code, env={**os.environ, "NETDAE_SERVER": "0"})
    assert done.stdout.strip().splitlines()[-1] == "[0, 0] False", done.stderr


def test_help_is_fast():
    start = time.perf_counter()
    done = _run("-m", "netdae", "--help")
    elapsed = time.perf_counter() - start
    assert done.returncode == 0 and "compare" in done.stdout
    assert elapsed < 1.0, f"netdae --help took {elapsed:.2f} s"  # ~0.05 s measured; numpy alone adds ~0.1 s


@pytest.mark.parametrize("argv, message", [
    (["run", RC, "--rtol", "-1"], "argument --rtol/--reltol: expected a relative tolerance between 0 and 1"),
    (["run", RC, "--rtol", "2"], "argument --rtol/--reltol: expected a relative tolerance between 0 and 1"),
    (["run", RC, "--reltol", "abc"], "argument --rtol/--reltol: expected a number, got 'abc'"),
    (["run", RC, "--abstol=-1e-12"], "argument --abstol: expected a current tolerance in amperes from 1e-20"),
    (["run", RC, "--vntol", "0"], "argument --vntol: expected a voltage tolerance in volts from 1e-20"),
    (["run", RC, "--vntol", "nan"], "argument --vntol: expected a voltage tolerance in volts from 1e-20"),
    (["run", RC, "--save", "v(out"], "argument --save: unbalanced parentheses"),
    (["run", RC, "--save", "vdb(out)"], "argument --save: bad signal name 'vdb(out)'"),
    (["run", RC, "--export", "m.txt"], "argument --export: expected a .npz or .mtx path"),
    (["run", RC, "--save", ",,"], "argument --save: expected signal names separated by commas"),  # kept all
    (["sweep", RC, "--out", "o", "--save", " "], "argument --save: expected signal names separated by commas"),
    (["compare", RC, "--tol", "abc"], "argument --tol: expected a number"),
    (["compare", RC, "--tol", "0"], "argument --tol: expected a positive number"),
    (["compare", RC, "--reltol", "1"], "argument --reltol: expected a relative tolerance"),
    (["compare", RC, "--timeout", "-5"], "argument --timeout: expected a positive number, got '-5'"),
    (["compare", RC, "--signals", "v(a"], "argument --signals: unbalanced parentheses"),
    (["index", RC, "--tol", "2"], "argument --tol: expected a relative tolerance between 0 and 1"),
    (["index", RC, "--tol=-1e-9"], "argument --tol: expected a positive number"),
    (["check", RC, "-q", "-v"], "argument -v/--verbose: not allowed with argument -q/--quiet"),
    (["run", RC, "--out", ""], "argument --out: expected a directory name, got an empty one"),
    (["sweep", RC, "--out", " "], "argument --out: expected a directory name, got an empty one"),
])
def test_bad_values_are_usage_errors(capsys, argv, message):
    status, out, err = cli(capsys, *argv)
    assert status == 2 and out == ""
    assert err.startswith("usage: netdae ") and message in err


@pytest.mark.parametrize("argv, message", [
    (["run", RC, "--save", "v(zz)"], "netdae: error: cannot save 'v(zz)': no node 'zz' in the circuit"),
    (["run", RC, "--save", "i(r9)"], "netdae: error: cannot save 'i(r9)': no element 'r9' in the circuit"),
    (["compare", RC, "--signals", ""], "netdae: error: compare: --signals is empty: nothing to compare"),
    (["compare", RC, "--signals", "v(out)", "--exclude", "v(out)"],
     "netdae: error: compare: --signals names only signals --exclude leaves out: nothing to compare"),
])
def test_selections_that_name_nothing_are_errors_before_any_run(capsys, argv, message):
    status, out, err = cli(capsys, *argv)
    assert status == 2 and out == "" and err.startswith(message)


@pytest.mark.parametrize("argv, message", [
    # each changed nothing and said nothing: no file was written, or a csv file instead of a raw one
    (["run", RC, "--format", "raw"], "netdae: error: --format raw chooses the format of the files --out writes, "
                                     "and no --out was given (hint: add --out DIR)"),
    (["run", RC, "--ascii"], "netdae: error: --ascii writes raw files as text, and the files are not raw "
                             "(hint: add --format raw and --out DIR)"),
    (["run", RC, "--ascii", "--out", "{tmp}"], "netdae: error: --ascii writes raw files as text, and the files are "
                                               "not raw (hint: add --format raw)"),
])
def test_output_options_that_would_change_nothing_are_refused(capsys, tmp_path, argv, message):
    status, out, err = cli(capsys, *[str(a).replace("{tmp}", str(tmp_path / "o")) for a in argv])
    assert status == 2 and out == "" and err.strip() == message
    assert not (tmp_path / "o").exists()


def test_ascii_raw_files_are_written_with_both_options(capsys, tmp_path):
    status, out, err = cli(capsys, "run", RC, "--format", "raw", "--ascii", "--out", tmp_path)
    raw = (tmp_path / "tran.raw").read_bytes()
    assert status == 0 and raw.startswith(b"Title:") and b"Values:" in raw  # ascii, not "Binary:"


def test_an_empty_netlist_file_is_an_error(capsys, tmp_path):
    path = tmp_path / "empty.cir"
    path.write_text("")
    status, out, err = cli(capsys, "check", path)
    assert status == 2 and err.startswith(f"netdae: error: {path}:1:1: the netlist file is empty (0 bytes)")


@pytest.mark.parametrize("command", ["check", "run"])
def test_a_dash_for_the_standard_input_is_said_to_be_unread(capsys, tmp_path, monkeypatch, command):
    """'-' names the standard input to most tools; netdae reads files, and says so instead of blaming the name."""
    monkeypatch.chdir(tmp_path)
    status, out, err = cli(capsys, command, "-")
    assert status == 2 and err.startswith("netdae: error: netlist file '-' not found: netdae reads netlists "
                                          "from files, not from the standard input")
    assert "hint: save the netlist in a file and give its name" in err


@pytest.mark.parametrize("option", ["reltol=2", "reltol=1", "temp=-300", "tnom=-274", "maxord=7"])
def test_bad_netlist_options_exit_2(capsys, tmp_path, option):
    path = tmp_path / "o.cir"
    path.write_text(f"rc\nV1 in 0 1\nR1 in out 1k\nC1 out 0 1u\n.options {option}\n.op\n.end\n")
    status, out, err = cli(capsys, "run", path)
    name = option.split("=")[0]
    assert status == 2 and out == ""
    if name in ("temp", "tnom"):  # refused by the reader, located at the value
        assert err.startswith(f"netdae: error: {path}:5:") and "is not above absolute zero" in err
    else:
        column = len(".options ") + len(name) + 2  # located at the value on its card
        assert err.startswith(f"netdae: error: {path}:5:{column}: .options {name}") and "is out of range" in err
    assert err.count("\n") == 1 and "internal error" not in err


def test_unwritable_output_is_an_error_not_a_bug(capsys, tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("")
    status, _, err = cli(capsys, "run", RC, "--out", blocker / "sub")
    assert status == 2 and err.startswith("netdae: error: ") and "internal" not in err


def test_verbosity(capsys, tmp_path):
    status, out, err = cli(capsys, "run", DIFF, "--out", tmp_path)
    assert status == 0
    assert "note:" not in out and "wrote" not in out and out.startswith("Op-amp differentiator")
    assert "note: initial values made consistent" in err and f"wrote {tmp_path / 'tran.csv'}" in err
    assert "debug" not in err
    status, quiet_out, quiet_err = cli(capsys, "run", DIFF, "--out", tmp_path, "-q")
    assert status == 0 and quiet_err == "" and quiet_out.splitlines()[:2] == out.splitlines()[:2]
    status, _, loud = cli(capsys, "run", "-v", DIFF)
    assert status == 0 and loud.startswith(f"netdae: debug: read {DIFF}") and "note:" in loud
    for command in COMMANDS:
        assert cli(capsys, command, "--help")[0] == 0


def test_errors_go_through_the_logger(capsys, tmp_path):
    bad = tmp_path / "bad.cir"
    bad.write_text("bad\nR1 a 0\n.op\n.end\n")
    for flag in ((), ("-q",)):
        status, out, err = cli(capsys, "check", bad, *flag)
        assert status == 2 and out == "" and err.startswith(f"netdae: error: {bad}:2:")


def test_run_json_has_one_schema(capsys, tmp_path):
    path = tmp_path / "all.cir"
    path.write_text("rc\nV1 in 0 DC 1 AC 1 PULSE(0 1 0 1u 1u 1m 2m)\nR1 in out 1k\nC1 out 0 1u\n"
                    ".op\n.dc V1 0 2 1\n.ac dec 2 10 1k\n.tran 10u 1m\n.tran 20u 1m\n.end\n")
    status, out, _ = cli(capsys, "run", path, "--json", "--out", tmp_path / "res")
    doc = json.loads(out)
    assert status == 0 and list(doc) == ["op", "dc", "ac", "tran", "tran2"]
    assert len({tuple(entry) for entry in doc.values()}) == 1
    assert doc["tran2"]["files"] == [str(tmp_path / "res" / "tran2.csv")]
    assert doc["op"]["values"]["signals"]["v(out)"] == [pytest.approx(1.0, rel=1e-9)]
    assert [doc[k]["analysis"] for k in doc] == ["op", "dc", "ac", "tran", "tran"]


def test_save_applies_to_every_analysis(capsys, tmp_path):
    status, out, _ = cli(capsys, "run", RC, "--json", "--save", "V(out), v(in,out)")
    doc = json.loads(out)
    assert status == 0 and doc["tran"]["signals"] == doc["ac"]["signals"] == ["v(out)", "v(in,out)"]


def test_compare_timeout_is_passed_on(monkeypatch, capsys):
    import netdae.comparison as comparison

    seen = {}

    class Done:
        passed = True

    def fake(netlist, *, tight=None, tol=None, backend="auto", signals=None, exclude=(), reltol=None,
             analyses=None, timeout=None, behavior=None):
        seen.update(timeout=timeout, signals=signals, exclude=exclude)
        return Done()

    monkeypatch.setattr(comparison, "compare", fake)
    monkeypatch.setattr(comparison, "format_comparison", lambda c: "ok\n")
    status, out, _ = cli(capsys, "compare", RC, "--timeout", "2.5", "--signals", "V(out)", "--exclude", "i(v1)")
    assert status == 0 and out == "ok\n"
    assert seen == {"timeout": 2.5, "signals": ["v(out)"], "exclude": ["i(v1)"]}
    status, _, _ = cli(capsys, "compare", RC)
    assert status == 0 and seen["timeout"] is None


def test_run_shows_the_netlists_warnings(capsys, tmp_path):
    # what reading noted (a parameter read as ngspice reads it, a signal left out) reaches the user of run
    cir = tmp_path / "w.cir"
    cir.write_text("warned\n.param a='max(-3)'\nV1 1 0 {a}\nR1 1 0 1\n.save v(1) @r9[i]\n.op\n.end\n")
    for flag in ((), ("-q",)):
        status, out, err = cli(capsys, "run", cir, *flag)
        assert status == 0 and "v(1)   1 V" in out
        assert f"netdae: warning: {cir}:2:11: .param: max() with one argument: read as max(x, 1)" in err
        assert f"netdae: warning: {cir}:5:12: .save @r9[i]: no device 'r9' (not kept)" in err
