"""What an integration returns: :class:`IntegrationResult`."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from ..dense import Interpolant


if TYPE_CHECKING:
    from .failures import IntegrationFailure

__all__ = ["IntegrationResult"]


@dataclass
class IntegrationResult:
    """Output of :func:`integrate` (and of :meth:`BDF.result`).

    Attributes
    ----------
    t : ndarray, shape (m,)
        Accepted step times, ``t[0] = t0``.
    x : ndarray, shape (m, ns)
        Saved components at those times.
    order : ndarray of int8, shape (m,)
        Order of the step ending at each time (0 at t0).
    names : tuple of str, length ns
        Names of the saved components.
    save : ndarray of int, shape (ns,)
        Their positions among the unknowns.
    dense : Interpolant
        ``dense(t, components=None) -> ndarray (p, nc)``: the method's
        interpolant anywhere in ``[t[0], t[-1]]``.
    stats : dict
        ``steps``, ``rejected`` (error-test failures), ``newton_iterations``,
        ``newton_failures``, ``factorizations``, ``evaluations``,
        ``jacobian_evaluations``, ``cj_changes`` (changes of the Newton-matrix
        coefficient between attempts), ``restarts``, ``probes`` (derivative
        probes at the start and at restarts, one factorisation each),
        ``max_order_used``, ``h_min``, ``h_max``, ``events`` (switching events),
        ``wall_time`` [s].
    status : int
        0 on success, -1 on failure (``netdae.results`` conventions).
    message : str
        What happened; on failure with t, h, the worst unknown and a hint.
    tolerances : dict
        ``rtol``, ``vntol``, ``abstol``, ``atol`` (or ``"per-unknown"``),
        ``norm``, ``relref``, ``newton_tol``, ``index_excluded`` (number of
        unknowns left out of the error test), ``maxord``.
    failure : IntegrationFailure or None
        Where and why a failed run stopped (``t``, ``h``, ``what``, ``worst``, ``hint``).
    restarts : ndarray, shape (r,)
        Breakpoints at which the method restarted at order 1.
    jumps : list of (float, tuple of str)
        Times at which the solution jumped (an input value or an index-2
        unknown at a corner of the inputs, or an inconsistent start) and the
        unknowns that jumped by more than their tolerance. At each such time
        ``t`` holds two equal entries: the value reached from the left, then
        the right limit the method continued from.
    events : list of (float, tuple of str)
        Switching events: the times at which switches changed conductance (the
        method restarted there) and the switches that did.
    """

    t: np.ndarray
    x: np.ndarray
    order: np.ndarray
    names: tuple
    save: np.ndarray
    dense: Interpolant
    stats: dict
    status: int
    message: str
    tolerances: dict
    failure: IntegrationFailure | None = None
    restarts: np.ndarray = field(default_factory=lambda: np.empty(0))
    jumps: list = field(default_factory=list)
    events: list = field(default_factory=list)

    @property
    def ok(self) -> bool:
        """True when the integration reached ``t_bound``."""
        return self.status >= 0

    def __getitem__(self, name: str) -> np.ndarray:
        """Waveform of the saved component called ``name`` (case-insensitive)."""
        key = name.lower()
        for i, nm in enumerate(self.names):
            if nm.lower() == key:
                return self.x[:, i]
        raise KeyError(f"no saved component {name!r}")

