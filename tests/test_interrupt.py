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
    assert "interrupted at t=" in capsys.readouterr().err
