"""Running out of memory is an ordinary limit: a located message, the computed part kept, never 'a bug'."""

from __future__ import annotations

import math

import numpy as np
import pytest

import netdae
import netdae.dae.compiled.driver as driver
from netdae.cli import main as cli

RC = "RC\nV1 in 0 PULSE(0 1 0 1u 1u 0.3m 0.6m)\nR1 in out 1k\nC1 out 0 100n\n.tran 1u 20m\n"


def test_output_that_cannot_grow_ends_the_transient_with_what_was_computed(monkeypatch):
    monkeypatch.setattr(driver, "BUFFER_START_BYTES", 0)  # start at WINDOW_MIN points, whatever the step bound
    full = netdae.simulate(RC)
    assert full.ok and full.t.size > 2 * driver.BUFFER_START
    calls = []

    def no_memory(*args):
        calls.append(1)
        raise MemoryError

    monkeypatch.setattr(driver, "_grow", no_memory)
    part = netdae.simulate(RC)
    assert calls == [1] and not part.ok
    assert "not enough memory to keep more output" in part.message and "--save" in part.message
    kept = part.t.size
    assert 0 < kept <= driver.BUFFER_START and part.t[-1] < 20e-3
    np.testing.assert_array_equal(part.t, full.t[:kept])
    np.testing.assert_array_equal(part["v(out)"], full["v(out)"][:kept])


def test_the_command_line_reports_memory_exhaustion_as_a_limit(tmp_path, capsys, monkeypatch):
    import netdae.analyses.runner as runner

    def exhausted(*args, **kwargs):
        raise MemoryError

    monkeypatch.setattr(runner, "run", exhausted)
    path = tmp_path / "rc.cir"
    path.write_text(RC)
    assert cli(["run", str(path)]) == 2
    err = capsys.readouterr().err
    assert "out of memory" in err and "--save" in err and "bug" not in err


def test_output_buffers_start_with_room_for_the_points_the_step_bound_implies():
    """span / max_step points and a quarter more and 64, as a power of two, and BUFFER_START at least, within
    BUFFER_START_BYTES but at least WINDOW_MIN points."""
    assert driver._buffer_start(60e-3, 50e-6, 9) == 2048  # 1,200 points at least
    assert driver._buffer_start(1.0, math.inf, 9) == driver.BUFFER_START
    assert driver._buffer_start(1e-3, 1e-3, 9) == driver.BUFFER_START
    assert driver._buffer_start(1.0, 1e-9, 9, most=driver.BUFFER_START) == driver.BUFFER_START  # blocks of output
    wide = 10**6  # columns: the bytes bound
    assert driver._buffer_start(1.0, 1e-9, wide) == driver.WINDOW_MIN
    many = driver._buffer_start(1.0, 1e-9, 9)
    assert many * 8 * (9 + 2) <= driver.BUFFER_START_BYTES < 2 * many * 8 * (9 + 2)


def test_a_large_circuit_that_records_few_points_starts_with_small_output_buffers():
    """A 200,000-stage RC ladder recording about 100 points (tstop / tmax = 100) starts within the byte budget,
    not with room for BUFFER_START points of every unknown (1.5 GiB)."""
    columns = 200_001
    row = 8 * (columns + 2)
    cap = driver._buffer_start(1e-3, 1e-5, columns)
    assert cap * row <= max(driver.BUFFER_START_BYTES, driver.WINDOW_MIN * row)
    assert cap * row < 32 * 2**20 < driver.BUFFER_START * row


def _ladder(path, stages: int, tran: str) -> None:
    lines = ["RC ladder", "V1 n0 0 PULSE(0 1 0 1n 1n 1u 2u)"]
    lines += [f"R{k} n{k - 1} n{k} 1k\nC{k} n{k} 0 1p" for k in range(1, stages + 1)]
    path.write_text("\n".join(lines + [tran, ".end"]) + "\n")


#: Runs argv[3:] (an API call or the command line) with the address space limited to what the process maps
#: after importing netdae and argv[1] MiB more.
_LIMITED = """
import resource, sys
import netdae, netdae.cli, netdae.dae.compiled.driver
with open("/proc/self/statm") as f:
    mapped = int(f.read().split()[0]) * resource.getpagesize()
resource.setrlimit(resource.RLIMIT_AS, (mapped + int(sys.argv[1]) * 2**20, resource.RLIM_INFINITY))
if sys.argv[2] == "simulate":
    try:
        netdae.simulate(sys.argv[3])
    except netdae.NetdaeError as exc:
        print(exc, file=sys.stderr)
        sys.exit(2)
else:
    sys.exit(netdae.cli.main(sys.argv[3:]))
"""


def _limited(tmp_path, mib: int, *args: str):
    import os
    import subprocess
    import sys

    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1"}
    return subprocess.run([sys.executable, "-c", _LIMITED, str(mib), *args], capture_output=True, text=True,
                          timeout=300, cwd=tmp_path, env=env)


@pytest.mark.skipif(not hasattr(__import__("os"), "sysconf"), reason="POSIX address-space limits")
def test_an_output_too_large_for_the_address_space_limit_is_refused_before_the_run(tmp_path):
    """ulimit -v below the machine's memory: the size check takes the limit (less what the process maps) as
    the room, and refuses at the .tran card a run whose fewest points (1e6 of 2,002 unknowns, 16 GB) could not
    be kept, instead of running into an allocation failure later."""
    import netdae.analyses.tran as tran_module

    path = tmp_path / "ladder.cir"
    _ladder(path, 2000, ".tran 1n 1m")
    points, size = tran_module.output_size(2002, 1e-3, 1e-9)
    assert size > 2**30
    done = _limited(tmp_path, 1024, "simulate", str(path))
    assert done.returncode == 2, done.stderr
    assert "ladder.cir:4003:1: .tran: keeping 2,002 of 2,002 unknowns" in done.stderr
    assert "(ulimit -v)" in done.stderr and "the run cannot finish" in done.stderr
    assert "Traceback" not in done.stderr and "MemoryError" not in done.stderr


def test_a_large_ladder_under_an_address_space_limit_runs_or_says_it_is_out_of_memory(tmp_path):
    """The command line under ulimit -v: the run finishes or ends with netdae's message, never a traceback."""
    path = tmp_path / "ladder.cir"
    _ladder(path, 20_000, ".tran 10n 1u")
    for mib in (64, 2048):
        done = _limited(tmp_path, mib, "cli", "run", "-q", str(path), "--out", str(tmp_path / f"out{mib}"))
        assert done.returncode in (0, 2), done.stderr
        assert "Traceback" not in done.stderr and "MemoryError" not in done.stderr and "bug" not in done.stderr
        if done.returncode == 2:
            assert "out of memory" in done.stderr or "(ulimit -v)" in done.stderr


def test_the_memory_room_is_the_smaller_of_the_machine_and_the_address_space_limit(monkeypatch):
    import netdae.analyses.tran as tran_module

    monkeypatch.setattr(tran_module, "physical_memory", lambda: 8 * 2**30)
    monkeypatch.setattr(tran_module, "address_space_room", lambda: None)
    assert tran_module.memory_room() == (8 * 2**30, "this machine has 8.0 GiB")
    monkeypatch.setattr(tran_module, "address_space_room", lambda: 2**30)
    assert tran_module.memory_room() == (2**30, "this process may map 1.0 GiB more (ulimit -v)")
    monkeypatch.setattr(tran_module, "address_space_room", lambda: 16 * 2**30)
    assert tran_module.memory_room()[0] == 8 * 2**30
