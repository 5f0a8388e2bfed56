"""ngspice as a subprocess: ``ngspice -b -n -r out.raw netlist.cir``.

The netlist and the raw file live in a fresh temporary directory, which is
also ngspice's working directory, so that nothing a netlist writes lands
elsewhere. ``-n`` keeps the user's ``.spiceinit`` out (the system ``spinit``
is still read, as the shared library does); ``SPICE_ASCIIRAWFILE=0`` keeps
the raw file binary (ngspice's default, full double precision) whatever the
user's environment says. The raw file is read with
:func:`netdae.io.raw.read_raw`.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import tempfile

from ..errors import NetdaeError, NgspiceError
from ..io.raw import read_raw
from . import INSTALL_HINT, BackendOutput, BackendUnavailable

__all__ = ["run", "version", "executable"]

_VERSION = re.compile(r"ngspice-(\S+)")
#: Seconds allowed for ``ngspice -v``.
_VERSION_TIMEOUT = 30.0
_version_cache: dict[str, str] = {}


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


def run(netlist: str, *, timeout: float) -> BackendOutput:
    """Run a netlist with the ngspice executable in batch mode.

    Parameters
    ----------
    netlist : str
        The (translated) netlist.
    timeout : float
        Seconds before ngspice is killed.

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
    env = dict(os.environ, SPICE_ASCIIRAWFILE="0")
    with tempfile.TemporaryDirectory(prefix="netdae-ngspice-") as tmp:
        circuit = os.path.join(tmp, "netlist.cir")
        raw = os.path.join(tmp, "out.raw")
        with open(circuit, "w", encoding="utf-8") as handle:
            handle.write(netlist)
        try:
            done = subprocess.run(
                [exe, "-b", "-n", "-r", raw, circuit],
                cwd=tmp,
                env=env,
                stdin=subprocess.DEVNULL,
                capture_output=True,
                text=True,
                errors="replace",
                timeout=timeout,
            )
        except subprocess.TimeoutExpired:
            raise NgspiceError(f"ngspice did not finish within {timeout:g} s (it was stopped)") from None
        except OSError as exc:
            raise BackendUnavailable(f"cannot start {exe}: {exc}") from None
        results, read_error = [], None
        if os.path.exists(raw):
            try:
                results = read_raw(raw)
            except NetdaeError as exc:
                read_error = str(exc)
        for result in results:
            result.extra.pop("source", None)
    return BackendOutput(
        results=results,
        stdout=done.stdout.splitlines(),
        stderr=done.stderr.splitlines(),
        version=ngspice,
        returncode=done.returncode,
        read_error=read_error,
    )
