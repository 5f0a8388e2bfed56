"""``netdae sweep FILE``: parameter steps and Monte Carlo samples, on all cores or a Dask cluster.

The axes are the netlist's ``.step`` cards and the ``--step NAME=SPEC``
options (``SPEC``: ``start:stop:incr``, ``dec:points:start:stop``,
``oct:points:start:stop`` or a comma list ``v1,v2,...``; numbers with SPICE
suffixes); ``--mc N`` runs N Monte Carlo samples per point. Writes into
``--out DIR``: ``measures.csv`` and ``measures.json`` (one row per
simulation, see :mod:`netdae.io.sweep`), ``waveforms.npz`` with
``--waveforms``, and ``sweep.png`` (measure histograms for Monte Carlo, a
family of curves for steps). Prints a summary of each measure on stdout.

``--workers N`` local processes (default: the available cores);
``--scheduler ADDRESS`` runs on a Dask cluster (``tcp://host:8786``; needs
``pip install 'netdae[dask]'``). Ctrl-C keeps the finished rows: they are
written, the others marked not run, and the exit status is 130.
"""

from __future__ import annotations

import argparse
import json
import logging
import math
import sys
import time
from pathlib import Path

from . import (add_max_elements, add_ngbehavior, directory_name, log_diagnostics, option_value, output_directory,
               saved_names)

__all__ = ["add_parser", "main", "parse_step"]

LOG = logging.getLogger("netdae")
#: ``--analysis``: netdae.sweeps.worker.SWEPT_ANALYSES, written out here because building the parser imports no
#: numerics (``netdae --help``); tests/test_sweep.py holds the two equal.
ANALYSES = ("op", "dc", "ac", "tran", "noise")
#: Seconds to wait for a Dask scheduler before saying it cannot be reached.
SCHEDULER_TIMEOUT = 10.0


def _number(text: str) -> float:
    """A ``--step`` number, read as a netlist's (``4.7k``, ``1meg``); one the netlist reader would refuse or warn
    about (``1e999``, ``1e-999`` that reads as 0, ``1k2`` whose ``2`` is ignored) is refused here."""
    from ..netlist.numbers import ignored_text, parse_number, underflows

    token = text.strip().lower()
    value = parse_number(token)
    if value is None:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}")
    if not math.isfinite(value) or (value == 0.0 and underflows(token)):
        raise argparse.ArgumentTypeError(f"{text.strip()!r} is out of range (beyond a double)")
    ignored = ignored_text(token)
    if ignored:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r} ('{ignored}' after the number would "
                                         "be ignored)")
    return value


def parse_step(text: str) -> tuple[str, list[float]]:
    """An argparse type: ``NAME=SPEC`` as (name, values).

    Examples
    --------
    >>> parse_step("R=1k:3k:1k")
    ('r', [1000.0, 2000.0, 3000.0])
    >>> parse_step("c1=1n,4.7n")[1]
    [1e-09, 4.7e-09]
    >>> [round(v, 3) for v in parse_step("f=dec:2:1:100")[1]]
    [1.0, 3.162, 10.0, 31.623, 100.0]
    """
    from ..netlist.steps import grid

    name, sep, spec = text.partition("=")
    name = name.strip().lower()
    if not sep or not name or not spec.strip():
        raise argparse.ArgumentTypeError(f"expected NAME=SPEC (e.g. r1=1k:10k:1k), got {text!r}")
    parts = [p.strip() for p in spec.split(":")]
    try:
        if len(parts) == 1:
            return name, [_number(v) for v in parts[0].split(",")]
        if len(parts) == 3:
            return name, grid("lin", _number(parts[0]), _number(parts[1]), _number(parts[2])).tolist()
        if len(parts) == 4 and parts[0].lower() in ("dec", "oct", "lin"):
            kind = parts[0].lower()
            if kind == "lin":
                return name, grid("lin", _number(parts[1]), _number(parts[2]), _number(parts[3])).tolist()
            return name, grid(kind, _number(parts[2]), _number(parts[3]), _number(parts[1])).tolist()
    except (ValueError, argparse.ArgumentTypeError) as exc:  # a bad number too: say which --step it is in
        raise argparse.ArgumentTypeError(f"{text}: {exc}") from None
    raise argparse.ArgumentTypeError(f"{text}: expected start:stop:incr, dec:points:start:stop, "
                                     "oct:points:start:stop or v1,v2,...")


def _integer(minimum: int, what: str):
    """An argparse type: an integer >= ``minimum``."""

    def convert(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            value = None
        if value is None or value < minimum:
            raise argparse.ArgumentTypeError(f"expected {what}, got {text!r}")
        return value

    convert.__name__ = what  # argparse names the type in its messages
    return convert


_count = _integer(1, "a positive integer")


def _seed(text: str) -> int:
    """An argparse type: a Monte Carlo seed (:func:`netdae.netlist.montecarlo.seed_problem`)."""
    from ..netlist.montecarlo import seed_problem

    try:
        value = int(text)
    except ValueError:
        value = None
    if value is None or seed_problem(value) is not None:
        raise argparse.ArgumentTypeError(seed_problem(value if value is not None else text))
    return value


def add_parser(sub) -> argparse.ArgumentParser:
    p = sub.add_parser(
        "sweep",
        help="run a netlist over parameter steps and Monte Carlo samples",
        description="Run the netlist for every combination of its .step cards and --step values, "
        "optionally with Monte Carlo samples, and write a table of its measurements.",
    )
    p.add_argument("file", help="netlist file")
    p.add_argument("--out", metavar="DIR", type=directory_name, required=True, help="write measures.csv/.json and sweep.png into DIR")
    p.add_argument("--step", metavar="NAME=SPEC", action="append", type=parse_step, default=[],
                   help="step a top-level .param, an element or temp: start:stop:incr, "
                   "dec:points:start:stop, oct:points:start:stop or v1,v2,... (repeatable: all combinations)")
    p.add_argument("--mc", metavar="N", type=_count, help="Monte Carlo samples per point")
    p.add_argument("--seed", type=_seed, help="Monte Carlo seed, 0 to 2**64-1 (default .options seed=, else 1)")
    p.add_argument("--meas", metavar="CARD", action="append", default=[],
                   help="one more .meas card, e.g. 'tran ripple pp v(out) from=5m to=10m' (repeatable)")
    p.add_argument("--analysis", metavar="NAME", action="append", choices=ANALYSES,
                   help="run only this analysis of the netlist (repeatable; default all)")
    p.add_argument("--save", metavar="SIGNALS", type=saved_names,
                   help="comma-separated signals whose waveforms every row keeps (for --waveforms and the plot)")
    p.add_argument("--waveforms", action="store_true", help="write the saved waveforms to waveforms.npz")
    p.add_argument("--no-plot", dest="plot", action="store_false", help="do not write sweep.png")
    p.add_argument("--json", action="store_true", help="print the summary as JSON")
    group = p.add_mutually_exclusive_group()
    group.add_argument("--workers", type=_count, help="local worker processes (default: the available cores)")
    group.add_argument("--scheduler", metavar="ADDRESS",
                       help="run on a Dask cluster (e.g. tcp://127.0.0.1:8786; needs netdae[dask])")
    p.add_argument("--rtol", "--reltol", dest="reltol", type=option_value("reltol"),
                   help="relative tolerance, between 0 and 1 (overrides .options reltol)")
    p.add_argument("--abstol", type=option_value("abstol"), help="absolute current tolerance [A], positive")
    p.add_argument("--vntol", type=option_value("vntol"), help="absolute voltage tolerance [V], positive")
    add_ngbehavior(p)
    add_max_elements(p)
    return p


def _dask_executor(address: str):
    """A Dask client's executor, or a NetdaeError saying why there is none."""
    from ..errors import NetdaeError

    try:
        from distributed import Client
    except ImportError:
        raise NetdaeError("--scheduler needs Dask's 'distributed', which is not installed: "
                          "pip install 'netdae[dask]'") from None
    hint = "(hint: give the scheduler's address as Dask prints it, e.g. tcp://host:8786)"
    if not address.strip():
        raise NetdaeError(f"--scheduler: the address is empty {hint}")
    try:
        client = Client(address, timeout=f"{SCHEDULER_TIMEOUT}s")
    except (OSError, TimeoutError) as exc:
        raise NetdaeError(f"cannot reach the Dask scheduler at {address}: {exc} (hint: start one there "
                          "('dask scheduler' prints its address) and check the host and port, or leave out "
                          "--scheduler to run on this machine's cores)") from None
    except ValueError as exc:  # distributed's word for an address it cannot read ('foo': no port)
        raise NetdaeError(f"--scheduler {address!r} is not an address Dask can read: {exc} {hint}") from None
    return client, client.get_executor()


def _rescue(result, waveforms: bool, exc) -> list[str]:
    """The rows' files written to a fresh temporary directory when ``--out`` could not take them.

    A sweep's rows are hours of computation and the summary printed is not
    them: when ``--out`` fills up (or stops taking files) after the rows ran,
    the same files go to the system's temporary directory, another file system
    more often than not, and the log says where. Nothing is written there when
    that fails too (the original error is raised either way).
    """
    import tempfile

    from ..errors import OutputFileError
    from ..io.sweep import write_sweep

    try:
        folder = Path(tempfile.mkdtemp(prefix="netdae-sweep-"))
    except OSError:
        return []
    try:
        files = write_sweep(folder, result, waveforms=waveforms)
    except OutputFileError:
        return []
    LOG.warning("%s; the rows were written to %s instead", exc, folder)
    return files


class _Progress:
    """``[####......] 40/100 rows`` on a terminal, after a second."""

    def __init__(self, enabled: bool) -> None:
        self.enabled = enabled and sys.stderr.isatty()
        self.start = time.perf_counter()
        self.shown = False

    def __call__(self, done: int, total: int) -> None:
        if not self.enabled or time.perf_counter() - self.start < 1.0:
            return
        filled = int(30 * done / max(total, 1))
        sys.stderr.write(f"\r[{'#' * filled}{'.' * (30 - filled)}] {done}/{total} rows ")
        sys.stderr.flush()
        self.shown = True

    def close(self) -> None:
        if self.shown:
            sys.stderr.write("\r" + " " * 60 + "\r")
            sys.stderr.flush()


def main(args) -> int:
    from ..errors import NetdaeError, OutputFileError
    from ..io.sweep import write_sweep
    from ..netlist import load
    from ..sweeps import sweep

    seen: set[str] = set()
    for name, _ in args.step:  # a name stepped twice: one of the two would be dropped without a word
        if name in seen:
            raise NetdaeError(f"--step {name} is given twice (hint: give all its values in one --step, e.g. "
                              "r1=1k,2k,3k,4k)")
        seen.add(name)
    circuit = load(args.file, behavior=args.ngbehavior, max_elements=args.max_elements)
    log_diagnostics(circuit)
    out = output_directory(args.out)  # before the rows run: a bad --out is not found after hours
    executor, client = None, None
    if args.scheduler is not None:
        client, executor = _dask_executor(args.scheduler)
    bar = _Progress(args.verbosity >= 0)
    interrupted = None
    try:
        result = sweep(circuit, params=dict(args.step) or None, samples=args.mc, seed=args.seed,
                       analyses=args.analysis, save=args.save, measures=args.meas, executor=executor,
                       workers=args.workers, reltol=args.reltol, abstol=args.abstol, vntol=args.vntol,
                       progress=bar)
    except KeyboardInterrupt as exc:
        result = getattr(exc, "result", None)
        if result is None:
            raise
        interrupted = exc
    finally:
        bar.close()
        if client is not None:
            client.close()
    files: list[str] = []
    write_error = None
    try:
        files = write_sweep(out, result, waveforms=args.waveforms)
    except OutputFileError as exc:  # a full disk: the summary and the notes are still printed, then the error
        write_error = exc
        files = _rescue(result, args.waveforms, exc)
    if args.plot and write_error is None:
        from ..plotting import plot_sweep, save_figure

        try:
            files.append(str(save_figure(plot_sweep(result, title=circuit.title), out / "sweep.png", dpi=110)))
        except NetdaeError as exc:
            LOG.info("note: no plot: %s", exc)
    summary = result.summary()
    if args.json:
        from ..comparison.model import jsonable

        # JSON has no NaN: a statistic of a measure that failed in every row is null, as in measures.json
        json.dump(jsonable({"rows": result.rows, "failed": result.failed, "failures": result.failures(),
                            "measure_failures": result.measure_failures(), "seed": result.seed,
                            "summary": summary, "stats": {k: v for k, v in result.stats.items()}, "files": files}),
                  sys.stdout, indent=2, default=float, allow_nan=False)
        sys.stdout.write("\n")
    else:
        print(circuit.title)
        workers = result.stats['workers']
        print(f"{result.rows} rows ({result.stats['executor']}, {workers} worker{'' if workers == 1 else 's'}, "
              f"{result.stats['wall_time']:.3g} s); {result.failed} failed; seed {result.seed}")
        if summary:
            width = max(len(n) for n in summary)
            print(f"{'measure':<{width}}  {'count':>6}  {'mean':>12}  {'std':>10}  {'min':>12}  {'max':>12}")
            for name, s in summary.items():
                print(f"{name:<{width}}  {s['count']:>6}  {s['mean']:>12.6g}  {s['std']:>10.4g}  "
                      f"{s['min']:>12.6g}  {s['max']:>12.6g}")
    for note in result.notes:
        where, warned, message = note.partition("warning: ")  # a warning, located or not ("FILE:L:C: warning: ")
        if warned and (not where or where.endswith(": ")):
            LOG.warning("%s%s", where, message)
        else:
            LOG.warning("%s", note) if "failed" in note else LOG.info("note: %s", note)
    for path in files:
        LOG.info("wrote %s", path)
    if write_error is not None:
        raise write_error
    if interrupted is not None:
        from . import interruption

        word, status = interruption(interrupted)
        completed = result.stats.get("completed", 0)
        LOG.error("%s: %d of %d rows finished, %d not run", word, completed, result.rows, result.rows - completed)
        return status
    return 0 if result.failed == 0 else 1
