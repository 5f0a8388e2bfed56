"""The work of a sweep: run rows, in this process or in a worker, and report each as an :class:`Outcome`.

:func:`run_rows` is the only function an executor calls. It takes a
:class:`Job` (everything a worker needs, picklable: the parsed netlist, not
its text, so no worker parses again) and a list of rows, and never raises for
a row that fails: the failure is the row's outcome.

Waveforms are put on one grid shared by every row so that they stack into
arrays over (row, point): the ``.tran`` card's ``tstep`` grid from
``tstart`` to ``tstop`` read from the dense output (exact interpolation, not
the steps each row happened to take), the ``.ac`` frequencies, the ``.dc``
sweep points.
"""

from __future__ import annotations

import dataclasses
import time
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..circuit import TranAnalysis
from ..errors import NetdaeError
from .plan import Plan, Row

__all__ = ["Job", "Outcome", "run_rows", "run_row", "elaborate_row", "record", "tran_grid", "pool_worker",
           "SWEPT_ANALYSES"]

#: The analyses a sweep runs in its rows: those that give measures of a row (their ``.meas`` cards, a
#: ``.noise`` card's integrated noise). A netlist's ``.pz``, ``.tf`` and ``.sens`` cards and its ``.four``
#: cards are left out (the sweep's notes name them, :func:`netdae.sweeps.api.left_out`).
SWEPT_ANALYSES = ("op", "dc", "ac", "tran", "noise")


@dataclass(frozen=True)
class Job:
    """Everything a worker needs to run rows of a sweep (picklable).

    Parameters
    ----------
    netlist : Netlist
        The parsed netlist (:func:`netdae.netlist.parse`), extra ``.meas`` cards included.
    overrides : dict
        Top-level parameter values given before the sweep (``netdae.load(params=)``).
    max_elements : int or None
    seed : int
        The Monte Carlo seed.
    plan : Plan
    analyses : tuple of str or None
        The analyses to run (``"op"``, ``"dc"``, ``"ac"``, ``"tran"``, ``"noise"``); None: every card of
        those kinds (:data:`SWEPT_ANALYSES`).
    save : tuple of str
        Signals whose waveforms are kept.
    options : dict
        ``reltol``/``abstol``/``vntol`` given by the caller.
    token : str
        Unique to one sweep: what a process keeps between the sweep's tasks
        (:mod:`netdae.sweeps.linear`) is found by it ("": keep nothing).
    """

    netlist: Any
    overrides: dict
    max_elements: int | None
    seed: int
    plan: Plan
    analyses: tuple[str, ...] | None
    save: tuple[str, ...]
    options: dict = field(default_factory=dict)
    token: str = ""


@dataclass
class Outcome:
    """What one row produced.

    Attributes
    ----------
    row : int
    measures : dict of str to float
        NaN for a measurement that failed.
    reasons : dict of str to str
        Why a measurement failed (only failed ones).
    waves : dict of (str, str) to ndarray
        ``(analysis, signal)`` to values on the analysis's shared grid.
    axes : dict of str to (str, ndarray)
        ``analysis`` to its grid ``(name, values)``.
    error : str or None
        Why the row failed (an analysis that failed or refused), None when it ran.
    seconds : float
        Wall time of the row.
    """

    row: int
    measures: dict[str, float] = field(default_factory=dict)
    reasons: dict[str, str] = field(default_factory=dict)
    waves: dict[tuple[str, str], np.ndarray] = field(default_factory=dict)
    axes: dict[str, tuple[str, np.ndarray]] = field(default_factory=dict)
    error: str | None = None
    seconds: float = 0.0


def tran_grid(card: TranAnalysis) -> np.ndarray:
    """The output grid of a ``.tran`` card: ``tstart`` to ``tstop`` by ``tstep`` (``tstop`` included).

    Examples
    --------
    >>> tran_grid(TranAnalysis(1e-3, 5e-3)).round(6).tolist()
    [0.0, 0.001, 0.002, 0.003, 0.004, 0.005]
    """
    span = card.tstop - card.tstart
    count = max(int(round(span / card.tstep)), 1)
    return np.linspace(card.tstart, card.tstop, count + 1)


def _save_names(job: Job, circuit) -> list[str] | None:
    """What the runner keeps: the saved signals and what the measures read (None: nothing asked)."""
    names = list(job.save)
    if not names:
        for spec in circuit.measures:
            for name in spec.signals():
                if name not in names:
                    names.append(name)
    return names or None


def elaborate_row(job: Job, row: Row, trace=None):
    """The circuit of ``row``: its parameter and element values, its Monte Carlo sample, the job's analyses.

    Only analyses of :data:`SWEPT_ANALYSES` run, and no ``.four`` card is evaluated (a row records measures).

    ``trace``, a :class:`~netdae.netlist.params.Trace`, records the elaboration (:mod:`netdae.sweeps.linear`).

    Raises
    ------
    NetlistError
        What the row's values make wrong (a zero resistance ...).
    """
    from ..analyses.runner import analysis_name
    from ..netlist.elaborate import elaborate

    params, values = job.plan.overrides(row)
    circuit = elaborate(job.netlist, params={**job.overrides, **params}, values=values,
                        max_elements=job.max_elements, sample=row.sample if row.sample is not None else 0,
                        seed=job.seed, trace=trace)
    wanted = SWEPT_ANALYSES if job.analyses is None else job.analyses
    return dataclasses.replace(circuit, steps=[], fouriers=[],
                               analyses=[a for a in circuit.analyses if analysis_name(a) in wanted])


def run_row(job: Job, row: Row) -> Outcome:
    """Elaborate and simulate one row; failures become the outcome's ``error``.

    A row that runs out of memory is a failed row too (its message says so).

    Raises
    ------
    KeyboardInterrupt
        Passed on (the sweep keeps the rows finished before it).
    """
    from ..analyses.runner import run

    t0 = time.perf_counter()
    out = Outcome(row.index)
    try:
        circuit = elaborate_row(job, row)
        results = run(circuit, save=_save_names(job, circuit), **job.options)
    except NetdaeError as exc:
        out.error = str(exc)
    except (ValueError, ArithmeticError, np.linalg.LinAlgError) as exc:  # numerics refusing a sample's values
        out.error = f"{type(exc).__name__}: {exc}"
    except MemoryError:  # this row's values need more than the machine has: the other rows still run
        out.error = ("out of memory (hint: save fewer signals (save=, --save), simulate a shorter interval, "
                     "or run fewer workers)")
    else:
        record(job, circuit, results, out)
    out.seconds = time.perf_counter() - t0
    return out


def record(job: Job, circuit, results, out: Outcome) -> None:
    """Put the measures, the failures and the saved waveforms of ``results`` into ``out``."""
    problems = []
    for res in results:
        if not res.ok:
            problems.append(f"{res.analysis}: {res.message}")
        for m in res.measures:
            out.measures[m.name] = float(m.value) if m.ok and m.value is not None else float("nan")
            if not m.ok:
                out.reasons[m.name] = m.reason or "failed"
            else:  # a name measured again: the last card counts (as PARAM= reads it)
                out.reasons.pop(m.name, None)
        if res.analysis == "noise":  # the integrated noise: measures of the row (the first .noise card's)
            for name in ("onoise_total", "inoise_total"):
                if name in res.noise_totals:
                    out.measures.setdefault(name, float(res.noise_totals[name]))
        _collect_waves(job, circuit, res, out)
    out.error = "; ".join(problems) or None


def _collect_waves(job: Job, circuit, res, out: Outcome) -> None:
    """The saved signals of ``res`` on the analysis's shared grid."""
    if not job.save:
        return
    if res.analysis == "tran":
        card = next(a for a in circuit.analyses if isinstance(a, TranAnalysis))
        grid = tran_grid(card)
        if res.dense is None:
            return
        grid = grid[grid <= res.t[-1] * (1 + 1e-12)] if res.t.size else grid[:0]
        values = res.dense(grid) if grid.size else {}
        axis = ("time", grid)
    else:
        values = {name: res[name] for name in job.save if name in res}  # v(a,b) from the node voltages
        axis = (res.axis_name, res.axis) if res.axis_name is not None else ("point", np.zeros(1))
    out.axes.setdefault(res.analysis, axis)
    for name in job.save:  # canonical spellings (the sweep checked them), as results key their signals
        if name in values and (res.analysis, name) not in out.waves:
            out.waves[(res.analysis, name)] = np.asarray(values[name])


def run_rows(job: Job, rows: list[Row]) -> list[Outcome]:
    """Run ``rows`` of ``job`` (what each executor task does): together when they are AC rows of a
    linear circuit (:mod:`netdae.sweeps.linear`), else one after another.

    Returns
    -------
    list of Outcome
        One per row, in the order given.

    Raises
    ------
    KeyboardInterrupt
        Ctrl-C (in a local pool's worker: the sweep's, :func:`pool_worker`): a
        new one, whose ``finished`` attribute lists the outcomes of the rows
        that ended before it (small to send back from a worker, unlike the
        interrupted analysis's partial results).
    """
    from ..analyses.prepared import reusing
    from .linear import ac_batch

    out: list[Outcome] = []
    try:
        with _interruptible(), _fewer_collections():
            batched = ac_batch(job, rows)
            if batched is not None:
                return batched
            with reusing(_templates(job)):
                for row in rows:
                    if _STOP is not None and _STOP.is_set():  # the sweep was interrupted: no new row
                        raise KeyboardInterrupt
                    out.append(run_row(job, row))
                return out
    except KeyboardInterrupt as exc:
        stop = KeyboardInterrupt()
        stop.finished = exc.finished if hasattr(exc, "finished") else out  # the batch's rows, or these
        raise stop from None


#: True in a worker process of the sweep's own pool (:func:`pool_worker`), and the pool's stop event.
_POOL_WORKER = False
_STOP = None
#: The worker was forked from a sweep that ignores SIGINT (:func:`pool_worker`).
_SIGINT_IGNORED = False


def pool_worker(stop=None) -> None:
    """Initializer of the sweep's local worker processes: Ctrl-C only while rows run.

    The terminal's Ctrl-C goes to the whole process group, and the sweep
    interrupts its workers itself: a worker waiting for a task ignores it
    (it would end printing a traceback, and a pool that lost a process is
    broken); one running rows stops at the next return of the compiled
    engine to Python and hands back the rows it finished (:func:`run_rows`).

    Parameters
    ----------
    stop : multiprocessing.Event, optional
        Set by the interrupted sweep: a task taken after it runs no row
        (the tasks already queued to the workers cannot be cancelled).

    Notes
    -----
    A sweep that ignores SIGINT (started in the background by a shell without job control,
    or under ``nohup``-like wrappers that ignore it) cannot be interrupted, and its workers,
    forked with that disposition, keep ignoring it while rows run too: the rows are not stopped
    behind the back of a sweep that goes on.
    """
    import signal

    global _POOL_WORKER, _STOP, _SIGINT_IGNORED
    _POOL_WORKER, _STOP = True, stop
    _SIGINT_IGNORED = signal.getsignal(signal.SIGINT) == signal.SIG_IGN
    for signum in _stopping_signals():
        signal.signal(signum, signal.SIG_IGN)


def _stopping_signals() -> list:
    """SIGINT, and SIGTERM and SIGHUP where the platform has them: a signal to the whole process group
    (``timeout``, a closed terminal) reaches the workers as Ctrl-C does, and the sweep stops them."""
    import signal

    return [getattr(signal, name) for name in ("SIGINT", "SIGTERM", "SIGHUP") if hasattr(signal, name)]


@contextmanager
def _interruptible():
    """SIGINT (SIGTERM, SIGHUP) raises KeyboardInterrupt inside (in a pool worker; elsewhere nothing changes)."""
    if not _POOL_WORKER or _SIGINT_IGNORED:
        yield
        return
    import signal

    for signum in _stopping_signals():
        signal.signal(signum, signal.default_int_handler)
    try:
        yield
    finally:
        for signum in _stopping_signals():
            signal.signal(signum, signal.SIG_IGN)


#: The cyclic garbage collector's first threshold while rows run (Python's default: 700 allocations).
ROW_GC_THRESHOLD = 50_000


@contextmanager
def _fewer_collections():
    """Collect cyclic garbage less often while rows run (restored after).

    A row allocates tens of thousands of short-lived objects (the elaborated circuit, its arrays,
    the result) and frees them by reference counting; at Python's default threshold the collector
    runs every 700 allocations and, as the process's long-lived objects (numba's, scipy's) number
    in the hundreds of thousands, now and then a full collection of 0.05-0.1 s: about 5 % of a
    small circuit's row. Nothing is kept from collection: it runs at the larger threshold.
    """
    import gc

    old = gc.get_threshold()
    gc.set_threshold(max(old[0], ROW_GC_THRESHOLD), *old[1:])
    try:
        yield
    finally:
        gc.set_threshold(*old)


#: The assembly templates of the sweeps run in this process (:func:`netdae.analyses.prepared.reusing`),
#: by ``(Job.token, thread)``: a thread of its own, since the shared device families' scratch arrays
#: are not for two threads at once. The last few.
_TEMPLATES: dict[tuple[str, int], dict] = {}
#: How many sweeps' templates a process keeps.
KEEP_TEMPLATES = 4


def _templates(job: Job) -> dict:
    """The store of ``job``'s assembly templates in this thread (a new one for a job without a token)."""
    import threading

    if not job.token:
        return {}
    key = (job.token, threading.get_ident())
    if key not in _TEMPLATES:
        while len(_TEMPLATES) >= KEEP_TEMPLATES:
            del _TEMPLATES[next(iter(_TEMPLATES))]
        _TEMPLATES[key] = {}
    return _TEMPLATES[key]
