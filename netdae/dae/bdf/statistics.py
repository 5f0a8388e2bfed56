"""The integrator's counters (``IntegrationResult.stats``)."""

from __future__ import annotations

import math

__all__ = ["new_statistics", "count_step"]


def new_statistics() -> dict:
    """Fresh counters.

    Returns
    -------
    dict
        ``steps``, ``rejected`` (error-test failures), ``newton_iterations``,
        ``newton_failures`` (including retries with a fresh Jacobian),
        ``factorizations``, ``evaluations``, ``jacobian_evaluations``,
        ``cj_changes`` (changes of the Newton-matrix coefficient between
        attempts), ``restarts``, ``probes``, ``max_order_used``, ``h_min``,
        ``h_max``, ``events`` (steps ended where switches change), ``impasses`` (instants
        where Newton failed on every step size and the solution jumped to the steady-state
        solver's implicit-Euler steps right of them), ``wall_time`` [s].
    """
    return {
        "steps": 0, "rejected": 0, "newton_iterations": 0, "newton_failures": 0,
        "factorizations": 0, "evaluations": 0, "jacobian_evaluations": 0, "cj_changes": 0,
        "restarts": 0, "probes": 0, "max_order_used": 0, "h_min": math.inf, "h_max": 0.0,
        "events": 0, "impasses": 0, "wall_time": 0.0,
    }


def count_step(stats: dict, h: float, k: int) -> None:
    """Count an accepted step of size ``h`` and order ``k``.

    Examples
    --------
    >>> st = new_statistics(); count_step(st, 0.5, 2); count_step(st, 0.25, 1)
    >>> st["steps"], st["h_min"], st["h_max"], st["max_order_used"]
    (2, 0.25, 0.5, 2)
    """
    stats["steps"] += 1
    if h < stats["h_min"]:
        stats["h_min"] = h
    if h > stats["h_max"]:
        stats["h_max"] = h
    if k > stats["max_order_used"]:
        stats["max_order_used"] = k
