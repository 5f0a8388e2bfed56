"""Time netdae's refactoring sparse LU against SuperLU and a dense LU on MNA Newton matrices.

Usage::

    python benchmarks/lu.py [--quick] [--reps N]

Matrices: the BDF Newton matrix ``cj E - dphi/dx`` (``cj = 1 / 10 ns``, the
Jacobians at x = 0) of benchmark circuits (:mod:`benchmarks.circuits`): the
RC ladders of 10,000 and 100,000 sections, and small circuits of 3, 9, 18 and
50 unknowns (the pulse-train RC section, the diode bridge, the 4-stage
multiplier, a 48-section ladder). For each, medians over many runs of

- *splu*: ``scipy.sparse.linalg.splu`` (the project's column ordering) and
  one solve, from Python: what ``LuCache`` did before;
- *fresh*: the symbolic phase (SuperLU's pivots, ``make_plan``) plus a
  refactorisation: what a degraded pivot costs;
- *refactor+solve (Python)*: ``SparseLU.factor`` + ``SparseLU.solve``, call
  overhead included: what ``LuCache`` does now;
- *refactor+solve (compiled)*: the kernels called from a compiled loop, as
  the compiled transient engine will call them;
- *dense LU (compiled)*: a textbook partial-pivoting dense LU and solve in
  numba, the alternative for tiny systems (small sizes only).

Then numba's first-compile time of :mod:`netdae.dae.compiled.lu` (in a child
process with an empty cache directory) and the cached load time (a second
child on the same directory), and ``import numba`` alone.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
if __package__ in (None, ""):
    sys.path.insert(0, str(ROOT))

import numba  # noqa: E402
import numpy as np  # noqa: E402
from scipy.sparse.linalg import splu  # noqa: E402

import netdae  # noqa: E402
from benchmarks import circuits as C  # noqa: E402
from netdae.dae.compiled.lu import (  # noqa: E402
    DEFAULT_PERMC_SPEC,
    PIVOT_REL_THRESHOLD,
    SparseLU,
    fresh_pivots,
    make_plan,
    refactor,
    solve,
)
from netdae.mna import assemble  # noqa: E402

H_STEP = 10e-9


def newton_matrix(text: str):
    """Pattern and data of ``E / h - dphi/dx`` at x = 0 for a netlist text."""
    system = assemble(netdae.load(text))
    ev = system.evaluate(np.zeros(system.n), 0.0, jacobian=True)
    return system.pattern, np.asarray(ev.dq) / H_STEP - np.asarray(ev.dphi)


def cases(quick: bool):
    out = [
        ("pulse-train RC section", C.pulse_train(1).text),
        ("diode bridge", C.bridge_rectifier(1).text),
        ("4-stage multiplier", C.voltage_multiplier(4, 1).text),
        ("RC ladder, 48 sections", C.rc_ladder(48).text),
        ("RC ladder, 10,000 sections", C.rc_ladder(10000).text),
    ]
    if not quick:
        out.append(("RC ladder, 100,000 sections", C.rc_ladder(100000).text))
    return out


def median_time(fn, reps: int, inner: int) -> float:
    """Median over ``reps`` runs of the time per call of ``inner`` calls of ``fn``."""
    fn()
    times = []
    for _ in range(reps):
        t = time.perf_counter()
        for _ in range(inner):
            fn()
        times.append((time.perf_counter() - t) / inner)
    return statistics.median(times)


@numba.njit(cache=True)
def _sparse_loop(count, b_ptr, b_rows, b_slots, l_ptr, l_rows, u_ptr, u_rows, perm_r, perm_c,
                 a_data, l_data, u_data, work, work2, b, x, threshold):
    for _ in range(count):
        refactor(b_ptr, b_rows, b_slots, l_ptr, l_rows, u_ptr, u_rows, a_data, l_data, u_data, work,
                 threshold)
        x[:] = b
        solve(perm_r, perm_c, l_ptr, l_rows, u_ptr, u_rows, l_data, u_data, x, work2)


@numba.njit(cache=True)
def _dense_loop(count, a, lu, piv, b, x):
    n = a.shape[0]
    for _ in range(count):
        lu[:, :] = a
        for k in range(n):
            p = k
            m = abs(lu[k, k])
            for i in range(k + 1, n):
                if abs(lu[i, k]) > m:
                    m = abs(lu[i, k])
                    p = i
            piv[k] = p
            if p != k:
                for j in range(n):
                    t = lu[k, j]
                    lu[k, j] = lu[p, j]
                    lu[p, j] = t
            inv = 1.0 / lu[k, k]
            for i in range(k + 1, n):
                lu[i, k] *= inv
                f = lu[i, k]
                for j in range(k + 1, n):
                    lu[i, j] -= f * lu[k, j]
        x[:] = b
        for k in range(n):
            p = piv[k]
            t = x[k]
            x[k] = x[p]
            x[p] = t
            for i in range(k + 1, n):
                x[i] -= lu[i, k] * x[k]
        for k in range(n - 1, -1, -1):
            x[k] /= lu[k, k]
            for i in range(k):
                x[i] -= lu[i, k] * x[k]


def bench_matrix(label: str, pattern, data, reps: int) -> dict:
    n, nnz = pattern.n, pattern.nnz
    scale = max(1, int(2e5 / (nnz + 10 * n)))  # inner loop count: ~ equal work per sample
    matrix = pattern.matrix(data.copy())
    b = np.random.default_rng(0).standard_normal(n)
    row = {"case": label, "n": n, "nnz": nnz}
    row["splu"] = median_time(lambda: splu(matrix, permc_spec=DEFAULT_PERMC_SPEC).solve(b), reps,
                              max(1, scale // 20))
    lu = SparseLU(pattern)
    assert lu.factor(data)
    plan = lu.plan
    row["fill"] = plan.l_nnz + plan.u_nnz

    def fresh():
        pr, pc = fresh_pivots(matrix)
        make_plan(pattern, pr, pc)
        lu.factor(data)

    row["fresh"] = median_time(fresh, reps, max(1, scale // 20))
    row["python"] = median_time(lambda: (lu.factor(data), lu.solve(b)), reps, scale)
    assert lu.fresh_factorizations == 1
    args = (*plan.refactor_args(), plan.perm_r, plan.perm_c, data, np.empty(plan.l_nnz),
            np.empty(plan.u_nnz), np.zeros(n), np.zeros(n), b, np.empty(n), PIVOT_REL_THRESHOLD)
    inner = 20 * scale
    _sparse_loop(1, *args)
    row["compiled"] = median_time(lambda: _sparse_loop(inner, *args), reps, 1) / inner
    if n <= 200:
        dense = matrix.toarray()
        dargs = (dense, np.empty_like(dense), np.empty(n, np.int64), b, np.empty(n))
        _dense_loop(1, *dargs)
        row["dense"] = median_time(lambda: _dense_loop(inner, *dargs), reps, 1) / inner
    return row


_CHILD = """
import time
t0 = time.perf_counter()
import numba
t1 = time.perf_counter()
import numpy as np
from netdae.dae.sparse import SparsePattern
import netdae.dae.compiled.lu as m
t2 = time.perf_counter()
a = np.array([[0.0, 1.0, 0.0], [1.0, 2.0, 1.0], [0.0, 1.0, 3.0]])
pat = SparsePattern.from_matrices(a)
lu = m.SparseLU(pat)
lu.factor(pat.data_of(a)); lu.solve(np.ones(3)); lu.solve(np.ones(3), trans=True)
t3 = time.perf_counter()
lu.factor(pat.data_of(a)); lu.solve(np.ones(3))
t4 = time.perf_counter()
print(t1 - t0, t2 - t1, t3 - t2, t4 - t3)
"""


def compile_times(reps: int) -> dict:
    """Child processes: numba import, module import, first use (compile or cache load)."""
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    first, cached = [], []
    for _ in range(reps):
        with tempfile.TemporaryDirectory() as cache:
            env["NUMBA_CACHE_DIR"] = cache
            for out in (first, cached):
                res = subprocess.run([sys.executable, "-c", _CHILD], env=env, capture_output=True,
                                     text=True, check=True)
                out.append([float(v) for v in res.stdout.split()])
    med = lambda rows, k: statistics.median(r[k] for r in rows)  # noqa: E731
    return {"import numba": med(cached, 0), "import module": med(cached, 1),
            "first use, empty cache (compile)": med(first, 2), "first use, cached": med(cached, 2),
            "second use": med(cached, 3)}


def fmt(t: float) -> str:
    return f"{t * 1e6:.3g} us" if t < 1e-3 else f"{t * 1e3:.3g} ms"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="no 100,000-section ladder, fewer repetitions")
    ap.add_argument("--reps", type=int, default=None, help="samples per median (default 15, quick 5)")
    args = ap.parse_args(argv)
    reps = args.reps or (5 if args.quick else 15)
    print(f"numba {numba.__version__}, numpy {np.__version__}; medians of {reps} samples; "
          f"Newton matrix E/h - dphi/dx, h = {H_STEP:g} s\n")
    print("| matrix | n | nnz | L+U fill | splu + solve | fresh pivots + plan + refactor | "
          "refactor + solve (Python) | refactor + solve (compiled) | dense LU + solve (compiled) | "
          "splu / compiled |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for label, text in cases(args.quick):
        pattern, data = newton_matrix(text)
        r = bench_matrix(label, pattern, data, reps)
        dense = fmt(r["dense"]) if "dense" in r else "-"
        print(f"| {label} | {r['n']:,} | {r['nnz']:,} | {r['fill']:,} | {fmt(r['splu'])} | {fmt(r['fresh'])} | "
              f"{fmt(r['python'])} | {fmt(r['compiled'])} | {dense} | {r['splu'] / r['compiled']:.1f}x |",
              flush=True)
    print()
    for k, v in compile_times(3 if args.quick else 5).items():
        print(f"- {k}: {v:.3f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
