"""One statistics vocabulary (netdae.stats.Statistics) and typed Result metadata (no untyped bag)."""

from __future__ import annotations

import dataclasses
import json
import re
from pathlib import Path

import numpy as np
import pytest

import netdae
from netdae.dae.bdf.statistics import new_statistics
from netdae.metadata import LEGACY_EXTRA, NoiseInfo, Provenance, TransientInfo
from netdae.results import Result
from netdae.stats import RENAMED, Statistics

PACKAGE = Path(netdae.__file__).parent

# every analysis on one small circuit: R = 1k, C = 1u
ALL = """all analyses
V1 in 0 DC 1 PULSE(0 1 0.1m 1u 1u 5m 10m) AC 1
R1 in out 1k
C1 out 0 1u
.op
.dc V1 0 1 0.5
.ac dec 2 1 1k
.tran 50u 1m
.pz in 0 out 0 vol pz
.tf v(out) V1
.noise v(out) V1 dec 2 1 1k
.end
"""


@pytest.fixture(scope="module")
def every_analysis(tmp_path_factory):
    path = tmp_path_factory.mktemp("vocab") / "all.cir"
    path.write_text(ALL)
    return {r.analysis: r for r in netdae.run(path)}


def test_every_analysis_has_the_one_statistics_type(every_analysis):
    assert set(every_analysis) == {"op", "dc", "ac", "tran", "pz", "tf", "noise"}
    for name, res in every_analysis.items():
        assert res.ok, (name, res.message)
        assert type(res.stats) is Statistics, name
        assert res.stats.newton_iterations is not None and res.stats["newton_iterations"] >= 1, name
        assert res.stats.wall_time > 0 and res.stats.n_unknowns == 3, name
        assert set(res.stats) <= {f.name for f in dataclasses.fields(Statistics)}
    tran = every_analysis["tran"]
    assert type(tran.stats.integrator) is Statistics and tran.stats.steps == tran.stats.integrator.steps > 0
    assert tran.stats.newton_iterations == tran.stats.integrator.newton_iterations
    assert every_analysis["dc"].stats.points == 3 and every_analysis["ac"].stats.points == 7
    assert every_analysis["op"].stats.strategy == "newton"
    assert every_analysis["pz"].stats.poles == 1 and every_analysis["pz"].stats.zeros == 0


def test_every_analysis_has_typed_metadata(every_analysis):
    r = every_analysis
    for name in ("ac", "pz", "tf", "noise"):
        op = r[name].operating_point
        assert isinstance(op, Result) and op.analysis == "op"
        assert float(op["v(out)"][0]) == pytest.approx(1.0)
    assert np.allclose(r["pz"].poles, [-1e3]) and r["pz"].zeros.size == 0
    assert isinstance(r["tran"].transient, TransientInfo) and r["tran"].transient.index == 1
    assert r["tran"].transient.jumps == [] and r["tran"].transient.events == []
    assert isinstance(r["noise"].noise, NoiseInfo) and r["noise"].noise.input_unit == "V"
    assert r["noise"].noise_totals is r["noise"].noise.totals and "onoise_total" in r["noise"].noise_totals
    assert r["op"].operating_point is None and r["op"].noise is None and r["op"].source is None


def test_a_renamed_statistic_names_its_new_spelling():
    s = Statistics(newton_iterations=4, op_newton_iterations=2)
    for old, new in RENAMED.items():
        with pytest.raises(KeyError, match=new):
            s[old]
        with pytest.raises(KeyError, match=new):
            s.get(old)
        with pytest.raises(KeyError, match=new):
            Statistics.from_counts({old: 1})
        assert old not in s
    with pytest.raises(KeyError, match="not a statistic"):
        Statistics.from_counts({"newton_its": 1})
    with pytest.raises(TypeError):
        Statistics(newton=1)
    with pytest.raises(dataclasses.FrozenInstanceError):
        s.steps = 3


def test_statistics_is_a_mapping_of_its_set_fields():
    s = Statistics(points=2, steps=1, wall_time=0.5, integrator=Statistics(steps=1, engine="compiled"))
    assert dict(s) == {"points": 2, "steps": 1, "wall_time": 0.5, "integrator": s.integrator}
    assert len(s) == 4 and "rejected" not in s and s.get("rejected", 7) == 7
    with pytest.raises(KeyError):
        s["rejected"]
    assert s["integrator"]["engine"] == "compiled" and "load_time" not in s["integrator"]
    assert json.loads(json.dumps(s.to_dict())) == {"points": 2, "steps": 1, "wall_time": 0.5,
                                                   "integrator": {"steps": 1, "engine": "compiled"}}
    assert s.summary() == "points=2, steps=1, wall=0.5s"


def test_the_integrators_counters_are_in_the_vocabulary():
    counts = new_statistics()
    assert set(counts) <= {f.name for f in dataclasses.fields(Statistics)}
    assert Statistics.from_counts(counts).h_min == np.inf


def test_a_mapping_given_as_stats_is_checked_and_converted():
    r = Result("op", stats={"newton_iterations": 3, "strategy": "newton"})
    assert type(r.stats) is Statistics and r.stats.newton_iterations == 3
    with pytest.raises(KeyError, match="newton_iterations"):
        Result("op", stats={"newton": 3})


def test_json_and_summary_come_from_the_statistics(every_analysis, capsys):
    tran = every_analysis["tran"]
    d = tran.to_dict()
    assert d["stats"] == json.loads(json.dumps(tran.stats.to_dict()))
    assert "newton" not in d["stats"] and d["stats"]["integrator"]["steps"] == tran.stats.steps
    assert tran.stats.summary().startswith(f"points={tran.points}, steps={tran.stats.steps}, ")
    assert "newton_iterations=" in tran.stats.summary()


def test_extra_is_a_deprecated_read_only_view(every_analysis):
    pz, tran, noise = every_analysis["pz"], every_analysis["tran"], every_analysis["noise"]
    with pytest.warns(DeprecationWarning, match="typed fields"):
        view = pz.extra
    assert view["poles"] is pz.poles and view["op"] is pz.operating_point
    with pytest.raises(TypeError):
        view["poles"] = None
    with pytest.warns(DeprecationWarning):
        assert tran.extra["jumps"] is tran.transient.jumps and tran.extra["initial_correction"] is None
    with pytest.warns(DeprecationWarning):
        assert noise.extra["totals"] is noise.noise.totals
    read = Result("tran", source=Provenance(path="x.raw", method="gear"))
    with pytest.warns(DeprecationWarning):
        assert dict(read.extra) == {"source": "x.raw", "method": "gear"}
    assert set(LEGACY_EXTRA) >= {"op", "poles", "zeros", "card", "jumps", "events", "initial_correction",
                                 "totals", "contributions", "input_unit", "variable_types", "method",
                                 "source", "ngspice_version", "unknown_header_lines"}
    with pytest.raises(TypeError):
        Result("op", extra={"op": None})


def _sources():
    for path in sorted(PACKAGE.rglob("*.py")):
        yield path.relative_to(PACKAGE).as_posix(), path.read_text()


# the integrator's own counters (netdae.dae.bdf, the compiled driver) are plain dicts in the vocabulary,
# checked where a transient turns them into Statistics (Statistics.from_counts)
INTEGRATOR_LAYER = ("dae/bdf/", "dae/compiled/driver.py")


def test_no_module_builds_a_stats_dict_by_hand():
    by_hand = re.compile(r"""stats\s*=\s*(\{|dict\()|["'](newton|op_newton)["']\s*:""")
    found = [f"{name}:{text[:m.start()].count(chr(10)) + 1}" for name, text in _sources()
             if not name.startswith(INTEGRATOR_LAYER) and name != "stats.py"  # stats.py: RENAMED
             for m in by_hand.finditer(text)]
    assert found == []


def test_no_module_uses_an_untyped_extra_bag_of_a_result():
    bag = re.compile(r"""\b(res|result|results\[-1\]|nd|ng|r|plot)\.extra\b""")  # Result(extra=...) is a TypeError
    found = [f"{name}:{text[:m.start()].count(chr(10)) + 1}" for name, text in _sources()
             for m in bag.finditer(text)]
    assert found == []
