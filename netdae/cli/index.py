"""``netdae index FILE``: what kind of DAE the circuit is, and why, in circuit terms.

Prints the index, the structure of the pencil (rank of E, dynamic states,
infinite blocks, natural frequencies), the circuit reasons (CV-loops,
LI-cutsets, voltage-source loops, current-source cutsets, floating nodes),
the classification of every unknown, the rank decisions with their
tolerances, and whether the transient's start is consistent. ``--json``
prints the same as one JSON object.
"""

from __future__ import annotations

import argparse
import json
import sys

from . import add_max_elements, add_ngbehavior, positive_float

__all__ = ["add_parser", "main", "format_report"]

#: At most this many unknowns are listed one per line in the text report.
LIST_UNKNOWNS = 40


def add_parser(sub) -> argparse.ArgumentParser:
    p = sub.add_parser(
        "index",
        help="index and structure of the circuit's DAE, with the circuit reasons",
        description="Analyse the pencil (E, H) of the circuit's DAE: regularity, Kronecker index, dynamic "
        "states, which unknowns depend on input derivatives, and the topological reasons.",
    )
    p.add_argument("file", help="netlist file")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.add_argument("--at", choices=("op", "t0"), default="op",
                   help="linearise at the DC operating point (default) or at the transient's initial point")
    p.add_argument("--tol", type=_rank_tol, help="relative tolerance of the rank decisions, between 0 and 1 "
                   "(default n*eps)")
    p.add_argument("--method", choices=("auto", "kronecker", "topological", "sparse"), default="auto",
                   help="auto: dense Kronecker analysis up to the dense limit, sparse above; sparse: the circuit's "
                   "structure where it gives the index, else the algebraic part (index 0-2 and the index-2 "
                   "unknowns); topological: the structure only")
    add_ngbehavior(p)
    add_max_elements(p)
    return p


def _rank_tol(text: str) -> float:
    value = positive_float(text)
    if value >= 1.0:
        raise argparse.ArgumentTypeError(f"expected a relative tolerance between 0 and 1, got {text!r}")
    return value


def _fmt_eig(z: complex) -> str:
    if abs(z.imag) <= 1e-12 * max(abs(z.real), 1e-300):
        return f"{z.real:.6g}"
    return f"{z.real:.6g}{z.imag:+.6g}j"


def _decision_line(d) -> str:
    kept = ", ".join(f"{v:.3g}" for v in d.kept) or "-"
    dropped = ", ".join(f"{v:.3g}" for v in d.dropped) or "-"
    return f"{d.what}: rank {d.rank} of {min(d.shape)} (tol {d.tol:.3g}; kept ... {kept} | dropped {dropped} ...)"


def format_report(rep, title: str = "") -> str:
    """The text diagnosis of an :class:`~netdae.analyses.index.IndexReport`."""
    from ..dae.kronecker import format_sizes
    lines = []
    if title:
        lines.append(title)
    where = "the DC operating point" if rep.at == "op" else "the transient's initial point"
    idx = "none (singular pencil)" if rep.regular is False else ("unknown" if rep.index is None else str(rep.index))
    if getattr(rep, "point", "").startswith("linear circuit"):
        where = "no operating point: the circuit is linear"
    elif getattr(rep, "point", ""):
        where = rep.point
    how = (where if where.startswith("no ") else f"linearised at {where}") if rep.method in ("kronecker", "sparse") \
        else "circuit structure"
    lines.append(f"index: {idx}   method: {rep.method} ({how}), {rep.n_unknowns} unknowns")
    if rep.method == "kronecker":
        lines.append(f"  pencil: {'regular' if rep.regular else 'singular'}; rank E = {rep.rank_E}; "
                     f"dynamic states = {rep.n_dynamic}; infinite blocks = {format_sizes(rep.infinite_blocks)}")
        if rep.finite_eigenvalues.size:
            eig = ", ".join(_fmt_eig(z) for z in rep.finite_eigenvalues[:12])
            more = " ..." if rep.finite_eigenvalues.size > 12 else ""
            lines.append(f"  natural frequencies [1/s]: {eig}{more}")
        else:
            lines.append("  natural frequencies: none (no dynamic states)")
    lines.append("")
    lines.append("diagnosis:")
    lines += [f"  {m}" for m in rep.messages]
    if rep.unknowns:
        lines.append("")
        lines.append("unknowns:")
        items = list(rep.unknowns.items())
        width = max(len(nm) for nm, _ in items)
        special = [(nm, lb) for nm, lb in items if lb.startswith("index")]
        shown = items if len(items) <= LIST_UNKNOWNS else special
        for nm, lb in shown:
            lines.append(f"  {nm:<{width}}  {lb}")
        if len(shown) < len(items):
            counts: dict[str, int] = {}
            for _, lb in items:
                counts[lb] = counts.get(lb, 0) + 1
            lines.append("  (" + ", ".join(f"{c} {lb}" for lb, c in sorted(counts.items())) + ")")
    if rep.pencil is not None:
        lines.append("")
        lines.append(f"rank decisions (relative tolerance {rep.tolerance.get('rtol', 0):.3g}):")
        lines += [f"  {_decision_line(d)}" for d in rep.pencil.evidence[:12]]
        lines += [f"  warning: {w}" for w in rep.pencil.warnings]
    if rep.consistency is not None:
        lines.append("")
        state = "consistent" if rep.consistency.consistent else "INCONSISTENT (netdae corrects it; ngspice does not)"
        lines.append(f"transient start: {state}")
    return "\n".join(lines)


def main(args) -> int:
    from ..analyses.index import analyze_index
    from ..netlist import load

    circuit = load(args.file, behavior=args.ngbehavior, max_elements=args.max_elements)
    rep = analyze_index(circuit, at=args.at, tol=args.tol, method=args.method)
    if args.json:
        json.dump(rep.to_dict(), sys.stdout, indent=2)
        sys.stdout.write("\n")
    else:
        print(format_report(rep, f"{args.file}: {circuit.title}"))
    return 0
