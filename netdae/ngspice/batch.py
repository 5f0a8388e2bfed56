"""ngspice as a subprocess: ``ngspice -b -n -r out.raw netlist.cir``.

The netlist and the raw file live in a fresh private temporary directory,
which is also ngspice's working directory and ``HOME``, so that nothing
ngspice writes lands elsewhere. ``-n`` keeps the user's ``.spiceinit`` out
(the system ``spinit`` is still read, as the shared library does); in a
compatibility mode netdae writes a private ``.spiceinit`` holding only ``set
ngbehavior=...`` there instead (:func:`spiceinit`). ngspice
runs in a session of its own: on a timeout the whole process group is
killed, so no ngspice process outlives the run. ``SPICE_ASCIIRAWFILE=0`` keeps
the raw file binary (ngspice's default, full double precision) whatever the
user's environment says. The raw file is read with
:func:`netdae.io.raw.read_raw`.

ngspice 39 makes no measurement in batch mode with a raw file ("No .measure
possible in batch mode (-b) with -r rawfile set!"): a netlist with ``.meas``
cards is run a second time without ``-r`` (``ngspice -b -n netlist.cir``),
whose printed output carries the measurements; the note ngspice printed about
them in the first run is left out. A netlist with netdae's control block
(:func:`netdae.ngspice.deck.script_block`) runs once, without ``-r``: the
block writes every analysis's plot to ``out.raw`` itself.
"""

from __future__ import annotations

import contextlib
import dataclasses
import os
import re
import shutil
import signal
import subprocess
import tempfile

from ..errors import NetdaeError, NgspiceError
from ..io.raw import read_raw
from . import INSTALL_HINT, BackendOutput, BackendUnavailable
from .deck import SCRIPT_MARK
from .measures import measure_cards

__all__ = ["run", "version", "executable"]

_VERSION = re.compile(r"ngspice-(\S+)")
#: Seconds allowed for ``ngspice -v``.
_VERSION_TIMEOUT = 30.0
_version_cache: dict[str, str] = {}
#: ngspice's note that it measures nothing with ``-r`` (and its two continuation lines).
_NO_MEASURE = re.compile(r"no \.measure possible in batch mode|^remove rawfile and use|"
                         r"^select interactive mode \(optionally", re.I)


def executable() -> str:
    """Path of the ngspice executable.

    Raises
    ------
    BackendUnavailable
        When there is none on the PATH.
    """
    path = shutil.which("ngspice")
    if path is None:
        raise BackendUnavailable(f"the ngspice executable is not installed (install it with: {INSTALL_HINT})")
    return path


def version() -> str:
    """``"ngspice-39"``, from ``ngspice -v`` (cached per executable)."""
    exe = executable()
    if exe not in _version_cache:
        try:
            done = subprocess.run(
                [exe, "-v"], capture_output=True, text=True, timeout=_VERSION_TIMEOUT, errors="replace"
            )
        except (OSError, subprocess.TimeoutExpired) as exc:
            raise BackendUnavailable(f"cannot run {exe} -v: {exc}") from None
        match = _VERSION.search(done.stdout + done.stderr)
        if match is None:
            raise BackendUnavailable(f"{exe} -v does not say which ngspice it is: {done.stdout.strip()!r}")
        _version_cache[exe] = f"ngspice-{match.group(1)}"
    return _version_cache[exe]


def run(netlist: str, *, timeout: float | None, ngbehavior: str | None = None) -> BackendOutput:
    """Run a netlist with the ngspice executable in batch mode.

    Parameters
    ----------
    netlist : str
        The (translated) netlist.
    timeout : float or None
        Seconds before ngspice is killed (None: no limit).
    ngbehavior : str, optional
        ngspice's compatibility mode: a private ``.spiceinit`` holding only ``set
        ngbehavior=...`` is written in the run's directory (also its ``HOME``) and read
        instead of ``-n``.

    Returns
    -------
    BackendOutput
        ``read_error`` is set instead of raising when the raw file cannot be
        read: the caller first looks for errors ngspice reported.

    Raises
    ------
    NgspiceError
        When ngspice is missing (with the install command) or times out.
    """
    exe = executable()
    ngspice = version()
    with tempfile.TemporaryDirectory(prefix="netdae-ngspice-") as tmp:
        env = dict(os.environ, SPICE_ASCIIRAWFILE="0", HOME=tmp)
        env.pop("SPICE_USERINIT_DIR", None)
        circuit = os.path.join(tmp, "netlist.cir")
        raw = os.path.join(tmp, "out.raw")
        with open(circuit, "w", encoding="utf-8") as handle:
            handle.write(netlist)
        init = ["-n"]
        if ngbehavior is not None:
            with open(os.path.join(tmp, ".spiceinit"), "w", encoding="utf-8") as handle:
                handle.write(spiceinit(ngbehavior))
            init = []
        script = SCRIPT_MARK in netlist  # netdae's control block writes every plot to out.raw itself
        raw_file = [] if script else ["-r", "out.raw"]
        done = _run_killable([exe, "-b", *init, *raw_file, "netlist.cir"], tmp, env, timeout)
        stdout, stderr = done.stdout.splitlines(), done.stderr.splitlines()
        if measure_cards(netlist) and not script:
            again = _run_killable([exe, "-b", *init, "netlist.cir"], tmp, env, timeout)
            stderr = [line for line in stderr if not _NO_MEASURE.search(line)]
            stdout += again.stdout.splitlines()
            stderr += again.stderr.splitlines()
        results, read_error = [], None
        if os.path.exists(raw):
            try:
                results = read_raw(raw)
            except NetdaeError as exc:
                read_error = str(exc)
        for result in results:
            if result.source is not None:  # the temporary raw file is gone
                result.source = dataclasses.replace(result.source, path=None)
    return BackendOutput(
        results=results,
        stdout=stdout,
        stderr=stderr,
        version=ngspice,
        returncode=done.returncode,
        read_error=read_error,
    )


def spiceinit(ngbehavior: str) -> str:
    """The private start-up file that selects ngspice's compatibility mode (and nothing else).

    Raises
    ------
    NgspiceError
        A value that is not letters and digits (it is written into a command).
    """
    if not re.fullmatch(r"[a-z0-9]+", ngbehavior):
        raise NgspiceError(f"ngbehavior value {ngbehavior!r} is not letters and digits")
    return f"* netdae: ngspice's compatibility mode (the user's .spiceinit is not read)\nset ngbehavior={ngbehavior}\n"


def _run_killable(argv: list[str], cwd: str, env: dict, timeout: float | None) -> subprocess.CompletedProcess:
    """Run ngspice in a session of its own; on a timeout kill its whole process group."""
    try:
        process = subprocess.Popen(
            argv, cwd=cwd, env=env, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
            text=True, errors="replace", start_new_session=True,
        )
    except OSError as exc:
        raise BackendUnavailable(f"cannot start {argv[0]}: {exc}") from None
    try:
        stdout, stderr = process.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        _kill_group(process)
        raise NgspiceError(f"ngspice did not finish within {timeout:g} s (it was killed)") from None
    except BaseException:  # KeyboardInterrupt: leave no ngspice behind
        _kill_group(process)
        raise
    return subprocess.CompletedProcess(argv, process.returncode, stdout, stderr)


def _kill_group(process: subprocess.Popen) -> None:
    with contextlib.suppress(ProcessLookupError, PermissionError):
        os.killpg(process.pid, signal.SIGKILL)
    process.kill()
    process.communicate()
