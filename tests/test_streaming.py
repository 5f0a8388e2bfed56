"""A transient's result file is written while it runs: what was computed is never lost.

The oracle of a completed run is the whole-file writer (``format_raw``,
``format_csv``) of the same result, byte for byte; of a run that stopped
(Ctrl-C, a failed step, a full disk), the same run completed: the file holds
its first points exactly, and ``read_raw`` reads it without ``partial``.
"""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

import netdae
from netdae.analyses.runner import run
from netdae.errors import NetdaeError
from netdae.io.csv import CsvStream, format_csv, read_csv
from netdae.io.raw import RawStream, format_raw, parse_raw, read_raw

from test_io_files import _child
from test_interrupt import StopAt

#: A sine into an RC low-pass with a saved difference and a measurement: thousands of points, many chunks.
NETLIST = """RC low-pass driven by a sine
V1 in 0 SIN(0 1 1k)
R1 in out 1k
C1 out 0 100n
.save v(out) v(in,out) i(v1)
.meas tran vmax max v(out)
.op
.tran 1u 20m 1m
.end
"""


@pytest.fixture(autouse=True)
def chunk_returns_often(monkeypatch):
    """Return to Python after every chunk (not every 0.1 s), so that a run hands its points over in many blocks."""
    from netdae.dae.compiled import driver

    monkeypatch.setattr(driver, "PROGRESS_INTERVAL", 0.0)


def _streamed(netlist: str, tmp_path, csv: bool = True):
    """Run ``netlist`` with its transients streamed to raw (binary, ascii) and CSV files; the results and files."""
    circuit = netdae.load(netlist)
    streams: dict = {}
    blocks: list[int] = []

    def output(position, start, block):
        if position not in streams:
            streams[position] = (RawStream(tmp_path / f"{position}.raw", title=circuit.title, date="today"),
                                 RawStream(tmp_path / f"{position}a.raw", binary=False, title=circuit.title,
                                           date="today"),
                                 *([CsvStream(tmp_path / f"{position}.csv")] if csv else []))
        blocks.append(block.points)
        for stream in streams[position]:
            stream.write(start, block)

    results = run(circuit, output=output)
    for files in streams.values():
        for stream in files:
            stream.close()
    return circuit, results, streams, blocks


def test_a_completed_run_streams_the_files_the_whole_file_writers_write(tmp_path):
    netlist = NETLIST.replace(" v(in,out)", "")  # CSV refuses a comma in a column name
    circuit, results, streams, blocks = _streamed(netlist, tmp_path)
    assert list(streams) == [1]  # the transient; the .op is written whole
    tran = results[1]
    assert tran.ok and len(blocks) > 5 and sum(blocks) == tran.points
    assert tran.t[0] >= 1e-3  # tstart: the points before it are in neither
    binary, ascii_, csv = (open(s.path, "rb").read() for s in streams[1])
    assert binary == format_raw(tran, title=circuit.title, date="today")
    assert ascii_ == format_raw(tran, title=circuit.title, date="today", binary=False)
    assert csv == format_csv(tran).encode()
    (back,) = read_raw(streams[1][0].path)
    np.testing.assert_array_equal(back["v(out)"], tran["v(out)"])
    assert tran.measures[0].ok  # the dense output stays for .meas


def test_the_streamed_signals_are_the_results_selection_in_its_order(tmp_path):
    circuit, results, streams, _ = _streamed(NETLIST, tmp_path, csv=False)
    tran = results[1]
    assert tran.names() == ["v(out)", "v(in,out)", "i(v1)"]
    (back,) = parse_raw(open(streams[1][0].path, "rb").read())
    assert back.names() == tran.names()
    for name in tran.names():
        np.testing.assert_array_equal(back[name], tran[name])


def test_netdae_run_streams_the_transient_and_its_file_equals_write_raw(tmp_path):
    from netdae.cli import main

    path = tmp_path / "rc.cir"
    path.write_text(NETLIST)
    assert main(["run", str(path), "--out", str(tmp_path / "out"), "--format", "raw"]) == 0
    data = (tmp_path / "out" / "tran.raw").read_bytes()
    date = re.search(rb"^Date: (.*)$", data, re.M).group(1).decode()
    tran = next(r for r in netdae.run(str(path)) if r.analysis == "tran")
    assert data == format_raw(tran, title="RC low-pass driven by a sine", date=date)


def _full_tran(netlist: str):
    return next(r for r in netdae.run(netdae.load(netlist)) if r.analysis == "tran")


@pytest.mark.parametrize("fmt", ["raw", "csv"])
def test_ctrl_c_leaves_a_valid_file_of_the_points_up_to_the_stop(tmp_path, monkeypatch, caplog, fmt):
    from netdae.cli import main
    from netdae.cli import progress

    netlist = NETLIST.replace(" v(in,out)", "")
    path = tmp_path / "rc.cir"
    path.write_text(netlist)
    written: list[int] = []
    real_write = RawStream.write if fmt == "raw" else CsvStream.write

    def counted(self, start, block):  # the blocks that reached the file before the Ctrl-C
        written.append(block.points)
        return real_write(self, start, block)

    monkeypatch.setattr(RawStream if fmt == "raw" else CsvStream, "write", counted)
    monkeypatch.setattr(progress, "ProgressBar", lambda enabled=True: StopAt(5e-3))
    assert main(["run", str(path), "--out", str(tmp_path / "out"), "--format", fmt]) == 130
    part = read_raw(tmp_path / "out" / "tran.raw")[0] if fmt == "raw" else read_csv(tmp_path / "out" / "tran.csv")
    full = _full_tran(netlist)
    m = part.points
    assert len(written) > 1 and 5e-3 <= part.t[-1] < 20e-3 and m < full.points
    np.testing.assert_array_equal(part.t, full.t[:m])
    np.testing.assert_array_equal(part["v(out)"], full["v(out)"][:m])
    assert any("interrupted at t=" in r.getMessage() for r in caplog.records)


def test_a_step_failure_leaves_a_valid_file_and_the_log_says_where_it_ends(tmp_path, monkeypatch, caplog):
    import netdae.analyses.tran as tran_module
    from netdae.cli import main

    real = tran_module.integrate

    def few_steps(*args, **kwargs):  # the integrator gives up after 3000 steps: a failed step
        return real(*args, max_steps=3000, **kwargs)

    monkeypatch.setattr(tran_module, "integrate", few_steps)
    path = tmp_path / "rc.cir"
    path.write_text(NETLIST)
    assert main(["run", str(path), "--out", str(tmp_path / "out"), "--format", "raw"]) == 1
    (part,) = read_raw(tmp_path / "out" / "tran.raw")
    assert 1e-3 <= part.t[-1] < 20e-3
    message = next(r.getMessage() for r in caplog.records if "tran.raw holds the" in r.getMessage())
    assert f"holds the {part.points:,} points up to t={part.t[-1]:.9g}" in message
    assert "max_steps=3000" in message
    monkeypatch.setattr(tran_module, "integrate", real)
    full = _full_tran(NETLIST)
    np.testing.assert_array_equal(part["v(in,out)"], full["v(in,out)"][: part.points])


def test_a_full_disk_stops_the_run_and_keeps_a_valid_file(tmp_path):
    out = tmp_path / "res"
    out.mkdir()
    path = tmp_path / "rc.cir"
    path.write_text(NETLIST.replace(".op\n", ""))
    limit = 40_000  # bytes: the header and some hundreds of points (4 doubles each)
    done = _child(["cli", out, path], size_limit=limit)
    assert done.returncode == 2, done.stderr
    assert f"cannot write {out / 'tran.raw'}: the file-size limit was reached" in done.stderr
    assert "bug" not in done.stderr
    (part,) = read_raw(out / "tran.raw")
    assert 0 < part.points and part.t[-1] < 20e-3 and (out / "tran.raw").stat().st_size <= limit
    assert f"it holds the {part.points:,} points up to {part.t[-1]:.9g}" in done.stderr
    full = _full_tran(NETLIST)
    np.testing.assert_array_equal(part["i(v1)"], full["i(v1)"][: part.points])


def test_a_full_disk_still_prints_what_was_computed(tmp_path):
    """The .op before the transient, the transient's message and its measurement on the points it reached are
    printed, the .op's file written; the error about the transient's file comes last (exit status 2)."""
    out = tmp_path / "res"
    out.mkdir()
    path = tmp_path / "rc.cir"
    path.write_text(NETLIST.replace(".meas tran vmax max v(out)", ".meas tran vmax max v(out) to=2m"))
    done = _child(["cli", out, path], size_limit=40_000)
    assert done.returncode == 2, done.stderr
    assert "bug" not in done.stderr and "Traceback" not in done.stderr
    error = done.stderr.strip().splitlines()[-1]
    assert error.startswith(f"netdae: error: cannot write {out / 'tran.raw'}: the file-size limit was reached")
    (part,) = read_raw(out / "tran.raw")
    (op,) = read_raw(out / "op.raw")
    assert op["v(out)"][0] == 0.0
    assert ".op: converged" in done.stdout and re.search(r"^v\(out\)\s+0 V$", done.stdout, re.M)
    assert f".tran: stopped at t=" in done.stdout and "the file-size limit was reached" in done.stdout
    # the sine's first maximum through the RC (tau = 0.1 ms): the measurement made on the points reached
    vmax = float(re.search(r"^vmax\s+=\s+(\S+)", done.stdout, re.M).group(1))
    full = _full_tran(NETLIST)
    assert part.t[-1] > 2e-3
    assert vmax == pytest.approx(full["v(out)"][full.t <= 2e-3].max(), rel=1e-3)


def test_a_file_killed_mid_run_is_refused_unless_read_partially(tmp_path):
    circuit = netdae.load(NETLIST)
    stream = RawStream(tmp_path / "tran.raw", title=circuit.title, date="today")
    snapshots = []

    def output(position, start, block):
        stream.write(start, block)
        if len(snapshots) < 3:
            snapshots.append((stream.points, (tmp_path / "tran.raw").read_bytes()))

    tran = run(circuit, output=output)[1]
    stream.close()
    points, killed = snapshots[-1]  # the file as a process killed then leaves it: the count not yet patched
    assert 0 < points < tran.points
    with pytest.raises(NetdaeError, match=rf"announces 0 points, the file holds {points} complete points"):
        parse_raw(killed, "killed")
    (prefix,) = parse_raw(killed, "killed", partial=True)
    np.testing.assert_array_equal(prefix["v(out)"], tran["v(out)"][:points])
    # a point cut in the middle is left out
    (cut,) = parse_raw(killed[:-5], "killed", partial=True)
    assert cut.points == points - 1


def test_a_bounded_run_keeps_only_its_last_points_in_memory_and_all_in_the_file(tmp_path, monkeypatch):
    from netdae.cli import main
    from netdae.dae.compiled import driver

    netlist = NETLIST.replace(".meas tran vmax max v(out)\n", "")  # nothing needs the dense output
    monkeypatch.setattr(driver, "WINDOW_BYTES", 64 * 8 * 5)  # 64 points of time and 3 signals
    full = _full_tran(netlist)
    circuit = netdae.load(netlist)
    stream = RawStream(tmp_path / "bounded.raw", title=circuit.title, date="today")
    tran = run(circuit, output=lambda position, start, block: stream.write(start, block), bounded=True)[1]
    stream.close()
    assert tran.ok and tran.points <= 64 < full.points == tran.stats.points == stream.points
    assert any(f"holds the last {tran.points:,} of the {full.points:,} points" in n for n in tran.notes)
    np.testing.assert_array_equal(tran["v(in,out)"], full["v(in,out)"][-tran.points:])
    assert (tmp_path / "bounded.raw").read_bytes() == format_raw(full, title=circuit.title, date="today")
    # netdae run bounds its memory (no .meas, no --plot, no --json) and writes every point
    path = tmp_path / "rc.cir"
    path.write_text(netlist)
    assert main(["run", str(path), "--out", str(tmp_path / "out"), "--format", "raw"]) == 0
    (back,) = read_raw(tmp_path / "out" / "tran.raw")
    np.testing.assert_array_equal(back.t, full.t)
    np.testing.assert_array_equal(back["i(v1)"], full["i(v1)"])


def test_transients_that_are_not_their_integrators_points_are_written_whole(tmp_path):
    interp = NETLIST.replace(".op\n", ".options interp\n")
    quantities = NETLIST.replace(".save v(out)", ".save i(r1) v(out)")
    for netlist in (interp, quantities):
        circuit, results, streams, blocks = _streamed(netlist, tmp_path)
        assert streams == {} and blocks == []


def test_a_save_set_too_large_for_the_memory_is_refused_before_the_run(tmp_path, monkeypatch):
    import netdae.analyses.tran as tran_module
    from netdae.cli import main

    ladder = ["RC ladder", "V1 n0 0 PULSE(0 1 0 1n 1n 1u 2u)"]
    ladder += [f"R{k} n{k - 1} n{k} 1k\nC{k} n{k} 0 1p" for k in range(1, 201)]
    path = tmp_path / "ladder.cir"
    path.write_text("\n".join(ladder + [".tran 1n 1m", ".end"]) + "\n")
    points, size = tran_module.output_size(202, 1e-3, 1e-9)
    assert points == 1_000_001 and size == points * (8 * 203 + 1)
    monkeypatch.setattr(tran_module, "physical_memory", lambda: size - 1)
    with pytest.raises(NetdaeError, match=r"ladder.cir:403:1: \.tran: keeping 202 of 202 unknowns at 1,000,001 "
                                          r"points or more .* the run cannot finish \(hint: save only"):
        netdae.simulate(str(path))
    assert main(["run", str(path)]) == 2
    # saving one node needs 200 times less: a warning only when it fills a quarter of the memory
    monkeypatch.setattr(tran_module, "physical_memory", lambda: 4 * tran_module.output_size(2, 1e-3, 1e-9)[1] - 1)
    circuit = netdae.load(str(path))
    card = circuit.analyses[0]
    assert "warning: keeping 2 of 202" in tran_module._check_size(2, 202, card, 1e-9)


def test_a_tstop_whose_point_count_overflows_is_refused_by_the_size_check(tmp_path):
    # .tran 2ns 1e300: tstop / tmax overflows to infinity, which math.ceil could not make an integer
    # (an OverflowError traceback before); counted in floating point past tran.MOST_POINTS, refused by name
    import netdae.analyses.tran as tran_module
    from netdae.cli import main

    assert tran_module.output_size(3, 1e300, 2e-9) == (math.inf, math.inf)
    path = tmp_path / "far.cir"
    path.write_text("far\nV1 a 0 PULSE(0 1 2n 2n 2n 80n)\nR1 a b 1k\nC1 b 0 1p\n.tran 2ns 1e300\n.end\n")
    with pytest.raises(NetdaeError, match=r"far.cir:5:1: \.tran: keeping 3 of 3 unknowns at tstop/tmax = "
                                          r"1e\+300/2e-09 points or more \(beyond 1\.8e\+308\) needs more than any "
                                          r"memory or disk holds: the run cannot finish"):
        netdae.simulate(str(path))
    assert main(["run", str(path)]) == 2


def test_a_block_cut_short_by_ctrl_c_is_written_again_whole(tmp_path, monkeypatch):
    import netdae.io.files as files
    from netdae.results import Result

    t = np.linspace(0.0, 1e-3, 50)
    whole = Result("tran", axes={"time": t}, signals={"v(out)": np.sin(t * 1e4)})
    real = files._write_all
    calls = []

    def interrupted(handle, data):
        calls.append(len(data))
        if len(calls) == 3:  # the header, the first block, then half of the second: Ctrl-C
            real(handle, data[: len(data) // 2])
            raise KeyboardInterrupt
        real(handle, data)

    monkeypatch.setattr(files, "_write_all", interrupted)
    stream = RawStream(tmp_path / "tran.raw", date="today")
    for start, stop in ((0, 20), (20, 50), (10, 50)):  # the driver hands the second block on again
        try:
            stream.write(start, Result("tran", axes={"time": t[start:stop]},
                                       signals={"v(out)": whole["v(out)"][start:stop]}))
        except KeyboardInterrupt:
            pass
    stream.close()
    assert len(calls) == 5 and stream.points == 50  # and the count patched by close
    assert (tmp_path / "tran.raw").read_bytes() == format_raw(whole, date="today")


def test_a_bounded_run_is_sized_against_the_disk_not_the_memory(tmp_path, monkeypatch):
    import netdae.analyses.tran as tran_module
    from netdae.errors import size_text

    netlist = NETLIST.replace(".meas tran vmax max v(out)\n", "")
    monkeypatch.setattr(tran_module, "physical_memory", lambda: 1)  # no memory at all
    with pytest.raises(NetdaeError, match="of memory, this machine has"):
        netdae.run(netlist)
    points, size = tran_module.output_size(3, 20e-3, 1e-6)  # v(out), i(v1) and v(in) kept
    with pytest.raises(NetdaeError, match=rf"at {points:,} points or more .* of disk space for its file") as err:
        run(netdae.load(netlist), output=lambda *args: None, bounded=True, room=size - 1)
    # sizes in the unit that shows them: this file of 644.6 KiB was 'at least 0.0 GiB ..., 0.0 GiB are free there'
    assert f"needs at least {size_text(size)} of disk space for its file, {size_text(size - 1)} are free there" \
        in str(err.value) and "at least 644.6 KiB" in str(err.value)
    tran = run(netdae.load(netlist), output=lambda *args: None, bounded=True, room=4 * size)[1]
    assert tran.ok and tran.stats.points > points // 2


def test_an_ascii_file_killed_inside_a_number_drops_that_point(tmp_path):
    from netdae.results import Result

    t = np.linspace(0.0, 1e-3, 7)
    stream = RawStream(tmp_path / "tran.raw", binary=False, date="today")
    stream.write(0, Result("tran", axes={"time": t}, signals={"v(out)": np.sqrt(t + 1.0)}))
    killed = (tmp_path / "tran.raw").read_bytes()[:-5]  # mid-way through the last value, count not patched
    stream.close()
    with pytest.raises(NetdaeError, match="announces 0 points, the file holds 6 complete points"):
        parse_raw(killed, "killed")
    (prefix,) = parse_raw(killed, "killed", partial=True)
    np.testing.assert_array_equal(prefix["v(out)"], np.sqrt(t + 1.0)[:6])


def test_output_memory_exhausted_leaves_a_valid_file_of_what_was_computed(tmp_path, monkeypatch, caplog):
    from netdae.cli import main
    from netdae.dae.compiled import driver

    def no_memory(*args):
        raise MemoryError

    monkeypatch.setattr(driver, "_grow", no_memory)
    path = tmp_path / "rc.cir"
    path.write_text(NETLIST.replace(" 20m 1m", " 20m"))  # its .meas keeps every point in memory: they cannot grow
    assert main(["run", str(path), "--out", str(tmp_path / "out"), "--format", "raw"]) == 1
    (part,) = read_raw(tmp_path / "out" / "tran.raw")
    assert 0 < part.points <= driver.BUFFER_START and part.t[-1] < 20e-3
    message = next(r.getMessage() for r in caplog.records if "tran.raw holds the" in r.getMessage())
    assert "not enough memory to keep more output" in message and "--save" in message


def test_a_fourier_card_keeps_the_transient_whole_in_memory(tmp_path, monkeypatch):
    """``.four`` reads the last period of the run from the result in memory: a bounded run (``netdae run
    --out``, no ``.meas``) kept only its last points and failed it ("its period 0.001 s is longer than the
    transient's interval [0.0020455, 0.003] s"). With a ``.four`` card, as with ``.meas``, the run keeps its
    points; the harmonics are those of the unbounded run."""
    from netdae.dae.compiled import driver

    netlist = ("four through a bounded run\nV1 in 0 SIN(0 1 1k)\nR1 in a 1k\nD1 a b dm\nR2 b 0 1k\n"
               ".model dm D(IS=1e-14)\n.tran 1u 3m\n.four 1k v(b)\n.end\n")
    monkeypatch.setattr(driver, "WINDOW_BYTES", 64 * 8 * 3)  # 64 points: far less than a period
    full = run(netdae.load(netlist))[0]
    (whole,) = full.fourier
    assert whole.ok
    tran = run(netdae.load(netlist), output=lambda position, start, block: None, bounded=True)[0]
    (four,) = tran.fourier
    assert four.ok, four.reason
    np.testing.assert_allclose(four.magnitude, whole.magnitude, rtol=1e-12, atol=1e-15)
