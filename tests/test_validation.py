"""Every netlist in ``netlists/`` agrees with ngspice within the tolerance its header states.

One test per analysis card of every netlist: ``netdae.compare`` runs the
netlist in both simulators (once per netlist, cached) and the analysis must
pass the header's ``* compare tolerance:`` (1e-3 of the signal's scale when
the header states none), with the header's ``* compare options:``. Transient
cards are skipped, with the reason, only while netdae's transient analysis
(``netdae.analyses.tran``) is not built; they assert as soon as it is.
"""

from __future__ import annotations

import functools
import importlib.util
from pathlib import Path

import pytest

from netdae.analyses.runner import analysis_name
from netdae.comparison import compare, read_header
from netdae.comparison.report import format_analysis
from netdae.netlist import load

NETLISTS = sorted((Path(__file__).resolve().parent.parent / "netlists").glob("*.cir"))
HAVE_TRAN = importlib.util.find_spec("netdae.analyses.tran") is not None

#: The validation set of passive, linear, controlled-source and index-2 circuits
#: (the device netlists and the examples have their own owners and headers).
VALIDATION_SET = (
    "bode_rc_rlc", "bridge_dc", "controlled_sources", "cv_loop_capacitors", "cv_loop_sin",
    "differentiator_finite_gain", "inverting_amplifier", "lc_ladder_butterworth5", "li_cutset",
    "opamp_integrator", "pwl_rc", "rc_differentiator", "rc_highpass_sin", "rc_lowpass_pulse",
    "rl_highpass_pulse", "rl_lowpass_sin", "rlc_parallel_overdamped", "rlc_series_critical",
    "rlc_series_underdamped", "sallen_key_lowpass", "subckt_rc_ladder", "transformer",
)


def _cases():
    cases = []
    for path in NETLISTS:
        try:
            cards = load(path).analyses
        except Exception as exc:  # noqa: BLE001 - reported by the test, not at collection
            cases.append(pytest.param(path, "load", 0, repr(exc), id=f"{path.stem}-load"))
            continue
        seen: dict[str, int] = {}
        for card in cards:
            kind = analysis_name(card)
            k = seen.get(kind, 0)
            seen[kind] = k + 1
            suffix = f"{kind}{k + 1}" if k else kind
            cases.append(pytest.param(path, kind, k, None, id=f"{path.stem}-{suffix}"))
    return cases


def _judged(path: Path, header) -> tuple[str, ...]:
    """The analysis kinds of a netlist that have a numeric tolerance (the others are not run)."""
    kinds = {analysis_name(card) for card in load(path).analyses}
    if not HAVE_TRAN:
        kinds.discard("tran")
    return tuple(sorted(k for k in kinds if not (header.states(k) and header.tolerance(k) is None)))


@functools.cache
def _comparison(path: Path):
    return compare(path, analyses=_judged(path, read_header(path)))


@pytest.mark.ngspice
@pytest.mark.parametrize("path, kind, occurrence, load_error", _cases())
def test_netlist_agrees_with_ngspice(path, kind, occurrence, load_error):
    assert load_error is None, f"{path.name} does not load: {load_error}"
    if kind == "tran" and not HAVE_TRAN:
        pytest.skip("netdae's transient analysis (netdae.analyses.tran) is not built yet")
    header = read_header(path)
    if header.states(kind) and header.tolerance(kind) is None:
        pytest.skip(f"{path.name} states no numeric {kind} tolerance: {header.tolerance_text}")
    comparison = _comparison(path)
    if comparison.ngspice_error is not None:
        pytest.fail(comparison.ngspice_error, pytrace=False)
    item = comparison.analysis(kind, occurrence)
    if not item.passed:  # an error (a simulator failed) or a signal out of tolerance
        pytest.fail(f"{path.name} (tight={comparison.tight}):\n{format_analysis(item)}", pytrace=False)


@pytest.mark.parametrize("name", VALIDATION_SET)
def test_validation_netlist_states_index_and_tolerance(name):
    path = NETLISTS[0].parent / f"{name}.cir"
    header = read_header(path)
    assert header.expected_index is not None, f"{path.name}: no '* expected index:' line"
    assert header.tolerances, f"{path.name}: no '* compare tolerance:' line"
    for kind in {analysis_name(card) for card in load(path).analyses}:
        tol = header.tolerance(kind) if header.states(kind) else None
        assert tol is not None, f"{path.name}: no numeric {kind} tolerance"
        if tol.rel > 1e-3:
            # a looser tolerance must say why, in the tolerance statement itself
            assert "(" in header.tolerance_text, f"{path.name}: tolerance {tol.rel:g} without a reason"
