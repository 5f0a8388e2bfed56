"""Ctrl-C keeps what was computed: the partial transient in the API and in ``netdae run``'s files.

A progress callback that raises KeyboardInterrupt stands for the signal: it is
called from the transient's loop, where a real Ctrl-C arrives.
"""

from __future__ import annotations

import numpy as np
import pytest

import netdae

NETLIST = """RC low-pass driven by a sine
V1 in 0 SIN(0 1 1k)
R1 in out 1k
C1 out 0 100n
.op
.tran 1u 20m
.end
"""


class StopAt:
    """A progress callback that raises KeyboardInterrupt once the transient passes ``t_stop``."""

    def __init__(self, t_stop):
        self.t_stop = t_stop

    def __call__(self, t, tstop, steps):
        if t >= self.t_stop:
            raise KeyboardInterrupt

    def close(self):
        pass


@pytest.fixture(autouse=True)
def progress_every_chunk(monkeypatch):
    """Report progress after every chunk of steps (not every 0.1 s), so that the test interrupts mid-run."""
    from netdae.dae.compiled import driver

    monkeypatch.setattr(driver, "PROGRESS_INTERVAL", 0.0)


def test_run_hands_on_the_results_computed_before_the_interrupt():
    with pytest.raises(KeyboardInterrupt) as info:
        netdae.run(netdae.load(NETLIST), progress=StopAt(1e-3))
    results = info.value.results
    assert [r.analysis for r in results] == ["op", "tran"]
    tran = results[-1]
    assert not tran.ok and "interrupted at t=" in tran.message
    t = tran.axes["time"]
    assert 1e-3 <= t[-1] < 20e-3 and np.all(np.diff(t) >= 0)
    # the kept part is the solution: RC low-pass of a 1 kHz sine, compared with the full run
    full = next(r for r in netdae.run(netdae.load(NETLIST)) if r.analysis == "tran")
    tt = np.linspace(0.0, t[-1], 200)
    assert np.max(np.abs(tran.dense(tt)["v(out)"] - full.dense(tt)["v(out)"])) < 1e-3


def test_netdae_run_writes_the_partial_results_and_exits_130(tmp_path, monkeypatch, capsys):
    from netdae.cli import main
    from netdae.cli import progress

    path = tmp_path / "rc.cir"
    path.write_text(NETLIST)
    monkeypatch.setattr(progress, "ProgressBar", lambda enabled=True: StopAt(2e-3))
    status = main(["run", str(path), "--out", str(tmp_path / "out")])
    assert status == 130
    lines = (tmp_path / "out" / "tran.csv").read_text().splitlines()
    last_t = float(lines[-1].split(",")[0])
    assert 2e-3 <= last_t < 20e-3
    assert (tmp_path / "out" / "op.csv").exists()
    last = capsys.readouterr().err.strip().splitlines()[-1]
    assert last.startswith("netdae: error: interrupted at t=")  # once (it read "interrupted: interrupted at t=")


DC_NETLIST = """Diode curve, many points
V1 in 0 0
D1 in out dd
R1 out 0 1k
.model dd d is=1e-14
.op
.dc V1 0 1 1e-4
.end
"""


def test_an_interrupted_dc_sweep_keeps_the_points_solved(monkeypatch):
    """Ctrl-C during a long .dc: the operating point and the sweep's points up to it are handed on."""
    from netdae.analyses import dc
    from netdae.dae.compiled import steady_driver

    calls = []
    solve = steady_driver.sweep_points

    def interrupted_third_chunk(*args, **kwargs):
        calls.append(1)
        if len(calls) == 3:
            raise KeyboardInterrupt
        return solve(*args, **kwargs)

    monkeypatch.setattr(dc, "SWEEP_CHUNK", 1000)
    monkeypatch.setattr(steady_driver, "sweep_points", interrupted_third_chunk)
    with pytest.raises(KeyboardInterrupt) as info:
        netdae.run(netdae.load(DC_NETLIST), save=["v(out)"])
    op, sweep = info.value.results
    assert op.analysis == "op" and op.ok
    # the first point by the full solver, then two chunks of 1,000 compiled points
    v1 = sweep.axes["v1"]
    assert sweep.analysis == "dc" and not sweep.ok and v1.size == 2001
    assert "interrupted at v1 = 0.2, point 2001 of 10001" in sweep.message
    assert sweep.names() == ["v(out)"]
    # the kept points are the sweep's: the same values as the whole sweep's first 2,001
    full = netdae.run(netdae.load(DC_NETLIST), save=["v(out)"])[1]
    np.testing.assert_array_equal(sweep["v(out)"], full["v(out)"][:2001])


def test_sigterm_and_sighup_stop_a_command_as_ctrl_c_does():
    """On the command line SIGTERM and SIGHUP raise Terminated (a KeyboardInterrupt) in the command, so that
    what was computed is written; the exit status is 128 + the signal, and the handlers are restored."""
    import os
    import signal
    import time

    from netdae.cli import Terminated, _termination_as_interrupt, interruption

    for signum in (signal.SIGTERM, signal.SIGHUP):
        before = signal.getsignal(signum)
        with pytest.raises(Terminated) as info:
            with _termination_as_interrupt():
                os.kill(os.getpid(), signum)
                time.sleep(5)
        assert isinstance(info.value, KeyboardInterrupt) and info.value.signum == signum
        assert interruption(info.value) == (f"terminated ({signal.Signals(signum).name})", 128 + signum)
        assert signal.getsignal(signum) == before
    assert interruption(KeyboardInterrupt()) == ("interrupted", 130)
