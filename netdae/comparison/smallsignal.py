"""Compare ``.pz``, ``.tf`` and ``.noise`` results: roots as sets, numbers value by value, noise spectra.

ngspice's pole-zero search is iterative (Muller's method on the determinant,
deflating each root it finds) and can miss roots or stop early; netdae's roots
are the finite eigenvalues of two pencils. Roots are therefore matched as
*sets*, by an optimal one-to-one assignment (:func:`match_roots`): each pair's
error is ``|a - b|`` over the larger magnitude of the two, floored at
:data:`ROOT_FLOOR` (1e-12) of the largest root of the analysis (a root at the
origin, exactly 0 in one simulator and 1e-13 in the other, compares
absolutely); a root exactly at the origin in one simulator matches one
within :data:`ORIGIN` (sqrt(eps)) of the largest root in the other, since a
multiple root at the origin splits by that much in rounding (netdae computes
a double zero at 0 of a circuit with two coupling capacitors as
``+-1.3e-5j`` when its largest root is 8.8e10; ngspice finds s = 0 exactly). A root only netdae finds is reported (``only_netdae`` and a
note saying ngspice missed it) and does not fail the comparison; a root only
ngspice finds fails it.

``.tf``: the three numbers are compared value by value, each relative to the
larger of its two values; an impedance below :data:`TF_IMPEDANCE_FLOOR` of the
largest finite impedance (an output node shorted at DC: 0 in one simulator,
7e-15 ohm in the other) against that floor.
The output impedance of a current output is not judged when ngspice reports
1e20 and netdae a finite value: ngspice 39 computes it as
``1 / max(1e-20, i)``, which is 1e20 for every branch whose current per
series volt is negative (every passive load); :mod:`netdae.analyses.tf`.

``.noise``: every spectral density both produce (``onoise_spectrum``,
``inoise_spectrum``, and with a summary each generator's) at ngspice's
frequencies, relative to the larger density at each frequency floored at
:data:`NOISE_DYNAMIC_RANGE` of the signal's peak; then every integrated
total (``onoise_total`` ...) relative to the larger of the two values.
"""

from __future__ import annotations

import numpy as np

from ..circuit import ABSOLUTE_ZERO
from ..kinds import KINDS, Kind
from ..results import Result
from .header import Tolerance
from .model import AnalysisComparison, SignalComparison

__all__ = ["ROOT_FLOOR", "TF_IMPEDANCE_FLOOR", "MATCH_LIMIT", "NOISE_DYNAMIC_RANGE", "match_roots", "compare_pz", "compare_tf",
           "compare_sens", "compare_noise", "NGSPICE_WRONG_SENS"]

#: Roots smaller than this fraction of the analysis's largest root are compared absolutely: a root at
#: the origin computed as 0 by one simulator and 1e-13 by the other; every other root relatively.
ROOT_FLOOR = 1e-12
#: A root exactly at the origin in one simulator is matched by one within this fraction of the
#: largest root in the other (a double root at 0 splits into +-sqrt(eps) of the spectrum's scale).
ORIGIN = float(np.sqrt(np.finfo(float).eps))
#: Two roots further apart than this (relative) are not the same root, whatever the assignment says.
MATCH_LIMIT = 1e-2
#: A noise density's error is relative to the larger density at its frequency, floored at this
#: fraction of the signal's peak (the same floor as the AC phasors').
NOISE_DYNAMIC_RANGE = 1e-9
#: ngspice's infinite impedance.
_INFINITE = 1e20
#: A ``.tf`` impedance smaller than this fraction of the largest finite impedance of the analysis
#: (input or output, either simulator) is compared absolutely: an output node shorted at DC (through
#: an inductor) has the impedance 0 in one simulator and 7e-15 ohm in the other, a rounding error
#: of the solve; the same floor as the roots' (:data:`ROOT_FLOOR`).
TF_IMPEDANCE_FLOOR = ROOT_FLOOR


def _is_impedance(name: str) -> bool:
    return "impedance" in name  # src#input_impedance, x#output_impedance, output_impedance_at_v(...)


def _largest_impedance(nd: Result, ng: Result, names) -> float:
    """The largest finite ``.tf`` impedance either simulator reports (0 when there is none)."""
    values = [abs(float(r.signals[n][0])) for r in (nd, ng) for n in names if _is_impedance(n) and n in r.signals]
    finite = [v for v in values if np.isfinite(v) and v < _INFINITE]
    return max(finite, default=0.0)


def match_roots(a, b, *, floor: float, origin: float = 0.0) -> tuple[list[tuple[int, int, float]], list[int], list[int]]:
    """Pair the roots of two sets, one to one, minimising the total relative distance.

    Parameters
    ----------
    a, b : array_like of complex
    floor : float
        Smallest scale of a relative distance (absolute units).
    origin : float
        Smallest scale of the distance to a root exactly at the origin (a multiple root
        there splits by this much in the other simulator's rounding: :data:`ORIGIN` of the
        largest root).

    Returns
    -------
    pairs : list of (i, j, relative distance)
        ``a[i]`` paired with ``b[j]``; pairs further apart than
        :data:`MATCH_LIMIT` are not pairs.
    only_a, only_b : list of int
        Indices left without a partner.

    Examples
    --------
    >>> pairs, only_a, only_b = match_roots([-1 + 1j, -1 - 1j, -5], [-1 - 1j, -1 + 1j], floor=1e-9)
    >>> [(i, j) for i, j, _ in pairs], only_a, only_b
    ([(0, 1), (1, 0)], [2], [])

    A root computed as 1.8e-10 in one and exactly 0 in the other, beside a root of 1e4:

    >>> [(i, j, round(d, 9)) for i, j, d in match_roots([1.8e-10, -1e4], [0.0, -1e4], floor=1e-8, origin=1.5e-4)[0]]
    [(0, 0, 1.2e-06), (1, 1, 0.0)]
    """
    from scipy.optimize import linear_sum_assignment

    a = np.asarray(a, dtype=complex)
    b = np.asarray(b, dtype=complex)
    if a.size == 0 or b.size == 0:
        return [], list(range(a.size)), list(range(b.size))
    scale = np.maximum(np.maximum(np.abs(a)[:, None], np.abs(b)[None, :]), floor)
    at_origin = (a[:, None] == 0) | (b[None, :] == 0)
    scale = np.where(at_origin, np.maximum(scale, origin), scale)
    cost = np.abs(a[:, None] - b[None, :]) / scale
    rows, cols = linear_sum_assignment(cost)
    pairs = [(int(i), int(j), float(cost[i, j])) for i, j in zip(rows, cols) if cost[i, j] <= MATCH_LIMIT]
    used_a = {i for i, _, _ in pairs}
    used_b = {j for _, j, _ in pairs}
    return pairs, [i for i in range(a.size) if i not in used_a], [j for j in range(b.size) if j not in used_b]


def _roots(result: Result, kind: str) -> tuple[list[str], np.ndarray]:
    names = [n for n in result.signals if n.startswith(kind + "(")]
    return names, np.array([complex(result.signals[n][0]) for n in names], dtype=complex)


def _text(value: complex) -> str:
    return f"{value.real:.6e},{value.imag:.6e}"


def compare_pz(nd: Result, ng: Result, *, tol: Tolerance | None, wanted=None, exclude=()) -> AnalysisComparison:
    """Compare poles and zeros as sets (module docstring).

    Each matched root is a :class:`SignalComparison` named as netdae names it
    (``pole(2)``), with both values; a root ngspice finds and netdae does not
    is a failed one (``max_rel`` infinite).
    """
    item = AnalysisComparison("pz", tolerance=tol)
    item.points = 1
    every = np.concatenate([_roots(r, k)[1] for r in (nd, ng) for k in ("pole", "zero")])
    top = float(np.abs(every).max()) if every.size else 0.0
    top = top if top > 0 else 1.0
    floor = ROOT_FLOOR * top
    floored: list[str] = []
    signals: list[SignalComparison] = []
    for kind in ("pole", "zero"):
        names_a, a = _roots(nd, kind)
        names_b, b = _roots(ng, kind)
        pairs, only_a, only_b = match_roots(a, b, floor=floor, origin=ORIGIN * top)
        for i, j, _ in pairs:
            err = abs(a[i] - b[j])
            scale = max(abs(a[i]), abs(b[j]), floor)
            if ((a[i] == 0) != (b[j] == 0)) and err <= ORIGIN * top:
                scale = ORIGIN * top  # a root at the origin: a multiple one splits by sqrt(eps)
                floored.append(names_a[i])
            passed = None if tol is None else bool(err <= tol.rel * scale or (tol.abs is not None and err <= tol.abs))
            signals.append(SignalComparison(names_a[i], err, err / scale, err, {}, scale,
                                            "floor" if scale in (floor, ORIGIN * top) else "magnitude", passed,
                                            netdae=a[i], ngspice=b[j]))
        for i in only_a:
            item.only_netdae.append(names_a[i])
        if only_a:
            item.notes.append(f"netdae finds {len(only_a)} {kind}(s) more than ngspice (ngspice's iterative "
                              "search missed them): " + "; ".join(f"{names_a[i]} = {_text(a[i])}" for i in only_a))
        for j in only_b:
            item.only_ngspice.append(names_b[j])
            signals.append(SignalComparison(f"{names_b[j]} (ngspice only)", float("inf"), float("inf"),
                                            float("inf"), {}, floor, "floor", None if tol is None else False,
                                            netdae=None, ngspice=b[j]))
        if only_b:
            item.notes.append(f"ngspice finds {kind}(s) netdae does not: "
                              + "; ".join(f"{names_b[j]} = {_text(b[j])}" for j in only_b))
        if a.size or b.size:
            item.notes.append(f"{kind}s: netdae {a.size}, ngspice {b.size}, matched {len(pairs)}")
    if not signals and not item.only_netdae:
        # agreement on an empty answer (a resistive circuit): one count compared, so that the analysis passes
        signals.append(SignalComparison("finite poles and zeros (count)", 0.0, 0.0, 0.0, {}, 1.0, "magnitude",
                                        None if tol is None else True, netdae=0.0, ngspice=0.0))
        item.notes.append("no finite pole or zero in either simulator")
    if floored:
        item.notes.append(f"{', '.join(floored)}: at the origin in one simulator; compared absolutely, against "
                          f"sqrt(eps) of the largest root ({ORIGIN * top:.3g}), since a multiple root at the "
                          "origin splits by that much in rounding")
    item.signals = sorted(signals, key=lambda s: (-s.max_rel, s.name))
    return item


def compare_tf(nd: Result, ng: Result, *, tol: Tolerance | None, wanted=None, exclude=()) -> AnalysisComparison:
    """Compare the transfer function and the two impedances, value by value.

    Each is a different quantity: its error is relative to the larger
    magnitude of the two values (no floor across quantities).
    """
    from .analyses import select_signals

    item = AnalysisComparison("tf", tolerance=tol)
    item.points = 1
    skip = [n for n in nd.names() if n.endswith("#output_impedance") and n in ng.signals
            and float(ng.signals[n][0]) == _INFINITE and float(nd.signals[n][0]) != _INFINITE]
    compared, item.only_netdae, item.only_ngspice, item.excluded = select_signals(
        nd.names(), ng.names(), wanted, [*exclude, *skip])
    for n in skip:
        item.notes.append(f"{n} not judged: ngspice 39 reports 1e20 (it computes 1/max(1e-20, i), infinite for "
                          f"every branch whose current per series volt is negative); netdae "
                          f"{float(nd.signals[n][0]):.6g} ohm, the impedance a source in series with the branch "
                          "sees")
    if not compared:
        item.error = "no quantity is produced by both simulators (see only_netdae / only_ngspice)"
        return item
    signals = []
    floor = TF_IMPEDANCE_FLOOR * _largest_impedance(nd, ng, compared)
    floored = []
    for name in compared:
        a, b = float(nd.signals[name][0]), float(ng.signals[name][0])
        err = abs(a - b)
        scale = max(abs(a), abs(b)) or 1.0
        how = "magnitude"
        if _is_impedance(name) and floor > scale:
            scale, how = floor, "floor"
            floored.append(name)
        passed = None if tol is None else bool(err <= tol.rel * scale or (tol.abs is not None and err <= tol.abs))
        signals.append(SignalComparison(name, err, err / scale, err, {}, scale, how, passed,
                                        netdae=a, ngspice=b))
    if floored:
        item.notes.append(f"{', '.join(floored)}: at the rounding level of the circuit's impedances in one "
                          f"simulator (a node shorted at DC); compared absolutely, against "
                          f"{TF_IMPEDANCE_FLOOR:g} of the largest impedance ({floor / TF_IMPEDANCE_FLOOR:.6g} ohm)")
    item.signals = sorted(signals, key=lambda s: (-s.max_rel, s.name))
    return item


def compare_noise(nd: Result, ng: Result, *, tol: Tolerance | None, wanted=None, exclude=()) -> AnalysisComparison:
    """Compare noise spectral densities at ngspice's frequencies, then the integrated totals.

    The densities are compared at the frequencies both results hold (the
    comparison runs netdae on ngspice's grid; a note says when some are
    left out). A density's error at each frequency is
    ``|a - b| / max(a, b, floor)``, ``floor = NOISE_DYNAMIC_RANGE`` times
    its peak; a total's is relative to the larger of the two values.
    """
    from .analyses import select_signals

    item = AnalysisComparison("noise", tolerance=tol, axis="frequency")
    compared, item.only_netdae, item.only_ngspice, item.excluded = select_signals(
        nd.names(), ng.names(), wanted, exclude)
    totals_a, totals_b = nd.noise_totals, ng.noise_totals
    common = [k for k in totals_a if k in totals_b and k not in exclude]
    item.only_netdae += [k for k in totals_a if k not in totals_b]
    item.only_ngspice += [k for k in totals_b if k not in totals_a]
    if not compared and not common:
        item.error = "no noise density or total is produced by both simulators (see only_netdae / only_ngspice)"
        return item
    f, fa = ng.axis, nd.axis
    ia = ib = None
    if compared:
        if f is None or fa is None:
            item.error = "a noise result has no frequency axis"
            return item
        # the frequencies both have (the same grid, unless ngspice's own differs at its end)
        pos = np.clip(np.searchsorted(fa, f), 0, max(fa.size - 1, 0))
        near = np.clip(pos - 1, 0, None)
        pos = np.where(np.abs(fa[near] - f) < np.abs(fa[pos] - f), near, pos)
        same = np.isclose(fa[pos], f, rtol=1e-9, atol=0.0)
        if not same.any():
            item.error = f"no frequency in common: netdae {fa.size} point(s), ngspice {f.size}"
            return item
        ia, ib = pos[same], np.flatnonzero(same)
        if ib.size != f.size or ia.size != fa.size:
            item.notes.append(f"densities compared at the {ib.size} frequencies both have (netdae {fa.size}, "
                              f"ngspice {f.size})")
        f = f[ib]
    signals = []
    if compared:
        item.points = int(f.size)
        item.curves = {"axis": f, "start": 0,
                       "values": {n: (np.asarray(nd.signals[n], float)[ia], np.asarray(ng.signals[n], float)[ib])
                                  for n in compared}}
    for name in compared:
        a, b = item.curves["values"][name]
        floor = max(NOISE_DYNAMIC_RANGE * float(max(np.max(np.abs(a)), np.max(np.abs(b)))), 1e-300)
        scale = np.maximum(np.maximum(np.abs(a), np.abs(b)), floor)
        err = np.abs(a - b)
        rel = err / scale
        k = int(np.argmax(rel))
        passed = None if tol is None else bool(np.all(err <= tol.rel * scale + (tol.abs or 0.0)))
        signals.append(SignalComparison(name, float(err.max()), float(rel[k]), float(np.sqrt(np.mean(rel ** 2))),
                                        {"frequency": float(f[k])}, float(scale[k]),
                                        "floor" if scale[k] == floor else "magnitude", passed,
                                        netdae=float(a[k]), ngspice=float(b[k])))
    for name in common:
        a, b = float(totals_a[name]), float(totals_b[name])
        err = abs(a - b)
        scale = max(abs(a), abs(b)) or 1.0
        passed = None if tol is None else bool(err <= tol.rel * scale or (tol.abs is not None and err <= tol.abs))
        signals.append(SignalComparison(name, err, err / scale, err / scale, {}, scale, "magnitude", passed,
                                        netdae=a, ngspice=b))
    item.signals = sorted(signals, key=lambda s: (-s.max_rel, s.name))
    return item


def _sens_floor(values: dict[str, float], sens: dict[str, float]) -> tuple[float, dict[str, float]]:
    """The largest output change per relative parameter change, and each parameter's floor.

    ``M = max_p |p S_p|`` is in the output's unit; a sensitivity error
    ``dS_p`` changes the predicted output by ``p dS_p`` for a relative change
    of ``p``, so ``dS_p`` is judged against ``max(|S_p|, M / |p|)`` (``M``
    alone for a parameter whose value is zero, stepped absolutely).
    """
    top = max((abs(values.get(n, 0.0) * s) for n, s in sens.items() if np.isfinite(s)), default=0.0)
    return top, {n: (top / abs(v) if v else top) for n, v in values.items()}


#: Diode parameters whose sensitivity ngspice 39 gets wrong (measured against the operating point re-solved
#: with the parameter changed, which netdae's values match to 1e-7): it reports 0 for the model's
#: ``area``, the multiplier and the series resistance, 41 times the true value for the instance area and
#: 100 times for the instance temperature. Not judged; ``docs/ngspice.md``.
NGSPICE_WRONG_SENS = {"diode": (":area", "_m", ":rs", "_area", "_temp")}


def _broken_ac_sens(kind: str) -> bool:
    """ngspice 39's AC sensitivity disagrees with its own ``.ac`` on a circuit with this kind of element.

    Measured on a forward-biased diode and a MOSFET amplifier (every semiconductor device whose model
    parameters the sensitivity changes, ``ElementKind.parameters``; netdae's ``<source>_acmag`` equals
    the AC transfer), and with a K element (its ``k1`` is -1e12 times the derivative by the coupling
    factor, and the other sensitivities are 2e-3 away from its own ``.ac`` at 1 MHz on a circuit whose
    sensitivities netdae matches to 1e-9 against ``.ac`` runs with each parameter changed).
    """
    return KINDS[kind].parameters is not None or kind == Kind.COUPLING


def _first_frequency_only(circuit, names: list[str]) -> list[str]:
    """The resistors' values among ``names``: ngspice 39's AC sensitivity to them is 0 after the first frequency."""
    if circuit is None:
        return []
    resistors = {el.name for el in circuit.elements if el.kind == Kind.RESISTOR}
    return [n for n in names if n in resistors]


def _wrong_in_ngspice(circuit) -> list[str]:
    if circuit is None:
        return []
    return [el.name + suffix for el in circuit.elements for suffix in NGSPICE_WRONG_SENS.get(el.kind, ())]


def compare_sens(nd: Result, ng: Result, *, tol: Tolerance | None, wanted=None, exclude=(),
                 circuit=None) -> AnalysisComparison:
    """Compare sensitivities parameter by parameter (each at ngspice's frequencies for the AC one).

    Each sensitivity has its parameter's unit: its error is relative to the
    larger magnitude of the two values, floored at ``M / |p|``
    (:func:`_sens_floor`; ngspice's one-sided differences leave about 1e-6
    of the largest effect in sensitivities that are zero). A parameter
    netdae does not compute (NaN, its note says why) is listed as
    ngspice-only and does not fail the comparison; one ngspice does not list
    is netdae-only.
    """
    from ..analyses.sens import sens_parameters
    from .analyses import select_signals

    ac = nd.axes.get("frequency") is not None
    devices = sorted({el.kind for el in circuit.elements if _broken_ac_sens(el.kind)}) if circuit else []
    unjudged = ac and bool(devices)
    item = AnalysisComparison("sens", tolerance=None if unjudged else tol, axis="frequency" if ac else None)
    if unjudged:
        tol = None
        item.notes.append("not judged: ngspice 39's AC sensitivity is unreliable with these elements "
                          f"({', '.join(devices)}), measured: it evaluates semiconductor devices away from the "
                          "operating point (on a forward-biased diode its v1_acmag is 1.4e-10 V/V where its own "
                          ".ac gives 0.09 V/V), and with a K element its sensitivities are 2e-3 away from its "
                          "own .ac")
    computed = [n for n in nd.names() if np.all(np.isfinite(nd.signals[n]))]
    wrong = [n for n in _wrong_in_ngspice(circuit) if n in ng.signals and n in computed]
    compared, item.only_netdae, item.only_ngspice, item.excluded = select_signals(computed, ng.names(), wanted,
                                                                               [*exclude, *wrong])
    if wrong:
        item.notes.append("not judged, ngspice 39 computes them wrong (NGSPICE_WRONG_SENS): "
                          + ", ".join(f"{n} netdae {complex(nd.signals[n][0]).real:.6g} ngspice "
                                      f"{complex(ng.signals[n][0]).real:.6g}" for n in wrong))
    uncomputed = [n for n in item.only_ngspice if n in nd.signals]
    if uncomputed:
        item.notes.append(f"not computed by netdae (its notes say why), not judged: {', '.join(uncomputed)}")
    if not compared:
        item.error = "no sensitivity is produced by both simulators (see only_netdae / only_ngspice)"
        return item
    values = {}
    if circuit is not None:
        values = {p.name: p.base + (-ABSOLUTE_ZERO if p.kelvin else 0.0)
                  for p in sens_parameters(circuit, ac)[0]}
    if ac:
        fa, fb = nd.axes["frequency"], ng.axes.get("frequency")
        if fb is None or fa.size != fb.size or not np.allclose(fa, fb, rtol=1e-9, atol=0.0):
            item.error = "the two sensitivities are not at the same frequencies"
            return item
    item.points = int(ng.signals[compared[0]].size)
    a_all = {n: np.asarray(nd.signals[n], dtype=complex) for n in compared}
    b_all = {n: np.asarray(ng.signals[n], dtype=complex) for n in compared}
    first = _first_frequency_only(circuit, compared) if ac and item.points > 1 else []
    if first:
        item.notes.append("judged at the first frequency only (ngspice 39 reports 0 for a resistor's value at "
                          f"every later one, though its r_ac and r_scale are right): {', '.join(first)}")
    signals = []
    floors = [_sens_floor(values, {n: abs(a_all[n][k]) for n in compared})[1] for k in range(item.points)]
    for name in compared:
        a, b = a_all[name], b_all[name]
        err = np.abs(a - b)
        if name in first:
            err = np.where(np.arange(err.size) == 0, err, 0.0)
        floor = np.array([f.get(name, 0.0) for f in floors])
        scale = np.maximum(np.maximum(np.abs(a), np.abs(b)), floor)
        scale[scale == 0.0] = 1.0
        rel = err / scale
        k = int(np.argmax(rel))
        passed = None if tol is None else bool(np.all((err <= tol.rel * scale)
                                                      | (tol.abs is not None and err <= (tol.abs or 0.0))))
        at = {"frequency": float(ng.axes["frequency"][k])} if ac else {}
        signals.append(SignalComparison(name, float(err[k]), float(rel[k]), float(np.sqrt(np.mean(err ** 2))), at,
                                        float(scale[k]), "floor" if scale[k] == floor[k] else "magnitude", passed,
                                        netdae=float(a[k].real if not ac else abs(a[k])),
                                        ngspice=float(b[k].real if not ac else abs(b[k]))))
    item.signals = sorted(signals, key=lambda s: (-s.max_rel, s.name))
    return item
