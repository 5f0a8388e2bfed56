"""How the integrator names a failure: the worst unknown, hints, the failure record and message."""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from ...circuit import TOLERANCE_MIN
from ..newton import INFO_EVALUATION, INFO_SINGULAR

__all__ = ["Failure", "IntegrationFailure", "worst_unknown", "nonfinite_unknown", "newton_hint", "error_hint",
           "failure_record", "runaway", "runaway_unknown", "with_runaway", "RUNAWAY_FACTOR"]

#: An unknown this many times the largest start value of its kind (volts, amperes; at least 1 V or 1 A)
#: has run away: a failure there is named after the growth, not after the Newton iterates it spoiled.
RUNAWAY_FACTOR = 1e6
_UNITS = {0: "V", 1: "A"}


class Failure(Exception):
    """A numerical failure found by a part of the integrator, for the driver to record.

    ``what``, ``worst`` and ``hint`` are those of the :class:`IntegrationFailure` the
    driver makes of it, with the time and step size it knows.
    """

    def __init__(self, what: str, worst, hint: str) -> None:
        super().__init__(what)
        self.what, self.worst, self.hint = what, worst, hint


def worst_unknown(names, v: np.ndarray, w: np.ndarray, w_fallback: np.ndarray) -> str:
    """Name of the unknown with the largest ``|v w|`` (``w_fallback`` when ``v w`` is zero everywhere).

    Non-finite entries count as infinite.
    """
    s = np.abs(v * w)
    if not np.any(s > 0):
        s = np.abs(v * w_fallback)
    return names[int(np.argmax(np.where(np.isfinite(s), s, np.inf)))]


def nonfinite_unknown(names, ev) -> str | None:
    """Name of the first unknown whose row of an ``Evaluation`` is not finite (None: all finite)."""
    bad = ~np.isfinite(np.asarray(ev.phi, dtype=float))
    if ev.q is not None:
        bad |= ~np.isfinite(np.asarray(ev.q, dtype=float))
    return names[int(np.argmax(bad))] if np.any(bad) else None


def newton_hint(reason) -> str:
    """The hint for a corrector failure of the given ``newton`` info code."""
    if reason == INFO_EVALUATION:
        return ("the system evaluation is not finite (ok=False) at every step size tried: "
                "the model is undefined beyond this time")
    if reason == INFO_SINGULAR:
        return ("the Newton matrix is singular: the DAE is singular or of index > 2 "
                "(a floating node, a loop of voltage sources, a cutset of current sources?)")
    return ("Newton does not converge even on small steps: a discontinuity in the model, "
            "an inconsistent initial value, or too few newton_maxiter")


def error_hint(worst_atol: float | None = None) -> str:
    """The hint for repeated error-test failures (``worst_atol``: the failing unknown's absolute tolerance;
    one below :data:`netdae.circuit.TOLERANCE_MIN`, given to the integrator directly, is named).

    >>> error_hint(1e-30).startswith("the absolute tolerance of the worst unknown, 1e-30")
    True
    """
    hint = ("the solution is not smooth here: an input discontinuity without a breakpoint, "
            "an inconsistent initial value, or an index-2 unknown not marked in `index`")
    if worst_atol is not None and worst_atol < TOLERANCE_MIN:
        return (f"the absolute tolerance of the worst unknown, {worst_atol:.3g}, is below what its values can be "
                "computed to where they are near zero: raise .options abstol (currents) or vntol (voltages); "
                "ngspice's defaults are 1e-12 A and 1e-6 V; or " + hint)
    return hint


def runaway(names, kinds, x_start: np.ndarray, x: np.ndarray, max_order: int = 0) -> str | None:
    """The sentence that names a solution grown without bound, or None.

    A circuit whose DAE has a mode growing as ``exp(lambda t)`` with
    ``lambda > 0`` (a negative capacitance or resistance, positive feedback
    through a controlled source) reaches values no part of the circuit had at
    the start; the integrator, following it, then fails where the rounding of
    those values exceeds the tolerances of the unknowns that are their small
    differences (a node current balancing terms of 1e16 A is known to about
    1 A), and the unknown its Newton test blames is a bystander. This names
    the unknown that grew most, against the largest start value of its kind.

    Parameters
    ----------
    names : sequence of str
        The unknowns' names.
    kinds : ndarray of int
        ``KIND_VOLTAGE`` (0), ``KIND_CURRENT`` (1) or other, per unknown.
    x_start, x : ndarray, shape (n,)
        The solution at the start and at the last accepted point.
    max_order : int
        The highest BDF order the run used: from 3 on, the sentence also names the
        integrator's own growth of a lightly damped resonance (those orders are not
        A-stable: a 60 Hz rectifier's leakage-inductance ringing after a diode's
        reverse recovery, followed for thousands of periods at orders 3-5, grew from
        20 mA to 1e12 A; at orders 1-2 it decays as the circuit's does).

    Returns
    -------
    str or None
        None when every volt and ampere unknown stays within
        :data:`RUNAWAY_FACTOR` times the largest start value of its kind
        (at least 1 V or 1 A).

    Examples
    --------
    >>> runaway(["v(a)", "i(v1)"], np.array([0, 1]), np.array([1.0, 1e-3]), np.array([2e9, 1e-3]))[:37]
    'the solution ran away: v(a) = 2e+09 V'
    >>> runaway(["v(a)"], np.array([0]), np.array([1.0]), np.array([5.0])) is None
    True
    """
    best = runaway_unknown(kinds, x_start, x)
    if best is None:
        return None
    i, kind, scale = best
    x_start, x = np.abs(np.asarray(x_start, dtype=float)), np.abs(np.asarray(x, dtype=float))
    u = _UNITS[kind]
    return (f"the solution ran away: {names[i]} = {x[i]:.3g} {u} ({x_start[i]:.3g} {u} at the start, where no "
            f"{'voltage' if kind == 0 else 'current'} exceeded {scale:.3g} {u}): a mode of the circuit grows without "
            "bound (a pole in the right half-plane: a negative capacitance or resistance, positive feedback through "
            "a controlled source), so the DAE has no bounded solution here, and Newton fails where the rounding of "
            "such values exceeds the tolerances; SPICE steps longer than 2/lambda damp such a mode (implicit Euler "
            "multiplies it by 1/(1 - h lambda)) and show a bounded waveform the DAE does not have"
            + ("" if max_order < 3 else
               f"; or the steps followed a lightly damped resonance (an LC ringing) for many periods at BDF order "
               f"{max_order}: orders 3-5 are not A-stable, their error per step can outweigh a high-Q mode's "
               "damping and it grows in the integration while it decays in the circuit (.options maxord=2 keeps "
               "the A-stable orders 1-2; they also damp a true right-half-plane mode at long steps, so a run "
               "that then finishes shows this cause only where the circuit has no such pole: check with .pz)"))


def runaway_unknown(kinds, x_start: np.ndarray, x: np.ndarray) -> tuple[int, int, float] | None:
    """The unknown that grew most against the largest start value of its kind (:func:`runaway`).

    Returns
    -------
    (index, kind, scale) or None
        ``scale``: the largest start value of the kind, at least 1 (V or A); None when no volt or
        ampere unknown exceeds :data:`RUNAWAY_FACTOR` times its kind's scale.

    Examples
    --------
    >>> runaway_unknown(np.array([0, 1]), np.array([1.0, 1e-3]), np.array([2.0, 4e19]))
    (1, 1, 1.0)
    """
    x_start = np.abs(np.asarray(x_start, dtype=float))
    x = np.abs(np.asarray(x, dtype=float))
    kinds = np.asarray(kinds)
    best, ratio_best = None, RUNAWAY_FACTOR
    for kind in _UNITS:
        sel = np.flatnonzero(kinds == kind)
        if not sel.size:
            continue
        scale = max(1.0, float(np.max(x_start[sel])))
        i = sel[int(np.argmax(np.where(np.isfinite(x[sel]), x[sel], np.inf)))]
        ratio = x[i] / scale
        if ratio > ratio_best:
            best, ratio_best = (int(i), int(kind), scale), ratio
    return best


@dataclass(frozen=True, slots=True)
class IntegrationFailure:
    """Where and why an integration stopped (``IntegrationResult.failure``, ``TransientInfo.failure``).

    Attributes
    ----------
    t : float
        Time reached.
    h : float
        Step size of the failed attempt.
    what : str
        What failed.
    worst : str or None
        The unknown to blame.
    hint : str
        What the user can do.
    runaway_order : int
        When the solution ran away (:func:`runaway`), the highest BDF order the run used;
        0 otherwise.
    runaway : str
        When the solution ran away, the unknown that grew most (``"i(v1)"``); ``""`` otherwise.
    runaway_value : float
        Its value at the last accepted point (0 when it did not run away).
    cause : str
        When the solution ran away, the sentence that says so, the start of ``hint``.
    """

    t: float
    h: float
    what: str
    worst: str | None
    hint: str
    runaway_order: int = 0
    runaway: str = ""
    runaway_value: float = 0.0
    cause: str = ""

    @property
    def message(self) -> str:
        """``BDF failed: <what> at t=..., h=..., worst unknown ... (hint: ...)``."""
        text = f"BDF failed: {self.what} at t={self.t:.9g}, h={self.h:.3g}"
        if self.worst:
            text += f", worst unknown {self.worst}"
        return text + f" (hint: {self.hint})"

    def error(self):
        """The :class:`~netdae.errors.ConvergenceError` that reports it."""
        from ...errors import ConvergenceError

        return ConvergenceError(self.what, t=self.t, h=self.h, worst=self.worst, hint=self.hint)

    def as_dict(self) -> dict:
        """The fields as a plain dict (for JSON)."""
        return asdict(self)


def failure_record(t: float, h: float, what: str, worst, hint: str) -> tuple[str, IntegrationFailure]:
    """The failure message and record of ``IntegrationResult``."""
    rec = IntegrationFailure(float(t), float(h), what, worst, hint)
    return rec.message, rec


def with_runaway(failure: IntegrationFailure, names, kinds, x_start, x, max_order: int = 0) -> IntegrationFailure:
    """``failure`` with :func:`runaway`'s sentence before its hint when the solution ran away.

    Parameters
    ----------
    failure : IntegrationFailure
    names, kinds, x_start, x, max_order
        As :func:`runaway`'s.

    Returns
    -------
    IntegrationFailure
        With ``runaway_order`` set to ``max_order`` (at least 1), ``runaway``, ``runaway_value`` and
        ``cause`` when the solution ran away.
    """
    sentence = runaway(names, kinds, x_start, x, max_order)
    if sentence is None:
        return failure
    i = runaway_unknown(kinds, x_start, x)[0]
    return IntegrationFailure(failure.t, failure.h, failure.what, failure.worst,
                              f"{sentence}; {failure.hint}", max(int(max_order), 1), names[i], float(x[i]), sentence)
