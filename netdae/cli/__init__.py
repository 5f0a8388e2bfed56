"""The ``netdae`` command line: ``netdae check | run | index | compare | demo``.

Each subcommand lives in its own module of this package with two functions,
``add_parser(subparsers)`` and ``main(args) -> int``. Modules import the
numerical parts of netdae inside ``main`` so that ``netdae --help`` stays fast.

Errors: every :class:`netdae.errors.NetdaeError` becomes one readable line on
stderr and exit status 2; a bug inside netdae is reported as an internal
error in one line (set ``NETDAE_DEBUG=1`` for the traceback), exit status 3.
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys

__all__ = ["main", "COMMANDS"]

#: Subcommands in the order ``--help`` lists them.
COMMANDS = ("check", "index", "run", "compare", "demo")

EXIT_OK = 0
EXIT_FAIL = 1  # the command ran and its verdict is negative (e.g. compare out of tolerance)
EXIT_ERROR = 2  # bad input or a netdae error
EXIT_INTERNAL = 3  # a bug in netdae


def signal_list(text: str | None) -> list[str] | None:
    """Split a comma-separated signal list, keeping ``v(a,b)`` whole.

    >>> signal_list("v(out), v(in,minus),i(v1)")
    ['v(out)', 'v(in,minus)', 'i(v1)']
    """
    if text is None:
        return None
    parts, depth, cur = [], 0, []
    for ch in text:
        if ch == "," and depth == 0:
            parts.append("".join(cur))
            cur = []
            continue
        depth += (ch == "(") - (ch == ")")
        cur.append(ch)
    parts.append("".join(cur))
    return [p.strip().lower() for p in parts if p.strip()]


def build_parser() -> argparse.ArgumentParser:
    """The top-level parser with every available subcommand registered."""
    from .. import __version__

    parser = argparse.ArgumentParser(
        prog="netdae",
        description="A SPICE-dialect circuit simulator that treats a netlist as a "
        "differential-algebraic equation.",
    )
    parser.add_argument("--version", action="version", version=f"netdae {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    for name in COMMANDS:
        try:
            module = importlib.import_module(f"{__name__}.{name}")
        except ModuleNotFoundError as exc:  # a subcommand not built into this tree
            if exc.name == f"{__name__}.{name}":
                continue
            raise
        p = module.add_parser(sub)
        p.set_defaults(_main=module.main)
    return parser


#: BLAS threads for the command line. netdae's dense work is small (pencils of
#: a few hundred unknowns) and its sparse LU is single-threaded; on small
#: machines BLAS threads only add contention (measured: a 200x200 SVD takes
#: 20 ms on one thread and 250 ms with two threads on a loaded 2-core machine).
#: A user's own setting of these variables wins.
BLAS_THREADS = "1"


def _limit_blas_threads() -> None:
    for var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(var, BLAS_THREADS)


def main(argv: list[str] | None = None) -> int:
    """Run the command line; returns the exit status."""
    _limit_blas_threads()
    from ..errors import NetdaeError

    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args._main(args) or 0)
    except NetdaeError as exc:
        print(f"netdae: error: {exc}", file=sys.stderr)
        return EXIT_ERROR
    except KeyboardInterrupt:
        print("netdae: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:
        return EXIT_OK
    except Exception as exc:  # noqa: BLE001 - the CLI never shows a traceback
        if os.environ.get("NETDAE_DEBUG"):
            raise
        print(
            f"netdae: internal error: {type(exc).__name__}: {exc} "
            "(this is a bug in netdae; rerun with NETDAE_DEBUG=1 for the traceback)",
            file=sys.stderr,
        )
        return EXIT_INTERNAL


def run() -> None:
    """Console-script entry point."""
    sys.exit(main())
