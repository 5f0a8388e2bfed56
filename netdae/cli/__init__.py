"""The ``netdae`` command line: ``netdae check | index | run | sweep | compare | demo | osdi | server``.

Each subcommand lives in its own module of this package with two functions,
``add_parser(subparsers)`` and ``main(args) -> int``. Modules import the
numerical parts of netdae inside ``main`` so that ``netdae --help`` stays fast.

Results (tables, reports, JSON) go to stdout; diagnostics (notes, files
written, errors) go to stderr through the ``logging`` logger ``"netdae"``,
whose level every subcommand's ``-q`` (warnings and errors only) and ``-v``
(also timings and sizes) set.

Errors: a bad command-line value is a usage error (argparse's message, exit
status 2); every :class:`netdae.errors.NetdaeError` and every file that
cannot be read or written becomes one readable line on stderr and exit
status 2; a bug inside netdae is reported as an internal error in one line
(set ``NETDAE_DEBUG=1`` for the traceback), exit status 3.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import logging
import math
import os
import sys

__all__ = ["main", "parser", "COMMANDS", "LOG", "signal_names", "option_value", "positive_float", "add_verbosity",
           "output_directory", "positive_count", "add_max_elements"]

#: Subcommands in the order ``--help`` lists them.
COMMANDS = ("check", "index", "run", "sweep", "compare", "demo", "osdi", "server")

EXIT_OK = 0
EXIT_FAIL = 1  # the command ran and its verdict is negative (e.g. compare out of tolerance)
EXIT_ERROR = 2  # bad input or a netdae error
EXIT_INTERNAL = 3  # a bug in netdae

#: The command line's logger: diagnostics (notes, files written, errors) go to
#: stderr through it; results (tables, reports, JSON) are printed on stdout.
LOG = logging.getLogger("netdae")

#: Logging level per verbosity: ``-q`` warnings and errors only, default also
#: notes and written files, ``-v`` also timings and sizes.
LEVELS = {-1: logging.WARNING, 0: logging.INFO, 1: logging.DEBUG}


def log_diagnostics(circuit) -> None:
    """Log what reading a netlist noted: its warnings as warnings (shown with ``-q`` too), its notes as notes."""
    for d in circuit.diagnostics:
        where = f"{d.location}: " if d.location else ""
        if d.severity == "warning":
            LOG.warning("%s%s", where, d.message)
        else:
            LOG.info("%snote: %s", where, d.message)


class _StderrHandler(logging.StreamHandler):
    """Writes to the current ``sys.stderr`` after flushing stdout, so both streams keep their order."""

    def __init__(self) -> None:
        super().__init__(sys.stderr)

    def emit(self, record: logging.LogRecord) -> None:
        self.setStream(sys.stderr)
        try:
            sys.stdout.flush()
        except (OSError, ValueError):
            pass
        super().emit(record)


class _Formatter(logging.Formatter):
    """``note``-style info lines as written; ``netdae: warning: ...`` above."""

    def format(self, record: logging.LogRecord) -> str:
        text = record.getMessage()
        if record.levelno >= logging.CRITICAL:
            return f"netdae: internal error: {text}"
        if record.levelno >= logging.WARNING:
            return f"netdae: {record.levelname.lower()}: {text}"
        if record.levelno <= logging.DEBUG:
            return f"netdae: debug: {text}"
        return text


def _configure_logging(verbosity: int) -> None:
    for handler in [h for h in LOG.handlers if isinstance(h, _StderrHandler)]:
        LOG.removeHandler(handler)
    handler = _StderrHandler()
    handler.setFormatter(_Formatter())
    LOG.addHandler(handler)
    LOG.setLevel(LEVELS[max(-1, min(1, verbosity))])
    LOG.propagate = False


def add_verbosity(parser: argparse.ArgumentParser) -> None:
    """Give a (sub)command ``-q/--quiet`` and ``-v/--verbose``."""
    group = parser.add_mutually_exclusive_group()
    group.add_argument("-q", "--quiet", dest="verbosity", action="store_const", const=-1,
                       help="print results and errors only (no notes, no progress bar)")
    group.add_argument("-v", "--verbose", dest="verbosity", action="store_const", const=1,
                       help="also print timings and sizes on stderr")


# -- argument types: a bad value is a usage error (exit status 2) -----------------------
def signal_names(text: str) -> list[str]:
    """An argparse type: a comma-separated signal list, each name in its canonical spelling.

    >>> signal_names("V(out), v(in,minus),i(V1), v(a, gnd)")
    ['v(out)', 'v(in,minus)', 'i(v1)', 'v(a)']
    """
    from ..signals import canonical, split_signals

    try:
        return [canonical(name) for name in split_signals(text) or []]
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def saved_names(text: str) -> list[str]:
    """An argparse type: the signals ``--save`` keeps, as :func:`signal_names`, at least one.

    An empty list is refused: ``--save ,,`` kept every signal without a word.

    >>> saved_names("v(out),i(V1)")
    ['v(out)', 'i(v1)']
    """
    names = signal_names(text)
    if not names:
        raise argparse.ArgumentTypeError(f"expected signal names separated by commas, e.g. 'v(out),i(v1)', "
                                         f"got none in {text!r}")
    return names


def directory_name(text: str) -> str:
    """An argparse type: a directory name, not empty (``--out ""`` would write nothing and say nothing).

    >>> directory_name("out")
    'out'
    """
    if not text.strip():
        raise argparse.ArgumentTypeError("expected a directory name, got an empty one")
    return text


def _number(text: str) -> float:
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None


def option_value(name: str):
    """An argparse type for the simulator option ``name`` (range from :data:`~netdae.analyses.runner.OPTION_RANGES`)."""

    def convert(text: str) -> float:
        from ..analyses.runner import option_problem

        value = _number(text)
        problem = option_problem(name, value)
        if problem is not None:
            raise argparse.ArgumentTypeError(f"{problem}, got {text!r}")
        return value

    convert.__name__ = name  # argparse names the type in its messages
    return convert


def positive_float(text: str) -> float:
    """An argparse type: a positive, finite number."""
    value = _number(text)
    if not (math.isfinite(value) and value > 0.0):
        raise argparse.ArgumentTypeError(f"expected a positive number, got {text!r}")
    return value


def output_directory(path) -> "Path":
    """The ``--out DIR`` of a command, created now, before anything runs.

    Raises
    ------
    OutputFileError
        When ``path`` (or a part of it) is a file, or the directory cannot be
        created or does not take a file (no write permission, a read-only file
        system): said in words, naming the option, before a long run is lost
        to it.
    """
    import errno
    from pathlib import Path

    from ..errors import OutputFileError

    out = Path(path)
    if out.exists() and not out.is_dir():
        raise OutputFileError(str(out), "--out names a file, not a directory (hint: give a directory, "
                                        "which netdae creates if it does not exist)", errno.ENOTDIR)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except FileExistsError:  # a part of the path is a file
        raise OutputFileError(str(out), "a part of the path is a file, not a directory", errno.ENOTDIR) from None
    except NotADirectoryError:
        raise OutputFileError(str(out), "a part of the path is a file, not a directory", errno.ENOTDIR) from None
    except OSError as exc:
        raise OutputFileError(str(out), f"cannot create the --out directory: {exc.strerror or exc}",
                              exc.errno) from None
    import tempfile

    try:  # an existing directory this user cannot write into (or a read-only file system): found now, not after
        with tempfile.TemporaryFile(dir=out, prefix=".netdae-"):  # the run, as the files are written
            pass
    except OSError as exc:
        raise OutputFileError(str(out), f"the --out directory does not take files: {exc.strerror or exc} "
                              "(hint: give a directory you can write into)", exc.errno) from None
    return out


def add_ngbehavior(p: argparse.ArgumentParser) -> None:
    """The ``--ngbehavior VALUE`` option: ngspice's compatibility mode (:func:`netdae.load`'s ``behavior``)."""
    p.add_argument("--ngbehavior", metavar="VALUE", default=None,
                   help="ngspice's compatibility mode, as 'set ngbehavior=VALUE' in .spiceinit selects it: psa "
                        "(PSpice's idioms in every file), ps (in included files); '' for none (default: the "
                        "set ngbehavior line of the .spiceinit next to the netlist, else in the working directory)")


def positive_count(text: str) -> int:
    """An argparse type: a whole number of at least 1.

    >>> positive_count("600000")
    600000
    """
    try:
        value = int(text.replace("_", ""))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number, got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected a whole number of at least 1, got {text!r}")
    return value


def add_max_elements(p: argparse.ArgumentParser) -> None:
    """The ``--max-elements N`` option: the largest flat circuit read (:func:`netdae.load`'s ``max_elements``)."""
    p.add_argument("--max-elements", metavar="N", type=positive_count, default=None,
                   help="the largest expanded circuit read, in elements (netdae.load's max_elements; a netlist "
                        "above the default limit is refused with the count; about 2 kB of memory per element)")


def build_parser() -> argparse.ArgumentParser:
    """The top-level parser with every available subcommand registered."""
    from .. import __version__

    parser = argparse.ArgumentParser(
        prog="netdae",
        description="A SPICE-dialect circuit simulator that treats a netlist as a "
        "differential-algebraic equation.",
    )
    parser.add_argument("--version", action="version", version=f"netdae {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    for name in COMMANDS:
        try:
            module = importlib.import_module(f"{__name__}.{name}")
        except ModuleNotFoundError as exc:  # a subcommand not built into this tree
            if exc.name == f"{__name__}.{name}":
                continue
            raise
        p = module.add_parser(sub)
        add_verbosity(p)
        p.set_defaults(_main=module.main, verbosity=0)
    return parser


#: BLAS threads for the command line. netdae's dense work is small (pencils of
#: a few hundred unknowns) and its sparse LU is single-threaded; on small
#: machines BLAS threads only add contention (measured: a 200x200 SVD takes
#: 20 ms on one thread and 250 ms with two threads on a loaded 2-core machine).
#: A user's own setting of these variables wins.
BLAS_THREADS = "1"


def _limit_blas_threads() -> None:
    for var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(var, BLAS_THREADS)


_PARSER: argparse.ArgumentParser | None = None


def parser() -> argparse.ArgumentParser:
    """:func:`build_parser`'s parser, built once per process (a netdae server builds it before forking)."""
    global _PARSER
    if _PARSER is None:
        _PARSER = build_parser()
    return _PARSER


def main(argv: list[str] | None = None) -> int:
    """Run the command line; returns the exit status."""
    _limit_blas_threads()
    try:
        args = parser().parse_args(argv)
    except SystemExit as exc:  # --help, --version (0) or a usage error (2), already printed
        return exc.code if isinstance(exc.code, int) else EXIT_ERROR
    _configure_logging(args.verbosity)
    try:
        with _termination_as_interrupt():
            return _main(args)
    except Terminated as exc:  # SIGTERM or SIGHUP: what was computed was written, as on Ctrl-C
        word, status = interruption(exc)
        LOG.error("%s", word)
        return status


class Terminated(KeyboardInterrupt):
    """SIGTERM or SIGHUP, raised where Ctrl-C raises ``KeyboardInterrupt``.

    The command line treats them as Ctrl-C: a transient or a sweep writes what
    it computed, a sweep stops its workers; the exit status is 128 plus the
    signal's number.
    """

    def __init__(self, signum: int) -> None:
        super().__init__(signum)
        self.signum = int(signum)
        import signal

        self.name = signal.Signals(signum).name


def interruption(exc: KeyboardInterrupt) -> tuple[str, int]:
    """How a command reports ``exc``: ``("interrupted", 130)`` for Ctrl-C, ``("terminated (SIGTERM)", 143)``
    for a :class:`Terminated`."""
    if isinstance(exc, Terminated):
        return f"terminated ({exc.name})", 128 + exc.signum
    return "interrupted", 130


@contextlib.contextmanager
def _termination_as_interrupt():
    """SIGTERM and SIGHUP raise :class:`Terminated` in this process while the command runs.

    Only in the main thread and where the signal is not ignored (``nohup``); a
    process forked meanwhile (a sweep's pool worker) keeps the default action.
    """
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        yield
        return
    pid = os.getpid()

    def handler(signum, frame):
        if os.getpid() != pid:  # a forked child: die as it would have
            signal.signal(signum, signal.SIG_DFL)
            os.kill(os.getpid(), signum)
            return
        raise Terminated(signum)

    previous = {}
    for name in ("SIGTERM", "SIGHUP"):
        signum = getattr(signal, name, None)
        if signum is None or signal.getsignal(signum) == signal.SIG_IGN:
            continue
        previous[signum] = signal.signal(signum, handler)
    try:
        yield
    finally:
        for signum, old in previous.items():
            signal.signal(signum, old)


def _main(args) -> int:
    """Run the parsed command; errors become messages and exit statuses."""
    from ..errors import NetdaeError
    import numpy as np

    try:
        # numpy's floating-point warnings (an exp that overflows at .temp 1e6, a norm of 1e300 currents)
        # would print its own source lines on the terminal: netdae checks what it computes for finiteness
        # and says in words where a value is not finite, so the command line keeps them quiet
        with np.errstate(over="ignore", under="ignore", divide="ignore", invalid="ignore"):
            return int(args._main(args) or 0)
    except NetdaeError as exc:
        LOG.error("%s", exc)
        return EXIT_ERROR
    except OSError as exc:  # a file that cannot be read or written: the user's to fix
        if isinstance(exc, BrokenPipeError):
            return EXIT_OK
        if exc.filename is None and not isinstance(exc, NetdaeError) and exc.errno is not None:
            # a write to the standard output (`netdae run --json > /dev/full`): no file name to give
            from ..io.files import reason_of

            LOG.error("cannot write the output: %s", reason_of(exc))
            return EXIT_ERROR
        LOG.error("%s", exc)
        return EXIT_ERROR
    except Terminated:
        raise
    except KeyboardInterrupt:
        LOG.error("interrupted")
        return 130
    except MemoryError:  # an ordinary limit of the machine, not a bug
        LOG.error("out of memory (hint: save fewer signals with --save or .save, simulate a shorter interval, "
                  "or split the circuit)")
        return EXIT_ERROR
    except Exception as exc:  # noqa: BLE001 - the CLI never shows a traceback
        if os.environ.get("NETDAE_DEBUG"):
            raise
        LOG.critical("%s: %s (this is a bug in netdae; rerun with NETDAE_DEBUG=1 for the traceback)",
                     type(exc).__name__, exc)
        return EXIT_INTERNAL


def run() -> None:
    """Console-script entry point: through a warm netdae server when one runs, else here.

    See :mod:`netdae.server`: a running server for this installation takes the
    command (same arguments, directory, environment and streams) and saves the
    start-up; without one the command runs in this process, and a command that
    loaded the compiled engine then starts a server for the next ones.
    ``netdae server ...`` itself and ``NETDAE_SERVER=0`` always run here.
    """
    argv = sys.argv[1:]
    path = None
    _limit_blas_threads()  # before the server key, which covers these variables
    from ..server import wanted

    # --help, --version and `netdae server` run here; so does everything when the server is off
    if argv and not argv[0].startswith("-") and argv[0] != "server" and wanted():
        from ..server import client

        if client.enabled():
            path = client.socket_path()
        if path is not None:
            try:
                status = client.forward(argv, path)
            except client.RunStatus as exc:
                sys.stderr.write(f"netdae: error: {exc}\n")
                sys.exit(EXIT_FAIL)
            if status is not None:
                sys.exit(status)
    status = main(argv)
    if path is not None and "numba" in sys.modules:
        _start_server(path)
    sys.exit(status)


def _start_server(path: str) -> None:
    from ..server import client

    try:
        client.start(path)
    except OSError:  # no server this time: nothing is lost
        return
    if sys.stderr.isatty():
        minutes = client.idle_seconds() / 60.0
        sys.stderr.write(f"note: started a netdae server that keeps the engine loaded for the next commands "
                         f"(it exits after {minutes:g} idle minutes; NETDAE_SERVER=0 turns it off)\n")
