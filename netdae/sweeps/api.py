""":func:`sweep`: parameter steps, corners and Monte Carlo in one call, on any executor.

One seam, three levels of parallelism:

1. in this process (``workers=1``): the netlist is parsed once and each row
   only elaborated and simulated; the topology analysis is memoised per
   structure, so rows that change values only analyse it once; the compiled
   engine is loaded once;
2. on the local cores (the default when there are enough rows): a
   :class:`concurrent.futures.ProcessPoolExecutor`. On Linux its workers are
   forked from this process after the first row has run here, so they start
   with the engine loaded and compile nothing;
3. on a cluster: any :class:`concurrent.futures.Executor`, e.g. Dask's
   ``distributed.Client(...).get_executor()``.

Rows go to the executor in chunks (about four per worker) as tasks of
:func:`netdae.sweeps.worker.run_rows`, which receives the parsed netlist, not
its text. A row's values depend only on the netlist, the seed and the row
(:mod:`netdae.netlist.montecarlo`), so the executor and the number of workers
never change a result.
"""

from __future__ import annotations

import dataclasses
import os
import secrets
import time
from collections.abc import Callable, Iterable, Mapping
from typing import TYPE_CHECKING

from ..circuit import Circuit
from ..analyses.runner import check_callable, string_entries
from ..errors import NetdaeError
from ..netlist.montecarlo import seed_problem
from ..stats import Statistics
from .plan import Plan, make_plan
from .result import SweepResult, reserved_columns
from .worker import SWEPT_ANALYSES, Job, Outcome, pool_worker, run_rows

if TYPE_CHECKING:  # the pools' modules are imported when a pool is used (a serial sweep needs neither)
    import concurrent.futures as cf

__all__ = ["sweep", "add_measures", "left_out", "measure_warnings", "MEASURES_FILE", "CHUNKS_PER_WORKER"]

#: Tasks per worker: enough to balance uneven rows, few enough to keep the overhead per task small.
CHUNKS_PER_WORKER = 4
#: Below this many rows per worker, the sweep runs in this process (starting workers costs more).
MIN_ROWS_PER_WORKER = 4
#: Rows per chunk in this process: progress is reported per chunk, linear AC rows are solved per chunk.
SERIAL_CHUNK = 100
#: The file name locating the cards given as ``measures=`` (``--meas``): the k-th card is line k.
MEASURES_FILE = "<measures>"
#: Ctrl-C: how long the sweep's own workers have to hand back the rows they finished [s] (the compiled
#: engine returns to Python every 0.1 s) before they are terminated.
INTERRUPT_GRACE = 2.0


def add_measures(circuit: Circuit, measures: Iterable[str]) -> Circuit:
    """The circuit with more ``.meas`` cards (card text with or without the leading ``.meas``).

    Raises
    ------
    NetlistError
        A card that does not parse or does not fit the circuit (located in ``<measures>``).
    """
    from ..netlist.elaborate import elaborate
    from ..netlist.lines import Card
    from ..netlist.measure import parse_measure

    cards = []
    for k, text in enumerate(measures):
        text = str(text).strip()
        spans = [(0, k + 1, 1)]
        if not text.lower().startswith(".meas"):
            # the columns are the text's as given: the added word maps to its first column
            text = ".meas " + text
            spans.append((len(".meas "), k + 1, 1))
        cards.append(parse_measure(Card(text, MEASURES_FILE, spans)))
    if not cards:
        return circuit
    net = dataclasses.replace(circuit.netlist, measures=list(circuit.netlist.measures) + cards)
    return elaborate(net, params=circuit.overrides, max_elements=circuit.max_elements, sample=circuit.sample,
                     seed=circuit.seed)


def left_out(circuit: Circuit, analyses: tuple[str, ...] | None = None) -> str | None:
    """The note naming the cards of ``circuit`` a sweep does not run, and why; None when there are none.

    A sweep records measures per row: the ``.meas`` cards of the analyses it runs
    (:data:`~netdae.sweeps.worker.SWEPT_ANALYSES`) and a ``.noise`` card's integrated
    noise. A ``.pz``, ``.tf`` or ``.sens`` card gives none (named unless ``analyses``
    chose what runs), nor does a ``.four`` card (named when the transient runs).

    Parameters
    ----------
    circuit : Circuit
    analyses : tuple of str, optional
        The analyses the sweep runs (None: all of its kinds).

    Returns
    -------
    str or None

    Examples
    --------
    >>> from netdae import load
    >>> c = load("t\\nR1 a 0 1k\\nI1 0 a 1m\\n.tran 1u 10u\\n.tf v(a) I1\\n.four 100k v(a)\\n.end\\n")
    >>> print(left_out(c))
    not run in the sweep: .tf (<string>:5:1), .four (<string>:6:1): a sweep records measures per row (its .meas cards, a .noise card's integrated noise), which these cards do not give (run them with 'netdae run')
    """
    from ..analyses.runner import analysis_name

    cards = []
    if analyses is None:
        cards = [(f".{analysis_name(a)}", a.location) for a in circuit.analyses
                 if analysis_name(a) not in SWEPT_ANALYSES]
    if analyses is None or "tran" in analyses:
        cards += [(".four", f.location) for f in circuit.fouriers]
    if not cards:
        return None
    named = ", ".join(f"{what} ({where})" if where is not None else what for what, where in cards)
    return (f"not run in the sweep: {named}: a sweep records measures per row (its .meas cards, a .noise card's "
            "integrated noise), which these cards do not give (run them with 'netdae run')")


def measure_warnings(circuit: Circuit, analyses: tuple[str, ...] | None) -> list[str]:
    """The warnings about the cards given as ``measures=``, as notes of the sweep (``location: warning: ...``).

    Those made adding them (:func:`add_measures`: a name the netlist's ``.meas``
    cards, or an earlier added card, measure already, whose values the table then
    holds), and a card whose analysis the sweep does not run (not made).

    Parameters
    ----------
    circuit : Circuit
        With the cards added.
    analyses : tuple of str, optional
        The analyses the sweep runs (None: all).

    Returns
    -------
    list of str
    """
    from ..circuit import Diagnostic

    out = [str(d) for d in circuit.diagnostics if d.location is not None and d.location.file == MEASURES_FILE]
    for card in circuit.netlist.measures:
        if analyses is not None and card.card.file == MEASURES_FILE and card.analysis not in analyses:
            runs = ", ".join(analyses)
            out.append(str(Diagnostic("warning", f".meas: measurement '{card.name}' measures the .{card.analysis} "
                                      f"analysis, which the sweep does not run (it runs {runs}): it is not made",
                                      card.card.location(card.offset))))
    return out


def _step_warnings(circuit: Circuit, plan: Plan, params: Mapping | None,
                   analyses: tuple[str, ...] | None) -> list[str]:
    """The warnings about the axes given as ``params=`` (``--step``) that a ``.step`` card would get at the card
    (:func:`netdae.netlist.steps.unseen_step`: a source's DC value stepped under a transient function); an axis
    a card steps too has its warning at the card."""
    from ..analyses.runner import analysis_name
    from ..netlist.steps import unseen_step

    given = {str(name).lower() for name in params or ()} - {s.name for s in circuit.steps}
    cards = [a for a in circuit.analyses if analyses is None or analysis_name(a) in analyses]
    out = []
    for axis in plan.axes:
        if axis.target == "element" and axis.name in given:
            why = unseen_step(circuit.element(axis.name), cards)
            if why is not None:
                out.append(f"warning: {why}")
    return out


def _swept_value(circuit: Circuit, axis) -> float | None:
    """The value a parameter or element axis replaces in ``circuit`` (None for other axes or none)."""
    if axis.target == "param":
        value = circuit.params.get(axis.name)
        return None if value is None else float(value)
    if axis.target == "element":
        el = circuit.element(axis.name)
        if el.source is not None:
            return float(el.source.dc or 0.0)
        return None if el.value is None else float(el.value)
    return None


def stepped_draws(circuit: Circuit, plan: Plan, seed: int) -> list[str]:
    """Warnings for the axes of a Monte Carlo sweep whose values vary from sample to sample.

    A stepped ``.param`` or element whose own value draws (``.param r={gauss(1k,0.1,3)}`` stepped
    as ``r``) is set to the step's fixed values in every row: its variation is gone from the
    samples, silently. It is found by elaborating the netlist for a second sample and comparing
    the axis's value with the first sample's.

    Parameters
    ----------
    circuit : Circuit
        The sweep's circuit (sample 0, without the axes' values).
    plan : Plan
    seed : int
        The sweep's seed.

    Returns
    -------
    list of str
        One ``"warning: ..."`` per such axis.

    Examples
    --------
    >>> import netdae
    >>> from netdae.sweeps.plan import make_plan
    >>> c = netdae.load("t\\n.param r={gauss(1k,0.1,3)}\\nV1 a 0 1\\nR1 a 0 {r}\\n.op\\n")
    >>> print(stepped_draws(c, make_plan(c, {"r": [1e3, 2e3]}, 4), 1)[0][:69])
    warning: the stepped r varies from one Monte Carlo sample to the next
    """
    axes = [a for a in plan.axes if a.target in ("param", "element")]
    if not axes or circuit.netlist is None:
        return []
    try:
        other = circuit.variant(sample=1, seed=seed)
        first = circuit.variant(sample=0, seed=seed)
    except NetdaeError:  # the sample's own elaboration fails: its rows say so
        return []
    out = []
    for axis in axes:
        a, b = _swept_value(first, axis), _swept_value(other, axis)
        if a is None or b is None or a == b:
            continue
        what = "a .param" if axis.target == "param" else "an element"
        out.append(f"warning: the stepped {axis.name} varies from one Monte Carlo sample to the next ({what} whose "
                   f"value draws: {a:g} in sample 0, {b:g} in sample 1); each row sets it to the step's value, so its "
                   "variation is not in the samples (hint: to vary it around each stepped value, step its nominal "
                   "through a .param the draw uses, e.g. .param rnom=1k r={gauss(rnom,0.1,3)} and .step param "
                   "rnom ...)")
    return out


def _check_measure_names(circuit: Circuit, plan: Plan, analyses: tuple[str, ...] | None) -> None:
    """Refuse a recorded measure named like a column of the sweep's table (it would overwrite the column).

    Raises
    ------
    NetlistError
        At the measure's name on its ``.meas`` card: the column and what it holds.
    """
    from ..netlist.elements import error

    reserved = reserved_columns(plan)
    recorded = {m.name for m in circuit.measures if analyses is None or m.analysis in analyses}
    for card in circuit.netlist.measures:
        what = reserved.get(card.name.lower())
        if what is not None and card.name in recorded:
            raise error(card.card, card.offset, f"the measurement '{card.name}' is named like the sweep table's "
                        f"column '{card.name.lower()}' ({what}), which its values would overwrite",
                        hint=f"rename the measurement (e.g. {card.name}_m)")


def _check_save(circuit: Circuit, save: Iterable[str]) -> list[str]:
    """The ``save`` names in canonical spelling, each naming a node or an element of the circuit.

    Raises
    ------
    NetdaeError
        A malformed name, or one naming no node or element (checked once, not per row).
    """
    from ..signals import missing_name, parse_signal

    nodes = set(circuit.nodes) | {"0"}
    names = {el.name for el in circuit.elements}
    out = []
    for text in save:
        try:
            sig = parse_signal(text)
        except ValueError as exc:
            raise NetdaeError(f"sweep: save: {exc}") from None
        missing = missing_name(sig, nodes, names)
        if missing:
            raise NetdaeError(f"sweep: save: {missing} (in {text!r})")
        out.append(sig.name)
    return out


def _executor(executor: cf.Executor | None, workers: int | None, rows: int) -> tuple[cf.Executor | None, int, str]:
    """The executor to use (None: this process), its worker count, and its name for the stats."""
    if executor is not None:
        import concurrent.futures as cf  # imported by whoever made the executor

        if not isinstance(executor, cf.Executor):
            raise NetdaeError(f"sweep: executor must be a concurrent.futures.Executor, not {type(executor).__name__}")
        count = getattr(executor, "_max_workers", None) or workers or os.cpu_count() or 1
        return executor, int(count), type(executor).__name__
    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, int) or workers < 1):
        raise NetdaeError(f"sweep: workers must be a positive integer, got {workers!r}")
    if workers is not None:
        count = workers
    elif hasattr(os, "sched_getaffinity"):
        count = len(os.sched_getaffinity(0))
    else:
        count = os.cpu_count() or 1
    count = min(count, max(rows // MIN_ROWS_PER_WORKER, 1))
    if count <= 1:
        return None, 1, "serial"
    import concurrent.futures as cf
    import multiprocessing

    methods = multiprocessing.get_all_start_methods()
    context = multiprocessing.get_context("fork" if "fork" in methods else "spawn")
    stop = context.Event()  # set on Ctrl-C: the workers start no new row (_interrupt)
    pool = cf.ProcessPoolExecutor(max_workers=count, mp_context=context, initializer=pool_worker, initargs=(stop,))
    pool.netdae_stop = stop
    return pool, count, "ProcessPoolExecutor"


def _chunks(rows: list, count: int) -> list[list]:
    size = max(1, -(-len(rows) // (count * CHUNKS_PER_WORKER)))
    return [rows[k:k + size] for k in range(0, len(rows), size)]


def sweep(circuit: Circuit | str | os.PathLike, *, params: Mapping[str, Iterable[float] | float] | None = None,
          samples: int | None = None, seed: int | None = None, analyses: Iterable[str] | None = None,
          save: Iterable[str] | None = None, measures: Iterable[str] | None = None,
          executor: cf.Executor | None = None, workers: int | None = None,
          reltol: float | None = None, abstol: float | None = None, vntol: float | None = None,
          progress: Callable[[int, int], None] | None = None) -> SweepResult:
    """Run a circuit over parameter steps and Monte Carlo samples.

    Parameters
    ----------
    circuit : Circuit, str or path-like
        An elaborated circuit (:func:`netdae.load`) or a netlist file or text
        (whose warnings, when the sweep loads it, are notes of the result).
        Its ``.step`` cards are the sweep's axes.
    params : mapping, optional
        More axes: a top-level ``.param``, an element (full name) or ``temp``
        to its values; a name a ``.step`` card steps replaces that card's values.
        All combinations are run, the first axis outermost.
    samples : int, optional
        Monte Carlo samples per point: sample k draws the netlist's
        ``gauss``/``agauss``/``unif``/``aunif``/``limit`` from the stream ``(seed, k)``.
    seed : int, optional
        The Monte Carlo seed, an integer from 0 to
        :data:`~netdae.netlist.montecarlo.MAX_SEED` (default the netlist's
        ``.options seed=``, else 1).
    analyses : iterable of str, optional
        Which of the netlist's analyses to run (``"op"``, ``"dc"``, ``"ac"``,
        ``"tran"``, ``"noise"``; default all). A ``.noise`` card's integrated
        noise is recorded as the measures ``onoise_total`` and
        ``inoise_total`` (the first card's).
    save : iterable of str, optional
        Signals whose waveforms to keep for every row (``v(out)``, ``i(v1)``),
        on each analysis's grid (a ``.tran``'s ``tstep`` grid, read from the
        dense output). Default: none, only measures.
    measures : iterable of str, optional
        More ``.meas`` cards (``"tran ripple pp v(out) from=5m to=10m"``),
        added to the netlist's.
    executor : concurrent.futures.Executor, optional
        Where to run the rows (e.g. a Dask ``Client(...).get_executor()``);
        default: a local process pool over the available cores, or this
        process when the sweep is small or ``workers=1``.
    workers : int, optional
        Local worker processes (default: the available cores).
    reltol, abstol, vntol : float, optional
        Tolerances for every row.
    progress : callable, optional
        ``progress(done, total)`` after each finished chunk of rows.

    Returns
    -------
    SweepResult
        A failed row is a row with its error message (``result.errors``),
        never a lost sweep.

    Raises
    ------
    NetlistError
        Bad input in the netlist or in ``measures``; a measurement named like a
        column of the table (``row``, ``sample``, ``error``, ``reasons``, an axis).
    NetdaeError
        An unknown name to step, no values, a bad sample count or seed,
        nothing to record (no measure and no ``save``), a netlist without
        Monte Carlo functions given ``samples``.
    KeyboardInterrupt
        Ctrl-C: its ``result`` attribute holds the sweep with the rows
        finished so far (the others marked not run).

    Examples
    --------
    >>> import netdae
    >>> res = netdae.sweep("netlists/voltage_divider.cir", params={"r2": [1e3, 2e3]},
    ...                    measures=["dc vout find v(out) at=10"], analyses=["dc"], workers=1)
    >>> res
    <SweepResult 2 rows (r2 x2); measures: vout; 0 waveforms; 0 failed>
    >>> res.measures["vout"].round(4).tolist()
    [0.9091, 1.6667]
    """
    from ..analyses.runner import check_options
    from ..netlist import load

    t0 = time.perf_counter()
    measures, save, analyses = (string_entries(value, what) for value, what in
                                ((measures, "measures"), (save, "save"), (analyses, "analyses")))
    if params is not None and not isinstance(params, Mapping):
        raise NetdaeError(f"sweep: params must be a mapping of names to values (e.g. {{'r2': [1e3, 2e3]}}), "
                          f"not {type(params).__name__}")
    loaded: list[str] = []
    if not isinstance(circuit, Circuit):
        circuit = load(circuit)
        loaded = [str(d) for d in circuit.diagnostics if d.severity == "warning"]  # nobody else shows them
    if circuit.netlist is None:
        raise NetdaeError("sweep: the circuit must come from a netlist (netdae.load), not be built by hand")
    altering = next((a for a in circuit.analyses if a.alter), None)
    if altering is not None:  # a row's values and the script's changes would both be element values
        raise NetdaeError(f"sweep: {altering.alter[0].location}: the netlist's .control script alters the circuit "
                          f"('{altering.alter[0].command}'); netdae sweeps netlists without alter and altermod "
                          "(run it with 'netdae run', or step the values with .step)")
    if seed is not None and seed_problem(seed) is not None:
        raise NetdaeError(f"sweep: seed: {seed_problem(seed)}")
    check_callable(progress, "progress", "progress(done, total)")
    if measures:
        circuit = add_measures(circuit, measures)
    options = {k: v for k, v in (("reltol", reltol), ("abstol", abstol), ("vntol", vntol)) if v is not None}
    try:
        check_options(circuit, **options)
    except ValueError as exc:
        raise NetdaeError(f"sweep: {exc}") from None
    wanted = None
    if analyses is not None:
        from ..analyses.runner import analysis_name

        wanted = tuple(str(a).lower() for a in string_entries(analyses, "analyses"))
        if not wanted:
            raise NetdaeError("sweep: analyses= is empty (name the analyses to run, e.g. analyses=['tran'], or leave "
                              "it out to run them all)")
        bad = [a for a in wanted if a not in SWEPT_ANALYSES]
        if bad:
            raise NetdaeError(f"sweep: unknown analysis {bad[0]!r} (op, dc, ac, tran or noise)")
        have = {analysis_name(a) for a in circuit.analyses}
        missing = [a for a in wanted if a not in have]
        if missing:
            raise NetdaeError(f"sweep: the netlist has no {missing[0]} analysis (it has: "
                              f"{', '.join(sorted(have)) or 'none'}): add a .{missing[0]} card or leave it out of "
                              "analyses")
    save = tuple(_check_save(circuit, save or ()))
    noise = any(type(a).__name__ == "NoiseAnalysis" for a in circuit.analyses) and (wanted is None or "noise" in wanted)
    if not save and not circuit.measures and not noise:
        raise NetdaeError("sweep: nothing to record: give measures (.meas cards or measures=) or save= signals")
    plan = make_plan(circuit, params, samples)
    warnings = loaded + (measure_warnings(circuit, wanted) if measures else []) + _step_warnings(circuit, plan, params,
                                                                                                 wanted)
    _check_measure_names(circuit, plan, wanted)
    seed = circuit.seed if seed is None else seed
    if samples is not None and circuit.draws == 0:
        raise NetdaeError(f"sweep: {samples} Monte Carlo samples asked, but the netlist draws nothing: use gauss, "
                          "agauss, unif, aunif or limit in a .param or an element value")
    if samples is not None:
        warnings += stepped_draws(circuit, plan, seed)
    job = Job(circuit.netlist, dict(circuit.overrides), circuit.max_elements, seed, plan, wanted, save, options,
              secrets.token_hex(8))
    pool, count, name = _executor(executor, workers, len(plan.rows))
    owned = executor is None and pool is not None
    outcomes: dict[int, Outcome] = {}
    try:
        _run(job, plan, pool, count, outcomes, progress, owned)
    except KeyboardInterrupt as exc:
        exc.result = _finish(job, circuit, outcomes, name, count, t0, warnings, interrupted=True)
        raise
    finally:
        if owned:
            pool.shutdown(wait=True, cancel_futures=True)
    return _finish(job, circuit, outcomes, name, count, t0, warnings)


def _run(job: Job, plan: Plan, pool: cf.Executor | None, count: int, outcomes: dict[int, Outcome],
         progress: Callable[[int, int], None] | None, owned: bool = False) -> None:
    """Run the plan's rows into ``outcomes``; on Ctrl-C the rows finished so far are there (:func:`_interrupt`)."""
    rows = list(plan.rows)
    total = len(rows)
    if pool is None:
        for chunk in [rows[k:k + SERIAL_CHUNK] for k in range(0, total, SERIAL_CHUNK)]:
            for o in _rows(job, chunk, outcomes):
                outcomes[o.row] = o
            if progress is not None:
                progress(len(outcomes), total)
        return
    import concurrent.futures as cf

    if isinstance(pool, cf.ProcessPoolExecutor):  # the first row here: forked workers then start warm
        for o in _rows(job, rows[:1], outcomes):
            outcomes[o.row] = o
        rows = rows[1:]
    futures = {pool.submit(run_rows, job, chunk): chunk for chunk in _chunks(rows, count)}
    try:
        for fut in cf.as_completed(futures):
            _collect(fut, futures[fut], outcomes, stopping=False)
            if progress is not None:
                progress(len(outcomes), total)
    except KeyboardInterrupt:
        _interrupt(pool, futures, outcomes, owned)
        raise
    except BaseException:
        for fut in futures:
            fut.cancel()
        raise


def _rows(job: Job, rows: list, outcomes: dict[int, Outcome]) -> list[Outcome]:
    """:func:`run_rows` in this process; on Ctrl-C the rows it finished go into ``outcomes`` first."""
    try:
        return run_rows(job, rows)
    except KeyboardInterrupt as exc:
        for o in getattr(exc, "finished", ()):
            outcomes[o.row] = o
        raise


def _collect(fut, chunk: list, outcomes: dict[int, Outcome], stopping: bool = True) -> None:
    """The outcomes of a finished task into ``outcomes``: its rows', a lost worker's failed rows, or those an
    interrupted task finished.

    A task a worker stopped on Ctrl-C (its KeyboardInterrupt carries the rows it finished) raises
    KeyboardInterrupt here too unless the sweep is ``stopping`` already: the terminal's SIGINT reaches the
    workers and the sweep together, and whichever sees it first, the sweep ends as interrupted (measured:
    now and then the sweep went on to a normal end with the stopped rows missing and exit status 1).
    """
    try:
        done = fut.result()
    except KeyboardInterrupt as exc:
        if not hasattr(exc, "finished"):
            raise  # this process's own Ctrl-C, raised while it took the result: not swallowed
        for o in exc.finished:  # a worker stopped by Ctrl-C: the rows it finished
            outcomes[o.row] = o
        if not stopping:
            raise KeyboardInterrupt from None
        return
    except Exception as exc:  # noqa: BLE001 - a lost worker fails its rows, never the sweep
        done = [Outcome(row.index, error=lost_worker(exc)) for row in chunk]
    for o in done:
        outcomes[o.row] = o


def _interrupt(pool: cf.Executor, futures: dict, outcomes: dict[int, Outcome], owned: bool) -> None:
    """Ctrl-C: stop the rows promptly, keeping every row finished.

    The tasks that have not started are cancelled (any executor). The
    sweep's own process pool is stopped as well: its stop event tells the
    workers to start no new row (the tasks already queued to them), its
    running workers are interrupted (SIGINT; they ignore it between tasks,
    :func:`~netdae.sweeps.worker.pool_worker`) and hand back the rows they
    finished within :data:`INTERRUPT_GRACE` seconds; then every worker
    still alive is terminated, so that shutting the pool down does not wait
    for a row. An executor the caller gave keeps running what it started
    (its workers are the caller's).
    """
    import concurrent.futures as cf
    import signal

    for fut in futures:
        fut.cancel()
    for fut in futures:  # finished while the interrupt arrived
        if fut.done() and not fut.cancelled():
            _collect(fut, futures[fut], outcomes)
    if not (owned and hasattr(pool, "netdae_stop")):
        return
    pool.netdae_stop.set()
    processes = list((getattr(pool, "_processes", None) or {}).values())
    for proc in processes:
        try:
            os.kill(proc.pid, signal.SIGINT)
        except (OSError, TypeError):  # ended already
            pass
    running = [fut for fut in futures if not fut.done()]
    if running:
        finished, _ = cf.wait(running, timeout=INTERRUPT_GRACE)
        for fut in finished:
            if not fut.cancelled():
                _collect(fut, futures[fut], outcomes)
    for proc in processes:
        if proc.is_alive():
            proc.terminate()


def lost_worker(exc: BaseException) -> str:
    """Why the rows of a task whose worker failed have no result (a row's error message).

    A worker process that ends abruptly (killed, or by the operating system's
    out-of-memory killer) breaks the process pool, so every task still pending
    there fails the same way; a Dask cluster whose scheduler or worker goes away
    fails its tasks with a communication error. Those rows are failed rows, the
    finished ones are kept.

    Parameters
    ----------
    exc : BaseException
        What the task's future raised.

    Returns
    -------
    str

    Examples
    --------
    >>> lost_worker(MemoryError())
    'not run: the worker ran out of memory (hint: fewer workers, or a smaller circuit or save= list per row)'
    """
    import concurrent.futures.process as cfp

    if isinstance(exc, cfp.BrokenProcessPool):
        return ("not run: a worker process ended abruptly (killed, or out of memory) "
                "(hint: rerun with fewer workers, or run the failed rows again)")
    if isinstance(exc, MemoryError):
        return "not run: the worker ran out of memory (hint: fewer workers, or a smaller circuit or save= list per row)"
    if isinstance(exc, NetdaeError):
        return f"not run: {exc}"
    text = str(exc) or "no message"
    return f"not run: the task failed on its worker: {type(exc).__name__}: {text} (hint: check the executor's workers)"


def _finish(job: Job, circuit: Circuit, outcomes: dict[int, Outcome], name: str, count: int, t0: float,
            warnings: list[str], interrupted: bool = False) -> SweepResult:
    # the measurements of the analyses that run (those of an analysis left out of analyses= are not made)
    names = [m.name for m in circuit.measures if job.analyses is None or m.analysis in job.analyses]
    res = SweepResult.collect(job.plan, job.seed, outcomes, names, job.save)
    res.stats = Statistics(wall_time=time.perf_counter() - t0, row_seconds=sum(o.seconds for o in outcomes.values()),
                           executor=name, workers=count, completed=len(outcomes))
    res.notes.extend(warnings)
    cards = left_out(circuit, job.analyses)
    if cards is not None:
        res.notes.append(cards)
    if interrupted:
        res.notes.append(f"interrupted: {len(outcomes)} of {res.rows} rows finished, {res.rows - len(outcomes)} "
                         "not run")
    if res.failed:
        res.notes.append(f"{res.failed} of {res.rows} rows failed: " +
                         "; ".join(f"{n} x {why}" for why, n in list(res.failures().items())[:3]))
    for name, counts in res.measure_failures().items():  # the rows ran, the measurement could not be made
        res.notes.append(f"measure {name} failed in {sum(counts.values())} of {res.rows} rows: " +
                         "; ".join(f"{n} x {why}" for why, n in list(counts.items())[:3]))
    return res
