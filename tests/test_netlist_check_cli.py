"""``netdae check``: the text summary, the JSON object, exit statuses; a large netlist end to end."""

from __future__ import annotations

import json
from pathlib import Path

from netdae.cli import main as cli_main
from netdae.cli.check import format_summary, summarize
from netdae.netlist import load

NETLISTS = Path(__file__).resolve().parent.parent / "netlists"


def test_check_prints_the_summary(capsys):
    assert cli_main(["check", str(NETLISTS / "subckt_ladder.cir")]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0].endswith("subckt_ladder.cir: RC ladder of four sections built from one subcircuit")
    assert out[1] == "  nodes (5): in n1 n2 n3 out"
    assert out[2] == "  elements (9): C 4, R 4, V 1"
    assert out[3] == "  analyses: .tran tstep=5e-06 tstop=0.004"
    assert "reltol=0.001" in out[4] and out[5] == "  params: cval=1e-07"
    assert out[-1] == "  diagnostics: none"


def test_check_json_has_the_documented_keys(capsys):
    assert cli_main(["check", "--json", str(NETLISTS / "rc_lowpass.cir")]) == 0
    data = json.loads(capsys.readouterr().out)
    assert {"title", "nodes", "elements", "analyses", "diagnostics", "options"} <= set(data)
    assert data["nodes"] == ["in", "out"] and data["elements"] == {"c": 1, "r": 1, "v": 1}
    assert [a["type"] for a in data["analyses"]] == ["tran", "ac"]
    ac_line = 1 + next(i for i, ln in enumerate((NETLISTS / "rc_lowpass.cir").read_text().splitlines())
                       if ln.lower().startswith(".ac"))
    assert data["analyses"][1] == {"type": "ac", "variation": "dec", "points": 10, "fstart": 1.0,
                                   "fstop": 100000.0, "line": ac_line}
    assert data["options"]["reltol"] == 1e-3 and data["options"]["extra"] == {}


def test_summary_lists_diagnostics_and_extra_sections():
    c = load("t\nR1 a 0 1\n.save v(zz)\n.control\nlet a=1\n.endc\n.dc temp 0 50 25\n.options rshunt=1e9\n.end\n")
    summary = summarize(c)
    assert [d["severity"] for d in summary["diagnostics"]] == ["note", "warning"]
    assert summary["analyses"] == [{"type": "dc", "sweeps": [{"source": "temp", "start": 0.0, "stop": 50.0,
                                                              "step": 25.0}], "line": 7}]
    summary["findings"] = ["loop of voltage sources: v1 v2"]
    text = format_summary(summary)
    assert "  findings:\n    loop of voltage sources: v1 v2" in text
    assert "rshunt=1e+09" in text and ".dc temp 0 to 50 step 25" in text
    assert text.endswith("<string>:3:7: warning: .save v(zz): no node 'zz' (not kept)")


def test_check_on_every_example_netlist(capsys):
    for path in sorted(NETLISTS.glob("*.cir")):
        assert cli_main(["check", "--json", str(path)]) == 0, path
        data = json.loads(capsys.readouterr().out)
        assert sum(data["elements"].values()) > 0


def test_large_hierarchical_ladder(tmp_path):
    n = 20_000
    lines = ["ladder", ".subckt sec a b params: r=1k", "R1 a b {r}", "C1 b 0 1p", ".ends",
             "V1 n0 0 PULSE(0 1 0 1n 1n 1u 2u)"]
    lines += [f"X{i} n{i} n{i + 1} sec r={i + 1}" for i in range(n)]
    path = tmp_path / "ladder.cir"
    path.write_text("\n".join(lines + [".tran 1n 1u", ".end", ""]))
    c = load(path)
    assert len(c.elements) == 2 * n + 1 and len(c.nodes) == n + 1
    assert c.element(f"r.x{n - 1}.r1").value == n and c.element(f"r.x{n - 1}.r1").nodes == (f"n{n - 1}", f"n{n}")
    assert c.element("c.x7.c1").nodes == ("n8", "0")


def test_check_shows_the_step_axes(tmp_path, capsys):
    """A stepped netlist's axes and their values (they were not shown: nothing told what netdae sweep would run)."""
    path = tmp_path / "s.cir"
    path.write_text("rc\nV1 a 0 1\nR1 a b {r}\nC1 b 0 1u\n.param r=1k\n.step param r list 1k 2k 3k\n"
                    ".step temp 0 50 25\n.tran 1u 1m\n.end\n")
    assert cli_main(["check", str(path)]) == 0
    assert "  .step (9 rows, netdae sweep): r (param): 1000 2000 3000; temp (temp): 0 25 50" in capsys.readouterr().out
    assert cli_main(["check", str(path), "--json"]) == 0
    steps = json.loads(capsys.readouterr().out)["steps"]
    assert steps == [{"target": "param", "name": "r", "values": [1000.0, 2000.0, 3000.0]},
                     {"target": "temp", "name": "temp", "values": [0.0, 25.0, 50.0]}]


def test_check_refuses_a_model_value_that_run_refuses(tmp_path, capsys):
    """A MOSFET of zero length passed ``check`` with "diagnostics: none" while ``run`` refused it: ``check``
    now builds the device models as a run does, and refuses it at the element, with the hint."""
    path = tmp_path / "l0.cir"
    path.write_text("t\nV1 a 0 1\nVd d 0 1\nR1 a b 1k\nM1 b d 0 0 mm l=0 w=1u\n.model mm nmos\n.op\n.end\n")
    assert cli_main(["check", str(path)]) == 2
    err = capsys.readouterr().err
    assert f"{path}:5:1: m1: effective channel length L - 2 LD = 0 m is not positive" in err
    assert "hint: give l more than twice ld" in err


def test_max_elements_on_the_command_line(capsys):
    """The refusal of a netlist above the element limit named only netdae.load's max_elements, which the command
    line did not have: --max-elements N sets it for check, index, run and sweep."""
    rc = str(NETLISTS / "rc_lowpass.cir")  # 3 elements
    assert cli_main(["check", rc, "--max-elements", "2"]) == 2
    err = capsys.readouterr().err
    assert "3 elements, more than the limit of 2" in err and "--max-elements N on the command line" in err
    assert cli_main(["check", rc, "--max-elements", "3"]) == 0
    capsys.readouterr()
    try:
        cli_main(["run", rc, "--max-elements", "0"])
    except SystemExit as stop:
        assert stop.code == 2
    assert "--max-elements: expected a whole number of at least 1, got '0'" in capsys.readouterr().err


def test_a_circuit_error_of_an_element_carries_its_location(tmp_path, capsys):
    """A CircuitError raised for an element carried its file:line:col only in its text; it keeps the location as
    ``location`` (as a NetlistError does), its message without it, and ``netdae check --json`` reports the file,
    line and column of the error as data."""
    import pickle

    import pytest

    from netdae.errors import CircuitError, SourceLocation
    from netdae.mna import assemble

    path = tmp_path / "l0.cir"
    path.write_text("t\nV1 a 0 1\nVd d 0 1\nR1 a b 1k\nM1 b d 0 0 mm l=0 w=1u\n.model mm nmos\n.op\n.end\n")
    with pytest.raises(CircuitError) as info:
        assemble(load(str(path)))
    err = info.value
    assert err.location == SourceLocation(str(path), 5, 1)
    assert err.message.startswith("m1: effective channel length L - 2 LD = 0 m is not positive")
    assert str(err) == f"{path}:5:1: {err.message} (hint: {err.hint})"
    again = pickle.loads(pickle.dumps(err))
    assert (str(again), again.location, again.message) == (str(err), err.location, err.message)

    assert cli_main(["check", "--json", str(path)]) == 2
    out, text = capsys.readouterr()
    assert f"netdae: error: {path}:5:1: m1: effective channel length" in text
    error = json.loads(out)["error"]
    assert error == {"type": "CircuitError", "message": err.message, "file": str(path), "line": 5, "column": 1,
                     "hint": err.hint, "elements": ["m1"], "nodes": []}


def test_check_json_reports_a_netlist_error_as_data(tmp_path, capsys):
    path = tmp_path / "bad.cir"
    path.write_text("t\nR1 a 0\n.op\n.end\n")
    assert cli_main(["check", "--json", str(path)]) == 2
    out, text = capsys.readouterr()
    error = json.loads(out)["error"]
    assert error["type"] == "NetlistError" and (error["file"], error["line"]) == (str(path), 2)
    assert error["message"] in text and error["expected"]
