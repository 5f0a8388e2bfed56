"""``netdae run FILE``: run the analyses in a netlist, print a summary, write results.

Writes one file per analysis into ``--out DIR`` (``op.csv``, ``dc.csv``,
``ac.csv``, ``tran.csv``, or ``.raw`` with ``--format raw``), optional PNG plots
(``--plot``), and prints a table of the operating point and the statistics of
every analysis (or one JSON object with ``--json``).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

__all__ = ["add_parser", "main"]


def add_parser(sub) -> argparse.ArgumentParser:
    p = sub.add_parser(
        "run",
        help="run the analyses of a netlist (.op, .dc, .ac, .tran)",
        description="Run every analysis in the netlist, print a summary and write the results.",
    )
    p.add_argument("file", help="netlist file")
    p.add_argument("--out", metavar="DIR", help="write one file per analysis into DIR")
    p.add_argument("--format", choices=("csv", "raw"), default="csv",
                   help="result file format: csv (default) or ngspice raw (binary)")
    p.add_argument("--ascii", action="store_true", help="with --format raw: write ascii raw files")
    p.add_argument("--plot", action="store_true", help="also write a PNG plot per analysis (into --out or .)")
    p.add_argument("--json", action="store_true", help="print one JSON object instead of tables")
    p.add_argument("--rtol", "--reltol", dest="reltol", type=float, help="relative tolerance (overrides .options reltol)")
    p.add_argument("--abstol", type=float, help="absolute current tolerance [A]")
    p.add_argument("--vntol", type=float, help="absolute voltage tolerance [V]")
    p.add_argument("--save", metavar="SIGNALS",
                   help="comma-separated signals to keep, e.g. 'v(out),i(v1)' (default: .save cards or all)")
    p.add_argument("--export", metavar="PATH",
                   help="write the matrices E, H, B of the (linearised) MNA system: .npz or .mtx (MatrixMarket)")
    return p


def _overrides(args) -> dict:
    return {k: getattr(args, k) for k in ("reltol", "abstol", "vntol") if getattr(args, k) is not None}


def _op_lines(result) -> list[str]:
    names = result.names()
    width = max((len(n) for n in names), default=4)
    lines = [f"{'signal':<{width}}  value"]
    for name in names:
        unit = "V" if name.startswith("v(") else "A"
        lines.append(f"{name:<{width}}  {result.signals[name][0]: .9g} {unit}")
    return lines


def _stats_line(result) -> str:
    s = result.stats
    keys = ("points", "steps", "rejected", "newton", "factorizations", "strategy")
    parts = [f"{k}={s[k]}" for k in keys if k in s]
    if "wall_time" in s:
        parts.append(f"wall={s['wall_time']:.3g}s")
    return ", ".join(parts)


def _scalars(stats: dict) -> dict:
    """The numbers and strings of a stats dict, nested dicts (the integrator's counters) included."""
    out = {}
    for k, v in stats.items():
        if isinstance(v, (int, float, str, bool)):
            out[k] = v
        elif isinstance(v, dict):
            out[k] = _scalars(v)
    return out


def _json_of(result, files) -> dict:
    if result.analysis == "op":
        return {name: float(v[0]) for name, v in result.signals.items()}
    out = {
        "status": result.status,
        "message": result.message,
        "points": int(result.axis.size) if result.axis is not None else 0,
        "signals": result.names(),
        "stats": _scalars(result.stats),
        "tolerances": result.tolerances,
        "notes": result.notes,
    }
    if files:
        out["files"] = files
    return out


def main(args) -> int:
    from ..analyses.runner import run
    from . import signal_list
    from ..netlist import load

    circuit = load(args.file)
    save = signal_list(args.save)
    from .progress import ProgressBar

    bar = ProgressBar()
    try:
        results = run(circuit, save=save, progress=bar, **_overrides(args))
    finally:
        bar.close()
    out_dir = Path(args.out) if args.out else None
    if out_dir is not None:
        out_dir.mkdir(parents=True, exist_ok=True)
    written: dict[int, list[str]] = {}
    counts: dict[str, int] = {}
    for k, res in enumerate(results):
        counts[res.analysis] = counts.get(res.analysis, 0) + 1
        stem = res.analysis if counts[res.analysis] == 1 else f"{res.analysis}{counts[res.analysis]}"
        files = []
        if out_dir is not None:
            if args.format == "csv":
                from ..io.csv import write_csv

                path = out_dir / f"{stem}.csv"
                write_csv(path, res)
            else:
                from ..io.raw import write_raw

                path = out_dir / f"{stem}.raw"
                write_raw(path, [res], binary=not args.ascii, title=circuit.title)
            files.append(str(path))
        if args.plot and res.analysis != "op":
            from ..plotting import plot_result

            path = (out_dir or Path(".")) / f"{stem}.png"
            plot_result(res, path, title=f"{circuit.title} ({stem})")
            files.append(str(path))
        written[k] = files
    if args.export:
        from ..io.matrices import export_matrices

        export_matrices(circuit, args.export)
    if args.json:
        doc: dict = {}
        seen: dict[str, int] = {}
        for k, res in enumerate(results):
            seen[res.analysis] = seen.get(res.analysis, 0) + 1
            key = res.analysis if seen[res.analysis] == 1 else f"{res.analysis}{seen[res.analysis]}"
            doc[key] = _json_of(res, written[k])
        if args.export:
            doc["export"] = args.export
        json.dump(doc, sys.stdout, indent=2)
        sys.stdout.write("\n")
    else:
        print(circuit.title)
        for k, res in enumerate(results):
            print()
            print(f".{res.analysis}: {res.message or 'ok'} ({_stats_line(res)})")
            if res.analysis == "op":
                print("\n".join(_op_lines(res)))
            for note in res.notes:
                print(f"note: {note}")
            for path in written[k]:
                print(f"wrote {path}")
        if args.export:
            print(f"wrote matrices to {args.export}")
    return 0 if all(r.ok for r in results) else 1
