"""The netdae server: a command run through it is the command run in its own process.

A real server (``netdae server start``) in a private directory of the test;
commands go through :func:`netdae.server.client.forward` (the console script's
path) and are compared with the same command run by :func:`netdae.cli.main`
in this process: same exit status, same files, same messages. Signals reach
the worker, so Ctrl-C keeps the partial results as without a server.
"""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import time

import pytest

from netdae.server import client

from conftest import NETLISTS

pytestmark = pytest.mark.skipif(not hasattr(__import__("socket"), "send_fds"), reason="no Unix fd passing")


def _env(tmp_path, **extra) -> dict:
    env = dict(os.environ)
    env.update({"NETDAE_SERVER": "1", "NETDAE_SERVER_DIR": str(tmp_path / "sockets"), "NETDAE_SERVER_IDLE": "120"})
    env.update(extra)
    return env


def _netdae(*args, env, **kw) -> subprocess.CompletedProcess:
    script = os.path.join(os.path.dirname(sys.executable), "netdae")
    return subprocess.run([script, *args], env=env, capture_output=True, text=True, timeout=300, **kw)


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    """A started server; yields (socket path, environment); stopped at the end."""
    tmp = tmp_path_factory.mktemp("server")
    env = _env(tmp)
    started = _netdae("server", "start", env=env)
    assert started.returncode == 0, started.stderr
    status = _netdae("server", "status", env=env)
    assert status.returncode == 0 and "netdae server pid" in status.stdout
    path = re.search(r"socket (\S+?)[,)]", status.stdout).group(1)
    yield path, env
    stopped = _netdae("server", "stop", env=env)
    assert "stopped 1 netdae server" in stopped.stdout
    assert _netdae("server", "status", env=env).returncode == 1


def _without_walls(text: str) -> str:
    return re.sub(r"wall=[0-9.e+-]+s", "wall=?", text)


def test_a_run_through_the_server_is_the_run_in_this_process(server, tmp_path, capfd, monkeypatch):
    path, env = server
    from netdae.cli import main

    argv = ["run", str(NETLISTS / "rc_lowpass.cir"), "--format", "csv"]
    monkeypatch.setenv("NETDAE_SERVER_DIR", env["NETDAE_SERVER_DIR"])
    status = client.forward(argv + ["--out", str(tmp_path / "served")], path)
    served = capfd.readouterr()
    assert status == 0, served.err  # not None: the server ran it
    local = main(argv + ["--out", str(tmp_path / "local")])
    here = capfd.readouterr()
    assert local == 0
    assert _without_walls(served.out) == _without_walls(here.out)
    assert served.err.replace("served", "local") == here.err
    for name in ("tran.csv", "ac.csv"):
        assert (tmp_path / "served" / name).read_bytes() == (tmp_path / "local" / name).read_bytes()


def test_the_working_directory_and_the_error_status_are_the_callers(server, tmp_path, capfd):
    path, _env_ = server
    bad = tmp_path / "bad.cir"
    bad.write_text("bad netlist\nR1 a 0 1k\nC1 a 0 oops\n.tran 1u 1m\n.end\n")
    old = os.getcwd()
    os.chdir(tmp_path)
    try:
        status = client.forward(["run", "bad.cir"], path)
    finally:
        os.chdir(old)
    err = capfd.readouterr().err
    assert status == 2
    assert re.search(r"bad\.cir:3:\d+", err), err  # located, relative to the caller's directory


def test_the_console_script_uses_the_running_server(server, tmp_path):
    path, env = server
    t0 = time.monotonic()
    done = _netdae("run", str(NETLISTS / "rc_lowpass.cir"), "--out", str(tmp_path / "o"), "-q", env=env)
    assert done.returncode == 0, done.stderr
    assert (tmp_path / "o" / "tran.csv").exists()
    # the in-process alternative imports numba and initialises it: well over a second on any machine
    assert client.request("status", path) is not None
    assert time.monotonic() - t0 < 60


LONG = "long RC ladder run\nV1 n0 0 SIN(0 1 1k)\n" + "".join(
    f"R{k} n{k - 1} n{k} 100\nC{k} n{k} 0 10n\n" for k in range(1, 101)) + ".save v(n100)\n.tran 1m 20\n.end\n"


def test_ctrl_c_reaches_the_worker_and_keeps_the_partial_results(server, tmp_path):
    _path, env = server
    netlist = tmp_path / "long.cir"
    netlist.write_text(LONG)
    script = os.path.join(os.path.dirname(sys.executable), "netdae")
    proc = subprocess.Popen([script, "run", str(netlist), "--out", str(tmp_path / "o")], env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    time.sleep(1.0)
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=120)
    assert proc.returncode == 130, err
    assert "interrupted at t=" in out + err
    rows = (tmp_path / "o" / "tran.csv").read_text().splitlines()
    assert 0.0 < float(rows[-1].split(",")[0]) < 20.0


def test_the_key_follows_the_environment_and_the_switch():
    base = dict(os.environ, NETDAE_SERVER="1")
    assert client.key(base) == client.key(dict(base, NETDAE_SERVER_IDLE="5"))
    assert client.key(base) != client.key(dict(base, NUMBA_OPT="1"))
    assert client.key(base) != client.key(dict(base, NETDAE_DEBUG="1"))
    assert client.enabled(dict(base, NETDAE_SERVER="1"))
    assert not client.enabled(dict(base, NETDAE_SERVER="0"))
    assert not client.enabled(dict(base, NETDAE_SERVER="off"))


def test_an_unsafe_socket_directory_is_not_used(tmp_path):
    shared = tmp_path / "shared"
    shared.mkdir(mode=0o777)
    os.chmod(shared, 0o777)
    assert client.server_dir({"NETDAE_SERVER_DIR": str(shared)}) is None
    private = tmp_path / "private"
    assert client.server_dir({"NETDAE_SERVER_DIR": str(private)}) == str(private)
    assert (private.stat().st_mode & 0o777) == 0o700


def test_no_server_means_nothing_ran(tmp_path):
    assert client.forward(["run", "x.cir"], str(tmp_path / "none.sock")) is None


def test_the_callers_resource_limits_bind_the_worker(server, tmp_path):
    """``ulimit -f`` of the caller applies to the command run by the server (its output file is cut)."""
    import resource

    _path, env = server

    def small_files():
        resource.setrlimit(resource.RLIMIT_FSIZE, (4096, resource.getrlimit(resource.RLIMIT_FSIZE)[1]))

    args = ["run", str(NETLISTS / "rc_lowpass.cir"), "-q"]
    limited = _netdae(*args, "--out", str(tmp_path / "limited"), env=env, preexec_fn=small_files)
    assert limited.returncode == 2 and "file-size limit" in limited.stderr, limited.stderr
    # the transient's file, written as it ran, stops at the limit and keeps its complete rows
    from netdae.io.csv import read_csv

    kept = tmp_path / "limited" / "tran.csv"
    assert kept.stat().st_size <= 4096 and f"it holds the {read_csv(kept).points:,} points" in limited.stderr
    free = _netdae(*args, "--out", str(tmp_path / "free"), env=env)
    assert free.returncode == 0 and (tmp_path / "free" / "tran.csv").stat().st_size > 4096
