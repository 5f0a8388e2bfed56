"""The statistics vocabulary: one named, typed record of the work of every analysis.

Every :class:`~netdae.results.Result` carries a :class:`Statistics`. Its
fields are the one spelling of each count (``newton_iterations``, never
``newton``); a field that does not apply to an analysis is ``None`` and is
absent from the mapping view, the JSON output and the printed summary.

A :class:`Statistics` is a read-only :class:`collections.abc.Mapping` over
its set fields, so ``result.stats["steps"]``, ``"engine" in
result.stats["integrator"]`` and ``dict(result.stats)`` work. A key that
was renamed raises a :class:`KeyError` that names its new spelling:

>>> s = Statistics(points=3, newton_iterations=7)
>>> s["newton_iterations"], dict(s)
(7, {'points': 3, 'newton_iterations': 7})
>>> s["newton"]
Traceback (most recent call last):
...
KeyError: "'newton' was renamed 'newton_iterations'"
>>> s.summary()
'points=3, newton_iterations=7'
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, fields
from typing import Any, Iterator

__all__ = ["Statistics", "RENAMED"]

#: Keys of the former statistics dicts and their one spelling now.
RENAMED = {"newton": "newton_iterations", "op_newton": "op_newton_iterations"}

#: The fields of the one-line summary (``netdae run``, ``netdae demo``), in order.
SUMMARY_FIELDS = ("points", "steps", "rejected", "newton_iterations", "factorizations", "strategy")


@dataclass(frozen=True)
class Statistics(Mapping):
    """Work counters and timings of one analysis (or of the integrator of a transient).

    Every field is optional: ``None`` means "does not apply to this analysis".

    Parameters
    ----------
    points : int, optional
        Points of the result (sweep points, output times, frequencies).
    steps : int, optional
        Accepted integration steps.
    rejected : int, optional
        Steps rejected by the local error test (error-test failures).
    newton_iterations : int, optional
        Newton iterations: of the operating point for ``op``/``ac``/``pz``/``tf``/
        ``noise``, summed over the points of ``dc``, over the steps of ``tran``.
    newton_failures : int, optional
        Steps whose Newton iteration failed (retries included).
    factorizations : int, optional
        LU factorizations of the Newton or circuit matrix.
    evaluations : int, optional
        Residual evaluations.
    jacobian_evaluations : int, optional
        Jacobian evaluations.
    cj_changes : int, optional
        Changes of the Newton-matrix coefficient between attempts.
    restarts : int, optional
        Integrator restarts at breakpoints and events.
    probes : int, optional
        Probe evaluations (events, breakpoints).
    max_order_used : int, optional
        Highest BDF order used.
    h_min, h_max : float, optional
        Smallest and largest accepted step [s].
    events : int, optional
        Steps ended where a switch changes state.
    impasses : int, optional
        Instants where the attempts failed on every step size and the solution
        continued from the steady-state solver's implicit-Euler steps (a jump).
    op_newton_iterations : int, optional
        Newton iterations of the initial operating point of a transient.
    strategy : str, optional
        How an operating point converged: ``"newton"``, ``"gmin stepping"`` ...
    poles, zeros : int, optional
        Number of poles and zeros found (``pz``).
    generators : int, optional
        Noise generators (``noise``).
    batched : int, optional
        Rows solved together in one batched small-signal sweep.
    executor : str, optional
        Where the rows of a sweep ran (``"serial"``, ``"process"`` ...).
    workers : int, optional
        Worker processes of a sweep.
    completed : int, optional
        Rows of a sweep that finished.
    row_seconds : float, optional
        The wall times of a sweep's rows, summed [s].
    wall_time : float, optional
        Elapsed time [s].
    load_time : float, optional
        Time to prepare the compiled engine [s].
    engine : str, optional
        ``"compiled"`` when the compiled engine integrated a transient.
    n_unknowns, n_nodes, n_branches, nnz : int, optional
        Size of the circuit equations: unknowns, nodes, branch currents,
        structural non-zeros of the matrix.
    linear : bool, optional
        Whether the circuit equations are linear.
    integrator : Statistics, optional
        The integrator's own counters (transient).
    """

    points: int | None = None
    steps: int | None = None
    rejected: int | None = None
    newton_iterations: int | None = None
    newton_failures: int | None = None
    factorizations: int | None = None
    evaluations: int | None = None
    jacobian_evaluations: int | None = None
    cj_changes: int | None = None
    restarts: int | None = None
    probes: int | None = None
    max_order_used: int | None = None
    h_min: float | None = None
    h_max: float | None = None
    events: int | None = None
    impasses: int | None = None
    op_newton_iterations: int | None = None
    strategy: str | None = None
    poles: int | None = None
    zeros: int | None = None
    generators: int | None = None
    batched: int | None = None
    executor: str | None = None
    workers: int | None = None
    completed: int | None = None
    row_seconds: float | None = None
    wall_time: float | None = None
    load_time: float | None = None
    engine: str | None = None
    n_unknowns: int | None = None
    n_nodes: int | None = None
    n_branches: int | None = None
    nnz: int | None = None
    linear: bool | None = None
    integrator: "Statistics | None" = None

    # -- the mapping view -------------------------------------------------------
    def _set(self) -> list[str]:
        return [f.name for f in fields(self) if getattr(self, f.name) is not None]

    def __getitem__(self, key: str) -> Any:
        if key in RENAMED:
            raise KeyError(f"{key!r} was renamed {RENAMED[key]!r}")
        value = getattr(self, key, None) if key in _FIELDS else None
        if value is None:
            raise KeyError(key)
        return value

    def get(self, key: str, default: Any = None) -> Any:
        """The value of a set field, else ``default``; a renamed key raises :class:`KeyError`."""
        if key in RENAMED:
            raise KeyError(f"{key!r} was renamed {RENAMED[key]!r}")
        return super().get(key, default)

    def __iter__(self) -> Iterator[str]:
        return iter(self._set())

    def __len__(self) -> int:
        return len(self._set())

    def __contains__(self, key: object) -> bool:
        return isinstance(key, str) and key in _FIELDS and getattr(self, key) is not None

    # -- construction and presentation -----------------------------------------
    @classmethod
    def from_counts(cls, counts: Mapping[str, Any] | None) -> "Statistics":
        """The statistics of a counter mapping (the integrator's ``stats``), names checked.

        Parameters
        ----------
        counts : mapping or None
            Keys among the field names; a nested ``integrator`` mapping is converted too.

        Raises
        ------
        KeyError
            For a key outside the vocabulary (a renamed key names its new spelling).

        Examples
        --------
        >>> Statistics.from_counts({"steps": 4, "h_min": 0.5}).steps
        4
        """
        if counts is None:
            return cls()
        if isinstance(counts, Statistics):
            return counts
        kw: dict[str, Any] = {}
        for key, value in counts.items():
            if key in RENAMED:
                raise KeyError(f"{key!r} was renamed {RENAMED[key]!r}")
            if key not in _FIELDS:
                raise KeyError(f"{key!r} is not a statistic; known: {', '.join(_FIELDS)}")
            kw[key] = cls.from_counts(value) if key == "integrator" else value
        return cls(**kw)

    def to_dict(self) -> dict[str, Any]:
        """The set fields as a plain dict (``integrator`` as a nested dict)."""
        return {k: (v.to_dict() if isinstance(v, Statistics) else v) for k, v in self.items()}

    def summary(self) -> str:
        """The one-line summary ``points=..., steps=..., newton_iterations=..., wall=...s``.

        Examples
        --------
        >>> Statistics(newton_iterations=1, factorizations=1, strategy="newton", wall_time=0.25).summary()
        'newton_iterations=1, factorizations=1, strategy=newton, wall=0.25s'
        """
        parts = [f"{k}={getattr(self, k)}" for k in SUMMARY_FIELDS if getattr(self, k) is not None]
        if self.wall_time is not None:
            parts.append(f"wall={self.wall_time:.3g}s")
        return ", ".join(parts)


_FIELDS = tuple(f.name for f in fields(Statistics))
