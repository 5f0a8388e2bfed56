"""``netdae run FILE``: run the analyses in a netlist, print a summary, write results.

Writes one file per analysis into ``--out DIR`` (``op.csv``, ``dc.csv``,
``ac.csv``, ``tran.csv``, ``pz.csv``, ``tf.csv``, ``sens.csv``, ``noise.csv`` and the
integrated noise ``noise_total.csv``; a second card of a kind ``tran2.csv``
...; ``.raw`` with ``--format raw``), optional PNG plots (``--plot``), and prints a table of
the operating point and the statistics of every analysis on stdout (or one
JSON object with ``--json``: one :meth:`~netdae.results.Result.to_dict` per
analysis). The analyses' notes and the files written are logged on stderr.
Measurements (``.meas`` cards) are printed as ngspice prints them
(``name = value``, with ``at=``, ``from= to=`` or ``targ= trig=``), go into the
JSON (``measures`` of each analysis) and, with ``--out``, into
``measures.csv`` (:mod:`netdae.io.measures`); Fourier analyses (``.four``) are
printed as ngspice's tables, go into the JSON (``fourier``) and into
``fourier.csv`` (:mod:`netdae.io.fourier`).

Ctrl-C during a transient keeps what was computed: the results of the
analyses before it and the transient up to where it stopped are written and
printed as usual, then ``netdae run`` exits with status 130. A transient that
fails mid-way, and a ``.dc`` sweep whose point fails, are written with the
points before the failure, the log saying where the file ends and why; the
analyses after them run, and the exit status is 1.

With ``--out``, a transient's file (``tran.raw`` or ``tran.csv``) is written
while the run goes on (:class:`~netdae.io.raw.RawStream`,
:class:`~netdae.io.csv.CsvStream`): a run that stops (Ctrl-C, a failed step,
a full disk) leaves the points it computed in a valid file, and the log says
where and why it ends. A transient whose result is not its integrator's
points (``.options interp``, index 3, device quantities such as ``i(r1)``)
is written whole when it ends, as every other analysis.
"""

from __future__ import annotations

import argparse
import json
import logging
import sys
import time
from pathlib import Path
from types import SimpleNamespace

from . import (EXIT_ERROR, add_max_elements, add_ngbehavior, directory_name, log_diagnostics, option_value,
               output_directory, saved_names)
from ..signals import signal_unit
from ..errors import OutputFileError

__all__ = ["add_parser", "main", "stems"]

LOG = logging.getLogger("netdae")

#: Exit status after Ctrl-C (128 + SIGINT, as shells report it).
#: Matrix file formats of ``--export``, by suffix.
EXPORT_SUFFIXES = (".npz", ".mtx")


def _export_path(text: str) -> str:
    if Path(text).suffix not in EXPORT_SUFFIXES:
        raise argparse.ArgumentTypeError(f"expected a .npz or .mtx path, got {text!r}")
    return text


def add_parser(sub) -> argparse.ArgumentParser:
    p = sub.add_parser(
        "run",
        help="run the analyses of a netlist (.op, .dc, .ac, .tran, .pz, .tf, .noise, .sens)",
        description="Run every analysis in the netlist, print a summary and write the results.",
    )
    p.add_argument("file", help="netlist file")
    p.add_argument("--out", metavar="DIR", type=directory_name, help="write one file per analysis into DIR")
    p.add_argument("--format", choices=("csv", "raw"), default=None,
                   help="with --out: the result files' format, csv (default) or ngspice raw (binary)")
    p.add_argument("--ascii", action="store_true", help="with --format raw: write ascii raw files")
    p.add_argument("--plot", action="store_true", help="also write a PNG plot per analysis (into --out or .)")
    p.add_argument("--json", action="store_true", help="print one JSON object instead of tables")
    p.add_argument("--rtol", "--reltol", dest="reltol", type=option_value("reltol"),
                   help="relative tolerance, between 0 and 1 (overrides .options reltol)")
    p.add_argument("--abstol", type=option_value("abstol"), help="absolute current tolerance [A], positive")
    p.add_argument("--vntol", type=option_value("vntol"), help="absolute voltage tolerance [V], positive")
    p.add_argument("--save", metavar="SIGNALS", type=saved_names,
                   help="comma-separated signals every analysis keeps, e.g. 'v(out),v(a,b),i(v1)' "
                   "(default: the .save/.print/.probe signals, else all)")
    p.add_argument("--export", metavar="PATH", type=_export_path,
                   help="write the matrices E, H, B of the (linearised) MNA system: PATH.npz, or "
                   "PATH's stem .E.mtx .H.mtx .B.mtx .names.txt (MatrixMarket) for a .mtx path")
    add_ngbehavior(p)
    add_max_elements(p)
    return p


def _op_lines(result) -> list[str]:
    names = result.names()
    width = max((len(n) for n in names), default=4)
    lines = [f"{'signal':<{width}}  value"]
    for name in names:
        unit = signal_unit(name)
        lines.append(f"{name:<{width}}  {result.signals[name][0]: .9g} {unit}")
    return lines


def _quantity_lines(result) -> list[str]:
    """A ``.pz`` or ``.tf`` result as ngspice prints it: ``pole(1) = re,im``, ``transfer_function = v``."""
    if result.analysis == "pz":
        from ..analyses.pz import format_root

        lines = [format_root(name, complex(v[0])) for name, v in result.signals.items()]
        return lines or ["(no finite pole or zero)"]
    return [f"{name} = {float(v[0]):.6e}" for name, v in result.signals.items()]


def _sens_lines(result) -> list[str]:
    """A ``.sens`` result as a table: one row per parameter (per frequency for the AC sensitivity)."""
    names = list(result.signals)
    if not names:
        return ["(no parameter)"]
    width = max(len("parameter"), *(len(n) for n in names))
    freqs = result.axes.get("frequency")
    if freqs is None:
        lines = [f"{'parameter':<{width}}  d out / d parameter"]
        for name in names:
            v = float(result.signals[name][0])
            lines.append(f"{name:<{width}}  " + ("not computed" if v != v else f"{v: .6e}"))
        return lines
    lines = []
    for i, f in enumerate(freqs):
        lines.append(f"frequency = {f:.6e} Hz")
        lines.append(f"{'parameter':<{width}}  {'real':>13}  {'imaginary':>13}  {'magnitude':>13}")
        for name in names:
            v = complex(result.signals[name][i])
            if v != v:
                lines.append(f"{name:<{width}}  not computed")
            else:
                lines.append(f"{name:<{width}}  {v.real: .6e}  {v.imag: .6e}  {abs(v): .6e}")
    return lines


def stems(results) -> list[str]:
    """File stems (and JSON keys) of results: the analysis, numbered from its second card on.

    >>> from types import SimpleNamespace as R
    >>> stems([R(analysis="op"), R(analysis="tran"), R(analysis="tran"), R(analysis="ac")])
    ['op', 'tran', 'tran2', 'ac']
    """
    counts: dict[str, int] = {}
    out = []
    for res in results:
        counts[res.analysis] = counts.get(res.analysis, 0) + 1
        out.append(res.analysis if counts[res.analysis] == 1 else f"{res.analysis}{counts[res.analysis]}")
    return out


def _stream(args, path: Path, title: str):
    """The streamed file of a transient (raw or CSV, as ``--format`` asks)."""
    if args.format == "csv":
        from ..io.csv import CsvStream

        return CsvStream(path)
    from ..io.raw import RawStream

    return RawStream(path, binary=not args.ascii, title=title)


def _free_space(folder: Path | None) -> int | None:
    """Bytes free for a user in ``folder`` (None without one, or when the system does not say)."""
    if folder is None:
        return None
    import shutil

    try:
        return shutil.disk_usage(folder).free
    except OSError:
        return None


def _finish_stream(res, stream) -> bool:
    """Close a transient's streamed file; True when it holds the result (else it is written whole).

    Raises
    ------
    OutputFileError
        When the file cannot be completed.
    """
    if stream is None or not stream.opened:
        return False
    stream.close()
    if stream.error is not None:  # the run stopped there; the file keeps its points
        from ..errors import OutputFileError

        raise OutputFileError(stream.path, stream.failure())
    axis = res.axis
    if (stream.points != (res.stats.points or res.points) or stream.names != list(res.axes) + list(res.signals)
            or (axis is not None and axis.size and stream.last != float(axis[-1]))):  # e.g. a run run again
        LOG.debug("%s: the streamed points differ from the result's; written whole", stream.path)
        return False
    if not res.ok:
        LOG.warning("%s holds the %s points up to t=%.9g: %s", stream.path, f"{stream.points:,}", stream.last,
                    res.message)
    return True


def _partial(path, res) -> None:
    """Say what the file of a failed result written whole holds: its points up to where it stopped, and why.

    The streamed transient's file says the same (:func:`_finish_stream`); a ``.dc`` sweep whose point
    failed ends at the point before (``dc.csv holds the 3 points up to v1 = 0: .dc at v1 = -0.5: ...``).
    """
    axes = {name: values for name, values in res.axes.items() if len(values)}
    if res.ok or not axes:
        return
    if res.analysis == "tran":
        last = f"t={float(res.t[-1]):.9g}"
    else:
        last = ", ".join(f"{name} = {float(values[-1]):.9g}" for name, values in axes.items())
    LOG.warning("%s holds the %s up to %s: %s", path, f"{res.points:,} point" + "s" * (res.points != 1), last,
                res.message)


def _write(res, stem: str, args, out_dir: Path | None, title: str, circuit=None, stream=None) -> list[str]:
    files = []
    if out_dir is not None and _finish_stream(res, stream):
        files.append(stream.path)
    elif out_dir is not None:
        if args.format == "csv":
            from ..io.csv import write_csv

            path = out_dir / f"{stem}.csv"
            write_csv(path, res)
            if res.analysis == "noise" and res.noise_totals:
                from ..io.csv import write_noise_totals

                files.append(str(path))
                path = out_dir / f"{stem}_total.csv"
                write_noise_totals(path, res.noise_totals)
        else:
            from ..io.raw import write_raw

            path = out_dir / f"{stem}.raw"
            write_raw(path, [res], binary=not args.ascii, title=title)
        files.append(str(path))
        _partial(path, res)
    if args.plot and res.analysis not in ("op", "pz", "tf", "sens"):
        from ..plotting import plot_result

        path = (out_dir or Path(".")) / f"{stem}.png"
        plot_result(res, path, title=f"{title} ({stem})", circuit=circuit)
        files.append(str(path))
    return files


def _check_output_files(out_dir: Path, circuit, args) -> None:
    """Refuse, before anything runs, an output file whose name is taken by a directory.

    A transient streams its file as it runs: a directory in its place stopped it after its first
    chunk of points. The other files would fail only after the run.

    Raises
    ------
    OutputFileError
    """
    from ..analyses.runner import analysis_name

    names = [f"{stem}.{args.format}" for stem in stems([SimpleNamespace(analysis=analysis_name(card))
                                                          for card in circuit.analyses])]
    names += ["measures.csv", "fourier.csv"]
    for name in names:
        path = out_dir / name
        if path.is_dir():
            raise OutputFileError(str(path), "it is a directory (hint: remove or rename it, or give another --out)")


def _write_table(path, items: list, write, errors: list) -> str | None:
    """``write(path, items)`` when there are items: the path written, or None (nothing to write, or the
    failure appended to ``errors``)."""
    if not items:
        return None
    try:
        write(path, items)
    except OutputFileError as exc:
        errors.append(exc)
        return None
    return str(path)


def _log_notes(notes) -> None:
    for note in notes:
        if note.startswith("warning: "):
            LOG.warning("%s", note.removeprefix("warning: "))
        else:
            LOG.info("note: %s", note)


def _check_format_options(args) -> None:
    """``--format`` and ``--ascii`` choose how ``--out`` writes: given where they change nothing, they are refused
    (a ``--format raw`` without ``--out`` wrote no file and said nothing). Sets the default format, csv.

    Raises
    ------
    NetdaeError
        Naming the option and what it needs.
    """
    from ..errors import NetdaeError

    if args.format is not None and not args.out:
        raise NetdaeError(f"--format {args.format} chooses the format of the files --out writes, and no --out was "
                          "given (hint: add --out DIR)")
    if args.ascii and args.format != "raw":
        raise NetdaeError("--ascii writes raw files as text, and the files are not raw (hint: add --format raw"
                          + (")" if args.out else " and --out DIR)"))
    args.format = args.format or "csv"


def main(args) -> int:
    from ..analyses.runner import analysis_name, run
    from ..netlist import load
    from .progress import ProgressBar

    _check_format_options(args)
    t0 = time.perf_counter()
    circuit = load(args.file, behavior=args.ngbehavior, max_elements=args.max_elements)
    log_diagnostics(circuit)
    LOG.debug("read %s in %.3g s: %d nodes, %d elements, %d analyses", args.file, time.perf_counter() - t0,
              len(circuit.nodes), len(circuit.elements), len(circuit.analyses))
    bar = ProgressBar(enabled=args.verbosity >= 0)
    out_dir = output_directory(args.out) if args.out else None
    if out_dir is not None:
        _check_output_files(out_dir, circuit, args)
    streams: dict = {}  # a transient's position among the analyses -> its streamed file

    def output(position: int, start: int, block) -> str | None:
        if position not in streams:
            stem = stems([SimpleNamespace(analysis=analysis_name(card)) for card in circuit.analyses])[position]
            streams[position] = _stream(args, out_dir / f"{stem}.{args.format}", circuit.title)
        return streams[position].write(start, block)

    interrupted = None
    try:
        results = run(circuit, save=args.save, progress=bar, reltol=args.reltol, abstol=args.abstol,
                      vntol=args.vntol, output=output if out_dir is not None else None,
                      bounded=not (args.plot or args.json), room=_free_space(out_dir))
    except KeyboardInterrupt as exc:
        results = getattr(exc, "results", None)
        if not results:
            _close_streams(streams)
            raise
        interrupted = exc  # write what was computed, then report the interruption
    except BaseException:
        _close_streams(streams)  # what was written stays a valid file
        raise
    finally:
        bar.close()
    keys = stems(results)
    # A file that cannot be written (a full disk) does not lose what was computed: the other files are
    # written, the results and measurements printed, and the error said last (exit status 2).
    write_errors: list[OutputFileError] = []
    written: list[list[str]] = []
    try:
        for position, (res, stem) in enumerate(zip(results, keys)):
            try:
                written.append(_write(res, stem, args, out_dir, circuit.title, circuit, streams.get(position)))
            except OutputFileError as exc:
                write_errors.append(exc)
                written.append([])
    finally:
        _close_streams(streams)  # those a failed write left open

    measures = [m for res in results for m in res.measures]
    fouriers = [f for res in results for f in res.fourier]
    measures_file = fourier_file = None
    if out_dir is not None:
        from ..io.fourier import write_fourier
        from ..io.measures import write_measures

        measures_file = _write_table(out_dir / "measures.csv", measures, write_measures, write_errors)
        fourier_file = _write_table(out_dir / "fourier.csv", fouriers, write_fourier, write_errors)
    exported = []
    if args.export:
        from ..io.matrices import export_matrices

        try:
            exported = [str(f) for f in export_matrices(circuit, args.export)]
        except OutputFileError as exc:
            write_errors.append(exc)
    if args.json:
        doc: dict = {}
        for key, res, files in zip(keys, results, written):
            every = True if res.analysis == "sens" else None  # a sensitivity's values are few: always in
            doc[key] = {**res.to_dict(values=every), "files": files}
        if measures:
            doc["measures"] = {"file": measures_file, "values": [m.to_dict() for m in measures]}
        if fouriers:
            doc["fourier"] = {"file": fourier_file, "values": [f.to_dict() for f in fouriers]}
        if args.export:
            doc["export"] = exported
        json.dump(doc, sys.stdout, indent=2)
        sys.stdout.write("\n")
        for files in written:
            for path in files:
                LOG.info("wrote %s", path)
    else:
        print(circuit.title)
        for res, files in zip(results, written):
            print()
            print(f".{res.analysis}: {res.message or 'ok'} ({res.stats.summary()})")
            if res.analysis == "op":
                print("\n".join(_op_lines(res)))
            elif res.analysis in ("pz", "tf"):
                print("\n".join(_quantity_lines(res)))
            elif res.analysis == "noise":
                print("\n".join(f"{name} = {value:.6e}" for name, value in res.noise_totals.items()))
            elif res.analysis == "sens":
                print("\n".join(_sens_lines(res)))
            if res.measures:
                from ..measures import format_measure

                print(f"  Measurements for .{res.analysis}")
                print("\n".join(format_measure(m) for m in res.measures))
            if res.fourier:
                from ..fourier import format_fourier

                print("\n\n".join(format_fourier(f) for f in res.fourier))
            _log_notes(res.notes)
            for path in files:
                LOG.info("wrote %s", path)
    if measures_file is not None:
        LOG.info("wrote %s", measures_file)
    if fourier_file is not None:
        LOG.info("wrote %s", fourier_file)
    for path in exported:
        LOG.info("wrote %s", path)
    for exc in write_errors:
        LOG.error("%s", exc)
    if interrupted is not None:
        from . import interruption

        word, status = interruption(interrupted)
        message = results[-1].message
        # "interrupted at t=... of ..." says it already (it read "interrupted: interrupted at ...")
        LOG.error("%s", message if message.startswith(word) else f"{word}: {message}")
        return status
    if write_errors:
        return EXIT_ERROR
    return 0 if all(r.ok for r in results) else 1


def _close_streams(streams: dict) -> None:
    """Complete the streamed files of a run that ends with an error (their points stay readable)."""
    from ..errors import OutputFileError

    for stream in streams.values():
        try:
            stream.close()
        except OutputFileError as exc:
            LOG.error("%s", exc)
