"""``netdae demo [FILE] --out DIR``: the whole story on one netlist.

1. what netdae read (``netdae check``, with the topological findings);
2. what kind of DAE it is and why (``netdae index``);
3. the transient (``netdae run``): statistics, notes (e.g. the consistent
   initial values of an index-2 circuit), ``DIR/tran.csv`` and ``DIR/tran.png``;
4. the comparison with ngspice (``netdae compare``): the table and
   ``DIR/compare.png``.

Without ngspice the last part is replaced by the command that installs it.
"""

from __future__ import annotations

import argparse

from . import directory_name

__all__ = ["add_parser", "main", "DEFAULT_NETLIST"]

#: The bundled netlist the demo runs when none is given.
DEFAULT_NETLIST = "netlists/differentiator.cir"


def add_parser(sub) -> argparse.ArgumentParser:
    p = sub.add_parser(
        "demo",
        help="the whole story on a netlist: structure, index, transient, comparison with ngspice",
        description="Read the netlist, explain its DAE structure and index, run its transient and compare "
        "it with ngspice, writing the results and plots into --out.",
    )
    p.add_argument("file", nargs="?", default=DEFAULT_NETLIST, help=f"netlist (default {DEFAULT_NETLIST})")
    p.add_argument("--out", metavar="DIR", type=directory_name, default="out", help="directory for results and plots (default: out)")
    return p


def _default_netlist(name: str) -> str:
    """``name`` as given when it exists, else the differentiator of netdae's own tree (an installation from
    the repository), so that ``netdae demo`` runs from any directory."""
    from pathlib import Path

    if name != DEFAULT_NETLIST or Path(name).exists():
        return name
    bundled = Path(__file__).resolve().parents[2] / DEFAULT_NETLIST
    return str(bundled) if bundled.exists() else name


def _section(title: str) -> None:
    print()
    print(f"== {title} " + "=" * max(0, 74 - len(title)))


def main(args) -> int:
    from ..analyses.index import analyze_index
    from ..analyses.runner import run
    from ..errors import NgspiceError
    from ..io.csv import write_csv
    from ..netlist import load
    from ..plotting import plot_result
    from ..topology import analyze_topology
    from . import output_directory
    from .check import format_summary, summarize, topology_lines
    from .index import format_report
    from .progress import ProgressBar

    out = output_directory(args.out)
    args.file = _default_netlist(args.file)
    circuit = load(args.file)

    _section("1. the netlist (netdae check)")
    summary = summarize(circuit)
    topo = analyze_topology(circuit)
    summary["topology"] = topology_lines(topo)
    print(format_summary(summary))

    _section("2. what kind of DAE it is (netdae index)")
    print(format_report(analyze_index(circuit)))

    _section("3. simulation (netdae run)")
    bar = ProgressBar(enabled=args.verbosity >= 0)
    try:
        results = run(circuit, progress=bar)
    finally:
        bar.close()
    counts: dict[str, int] = {}
    for res in results:
        counts[res.analysis] = counts.get(res.analysis, 0) + 1
        stem = res.analysis if counts[res.analysis] == 1 else f"{res.analysis}{counts[res.analysis]}"
        print(f".{res.analysis}: {res.message}")
        print(f"  {res.stats.summary()}")
        for note in res.notes:
            print(f"  note: {note}")
        csv_path = out / f"{stem}.csv"
        write_csv(csv_path, res)
        print(f"  wrote {csv_path}")
        if res.analysis != "op":
            png = plot_result(res, out / f"{stem}.png", title=f"{circuit.title} (netdae {res.analysis})", circuit=circuit)
            print(f"  wrote {png}")

    _section("4. netdae vs ngspice (netdae compare)")
    from ..comparison import compare, format_comparison
    from ..comparison.plot import plot_comparison

    try:
        comparison = compare(args.file)
    except NgspiceError as exc:
        print(f"skipped: {exc}")
        return 0
    print(format_comparison(comparison), end="")
    if any(a.signals for a in comparison.analyses if a.analysis != "op"):
        png = plot_comparison(comparison, out / "compare.png")
        print(f"wrote {png}  (both waveforms overlaid, the difference underneath)")
    return 0 if comparison.passed else 1
