"""PNG plots of results (matplotlib, imported lazily, non-interactive backend).

- transient: voltages and currents over time (two panels when both exist);
- AC: Bode plot, magnitude in dB and phase in degrees over log frequency;
- DC: transfer curves over the first swept source (one curve per value of
  the second sweep).
"""

from __future__ import annotations

import textwrap
from pathlib import Path

import numpy as np

from .results import Result

__all__ = ["plot_result", "MAX_CURVES"]

#: At most this many signals are drawn per panel (the first ones in order).
MAX_CURVES = 12
#: Titles are wrapped at this many characters.
TITLE_WIDTH = 80


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _pick(result: Result, signals) -> list[str]:
    names = [s.lower() for s in signals] if signals else result.names()
    return [n for n in names if n in result.signals]


def plot_result(result: Result, path: str | Path, *, title: str = "", signals=None) -> Path:
    """Write a PNG of ``result`` to ``path`` and return the path.

    Parameters
    ----------
    result : Result
        A ``tran``, ``ac`` or ``dc`` result.
    path : str or Path
    title : str
    signals : list of str, optional
        Which signals to draw (default: all, up to MAX_CURVES per panel).
    """
    plt = _pyplot()
    path = Path(path)
    names = _pick(result, signals)
    volts = [n for n in names if n.startswith("v(")][:MAX_CURVES]
    amps = [n for n in names if not n.startswith("v(")][:MAX_CURVES]
    if result.analysis == "ac":
        fig, (ax_m, ax_p) = plt.subplots(2, 1, sharex=True, figsize=(8, 6))
        f = result.axis
        for n in (volts + amps)[:MAX_CURVES]:
            h = result.signals[n]
            mag = 20 * np.log10(np.maximum(np.abs(h), 1e-300))
            ax_m.semilogx(f, mag, label=n)
            ax_p.semilogx(f, np.degrees(np.unwrap(np.angle(h))), label=n)
        ax_m.set_ylabel("magnitude [dB]")
        ax_p.set_ylabel("phase [deg]")
        ax_p.set_xlabel("frequency [Hz]")
        ax_m.legend(fontsize="small")
        panels = (ax_m, ax_p)
    else:
        groups = [g for g in (volts, amps) if g]
        fig, axes = plt.subplots(max(len(groups), 1), 1, sharex=True, figsize=(8, 3 + 2.5 * len(groups)))
        axes = np.atleast_1d(axes)
        x = result.axis
        xname = result.axis_name or ""
        second = list(result.axes)[1] if result.analysis == "dc" and len(result.axes) > 1 else None
        for ax, group in zip(axes, groups):
            for n in group:
                y = result.signals[n]
                if second is None:
                    ax.plot(x, y, label=n)
                else:
                    for val in np.unique(result.axes[second]):
                        sel = result.axes[second] == val
                        ax.plot(x[sel], y[sel], label=f"{n} ({second}={val:g})")
            ax.set_ylabel("voltage [V]" if group is volts else "current [A]")
            ax.legend(fontsize="small")
            ax.grid(True, alpha=0.3)
        axes[-1].set_xlabel("time [s]" if xname == "time" else xname)
        panels = tuple(axes)
    if title:
        panels[0].set_title(textwrap.fill(title, TITLE_WIDTH), fontsize="medium")
    fig.tight_layout()
    save_figure(fig, path, dpi=110)
    plt.close(fig)
    return path


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
        raise NetdaeError(f"cannot draw {path}: unknown image format '.{kind}' (use {', '.join('.' + k for k in sorted(supported))})")
    with atomic_output(path) as handle:
        fig.savefig(handle, format=kind, dpi=dpi)
    return path
