"""Bad ``.meas`` cards: each a NetlistError at its file, line and column, with the expected form and a hint.

And the command line: ``netdae run`` prints measurements as ngspice does, writes
``measures.csv`` and the JSON; a bad card is one error line (exit status 2).
"""

from __future__ import annotations

import csv
import json
import math

import pytest

from netdae.cli import main as cli_main
from netdae.errors import NetlistError
from netdae.netlist import load

HEAD = "t\nV1 in 0 PULSE(0 1 0 1n 1n 1m 2m) AC 1\nR1 in out 1k\nC1 out 0 1u\n.tran 1u 2m\n"

# (card, message regex, the text the column must point at)
CASES = [
    (".meas tran x FIND v(out) AT 1m", r"missing '=' after AT", "1m"),
    (".meas tran x WHEN v(out) 0.5", r"missing '=' after the WHEN signal", "0.5"),
    (".meas tran x WHEN v(out)=0.5 BOGUS=1", r"unknown keyword BOGUS= in WHEN", "bogus"),
    (".meas tran x MAX v(out) FROM=1m UNTIL=2m", r"unknown keyword UNTIL=", "until"),
    (".meas op x FIND v(out) AT=1m", r"expected the analysis tran, ac or dc, found 'op'", "op"),
    (".meas noise x FIND v(out) AT=1m", r"expected the analysis tran, ac or dc", "noise"),
    (".meas ac x FIND vdb(out) AT=1k", r"no \.ac card: a \.meas ac has nothing to measure", "ac"),
    (".meas tran x FIND vdb(out) AT=1m", r"vdb\(\) is for ac measurements, this is a \.meas tran", "vdb"),
    (".meas tran x PARAM='y*2'", r"PARAM: 'y' is neither a measurement nor a top-level \.param", "'y*2'"),
    (".meas tran x FIND v(nowhere) AT=1m", r"unknown node 'nowhere'", "v(nowhere)"),
    (".meas tran x FIND i(r9) AT=1m", r"i\(r9\): 'r9' is no element", "i(r9)"),
    (".meas tran x TRIG v(out) VAL=0.1 RISE=1", r"TRIG without TARG", None),
    (".meas tran x TRIG v(out) VAL=0.1 TARG v(out) VAL=0.9 RISE=1", r"TRIG needs RISE=, FALL=, CROSS= or LAST",
     "trig"),
    (".meas tran x TRIG v(out) RISE=1 TARG v(out) VAL=0.9 RISE=1", r"TRIG needs VAL=", "trig"),
    (".meas tran x WHEN v(out)=0.5 RISE=0", r"RISE= takes a positive whole number or LAST", "0"),
    (".meas tran x WHEN v(out)=0.5 RISE=1 FALL=1", r"more than one of RISE=, FALL=, CROSS=, LAST", "fall"),
    (".meas tran x FOURIER v(out)", r"unknown measurement function 'fourier'", "fourier"),
    (".meas tran x ERR v(out)", r"ERR is not supported by netdae", "err"),
    (".meas tran x FIND v(out)", r"FIND needs AT=x or WHEN", None),
    (".meas tran x FIND out AT=1m", r"expected a signal after FIND, found 'out'", "out"),
    (".meas tran x MAX v(out) extra", r"unexpected 'extra'", "extra"),
    (".meas tran 1x MAX v(out)", r"expected the measurement's name", "1x"),
    (".meas tran x MAX v(out) FROM=2m TO=1m", r"TO=0.001 is before FROM=0.002", "x"),
    # ngspice 39: "no such vector as v(out,)"; netdae read v(out)
    (".meas tran x WHEN v(out,)=0.5", r"v\(\.\.\.\): a node is missing after ','", ")"),
    (".meas tran x MAX v(,out)", r"v\(\.\.\.\): a node is missing before ','", ","),
    (".meas tran x MAX i(v1,)", r"i\(\.\.\.\): an element name is missing after ','", ")"),
]


@pytest.mark.parametrize("card, message, token", CASES, ids=[c[1][:40] for c in CASES])
def test_bad_measure_cards_are_located(card, message, token):
    text = HEAD + card + "\n"
    with pytest.raises(NetlistError, match=message) as info:
        load(text)
    err = info.value
    loc = err.location
    lines = text.split("\n")
    line = lines[loc.line - 1]
    assert loc.line >= 6 and line.lower().startswith(".meas")
    if token is not None:
        assert line.lower()[loc.column - 1:].startswith(token.lower()), (line, loc.column)
    assert err.expected is not None and ".meas tran|ac|dc name" in err.expected


def test_check_prints_one_located_line_without_traceback(tmp_path, capsys):
    path = tmp_path / "bad.cir"
    path.write_text(HEAD + ".meas tran x FIND v(out) AT 1m\n")
    assert cli_main(["check", str(path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and f"{path}:6:29: .meas: missing '=' after AT" in err[0] and "hint: write AT=value" in err[0]


def test_run_prints_writes_csv_and_json(tmp_path, capsys):
    path = tmp_path / "rc.cir"
    path.write_text(HEAD + ".meas tran thalf WHEN v(out)=0.5\n.meas tran top MAX v(out)\n"
                    ".meas tran never WHEN v(out)=3\n")
    out_dir = tmp_path / "out"
    assert cli_main(["run", str(path), "--out", str(out_dir)]) == 0
    printed = capsys.readouterr().out
    assert "  Measurements for .tran" in printed
    line = next(s for s in printed.splitlines() if s.startswith("thalf"))
    name, value = line.split("=")
    assert name.strip() == "thalf" and float(value) == pytest.approx(1e-3 * math.log(2), rel=1e-3)
    assert next(s for s in printed.splitlines() if s.startswith("top")).count("at=") == 1
    assert "never               =  failed (WHEN: v(out) never crosses 3" in printed
    rows = list(csv.DictReader((out_dir / "measures.csv").open()))
    assert [r["name"] for r in rows] == ["thalf", "top", "never"]
    assert float(rows[0]["value"]) == pytest.approx(1e-3 * math.log(2), rel=1e-3)
    assert rows[2]["status"] == "failed" and rows[2]["value"] == "" and "never crosses" in rows[2]["reason"]
    assert cli_main(["run", str(path), "--json", "-q"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert [m["name"] for m in doc["tran"]["measures"]] == ["thalf", "top", "never"]
    assert doc["measures"]["values"][2]["value"] is None and doc["measures"]["file"] is None


def test_check_lists_the_measurements(tmp_path, capsys):
    path = tmp_path / "m.cir"
    path.write_text(HEAD + ".meas tran tr TRIG v(out) VAL=0.1 RISE=1 TARG v(out) VAL=0.9 RISE=1\n"
                    ".meas tran r PARAM='tr*2'\n")
    assert cli_main(["check", str(path)]) == 0
    assert "  measures: tr (tran trig v(out) v(out)); r (tran param)" in capsys.readouterr().out
    assert cli_main(["check", str(path), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["measures"][1] == {"name": "r", "analysis": "tran", "function": "param", "signals": []}
