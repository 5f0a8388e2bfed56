"""``.four`` results as data: the Fourier components of a transient signal, and ngspice's printed table.

Computed by :mod:`netdae.analyses.fourier`; printed by the command line as ngspice prints its
``.four`` output, and given in JSON by :meth:`Fourier.to_dict`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["Fourier", "format_fourier"]


@dataclass(frozen=True)
class Fourier:
    """The Fourier analysis of one signal over the last period of a transient (ngspice's ``.four``).

    Attributes
    ----------
    signal : str
    fundamental : float
        The fundamental frequency (Hz).
    frequency, magnitude, phase, norm_magnitude, norm_phase : ndarray, shape (nfreqs,)
        Harmonic ``k`` at ``k * fundamental``: its amplitude (the DC value for ``k = 0``), its
        phase in degrees against a sine starting at the period's beginning, both divided by
        (less) the fundamental's.
    thd : float
        Total harmonic distortion in percent: ``100 sqrt(sum_{k >= 2} norm_magnitude[k]^2)``.
    gridsize : int
        The samples of the period (on the transient's dense output).
    start, stop : float
        The period analysed (s).
    status : str
        ``"ok"`` or ``"failed"`` (then ``reason`` says why and the arrays are empty).
    reason : str
    """

    signal: str
    fundamental: float
    frequency: np.ndarray
    magnitude: np.ndarray
    phase: np.ndarray
    norm_magnitude: np.ndarray
    norm_phase: np.ndarray
    thd: float
    gridsize: int
    start: float
    stop: float
    status: str = "ok"
    reason: str = ""

    @property
    def ok(self) -> bool:
        return self.status == "ok"

    def to_dict(self) -> dict:
        """JSON-ready: plain floats and lists."""
        out = {"signal": self.signal, "fundamental": self.fundamental, "status": self.status}
        if not self.ok:
            out["reason"] = self.reason
            return out
        out.update(thd_percent=_finite(self.thd), gridsize=self.gridsize, start=self.start, stop=self.stop,
                   harmonics=[{"harmonic": k, "frequency": float(self.frequency[k]),
                               "magnitude": float(self.magnitude[k]), "phase_deg": float(self.phase[k]),
                               "norm_magnitude": _finite(self.norm_magnitude[k]),
                               "norm_phase_deg": _finite(self.norm_phase[k])}
                              for k in range(self.frequency.size)])
        return out


def _finite(x) -> float | None:
    """A float for JSON, None where it is not finite (no normalised values without a fundamental)."""
    x = float(x)
    return x if np.isfinite(x) else None


def _num(x: float) -> str:
    return f"{x:.6g}"


def format_fourier(f: Fourier) -> str:
    """The table ngspice prints for a ``.four`` signal (its columns and headings), or why it failed.

    Examples
    --------
    >>> f = Fourier("v(a)", 1e3, np.array([0.0, 1e3]), np.array([0.5, 1.0]), np.array([0.0, 90.0]),
    ...             np.array([0.0, 1.0]), np.array([0.0, 0.0]), 0.0, 200, 0.0, 1e-3)
    >>> print(format_fourier(f).splitlines()[1])
      No. Harmonics: 2, THD: 0 %, Gridsize: 200, Interpolation Degree: dense output
    """
    if not f.ok:
        return f"Fourier analysis for {f.signal}: failed: {f.reason}"
    rows = [f"Fourier analysis for {f.signal}:",
            f"  No. Harmonics: {f.frequency.size}, THD: {f.thd:g} %, Gridsize: {f.gridsize}, "
            "Interpolation Degree: dense output", "",
            f"{'Harmonic':8s} {'Frequency':12s} {'Magnitude':12s} {'Phase':12s} {'Norm. Mag':12s} Norm. Phase",
            f"{'--------':8s} {'---------':12s} {'---------':12s} {'-----':12s} {'---------':12s} -----------"]
    for k in range(f.frequency.size):
        rows.append(f" {k:<7d} {_num(f.frequency[k]):12s} {_num(f.magnitude[k]):12s} {_num(f.phase[k]):12s} "
                    f"{_num(f.norm_magnitude[k]):12s} {_num(f.norm_phase[k])}")
    return "\n".join(rows)
