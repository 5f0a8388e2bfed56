"""Random linear circuits of extreme element values: the structure `netdae index` reports against the true one.

Usage::

    python scripts/fuzz_index.py [--seed S] [--circuits N] [--keep DIR]

Each circuit has 3 to 8 nodes, a PULSE source, and 3 to 11 random resistors (1 mohm to 1 Gohm), capacitors
(1 fF to 1 uF), inductors, 0 V sources, VCVS and VCCS (gains up to 1e9), with a 1 Tohm leak from every node
to ground. The true structure comes from the circuit's MNA assembled in rational arithmetic from the values
as written (no rounding anywhere), decided by ranks over prime fields (:mod:`netdae.dae.exact`). Prints how
many reports are right, wrong without a warning, disputed (and of those right anyway), and decided in exact
arithmetic (right or wrong); with ``--keep`` the silently wrong netlists are written there.
docs/index-theory.md quotes its results.
"""

from __future__ import annotations

import argparse
import sys
import warnings
from fractions import Fraction
from pathlib import Path

import numpy as np

import netdae
from netdae.dae import exact


def circuit(rng: np.random.Generator) -> str:
    """A random netlist (see the module docstring)."""
    nodes = [f"n{i}" for i in range(int(rng.integers(3, 9)))] + ["0"]
    lines = ["fuzz", "V1 n0 0 PULSE(0 1 1n 1n 1n 5n 20n)"]

    def two():
        a, b = rng.choice(len(nodes), 2, replace=False)
        return nodes[a], nodes[b]

    for k in range(1, int(rng.integers(3, 12)) + 1):
        kind = rng.choice(["R", "C", "E", "L", "G", "V"], p=[0.35, 0.3, 0.15, 0.08, 0.07, 0.05])
        a, b = two()
        if kind == "R":
            lines.append(f"R{k} {a} {b} {rng.choice([1e-3, 1, 1e3, 1e6, 1e9])}")
        elif kind == "C":
            lines.append(f"C{k} {a} {b} {rng.choice([1e-15, 1e-12, 1e-9, 1e-6])}")
        elif kind == "L":
            lines.append(f"L{k} {a} {b} {rng.choice([1e-9, 1e-6, 1e-3])}")
        elif kind == "V":
            lines.append(f"V{k} {a} {b} DC 0")
        else:
            c, d = two()
            lines.append(f"{kind}{k} {a} {b} {c} {d} {rng.choice([1e3, 1e6, 1e9, -1e6, 2.0])}")
    lines += [f"Rg{nd} {nd} 0 1e12" for nd in nodes[:-1]]
    return "\n".join(lines + [".tran 1n 20n", ".end"]) + "\n"


def _residues(M, p: int) -> np.ndarray:
    return np.array([[(f.numerator % p) * pow(f.denominator, -1, p) % p for f in row] for row in M], dtype=np.int64)


def true_structure(text: str) -> exact.ExactStructure:
    """The structure of the netlist's MNA (R, C, L, V, E, G cards) in rational arithmetic."""
    nodes, branches, cards = {}, [], []
    for ln in text.splitlines()[1:]:
        t = ln.split()
        if not t or t[0].startswith("."):
            continue
        cards.append(t)
        for nd in t[1:3] + (t[3:5] if t[0][0] in "EG" else []):
            if nd != "0":
                nodes.setdefault(nd, len(nodes))
        if t[0][0] in "VEL":
            branches.append(t[0])
    n = len(nodes) + len(branches)
    E = [[Fraction(0)] * n for _ in range(n)]
    H = [[Fraction(0)] * n for _ in range(n)]
    at = {b: len(nodes) + k for k, b in enumerate(branches)}

    def add(M, i, j, v):
        if i >= 0 and j >= 0:
            M[i][j] += v

    for t in cards:
        kind, a, b = t[0][0], nodes.get(t[1], -1), nodes.get(t[2], -1)
        if kind in "RC":
            M, g = (H, -1 / Fraction(t[3])) if kind == "R" else (E, Fraction(t[3]))
            add(M, a, a, g), add(M, b, b, g), add(M, a, b, -g), add(M, b, a, -g)
        elif kind == "G":
            c, d, g = nodes.get(t[3], -1), nodes.get(t[4], -1), Fraction(t[5])
            add(H, a, c, -g), add(H, a, d, g), add(H, b, c, g), add(H, b, d, -g)
        else:
            k = at[t[0]]
            add(H, a, k, -1), add(H, b, k, 1), add(H, k, a, 1), add(H, k, b, -1)
            if kind == "E":
                c, d, g = nodes.get(t[3], -1), nodes.get(t[4], -1), Fraction(t[5])
                add(H, k, c, -g), add(H, k, d, g)
            elif kind == "L":
                E[k][k] += Fraction(t[3])
    rng = np.random.default_rng(0)
    found = [exact._null_dims(_residues(E, p), _residues(H, p), p, rng) for p in exact.PRIMES]
    regular = [dims for reg, _, dims in found if reg]
    if regular:  # the higher ranks (fewer null dimensions) are the rational ones
        return exact.ExactStructure(n, True, n, min(regular, key=lambda d: (sum(d), d)))
    return exact.ExactStructure(n, False, max(rank for _, rank, _ in found))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--circuits", type=int, default=300)
    ap.add_argument("--keep", type=Path)
    args = ap.parse_args(argv)
    rng = np.random.default_rng(args.seed)
    count = dict(analysed=0, right=0, wrong_silently=0, disputed=0, disputed_but_right=0, exact_right=0,
                 exact_wrong=0, refused=0)
    for k in range(args.circuits):
        text = circuit(rng)
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                rep = netdae.analyze_index(netdae.load(text))
        except netdae.NetdaeError:
            count["refused"] += 1  # a singular DC matrix before any pencil, or a reader's refusal
            continue
        p = rep.pencil
        if p is None:
            continue
        true = true_structure(text)
        count["analysed"] += 1
        ok = true.agrees(p)
        if p.decided_exactly:
            count["exact_right" if ok else "exact_wrong"] += 1
        elif p.disputed:
            count["disputed"] += 1
            count["disputed_but_right"] += int(ok)
        elif ok:
            count["right"] += 1
        else:
            count["wrong_silently"] += 1
            if args.keep:
                args.keep.mkdir(parents=True, exist_ok=True)
                (args.keep / f"wrong_{args.seed}_{k}.cir").write_text(text)
    print(count)
    return 0


if __name__ == "__main__":
    sys.exit(main())
