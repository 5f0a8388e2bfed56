"""The console script's side of the netdae server (standard library only).

Nothing here imports numpy: a command handed to a running server costs the
interpreter's start-up, this module, a connection and a fork.

The protocol on a Unix stream socket (private directory, mode 0700):

1. the client sends one framed JSON request (``kind``: ``run``, ``status`` or
   ``stop``) with its standard input, output and error attached as file
   descriptors (``SCM_RIGHTS``);
2. for ``run`` the server answers with the worker's process id, then with its
   exit status (a negative status is the signal that ended the worker); for
   ``status``/``stop`` with one framed JSON answer.

The worker takes the caller's arguments, working directory, environment,
umask, resource limits (``ulimit``) and standard streams; the caller forwards
its signals to it (Ctrl-C, termination, Ctrl-Z and ``fg``).

A server serves one *key*: a hash of the interpreter, its flags and path, the
environment variables read at import time (``NUMBA_*``, ``NETDAE_*``,
``PYTHON*``, thread counts) and the names, sizes and modification times of
netdae's own files. An edited installation or a different environment simply
finds no server and starts its own; the old one ends when idle.
"""

from __future__ import annotations

import hashlib
import json
import os
import signal
import socket
import struct
import sys

__all__ = [
    "SWITCH", "IDLE_SECONDS", "enabled", "key", "server_dir", "socket_path", "request",
    "forward", "start", "RunStatus", "limits",
]

from . import SWITCH, wanted
#: Seconds a server waits for a command before it exits (``NETDAE_SERVER_IDLE``).
IDLE_SECONDS = 900.0
#: Environment variables that change what an import does: part of the key.
KEY_PREFIXES = ("NUMBA_", "NETDAE_", "PYTHON", "OMP_", "OPENBLAS_", "MKL_", "LD_")
#: Variables of the server itself, not part of the key.
KEY_EXCLUDED = ("NETDAE_SERVER", "NETDAE_SERVER_IDLE")
_FRAME = struct.Struct("!I")
_MAX_FRAME = 64 * 1024 * 1024


class RunStatus(Exception):
    """The connection ended before the worker reported (carries a message)."""


def enabled(env: dict | None = None) -> bool:
    """Whether commands may go through a server on this platform and environment."""
    if os.name != "posix" or not hasattr(socket, "AF_UNIX") or not hasattr(socket, "send_fds"):
        return False
    return wanted(env)


def server_dir(env: dict | None = None) -> str | None:
    """The private directory of this user's server sockets, created if missing; None if unsafe.

    ``$NETDAE_SERVER_DIR`` when set, else ``$XDG_RUNTIME_DIR/netdae``, else
    ``/tmp/netdae-server-<uid>``. The directory must be owned by the user and
    closed to everyone else; otherwise no server is used.
    """
    env = os.environ if env is None else env
    path = env.get("NETDAE_SERVER_DIR")
    if not path:
        runtime = env.get("XDG_RUNTIME_DIR")
        if runtime and os.path.isdir(runtime):
            path = os.path.join(runtime, "netdae")
        else:
            path = os.path.join(env.get("TMPDIR") or "/tmp", f"netdae-server-{os.getuid()}")
    try:
        os.makedirs(path, mode=0o700, exist_ok=True)
        st = os.lstat(path)
    except OSError:
        return None
    import stat

    if not stat.S_ISDIR(st.st_mode) or st.st_uid != os.getuid() or st.st_mode & 0o077:
        return None
    return path


def _package_files(root: str):
    stack = [root]
    while stack:
        top = stack.pop()
        try:
            entries = list(os.scandir(top))
        except OSError:
            continue
        for entry in entries:
            if entry.is_dir(follow_symlinks=False):
                if entry.name != "__pycache__":
                    stack.append(entry.path)
            elif entry.name.endswith((".py", ".so")):
                st = entry.stat()
                yield entry.path, st.st_mtime_ns, st.st_size


def key(env: dict | None = None) -> str:
    """The installation and environment key a server serves (hex, 20 characters).

    Notes
    -----
    Cost: one ``stat`` per file of the netdae package (about 1 ms).
    """
    env = os.environ if env is None else env
    h = hashlib.sha256()
    h.update(repr((sys.executable, sys.version, tuple(sys.flags), sys.warnoptions, sys.path[1:],
                   os.getuid())).encode())
    for name in sorted(env):
        if name.startswith(KEY_PREFIXES) and name not in KEY_EXCLUDED:
            h.update(f"{name}={env[name]}\0".encode())
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    for item in sorted(_package_files(root)):
        h.update(repr(item).encode())
    return h.hexdigest()[:20]


def socket_path(env: dict | None = None) -> str | None:
    """The socket of the server for this key, or None when no private directory exists."""
    directory = server_dir(env)
    return None if directory is None else os.path.join(directory, f"{key(env)}.sock")


# -- framing -----------------------------------------------------------------------------
def send_frame(sock: socket.socket, payload: dict, fds: list[int] | None = None) -> None:
    """Send one length-prefixed JSON frame, with file descriptors attached to its first bytes."""
    body = json.dumps(payload).encode()
    data = _FRAME.pack(len(body)) + body
    if fds:
        sent = socket.send_fds(sock, [data], fds)
        data = data[sent:]
    if data:
        sock.sendall(data)


def _recv_exact(sock: socket.socket, n: int) -> bytes:
    chunks = []
    while n:
        chunk = sock.recv(n)
        if not chunk:
            raise EOFError("connection closed")
        chunks.append(chunk)
        n -= len(chunk)
    return b"".join(chunks)


def recv_frame(sock: socket.socket, *, fds: int = 0) -> tuple[dict, list[int]]:
    """Receive one frame and the file descriptors attached to it (at most ``fds``)."""
    received: list[int] = []
    if fds:
        head, received, _flags, _addr = socket.recv_fds(sock, _FRAME.size, fds)
        if not head:
            raise EOFError("connection closed")
        if len(head) < _FRAME.size:
            head += _recv_exact(sock, _FRAME.size - len(head))
    else:
        head = _recv_exact(sock, _FRAME.size)
    (size,) = _FRAME.unpack(head)
    if size > _MAX_FRAME:
        raise ValueError(f"frame of {size} bytes")
    return json.loads(_recv_exact(sock, size)), list(received)


def _connect(path: str, timeout: float = 1.0) -> socket.socket | None:
    sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    sock.settimeout(timeout)
    try:
        sock.connect(path)
    except OSError:
        sock.close()
        return None
    return sock


def request(kind: str, path: str, timeout: float = 5.0) -> dict | None:
    """Send a ``status`` or ``stop`` request; the server's answer, or None when none answers."""
    sock = _connect(path)
    if sock is None:
        return None
    with sock:
        sock.settimeout(timeout)
        try:
            send_frame(sock, {"kind": kind})
            answer, _ = recv_frame(sock)
        except (OSError, EOFError, ValueError):
            return None
    return answer


# -- running a command -------------------------------------------------------------------
_FORWARDED = ("SIGINT", "SIGTERM", "SIGHUP", "SIGQUIT", "SIGUSR1", "SIGUSR2", "SIGWINCH")


def _stream_spec(stream) -> dict:
    return {"encoding": getattr(stream, "encoding", None) or "utf-8",
            "errors": getattr(stream, "errors", None) or "strict"}


def forward(argv: list[str], path: str) -> int | None:
    """Run a command line in the server at ``path``; its exit status, or None when no server took it.

    None means nothing ran (no server, or it refused before starting a
    worker): the caller runs the command itself.

    Raises
    ------
    RunStatus
        The worker started but the connection ended without its status.
    """
    try:  # a deleted working directory, an unreadable limit: run here, where the error is reported
        payload = {
            "kind": "run", "argv": list(argv), "cwd": os.getcwd(), "env": dict(os.environ),
            "umask": _umask(), "limits": limits(), "stdin": _stream_spec(sys.stdin),
            "stdout": _stream_spec(sys.stdout), "stderr": _stream_spec(sys.stderr),
        }
    except (OSError, ValueError):
        return None
    sock = _connect(path)
    if sock is None:
        return None
    with sock:
        sock.settimeout(30.0)
        try:
            for stream in (sys.stdout, sys.stderr):
                stream.flush()
            send_frame(sock, payload, [0, 1, 2])
            started, _ = recv_frame(sock)
        except (OSError, EOFError, ValueError):
            return None
        pid = started.get("pid")
        if not isinstance(pid, int):
            return None
        previous = {}

        def relay(signum, _frame):
            try:
                os.kill(pid, signum)
            except OSError:
                pass

        def suspend(_signum, _frame):  # Ctrl-Z: stop the worker, then this process as the shell expects
            try:
                os.kill(pid, signal.SIGSTOP)
            except OSError:
                pass
            os.kill(os.getpid(), signal.SIGSTOP)

        def resume(_signum, _frame):
            try:
                os.kill(pid, signal.SIGCONT)
            except OSError:
                pass

        for name in _FORWARDED:
            signum = getattr(signal, name, None)
            if signum is not None:
                previous[signum] = signal.signal(signum, relay)
        if hasattr(signal, "SIGTSTP"):
            previous[signal.SIGTSTP] = signal.signal(signal.SIGTSTP, suspend)
            previous[signal.SIGCONT] = signal.signal(signal.SIGCONT, resume)
        try:
            sock.settimeout(None)
            done, _ = recv_frame(sock)
        except (OSError, EOFError, ValueError) as exc:
            raise RunStatus(f"the netdae server's worker (pid {pid}) ended without a status ({exc})") from None
        finally:
            for signum, handler in previous.items():
                signal.signal(signum, handler)
    status = done.get("status")
    if not isinstance(status, int):
        raise RunStatus("the netdae server answered without an exit status")
    if status < 0:  # the worker was ended by a signal: end the same way, as a shell expects
        return 128 - status
    return status


#: Resource limits a command run through the server keeps (``ulimit``): the worker lowers its own to them.
LIMITS = ("RLIMIT_AS", "RLIMIT_DATA", "RLIMIT_RSS", "RLIMIT_CPU", "RLIMIT_FSIZE", "RLIMIT_NOFILE",
          "RLIMIT_STACK", "RLIMIT_CORE", "RLIMIT_NPROC", "RLIMIT_MEMLOCK")


def limits() -> dict:
    """This process's resource limits by name (``resource.getrlimit``), for the worker to take."""
    import resource

    out = {}
    for name in LIMITS:
        which = getattr(resource, name, None)
        if which is not None:
            out[name] = list(resource.getrlimit(which))
    return out


def _umask() -> int:
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


# -- starting a server -------------------------------------------------------------------
_BOOT = ("import sys, json; a = json.loads(sys.argv[1]); sys.path[:] = a['path']; "
         "from netdae.server.serve import main; main(a['socket'], a['idle'])")


def idle_seconds(env: dict | None = None) -> float:
    """The idle time after which a server exits (``NETDAE_SERVER_IDLE``, seconds)."""
    env = os.environ if env is None else env
    try:
        value = float(env.get("NETDAE_SERVER_IDLE", IDLE_SECONDS))
    except ValueError:
        return IDLE_SECONDS
    return value if value > 0 else IDLE_SECONDS


def start(path: str, *, wait: float = 0.0):
    """Start a server for ``path`` in the background (its own session, no terminal).

    The server takes this process's interpreter, module path and environment,
    so it serves exactly this installation. With ``wait`` > 0, wait up to that
    many seconds for it to accept commands. Returns its ``subprocess.Popen``.
    """
    import subprocess

    args = json.dumps({"path": sys.path, "socket": path, "idle": idle_seconds()})
    proc = subprocess.Popen([sys.executable, "-c", _BOOT, args], stdin=subprocess.DEVNULL,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, cwd="/",
                            start_new_session=True, close_fds=True)
    if wait > 0:
        import time

        deadline = time.monotonic() + wait
        while time.monotonic() < deadline and proc.poll() is None:
            if request("status", path) is not None:
                break
            time.sleep(0.05)
    return proc
