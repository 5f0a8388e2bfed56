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
    monkeypatch.setattr(driver, "BUFFER_START_BYTES", 0)  # start at BUFFER_START points, whatever the step bound
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
    """span / max_step points and a quarter more, as a power of two, within BUFFER_START_BYTES;
    no bound (or a run of fewer points): BUFFER_START."""
    assert driver._buffer_start(60e-3, 50e-6, 9) == 2048  # 1,200 points at least
    assert driver._buffer_start(1.0, math.inf, 9) == driver.BUFFER_START
    assert driver._buffer_start(1e-3, 1e-3, 9) == driver.BUFFER_START
    wide = 10**6  # columns: the bytes bound
    assert driver._buffer_start(1.0, 1e-9, wide) == driver.BUFFER_START
    many = driver._buffer_start(1.0, 1e-9, 9)
    assert many * 8 * (9 + 2) <= driver.BUFFER_START_BYTES < 2 * many * 8 * (9 + 2)
