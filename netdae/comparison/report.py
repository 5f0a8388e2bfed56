"""The comparison as text: one table per analysis, worst signal first.

Columns: signal, max abs err, max rel err (relative to the signal's scale),
RMS err, where the worst error is (time, frequency or sweep point), pass; for
AC also the magnitude error in dB and the phase error in degrees. Above the
tables: ngspice's version and backend, the tolerances each side used, and
every translation the bridge made; below each table: the initial jump, the
signals only one simulator produced, and notes.
"""

from __future__ import annotations

from .model import AnalysisComparison, Comparison, MeasureComparison, SignalComparison

__all__ = ["format_comparison", "format_analysis", "format_measures"]

_UNIT_OF_AXIS = {"time": "s", "frequency": "Hz"}


def _verdict(passed: bool | None) -> str:
    return {True: "pass", False: "FAIL", None: "-"}[passed]


def _at(sig: SignalComparison) -> str:
    if not sig.at:
        return ""
    parts = [f"{name}={value:.6g}{_UNIT_OF_AXIS.get(name, '')}" for name, value in sig.at.items()]
    return ", ".join(parts).replace("time=", "t=").replace("frequency=", "f=")


def _unit(name: str) -> str:
    return {"v(": " V", "i(": " A"}.get(name[:2], "")


def _table(rows: list[list[str]], right: set[int]) -> list[str]:
    widths = [max(len(row[k]) for row in rows) for k in range(len(rows[0]))]
    lines = []
    for row in rows:
        cells = [cell.rjust(w) if k in right else cell.ljust(w) for k, (cell, w) in enumerate(zip(row, widths))]
        lines.append("  ".join(cells).rstrip())
    return lines


def format_analysis(item: AnalysisComparison) -> str:
    """One analysis as a table with its notes."""
    label = f".{item.analysis}" + (f" #{item.occurrence + 1}" if item.occurrence else "")
    tol = "not judged (no tolerance)" if item.tolerance is None else (
        f"tolerance {item.tolerance.rel:g} of the scale"
        + (f" or {item.tolerance.abs:g} absolute" if item.tolerance.abs is not None else ""))
    head = f"{label}: {_verdict(item.passed)}, {item.points} points, {tol}"
    lines = [head]
    if item.error:
        lines.append(f"  error: {item.error}")
    if item.window:
        lines.append(f"  initial jump: {item.window['reason']}")
        for sig in item.signals:
            if sig.jump:
                lines.append(f"    {sig.name}: netdae {sig.jump['netdae']:.6g}{_unit(sig.name)} (consistent), "
                             f"ngspice {sig.jump['ngspice']:.6g}{_unit(sig.name)} at t0; agree from "
                             f"t={sig.jump['settle_time']:.6g}s")
    if item.signals:
        ac = item.analysis == "ac"
        header = ["signal", "max abs err", "max rel err", "rms err"]
        if ac:
            header += ["max dB err", "max phase err"]
        header += ["at", "pass"]
        rows = [header]
        for sig in item.signals:
            row = [sig.name, f"{sig.max_abs:.3e}", f"{sig.max_rel:.3e}", f"{sig.rms:.3e}"]
            if ac:
                row += [f"{sig.max_db:.3e}", f"{sig.max_phase_deg:.3e} deg"]
            row += [_at(sig), _verdict(sig.passed)]
            rows.append(row)
        right = set(range(1, len(header) - 2))
        lines += ["  " + line for line in _table(rows, right)]
        floored = [s.name for s in item.signals if s.scale_from == "floor"]
        if floored and item.analysis == "sens":
            lines.append("  scale floored at the largest effect M = max |p dout/dp| over |p| (a sensitivity whose "
                         f"parameter moves the output little): {', '.join(floored)}")
        elif floored:
            lines.append(f"  scale floored (signal smaller than 1 % of its kind's largest): {', '.join(floored)}")
        if item.window:
            worst_whole = max(item.signals, key=lambda s: s.whole["max_rel"] if s.whole else 0.0)
            if worst_whole.whole:
                lines.append(f"  over the whole interval (jump included): worst {worst_whole.name} "
                             f"{worst_whole.whole['max_rel']:.3e} of its scale")
    if item.only_netdae:
        lines.append(f"  only in netdae (not compared): {_listed(item.only_netdae)}")
    if item.only_ngspice:
        lines.append(f"  only in ngspice (not compared): {_listed(item.only_ngspice)}")
    if item.excluded:
        lines.append(f"  excluded: {_listed(item.excluded)}")
    for note in item.notes:
        lines.append(f"  note: {note}")
    return "\n".join(lines)


#: Names a report line lists before it counts the rest (a lossy line's 1,200 internal unknowns).
LISTED_NAMES = 12


def _listed(names: list[str]) -> str:
    """The names joined, the first :data:`LISTED_NAMES` of a long list and how many more (the JSON has all).

    >>> _listed(["v(a)", "v(b)"]), _listed([f"v(n{k})" for k in range(14)]).split(", ")[-1]
    ('v(a), v(b)', 'v(n11) and 2 more')
    """
    if len(names) <= LISTED_NAMES:
        return ", ".join(names)
    return ", ".join(names[:LISTED_NAMES]) + f" and {len(names) - LISTED_NAMES} more"


def _tolerance_line(name: str, values: dict) -> str:
    keys = ("reltol", "vntol", "abstol", "chgtol", "trtol", "method")
    parts = [f"{k}={values[k]:g}" if isinstance(values[k], float) else f"{k}={values[k]}"
             for k in keys if k in values]
    return f"  {name}: " + (" ".join(parts) if parts else "(none reported)")


def format_comparison(comparison: Comparison) -> str:
    """The whole report as text (a stepped netlist: a verdict, then the report of each point)."""
    c = comparison
    if c.points:
        verdict = "PASS" if c.passed else "FAIL"
        failed = sum(not p.passed for p in c.points)
        head = [f"{c.title}  ({c.source})",
                f"netdae vs ngspice on {len(c.points)} points of the .step cards: {verdict}"
                + (f" ({failed} failed)" if failed else "")]
        parts = []
        for p in c.points:
            label = ", ".join(f"{k}={v:g}" for k, v in p.point.items())
            parts.append(f"== point {label}\n" + format_comparison(p))
        return "\n".join(head) + "\n\n" + "\n".join(parts)
    lines = [f"{c.title}  ({c.source})"]
    verdict = "PASS" if c.passed else "FAIL"
    lines.append(f"netdae vs {c.ngspice_version or 'ngspice'}"
                 + (f" ({c.backend} backend)" if c.backend else "")
                 + f": {verdict}" + (" [tight tolerances]" if c.tight else ""))
    if c.ngspice_error:
        lines.append(f"ngspice failed: {c.ngspice_error}")
    lines.append(f"tolerance from: {c.tolerance_source}")
    tolerances_shown = next((a for a in c.analyses if a.netdae_tolerances or a.ngspice_tolerances), None)
    if tolerances_shown is not None:
        lines.append("simulator tolerances:")
        lines.append(_tolerance_line("netdae ", tolerances_shown.netdae_tolerances))
        lines.append(_tolerance_line("ngspice", tolerances_shown.ngspice_tolerances))
    if c.ngspice_options:
        lines.append("ngspice options overridden: "
                     + " ".join(f"{k}={v:g}" if isinstance(v, float) else f"{k}={v}"
                                for k, v in c.ngspice_options.items()))
    if c.translations:
        lines.append("ngspice bridge (translations and choices):")
        lines += [f"  {note}" for note in c.translations]
    for warning in c.ngspice_warnings:
        lines.append(f"ngspice warning: {warning}")
    for item in c.analyses:
        lines.append("")
        lines.append(format_analysis(item))
    if c.measures:
        lines.append("")
        lines.append(format_measures(c.measures))
    return "\n".join(lines) + "\n"


def _value(m) -> str:
    return f"{m.value:.7g}" if m.ok else "failed"


def format_measures(items: list[MeasureComparison]) -> str:
    """The ``.meas`` table: netdae's and ngspice's values, their difference, why one failed."""
    rows = [["measure", "analysis", "netdae", "ngspice", "difference", "relative"]]
    notes = []
    for item in items:
        diff, rel = item.difference, item.relative
        rows.append([item.name, item.analysis, _value(item.netdae), _value(item.ngspice),
                     "" if diff is None else f"{diff:.3e}", "" if rel is None else f"{rel:.3e}"])
        for side, m in (("netdae", item.netdae), ("ngspice", item.ngspice)):
            if not m.ok:
                notes.append(f"  {item.name}: {side} failed: {m.reason}")
    lines = ["measurements (reported, not judged; ngspice prints 7 significant digits):"]
    lines += ["  " + line for line in _table(rows, {2, 3, 4, 5})]
    return "\n".join(lines + notes)
