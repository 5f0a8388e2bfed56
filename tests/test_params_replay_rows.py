"""A recorded elaboration replayed for many rows at once (``Replay.rows``) against one row at a time.

``Replay.values`` repeats a traced elaboration for one sample in Python floats;
``Replay.rows`` does the same evaluations for many samples on arrays over the rows,
each row's draws from its own sample's stream. A row it marks good must have every
value ``Replay.values`` gives that row, bit for bit, and (through it) the values an
elaboration of that sample gives its elements; a row it cannot vouch for (another
branch of ``c ? a : b``, a division by zero, a sigma that is not positive) must be
marked, never given other numbers.
"""

from __future__ import annotations

import numpy as np
import pytest

from netdae.errors import NetlistError
from netdae.netlist import load
from netdae.netlist.elaborate import elaborate
from netdae.netlist.params import Replay, ReplayMismatch, Trace

#: Every Monte Carlo function; nested .param dependencies (a global draw used by several values and
#: by other parameters); per-instance draws (in element values and in subcircuit parameters and
#: defaults); a .func; built-in functions and operators whose scalar and vectorised roundings could differ.
EVERYTHING = """replay of every kind of evaluation
.param seed_r={agauss(1k, 50, 1)} g={gauss(100n, 0.05, 3)} u={unif(10m, 0.1)} a={aunif(2, 0.5)}
.param lim={limit(500, 50)}
.param twice={2*seed_r} mixed={twice/3 + sqrt(seed_r)*a - lim**1.5/1e3} deep={mixed*pow(a, 2) + exp(-a)}
.param sel={max(seed_r, 1k) + min(u*1e5, 1k) + abs(-a) + ln(seed_r) + sin(a) + tan(a/4) + atan(a)}
.func scaled(x, y) {x*y + 1}
.subckt cell a b rv=1k cv={aunif(100n, 5n)}
R1 a m {rv*unif(1, 0.01)}
C1 m b {cv}
.ends
V1 in 0 DC {aunif(5, 0.1)} AC {agauss(1, 0.01, 1)}
R1 in a {seed_r}
R2 a 0 {twice}
R3 a b {mixed + 10k}
R4 b 0 {deep + 10k}
R5 b c {sel}
L1 c d {u}
C1 d 0 {g}
C2 d 0 {scaled(g, 2)}
R6 d 0 {agauss(1k, 100, 2)}
R7 d 0 {agauss(1k, 100, 2)}
X1 d 0 cell rv={agauss(2k, 100, 1)}
X2 d 0 cell
.ac dec 5 100 100k
.meas ac peak max vm(d)
"""


def _traced(text: str, seed: int, params=None) -> tuple[Trace, Replay]:
    trace = Trace()
    elaborate(load(text).netlist, sample=0, seed=seed, params=params, trace=trace)
    assert trace.broken is None
    return trace, Replay(trace, seed)


def _row(values, r: int):
    """Row ``r`` of :meth:`Replay.rows`'s values (an array, a float shared by the rows, or None)."""
    return [v if v is None or isinstance(v, float) else v[r] for v in values]


def _assert_rows_are_the_scalar_replay(replay: Replay, samples, params=None) -> np.ndarray:
    values, ok = replay.rows(samples, params)
    for r, k in enumerate(samples):
        if not ok[r]:
            continue
        got, want = _row(values, r), replay.values(k, params[r] if params else None)
        for e, (a, b) in enumerate(zip(got, want)):
            assert (a is None and b is None) or (a is not None and b is not None and float(a) == float(b)), \
                f"sample {k}, evaluation {e}: {a!r} != {b!r}"
    return ok


def test_every_function_nested_parameters_and_instances_equal_the_scalar_replay_bit_for_bit():
    trace, replay = _traced(EVERYTHING, 11)
    samples = list(range(120))
    ok = _assert_rows_are_the_scalar_replay(replay, samples)
    assert ok.all()  # nothing here needs the scalar path
    values, _ = replay.rows(samples)
    fields = {e.role: v for e, v in zip(trace.events, values) if isinstance(e.role, tuple)}
    assert np.unique(fields[("r6", "value")]).size == len(samples)  # a draw per row
    # per-instance mismatch: R6 and R7 write the same agauss(), each draws its own; X1.C1 and X2.C1 too
    assert not np.array_equal(fields[("r6", "value")], fields[("r7", "value")])
    assert not np.array_equal(fields[("c.x1.c1", "value")], fields[("c.x2.c1", "value")])
    # a global draw: R1 and R2 read the same .param drawn once per row
    np.testing.assert_array_equal(fields[("r2", "value")], 2 * fields[("r1", "value")])


def test_the_rows_values_are_the_elaborated_elements_values():
    trace, replay = _traced(EVERYTHING, 5)
    samples = [0, 3, 17, 40]
    values, ok = replay.rows(samples)
    assert ok.all()
    netlist = load(EVERYTHING).netlist
    for r, k in enumerate(samples):
        fields = {e.role: v for e, v in zip(trace.events, _row(values, r)) if isinstance(e.role, tuple)}
        circuit = elaborate(netlist, sample=k, seed=5)
        for el in circuit.elements:
            if el.value is not None and (el.name, "value") in fields:
                assert float(fields[(el.name, "value")]) == el.value, (k, el.name)
        v1 = circuit.element("v1").source
        assert (float(fields[("v1", "dc")]), float(fields[("v1", "ac_mag")])) == (v1.dc, v1.ac_mag)


def test_the_draws_do_not_depend_on_the_other_rows():
    _, replay = _traced(EVERYTHING, 2)
    together, _ = replay.rows(list(range(30)))
    for part in ([5, 6, 7], [29, 0], [13]):
        alone, ok = replay.rows(part)
        assert ok.all()
        for v_all, v_part in zip(together, alone):
            if v_all is None or isinstance(v_all, float):
                assert v_part == v_all
            else:
                np.testing.assert_array_equal(np.asarray(v_part), v_all[part])


def test_top_level_parameter_values_per_row():
    text = """stepped
.param rl=1k k=2
R1 a 0 {rl*agauss(1, 0.1, 1)}
R2 a 0 {rl + k*unif(1, 0.5)}
V1 a 0 AC 1
.ac dec 5 1 1k
.meas ac m max vm(a)
"""
    _, replay = _traced(text, 3, params={"rl": 1e3, "k": 2.0})
    params = [{"rl": rl, "k": k} for rl in (500.0, 1e3, 2e3) for k in (1.0, 3.0)]
    ok = _assert_rows_are_the_scalar_replay(replay, list(range(len(params))), params)
    assert ok.all()
    low, _ = replay.rows([0, 1], [{"rl": 1.0, "k": 1.0}] * 2)
    high, _ = replay.rows([0, 1], [{"rl": 2.0, "k": 1.0}] * 2)
    assert any(not np.array_equal(a, b) for a, b in zip(low, high) if isinstance(a, np.ndarray))


def test_a_row_on_the_other_branch_of_a_conditional_is_left_to_its_own_replay():
    text = """branches
.param x={agauss(1, 0.5, 1)}
.param y={x > 1 ? aunif(10, 1) : 2*aunif(3, 1)}
R1 a 0 {y + 100}
V1 a 0 AC 1
.ac dec 5 1 1k
.meas ac m max vm(a)
"""
    from netdae.netlist.montecarlo import Draws

    _, replay = _traced(text, 4)
    samples = list(range(40))
    branch = np.array([Draws(4, k).draw("agauss", [1.0, 0.5, 1.0]) > 1 for k in samples])
    assert 0 < branch.sum() < len(samples)
    ok = _assert_rows_are_the_scalar_replay(replay, samples)
    np.testing.assert_array_equal(ok, branch == branch[0])  # the first row's branch is the one evaluated
    ok = _assert_rows_are_the_scalar_replay(replay, samples[::-1])
    np.testing.assert_array_equal(ok, branch[::-1] == branch[-1])


def test_rows_whose_own_evaluation_fails_are_marked_never_given_numbers():
    # 1/limit(1, 1) divides by zero in about half the rows; agauss with a drawn sigma has a negative one in others
    text = """failures
.param d={limit(1, 1)} s={limit(0.5, 1)}
R1 a 0 {1/d + 1}
R2 a 0 {agauss(1k, 10, s)}
V1 a 0 AC 1
.ac dec 5 1 1k
.meas ac m max vm(a)
"""
    from netdae.netlist.montecarlo import Draws

    def first_draws(seed, k):
        d = Draws(seed, k)
        return d.draw("limit", [1.0, 1.0]), d.draw("limit", [0.5, 1.0])

    seed = next(s for s in range(1, 200) if first_draws(s, 0) == (2.0, 1.5))
    _, replay = _traced(text, seed)
    samples = list(range(32))
    ok = _assert_rows_are_the_scalar_replay(replay, samples)
    for r, k in enumerate(samples):
        d, s = first_draws(seed, k)
        assert ok[r] == (d != 0.0 and s > 0.0)
        if not ok[r]:
            with pytest.raises(NetlistError):
                replay.values(k)
    assert 0 < ok.sum() < len(samples)


def test_rows_that_draw_in_other_places_than_the_recording_are_left_to_their_own_replay():
    # the branch taken decides how many values are drawn: a row whose first row (in the pass) draws
    # otherwise than the recorded elaboration leaves every row to the scalar replay
    text = """draws in a branch
.param x={agauss(1, 0.5, 1)}
.param y={x > 1 ? agauss(10, 1, 1) + agauss(1, 1, 1) : 2}
R1 a 0 {y + 100}
V1 a 0 AC 1
.ac dec 5 1 1k
.meas ac m max vm(a)
"""
    from netdae.netlist.montecarlo import Draws

    def above(seed, k):
        return Draws(seed, k).draw("agauss", [1.0, 0.5, 1.0]) > 1

    seed = next(s for s in range(1, 200) if above(s, 0))
    _, replay = _traced(text, seed)
    samples = list(range(40))
    branch = np.array([above(seed, k) for k in samples])
    assert 0 < branch.sum() < len(samples)
    on, off = samples[int(np.argmax(branch))], samples[int(np.argmin(branch))]
    ok = _assert_rows_are_the_scalar_replay(replay, [on] + samples)
    np.testing.assert_array_equal(ok, np.concatenate([[True], branch]))
    _, ok = replay.rows([off] + samples)
    assert not ok.any()
    with pytest.raises(ReplayMismatch):
        replay.values(off)
