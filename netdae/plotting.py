"""Figures of results: :func:`plot` returns a matplotlib Figure, :func:`plot_result` saves one.

- transient: voltages, currents and other signals over time, one panel each;
- AC: Bode plot, magnitude in dB and phase in degrees over log frequency;
- DC: transfer curves over the first swept source (one curve per value of
  the second sweep).

Readable by default:

- axes carry SI prefixes (``2 ms``, ``500 mV``, ``10 kHz``: matplotlib's
  ``EngFormatter``);
- supply rails (nodes held by constant voltage sources, known when the
  circuit is given) and internal device nodes (``v(d1#internal)``, names with
  ``#`` or ``:``) are left out unless asked for, and the figure says what it
  left out;
- magnitudes below :data:`MAGNITUDE_FLOOR` of the largest one drawn (and exact
  zeros) are rounding noise: they are not drawn, so the dB axis spans the
  data's meaningful range instead of falling to -6000 dB;
- more than ten curves in a panel get distinct colours from a continuous
  colour map and alternating line styles;
- the title sits above all panels (constrained layout), legends beside them.

The figure is built without pyplot (no global state, no backend switch), so a
notebook shows the returned Figure as it is; matplotlib is imported lazily.
"""

from __future__ import annotations

import textwrap
from pathlib import Path

import numpy as np

from .kinds import Kind
from .results import Result
from .signals import parse_signal

__all__ = ["plot", "plot_result", "save_figure", "hidden_signals", "magnitude_db", "engineering_axis", "unit_of",
           "MAX_CURVES", "MAGNITUDE_FLOOR"]

#: At most this many curves are drawn per panel; the figure names how many more were left out.
MAX_CURVES = 20
#: Titles are wrapped at this many characters.
TITLE_WIDTH = 80
#: Magnitudes below this fraction of the largest magnitude drawn (-240 dB) are
#: at the rounding level of a double computation: not drawn.
MAGNITUDE_FLOOR = 1e-12
#: Space in dB left above and below the magnitudes drawn.
DB_MARGIN = 3.0
#: Curves of a panel up to this many use matplotlib's ten distinct colours.
FEW_CURVES = 10
_LINESTYLES = ("-", "--", "-.", ":")
_DPI = 110
#: Units of the axes, by signal or sweep prefix.
_AXIS_UNITS = {"time": "s", "frequency": "Hz", "temp": "°C"}
_SWEEP_UNITS = {"v": "V", "i": "A", "r": "Ω"}


def _is_internal(name: str) -> bool:
    """A signal of an internal device node (``v(d1#internal)``, ``v(q1:collector)``)."""
    try:
        sig = parse_signal(name)
    except ValueError:
        return False
    return sig.kind == "v" and name.startswith("v(") and any("#" in n or ":" in n for n in sig.nodes)


def _rails(circuit, result: Result) -> set[str]:
    """Nodes held at a constant potential by voltage sources, reached from ground."""
    swept = set(result.axes)
    edges = []
    for el in getattr(circuit, "elements", ()):
        if el.kind != Kind.VSOURCE or el.source is None or el.name in swept:
            continue
        constant = el.source.ac_mag == 0.0 if result.analysis == "ac" else el.source.tran is None
        if constant:
            edges.append(tuple(el.nodes[:2]))
    held, grown = {"0"}, True
    while grown:
        grown = False
        for a, b in edges:
            if (a in held) != (b in held):
                held.update((a, b))
                grown = True
    return held - {"0"}


def hidden_signals(result: Result, circuit=None) -> dict[str, list[str]]:
    """Signals :func:`plot` leaves out by default: ``{"rails": [...], "internal": [...]}``.

    Parameters
    ----------
    result : Result
    circuit : Circuit, optional
        Needed to know the supply rails (without it none are hidden).

    Examples
    --------
    >>> import numpy as np
    >>> r = Result("tran", axes={"time": np.array([0.0, 1.0])},
    ...            signals={n: np.zeros(2) for n in ("v(out)", "v(d1#internal)", "i(v1)")})
    >>> hidden_signals(r)
    {'rails': [], 'internal': ['v(d1#internal)']}
    """
    rails = {f"v({node})" for node in _rails(circuit, result)} if circuit is not None else set()
    return {
        "rails": [n for n in result.signals if n in rails],
        "internal": [n for n in result.signals if _is_internal(n)],
    }


def _choose(result: Result, signals, circuit, rails: bool, internal: bool) -> tuple[list[str], list[str]]:
    """The signals to draw and a description of those left out."""
    if signals:
        return list(result.signals), []  # result is already the subset asked for
    hidden = hidden_signals(result, circuit)
    left_out = []
    drop = set()
    if not rails and hidden["rails"]:
        drop.update(hidden["rails"])
        left_out.append(f"{len(hidden['rails'])} supply rail{'s' * (len(hidden['rails']) > 1)} "
                        f"({', '.join(hidden['rails'][:4])}{', ...' if len(hidden['rails']) > 4 else ''})")
    if not internal and hidden["internal"]:
        drop.update(hidden["internal"])
        left_out.append(f"{len(hidden['internal'])} internal device node{'s' * (len(hidden['internal']) > 1)}")
    return [n for n in result.signals if n not in drop], left_out


def _styles(count: int) -> list[dict]:
    """Distinct (colour, line style) for ``count`` curves of one panel."""
    from matplotlib import colormaps

    if count <= FEW_CURVES:
        colours = [colormaps["tab10"](k) for k in range(count)]
        return [{"color": c, "linestyle": "-"} for c in colours]
    colours = colormaps["turbo"](np.linspace(0.05, 0.95, count))
    return [{"color": tuple(colours[k]), "linestyle": _LINESTYLES[k % len(_LINESTYLES)]} for k in range(count)]


def engineering_axis(axis, unit: str) -> None:
    """Label the ticks of a matplotlib axis with SI prefixes and ``unit`` (``2 ms``)."""
    from matplotlib.ticker import EngFormatter, NullFormatter

    axis.set_major_formatter(EngFormatter(unit=unit))
    axis.set_minor_formatter(NullFormatter())


def unit_of(axis_name: str) -> str:
    """The unit of a sweep axis: ``time`` s, ``frequency`` Hz, ``temp`` °C, ``v1`` V, ``i1`` A, ``r1`` Ω."""
    if axis_name in _AXIS_UNITS:
        return _AXIS_UNITS[axis_name]
    return _SWEEP_UNITS.get(axis_name[:1], "")


def magnitude_db(values: list[np.ndarray]) -> tuple[list[np.ndarray], tuple[float, float] | None]:
    """Magnitudes in dB with the rounding-level ones masked (NaN), and y-limits."""
    mags = [np.abs(v) for v in values]
    peak = max((float(np.max(m)) for m in mags if m.size), default=0.0)
    if peak == 0.0 or not np.isfinite(peak):
        return [np.full(m.shape, np.nan) for m in mags], None
    floor = peak * MAGNITUDE_FLOOR
    out = []
    for m in mags:
        with np.errstate(divide="ignore"):
            db = 20.0 * np.log10(m)
        db[~(m >= floor)] = np.nan
        out.append(db)
    drawn = np.concatenate([d[np.isfinite(d)] for d in out])
    return out, (float(drawn.min()) - DB_MARGIN, float(drawn.max()) + DB_MARGIN)


def _draw_curves(ax, curves: list[tuple[np.ndarray, np.ndarray, str]], *, semilogx: bool = False) -> int:
    """Draw (x, y, label) curves with distinct styles; returns how many were left out."""
    shown = curves[:MAX_CURVES]
    draw = ax.semilogx if semilogx else ax.plot
    for (x, y, label), style in zip(shown, _styles(len(shown))):
        draw(x, y, label=label, linewidth=1.2, **style)
    return len(curves) - len(shown)


def _legend(ax) -> None:
    if ax.get_legend_handles_labels()[0]:
        ax.legend(fontsize="small", loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0)


def _plot_ac(fig, result: Result, names: list[str]) -> int:
    ax_m, ax_p = fig.subplots(2, 1, sharex=True)
    f = result.axis
    dbs, limits = magnitude_db([result.signals[n] for n in names])
    mags, phases = [], []
    for n, db in zip(names, dbs):
        h = result.signals[n]
        phase = np.full(h.shape, np.nan)
        valid = np.isfinite(db)
        if valid.any():
            phase[valid] = np.degrees(np.unwrap(np.angle(h[valid])))
        label = n if valid.any() else f"{n} (zero)"
        mags.append((f, db, label))
        phases.append((f, phase, label))
    left = _draw_curves(ax_m, mags, semilogx=True)
    _draw_curves(ax_p, phases, semilogx=True)
    if limits is not None:
        ax_m.set_ylim(*limits)
    ax_m.set_ylabel("magnitude [dB]")
    ax_p.set_ylabel("phase [deg]")
    ax_p.set_xlabel("frequency")
    engineering_axis(ax_p.xaxis, "Hz")
    for ax in (ax_m, ax_p):
        ax.grid(True, which="both", alpha=0.3)
    _legend(ax_m)
    return left


def _plot_sweep(fig, result: Result, names: list[str]) -> int:
    groups = [
        ("voltage", "V", [n for n in names if n.startswith("v(")]),
        ("current", "A", [n for n in names if n.startswith("i(")]),
        ("other", "", [n for n in names if not n.startswith(("v(", "i("))]),
    ]
    groups = [g for g in groups if g[2]]
    axes = np.atleast_1d(fig.subplots(max(len(groups), 1), 1, sharex=True))
    x = result.axis
    xname = result.axis_name or ""
    second = list(result.axes)[1] if result.analysis == "dc" and len(result.axes) > 1 else None
    left = 0
    for ax, (label, unit, group) in zip(axes, groups):
        curves = []
        for n in group:
            y = np.asarray(result.signals[n])
            if second is None:
                curves.append((x, y, n))
            else:
                outer = result.axes[second]
                for value in np.unique(outer):
                    sel = outer == value
                    curves.append((x[sel], y[sel], f"{n} ({second}={value:g})"))
        left += _draw_curves(ax, curves)
        ax.set_ylabel(label)
        if unit:
            engineering_axis(ax.yaxis, unit)
        ax.grid(True, alpha=0.3)
        _legend(ax)
    axes[-1].set_xlabel(xname)
    engineering_axis(axes[-1].xaxis, unit_of(xname))
    return left


def _plot_noise(fig, result: Result, names: list[str]) -> int:
    """Noise densities on log-log axes: the output's (and each device's), then the input-referred one."""
    unit = "A" if (result.noise is not None and result.noise.input_unit == "A") else "V"
    groups = [("output noise", "V/\u221aHz", [n for n in names if n.startswith("onoise")]),
              ("input noise", f"{unit}/\u221aHz", [n for n in names if n.startswith("inoise")])]
    groups = [g for g in groups if g[2]]
    axes = np.atleast_1d(fig.subplots(max(len(groups), 1), 1, sharex=True))
    x = result.axis
    left = 0
    for ax, (label, unit_text, group) in zip(axes, groups):
        curves = [(x, np.asarray(result.signals[n], dtype=float), n) for n in group]
        shown = curves[:MAX_CURVES]
        for (cx, cy, name), style in zip(shown, _styles(len(shown))):
            ax.loglog(cx, np.where(cy > 0, cy, np.nan), label=name, linewidth=1.2, **style)
        left += len(curves) - len(shown)
        ax.set_ylabel(f"{label} [{unit_text}]")
        ax.grid(True, which="both", alpha=0.3)
        _legend(ax)
    axes[-1].set_xlabel("frequency [Hz]")
    return left


def plot(result: Result, *, title: str = "", signals=None, circuit=None, rails: bool = False,
         internal: bool = False):
    """A matplotlib Figure of ``result`` (not saved, not shown: a notebook displays it).

    Parameters
    ----------
    result : Result
        A ``tran``, ``ac`` or ``dc`` result.
    title : str
        Drawn above all panels.
    signals : list of str, optional
        Exactly which signals to draw (``v(out)``, ``v(a,b)``, ``i(v1)``);
        default: all but supply rails and internal device nodes.
    circuit : Circuit, optional
        The circuit of the result, to recognise its supply rails.
    rails, internal : bool
        Draw supply rails / internal device nodes too.

    Returns
    -------
    matplotlib.figure.Figure

    Raises
    ------
    NetdaeError
        For an ``op`` result or a result without signals to draw.
    KeyError
        For a name in ``signals`` the result does not have.
    TypeError
        For a ``result`` that is not a :class:`~netdae.results.Result`, or ``signals`` that are not names.

    Examples
    --------
    >>> import numpy as np
    >>> t = np.linspace(0.0, 2e-3, 50)
    >>> fig = plot(Result("tran", axes={"time": t}, signals={"v(out)": 1 - np.exp(-t / 1e-3)}))
    >>> ax = fig.axes[0]
    >>> ax.get_ylabel(), ax.xaxis.get_major_formatter()(1e-3), ax.yaxis.get_major_formatter()(0.5)
    ('voltage', '1 ms', '500 mV')
    """
    from matplotlib.figure import Figure

    from .analyses.runner import string_entries
    from .errors import NetdaeError

    if not isinstance(result, Result):
        raise TypeError(f"result must be a Result (of netdae.run or netdae.simulate), not {type(result).__name__}")
    signals = string_entries(signals, "signals")
    if result.analysis not in ("tran", "ac", "dc", "noise") or result.axis is None:
        raise NetdaeError(f"cannot plot a '{result.analysis}' result: it has no axis (tran, ac, dc and noise have "
                          "one)")
    if signals:
        result = result.subset(signals)
    names, left_out = _choose(result, signals, circuit, rails, internal)
    if not names:
        raise NetdaeError(f"nothing to plot: the {result.analysis} result has no signal to draw"
                          + (f" (left out: {'; '.join(left_out)})" if left_out else ""))
    if result.analysis == "noise":
        panels = len({n[:6] for n in names})
    else:
        panels = 2 if result.analysis == "ac" else len({n[:2] if n[:2] in ("v(", "i(") else "" for n in names})
    fig = Figure(figsize=(9, 2.0 + 2.6 * panels), layout="constrained")
    if result.analysis == "noise":
        more = _plot_noise(fig, result, names)
    else:
        more = _plot_ac(fig, result, names) if result.analysis == "ac" else _plot_sweep(fig, result, names)
    if more:
        left_out.append(f"{more} more curve{'s' * (more > 1)} (at most {MAX_CURVES} per panel)")
    heading = [textwrap.fill(title, TITLE_WIDTH)] if title else []
    if left_out:
        heading.append(textwrap.fill("not drawn: " + "; ".join(left_out) + " (choose with signals=)", TITLE_WIDTH + 20))
    if heading:
        fig.suptitle("\n".join(heading), fontsize="medium")
    return fig


def plot_sweep(result, *, title: str = ""):
    """A matplotlib Figure of a sweep: measure histograms (Monte Carlo) or a family of curves (steps).

    A Monte Carlo sweep draws one histogram per measurement; a sweep of
    steps draws each saved waveform of every row (one panel per signal,
    labelled by the row's values), or, without waveforms, each measurement
    against the first axis.

    Parameters
    ----------
    result : SweepResult
    title : str

    Returns
    -------
    matplotlib.figure.Figure

    Raises
    ------
    NetdaeError
        When there is nothing to draw (no measure value and no waveform).
    """
    from matplotlib.figure import Figure

    from .errors import NetdaeError

    measures = {k: v[np.isfinite(v)] for k, v in result.measures.items() if np.isfinite(v).any()}
    if result.plan.samples is not None and measures:
        fig = Figure(figsize=(9, 2.6 * len(measures) + 0.6), layout="constrained")
        # one histogram per point of the steps (all rows with the same axis values), overlaid
        points: dict[tuple, list[int]] = {}
        for row in result.plan.rows:
            points.setdefault(row.point, []).append(row.index)
        styles = _styles(min(len(points), MAX_CURVES))
        for k, name in enumerate(measures):
            ax = fig.add_subplot(len(measures), 1, k + 1)
            column = result.measures[name]
            ok = column[np.isfinite(column)]
            bins = np.histogram_bin_edges(ok, bins=max(10, min(60, int(np.sqrt(ok.size / len(points))) * 2)))
            for (point, rows), style in zip(list(points.items())[:MAX_CURVES], styles):
                values = column[rows]
                values = values[np.isfinite(values)]
                label = ", ".join(f"{a.name}={v:.4g}" for a, v in zip(result.plan.axes, point)) or None
                ax.hist(values, bins=bins, color=style["color"], alpha=0.8 if len(points) == 1 else 0.5,
                        label=label)
            mean, std = float(ok.mean()), float(ok.std(ddof=1)) if ok.size > 1 else 0.0
            over = " over all points" if len(points) > 1 else ""
            ax.set_title(f"{name}: mean {mean:.5g}, std {std:.3g}{over} ({ok.size} samples)", fontsize="medium")
            ax.set_ylabel("count")
            _legend(ax)
    elif result.waves:
        fig = Figure(figsize=(9, 2.6 * len(result.waves) + 0.6), layout="constrained")
        labels = [", ".join(f"{a.name}={row.point[i]:.4g}" for i, a in enumerate(result.plan.axes))
                  or f"row {row.index}" for row in result.plan.rows]
        for k, ((analysis, signal), values) in enumerate(result.waves.items()):
            ax = fig.add_subplot(len(result.waves), 1, k + 1)
            axis, grid = result.axes[analysis]
            ys = np.abs(values) if np.iscomplexobj(values) else values
            _draw_curves(ax, [(grid, ys[r], labels[r]) for r in range(ys.shape[0])], semilogx=analysis == "ac")
            ax.set_ylabel(f"|{signal}|" if np.iscomplexobj(values) else signal)
            engineering_axis(ax.xaxis, unit_of(axis))
            _legend(ax)
    elif measures and result.plan.axes:
        axis = result.plan.axes[0]
        x = result.params[axis.name]
        fig = Figure(figsize=(9, 2.6 * len(measures) + 0.6), layout="constrained")
        for k, name in enumerate(measures):
            ax = fig.add_subplot(len(measures), 1, k + 1)
            ax.plot(x, result.measures[name], "o-")
            ax.set_xlabel(axis.name)
            ax.set_ylabel(name)
    else:
        raise NetdaeError("nothing to plot: the sweep has no measured value and no saved waveform")
    if title:
        fig.suptitle(textwrap.fill(title, TITLE_WIDTH), fontsize="medium")
    return fig


def plot_result(result: Result, path: str | Path, *, title: str = "", signals=None, circuit=None,
                rails: bool = False, internal: bool = False) -> Path:
    """Write an image of ``result`` to ``path`` (PNG, or the format of its suffix) and return the path.

    Parameters are those of :func:`plot`.

    Raises
    ------
    NetdaeError
        As :func:`plot`, or for a suffix matplotlib cannot write.
    OutputFileError
        When the file cannot be written; nothing is left under its name.
    """
    fig = plot(result, title=title, signals=signals, circuit=circuit, rails=rails, internal=internal)
    return save_figure(fig, path, dpi=_DPI)


def save_figure(fig, path: str | Path, *, dpi: int) -> Path:
    """Save a matplotlib figure whole or not at all, in the format of the path's suffix.

    Raises
    ------
    NetdaeError
        For a suffix matplotlib cannot write.
    OutputFileError
        When the file cannot be written; nothing is left under its name.
    """
    from .errors import NetdaeError
    from .io.files import atomic_output

    path = Path(path)
    kind = path.suffix[1:].lower() or "png"
    supported = fig.canvas.get_supported_filetypes()
    if kind not in supported:
        raise NetdaeError(f"cannot draw {path}: unknown image format '.{kind}' "
                          f"(use {', '.join('.' + k for k in sorted(supported))})")
    with atomic_output(path) as handle:
        fig.savefig(handle, format=kind, dpi=dpi)
    return path
