"""``.four``: the Fourier components of transient signals over their last period, as ngspice computes them.

ngspice (``fourier.c``) takes the last period ``[t_end - 1/f, t_end]`` of the transient,
interpolates the signal linearly from its output points onto ``fourgridsize`` (200) equally
spaced samples starting at the period's beginning, and sums ``nfreqs`` (10) harmonics, the
DC value first: harmonic ``k >= 1`` has the amplitude ``2/N |sum v_i e^{-2 pi j k i / N}|`` and
the phase ``atan2(cos part, sin part)`` in degrees (0 for a sine starting at the period's
beginning); the normalised values divide by (subtract) the fundamental's, and the THD is
``100 sqrt(sum_{k >= 2} nmag_k^2)`` percent. netdae samples its dense output instead of
interpolating output points linearly (the interpolation error ngspice adds is of the order of its
steps squared); the sums are the same.
"""

from __future__ import annotations

import math

import numpy as np

from ..fourier import Fourier
from ..results import Result

__all__ = ["NFREQS", "GRIDSIZE", "components", "evaluate_fouriers", "fourier_sizes"]

#: Harmonics computed (the DC value and nine), ngspice's ``nfreqs``.
NFREQS = 10
#: Samples of the period, ngspice's ``fourgridsize``.
GRIDSIZE = 200
#: A fundamental at most this fraction of the signal's largest value is rounding: no normalised values.
FUNDAMENTAL_FLOOR = 1e-12


def fourier_sizes(extra: dict) -> tuple[int, int]:
    """``nfreqs`` and ``fourgridsize`` from a circuit's ``.options``, as ngspice 39's ``fourier.c`` reads them.

    ngspice's ``.options`` set its variables too, and ``.four`` reads these two with ``cp_getvar``: a
    number is truncated to an integer, and a value below 1 (or none, or one that is not a number) gives
    the default, ten harmonics and 200 samples.

    >>> fourier_sizes({"nfreqs": 15.0, "fourgridsize": 400.0}), fourier_sizes({"nfreqs": 0.0})
    ((15, 400), (10, 200))
    """
    def read(name: str, default: int) -> int:
        value = extra.get(name)
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            return default
        return int(value) if int(value) >= 1 else default

    return read("nfreqs", NFREQS), read("fourgridsize", GRIDSIZE)


def components(values, nfreqs: int = NFREQS):
    """ngspice's Fourier sums on ``N`` equally spaced samples of one period.

    Parameters
    ----------
    values : array_like, shape (N,)
        The samples at ``t_i = t_start + i T / N``, ``i = 0 .. N - 1``.
    nfreqs : int
        Harmonics, the DC value (``k = 0``) included.

    Returns
    -------
    magnitude, phase, norm_magnitude, norm_phase : ndarray, shape (nfreqs,)
        Phases in degrees; the normalised values are NaN when the signal has no fundamental (its
        magnitude at most FUNDAMENTAL_FLOOR of the signal's largest value: rounding).
    thd : float
        In percent (NaN without a fundamental).

    Examples
    --------
    A sine of amplitude 2 on an offset of 0.5, and its third harmonic of 0.2 as a cosine:

    >>> t = np.arange(200) / 200
    >>> mag, ph, nmag, nph, thd = components(0.5 + 2 * np.sin(2 * np.pi * t) + 0.2 * np.cos(6 * np.pi * t), 4)
    >>> np.round(mag, 12).tolist(), (np.round(ph[[1, 3]], 9) + 0.0).tolist(), round(thd, 9)
    ([0.5, 2.0, 0.0, 0.2], [0.0, 90.0], 10.0)

    (The phase of a harmonic of magnitude 0 is rounding noise, as in ngspice's table.)
    """
    v = np.asarray(values, dtype=float)
    n = v.size
    angle = 2.0 * np.pi * np.outer(np.arange(nfreqs), np.arange(n)) / n
    s, c = np.sin(angle) @ v, np.cos(angle) @ v
    magnitude = np.zeros(nfreqs)
    phase = np.zeros(nfreqs)
    magnitude[0] = c[0] / n
    a, b = 2.0 * s[1:] / n, 2.0 * c[1:] / n
    magnitude[1:] = np.hypot(a, b)
    phase[1:] = np.degrees(np.arctan2(b, a))
    norm_magnitude = np.zeros(nfreqs)
    norm_phase = np.zeros(nfreqs)
    if nfreqs > 1 and magnitude[1] > FUNDAMENTAL_FLOOR * float(np.max(np.abs(v), initial=0.0)):
        norm_magnitude[1:] = magnitude[1:] / magnitude[1]
        norm_phase[1:] = phase[1:] - phase[1]
        thd = 100.0 * math.sqrt(float(np.sum(norm_magnitude[2:] ** 2)))
    else:
        norm_magnitude[1:] = norm_phase[1:] = np.nan
        thd = math.nan
    return magnitude, phase, norm_magnitude, norm_phase, thd


def _failed(signal: str, f: float, reason: str) -> Fourier:
    empty = np.zeros(0)
    return Fourier(signal, f, empty, empty, empty, empty, empty, math.nan, 0, math.nan, math.nan, "failed", reason)


def _samples(result: Result, signals, grid: np.ndarray) -> dict:
    """The signals on ``grid`` (those the result holds): the dense output's where it has them, else linear
    between the points."""
    dense = {}
    if result.dense is not None:
        try:
            dense = result.dense(grid)
        except (KeyError, ValueError):
            dense = {}
    t = np.asarray(result.axes["time"], dtype=float)
    out = {}
    for signal in signals:
        if signal in dense:
            out[signal] = np.asarray(dense[signal], dtype=float)
        elif signal in result.signals:
            out[signal] = np.interp(grid, t, np.asarray(result.signals[signal], dtype=float))
    return out


def evaluate_fouriers(specs, result: Result, *, nfreqs: int = NFREQS, gridsize: int = GRIDSIZE) -> list[Fourier]:
    """The ``.four`` cards ``specs`` (:class:`netdae.circuit.FourierSpec`) on a transient ``result``.

    A signal the result does not hold, a period longer than the computed interval or a failed run
    give a failed :class:`~netdae.fourier.Fourier` with the reason (ngspice prints an error and goes
    on, and analyses nothing after a failed transient), never an exception.

    Cost: the dense output at ``gridsize`` times and ``nfreqs x gridsize`` products per signal.
    """
    t = np.asarray(result.axes.get("time", np.zeros(0)), dtype=float)
    out = []
    for spec in specs:
        f = spec.frequency
        reason, samples = None, {}
        if not result.ok:  # its last period is not the circuit's (ngspice analyses nothing then)
            reason = f"the transient failed: {result.message}"
        elif t.size < 2:
            reason = "the transient computed no interval"
        else:
            stop, first = float(t[-1]), float(t[0])
            start = stop - 1.0 / f
            if start < first - 1e-9 * (stop - first):
                reason = f"its period {1.0 / f:g} s is longer than the transient's interval [{first:g}, {stop:g}] s"
            elif not (stop - start) / gridsize > np.spacing(stop):
                reason = (f"its period {1.0 / f:g} s is too short to sample at t = {stop:g} s: {gridsize} points over "
                          "it are not distinct times in floating point")
            else:
                start = max(start, first)
                # one grid and one evaluation of the dense output for all the card's signals
                samples = _samples(result, spec.signals, start + (stop - start) * np.arange(gridsize) / gridsize)
        for signal in spec.signals:
            values = samples.get(signal)
            if reason is not None:
                out.append(_failed(signal, f, reason))
            elif values is None:
                out.append(_failed(signal, f, "the transient result does not hold this signal"))
            elif not np.all(np.isfinite(values)):
                out.append(_failed(signal, f, "the signal is not finite over the period"))
            else:
                mag, ph, nmag, nph, thd = components(values, nfreqs)
                out.append(Fourier(signal, f, f * np.arange(nfreqs, dtype=float), mag, ph, nmag, nph, thd, gridsize,
                                   start, stop))
    return out
