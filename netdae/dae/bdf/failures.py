"""How the integrator names a failure: the worst unknown, hints, the failure record and message."""

from __future__ import annotations

import numpy as np

from ..newton import INFO_EVALUATION, INFO_SINGULAR

__all__ = ["Failure", "worst_unknown", "nonfinite_unknown", "newton_hint", "error_hint", "failure_record"]


class Failure(Exception):
    """A numerical failure found by a part of the integrator, for the driver to record.

    Attributes
    ----------
    what : str
        What failed.
    worst : str or None
        The unknown to blame.
    hint : str
        What the user can do.
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


def error_hint() -> str:
    """The hint for repeated error-test failures."""
    return ("the solution is not smooth here: an input discontinuity without a breakpoint, "
            "an inconsistent initial value, or an index-2 unknown not marked in `index`")


def failure_record(t: float, h: float, what: str, worst, hint: str) -> tuple[str, dict]:
    """The failure message and record (``t``, ``h``, ``worst``, ``hint``, ``what``) of ``IntegrationResult``."""
    text = f"BDF failed: {what} at t={t:.9g}, h={h:.3g}"
    if worst:
        text += f", worst unknown {worst}"
    return text + f" (hint: {hint})", {"t": float(t), "h": float(h), "worst": worst, "hint": hint, "what": what}
