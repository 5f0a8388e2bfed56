"""``integrate``: the compiled engine when it serves the system, else the :class:`BDF` driver."""

from __future__ import annotations

import os
import time
from typing import Any, Callable

import numpy as np

from ...errors import ConvergenceError
from ..system import DaeSystem
from .constants import PROGRESS_INTERVAL
from .result import IntegrationResult
from .stepper import BDF, RunState

__all__ = ["integrate"]


def _compiled_engine_enabled() -> bool:
    """The compiled engine serves what it supports unless ``NETDAE_ENGINE=python``."""
    return os.environ.get("NETDAE_ENGINE", "compiled").lower() != "python"


def integrate(
    system: DaeSystem,
    t_span,
    x0,
    *,
    progress: Callable[[float, float, int], Any] | None = None,
    raise_on_failure: bool = False,
    **options,
) -> IntegrationResult:
    """Integrate ``d/dt q(x) = phi(x, t)`` over ``t_span`` with the FLC-BDF method.

    Parameters
    ----------
    system : DaeSystem
    t_span : (float, float)
        ``(t0, t_bound)``.
    x0 : ndarray, shape (n,)
        Consistent initial values.
    progress : callable, optional
        ``progress(t, t_bound, steps)``, called at most every 0.1 s of wall
        time and once at the end.
    raise_on_failure : bool
        Raise :class:`~netdae.errors.ConvergenceError` instead of returning a
        failed result.
    **options
        Passed to :class:`BDF` (``rtol``, ``atol``, ``vntol``, ``abstol``,
        ``index``, ``maxord``, ``max_step``, ``min_step``, ``first_step``,
        ``breakpoints``, ``xp0``, ``save``, ``norm``, ...).

    Returns
    -------
    IntegrationResult

    Raises
    ------
    ConvergenceError
        Only with ``raise_on_failure=True``, carrying t, h, the worst unknown
        and a hint.
    ValueError
        For invalid arguments.

    Examples
    --------
    The RC circuit ``C v' = -v/R`` from 1 V, with R C = 1 ms:

    >>> import numpy as np
    >>> from netdae.dae.system import LinearDae
    >>> rc = LinearDae([[1e-6]], [[-1e-3]])
    >>> res = integrate(rc, (0.0, 5e-3), np.array([1.0]), rtol=1e-6, atol=1e-9)
    >>> res.ok, bool(abs(res.x[-1, 0] - np.exp(-5.0)) < 1e-5)
    (True, True)
    """
    if _compiled_engine_enabled():
        from ..compiled.driver import integrate_compiled

        res = integrate_compiled(system, t_span, x0, progress=progress, raise_on_failure=raise_on_failure,
                                 **options)
        if res is not None:
            return res
    t0, tf = (float(v) for v in t_span)
    switching = getattr(system, "switching", None)
    locks = getattr(system, "behavioural_events", None)
    try:
        solver = BDF(system, t0, x0, tf, **options)
        last = time.perf_counter()
        while solver.status == RunState.RUNNING:
            # a solution that runs away overflows to inf: the step's finiteness checks fail it and the
            # failure names the growth (failures.runaway); numpy's warnings on the way are not the message
            with np.errstate(over="ignore", invalid="ignore"):
                solver.step()
            if progress is not None:
                now = time.perf_counter()
                if now - last >= PROGRESS_INTERVAL:
                    progress(solver.t, tf, solver.stats["steps"])
                    last = now
    finally:
        if switching is not None:
            switching.release()  # the system's evaluations decide the switches again
        if locks is not None:
            locks.release()  # and the behavioural sources' comparisons
    if progress is not None:
        progress(solver.t, tf, solver.stats["steps"])
    result = solver.result()
    if raise_on_failure and not result.ok:
        if result.failure is None:
            raise ConvergenceError(result.message)
        raise result.failure.error()
    return result
