"""How the integrator names a failure: the worst unknown, hints, the failure record and message."""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from ...circuit import TOLERANCE_MIN
from ..newton import INFO_EVALUATION, INFO_SINGULAR

__all__ = ["Failure", "IntegrationFailure", "worst_unknown", "nonfinite_unknown", "newton_hint", "error_hint",
           "failure_record"]


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
    """

    t: float
    h: float
    what: str
    worst: str | None
    hint: str

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
