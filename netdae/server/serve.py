"""The netdae server: pay the imports once, fork a worker per command.

Process tree: the server (its own session, started by
:func:`netdae.server.client.start`) accepts a connection and forks a
*supervisor*, which receives the request and the caller's standard streams,
forks the *worker*, tells the caller the worker's pid (the caller forwards
signals to it), waits for the worker or for the caller to go away (then the
worker gets SIGTERM), and sends the exit status. The worker takes the caller's
streams, directory, environment, umask and resource limits and runs
:func:`netdae.cli.main` on the arguments.

Only one server runs per key (a lock file next to the socket); it binds its
socket under a temporary name and renames it into place when warm, so a caller
never reaches a server that is still importing. It exits after the idle time,
or when its socket was removed or replaced.
"""

from __future__ import annotations

import fcntl
import io
import os
import select
import signal
import socket
import sys
import time

from .client import recv_frame, send_frame

__all__ = ["main", "warm_up"]

#: Small circuits run once at start-up so that their compiled kernels are loaded
#: from numba's cache before the first fork (each family's kernel once).
WARM_NETLISTS = (
    "* linear\nV1 in 0 PULSE(0 1 1u 1u 1u 5u 10u) AC 1\nR1 in out 1k\nC1 out 0 1n\nL1 out o2 1u\nR2 o2 0 50\n"
    ".tran 0.1u 20u\n.ac dec 5 1k 1meg\n.op\n.end\n",
    "* diode, bjt, mosfet, jfet, vdmos, behavioural\nV1 in 0 SIN(0 5 1k)\nD1 in a dmod\nC1 a 0 1u\nR1 a 0 1k\n"
    "Q1 c b 0 qmod\nRb a b 100k\nRc vcc c 1k\nVcc vcc 0 5\nM1 d a 0 0 nmod\nRd vcc d 1k\n"
    "J1 vcc a s jmod\nRs s 0 1k\nM2 vcc a p vmod\nRp p 0 1k\n"
    "B1 e 0 V=V(a)*0.5\nRe e 0 1k\n.model dmod d(is=1e-14 cjo=1p)\n.model qmod npn(bf=100 cje=1p)\n"
    ".model nmod nmos(level=1 vto=1 kp=1e-4 cgso=1e-12)\n.model jmod njf(vto=-2 beta=1m cgs=1p)\n"
    ".model vmod vdmos(vto=2 kp=1 cgs=1n cgdmax=1n cgdmin=0.1n cjo=1n rd=10m rg=2)\n"
    ".tran 10u 1m\n.end\n",
)


#: Modules the commands import after the analyses (writers, the comparison's own parts; not the
#: ngspice bridge: a shared library loaded before forking would be shared by every worker).
WARM_MODULES = ("netdae.cli.run", "netdae.cli.progress", "netdae.cli.check", "netdae.cli.index", "netdae.cli.sweep",
                "netdae.io.csv", "netdae.io.raw", "netdae.io.files", "netdae.io.sweep", "netdae.comparison",
                "netdae.sweeps", "netdae.analyses.pz", "netdae.analyses.tf", "netdae.analyses.noise",
                "netdae.analyses.sens", "netdae.analyses.dc", "netdae.analyses.index", "netdae.topology")


def warm_up() -> None:
    """Import the engine, run :data:`WARM_NETLISTS` (output discarded, errors ignored), import :data:`WARM_MODULES`."""
    import logging

    from .. import run
    from ..cli import parser

    parser()  # the command line's parser, built once for every worker

    logging.getLogger("netdae").disabled = True
    try:
        for text in WARM_NETLISTS:
            try:
                for result in run(text):
                    if result.analysis == "tran" and result.dense is not None:
                        result.dense(result.axis[:3])  # the dense-output kernel
            except Exception:  # noqa: BLE001 - warming is best effort; a real run reports its own errors
                pass
        import importlib

        for name in WARM_MODULES:
            try:
                importlib.import_module(name)
            except ImportError:
                pass
    finally:
        logging.getLogger("netdae").disabled = False
    import gc

    gc.collect()
    if hasattr(gc, "freeze"):  # keep the warm objects out of the workers' collections (fewer copied pages)
        gc.freeze()


def _stream(fd: int, spec: dict, mode: str):
    raw = io.FileIO(fd, mode, closefd=False)
    tty = os.isatty(fd)
    if mode == "r":
        return io.TextIOWrapper(io.BufferedReader(raw), encoding=spec.get("encoding"), errors=spec.get("errors"))
    return io.TextIOWrapper(io.BufferedWriter(raw), encoding=spec.get("encoding"), errors=spec.get("errors"),
                            line_buffering=tty, write_through=(fd == 2))


def _worker(request: dict, fds: list[int]) -> None:
    """Become the caller's command; never returns."""
    status = 3
    try:
        for target, fd in zip((0, 1, 2), fds):
            os.dup2(fd, target)
        for fd in fds:
            if fd > 2:
                os.close(fd)
        for signum in (signal.SIGTERM, signal.SIGHUP, signal.SIGCHLD, signal.SIGUSR1, signal.SIGUSR2):
            signal.signal(signum, signal.SIG_DFL)
        signal.signal(signal.SIGINT, signal.default_int_handler)
        os.chdir(request["cwd"])
        os.umask(int(request["umask"]))
        _apply_limits(request.get("limits") or {})
        os.environ.clear()
        os.environ.update(request["env"])
        sys.stdin = _stream(0, request.get("stdin", {}), "r")
        sys.stdout = _stream(1, request.get("stdout", {}), "w")
        sys.stderr = _stream(2, request.get("stderr", {}), "w")
        argv = [str(a) for a in request["argv"]]
        sys.argv = ["netdae", *argv]
        from ..cli import main

        status = main(argv)
    except SystemExit as exc:
        status = exc.code if isinstance(exc.code, int) else 1
    except KeyboardInterrupt:
        status = 130
    except BaseException as exc:  # noqa: BLE001 - report in one line, as the command line does
        try:
            sys.stderr.write(f"netdae: internal error: {type(exc).__name__}: {exc} (in the netdae server's "
                             "worker; NETDAE_SERVER=0 runs the command in its own process)\n")
        except Exception:  # noqa: BLE001
            pass
    finally:
        for stream in (sys.stdout, sys.stderr):
            try:
                stream.flush()
            except Exception:  # noqa: BLE001 - a closed pipe: nothing more to say
                pass
        os._exit(status if isinstance(status, int) and 0 <= status < 256 else 1)


def _apply_limits(limits: dict) -> None:
    """Take the caller's resource limits (lowering only: a process cannot raise a hard limit)."""
    import resource

    for name, (soft, hard) in limits.items():
        which = getattr(resource, name, None)
        if which is None:
            continue
        try:
            cur_soft, cur_hard = resource.getrlimit(which)
            hard = hard if cur_hard == resource.RLIM_INFINITY or 0 <= hard <= cur_hard else cur_hard
            soft = soft if hard == resource.RLIM_INFINITY or 0 <= soft <= hard else hard
            if (soft, hard) != (cur_soft, cur_hard):
                resource.setrlimit(which, (soft, hard))
        except (ValueError, OSError):
            pass


def _supervise(conn: socket.socket, listener: socket.socket) -> None:
    """Serve one connection in a forked child; never returns."""
    code = 0
    try:
        listener.close()
        signal.signal(signal.SIGCHLD, signal.SIG_DFL)
        signal.signal(signal.SIGTERM, signal.SIG_DFL)
        conn.settimeout(10.0)
        request, fds = recv_frame(conn, fds=3)
        kind = request.get("kind")
        if kind == "status":
            send_frame(conn, {"pid": os.getppid(), "key": os.path.basename(_SOCKET or "")[:-5],
                              "socket": _SOCKET, "idle": _IDLE, "started": _STARTED})
            return
        if kind == "stop":
            send_frame(conn, {"stopping": os.getppid()})
            os.kill(os.getppid(), signal.SIGTERM)
            return
        if kind != "run" or len(fds) != 3:
            return
        pid = os.fork()
        if pid == 0:
            conn.close()
            _worker(request, fds)
        for fd in fds:
            os.close(fd)
        send_frame(conn, {"pid": pid})
        status = _wait(pid, conn)
        send_frame(conn, {"status": status})
    except Exception:  # noqa: BLE001 - the caller sees the connection end and says so
        code = 1
    finally:
        os._exit(code)


def _wait(pid: int, conn: socket.socket) -> int:
    """Wait for the worker; if the caller goes away first, end the worker. Its status (negative: a signal)."""
    pidfd = os.pidfd_open(pid) if hasattr(os, "pidfd_open") else None
    watching = True
    while True:
        if pidfd is not None:
            ready, _, _ = select.select([pidfd] + ([conn] if watching else []), [], [])
        else:
            ready, _, _ = select.select([conn] if watching else [], [], [], 0.05)
        if watching and conn in ready:
            try:
                gone = conn.recv(1, socket.MSG_PEEK) == b""
            except OSError:
                gone = True
            if gone:
                watching = False
                try:
                    os.kill(pid, signal.SIGTERM)
                except OSError:
                    pass
        done, status = os.waitpid(pid, os.WNOHANG)
        if done:
            if pidfd is not None:
                os.close(pidfd)
            return -os.WTERMSIG(status) if os.WIFSIGNALED(status) else os.WEXITSTATUS(status)


_SOCKET: str | None = None
_IDLE = 0.0
_STARTED = 0.0


class _Stop(Exception):
    """SIGTERM (``netdae server stop``): leave the accept loop."""


def _stop(_signum, _frame):
    raise _Stop


def _same_file(path: str, inode: int) -> bool:
    try:
        return os.stat(path).st_ino == inode
    except OSError:
        return False


def main(path: str, idle: float) -> None:
    """Run a server on the socket ``path`` until it has been idle for ``idle`` seconds."""
    global _SOCKET, _IDLE, _STARTED
    os.chdir("/")
    lock = os.open(path + ".lock", os.O_CREAT | os.O_RDWR, 0o600)
    try:
        fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:  # another server for this key is starting or running
        return
    os.ftruncate(lock, 0)
    os.write(lock, str(os.getpid()).encode())  # for `netdae server stop` while this one warms up
    from ..cli import _limit_blas_threads

    _limit_blas_threads()
    warm_up()
    listener = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    staging = f"{path}.{os.getpid()}"
    try:
        os.unlink(staging)
    except OSError:
        pass
    listener.bind(staging)
    os.chmod(staging, 0o600)
    listener.listen(64)
    os.replace(staging, path)
    inode = os.stat(path).st_ino
    _SOCKET, _IDLE, _STARTED = path, idle, time.time()
    signal.signal(signal.SIGTERM, _stop)
    signal.signal(signal.SIGCHLD, signal.SIG_IGN)  # supervisors are reaped by the kernel
    last = time.monotonic()
    try:
        while True:
            left = idle - (time.monotonic() - last)
            if left <= 0 or not _same_file(path, inode):
                break
            ready, _, _ = select.select([listener], [], [], min(left, 30.0))
            if not ready:
                continue
            try:
                conn, _ = listener.accept()
            except OSError:
                continue
            last = time.monotonic()
            if os.fork() == 0:
                _supervise(conn, listener)
            conn.close()
    except _Stop:
        pass
    finally:
        if _same_file(path, inode):
            os.unlink(path)
        listener.close()
        os.close(lock)
