#!/usr/bin/env python3
"""Step counts of the Python integrator on every netlist in netlists/ (for refactoring checks).

Usage::

    NETDAE_ENGINE=python python scripts/integrator_counts.py > before.tsv
    NETDAE_ENGINE=python python scripts/integrator_counts.py --compare before.tsv

Prints one tab-separated line per netlist: steps, rejected steps, Newton
iterations, factorisations, and the final values' checksum (the sum of the
saved signals at the last point, to 17 digits); then Newton failures, evaluations,
changes of cj and probes. With ``--compare`` it prints
the two tables side by side and exits non-zero when a count differs.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

COLUMNS = ("steps", "rejected", "newton_iterations", "factorizations", "newton_failures", "evaluations",
           "cj_changes", "probes")


def counts(path: Path) -> list[str]:
    import numpy as np

    import netdae

    try:
        res = netdae.simulate(str(path))
    except Exception as exc:  # a netlist without .tran, or a refused circuit
        return ["-"] * len(COLUMNS) + [type(exc).__name__]
    st = res.stats.get("integrator", res.stats)
    last = sum(float(np.asarray(res[name])[-1]) for name in res.names())
    return [str(st.get(c, "-")) for c in COLUMNS] + [f"{last:.17g}"]


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--compare", help="a table written earlier")
    ap.add_argument("--only", help="comma-separated netlist stems")
    args = ap.parse_args()
    if os.environ.get("NETDAE_ENGINE", "").lower() != "python":
        print("set NETDAE_ENGINE=python", file=sys.stderr)
        return 2
    files = sorted((ROOT / "netlists").glob("*.cir"))
    if args.only:
        keep = set(args.only.split(","))
        files = [f for f in files if f.stem in keep]
    rows = {f.stem: counts(f) for f in files}
    if not args.compare:
        print("netlist\t" + "\t".join(COLUMNS) + "\tchecksum")
        for name, row in rows.items():
            print(name + "\t" + "\t".join(row), flush=True)
        return 0
    old = {}
    for line in Path(args.compare).read_text().splitlines()[1:]:
        parts = line.split("\t")
        old[parts[0]] = parts[1:]
    differ = 0
    print("| netlist | steps | rejected | newton | factorizations | same counts | other counts | same final values |")
    print("|---|---|---|---|---|---|---|---|")
    for name, row in rows.items():
        before = old.get(name)
        same = before is not None and before[:4] == row[:4]
        values = before is not None and before[-1] == row[-1]
        differ += not same
        cells = [b if b == a else f"{b} -> {a}" for b, a in zip(before or ["?"] * 4, row[:4])]
        others = "same" if before is not None and before[4:-1] == row[4:-1] else "differ"
        print(f"| {name} | " + " | ".join(cells)
              + f" | {'yes' if same else 'NO'} | {others} | {'yes' if values else 'no'} |")
    return 1 if differ else 0


if __name__ == "__main__":
    raise SystemExit(main())
