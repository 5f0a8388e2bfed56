"""The integrator's recorder alone: buffers, restarts, jumps and the dense output's segments."""

from __future__ import annotations

import numpy as np
import pytest

from netdae.dae.bdf.constants import BUFFER_START, BUFFER_START_BYTES
from netdae.dae.bdf.recorder import Recorder
from netdae.results import STATUS_OK


def _result(rec):
    return rec.result(stats={"steps": rec.m - 1}, status=STATUS_OK, message="ok", tolerances={"rtol": 1e-3},
                      failure=None)


def test_a_recorder_of_many_unknowns_starts_within_the_byte_budget():
    """200,001 saved unknowns: 16 points (25.6 MB), not BUFFER_START (1.6 GB); it still grows when full."""
    n = 200_001
    rec = Recorder([f"v({k})" for k in range(n)], np.arange(n), True)
    row = 8 * n
    assert rec.x.nbytes <= max(BUFFER_START_BYTES, 16 * row) < BUFFER_START * row
    for i in range(rec.t.size + 1):
        rec.record(float(i), np.zeros(n), 1)
    assert rec.m == rec.t.size // 2 + 1 and rec.x.shape[0] == rec.t.size


def test_records_saved_components_and_grows_its_buffers():
    rec = Recorder(("a", "b", "c"), np.array([2, 0]), False)
    m = BUFFER_START + 5
    for i in range(m):
        rec.record(float(i), np.array([i, 10.0 * i, 100.0 * i]), min(i, 5))
    res = _result(rec)
    assert rec.m == m and res.t.size == m
    assert res.names == ("c", "a")
    np.testing.assert_array_equal(res.x[-1], [100.0 * (m - 1), m - 1])
    assert res.order.dtype == np.int8 and res.order[0] == 0 and res.order[-1] == 5
    np.testing.assert_array_equal(res.save, [2, 0])


def test_a_jump_records_the_right_limit_at_the_same_time_in_a_new_segment():
    rec = Recorder(("u", "i"), np.arange(2), True)
    rec.record(0.0, np.array([0.0, 0.0]), 0)
    rec.record(1.0, np.array([1.0, 1.0]), 1)
    rec.jump(1.0, np.array([1.0, 5.0]), ["i"])
    rec.record(2.0, np.array([2.0, 5.0]), 1)
    res = _result(rec)
    np.testing.assert_array_equal(res.t, [0.0, 1.0, 1.0, 2.0])
    assert res.jumps == [(1.0, ("i",))]
    assert rec.segments == [0, 2]
    assert res.order[2] == 0
    # the dense output never interpolates across the jump: left value at t, the right segment after it
    np.testing.assert_allclose(res.dense(np.array([0.5, 1.0, 1.5]))[:, 1], [0.5, 1.0, 5.0])


def test_a_restart_begins_a_segment_at_the_last_point():
    rec = Recorder(("x",), np.arange(1), True)
    for t, x in ((0.0, 0.0), (1.0, 1.0), (2.0, 2.0)):
        rec.record(t, np.array([x]), 1 if t else 0)
    rec.restart(2.0)
    rec.record(3.0, np.array([0.0]), 1)
    res = _result(rec)
    np.testing.assert_array_equal(res.restarts, [2.0])
    assert rec.segments == [0, 2]
    assert res.dense(np.array([2.5]))[0, 0] == pytest.approx(1.0)


def test_result_copies_the_buffers():
    rec = Recorder(("x",), np.arange(1), True)
    rec.record(0.0, np.array([1.0]), 0)
    res = _result(rec)
    rec.record(1.0, np.array([2.0]), 1)
    rec.x[0, 0] = -1.0
    assert res.x[0, 0] == 1.0 and res.t.size == 1
