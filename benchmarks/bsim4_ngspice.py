"""netdae (BSIM4 through OSDI) against ngspice (its built-in BSIM4) on ring oscillators and inverter chains,
in the same run.

Usage::

    python benchmarks/bsim4_ngspice.py [--circuit ring|chain] [--stages 5,11,21,51] [--stop 20n] [--reps 3]

``--circuit chain``: N inverters in a row driven by a 1.2 V pulse (20 ps edges, 1 ns period), each stage
loaded by 2 fF; printed instead of the period: the delay from the input's 0.6 V crossings to the last
stage's (mean over the edges after the first period).

Needs the optional extra ``netdae[models]`` and ngspice. Each ring (N
inverters of ``M`` elements with ``level=54`` cards, 2 fF loads, started by
``.ic v(n0)=0``) is one netlist, read by both: netdae runs its ``M`` cards
through the bundled ``sp_bsim4v8`` module (the compiled engine, in this
process; the first, compiling, run is not timed), ngspice 39 through its C
BSIM4 (``ngspice -b`` as a child process, ``.options acct``). The two
alternate ``--reps`` times. ngspice runs one thread (``.options
num_threads=1``), as netdae does: its BSIM4 loads in two OpenMP threads by
default, whose barrier spins on a busy two-core machine took 0.1-8 s of CPU
for the same 5-stage ring. Printed per ring: CPU times, best of the
repetitions, with their ranges -- netdae's ``time.process_time`` of
:func:`netdae.simulate` (the transient with its operating point), ngspice's
own "Total analysis time" (``getrusage`` CPU of its analyses, without
start-up and reading) -- the ratio, steps and Newton iterations of each, and
the oscillation periods (mean of the rising 0.6 V crossings of ``n0`` after
the first period).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import measure as M  # noqa: E402

#: A 130 nm-like card pair (BSIM4's defaults and a handful of parameters), as tests/test_osdi_bsim4.py.
CARDS = """.model nch nmos level=54 version=4.8 toxe=2.5n toxp=2.0n toxm=2.5n vth0=0.42 k1=0.55 u0=0.03 vsat=1.1e5
+ rdsw=150 ndep=2e18 cgso=2.5e-10 cgdo=2.5e-10 cgbo=1e-12 cjs=1.2e-3 cjsws=1.5e-10 cjswgs=2e-10 mjs=0.4
+ mjsws=0.3 pbsws=0.8
.model pch pmos level=54 version=4.8 toxe=2.6n toxp=2.1n toxm=2.6n vth0=-0.40 k1=0.50 u0=0.01 vsat=0.9e5
+ rdsw=300 ndep=2e18 cgso=2.5e-10 cgdo=2.5e-10 cgbo=1e-12 cjs=1.3e-3 cjsws=1.6e-10 cjswgs=2e-10 mjs=0.4
+ mjsws=0.3 pbsws=0.8"""


def ring(stages: int, stop: str) -> str:
    """The ring oscillator, in the dialect both simulators read."""
    lines = [f"bsim4 ring {stages}", ".options acct num_threads=1", "Vdd vdd 0 1.2"]
    for i in range(stages):
        a, b = f"n{i}", f"n{(i + 1) % stages}"
        lines += [f"Mn{i} {b} {a} 0 0 nch l=0.13u w=1u ad=0.5p as=0.5p pd=3u ps=3u",
                  f"Mp{i} {b} {a} vdd vdd pch l=0.13u w=2u ad=1p as=1p pd=4u ps=4u", f"C{i} {b} 0 2f"]
    return "\n".join(lines + [CARDS, ".ic v(n0)=0", f".tran 10p {stop}", ".save v(n0)", ".end"]) + "\n"


def chain(stages: int, stop: str) -> str:
    """The inverter chain, in the dialect both simulators read."""
    lines = [f"bsim4 inverter chain {stages}", ".options acct num_threads=1", "Vdd vdd 0 1.2",
             "Vin n0 0 pulse(0 1.2 0.1n 20p 20p 0.48n 1n)"]
    for i in range(stages):
        a, b = f"n{i}", f"n{i + 1}"
        lines += [f"Mn{i} {b} {a} 0 0 nch l=0.13u w=1u ad=0.5p as=0.5p pd=3u ps=3u",
                  f"Mp{i} {b} {a} vdd vdd pch l=0.13u w=2u ad=1p as=1p pd=4u ps=4u", f"C{i} {b} 0 2f"]
    return "\n".join(lines + [CARDS, f".tran 10p {stop}", f".save v(n0) v(n{stages})", ".end"]) + "\n"


def crossings(t: np.ndarray, v: np.ndarray, level: float = 0.6) -> np.ndarray:
    """Times where ``v`` crosses ``level`` (either way), linearly interpolated."""
    k = np.flatnonzero((v[:-1] - level) * (v[1:] - level) < 0)
    return t[k] + (level - v[k]) * (t[k + 1] - t[k]) / (v[k + 1] - v[k])


def delay(t: np.ndarray, vin: np.ndarray, vout: np.ndarray, after: float = 1e-9) -> float:
    """Mean delay from each input crossing after ``after`` to the output's next crossing."""
    cin, cout = crossings(t, vin), crossings(t, vout)
    out = [cout[np.searchsorted(cout, c)] - c for c in cin[cin > after] if np.searchsorted(cout, c) < cout.size]
    return float(np.mean(out)) if out else float("nan")


def period(t: np.ndarray, v: np.ndarray, level: float = 0.6) -> float:
    """Mean period from the rising crossings of ``level`` after the first."""
    k = np.flatnonzero((v[:-1] < level) & (v[1:] >= level))
    cross = t[k] + (level - v[k]) * (t[k + 1] - t[k]) / (v[k + 1] - v[k])
    return float(np.diff(cross[1:]).mean()) if len(cross) > 2 else float("nan")


def main() -> None:
    import netdae

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--circuit", choices=("ring", "chain"), default="ring")
    ap.add_argument("--stages", default="5,11,21,51")
    ap.add_argument("--stop", default="20n")
    ap.add_argument("--reps", type=int, default=3)
    ap.add_argument("--timeout", type=float, default=600.0)
    args = ap.parse_args()
    what = "period" if args.circuit == "ring" else "delay"
    print(f"{'stages':>6} {'netdae CPU [s]':>16} {'ngspice CPU [s]':>16} {'ratio':>11} {'steps':>11} "
          f"{'newton':>11} {what + ' netdae':>14} {what + ' ngspice':>15}")
    with tempfile.TemporaryDirectory() as work:
        for n in (int(s) for s in args.stages.split(",")):
            text = ring(n, args.stop) if args.circuit == "ring" else chain(n, args.stop)
            path = Path(work) / f"{args.circuit}{n}.cir"
            path.write_text(text)
            saved = ["v(n0)"] if args.circuit == "ring" else ["v(n0)", f"v(n{n})"]
            netdae.simulate(netdae.load(text))  # compiles or loads the engine
            ours, theirs = [], []
            for _ in range(args.reps):  # alternating
                ng = M.run_ngspice(path, Path(work), saved, timeout=args.timeout)
                if not ng.ok:
                    raise SystemExit(f"ngspice failed on the {n}-stage {args.circuit}: {ng.message}")
                theirs.append(ng)
                circuit = netdae.load(text)
                t0 = time.process_time()
                res = netdae.simulate(circuit)
                ours.append((time.process_time() - t0, res))
            cpu_us = [c for c, _ in ours]
            cpu_ng = [r.stats["analysis_time"] for r in theirs]
            res, ng = ours[-1][1], theirs[-1]
            ratios = [a / b for a, b in zip(cpu_us, cpu_ng)]
            if args.circuit == "ring":
                p_us = period(np.asarray(res.t), np.asarray(res["v(n0)"]))
                p_ng = period(ng.time, ng.signals["v(n0)"])
            else:
                p_us = delay(np.asarray(res.t), np.asarray(res["v(n0)"]), np.asarray(res[f"v(n{n})"]))
                p_ng = delay(ng.time, ng.signals["v(n0)"], ng.signals[f"v(n{n})"])
            print(f"{n:>6} {min(cpu_us):>7.3f}-{max(cpu_us):<8.3f} {min(cpu_ng):>7.3f}-{max(cpu_ng):<8.3f} "
                  f"{min(ratios):>5.2f}-{max(ratios):<5.2f} {res.stats['steps']:>5}/{ng.stats['steps']:<5} "
                  f"{res.stats['newton_iterations']:>5}/{ng.stats['newton']:<5} {p_us * 1e9:>11.4f} ns {p_ng * 1e9:>12.4f} ns")


if __name__ == "__main__":
    main()
