"""``netdae compare FILE``: run a netlist in netdae and ngspice and report the differences.

Prints a table per analysis, worst signal first (signal, max abs err, max rel
err, RMS err, where, pass), or one JSON object with ``--json``; ``--plot
PNG`` draws both waveforms and their difference. Exit status 0 when every
judged signal is within tolerance, 1 otherwise (or when a simulator failed on
the netlist), 2 on bad input or a missing ngspice.
"""

from __future__ import annotations

import argparse
import json
import logging
import sys

from . import EXIT_ERROR, add_ngbehavior, option_value, positive_float, signal_names

__all__ = ["add_parser", "main"]

LOG = logging.getLogger("netdae")


def add_parser(sub) -> argparse.ArgumentParser:
    p = sub.add_parser(
        "compare",
        help="compare netdae with ngspice on a netlist, signal by signal",
        description="Run the netlist's analyses in netdae and in ngspice (the same text; netdae's ideal "
        "op-amp becomes a high-gain VCVS for ngspice) and report the error of every signal at "
        "ngspice's points: transient at its accepted time points (netdae's dense output), AC at its "
        "frequencies, DC per sweep point, the operating point per unknown.",
    )
    p.add_argument("file", help="netlist file")
    p.add_argument("--json", action="store_true", help="print one JSON object instead of tables")
    p.add_argument("--plot", metavar="PNG", help="write both waveforms and their difference to PNG")
    p.add_argument("--tight", action=argparse.BooleanOptionalAction, default=None,
                   help="tight tolerances on both sides (netdae and ngspice reltol 1e-6, ngspice step bounded); "
                   "default: the netlist header's '* compare options:', --no-tight overrides it")
    p.add_argument("--tol", type=positive_float, metavar="REL",
                   help="pass when every error is within REL of its signal's scale "
                   "(default: the netlist's '* compare tolerance:' header, else 1e-3)")
    p.add_argument("--reltol", type=option_value("reltol"),
                   help="relative tolerance for both simulators, between 0 and 1")
    p.add_argument("--backend", choices=("auto", "shared", "subprocess"), default="auto",
                   help="how to run ngspice (default: its shared library, else the executable)")
    p.add_argument("--signals", metavar="LIST", type=signal_names,
                   help="compare only these signals, e.g. 'v(out),i(v1)'")
    p.add_argument("--exclude", metavar="LIST", type=signal_names, default=[],
                   help="signals to leave out, e.g. 'v(minus)'")
    p.add_argument("--timeout", metavar="SECONDS", type=positive_float,
                   help="give up on ngspice after SECONDS (default: 300)")
    add_ngbehavior(p)
    return p


def _check_selection(signals: list[str] | None, exclude: list[str]) -> None:
    """Refuse a ``--signals`` list that leaves nothing to compare (an empty one, or all excluded).

    Raises
    ------
    NetdaeError
        A usage error (exit status 2), not a comparison that fails.
    """
    from ..errors import NetdaeError

    if signals is not None and not [s for s in signals if s not in exclude]:
        why = "is empty" if not signals else "names only signals --exclude leaves out"
        raise NetdaeError(f"compare: --signals {why}: nothing to compare (hint: name signals such as "
                          "'v(out),i(v1)', or leave --signals out to compare every common signal)")


def main(args) -> int:
    from ..comparison import compare, format_comparison

    _check_selection(args.signals, args.exclude)
    comparison = compare(
        args.file,
        tight=args.tight,
        tol=args.tol,
        backend=args.backend,
        signals=args.signals,
        exclude=args.exclude,
        reltol=args.reltol,
        timeout=args.timeout,
        behavior=args.ngbehavior,
    )
    from ..errors import OutputFileError

    written, write_error = None, None
    if args.plot:
        from ..comparison.plot import plot_comparison

        drawn = comparison.points[0] if comparison.points else comparison
        if comparison.points:
            LOG.info("note: --plot draws the first point of the .step cards (%s)",
                     ", ".join(f"{k}={v:g}" for k, v in drawn.point.items()))
        try:
            written = str(plot_comparison(drawn, args.plot))
        except OutputFileError as exc:  # a full disk: the comparison is still printed, then the error
            write_error = exc
    if args.json:
        doc = comparison.to_dict()
        if written:
            doc["plot"] = written
        json.dump(doc, sys.stdout, indent=2)
        sys.stdout.write("\n")
    else:
        sys.stdout.write(format_comparison(comparison))
    if written:
        LOG.info("wrote %s", written)
    if write_error is not None:
        LOG.error("%s", write_error)
        return EXIT_ERROR
    return 0 if comparison.passed else 1
