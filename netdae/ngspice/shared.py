"""ngspice's shared library in this process, through PySpice's binding.

This is the only module of netdae that imports PySpice. It uses PySpice 1.5
for what it does well -- finding and loading ``libngspice``, declaring its C
API to cffi, registering the callbacks -- and replaces the parts that do not
fit ngspice 39:

- PySpice treats every stderr line that does not start with ``Warning:`` as
  an error and raises on the next command, so ngspice's harmless notes
  (``Note: v1: dc value used for op ...``) would fail every run. netdae's
  subclass records ngspice's lines as they come and leaves the judgement to
  :func:`netdae.ngspice.translate.classify_output`.
- PySpice 1.5 knows ngspice up to version 34 and logs "Unsupported Ngspice
  version"; netdae reads the version itself (``version -f``) and keeps
  PySpice's log records out of the user's console (they become notes).
- Vectors are read with ``ngGet_Vec_Info`` directly (type, real or complex,
  length) rather than through PySpice's unit-carrying waveforms.
- PySpice names the library ``libngspice.so``, which only the ``-dev``
  package provides; netdae asks the dynamic loader for ``libngspice.so.0``
  too.

ngspice's library reads ``.spiceinit`` (commands) when it is initialised:
from the current directory, else from the user's home directory (taken from
the password database, not ``$HOME``; ``src/sharedspice.c``, ngspice 39).
netdae initialises it with a private temporary directory as the current
directory, holding an empty ``.spiceinit`` of its own, so neither the
directory the user works in nor the home directory is consulted;
``HOME`` points there too and ``SPICE_USERINIT_DIR`` is unset meanwhile.
Each run then takes place with a fresh private temporary directory as the
current directory (anything ngspice writes, e.g. a BSIM model check's log,
lands there and is removed). The current directory is a property of the
process: it is changed only while the lock is held and restored at once.
A run in one of ngspice's compatibility modes sets the variable ``ngbehavior``
by command before its circuit is loaded (what a ``.spiceinit`` holding ``set
ngbehavior=...`` would have set; ngspice reads it for every circuit it loads)
and unsets it afterwards.

The library is a process-wide singleton with global state, so runs are
serialised by a lock and each one starts clean: ``destroy all`` (every plot
of earlier runs), load the circuit, ``bg_run`` (the background thread, so a
timeout can halt it), collect the plots, ``remcirc``. A library that has
called its exit callback cannot be used again in this process: later runs
raise :class:`~netdae.ngspice.BackendUnavailable`, and ``backend="auto"``
runs the subprocess instead.
"""

from __future__ import annotations

import contextlib
import ctypes.util
import logging
import os
import re
import sys
import tempfile
import threading
import time

import numpy as np

from ..errors import NgspiceError
from ..io.raw import PLOTNAME_OF, complex_from_parts, quantity_name, sens_name, signal_name
from ..metadata import NoiseInfo, Provenance
from ..results import Result
from . import INSTALL_HINT, BackendOutput, BackendUnavailable
from .batch import spiceinit
from .deck import SCRIPT_MARK
from .translate import classify_output

__all__ = ["run", "version", "library_path"]

#: ngspice's ``enum simulation_types`` (``src/include/ngspice/sim.h``): the
#: type names of the vectors netdae reads.
_VECTOR_TYPES = {0: "notype", 1: "time", 2: "frequency", 3: "voltage", 4: "current"}
#: ngspice names plots ``tran1``, ``ac2`` ...: the analysis is the prefix.
_PLOT_PREFIX = re.compile(r"^([a-z]+)\d*$")
_ANALYSIS_OF_PREFIX = {"op": "op", "tran": "tran", "ac": "ac", "dc": "dc", "pz": "pz", "tf": "tf", "noise": "noise",
                       "sens": "sens"}
_AXIS_OF = {"tran": ("time",), "ac": ("frequency",), "noise": ("frequency",), "sens": ("frequency",), "dc": ("v-sweep", "i-sweep", "res-sweep", "temp-sweep")}
#: Seconds to wait for ngspice's background thread to stop after ``bg_halt``.
_HALT_WAIT = 10.0
#: Polling interval while waiting for the halted thread [s].
_HALT_POLL = 0.01
_VERSION = re.compile(r"ngspice-(\S+)")
#: Prefix of the private temporary directories ngspice runs in.
_TMP_PREFIX = "netdae-ngspice-"
#: Content of the empty ``.spiceinit`` that stands in for the user's.
_EMPTY_SPICEINIT = "* netdae: an empty ngspice start-up file (the user's .spiceinit is not read)\n"

_lock = threading.Lock()
_session = None  # the one _Session of this process, once created
_session_error: str | None = None  # why it could not be created, once tried


def library_path() -> str | None:
    """The ngspice shared library to load, or None when there is none.

    ``NGSPICE_LIBRARY_PATH`` (PySpice's variable) wins; otherwise the dynamic
    loader's name for ``libngspice`` (``libngspice.so.0`` on Debian).
    """
    env = os.environ.get("NGSPICE_LIBRARY_PATH")
    if env:
        return env
    return ctypes.util.find_library("ngspice")


class _Session:
    """The loaded library, its callbacks' record, and the lock-step protocol."""

    def __init__(self, path: str) -> None:
        with tempfile.TemporaryDirectory(prefix=_TMP_PREFIX) as private:
            with open(os.path.join(private, ".spiceinit"), "w", encoding="utf-8") as handle:
                handle.write(_EMPTY_SPICEINIT)
            with _inside(private, home=True):
                self.library, self.pyspice_notes = _load(path)
        self.ffi = self.library.ffi
        self.api = self.library._ngspice_shared
        self.version = self._read_version()

    # -- commands ----------------------------------------------------------

    def command(self, text: str) -> None:
        if self.library.exit_status is not None:
            raise BackendUnavailable(
                f"ngspice's shared library exited (status {self.library.exit_status}) and cannot be reused "
                "in this process"
            )
        rc = self.api.ngSpice_Command(text.encode("utf-8"))
        if rc:
            raise BackendUnavailable(f"ngspice's shared library refused the command {text!r} (code {rc})")

    def _read_version(self) -> str:
        self.library.lines.clear()
        self.command("version -f")
        match = _VERSION.search("\n".join(text for _, text in self.library.lines))
        if match is None:
            raise BackendUnavailable("ngspice's shared library does not say which version it is")
        return f"ngspice-{match.group(1)}"

    # -- a run ---------------------------------------------------------------

    def run(self, netlist: str, timeout: float | None, ngbehavior: str | None = None) -> BackendOutput:
        with tempfile.TemporaryDirectory(prefix=_TMP_PREFIX) as private, _inside(private):
            if ngbehavior is None:
                return self._run(netlist, timeout)
            spiceinit(ngbehavior)  # (checks the value)
            self.command(f"set ngbehavior={ngbehavior}")  # what the private .spiceinit would set
            try:
                return self._run(netlist, timeout)
            finally:
                if self.library.exit_status is None:
                    self.command("unset ngbehavior")

    def _run(self, netlist: str, timeout: float | None) -> BackendOutput:
        lib = self.library
        self.command("destroy all")
        lib.lines.clear()
        lib.finished.clear()
        try:
            circuit, commands = _split_script(netlist)
            self._load(circuit)
            stderr = [text for stream, text in lib.lines if stream == "stderr"]
            errors, _ = classify_output(stderr, [], strict=False)
            if not errors:
                deadline = None if timeout is None else time.monotonic() + timeout
                for command in commands or ["run"]:
                    # ngspice lowercases a deck's control lines as it reads them (its names are lower case),
                    # not the commands given to the library: 'dc VIN 0 10 5' found no source VIN
                    command = command.lower()
                    if command.split()[0] in _SCRIPT_ANALYSES:
                        self._background(command, deadline, timeout)
                    else:
                        self.command(command)
            return BackendOutput(
                results=[] if errors else self._collect(netlist),
                stdout=[text for stream, text in lib.lines if stream != "stderr"],
                stderr=[text for stream, text in lib.lines if stream == "stderr"],
                version=self.version,
            )
        finally:
            if lib.exit_status is None:
                self._clean()

    def _background(self, command: str, deadline: float | None, timeout: float | None) -> None:
        """Run ``command`` in ngspice's background thread (``bg_...``) and wait for it, up to ``deadline``."""
        lib = self.library
        lib.finished.clear()
        self.command("bg_" + command)
        try:
            finished = lib.finished.wait(None if deadline is None else max(deadline - time.monotonic(), 0.0))
        except KeyboardInterrupt:  # Ctrl-C: ngspice's thread stops before its circuit is removed below
            with contextlib.suppress(BackendUnavailable):  # (or the process exits: a crash, status -11)
                self._halt()
            raise
        if not finished:
            self._halt()
            raise NgspiceError(f"ngspice did not finish within {timeout:g} s (it was halted)")
        if lib.exit_status is not None:
            raise BackendUnavailable(f"ngspice's shared library exited with status {lib.exit_status}")

    def _load(self, netlist: str) -> None:
        ffi = self.ffi
        # ngSpice_Circ wants a NULL-terminated array of lines; ngspice >= 33
        # also wants an empty last line.
        keep = [ffi.new("char[]", line.encode("utf-8")) for line in [*netlist.splitlines(), ""]]
        lines = ffi.new("char *[]", [*keep, ffi.NULL])
        rc = self.api.ngSpice_Circ(lines)
        if rc or self.library.exit_status is not None:
            raise BackendUnavailable(f"ngspice's shared library could not take the circuit (code {rc})")

    def _halt(self) -> None:
        self.command("bg_halt")
        deadline = time.monotonic() + _HALT_WAIT
        while self.api.ngSpice_running() and time.monotonic() < deadline:
            time.sleep(_HALT_POLL)
        if self.api.ngSpice_running():
            self.library.exit_status = -1  # a thread that does not stop: never reuse
            raise BackendUnavailable("ngspice's background thread does not stop after bg_halt")

    def _clean(self) -> None:
        self.command("remcirc")
        self.command("destroy all")

    def _strings(self, array) -> list[str]:
        """The strings of a NULL-terminated ``char **``; none for a NULL array (ngSpice_AllVecs of a plot without
        vectors: a .pz of a circuit without poles or zeros)."""
        out: list[str] = []
        if array == self.ffi.NULL:
            return out
        index = 0
        while array[index] != self.ffi.NULL:
            out.append(self.ffi.string(array[index]).decode("utf-8", "replace"))
            index += 1
        return out

    def _collect(self, netlist: str) -> list[Result]:
        """The plots of this run, oldest first, as Results."""
        plots = [p for p in self._strings(self.api.ngSpice_AllPlots()) if p != "const"]
        title = netlist.splitlines()[0].strip() if netlist.strip() else ""
        results: list[Result] = []
        for plot in reversed(plots):
            res = self._plot(plot, title)
            if res.analysis == "noise" and not res.axes:  # noise2 ...: the integrated noise of the plot before
                if results and results[-1].analysis == "noise" and results[-1].noise is None:
                    results[-1].noise = NoiseInfo(totals={k: float(v[0]) for k, v in res.signals.items()})
                    continue
                raise NgspiceError(f"ngspice plot '{plot}' (integrated noise) does not follow its noise spectra")
            results.append(res)
        return results

    def _plot(self, plot: str, title: str) -> Result:
        match = _PLOT_PREFIX.match(plot)
        analysis = _ANALYSIS_OF_PREFIX.get(match.group(1) if match else "")
        if analysis is None:
            raise NgspiceError(
                f"ngspice plot '{plot}' is not an analysis netdae reads (it reads: op, dc, ac, tran, pz, tf, noise, sens)"
            )
        # ngspice lists the newest vector first: reversed, that is creation
        # order, the order of the raw file.
        names = list(reversed(self._strings(self.api.ngSpice_AllVecs(plot.encode("utf-8")))))
        axes: dict[str, np.ndarray] = {}
        signals: dict[str, np.ndarray] = {}
        types: dict[str, str] = {}
        for name in names:
            vtype, data = self._vector(f"{plot}.{name}")
            if name.lower() in _AXIS_OF.get(analysis, ()):
                key = name.lower()
                axes[key] = data.real.copy() if np.iscomplexobj(data) else data
            else:
                if analysis == "sens":
                    key = sens_name(name)
                else:
                    key = quantity_name(name) if analysis in ("pz", "tf", "noise") else signal_name(name, vtype)
                signals[key] = data
            types[key] = vtype
        source = Provenance(title=title, plotname=PLOTNAME_OF[analysis], plot=plot, variable_types=types)
        return Result(analysis, axes=axes, signals=signals, source=source)

    def _vector(self, name: str) -> tuple[str, np.ndarray]:
        info = self.api.ngGet_Vec_Info(name.encode("utf-8"))
        if info == self.ffi.NULL:
            raise NgspiceError(f"ngspice's shared library lists vector {name!r} but cannot return it")
        length = info.v_length
        vtype = _VECTOR_TYPES.get(info.v_type, "notype")
        if info.v_compdata != self.ffi.NULL:
            pairs = np.frombuffer(self.ffi.buffer(info.v_compdata, length * 16), dtype=np.float64)
            return vtype, complex_from_parts(pairs[0::2], pairs[1::2])  # an ac scale's imaginary part may be inf
        if length == 0:
            return vtype, np.zeros(0)
        return vtype, np.frombuffer(self.ffi.buffer(info.v_realdata, length * 8), dtype=np.float64).copy()


#: The commands run in ngspice's background thread: ``run`` (a netlist's dot analyses) and the analyses of
#: netdae's control block.
_SCRIPT_ANALYSES = frozenset({"run", "op", "tran", "ac", "dc", "pz", "tf", "noise", "sens"})


def _split_script(netlist: str) -> tuple[str, list[str]]:
    """The netlist without netdae's control block (:func:`netdae.ngspice.deck.script_block`), and the
    block's commands to send one by one (its ``write``, ``set appendwrite`` and ``quit`` left out: the plots are
    read from memory); no commands for a netlist without one.

    >>> _split_script("t\\nR1 1 0 1\\n.control\\n" + SCRIPT_MARK + "\\nset appendwrite\\nop\\nwrite out.raw\\n"
    ...               "alter r1 = 2.0\\nop\\nwrite out.raw\\nquit\\n.endc\\n.end")
    ('t\\nR1 1 0 1\\n.end', ['op', 'alter r1 = 2.0', 'op'])
    """
    lines = netlist.split("\n")
    if SCRIPT_MARK not in lines:
        return netlist, []
    start = lines.index(SCRIPT_MARK) - 1
    end = lines.index(".endc", start)
    commands = [c for c in lines[start + 2: end] if c not in ("set appendwrite", "quit") and not c.startswith("write ")]
    return "\n".join(lines[:start] + lines[end + 1:]), commands


@contextlib.contextmanager
def _inside(directory: str, *, home: bool = False):
    """Make ``directory`` the process's current directory (and ``HOME``) for a while."""
    saved_env = {name: os.environ.get(name) for name in ("HOME", "SPICE_USERINIT_DIR")}
    try:
        previous = os.getcwd()
    except OSError:  # the current directory was removed: there is nothing to return to
        previous = None
    os.chdir(directory)
    if home:
        os.environ["HOME"] = directory
        os.environ.pop("SPICE_USERINIT_DIR", None)
    try:
        yield
    finally:
        if previous is not None:
            os.chdir(previous)
        if home:
            for name, value in saved_env.items():
                if value is None:
                    os.environ.pop(name, None)
                else:
                    os.environ[name] = value


def _load(path: str):
    """Load the library through a PySpice subclass; returns (library, notes)."""
    try:
        from PySpice.Spice.NgSpice import Shared as pyspice_shared
    except Exception as exc:  # ImportError, or PySpice failing at import time
        raise BackendUnavailable(f"PySpice cannot be imported ({type(exc).__name__}: {exc})") from None

    ffi = pyspice_shared.ffi
    pyspice_version = getattr(sys.modules.get("PySpice"), "__version__", "?")

    class _Library(pyspice_shared.NgSpiceShared):
        """PySpice's binding with callbacks that record instead of judging."""

        LIBRARY_PATH = path

        def __init__(self) -> None:
            self.ffi = ffi
            self.lines: list[tuple[str, str]] = []
            self.finished = threading.Event()
            self.exit_status: int | None = None
            super().__init__(ngspice_id=0, send_data=False)

        @staticmethod
        def _send_char(message, ngspice_id, user_data):
            self = ffi.from_handle(user_data)
            stream, _, text = ffi.string(message).decode("utf-8", "replace").partition(" ")
            self.lines.append((stream, text))
            # PySpice reads its own record of stdout for the version check
            (self._stderr if stream == "stderr" else self._stdout).append(text)
            return 0

        @staticmethod
        def _exit(status, immediate_unload, quit_exit, ngspice_id, user_data):
            self = ffi.from_handle(user_data)
            self.exit_status = int(status)
            self.finished.set()
            return int(status)

        @staticmethod
        def _background_thread_running(not_running, ngspice_id, user_data):
            # ngspice passes True when its background thread has *stopped*
            self = ffi.from_handle(user_data)
            if not_running:
                self.finished.set()
            return 0

    records: list[logging.LogRecord] = []
    handler = _ListHandler(records)
    logger = logging.getLogger("PySpice")
    propagate = logger.propagate
    logger.addHandler(handler)
    logger.propagate = False
    try:
        library = _Library()
    except OSError as exc:
        raise BackendUnavailable(f"cannot load {path}: {exc}") from None
    except Exception as exc:  # cffi or PySpice failing on this library
        raise BackendUnavailable(f"PySpice cannot initialise {path} ({type(exc).__name__}: {exc})") from None
    finally:
        logger.removeHandler(handler)
        logger.propagate = propagate
    notes = [
        f"PySpice {pyspice_version}: {r.getMessage()} (netdae uses only its library loading, commands and "
        "callbacks, and reads versions and vectors itself)"
        for r in records
        if r.levelno >= logging.WARNING
    ]
    return library, notes


class _ListHandler(logging.Handler):
    def __init__(self, records: list[logging.LogRecord]) -> None:
        super().__init__(logging.DEBUG)
        self.records = records

    def emit(self, record: logging.LogRecord) -> None:
        self.records.append(record)


def _get_session() -> _Session:
    """The process's session, created on first use (call with the lock held)."""
    global _session, _session_error
    if _session is None:
        if _session_error is not None:
            raise BackendUnavailable(_session_error)
        path = library_path()
        if path is None:
            _session_error = f"ngspice's shared library is not installed (install it with: {INSTALL_HINT})"
            raise BackendUnavailable(_session_error)
        try:
            _session = _Session(path)
        except BackendUnavailable as exc:
            _session_error = str(exc)
            raise
    return _session


def version() -> str:
    """``"ngspice-39"``, from the shared library's ``version -f``."""
    with _lock:
        return _get_session().version


def run(netlist: str, *, timeout: float | None, ngbehavior: str | None = None) -> BackendOutput:
    """Run a netlist in the shared library.

    Parameters
    ----------
    netlist : str
        The (translated) netlist.
    timeout : float or None
        Seconds before the background thread is halted (None: no limit).
    ngbehavior : str, optional
        ngspice's compatibility mode for this run: the variable the private ``.spiceinit``
        of :func:`netdae.ngspice.batch.spiceinit` sets, set by command before the circuit is
        loaded (the library read its start-up file once, when it was loaded) and unset after.

    Returns
    -------
    BackendOutput
        ngspice's lines, and the results when loading reported no error.

    Raises
    ------
    BackendUnavailable
        When the library cannot be loaded or has exited.
    NgspiceError
        On a timeout.
    """
    with _lock:
        session = _get_session()
        output = session.run(netlist, timeout, ngbehavior)
        output.notes, session.pyspice_notes = session.pyspice_notes, []
        return output
