"""``netdae server status|start|stop``: the warm process that saves commands their start-up.

The ``netdae`` command hands its command line to a running server of the same
installation (:mod:`netdae.server`) and starts one after a command that loaded
the compiled engine; this subcommand shows, starts or stops it. ``status``
exits 1 when no server runs, ``start`` waits until the server accepts commands
(about the time of one small run), ``stop`` ends every server of this user
(also those of other installations or environments, and those still warming up).
"""

from __future__ import annotations

import argparse
import os

__all__ = ["add_parser", "main"]


def add_parser(sub) -> argparse.ArgumentParser:
    p = sub.add_parser(
        "server",
        help="show, start or stop the warm netdae process that saves commands their start-up",
        description="netdae runs commands in a warm server process when one is running for this "
                    "installation and environment (NETDAE_SERVER=0 turns it off). Exit status of "
                    "'status': 0 when a server runs, 1 when none does.",
    )
    p.add_argument("action", choices=("status", "start", "stop"), help="what to do")
    return p


def _sockets(directory: str) -> list[str]:
    try:
        names = sorted(os.listdir(directory))
    except OSError:
        return []
    return [os.path.join(directory, n) for n in names if n.endswith(".sock")]


def main(args: argparse.Namespace) -> int:
    from ..errors import NetdaeError
    from ..server import client
    from . import LOG

    if not client.enabled():
        LOG.info("the netdae server is off (NETDAE_SERVER=%s, or the platform has no Unix sockets)",
                 os.environ.get(client.SWITCH, ""))
        return 1 if args.action == "status" else 0
    directory = client.server_dir()
    if directory is None:
        raise NetdaeError("no private directory for the server's socket (set NETDAE_SERVER_DIR to a "
                          "directory of yours that only you can read)")
    path = client.socket_path()
    if args.action == "status":
        answer = client.request("status", path)
        if answer is None:
            print(f"no netdae server for this installation (socket {path})")
            return 1
        print(f"netdae server pid {answer.get('pid')}, socket {answer.get('socket')}, "
              f"exits after {answer.get('idle'):g} s without a command")
        return 0
    if args.action == "start":
        if client.request("status", path) is not None:
            print(f"a netdae server already runs (socket {path})")
            return 0
        proc = client.start(path, wait=600.0)
        if client.request("status", path) is None:
            raise NetdaeError(f"the netdae server did not start (exit status {proc.poll()}); "
                              "commands run in their own processes")
        print(f"netdae server started, pid {proc.pid} (socket {path})")
        return 0
    answered = {sock for sock in _sockets(directory) if client.request("stop", sock) is not None}
    stopped = len(answered) + _stop_warming(directory, answered)
    _wait_gone(answered)
    print(f"stopped {stopped} netdae server{'s' if stopped != 1 else ''}")
    return 0


#: Seconds ``netdae server stop`` waits for the servers it stopped to stop answering.
STOP_WAIT = 10.0


def _wait_gone(sockets: set[str]) -> None:
    """Return once none of ``sockets`` answers (a server answers ``stop`` before it closes its socket),
    or after :data:`STOP_WAIT` seconds: a ``status`` right after ``stop`` then finds no server."""
    import time

    from ..server import client

    deadline = time.monotonic() + STOP_WAIT
    left = set(sockets)
    while left and time.monotonic() < deadline:
        left = {sock for sock in left if client.request("status", sock, timeout=1.0) is not None}
        if left:
            time.sleep(0.05)


def _stop_warming(directory: str, stopped: set[str]) -> int:
    """End the servers still warming up (their lock is held, their socket not yet there); ``stopped``:
    the sockets whose servers were already asked to stop."""
    import fcntl
    import signal

    count = 0
    try:
        names = sorted(os.listdir(directory))
    except OSError:
        return 0
    for name in names:
        path = os.path.join(directory, name)
        if not name.endswith(".sock.lock") or path[:-len(".lock")] in stopped:
            continue
        try:
            fd = os.open(path, os.O_RDWR)
        except OSError:
            continue
        try:
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
                continue  # nobody holds it: no server for this key
            except OSError:
                pass
            try:
                pid = int(os.read(fd, 32).decode() or "0")
                with open(f"/proc/{pid}/cmdline", "rb") as f:
                    if b"netdae.server.serve" not in f.read():
                        continue
                os.kill(pid, signal.SIGTERM)
                count += 1
            except (OSError, ValueError):
                continue
        finally:
            os.close(fd)
    return count
