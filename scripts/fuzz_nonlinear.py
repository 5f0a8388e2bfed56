#!/usr/bin/env python3
"""Random nonlinear circuits against ngspice at tight settings: where netdae and ngspice part.

Usage::

    python scripts/fuzz_nonlinear.py [--seed 2] [--count 80] [--out fuzz-nonlinear]

Each circuit has 3 to 6 nodes tied by a tree of resistors to ground, the supply or the input (a
SIN or a PULSE of a period between 100 ns and 100 us), then 2 to 6 random elements among
resistors, capacitors, inductors (each with a parallel resistor), diodes, npn/pnp transistors and
level-1 MOSFETs, with their junction and diffusion charges; the transient spans three periods.
Each is run by both simulators through ``netdae.compare(..., tight=True)`` and reported as
``pass``, ``FAIL`` (with the signals beyond 1e-3 of their scale, or who failed) or ``ERROR`` (an
exception: always a bug). The netlists are written to ``--out``; the random choices come from
``--seed`` alone.

Measured 2026-11-29: seed 2, 73 of 80 passed (2 refused by both: a loop of an inductor and a
source; 1 where ngspice stopped and netdae ran; 3 within 3e-3 of millivolt scales; 1 fixed since,
tests/test_fast_mode_at_corner.py); seed 3, 87 of 100 passed (ngspice stopped on 3 that netdae
ran; ngspice's first step after an operating point of a circuit that stays at rest moves it by
6 mV; a snap of two transistors whose timing both simulators miss by 0.4-0.5 of the swing at
their default tolerances, netdae 9e-3 at reltol 1e-6 against ngspice's 1.3e-3 with its step
bound of 1e-4 of the interval); seed 4, 85 of 100 (ngspice stopped on 7 that netdae ran, 4 refused by
both; c4_43's 3.2e-2 is ngspice's tight run, 3.3e-2 off netdae's and off its own default run).
"""

from __future__ import annotations

import argparse
import json
import os

import numpy as np

import netdae

MODELS = """.model dn d(is=1e-14 rs=1 cjo=2p tt=5n bv=50)
.model qn npn(is=1e-16 bf=100 br=1 rb=50 rc=5 re=1 cje=1p cjc=1p tf=0.3n tr=10n vaf=80)
.model qp pnp(is=1e-16 bf=50 br=1 rb=80 rc=10 re=2 cje=1p cjc=1p tf=0.5n tr=15n vaf=60)
.model mn nmos(level=1 vto=0.7 kp=100u lambda=0.02 cgso=0.2n cgdo=0.2n cbd=5f cbs=5f)
.model mp pmos(level=1 vto=-0.7 kp=40u lambda=0.03 cgso=0.2n cgdo=0.2n cbd=5f cbs=5f)
"""

def val(rng, lo, hi):
    return float(10 ** rng.uniform(np.log10(lo), np.log10(hi)))

def circuit(rng, idx):
    n = int(rng.integers(3, 7))
    nodes = [f"n{k}" for k in range(1, n + 1)]
    allnodes = nodes + ["0"]
    lines = [f"random nonlinear {idx}"]
    vdd = rng.choice([3.0, 5.0, 12.0])
    lines.append(f"VDD vdd 0 {vdd}")
    per = val(rng, 1e-7, 1e-4)
    kind = rng.choice(["sin", "pulse"])
    amp = float(rng.uniform(0.5, vdd))
    if kind == "sin":
        lines.append(f"VIN in 0 SIN(0 {amp:.3g} {1/per:.4g})")
    else:
        lines.append(f"VIN in 0 PULSE(0 {amp:.3g} {per/10:.3g} {per/50:.3g} {per/50:.3g} {per/3:.3g} {per:.3g})")
    # tree: each node connected by a resistor to a previous node / supply / input / ground
    pool = ["0", "vdd", "in"]
    for k, nd in enumerate(nodes):
        other = pool[int(rng.integers(len(pool)))]
        lines.append(f"RT{k} {nd} {other} {val(rng, 100, 100e3):.4g}")
        pool.append(nd)
    counts = {}
    def nm(c):
        counts[c] = counts.get(c, 0) + 1
        return f"{c}{counts[c]}"
    def pick(k):
        return list(rng.choice(pool, size=k, replace=False))
    for _ in range(int(rng.integers(2, 7))):
        c = rng.choice(["R", "C", "D", "Q", "M", "C", "L"], p=[0.2, 0.2, 0.2, 0.15, 0.15, 0.05, 0.05])
        if c == "R":
            a, b = pick(2); lines.append(f"{nm('R')} {a} {b} {val(rng, 10, 1e5):.4g}")
        elif c == "C":
            a, b = pick(2); lines.append(f"{nm('C')} {a} {b} {val(rng, 1e-13, 1e-8):.4g}")
        elif c == "L":
            a, b = pick(2); lines.append(f"{nm('L')} {a} {b} {val(rng, 1e-8, 1e-4):.4g} ")
            lines.append(f"{nm('R')} {a} {b} {val(rng, 100, 1e4):.4g}")
        elif c == "D":
            a, b = pick(2); lines.append(f"{nm('D')} {a} {b} dn")
        elif c == "Q":
            a, b, e = pick(3); lines.append(f"{nm('Q')} {a} {b} {e} {rng.choice(['qn','qp'])}")
        elif c == "M":
            d, g, s = pick(3)
            t = rng.choice(["mn", "mp"])
            bulk = "0" if t == "mn" else "vdd"
            lines.append(f"{nm('M')} {d} {g} {s} {bulk} {t} w={val(rng,1e-6,2e-5):.3g} l=1u")
    lines.append(MODELS.strip())
    save = " ".join(f"v({x})" for x in nodes[:4])
    lines.append(f".save {save}")
    lines.append(f".tran {per/100:.4g} {3*per:.4g}")
    lines.append(".end")
    return "\n".join(lines) + "\n"

def main(seed: int, count: int, out: str) -> dict:
    os.makedirs(out, exist_ok=True)
    rng = np.random.default_rng(seed)
    tally = {}
    for i in range(count):
        text = circuit(rng, i)
        path = os.path.join(out, f"c{seed}_{i}.cir")
        open(path, "w").write(text)
        try:
            cmp = netdae.compare(netdae.load(path), tight=True)
            verdict = "pass" if cmp.passed else "FAIL"
            detail = ""
            if not cmp.passed:
                parts = []
                for an in cmp.analyses:
                    if getattr(an, "error", None):
                        parts.append(f"{an.analysis}: error {an.error}")
                    for sg in getattr(an, "signals", []):
                        if not sg.passed:
                            parts.append(f"{an.analysis} {sg.name} rel {sg.max_rel:.2e} at {sg.at} scale {sg.scale:.3g}")
                    for note in getattr(an, "notes", [])[:2]:
                        parts.append(f"note {note}")
                detail = " ; ".join(parts)[:700]
        except Exception as exc:
            verdict = "ERROR"
            detail = f"{type(exc).__name__}: {exc}"[:600]
        tally[verdict] = tally.get(verdict, 0) + 1
        print(f"{i:3d} {verdict:5s} {path} {detail}", flush=True)
    print(json.dumps(tally))
    return tally

if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seed", type=int, default=2)
    ap.add_argument("--count", type=int, default=80)
    ap.add_argument("--out", default="fuzz-nonlinear")
    a = ap.parse_args()
    main(a.seed, a.count, a.out)
