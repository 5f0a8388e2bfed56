"""PNG of a comparison: both waveforms overlaid, the difference underneath.

One pair of panels per signal, for the worst :data:`MAX_SIGNALS_PER_ANALYSIS`
signals of every analysis with an axis (``.tran``, ``.ac``, ``.dc``), at most
:data:`MAX_PAIRS` pairs in all:

- transient and DC: netdae (line) and ngspice (dots at its points); below,
  netdae - ngspice with the tolerance band, and the initial jump's window
  shaded when the metrics start after t0;
- AC: both magnitudes in dB; below, the relative error ``|A - B| / |B|`` on a
  log scale with the tolerance.

Axes carry SI prefixes; magnitudes at the rounding level (below
:data:`netdae.plotting.MAGNITUDE_FLOOR` of the largest) are not drawn, so the dB
axis spans the data. :func:`comparison_figure` returns the matplotlib Figure
(for a notebook), :func:`plot_comparison` saves it; matplotlib is imported when
a figure is built, without pyplot.
"""

from __future__ import annotations

import textwrap
from pathlib import Path

import numpy as np

from ..errors import NetdaeError
from ..plotting import MAGNITUDE_FLOOR, engineering_axis, magnitude_db, unit_of, save_figure
from .model import AnalysisComparison, Comparison

__all__ = ["comparison_figure", "plot_comparison", "MAX_PAIRS", "MAX_SIGNALS_PER_ANALYSIS"]

#: At most this many signal panels (overlay + difference) per figure.
MAX_PAIRS = 6
#: At most this many signals (the worst ones) of each analysis.
MAX_SIGNALS_PER_ANALYSIS = 3
#: Characters of the netlist's title kept in the figure's title.
TITLE_WIDTH = 80
#: ngspice's points are drawn as dots up to this many, as a dashed line beyond.
MAX_MARKERS = 400
_DPI = 110
#: Relative errors below 1e-18 (under double rounding) are drawn at this floor,
#: so exact agreement stays on the log axis.
_RELATIVE_FLOOR = 1e-18
#: Units of the x axis by analysis.
_X_UNITS = {"tran": "s", "ac": "Hz", "noise": "Hz"}


def _panels(comparison: Comparison) -> list[tuple[AnalysisComparison, str]]:
    chosen = []
    for item in comparison.analyses:
        if item.analysis == "op" or not item.curves:
            continue
        drawn = [sig for sig in item.signals if sig.name in item.curves.get("values", {})]  # not .noise totals
        for sig in drawn[:MAX_SIGNALS_PER_ANALYSIS]:
            chosen.append((item, sig.name))
    return chosen[:MAX_PAIRS]


def _xlabel(item: AnalysisComparison) -> str:
    return {"tran": "time", "ac": "frequency"}.get(item.analysis, item.axis or "")


def _yunit(name: str) -> str:
    return {"v(": "V", "i(": "A"}.get(name[:2], "")


def _curves(item: AnalysisComparison) -> list:
    """Index sets drawn as one curve each: one per outer value of a nested DC sweep."""
    axes = item.curves.get("axes")
    if item.analysis != "dc" or not axes or len(axes) < 2:
        return [slice(None)]
    outer = list(axes.values())[1]
    return [np.flatnonzero(outer == value) for value in np.unique(outer)]


def _draw_waveform(top, bottom, item: AnalysisComparison, name: str) -> None:
    x = item.curves["axis"]
    a, b = item.curves["values"][name]
    sig = next(s for s in item.signals if s.name == name)
    start = item.curves.get("start", 0)
    style = {"marker": ".", "markersize": 3, "linestyle": "none"} if x.size <= MAX_MARKERS else \
        {"linestyle": "--", "linewidth": 1.5}
    for k, sel in enumerate(_curves(item)):
        first = k == 0
        top.plot(x[sel], a[sel], "-", color="tab:blue", linewidth=1, label="netdae" if first else None)
        top.plot(x[sel], b[sel], color="tab:orange", label="ngspice" if first else None, **style)
        keep = np.arange(x.size)[sel]
        keep = keep[keep >= start]
        bottom.plot(x[keep], (a - b)[keep], "-", color="tab:red", linewidth=1,
                    label="netdae - ngspice" if first else None)
    if item.tolerance is not None:
        band = item.tolerance.rel * sig.scale
        for level in (band, -band):
            bottom.axhline(level, color="grey", linestyle="--", linewidth=0.8)
    if start:
        for ax in (top, bottom):
            ax.axvspan(x[0], x[start], color="grey", alpha=0.3, label="initial jump (not judged)")
        if sig.jump:
            bottom.annotate(f"at t0: netdae - ngspice = {sig.jump['netdae'] - sig.jump['ngspice']:.4g} "
                            f"(inconsistent start, not judged); drawn from t = {x[start]:.3g} s",
                            xy=(0.01, 0.04), xycoords="axes fraction", fontsize="small")
    top.set_ylabel(name)
    bottom.set_ylabel("difference")
    if _yunit(name):
        engineering_axis(top.yaxis, _yunit(name))
        engineering_axis(bottom.yaxis, _yunit(name))


def _draw_ac(top, bottom, item: AnalysisComparison, name: str) -> None:
    f = item.curves["axis"]
    a, b = item.curves["values"][name]
    (db_b, db_a), limits = magnitude_db([b, a])
    top.semilogx(f, db_b, ".", color="tab:orange", markersize=3, label="ngspice")
    top.semilogx(f, db_a, "-", color="tab:blue", linewidth=1, label="netdae")
    if limits is not None:
        top.set_ylim(*limits)
    scale = np.max(np.abs(b)) if b.size else 0.0
    with np.errstate(divide="ignore", invalid="ignore"):
        rel = np.abs(a - b) / np.maximum(np.abs(b), scale * MAGNITUDE_FLOOR)
    rel[~np.isfinite(rel)] = np.nan
    bottom.loglog(f, np.maximum(rel, _RELATIVE_FLOOR), "-", color="tab:red", linewidth=1,
                  label="|netdae - ngspice| / |ngspice|")
    if item.tolerance is not None:
        bottom.axhline(item.tolerance.rel, color="grey", linestyle="--", linewidth=0.8)
    top.set_ylabel(f"|{name}| [dB]")
    bottom.set_ylabel("relative error")


def comparison_figure(comparison: Comparison):
    """The overlay/difference matplotlib Figure of a comparison (not saved, not shown).

    Raises
    ------
    NetdaeError
        When no analysis has a waveform to draw (an operating point only, or
        every analysis failed).
    """
    from matplotlib.figure import Figure

    chosen = _panels(comparison)
    if not chosen:
        raise NetdaeError(f"{comparison.source}: nothing to plot: no .tran, .ac, .dc or .noise analysis was "
                          "compared")
    fig = Figure(figsize=(9, 1.2 + 3.6 * len(chosen)), layout="constrained")
    axes = fig.subplots(2 * len(chosen), 1, gridspec_kw={"height_ratios": [2, 1] * len(chosen)}, squeeze=False)
    axes = axes[:, 0]
    for k, (item, name) in enumerate(chosen):
        top, bottom = axes[2 * k], axes[2 * k + 1]
        if item.analysis == "ac":
            _draw_ac(top, bottom, item, name)
        else:
            _draw_waveform(top, bottom, item, name)
        sig = next(s for s in item.signals if s.name == name)
        top.set_title(f".{item.analysis} {name}: max error {sig.max_rel:.3g} of its scale"
                      + (" (after the initial jump)" if item.window else ""), fontsize="medium")
        bottom.set_xlabel(_xlabel(item))
        if item.analysis == "noise":  # densities over decades of frequency
            for ax in (top, bottom):
                ax.set_xscale("log")
            if np.all(np.asarray(item.curves["values"][name][1]) > 0):
                top.set_yscale("log")
        unit = _X_UNITS.get(item.analysis) or unit_of(item.axis or "")
        for ax in (top, bottom):
            engineering_axis(ax.xaxis, unit)
            ax.grid(True, alpha=0.3)
            ax.legend(fontsize="small", loc="upper right", framealpha=0.8)
    title = textwrap.shorten(comparison.title.lstrip("* "), TITLE_WIDTH, placeholder=" ...")
    fig.suptitle(f"{title}\nnetdae vs {comparison.ngspice_version or 'ngspice'}"
                 + (" (tight tolerances)" if comparison.tight else ""), fontsize="large")
    return fig


def plot_comparison(comparison: Comparison, path: str | Path) -> Path:
    """Write the overlay/difference image of a comparison (PNG, or the path's format) and return its path.

    Raises
    ------
    NetdaeError
        As :func:`comparison_figure`, or for a suffix matplotlib cannot write.
    OutputFileError
        When the file cannot be written; nothing is left under its name.
    """
    return save_figure(comparison_figure(comparison), path, dpi=_DPI)
