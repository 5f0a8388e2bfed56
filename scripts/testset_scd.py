"""Significant correct digits on the circuits of the Test Set for IVP Solvers: netdae, IDA, ngspice.

    python scripts/testset_scd.py [--tols 1e-4,1e-7,1e-10]

For each problem: netdae on its netlist in ``netlists/`` (reltol = abstol =
vntol = tol), SUNDIALS IDA (scikit-sundae) on the Test Set's own formulation
``M y' = f(y, t)`` (rtol = atol = tol) and ngspice on the same netlist
(reltol = abstol = vntol = tol, method=gear). scd = -log10 of the largest
relative error at tend over the components the Test Set scores. Prints a
markdown table (docs/integrator.md, "The Test Set's circuits").
"""

from __future__ import annotations

import argparse
import math
import time
from pathlib import Path

import numpy as np

import netdae

ROOT = Path(__file__).resolve().parent.parent

# -- transamp: the Test Set's M y' = f(y, t) ------------------------------------------------
TRANSAMP_REF = np.array([-0.5562145012262709e-2, 0.3006522471903042e1, 0.2849958788608128e1,
                         0.2926422536206241e1, 0.2704617865010554e1, 0.2761837778393145e1,
                         0.4770927631616772e1, 0.1236995868091548e1])


def transamp_ida(tol):
    import sksundae as sun

    ub, uf, alpha, beta, r0, r = 6.0, 0.026, 0.99, 1e-6, 1e3, 9e3
    c = [1e-6, 2e-6, 3e-6, 4e-6, 5e-6]
    M = np.zeros((8, 8))
    for a, b, cc in ((0, 1, c[0]), (3, 4, c[2]), (6, 7, c[4])):
        M[a, a] = M[b, b] = -cc
        M[a, b] = M[b, a] = cc
    M[2, 2], M[5, 5] = -c[1], -c[3]

    def f(t, u):
        f1 = beta * (math.exp((u[1] - u[2]) / uf) - 1.0)
        f2 = beta * (math.exp((u[4] - u[5]) / uf) - 1.0)
        return np.array([(u[0] - 0.1 * math.sin(200 * math.pi * t)) / r0,
                         u[1] / r + (u[1] - ub) / r + (1 - alpha) * f1, u[2] / r - f1,
                         (u[3] - ub) / r + alpha * f1,
                         u[4] / r + (u[4] - ub) / r + (1 - alpha) * f2, u[5] / r - f2,
                         (u[6] - ub) / r + alpha * f2, u[7] / r])

    def resfn(t, y, yp, res):
        res[:] = M @ yp - f(t, y)

    y0 = np.array([0.0, 3.0, 3.0, 6.0, 3.0, 3.0, 6.0, 0.0])
    yp0 = np.array([51.338775, 51.338775, 0.0, -24.9757667, -24.9757667, 0.0, -10.00564453, -10.00564453])
    solver = sun.ida.IDA(resfn, rtol=tol, atol=tol, max_num_steps=10_000_000, calc_initcond="yp0")
    sol = solver.solve(np.array([0.0, 0.2]), y0, yp0)
    return sol.y[-1], sol.success


def transamp_netdae(res):
    return np.array([res[f"v({i})"][-1] for i in range(1, 9)])


PROBLEMS = {
    "transamp": dict(netlist="testset_transamp.cir", ref=TRANSAMP_REF, ida=transamp_ida,
                     netdae=transamp_netdae, signals=[f"v({i})" for i in range(1, 9)]),
}


def scd(y, ref):
    err = np.max(np.abs(np.asarray(y) - ref) / np.abs(ref))
    return -math.log10(err) if err > 0 else math.inf


def run_ngspice(path: Path, tol: float, signals):
    from netdae.ngspice import run_ngspice_file

    out = run_ngspice_file(path, options={"reltol": tol, "abstol": tol, "vntol": tol, "method": "gear"},
                           timeout=600)
    tran = [r for r in out.results if r.analysis == "tran"][0]
    return np.array([tran[s][-1] for s in signals])


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tols", default="1e-4,1e-7,1e-10")
    ap.add_argument("--only", default=None)
    args = ap.parse_args()
    tols = [float(v) for v in args.tols.split(",")]
    print("| problem | tol | netdae scd | netdae steps (rejected) | netdae time | IDA scd | ngspice scd |")
    print("|---|---|---|---|---|---|---|")
    for name, p in PROBLEMS.items():
        if args.only and name not in args.only.split(","):
            continue
        path = ROOT / "netlists" / p["netlist"]
        circuit = netdae.load(path)
        for tol in tols:
            t0 = time.process_time()
            res = netdae.simulate(circuit, reltol=tol, abstol=tol, vntol=tol)
            cpu = time.process_time() - t0
            nd = scd(p["netdae"](res), p["ref"]) if res.ok else float("nan")
            st = res.stats
            y_ida, ok = p["ida"](tol)
            ida = scd(y_ida, p["ref"]) if ok else float("nan")
            try:
                ng = f"{scd(run_ngspice(path, tol, p['signals']), p['ref']):.2f}"
            except Exception as exc:  # noqa: BLE001 - reported in the table
                ng = f"failed ({type(exc).__name__})"
            print(f"| {name} | {tol:g} | {nd:.2f} | {st['steps']} ({st['rejected']}) | {cpu:.1f} s | "
                  f"{ida:.2f} | {ng} |", flush=True)


if __name__ == "__main__":
    main()
