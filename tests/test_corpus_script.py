"""scripts/corpus.py on a small corpus: every kind of file lands in its category."""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def _corpus_module():
    spec = importlib.util.spec_from_file_location("corpus_script", ROOT / "scripts" / "corpus.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


FILES = {
    "runs.cir": "divider\n.include parts.inc\nV1 a 0 1\nR1 a b 1k\nXr b 0 rdiv\n.op\n.end\n",
    "parts.inc": ".subckt rdiv p n\nR1 p n 1k\n.ends\n",
    "library.lib": "* models only\n.model dm d is=1e-14\n",
    "xspice.cir": "code model\nV1 a 0 1\na1 a b gain1\n.model gain1 gain(gain=2)\nR1 b 0 1k\n.op\n.end\n",
    "bsim.cir": "bsim\nV1 d 0 1\nM1 d d 0 0 nch\n.model nch nmos level=54\n.op\n.end\n",
    "missing.cir": "missing\n.include nowhere.inc\nV1 a 0 1\nR1 a 0 1\n.op\n.end\n",
    "mesfet.cir": "mesfet\nV1 d 0 1\nZ1 d 0 0 zm\n.model zm nmf level=7\n.op\n.end\n",
    "vdmos.cir": "vdmos\nV1 d 0 1\nM1 d d 0 tj tc vm thermal\n.model vm vdmos\n.op\n.end\n",
    "loops.cir": "loop\nV1 a 0 1\nR1 a 0 1k\n.control\nlet x = v(a)\nwhile x < 1\n  op\nend\n.endc\n.end\n",
}


def test_every_kind_of_file_lands_in_its_category(tmp_path):
    corpus = tmp_path / "corpus"
    corpus.mkdir()
    for name, text in FILES.items():
        (corpus / name).write_text(text)
    report = tmp_path / "r.json"
    module = _corpus_module()
    assert module.main([str(corpus), "--jobs", "1", "--timeout", "60", "--json", str(report)]) == 0
    data = json.loads(report.read_text())
    got = {name: (rec["category"], rec["bucket"]) for name, rec in data["files"].items()}
    assert got["runs.cir"] == ("runs", "")
    assert got["parts.inc"][0] == "not_netlist" and got["library.lib"][0] == "not_netlist"
    assert got["xspice.cir"] == ("out_of_scope", "XSPICE code models (A elements)")
    assert got["bsim.cir"] == ("out_of_scope", "compact MOSFET models (BSIM)")
    assert got["missing.cir"] == ("incomplete", "missing file nowhere.inc")
    assert got["mesfet.cir"][0] == "refused_named" and "MESFET level" in got["mesfet.cir"][1]
    assert got["vdmos.cir"][0] == "refused_named" and "VDMOS" in got["vdmos.cir"][1]
    assert got["loops.cir"][0] == "refused_named" and "cannot evaluate its condition" in got["loops.cir"][1]
    assert data["summary"]["in_scope"] == 4 and data["summary"]["runs"] == 1


def test_feature_buckets_name_the_feature():
    module = _corpus_module()
    assert module.feature("a.cir:3:1: .control: 'noise' (noise analysis) is not supported by netdae") == \
        "noise analysis (.control)"
    assert module.classify({"outcome": "refused", "message": "x.cir:1:1: m1: model p: MOSFET level 14 (BSIM4 in "
                                                            "ngspice) is not implemented by netdae"}) == \
        ("out_of_scope", "compact MOSFET models (BSIM, found by the reader)")
    assert module.classify({"outcome": "refused", "message": "x.cir:2:1: r1: unexpected 'foo'"})[0] == \
        "refused_unclear"


def test_a_comparison_out_of_time_keeps_the_run():
    # the worker prints the run's record before comparing; a comparison killed by the limit leaves it
    module = _corpus_module()
    printed = []
    rec = module.work(str(ROOT / "netlists" / "rc_lowpass.cir"), True, 60.0, emit=printed.append)
    assert rec["outcome"] == "runs" and rec["compare"] in ("agrees", "disagrees", "ngspice_failed")
    assert printed == [dict(printed[0], outcome="runs", compare="timeout")]
    out = "progress text\n" + json.dumps(printed[0]) + "\n"
    assert module._last_record(out, 1.5) == dict(printed[0], wall_s=1.5)
    assert module._last_record("Traceback ...\n", 1.5) is None
