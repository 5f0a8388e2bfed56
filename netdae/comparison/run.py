"""Run one netlist through netdae and ngspice and compare every analysis.

:func:`compare` reads the netlist once; netdae elaborates it
(:func:`netdae.load`) and runs each analysis card
(:func:`netdae.analyses.runner.run`); ngspice runs the *same text* through
the bridge (:func:`netdae.ngspice.run_ngspice`), which translates netdae's
extensions (the ideal op-amp becomes a VCVS of large gain) and lists every
change it made. Analyses are paired by kind and order (ngspice runs them in
its own order: ac, dc, op, tran) and compared at ngspice's points
(:mod:`netdae.comparison.analyses`).

Tolerances
----------
By default both simulators use the netlist's ``.options``. With
``tight=True``:

- netdae: ``reltol=1e-6`` (:data:`TIGHT_NETDAE`);
- ngspice: ``reltol=1e-6``, ``chgtol=1e-20`` C, ``trtol=1``
  (:data:`TIGHT_NGSPICE`), a maximum step of 1e-4 of the simulated interval
  (:data:`TIGHT_STEPS_PER_INTERVAL`), and an op-amp gain of 1e9
  (:data:`TIGHT_OPAMP_GAIN`); its absolute tolerances and the integration
  method stay the netlist's.

Why (measured with ngspice 39, reproduced in ``docs/validation.md``):
ngspice's truncation-error control is loose. On the series RLC of
``netlists/rlc_series_underdamped.cir`` its error against the closed form is
1.8e-3 of the range at the default tolerances and still 1.0e-3 at
``reltol=1e-6``; ``trtol=1`` (no factor-7 allowance on the truncation-error
estimate) brings it to 3e-4, and only the step bound to 2e-5. ``chgtol`` is
lowered so that small capacitors' charges are controlled relatively too.
Tighter ``vntol`` or ``abstol`` make ngspice stop with "timestep too small"
on ``netlists/bridge_rectifier.cir`` (with either method), and netdae's BDF
fail on ``netlists/halfwave_rectifier.cir`` (Newton diverges in the first
step at ``vntol=1e-9``, ``abstol=1e-15``), so both simulators keep their
absolute tolerances.
``method=gear`` is not more accurate on the ringing circuit and damps it
numerically, so the method is left alone.
"""

from __future__ import annotations

import dataclasses
import os
import re
from dataclasses import replace

import numpy as np

from ..analyses.runner import refuse_steps
from ..circuit import Circuit, TranAnalysis
from ..errors import NetdaeError, NgspiceError
from ..ngspice import RUNS_LAST_TO_FIRST
from ..ngspice.deck import SCRIPT_MARK
from ..signals import parse_signal
from ..results import Result
from .analyses import compare_ac, compare_dc, compare_op, compare_transient
from .smallsignal import compare_noise, compare_pz, compare_sens, compare_tf
from .header import ANALYSES, Tolerance, parse_header
from .model import AnalysisComparison, Comparison, MeasureComparison

__all__ = [
    "compare",
    "DEFAULT_TOLERANCE",
    "TIGHT_NETDAE",
    "TIGHT_NGSPICE",
    "TIGHT_STEPS_PER_INTERVAL",
    "TIGHT_OPAMP_GAIN",
]

#: Pass criterion when neither the caller nor the netlist's header gives one:
#: 1e-3 of the signal's scale, ngspice's default relative tolerance.
DEFAULT_TOLERANCE = Tolerance(1e-3)
#: netdae's tolerances with ``tight=True``.
TIGHT_NETDAE = {"reltol": 1e-6}
#: ngspice's options with ``tight=True`` (module docstring).
TIGHT_NGSPICE = {"reltol": 1e-6, "chgtol": 1e-20, "trtol": 1}
#: With ``tight=True`` ngspice's step is at most the simulated interval over this.
TIGHT_STEPS_PER_INTERVAL = 1e4
#: The ideal op-amp's gain in ngspice with ``tight=True``: a model error of
#: 1e-9 times the noise gain (ngspice runs the differentiator to completion
#: for gains up to 1e15, see docs/ngspice.md).
TIGHT_OPAMP_GAIN = 1e9
_COMPARERS = {"op": compare_op, "dc": compare_dc, "ac": compare_ac, "pz": compare_pz, "tf": compare_tf,
              "noise": compare_noise, "sens": compare_sens}


def _read(netlist, behavior=None) -> tuple[Circuit, str, str, str]:
    """(circuit, text, source name, working directory) of what the caller gave."""
    from ..netlist import load

    if isinstance(netlist, Circuit):
        path = netlist.path
        if path == "<string>" or not os.path.isfile(path):
            raise NetdaeError(
                "compare needs the netlist's text to run ngspice on it, and this circuit has no file "
                f"({path}); pass the netlist's path or text instead"
            )
        return netlist, _read_file(path), path, os.path.dirname(os.path.abspath(path))
    if isinstance(netlist, str) and "\n" in netlist:
        return load(netlist, behavior=behavior), netlist, "<string>", os.getcwd()
    circuit = load(netlist, behavior=behavior)  # first: the reader says what is wrong with the name or the file
    path = os.fspath(netlist)
    return circuit, _read_file(path), path, os.path.dirname(os.path.abspath(path))


def _behavior(circuit: Circuit):
    """The compatibility mode the circuit was read in (``""``: none), for ngspice and re-reads."""
    net = circuit.netlist
    mode = getattr(net, "behavior", None) if net is not None else None
    return mode if mode is not None else ""


def _read_file(path: str) -> str:
    try:
        with open(path, encoding="utf-8", errors="replace") as handle:
            return handle.read()
    except OSError as exc:
        raise NetdaeError(f"{path}: cannot read netlist: {exc.strerror}") from None


def _tolerances(tol, header) -> tuple[dict[str, Tolerance | None], str]:
    """Tolerance per analysis and where it came from."""
    if tol is None:
        if header.tolerances:
            return {a: header.tolerances.get(a, DEFAULT_TOLERANCE) for a in ANALYSES}, "header"
        return dict.fromkeys(ANALYSES, DEFAULT_TOLERANCE), "default"
    if isinstance(tol, Tolerance):
        return dict.fromkeys(ANALYSES, tol), "argument"
    if isinstance(tol, dict):
        out = {}
        for analysis in ANALYSES:
            value = tol.get(analysis, DEFAULT_TOLERANCE)
            out[analysis] = Tolerance(float(value)) if isinstance(value, (int, float)) else value
        return out, "argument"
    value = float(tol)
    if not value > 0:
        raise NetdaeError(f"the compare tolerance must be positive, got {tol!r}")
    return dict.fromkeys(ANALYSES, Tolerance(value)), "argument"


def _tight_maxstep(circuit: Circuit) -> float | None:
    spans = [(c.tstop - c.tstart, c.tmax) for c in circuit.analyses if isinstance(c, TranAnalysis)]
    if not spans:
        return None
    bounds = [span / TIGHT_STEPS_PER_INTERVAL for span, _ in spans]
    bounds += [tmax for _, tmax in spans if tmax]
    return min(bounds)


def _osdi_note(circuit) -> str:
    """Why ngspice fails on a netlist with ``N`` (OSDI) cards, else ``""``.

    ngspice 39 reads ``.osdi`` as no card of its own and knows no ``N`` element
    without OSDI support (and with it, OSDI 0.3 only: the models compiled by
    ``openvaf-r`` are 0.5): its "unknown device type" would otherwise be the
    whole story. BSIM3/BSIM4 ``M`` cards, which netdae runs through OSDI, are
    ngspice's own and compare.
    """
    from ..kinds import Kind

    names = [el.name for el in circuit.elements if el.kind == Kind.OSDI and el.name.startswith("n")]
    if not names:
        return ""
    what = "is an OSDI device (an N card)" if len(names) == 1 else "are OSDI devices (N cards)"
    return (f"\n(hint: {', '.join(names[:3])}{' ...' if len(names) > 3 else ''} {what}: "
            "ngspice 39 runs none (it reads OSDI 0.3 only, openvaf-r writes 0.5), so a netlist with N cards "
            "cannot be compared; BSIM3/BSIM4 M cards can, ngspice runs its own models for them)")


def _settings(circuit: Circuit, tight: bool, reltol: float | None) -> tuple[dict, dict, float | None]:
    """netdae overrides, ngspice option overrides, op-amp gain (None: the bridge's)."""
    if tight:
        ngspice = dict(TIGHT_NGSPICE)
        maxstep = _tight_maxstep(circuit)
        if maxstep is not None:
            ngspice["maxstep"] = maxstep
        netdae = dict(TIGHT_NETDAE)
        if reltol is not None:
            netdae["reltol"] = ngspice["reltol"] = float(reltol)
        return netdae, ngspice, TIGHT_OPAMP_GAIN
    if reltol is not None:
        return {"reltol": float(reltol)}, {"reltol": float(reltol)}, None
    return {}, {}, None


def _run_netdae(circuit: Circuit, card, overrides: dict) -> tuple[Result, Result]:
    """One analysis card through :func:`netdae.analyses.runner.run`: ``(compared, measured)``.

    When the netlist selects signals (``.save``, ``.print``, a control block's ``plot``),
    ``compared`` holds the selection and ``measured`` also what the ``.meas`` cards read:
    the comparison measures netdae's result (:func:`_compare_measures`) as ngspice measures
    its vectors, which a selection does not drop. Else both are the one result.
    """
    from ..analyses.runner import _with_measured, run, selection

    save = _with_measured(circuit.saves, circuit) if circuit.saves else None
    (result,) = run(replace(circuit, analyses=[card]), save=save, **overrides)
    if save is None or len(save) == len(circuit.saves):
        return result, result
    return selection(result, circuit.saves), result


def _netdae_ac_at(circuit: Circuit, freqs: np.ndarray, overrides: dict) -> Result:
    """netdae's AC phasors at exactly the given frequencies (ngspice's)."""
    from ..analyses.ac import linearize, solve_ac

    lin = linearize(circuit, **overrides)
    system, opts = lin.system, lin.options
    X = solve_ac(lin.E, lin.H_ac, system.B @ system.sources.ac, freqs, lin.delays)
    return Result("ac", axes={"frequency": np.asarray(freqs, dtype=float)},
                  signals={name: X[:, i] for i, name in enumerate(system.names)},
                  tolerances={"reltol": opts.reltol, "vntol": opts.vntol, "abstol": opts.abstol})


def _netdae_error(exc: BaseException) -> str:
    """What netdae's failure to run an analysis says; a missing module outside netdae is raised again."""
    if isinstance(exc, ModuleNotFoundError):
        if not (exc.name or "").startswith("netdae"):
            raise exc
        return f"netdae cannot run this analysis in this build: module {exc.name} is missing"
    return f"netdae failed: {exc}"


def _with_differences(ng: Result, names: list[str]) -> Result:
    """ngspice's result with the differences ``v(a,b)`` netdae reports, formed from ``v(a)`` and ``v(b)``.

    ngspice writes the nodes of a saved ``v(a,b)`` separately, and names the
    current netdae calls ``i(r1)`` (a resistor's, a capacitor's) ``@r1[i]``.
    """
    missing = [n for n in names if n not in ng.signals and n.startswith("v(") and "," in n]
    currents = {n: f"@{parse_signal(n).args[0]}[i]" for n in names if n.startswith("i(") and n not in ng.signals}
    currents = {n: at for n, at in currents.items() if at in ng.signals}  # i(r1) is ngspice's @r1[i]
    if currents:
        signals = {k: v for k, v in ng.signals.items() if k not in currents.values()}
        signals.update({n: ng.signals[at] for n, at in currents.items()})
        ng = replace(ng, signals=signals)
    if not missing:
        return ng
    extra = {}
    for name in missing:
        try:
            extra.update(ng.subset([name]).signals)
        except KeyError:
            continue  # a node ngspice did not write: reported as netdae-only
    return replace(ng, signals={**ng.signals, **extra}) if extra else ng


def _compare_card(kind: str, circuit: Circuit, card, ng: Result | None, tol, overrides, wanted, exclude,
                  ngspice_failed: bool, netdae_results: dict | None = None) -> AnalysisComparison:
    """One analysis card compared; netdae's result is kept in ``netdae_results`` (the first of its kind)."""
    if ng is None and kind == "sens" and not ngspice_failed:  # removed by the bridge: its notes say why
        return AnalysisComparison(kind, tolerance=None, notes=["not judged: ngspice 39 did not run this .sens card "
                                                               "(the bridge removed it; see its notes)"])
    if ng is None:
        reason = "ngspice failed on the netlist" if ngspice_failed else f"ngspice produced no {kind} result"
        return _netdae_alone(kind, circuit, card, tol, overrides, reason, netdae_results)
    try:
        if kind == "ac":
            nd = measured = _netdae_ac_at(circuit, ng.axis, overrides)
        elif kind == "noise" and card.summary <= 1 and ng.axis is not None and ng.axis.size:
            from ..analyses.noise import noise_analysis

            # ngspice's grid: its integration too
            nd = measured = noise_analysis(circuit, card, freqs=ng.axis, **overrides)
        else:
            nd, measured = _run_netdae(circuit, card, overrides)
    except (NetdaeError, ModuleNotFoundError) as exc:
        return AnalysisComparison(kind, tolerance=tol, error=_netdae_error(exc),
                                  ngspice_tolerances=dict(ng.tolerances))
    if netdae_results is not None:
        netdae_results.setdefault(kind, measured)
    ng = _with_differences(ng, nd.names())
    if kind == "tran":
        item = compare_transient(nd, ng, tol=tol, wanted=wanted, exclude=exclude)
    else:
        extra = {"circuit": circuit} if kind == "sens" else {}
        item = _COMPARERS[kind](nd, ng, tol=tol, wanted=wanted, exclude=exclude, **extra)
    if kind == "ac" and any(sig.passed is False for sig in item.signals):
        note = _switches_note(circuit)
        if note is not None:
            item.notes.append(note)
    if kind in ("op", "dc") and any(sig.passed is False for sig in item.signals):
        note = _current_law(kind, circuit, item, measured, ng, overrides)
        if note is not None:
            item.notes.append(note)
    item.netdae_tolerances = dict(nd.tolerances)
    item.ngspice_tolerances = {**ng.tolerances, "method": (ng.source.method if ng.source is not None and ng.source.method else "trap")}
    item.notes[:0] = [f"netdae: {note}" for note in nd.notes]
    return item


def _switches_note(circuit: Circuit) -> str | None:
    """Why an ``.ac`` of a circuit with switches can disagree: ngspice 39 takes every switch as ``ROFF`` in its
    AC matrix whatever its state at the operating point (docs/ngspice.md, quirks); netdae takes the state's
    resistance. None without switches.

    >>> from netdae.circuit import Element
    >>> print(_switches_note(Circuit("t", elements=[Element("s1", "vswitch", ("a", "b", "c", "0"))])))
    the circuit has switches (s1): ngspice 39's .ac takes each as open (ROFF) whatever its state at the operating point, netdae with that state's resistance (docs/ngspice.md); a switch that is on there makes the two differ
    """
    from ..kinds import Kind

    names = [el.name for el in circuit.elements if el.kind in (Kind.VSWITCH, Kind.CSWITCH)]
    if not names:
        return None
    return (f"the circuit has switches ({', '.join(names[:6])}{' ...' if len(names) > 6 else ''}): ngspice 39's .ac "
            "takes each as open (ROFF) whatever its state at the operating point, netdae with that state's "
            "resistance (docs/ngspice.md); a switch that is on there makes the two differ")


def _current_law(kind: str, circuit: Circuit, item, measured: Result, ng: Result, overrides: dict) -> str | None:
    """The current-law check of two disagreeing operating points (:mod:`netdae.comparison.currentlaw`):
    the ``.op``'s, or a source sweep's at the point where the two differ most (not a sweep of the
    temperature or of a resistor, whose system is another at every point)."""
    from ..kinds import kind_of
    from .currentlaw import current_law_note, worst_sweep_point

    if kind == "op":
        return current_law_note(circuit, {n: float(measured.signals[n][0]) for n in measured.names()},
                                {n: float(ng.signals[n][0]) for n in ng.names()}, overrides)
    axes = dict(ng.axes)
    sources = {el.name.lower() for el in circuit.elements if kind_of(el.kind).independent}
    if (not axes or not item.curves or measured.axis is None
            or any(name.lower() not in sources or name not in measured.axes for name in axes)):
        return None
    k = worst_sweep_point(item.curves, [(sig.name, sig.scale) for sig in item.signals])
    at = {name: float(np.asarray(values)[k]) for name, values in axes.items()}
    mine = np.all([np.isclose(np.asarray(measured.axes[name]), v, rtol=1e-9, atol=1e-15) for name, v in at.items()],
                  axis=0)
    hits = np.flatnonzero(mine)
    if hits.size != 1:
        return None
    j = int(hits[0])
    note = current_law_note(circuit, {n: float(measured.signals[n][j]) for n in measured.names()},
                            {n: float(ng.signals[n][k]) for n in ng.names()}, overrides, sources=at)
    if note is None:
        return None
    where = ", ".join(f"{name} = {value:g}" for name, value in at.items())
    return f"at {where} (the sweep's largest difference): {note}"


def _netdae_alone(kind: str, circuit: Circuit, card, tol, overrides, reason: str,
                  netdae_results: dict | None) -> AnalysisComparison:
    """An analysis ngspice gave no result for: not judged, but netdae's own run is made (its
    measurements reported beside ngspice's failure, its failure said with ngspice's)."""
    item = AnalysisComparison(kind, tolerance=tol, error=reason)
    try:
        nd, measured = _run_netdae(circuit, card, overrides)
    except (NetdaeError, ModuleNotFoundError) as exc:
        item.error = f"{reason}; netdae: {_netdae_error(exc)}"
        return item
    if netdae_results is not None:
        netdae_results.setdefault(kind, measured)
    item.netdae_tolerances = dict(nd.tolerances)
    item.notes = [f"netdae ran on its own ({len(nd.axis) if nd.axis is not None else 0} points): "
                  f"{nd.message or 'ok'}"] + [f"netdae: {note}" for note in nd.notes]
    return item


def _compare_measures(circuit: Circuit, netdae_results: dict[str, Result], ngspice_measures) -> list:
    """netdae's measurements (on the results it compared) paired with ngspice's, by name (the k-th card
    of a name with ngspice's k-th: ngspice measures each card of a repeated name)."""
    from ..analyses.measure import evaluate_measures
    from ..measures import STATUS_FAILED, Measure

    ours = evaluate_measures(circuit.measures, netdae_results)
    theirs: dict[str, list] = {}
    for m in ngspice_measures:
        theirs.setdefault(m.name, []).append(m)
    seen: dict[str, int] = {}
    out = []
    for m in ours:
        k = seen[m.name] = seen.get(m.name, -1) + 1
        same = theirs.get(m.name, [])
        ng = same[k] if k < len(same) else Measure(m.name, m.analysis, m.function, None, status=STATUS_FAILED,
                                                   reason="ngspice did not run")
        out.append(MeasureComparison(m.name, m.analysis, m, ng))
    return _one_analysis_measured(out)


#: ngspice's reason for a card it printed nothing about (netdae.ngspice.measures).
_SILENT = "ngspice printed no value"


def _one_analysis_measured(pairs: list) -> list:
    """The pairs, with the reason of ngspice's silence said where it is ngspice 39's batch mode.

    With cards of several analyses (``.meas tran`` and ``.meas ac``), ``ngspice -b`` makes the
    measurements of one analysis only and prints nothing for the others' cards. When every card of an
    analysis got no word from ngspice while another analysis's cards did, that is the reason.

    Examples
    --------
    >>> from netdae.measures import Measure
    >>> from netdae.comparison.model import MeasureComparison
    >>> tr = MeasureComparison("tr", "tran", Measure("tr", "tran", "trig", 1.0), Measure("tr", "tran", "trig", 1.0))
    >>> f = MeasureComparison("f", "ac", Measure("f", "ac", "when", 2.0),
    ...                       Measure("f", "ac", "when", None, status="failed", reason=_SILENT))
    >>> _one_analysis_measured([tr, f])[1].ngspice.reason[:60]
    'ngspice printed no value: ngspice 39 -b measures the .meas c'
    """
    from dataclasses import replace

    spoke = {p.analysis for p in pairs if p.ngspice.reason != _SILENT}
    silent = {p.analysis for p in pairs} - spoke
    if not spoke or not silent:
        return pairs
    kinds = ", ".join(f".meas {k}" for k in sorted(silent))
    why = (f"{_SILENT}: ngspice 39 -b measures the .meas cards of one analysis when a netlist runs several "
           f"(here those of {', '.join(sorted(spoke))}); run the {kinds} cards on a netlist with that analysis alone")
    return [replace(p, ngspice=replace(p.ngspice, reason=why)) if p.analysis in silent else p for p in pairs]


def compare(netlist, *, tight: bool | None = None, tol=None, backend: str = "auto", signals=None,
            exclude=(), reltol: float | None = None, analyses=None, timeout: float | None = None,
            behavior: str | None = None) -> Comparison:
    """Run a netlist in netdae and in ngspice and compare every analysis.

    Parameters
    ----------
    netlist : str, path-like or Circuit
        A netlist file, a netlist's text (a string with a newline), or a
        circuit loaded from a file (:func:`netdae.load`).
    tight : bool, optional
        Run both simulators with tight tolerances (module docstring) so that
        the differences show the models rather than the step control.
        Default: what the netlist's header says (``* compare options: tight``),
        else False.
    tol : float, Tolerance or dict, optional
        Pass criterion, relative to each signal's scale
        (:mod:`netdae.comparison.metrics`): one value for every analysis, or a
        dict from analysis (``"op"``, ``"dc"``, ``"ac"``, ``"tran"``) to a
        value (None: compare without judging). Default: the netlist's
        ``* compare tolerance:`` header, else 1e-3.
    backend : {"auto", "shared", "subprocess"}
        How to run ngspice (:func:`netdae.ngspice.run_ngspice`).
    signals : sequence of str, optional
        Compare only these signals (default: every signal both produce).
    exclude : sequence of str
        Signals to leave out.
    reltol : float, optional
        Relative tolerance for both simulators (overrides the netlist's and,
        with ``tight``, the tight one).
    analyses : sequence of str, optional
        Compare only these kinds of analysis (``"op"``, ``"dc"``, ``"ac"``,
        ``"tran"``); netdae skips the others (ngspice runs the netlist as written).
    timeout : float, optional
        Seconds the ngspice run may take; then ngspice is stopped (its process
        killed, or the shared library's thread halted) and the comparison
        fails with ``ngspice_error`` saying so. Default
        :data:`netdae.ngspice.DEFAULT_TIMEOUT`; ``math.inf`` for no limit.
    behavior : str, optional
        ngspice's compatibility mode (``"psa"`` ...; :func:`netdae.load`), default: the
        ``.spiceinit`` next to the netlist, else in the working directory; a Circuit keeps the
        mode it was loaded in. ngspice runs in the same mode.

    Returns
    -------
    Comparison
        Its ``passed`` is the verdict; a simulator that fails on the netlist
        is reported in it (``ngspice_error``, an analysis's ``error``), not raised.

    Raises
    ------
    NgspiceError
        When ngspice is not installed (the message gives the install command),
        the requested backend cannot run, or ``timeout`` is not positive.
    NetlistError
        When the netlist is malformed.
    NetdaeError
        For a signal name neither simulator produces, or a bad tolerance.

    Notes
    -----
    Cost: one netdae run and one ngspice run per analysis card, plus one
    dense evaluation of netdae's transient at ngspice's time points.
    """
    from ..analyses.runner import string_entries
    from ..ngspice import BACKENDS

    if backend not in BACKENDS:
        raise ValueError(f"backend must be one of {', '.join(repr(b) for b in BACKENDS)}, not {backend!r}")
    signals = string_entries(signals, "signals")  # one string is one signal
    exclude = string_entries(exclude, "exclude") or ()
    analyses = string_entries(analyses, "analyses")
    circuit, text, source, workdir = _read(netlist, behavior)
    options = {"tight": tight, "tol": tol, "backend": backend, "signals": signals, "exclude": exclude,
               "reltol": reltol, "analyses": analyses, "timeout": timeout}
    if circuit.draws:
        raise NetdaeError(f"{source}: the netlist draws {circuit.draws} Monte Carlo value(s) (gauss, agauss, unif, "
                          "aunif, limit): ngspice draws others, so the two runs are different circuits; compare "
                          "a netlist with fixed values, and the distributions with netdae sweep --mc")
    if circuit.steps:
        return _compare_points(circuit, text, source, workdir, options)
    return _compare_one(circuit, text, source, workdir, **options)


def refuse_random_sources(circuit: Circuit, kinds: set[str], source: str) -> None:
    """Refuse a transient comparison of a netlist with TRNOISE or TRRANDOM sources.

    Their values are random: netdae and ngspice draw different sequences, so
    the waveforms cannot agree point by point (their statistics can; see
    docs/ngspice.md). The other analyses see the sources' DC values and are
    compared as usual.

    Raises
    ------
    NetdaeError
        When ``kinds`` holds ``tran``, the circuit has a ``.tran`` card and a
        random source.
    """
    from ..netlist.waveforms import RandomSource

    if "tran" not in kinds or not any(isinstance(a, TranAnalysis) for a in circuit.analyses):
        return
    noisy = [el.name for el in circuit.elements
             if el.source is not None and isinstance(el.source.tran, RandomSource)]
    if noisy:
        shown = ", ".join(noisy[:5]) + (f" and {len(noisy) - 5} more" if len(noisy) > 5 else "")
        raise NetdaeError(f"{source}: {shown} draw(s) random values (TRNOISE, TRRANDOM): ngspice draws another "
                          "sequence, so the .tran waveforms cannot agree point by point; compare the other analyses "
                          "(analyses= of netdae.compare, or the netlist without its .tran card: they see the DC "
                          "values), and the transients by their statistics (docs/ngspice.md)")


#: The end card of a netlist (what follows it is not read).
_END = re.compile(r"^[ \t]*\.end[ \t]*$", re.IGNORECASE | re.MULTILINE)


def point_text(text: str, params: dict[str, float], temp: float | None) -> str:
    """The netlist with ``.param`` and ``.temp`` cards for one point added before its ``.end``.

    Both simulators take the last definition of a top-level parameter and the
    last ``.temp``.

    >>> point_text("t\\nR1 a 0 {r}\\n.end\\n", {"r": 2000.0}, 50.0)
    't\\nR1 a 0 {r}\\n.param r=2000.0\\n.temp 50.0\\n.end\\n'
    """
    extra = "".join(f".param {name}={value!r}\n" for name, value in params.items())
    if temp is not None:
        extra += f".temp {temp!r}\n"
    m = _END.search(text)
    if m is None:
        return text.rstrip("\n") + "\n" + extra
    return text[:m.start()] + extra + text[m.start():]


def _compare_points(circuit: Circuit, text: str, source: str, workdir: str, options: dict) -> Comparison:
    """A stepped netlist: one comparison per point of its ``.step`` cards (parameters and temp)."""
    from ..netlist import load
    from ..sweeps.plan import make_plan

    plan = make_plan(circuit)
    for axis in plan.axes:
        if axis.target in ("element", "model"):
            what = "an element" if axis.target == "element" else "a model parameter"
            raise NetdaeError(f"{source}: compare runs the points of .step cards of parameters and temp; "
                              f"'.step {axis.name}' steps {what} (step a .param used in its value instead)")
    parent = Comparison(source=source, title=circuit.title)
    for row in plan.rows:
        params = {a.name: v for a, v in zip(plan.axes, row.point) if a.target == "param"}
        temp = next((v for a, v in zip(plan.axes, row.point) if a.target == "temp"), None)
        text_k = point_text(text, params, temp)
        circuit_k = load(text_k, path=None if source == "<string>" else source, behavior=_behavior(circuit))
        one = _compare_one(dataclasses.replace(circuit_k, steps=[]), text_k, source, workdir, **options)
        one.point = {a.name: v for a, v in zip(plan.axes, row.point)}
        parent.points.append(one)
    return parent


def _compare_one(circuit: Circuit, text: str, source: str, workdir: str, *, tight, tol, backend, signals, exclude,
                 reltol, analyses, timeout) -> Comparison:
    """:func:`compare` of one circuit (not stepped) and the text ngspice runs."""
    from .. import ngspice as bridge
    from ..analyses.runner import analysis_name

    refuse_steps(circuit)
    if not circuit.analyses:
        from ..analyses.runner import _skipped_analyses

        raise NetdaeError(f"{source}: the netlist has no analysis card (.op, .dc, .ac or .tran); nothing to compare"
                          + _skipped_analyses(circuit))
    wanted_kinds = set(ANALYSES) if analyses is None else {a.lower().lstrip(".") for a in analyses}
    if not wanted_kinds <= set(ANALYSES):
        raise NetdaeError(f"unknown analysis in {sorted(wanted_kinds - set(ANALYSES))}; choose from {', '.join(ANALYSES)}")
    refuse_random_sources(circuit, wanted_kinds, source)
    header = parse_header(text, source=source)
    tight = header.tight if tight is None else bool(tight)
    tolerances, tol_source = _tolerances(tol, header)
    nd_overrides, ng_options, gain = _settings(circuit, tight, reltol)
    if not bridge.available():
        raise NgspiceError(f"ngspice is not installed, so netdae cannot compare against it; install it with: "
                           f"{bridge.INSTALL_HINT}")
    comparison = Comparison(source=source, title=circuit.title, tight=tight, tolerance_source=tol_source,
                            ngspice_options=dict(ng_options), netdae_options=dict(nd_overrides),
                            opamp_gain=gain if gain is not None else bridge.OPAMP_GAIN)
    kwargs = {"backend": backend, "workdir": workdir, "source": source, "options": ng_options or None,
              "timeout": bridge.check_timeout(timeout), "behavior": _behavior(circuit)}
    if gain is not None:
        kwargs["opamp_gain"] = gain
    ng_results: list[Result] = []
    ng_measures: list = []
    scripted = False  # ngspice ran the analyses as netdae's control block's commands, in netdae's order
    try:
        run = bridge.run_ngspice(text, **kwargs)
    except bridge.BackendUnavailable:
        raise
    except NgspiceError as exc:
        comparison.ngspice_error = str(exc) + _osdi_note(circuit)
    else:
        scripted = SCRIPT_MARK in run.netlist.split("\n")
        ng_results = run.results
        ng_measures = run.measures
        comparison.ngspice_version, comparison.backend = run.version, run.backend
        comparison.translations = list(run.notes)
        comparison.ngspice_warnings = list(run.warnings)
    if not comparison.ngspice_version:
        comparison.ngspice_version = _version_or_empty(backend)
    seen: dict[str, int] = {}
    netdae_results: dict[str, Result] = {}
    from ..analyses.altered import altered_circuit

    altered: dict = {}
    for card in circuit.analyses:
        kind = analysis_name(card)
        occurrence = seen.get(kind, 0)
        seen[kind] = occurrence + 1
        if kind not in wanted_kinds:
            continue
        ours = [r for r in ng_results if r.analysis == kind]
        if kind in RUNS_LAST_TO_FIRST and not scripted:  # netdae's k-th card of the kind: ngspice's k-th from the end
            ours.reverse()
        ng = ours[occurrence] if occurrence < len(ours) else None
        item = _compare_card(kind, altered_circuit(circuit, card.alter, altered), card, ng, tolerances[kind],
                             nd_overrides, signals, exclude,
                             comparison.ngspice_error is not None, netdae_results=netdae_results)
        item.occurrence = occurrence
        comparison.analyses.append(item)
    if not comparison.analyses:
        raise NetdaeError(f"{source}: the netlist has no {' or '.join('.' + k for k in sorted(wanted_kinds))} "
                          "analysis to compare")
    if circuit.measures:
        comparison.measures = _compare_measures(circuit, netdae_results, ng_measures)
    return comparison


def _version_or_empty(backend: str) -> str:
    from .. import ngspice as bridge

    try:
        return bridge.ngspice_version(backend)
    except NgspiceError:
        return ""
