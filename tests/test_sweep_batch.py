"""Linear AC sweeps solved together (netdae/sweeps/linear.py) against every row run on its own.

The batch path replays the first row's elaboration for each row's sample and values
(netdae.netlist.params.Replay), builds the rows' matrices as a linear map of the
element fields, solves all rows and frequencies at once and measures all rows at
once. Every test compares it with the same sweep whose rows all take the ordinary
path (``run_row``: elaborate, analyse, measure), to rounding.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import netdae
import netdae.sweeps.linear as linear
from netdae.netlist import load
from netdae.netlist.params import Replay, Trace

#: Relative agreement asked of the batched measures with the ordinary path's.
RTOL = 1e-12

#: Every Monte Carlo function, global (.param) and per instance (element values, subcircuit parameters), a .func.
MC_ALL = """band-pass with every Monte Carlo function
.param rg={agauss(1k, 50, 1)} cg={gauss(100n, 0.05, 1)} lg={unif(10m, 0.1)}
.func half(x) {x/2}
.subckt shunt a b rv=1k
R1 a m {rv}
C1 m b {aunif(100n, 5n)}
.ends
V1 in 0 DC 0 AC 1
R1 in a {rg}
L1 a b {half(2*lg)}
C1 b out {cg}
R2 out 0 {limit(500, 50)}
X1 out 0 shunt rv={agauss(2k, 100, 1)}
X2 out 0 shunt
.ac dec 20 100 100k
.meas ac peak max vm(out)
.meas ac fpk max_at vm(out)
.meas ac low min vdb(out)
.meas ac fhi when vm(out)=0.05 fall=1
.meas ac flast when vm(out)=0.05 cross=last
.meas ac ph find vp(out) at=1k
.meas ac gdb find vdb(out) when vm(out)=0.05 rise=1
.meas ac slope deriv vm(out) at=2k
.meas ac avgm avg vm(out) from=1k to=10k
.meas ac rmsm rms vm(out)
.meas ac ppdb pp vdb(out)
.meas ac area integ vm(out) from=200 to=20k
.meas ac bw trig vm(out) val=0.05 rise=1 targ vm(out) val=0.05 fall=1
.meas ac never when vm(out)=10
.meas ac third when vm(out)=0.05 rise=3
.meas ac ratio param='peak/avgm'
"""

#: Controlled sources whose gains are drawn, a stepped parameter, a supply whose DC value is drawn.
CONTROLLED = """controlled sources
.param ge={agauss(2, 0.1, 1)} gg={agauss(1m, 50u, 1)} gf={aunif(3, 0.2)} gh={agauss(100, 5, 1)}
.param rl=1k
.step param rl list 500 1k 2k
V1 in 0 AC 1
R1 in 0 1k
E1 e 0 in 0 {ge}
R2 e a 1k
C1 a 0 10n
G1 0 g a 0 {gg}
R3 g 0 {rl}
V2 g f 0
F1 0 o V2 {gf}
R4 o 0 1k
H1 h 0 V2 {gh}
L1 h o 1m
V3 d 0 DC {agauss(5, 0.1, 1)}
R5 d o 10k
.ac dec 10 1k 1meg
.meas ac vo max vm(o)
.meas ac fo when vm(o)=0.5 fall=1
.meas ac pho find vp(o) at=10k
"""


def _ordinary(monkeypatch, text, **kwargs):
    """The sweep with every row on the ordinary path."""
    with monkeypatch.context() as m:
        m.setattr(linear, "ac_batch", lambda job, rows: None)
        return netdae.sweep(text, workers=1, **kwargs)


def _spy(monkeypatch):
    """Rows run through ``run_row`` and rows elaborated on their own, while the batch path runs."""
    seen = {"ordinary": [], "elaborated": []}
    run_row, elaborate_row = linear.run_row, linear.elaborate_row
    monkeypatch.setattr(linear, "run_row", lambda job, row: seen["ordinary"].append(row.index) or run_row(job, row))
    monkeypatch.setattr(linear, "elaborate_row", lambda job, row, trace=None: seen["elaborated"].append(row.index)
                        or elaborate_row(job, row, trace))
    return seen


def _same(batched, ordinary, rtol=RTOL):
    assert batched.rows == ordinary.rows
    assert batched.errors == ordinary.errors
    assert batched.reasons == ordinary.reasons
    for name, values in ordinary.measures.items():
        got = batched.measures[name]
        assert np.array_equal(np.isnan(got), np.isnan(values)), name
        ok = ~np.isnan(values)
        np.testing.assert_allclose(got[ok], values[ok], rtol=rtol, atol=0, err_msg=name)


def test_every_monte_carlo_function_and_measure_kind_equals_the_ordinary_path(monkeypatch):
    ordinary = _ordinary(monkeypatch, MC_ALL, samples=40, seed=3)
    seen = _spy(monkeypatch)
    batched = netdae.sweep(MC_ALL, samples=40, seed=3, workers=1)
    assert seen["ordinary"] == [0] and seen["elaborated"] == [0]  # the rest replayed and solved together
    _same(batched, ordinary)
    assert not np.all(np.isnan(batched.measures["fhi"]))
    assert all(why.startswith("WHEN: vm(out) never crosses 10") for why in batched.reasons["never"])
    assert np.std(batched.measures["peak"]) > 0  # the draws differ between rows


def test_controlled_sources_and_a_step_list_equal_the_ordinary_path(monkeypatch):
    ordinary = _ordinary(monkeypatch, CONTROLLED, samples=10)
    seen = _spy(monkeypatch)
    batched = netdae.sweep(CONTROLLED, samples=10, workers=1)
    assert batched.rows == 30 and seen["ordinary"] == [0] and seen["elaborated"] == [0]
    _same(batched, ordinary)


def test_element_value_steps_equal_the_ordinary_path_and_the_closed_form(monkeypatch):
    text = """rc
V1 in 0 AC 1
R1 in out 1k
C1 out 0 1u
.ac dec 20 1 100k
.meas ac f3 when vdb(out)=-3.0103
"""
    values = {"r1": [500.0, 1e3, 2e3], "c1": [1e-7, 1e-6]}
    ordinary = _ordinary(monkeypatch, text, params=values)
    seen = _spy(monkeypatch)
    batched = netdae.sweep(text, params=values, workers=1)
    assert seen["ordinary"] == [0] and seen["elaborated"] == [0]
    _same(batched, ordinary)
    r, c = np.meshgrid(values["r1"], values["c1"], indexing="ij")
    # straight lines in frequency between 20 points a decade: the -3 dB point to about 0.5 %
    np.testing.assert_allclose(batched.measures["f3"], (1 / (2 * np.pi * r * c)).ravel(), rtol=5e-3)


def test_rows_that_cannot_be_replayed_fall_back_to_their_own_elaboration_or_the_ordinary_path(monkeypatch):
    # limit() gives R2 = 0 in some rows: their elaboration refuses the zero resistance, as the ordinary path does;
    # the phase steps have a stamp neither proportional nor reciprocal; the point count changes the grid
    text = """fallbacks
.param ph=0 pts=10
.step param ph list 0 30
.step param pts list 10 20
V1 in 0 AC 1 {ph}
R1 in out 1k
R2 out 0 {limit(1, 1)}
C1 out 0 1u
.ac dec {pts} 1 100k
.meas ac g find vm(out) at=100
.meas ac p find vp(out) at=100
"""
    from netdae.netlist.montecarlo import Draws

    def r2(seed, k):
        return Draws(seed, k).draw("limit", [1.0, 1.0])

    # a seed whose first sample is a resistance (the reference row) and some other sample is not
    seed = next(s for s in range(1, 100) if r2(s, 0) == 2.0 and 0.0 in [r2(s, k) for k in range(6)])
    ordinary = _ordinary(monkeypatch, text, samples=6, seed=seed)
    seen = _spy(monkeypatch)
    batched = netdae.sweep(text, samples=6, seed=seed, workers=1)
    _same(batched, ordinary)
    failed = [k for k, e in enumerate(batched.errors) if e is not None]
    assert failed and all("zero resistance" in batched.errors[k] for k in failed)
    assert set(failed) <= set(seen["ordinary"])
    assert len(seen["elaborated"]) > len(seen["ordinary"]) > 1  # the phase and grid steps elaborated again


def test_same_seed_same_samples_whatever_the_chunks_and_workers(monkeypatch):
    serial = netdae.sweep(MC_ALL, samples=30, seed=5, workers=1)
    monkeypatch.setattr("netdae.sweeps.api.SERIAL_CHUNK", 7)
    chunked = netdae.sweep(MC_ALL, samples=30, seed=5, workers=1)
    pooled = netdae.sweep(MC_ALL, samples=30, seed=5, workers=2)
    for other in (chunked, pooled):
        assert other.errors == serial.errors
        for name in serial.measures:
            np.testing.assert_array_equal(other.measures[name], serial.measures[name], err_msg=name)


def test_a_replayed_elaboration_draws_what_elaborating_the_sample_draws():
    c = load(MC_ALL)
    trace = Trace()
    from netdae.netlist.elaborate import elaborate

    elaborate(c.netlist, sample=0, seed=9, trace=trace)
    assert trace.broken is None
    replay = Replay(trace, 9)
    for k in (0, 1, 17):
        values = replay.values(k)
        fields = {e.role: v for e, v in zip(trace.events, values) if isinstance(e.role, tuple)}
        for el in elaborate(c.netlist, sample=k, seed=9).elements:
            if el.value is not None:
                assert fields[(el.name, "value")] == el.value  # bit for bit: the same stream, the same order


def test_a_draw_outside_a_parameter_marks_the_trace_unreplayable():
    text = """behavioural draw
V1 in 0 AC 1
B1 out 0 V=v(in)*agauss(1, 0.1, 1)
R1 out 0 1k
.ac dec 5 1 1k
"""
    from netdae.netlist.elaborate import elaborate

    trace = Trace()
    elaborate(load(text).netlist, trace=trace)
    assert trace.broken is not None


def test_the_batched_solve_equals_numpy_solve_per_frequency():
    from netdae.dae.shifted import shifted_solves

    rng = np.random.default_rng(4)
    E = rng.standard_normal((20, 5, 5))
    E[:, :2] = 0.0  # algebraic rows, as MNA has
    H = rng.standard_normal((20, 5, 5))
    b = rng.standard_normal((20, 5)) + 1j * rng.standard_normal((20, 5))
    s = 2j * math.pi * np.logspace(-1, 1, 9)
    X, failed = shifted_solves(E, H, b, s)
    assert not failed.any()
    direct = np.linalg.solve(s[None, :, None, None] * E[:, None] - H[:, None],
                             np.broadcast_to(b[:, None, :, None], (20, 9, 5, 1)))[..., 0]
    scale = np.abs(direct).max(axis=-1, keepdims=True)
    cond = np.linalg.cond(s[None, :, None, None] * E[:, None] - H[:, None])[..., None]
    assert np.all(np.abs(X - direct) / scale <= 50 * cond * np.finfo(float).eps)
    X, failed = shifted_solves(np.zeros((1, 2, 2)), np.zeros((1, 2, 2)), np.ones((1, 2)), s)
    assert failed.tolist() == [True]


@pytest.mark.parametrize("xq", [[-1.0, 0.0, 0.5, 3.0, 9.99, 10.0, 11.0], [2.0]])
def test_measure_interpolation_is_numpy_interp(xq):
    from netdae.analyses.measure import _interp

    rng = np.random.default_rng(1)
    x = np.sort(rng.uniform(0, 10, 30))
    x[0], x[-1] = 0.0, 10.0
    y = rng.standard_normal((4, 30))
    assert np.array_equal(_interp(xq, x, y), np.array([np.interp(xq, x, row) for row in y]))
    per = np.resize(np.asarray(xq), 4)
    assert np.array_equal(_interp(per, x, y, per_row=True), np.array([np.interp(q, x, r) for q, r in zip(per, y)]))


def test_a_row_whose_structure_changes_takes_the_ordinary_path(monkeypatch):
    # a resistance that changes sign changes the structure (the topology reads the sign of R C L values)
    text = """sign change
V1 in 0 AC 1
R1 in out 1k
R2 out 0 {aunif(0.5k, 1k)}
C1 out 0 1u
.ac dec 10 1 100k
.meas ac g find vm(out) at=100
"""
    from netdae.netlist.montecarlo import Draws

    def r2(seed, k):
        return Draws(seed, k).draw("aunif", [500.0, 1000.0])

    seed = next(s for s in range(1, 100) if r2(s, 0) > 0 and min(r2(s, k) for k in range(8)) < 0)
    negative = [k for k in range(8) if r2(seed, k) < 0]
    ordinary = _ordinary(monkeypatch, text, samples=8, seed=seed)
    seen = _spy(monkeypatch)
    batched = netdae.sweep(text, samples=8, seed=seed, workers=1)
    _same(batched, ordinary)
    assert set(negative) <= set(seen["ordinary"]) and set(negative) <= set(seen["elaborated"])
    assert len(seen["ordinary"]) == len(negative) + 1  # and the reference row


@pytest.mark.parametrize("key", [(0, 0), (1, 5), (2**31, 7), (2**32 - 1, 2**32 - 1), (2**32, 3), (5, 2**40), (3,), (0,),
                                 (7, 0), (1, 0, 0), (1, 2, 3), (0, 0, 0, 9), (2**32 - 1,) * 4, (1, 2, 3, 4, 5),
                                 (1, 2, 0, 0, 0)])
def test_the_sample_stream_is_numpys_seed_sequence_of_the_key(key):
    from netdae.netlist.montecarlo import generator

    ref = np.random.Generator(np.random.PCG64(np.random.SeedSequence(list(key))))
    assert np.array_equal(generator(key).standard_normal(5), ref.standard_normal(5))


@pytest.mark.parametrize("coupling", ["K1 L1 L2 0.9", "* uncoupled"])
def test_coupled_inductors_and_ac_resistances_equal_the_ordinary_path(monkeypatch, coupling):
    # a coupled inductor's stamp is not its own (M = k sqrt(L1 L2)): rows where it moves are elaborated again;
    # the ac= resistance is what .ac sees (H_ac), replayed
    text = f"""transformer
V1 in 0 AC 1
R1 in a 50 ac={{agauss(60, 3, 1)}}
L1 a 0 {{agauss(1m, 50u, 1)}}
L2 b 0 4m
{coupling}
R3 a b 10k
R2 b 0 {{agauss(1k, 50, 1)}}
.ac dec 10 100 1meg
.meas ac vb max vm(b)
.meas ac fb max_at vm(b)
"""
    ordinary = _ordinary(monkeypatch, text, samples=8)
    seen = _spy(monkeypatch)
    batched = netdae.sweep(text, samples=8, workers=1)
    _same(batched, ordinary)
    assert len(seen["elaborated"]) == (8 if coupling.startswith("K") else 1) and seen["ordinary"] == [0]


def test_an_element_with_two_moving_fields_is_elaborated_again(monkeypatch):
    # the value and the multiplier of R2 both drawn: the stamp is m / R, the changes multiply
    text = """two fields
V1 in 0 AC 1
R1 in out 1k
R2 out 0 {agauss(1k, 50, 1)} m={aunif(2, 0.5)}
C1 out 0 1u
.ac dec 10 1 100k
.meas ac g find vm(out) at=100
"""
    ordinary = _ordinary(monkeypatch, text, samples=6)
    seen = _spy(monkeypatch)
    batched = netdae.sweep(text, samples=6, workers=1)
    _same(batched, ordinary)
    assert len(seen["elaborated"]) == 6 and seen["ordinary"] == [0]


def test_rows_the_vectorised_replay_leaves_to_their_own_replay_equal_the_ordinary_path(monkeypatch):
    # the rows on the other branch of the conditional than the chunk's first replayed row are replayed one by
    # one (Replay.values), the others together (Replay.rows): every row as the ordinary path has it
    text = """branches
.param x={agauss(1, 0.5, 1)}
.param y={x > 1 ? aunif(10, 1) : 2*aunif(3, 1)}
V1 in 0 AC 1
R1 in out {y*100}
C1 out 0 1u
.ac dec 20 1 100k
.meas ac f3 when vdb(out)=-3.0103
.meas ac g find vm(out) at=200
"""
    from netdae.netlist.montecarlo import Draws

    ordinary = _ordinary(monkeypatch, text, samples=30, seed=4)
    seen = _spy(monkeypatch)
    alone = []
    values = Replay.values
    monkeypatch.setattr(Replay, "values", lambda self, k, params=None: alone.append(k) or values(self, k, params))
    batched = netdae.sweep(text, samples=30, seed=4, workers=1)
    _same(batched, ordinary)
    assert seen["ordinary"] == [0] and seen["elaborated"] == [0]
    branch = [Draws(4, k).draw("agauss", [1.0, 0.5, 1.0]) > 1 for k in range(30)]
    assert alone == [k for k in range(1, 30) if branch[k] != branch[1]] and alone


def test_the_regularity_screen_decides_as_the_singular_values_do():
    rng = np.random.default_rng(7)
    n = 5
    threshold = linear.RANK_TOLERANCE * n * np.finfo(float).eps
    H = rng.standard_normal((60, n, n))
    for k, ratio in enumerate(np.logspace(-18, -6, 40)):  # sigma_min / sigma_max from far below to far above
        u, _, vt = np.linalg.svd(H[k])
        H[k] = u @ np.diag(np.r_[np.ones(n - 1), ratio]) @ vt
    H[45, :, 2] = 0.0  # exactly singular: the batched inverse refuses the stack
    sv = np.linalg.svd(H, compute_uv=False)
    want = sv[:, -1] > threshold * sv[:, 0]
    assert want.any() and not want.all()
    np.testing.assert_array_equal(linear._regular(H), want)
    np.testing.assert_array_equal(linear._regular(np.delete(H, 45, axis=0)), np.delete(want, 45))
    for k in range(H.shape[0]):  # alone as in any stack
        assert linear._regular(H[k:k + 1])[0] == want[k]


def test_measure_columns_are_the_measures_of_each_row():
    from netdae.analyses.measure import evaluate_measure_columns, evaluate_measure_rows
    from netdae.results import Result

    specs = load(MC_ALL).measures
    rng = np.random.default_rng(2)
    f = np.logspace(2, 5, 61)
    rows = 25
    # band-pass magnitudes around 0.05, some rows never reaching the level, one row not finite
    gain = (0.02 + 0.1 * rng.random((rows, 1))) / (1 + (np.log10(f)[None, :] - 3.0 - 0.3 * rng.random((rows, 1))) ** 2)
    X = gain * np.exp(1j * rng.random((rows, f.size)))
    X[3, 10] = np.nan
    res = Result("ac", axes={"frequency": f}, signals={"v(out)": X}, message="ok")
    columns = evaluate_measure_columns(specs, {"ac": res}, rows)
    per_row = evaluate_measure_rows(specs, {"ac": res}, rows)
    assert [c.name for c in columns] == [s.name for s in specs]
    failures = 0
    for r, measures in enumerate(per_row):
        for c, m in zip(columns, measures):
            assert (c.reasons[r] is None) == m.ok, (c.name, r)
            if m.ok:
                assert c.values[r] == m.value, (c.name, r)
            else:
                assert c.reasons[r] == m.reason and np.isnan(c.values[r])
                failures += 1
    assert 0 < failures < rows * len(specs)


def test_ctrl_c_in_a_batch_keeps_the_rows_it_finished(monkeypatch):
    """Ctrl-C during the third part of a batched AC sweep: the reference row and the two parts solved and
    measured before it are in the result, with the measures of the ordinary path; the rest are 'not run'."""
    import netdae.dae.shifted as shifted

    real, calls = shifted.shifted_solves, []

    def interrupted(*args, **kwargs):
        calls.append(1)
        if len(calls) == 3:
            raise KeyboardInterrupt
        return real(*args, **kwargs)

    ordinary = _ordinary(monkeypatch, MC_ALL, samples=8, seed=5)
    monkeypatch.setattr(linear, "MAX_BATCH_ENTRIES", 1)  # one row per part
    monkeypatch.setattr(shifted, "shifted_solves", interrupted)
    with pytest.raises(KeyboardInterrupt) as exc:
        netdae.sweep(MC_ALL, samples=8, seed=5, workers=1)
    res = exc.value.result
    assert res.stats["completed"] == 3 and res.failed == 5
    assert "interrupted: 3 of 8 rows finished, 5 not run" in res.notes[0]
    np.testing.assert_allclose(res.measures["peak"][:3], ordinary.measures["peak"][:3], rtol=RTOL)
    assert np.isnan(res.measures["peak"][3:]).all()
