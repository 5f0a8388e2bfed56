"""netdae compare: the reason ngspice says nothing about the cards of one analysis of several."""

from __future__ import annotations

from netdae.comparison.model import MeasureComparison
from netdae.comparison.run import _one_analysis_measured
from netdae.measures import Measure

SILENT = "ngspice printed no value"


def _pair(name, analysis, ng_value=None, reason=None):
    ours = Measure(name, analysis, "when", 1.0)
    theirs = (Measure(name, analysis, "when", ng_value) if ng_value is not None else
              Measure(name, analysis, "when", None, status="failed", reason=reason))
    return MeasureComparison(name, analysis, ours, theirs)


def test_the_silent_analysis_is_explained():
    pairs = [_pair("tr", "tran", 1.0), _pair("nev", "tran", reason="out of interval"),
             _pair("f3", "ac", reason=SILENT), _pair("bw", "ac", reason=SILENT)]
    out = _one_analysis_measured(pairs)
    assert [p.ngspice.reason for p in out[:2]] == ["", "out of interval"]
    for p in out[2:]:
        assert p.ngspice.reason.startswith(SILENT + ": ngspice 39 -b measures the .meas cards of one analysis")
        assert "(here those of tran)" in p.ngspice.reason and ".meas ac cards" in p.ngspice.reason


def test_silence_without_another_analysis_speaking_is_left_as_it_is():
    pairs = [_pair("f3", "ac", reason=SILENT), _pair("g", "ac", 2.0)]  # ac spoke: no batch-mode reason
    assert [p.ngspice.reason for p in _one_analysis_measured(pairs)] == [SILENT, ""]
    alone = [_pair("f3", "ac", reason=SILENT)]
    assert _one_analysis_measured(alone)[0].ngspice.reason == SILENT
