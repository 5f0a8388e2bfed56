"""Sweeps and Monte Carlo: netdae against ngspice, and batched linear AC against independent runs.

Usage::

    python benchmarks/sweep.py [--samples N] [--reps R] [--workers W]

Two measurements (the sweep issue's targets), each repeated ``--reps`` times,
the two sides alternated, every side in a fresh process, CPU time = user +
system of the process and its workers (``RUSAGE_CHILDREN``):

1. **Monte Carlo of the diode bridge** (``benchmarks/sweep_bridge.cir``: the
   load and the reservoir capacitor each with a 5 % Gaussian tolerance,
   ripple and mean output measured): ``netdae sweep --mc N --workers W``
   against ngspice running the same N samples in one ``.control`` loop
   (``alter`` + ``tran`` + ``meas``; faster than N batch runs, each of which
   pays ngspice's start-up). Also checks that the ripple distributions agree
   (means within 3 combined standard errors).
2. **Monte Carlo of a linear RLC filter's AC response**: ``netdae.sweep`` of N
   samples in one process against N independent ``netdae.run`` calls in one
   warm process (load, elaborate, analyse, solve each time; netdae's
   per-structure memo of the topology analysis helps both). Both sides are timed after a
   warm-up (the imports, the sweep package's included, and a first analysis) and a full
   garbage collection, so neither pays a one-off cost of the process.

Prints a table and writes ``benchmarks/results/sweep.json``.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
BRIDGE = ROOT / "benchmarks" / "sweep_bridge.cir"

#: ngspice's Monte Carlo loop over the same circuit and tolerances (ngspice's own generator).
_NGSPICE_LOOP = """bridge Monte Carlo, ngspice control loop
V1 ac 0 DC 12 SIN(0 12 50)
RS ac acs 1
D1 acs pos d1n4007
D2 0 pos d1n4007
D3 neg acs d1n4007
D4 neg 0 d1n4007
C1 pos neg 470u
RL pos neg 1k
.model d1n4007 d (is=7.02767n rs=0.0341512 n=1.80803 eg=1.05743 xti=5 bv=1000 ibv=0.1
+ cjo=10p vj=0.7 m=0.5 fc=0.5 tt=100n)
.control
set rndseed={seed}
define agauss(nom, avar, sig) (nom + avar/sig * sgauss(0))
let mc_runs = {samples}
let run = 0
let ripple = unitvec(mc_runs)
dowhile run < mc_runs
  alter rl = agauss(1k, 50, 1)
  alter c1 = agauss(470u, 23.5u, 1)
  tran 50u 60m
  let vd = v(pos) - v(neg)
  meas tran rip pp vd from=40m to=60m
  let ripple[run] = rip
  destroy all
  let run = run + 1
end
print ripple
.endc
.end
"""

_AC = """series RLC band-pass, Monte Carlo
.param r={agauss(50, 2.5, 1)} l={agauss(10m, 0.5m, 1)} c={agauss(1u, 0.05u, 1)}
V1 in 0 DC 0 AC 1
R1 in a {r}
L1 a b {l}
C1 b out {c}
R2 out 0 50
.ac dec 50 100 100k
.meas ac peak max vm(out)
.meas ac fhi when vm(out)=0.3535533906 fall=1
"""

_AC_CHILD = """
import gc, sys, time, netdae
import netdae.sweeps
from netdae.netlist import load
text, n, mode = sys.argv[1], int(sys.argv[2]), sys.argv[3]
netdae.run(load(text))  # warm: imports (the sweep's too) and the first analysis out of the timing
gc.collect()  # the warm-up's garbage: else its full collection falls into whichever side is timed
t0 = time.process_time()
if mode == "sweep":
    res = netdae.sweep(text, samples=n, workers=1)
    assert res.failed == 0
else:
    c = load(text)
    for k in range(n):
        netdae.run(c.variant(sample=k))
print(time.process_time() - t0)
"""


def _timed(argv: list[str], cwd: Path) -> tuple[float, float, str]:
    """(wall, cpu of the child and its descendants, stdout) of one run."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.run(argv, cwd=cwd, capture_output=True, text=True, timeout=3600,
                          env=dict(os.environ, OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1"))
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if proc.returncode not in (0, 1):
        raise RuntimeError(f"{argv[0]} failed ({proc.returncode}): {proc.stderr[-2000:]}")
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu, proc.stdout


def _ngspice_ripple(text: str) -> list[float]:
    values = []
    for line in text.splitlines():
        parts = line.split()
        if len(parts) == 2 and parts[0].isdigit():
            values.append(float(parts[1]))
    return values


def bridge(samples: int, reps: int, workers: int, work: Path) -> dict:
    rows = []
    seen = {}
    (work / "loop.cir").write_text(_NGSPICE_LOOP.format(samples=samples, seed=7))
    for rep in range(reps):
        for side in (("netdae", "ngspice") if rep % 2 == 0 else ("ngspice", "netdae")):
            if side == "netdae":
                out = work / f"out{rep}"
                wall, cpu, stdout = _timed([sys.executable, "-m", "netdae", "sweep", str(BRIDGE), "--mc",
                                            str(samples), "--workers", str(workers), "--out", str(out),
                                            "--no-plot", "--json", "-q"], work)
                doc = json.loads(stdout)
                seen["netdae"] = json.loads((out / "measures.json").read_text())["rows"]
                rows.append({"side": side, "wall": wall, "cpu": cpu, "failed": doc["failed"]})
            else:
                wall, cpu, stdout = _timed(["ngspice", "-n", "-b", "loop.cir"], work)
                seen["ngspice"] = _ngspice_ripple(stdout)
                rows.append({"side": side, "wall": wall, "cpu": cpu})
    nd = [r["ripple"] for r in seen["netdae"] if r["ripple"] is not None]
    ng = seen["ngspice"]
    m1, m2 = statistics.fmean(nd), statistics.fmean(ng)
    se = math.sqrt(statistics.variance(nd) / len(nd) + statistics.variance(ng) / len(ng))
    return {"samples": samples, "workers": workers, "runs": rows,
            "ripple": {"netdae_mean": m1, "netdae_std": statistics.stdev(nd), "netdae_count": len(nd),
                       "ngspice_mean": m2, "ngspice_std": statistics.stdev(ng), "ngspice_count": len(ng),
                       "difference_in_standard_errors": abs(m1 - m2) / se}}


def linear_ac(samples: int, reps: int, work: Path) -> dict:
    rows = []
    for rep in range(reps):
        for mode in (("sweep", "loop") if rep % 2 == 0 else ("loop", "sweep")):
            _, _, stdout = _timed([sys.executable, "-c", _AC_CHILD, _AC, str(samples), mode], work)
            rows.append({"side": mode, "cpu": float(stdout.strip().splitlines()[-1])})
    return {"samples": samples, "runs": rows}


def _summary(runs: list[dict], side: str, key: str) -> tuple[float, float, float]:
    v = [r[key] for r in runs if r["side"] == side]
    return statistics.median(v), min(v), max(v)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=1000)
    ap.add_argument("--reps", type=int, default=3)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--only", choices=("bridge", "ac"))
    args = ap.parse_args(argv)
    out: dict = {}
    with tempfile.TemporaryDirectory(prefix="netdae-sweep-bench-") as tmp:
        work = Path(tmp)
        if args.only in (None, "bridge"):
            b = bridge(args.samples, args.reps, args.workers, work)
            out["bridge"] = b
            print(f"Monte Carlo, diode bridge, {args.samples} samples ({args.workers} netdae workers):")
            for key in ("wall", "cpu"):
                nd, ng = _summary(b["runs"], "netdae", key), _summary(b["runs"], "ngspice", key)
                ratios = sorted(r1["{}".format(key)] / r2[key] for r1, r2 in
                                zip([r for r in b["runs"] if r["side"] == "netdae"],
                                    [r for r in b["runs"] if r["side"] == "ngspice"]))
                print(f"  {key:4s}: netdae {nd[0]:.2f} s ({nd[1]:.2f}-{nd[2]:.2f}), ngspice {ng[0]:.2f} s "
                      f"({ng[1]:.2f}-{ng[2]:.2f}); ratio {statistics.median(ratios):.2f}x "
                      f"({ratios[0]:.2f}-{ratios[-1]:.2f})")
            r = b["ripple"]
            print(f"  ripple: netdae {r['netdae_mean']:.5g} +- {r['netdae_std']:.3g} (n={r['netdae_count']}), "
                  f"ngspice {r['ngspice_mean']:.5g} +- {r['ngspice_std']:.3g} (n={r['ngspice_count']}); "
                  f"means differ by {r['difference_in_standard_errors']:.2f} standard errors")
        if args.only in (None, "ac"):
            a = linear_ac(args.samples, args.reps, work)
            out["linear_ac"] = a
            sw, lp = _summary(a["runs"], "sweep", "cpu"), _summary(a["runs"], "loop", "cpu")
            print(f"Monte Carlo, RLC filter AC, {args.samples} samples, one process (CPU):")
            print(f"  netdae.sweep {sw[0]:.3f} s ({sw[1]:.3f}-{sw[2]:.3f}); {args.samples} netdae.run calls "
                  f"{lp[0]:.3f} s ({lp[1]:.3f}-{lp[2]:.3f}); speed-up {lp[0] / sw[0]:.1f}x "
                  f"({lp[1] / sw[2]:.1f}-{lp[2] / sw[1]:.1f})")
    results = ROOT / "benchmarks" / "results"
    results.mkdir(parents=True, exist_ok=True)
    (results / "sweep.json").write_text(json.dumps(out, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
