"""Run one simulator on one netlist as a child process and measure it.

Each run is a fresh process, timed from ``Popen`` to its exit (the wall time
a user sees: interpreter start, imports, reading, analysis, writing the
results). Its peak resident set size comes from GNU ``/usr/bin/time -f %M``
(``ru_maxrss`` of ``wait4``), which forks and execs the child itself: a child
forked directly from this (large) Python process would inherit the parent's
high-water mark, because Linux carries the peak RSS of the address space an
``exec`` replaces into the new program's ``ru_maxrss``. ``time`` is a small C
program (about 2 MiB), so the floor it adds is negligible. Without it a
one-line Python wrapper does the same (floor about 9 MiB). A timer kills the
child's process group after ``timeout`` seconds; the run is then reported as
"> timeout".

- netdae: ``netdae run FILE --out DIR --format raw --json``; the counters
  come from the JSON statistics of the ``.tran`` result, the waveforms from
  ``DIR/tran.raw``.
- ngspice: ``ngspice -b -n -r out.raw FILE`` with ``.options acct`` in the
  netlist: ngspice then prints its statistics (``Accepted timepoints``,
  ``Rejected timepoints``, ``Transient iterations``, ``Total analysis time``
  ...). ngspice factors the matrix at every Newton iteration (``NIiter``
  calls ``SMPluFac`` after every load), so its factorizations equal its
  iterations.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import signal
import subprocess
import sys
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

__all__ = ["ChildRun", "SimRun", "run_child", "run_netdae", "run_ngspice", "ngspice_version", "NETDAE_EXE"]

ROOT = Path(__file__).resolve().parent.parent
#: The command-line tool of the virtualenv that runs this script (else the one on the PATH).
NETDAE_EXE = str(Path(sys.executable).with_name("netdae")) if Path(sys.executable).with_name("netdae").exists() \
    else (shutil.which("netdae") or "netdae")
#: Environment of every child: one BLAS thread (as netdae's CLI sets it), binary raw files.
CHILD_ENV = {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1",
             "SPICE_ASCIIRAWFILE": "0",
             # each netdae command in its own process (no warm server): CPU and RSS are its own
             "NETDAE_SERVER": "0"}

_ACCT = {
    "steps": re.compile(r"^Accepted timepoints\s*=\s*(\d+)", re.M),
    "rejected": re.compile(r"^Rejected timepoints\s*=\s*(\d+)", re.M),
    "newton": re.compile(r"^Transient iterations\s*=\s*(\d+)", re.M),
    "total_iterations": re.compile(r"^Total iterations\s*=\s*(\d+)", re.M),
    "analysis_time": re.compile(r"^Total analysis time \(seconds\)\s*=\s*([0-9.eE+-]+)", re.M),
    "tran_time": re.compile(r"^Transient analysis time\s*=\s*([0-9.eE+-]+)", re.M),
    "equations": re.compile(r"^Circuit Equations\s*=\s*(\d+)", re.M),
    "fillin": re.compile(r"^Circuit fill-in non-zeroes\s*=\s*(\d+)", re.M),
    "nnz": re.compile(r"^Circuit total non-zeroes\s*=\s*(\d+)", re.M),
}


@dataclass
class ChildRun:
    """Wall time [s], peak RSS [MiB], exit status and output of one child process."""

    wall: float
    rss_mb: float
    returncode: int
    timed_out: bool
    stdout: str
    stderr: str


@dataclass
class SimRun:
    """One simulator run: measurements, counters and the compared waveforms.

    ``stats`` holds ``steps``, ``rejected``, ``newton``, ``factorizations``,
    ``analysis_time`` (netdae: the transient's own wall time; ngspice: its
    "Total analysis time"), when known. ``time`` and ``signals`` are None
    when the run failed or timed out.
    """

    simulator: str
    child: ChildRun
    ok: bool
    message: str
    stats: dict = field(default_factory=dict)
    time: np.ndarray | None = None
    signals: dict | None = None


#: GNU time, if installed: reports the peak RSS of the program it runs.
GNU_TIME = "/usr/bin/time" if os.path.exists("/usr/bin/time") else None
#: Fallback wrapper: run argv[1:], write ru_maxrss [KiB] to the file named by argv[0].
_PY_WRAPPER = ("import os, sys; pid = os.fork()\n"
               "if pid == 0: os.execvp(sys.argv[2], sys.argv[2:])\n"
               "_, st, ru = os.wait4(pid, 0); open(sys.argv[1], 'w').write(str(ru.ru_maxrss))\n"
               "sys.exit(os.waitstatus_to_exitcode(st) & 255)")


def run_child(argv: list[str], *, cwd: str | os.PathLike, timeout: float, env: dict | None = None) -> ChildRun:
    """Run ``argv`` in ``cwd`` and measure its wall time and peak RSS.

    The child runs in its own process group, killed after ``timeout`` seconds;
    ``env`` adds to (and overrides) :data:`CHILD_ENV`.
    """
    env = {**os.environ, **CHILD_ENV, **(env or {})}
    cwd = Path(cwd)
    out_path, err_path, rss_path = cwd / "child.stdout", cwd / "child.stderr", cwd / "child.maxrss"
    if rss_path.exists():
        rss_path.unlink()
    if GNU_TIME is not None:
        wrapped = [GNU_TIME, "-f", "%M", "-o", str(rss_path)] + list(argv)
    else:
        wrapped = [sys.executable, "-c", _PY_WRAPPER, str(rss_path)] + list(argv)
    with open(out_path, "wb") as out, open(err_path, "wb") as err:
        t0 = time.perf_counter()
        proc = subprocess.Popen(wrapped, cwd=cwd, env=env, stdin=subprocess.DEVNULL, stdout=out, stderr=err,
                                start_new_session=True)
        killed = threading.Event()

        def kill():
            killed.set()
            try:
                os.killpg(proc.pid, signal.SIGKILL)
            except ProcessLookupError:
                pass

        timer = threading.Timer(timeout, kill)
        timer.start()
        try:
            proc.wait()
        finally:
            timer.cancel()
        wall = time.perf_counter() - t0
    rss_kib = 0.0
    try:
        text = rss_path.read_text().split()
        rss_kib = float(text[-1]) if text else 0.0
    except (OSError, ValueError):
        pass
    stderr = err_path.read_text(errors="replace")
    if GNU_TIME is not None and proc.returncode != 0:
        # GNU time reports a failing command on stderr; keep the child's own lines only
        stderr = "\n".join(ln for ln in stderr.splitlines() if not ln.startswith("Command "))
    return ChildRun(
        wall=wall, rss_mb=rss_kib / 1024.0, returncode=proc.returncode, timed_out=killed.is_set(),
        stdout=out_path.read_text(errors="replace"), stderr=stderr,
    )


def _read_tran(raw_path: Path, signals) -> tuple[np.ndarray, dict]:
    from netdae.io.raw import read_raw

    results = read_raw(raw_path)
    tran = next(r for r in results if r.analysis == "tran")
    return np.asarray(tran.t, dtype=float), {s: np.asarray(tran[s], dtype=float) for s in signals}


def run_netdae(netlist: Path, workdir: Path, signals, *, timeout: float) -> SimRun:
    """``netdae run NETLIST --out workdir/out --format raw --json``."""
    out = workdir / "out"
    if out.exists():
        shutil.rmtree(out)
    child = run_child([NETDAE_EXE, "run", str(netlist), "--out", str(out), "--format", "raw", "--json"],
                      cwd=workdir, timeout=timeout)
    if child.timed_out:
        return SimRun("netdae", child, False, f"> {timeout:g} s (stopped)")
    try:
        doc = json.loads(child.stdout)
        tran = doc["tran"]
    except (ValueError, KeyError):
        last = (child.stderr.strip().splitlines() or ["no output"])[-1]
        return SimRun("netdae", child, False, f"exit {child.returncode}: {last}")
    s = tran.get("stats", {})
    stats = {"steps": s.get("steps"), "rejected": s.get("rejected"), "newton": s.get("newton_iterations"),
             "factorizations": s.get("factorizations"), "analysis_time": s.get("wall_time"),
             "integration_time": _integration_time(s.get("integrator") or {}),
             "load_time": (s.get("integrator") or {}).get("load_time"),
             "integrator": s.get("integrator") or {},
             "points": s.get("points"), "unknowns": s.get("n_unknowns"), "nnz": s.get("nnz")}
    ok = tran.get("status", -1) >= 0
    t, sig = (None, None)
    raw = out / "tran.raw"
    if raw.exists():
        t, sig = _read_tran(raw, signals)
    return SimRun("netdae", child, ok, tran.get("message", ""), stats, t, sig if ok else None)


def _integration_time(integrator: dict) -> float | None:
    """The integrator's wall time without loading the compiled engine into the process.

    The first transient of a process loads the step loop's machine code from
    numba's cache (about 0.4-0.6 s, most of it numba's own initialisation);
    that is start-up, reported as ``load_time``, not integration.
    """
    wall = integrator.get("wall_time")
    if wall is None:
        return None
    return wall - (integrator.get("load_time") or 0.0)


def parse_acct(text: str) -> dict:
    """ngspice's ``.options acct`` statistics from its standard output."""
    stats = {}
    for key, rx in _ACCT.items():
        m = rx.search(text)
        if m is not None:
            stats[key] = float(m.group(1)) if key.endswith("time") else int(m.group(1))
    if "newton" in stats:
        stats["factorizations"] = stats["newton"]
    if "tran_time" in stats:
        stats["integration_time"] = stats["tran_time"]
    return stats


def run_ngspice(netlist: Path, workdir: Path, signals, *, timeout: float) -> SimRun:
    """``ngspice -b -n -r out.raw NETLIST`` (the netlist carries ``.options acct``)."""
    raw = workdir / "out.raw"
    if raw.exists():
        raw.unlink()
    exe = shutil.which("ngspice") or "ngspice"
    child = run_child([exe, "-b", "-n", "-r", str(raw), str(netlist)], cwd=workdir, timeout=timeout)
    if child.timed_out:
        return SimRun("ngspice", child, False, f"> {timeout:g} s (stopped)")
    stats = parse_acct(child.stdout)
    errors = [ln for ln in (child.stdout + child.stderr).splitlines()
              if re.search(r"error|too small|aborted|singular", ln, re.I) and "warning" not in ln.lower()]
    if child.returncode != 0 or not raw.exists() or "steps" not in stats:
        return SimRun("ngspice", child, False, (errors or [f"exit {child.returncode}"])[0], stats)
    t, sig = _read_tran(raw, signals)
    if errors:
        return SimRun("ngspice", child, False, errors[0], stats, t, None)
    return SimRun("ngspice", child, True, "ok", stats, t, sig)


def ngspice_version() -> str:
    """``ngspice --version``'s first line naming the version (e.g. ``ngspice-39 : ...``)."""
    exe = shutil.which("ngspice")
    if exe is None:
        return "not installed"
    done = subprocess.run([exe, "--version"], capture_output=True, text=True, errors="replace",
                          stdin=subprocess.DEVNULL, timeout=30)
    for line in done.stdout.splitlines():
        if "ngspice-" in line:
            return line.strip(" *")
    return done.stdout.strip().splitlines()[0] if done.stdout.strip() else "unknown"
