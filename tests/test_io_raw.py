"""ngspice raw files: netdae's reader against ngspice's own reader, and back.

The oracle for reading is ngspice itself: it ``load``s the raw file it wrote
and dumps its vectors with ``wrdata``/``print`` at 18 significant digits
(``option numdgt=17``), which parse back to the exact doubles. The oracle for
writing is the same: ngspice loads the file netdae wrote.
"""

from __future__ import annotations

import os
import subprocess
from types import SimpleNamespace

import numpy as np
import pytest

from netdae.errors import NetdaeError
from netdae.io.raw import PLOTNAME_OF, format_raw, parse_raw, read_raw, signal_name, write_raw
from netdae.results import Result

CIRCUIT = """raw reader test: RC into a two-level subcircuit
V1 in 0 DC 1 AC 1 PULSE(0 1 0 1u 1u 1 2)
R1 in out 1k
C1 out 0 1u
Xa out mid stage
.subckt stage a b
R1 a n1 500
R3 n1 b 500
Xb b 0 tank
.ends
.subckt tank p q
L1 p n2 1m
R2 n2 q 10
.ends
.op
.tran 20u 2m
.ac dec 5 10 100k
.dc v1 0 2 0.25
.end
"""

#: Vectors as ngspice names them in a raw file (and after ``load``).
RAW_VECTORS = ["v(in)", "v(out)", "v(mid)", "v(xa.n1)", "v(xa.xb.n2)", "i(l.xa.xb.l1)", "i(v1)"]
#: Plot, its scale as ngspice names it after ``load``.
PLOTS = {"tran": ("tran1", "time"), "ac": ("ac1", "frequency"), "dc": ("dc1", "v(v-sweep)")}


def _ngspice(exe: str, args: list[str], cwd, ascii_raw: bool = False) -> subprocess.CompletedProcess:
    env = dict(os.environ, SPICE_ASCIIRAWFILE="1" if ascii_raw else "0")
    done = subprocess.run([exe, "-b", "-n", *args], cwd=cwd, env=env, capture_output=True, text=True, timeout=60)
    # a netlist made of a .control block only ends with status 1 ("no
    # simulations run"); errors are what matters
    assert "error" not in done.stderr.lower(), done.stderr
    return done


def _wrdata_table(path) -> tuple[list[str], np.ndarray]:
    lines = path.read_text().splitlines()
    return lines[0].split(), np.array([[float(x) for x in line.split()] for line in lines[1:] if line.strip()])


def _ngspice_dump(exe: str, directory, raw_name: str, tag: str) -> dict:
    """Load ``raw_name`` in ngspice and dump every plot's vectors at full precision."""
    control = ["raw dump", ".control", f"load {raw_name}", "set wr_singlescale", "set wr_vecnames", "option numdgt=17"]
    for analysis, (plot, _) in PLOTS.items():
        control += [f"setplot {plot}", f"wrdata {tag}_{analysis}.txt {' '.join(RAW_VECTORS)}"]
    control += ["setplot op1", f"print {' '.join(RAW_VECTORS)}", ".endc", ".end", ""]
    (directory / f"{tag}_dump.cir").write_text("\n".join(control))
    done = _ngspice(exe, [f"{tag}_dump.cir"], directory)
    dump = {}
    for analysis in PLOTS:
        header, table = _wrdata_table(directory / f"{tag}_{analysis}.txt")
        dump[analysis] = (header, table)
    op = {}
    for line in done.stdout.splitlines():
        name, sep, value = line.partition(" = ")
        if sep and name.strip() in RAW_VECTORS:
            op[name.strip()] = float(value)
    dump["op"] = op
    return dump


@pytest.fixture(scope="module")
def ngspice_files(tmp_path_factory, ngspice_exe):
    directory = tmp_path_factory.mktemp("raw")
    (directory / "c.cir").write_text(CIRCUIT)
    _ngspice(ngspice_exe, ["-r", "bin.raw", "c.cir"], directory)
    _ngspice(ngspice_exe, ["-r", "asc.raw", "c.cir"], directory, ascii_raw=True)
    dump = _ngspice_dump(ngspice_exe, directory, "bin.raw", "bin")
    return directory, dump


NETDAE_NAMES = ["v(in)", "v(out)", "v(mid)", "v(xa.n1)", "v(xa.xb.n2)", "i(l.xa.xb.l1)", "i(v1)"]


def _check_against_dump(results, dump, *, rtol: float) -> None:
    by_analysis = {r.analysis: r for r in results}
    for analysis in ("tran", "ac", "dc"):
        result = by_analysis[analysis]
        header, table = dump[analysis]
        axis = table[:, 0]
        np.testing.assert_allclose(result.axis, axis, rtol=rtol, atol=0)
        if analysis == "ac":
            # wrdata writes a complex vector as a (real, imaginary) column pair
            for k, name in enumerate(NETDAE_NAMES):
                expected = table[:, 1 + 2 * k] + 1j * table[:, 2 + 2 * k]
                np.testing.assert_allclose(result.signals[name], expected, rtol=rtol, atol=0)
        else:
            assert header[1:] == RAW_VECTORS
            for k, name in enumerate(NETDAE_NAMES):
                np.testing.assert_allclose(result.signals[name], table[:, 1 + k], rtol=rtol, atol=0)
    op = by_analysis["op"]
    for raw_name, name in zip(RAW_VECTORS, NETDAE_NAMES):
        np.testing.assert_allclose(op.signals[name], [dump["op"][raw_name]], rtol=rtol, atol=0)


@pytest.mark.ngspice
def test_binary_raw_is_read_bit_exactly_as_ngspice_reads_it(ngspice_files):
    directory, dump = ngspice_files
    results = read_raw(directory / "bin.raw")
    assert [r.analysis for r in results] == ["ac", "dc", "op", "tran"]  # ngspice's order of execution
    _check_against_dump(results, dump, rtol=0.0)


@pytest.mark.ngspice
def test_ascii_raw_agrees_with_binary_to_ngspice_s_16_digits(ngspice_files):
    directory, dump = ngspice_files
    results = read_raw(directory / "asc.raw")
    # ngspice writes ascii values with %.15e: 16 significant digits
    _check_against_dump(results, dump, rtol=1e-15)


@pytest.mark.ngspice
def test_names_axes_and_metadata(ngspice_files):
    directory, _ = ngspice_files
    results = {r.analysis: r for r in read_raw(directory / "bin.raw")}
    for analysis, axis in [("tran", "time"), ("ac", "frequency"), ("dc", "v-sweep")]:
        assert list(results[analysis].axes) == [axis]
        assert sorted(results[analysis].names()) == sorted(NETDAE_NAMES)
    assert results["op"].axes == {}
    assert results["op"]["v(out)"].shape == (1,)
    assert np.iscomplexobj(results["ac"]["v(out)"]) and not np.iscomplexobj(results["ac"].axis)
    assert results["tran"].source.plotname == "Transient Analysis"
    assert results["tran"].source.title.startswith("raw reader test")
    assert results["tran"].source.variable_types["i(l.xa.xb.l1)"] == "current"
    # ngspice 39 leaves the imaginary part of the ac scale uninitialised
    assert any("imaginary part" in n for n in results["ac"].notes)


@pytest.mark.ngspice
def test_dc_values_are_those_of_a_divider(ngspice_files):
    # independent of ngspice's printing: at DC C1 is open and L1 a short, so
    # out = in * (1k + 10) / (1k + 1k + 10) and mid = 0
    directory, _ = ngspice_files
    dc = next(r for r in read_raw(directory / "bin.raw") if r.analysis == "dc")
    np.testing.assert_array_equal(dc.axis, np.arange(9) * 0.25)
    np.testing.assert_allclose(dc["v(out)"], dc.axis * 1010 / 2010, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(dc["i(v1)"], -dc.axis / 2010, rtol=1e-12, atol=1e-18)


def _cut(data: bytes, keep: int) -> bytes:
    return data[:keep]


@pytest.mark.ngspice
@pytest.mark.parametrize("name", ["bin.raw", "asc.raw"])
def test_a_run_cut_short_is_read_up_to_its_last_complete_point(ngspice_files, name):
    directory, _ = ngspice_files
    data = (directory / name).read_bytes()
    full = read_raw(directory / name)[-1]  # tran is the last plot
    n = len(full.t)
    # cut one and a half points off the end: n - 2 complete points remain
    row = 7 + 1  # values per point (axis + 7 vectors)
    if name == "bin.raw":
        cut = _cut(data, len(data) - int(1.5 * row * 8))
    else:
        text = data.decode()
        lines = text.rstrip("\n").split("\n")
        cut = ("\n".join(lines[: len(lines) - int(1.5 * row)]) + "\n").encode()
    with pytest.raises(NetdaeError, match=rf"is incomplete: the header announces {n} points, the file holds {n - 2} "):
        parse_raw(cut, "cut")
    tran = parse_raw(cut, "cut", partial=True)[-1]
    assert len(tran.t) == n - 2
    np.testing.assert_array_equal(tran["v(out)"], full["v(out)"][: n - 2])
    assert any(f"announces {n} points" in note for note in tran.notes)


@pytest.mark.ngspice
def test_a_killed_run_with_zero_points_announced_is_read_whole(ngspice_files):
    # ngspice writes 'No. Points: 0' (padded) and corrects it only at the end
    directory, _ = ngspice_files
    data = (directory / "bin.raw").read_bytes()
    full = read_raw(directory / "bin.raw")[-1]
    start = data.rindex(b"No. Points:")
    end = data.index(b"\n", start)
    field = b"No. Points: 0"
    killed = data[:start] + field.ljust(end - start) + data[end:]
    with pytest.raises(NetdaeError, match=rf"announces 0 points, the file holds {len(full.t)} complete points"):
        parse_raw(killed, "killed")
    tran = parse_raw(killed, "killed", partial=True)[-1]
    np.testing.assert_array_equal(tran["i(l.xa.xb.l1)"], full["i(l.xa.xb.l1)"])
    assert any("announces 0 points" in note for note in tran.notes)


def _sample_results() -> list[Result]:
    rng = np.random.default_rng(7)
    t = np.cumsum(rng.uniform(1e-9, 1e-6, 50))
    f = np.logspace(1, 6, 21)
    v1 = np.tile(np.linspace(0.0, 1.0, 3), 2)
    v2 = np.repeat([0.0, 0.5], 3)
    return [
        Result("op", signals={"v(a)": np.array([1 / 3]), "i(v1)": np.array([-np.pi * 1e-3])}),
        Result("tran", axes={"time": t}, signals={"v(x1.mid)": np.sin(t * 1e6), "i(l.x1.l1)": rng.normal(size=50)}),
        Result("ac", axes={"frequency": f}, signals={"v(out)": 1 / (1 + 1j * f / 1e3), "i(v1)": rng.normal(size=21) + 0j}),
        Result("dc", axes={"v1": v1, "v2": v2}, signals={"v(out)": v1 * 0.5 + v2 / 3}),
    ]


@pytest.mark.parametrize("binary", [True, False])
def test_round_trip_is_exact(binary):
    written = _sample_results()
    read = parse_raw(format_raw(written, binary=binary, title="round trip", date="now"))
    assert [r.analysis for r in read] == [r.analysis for r in written]
    for a, b in zip(written, read):
        assert list(a.axes) == list(b.axes) and a.names() == b.names()
        for key in a.axes:
            np.testing.assert_array_equal(a.axes[key], b.axes[key])
        for key in a.signals:
            assert np.iscomplexobj(a.signals[key]) == np.iscomplexobj(b.signals[key])
            np.testing.assert_array_equal(a.signals[key], b.signals[key])
        assert b.source.title == "round trip"


def test_write_raw_and_read_raw_use_files(tmp_path):
    results = _sample_results()
    write_raw(tmp_path / "x.raw", results)
    again = read_raw(tmp_path / "x.raw")
    np.testing.assert_array_equal(again[1].t, results[1].t)


@pytest.mark.ngspice
@pytest.mark.parametrize("binary", [True, False])
def test_ngspice_loads_what_netdae_writes(tmp_path, ngspice_exe, binary):
    results = _sample_results()
    write_raw(tmp_path / "n.raw", results, binary=binary, title="written by netdae")
    control = [
        "load netdae raw",
        ".control",
        "load n.raw",
        "option numdgt=17",
        "set wr_singlescale",
        "set wr_vecnames",
        "setplot op1",
        "print v(a) i(v1)",
        "setplot tran1",
        "wrdata tran.txt v(x1.mid) i(l.x1.l1)",
        "setplot ac1",
        "wrdata ac.txt v(out)",
        "setplot dc1",
        "wrdata dc.txt v2 v(out)",
        ".endc",
        ".end",
        "",
    ]
    (tmp_path / "load.cir").write_text("\n".join(control))
    done = _ngspice(ngspice_exe, ["load.cir"], tmp_path)
    op, tran, ac, dc = results
    printed = dict(line.split(" = ") for line in done.stdout.splitlines() if " = " in line)
    assert float(printed["v(a)"]) == op["v(a)"][0]
    assert float(printed["i(v1)"]) == op["i(v1)"][0]
    header, table = _wrdata_table(tmp_path / "tran.txt")
    assert header == ["time", "v(x1.mid)", "i(l.x1.l1)"]
    np.testing.assert_array_equal(table[:, 0], tran.t)
    np.testing.assert_array_equal(table[:, 1], tran["v(x1.mid)"])
    np.testing.assert_array_equal(table[:, 2], tran["i(l.x1.l1)"])
    _, table = _wrdata_table(tmp_path / "ac.txt")
    np.testing.assert_array_equal(table[:, 0], ac.axis)
    np.testing.assert_array_equal(table[:, 1] + 1j * table[:, 2], ac["v(out)"])
    header, table = _wrdata_table(tmp_path / "dc.txt")
    assert header[0] == "v1"  # the default scale of the plot is netdae's first axis
    np.testing.assert_array_equal(table[:, 0], dc.axes["v1"])
    np.testing.assert_array_equal(table[:, 1], dc.axes["v2"])
    np.testing.assert_array_equal(table[:, 2], dc["v(out)"])


def test_unpadded_plot_with_a_shorter_vector():
    # ngspice's 'write' with 'set nopadding' stores a shorter vector without
    # filler; its length is given by dims=
    header = (
        "Title: t\nDate: d\nPlotname: Transient Analysis\nFlags: real unpadded\n"
        "No. Variables: 3\nNo. Points: 3\nVariables:\n\t0\ttime\ttime\n\t1\tv(a)\tvoltage\n"
        "\t2\tv(b)\tvoltage dims=2\nBinary:\n"
    )
    rows = [0.0, 10.0, 20.0, 1.0, 11.0, 21.0, 2.0, 12.0]
    result = parse_raw(header.encode() + np.array(rows, "<f8").tobytes())[0]
    np.testing.assert_array_equal(result.t, [0.0, 1.0, 2.0])
    np.testing.assert_array_equal(result["v(a)"], [10.0, 11.0, 12.0])
    np.testing.assert_array_equal(result["v(b)"], [20.0, 21.0])


def test_command_and_option_lines_are_kept_not_executed():
    text = (
        "Title: t\nDate: d\nPlotname: Operating Point\nFlags: real\nNo. Variables: 1\nNo. Points: 1\n"
        "Command: version 39\nOption: reltol = 1e-06\nVariables:\n\t0\tout\tvoltage\nValues:\n 0\t2.5\n"
    )
    result = parse_raw(text.encode())[0]
    assert result.source.commands == ["version 39"]
    assert result.source.options == ["reltol = 1e-06"]
    assert result.signals == {"v(out)": np.array([2.5])}  # a bare node name of type voltage


@pytest.mark.parametrize(
    "text, message",
    [
        (b"", "no plot"),
        (b"Title: t\nPlotname: Distortion - 2nd harmonic\nFlags: real\nNo. Variables: 1\nNo. Points: 0\n"
         b"Variables:\n\t0\tfrequency\tfrequency\nBinary:\n", "not an analysis netdae reads"),
        (b"Title: t\nPlotname: Integrated Noise\nFlags: real\nNo. Variables: 1\nNo. Points: 1\n"
         b"Variables:\n\t0\tv(onoise_total)\tvoltage\nValues:\n 0\t1e-9\n", "does not follow a noise analysis"),
        (b"Title: t\nPlotname: AC Analysis\nFlags: complex\nNo. Variables: 2\nNo. Points: 1\n"
         b"Variables:\n\t0\tfrequency\tfrequency\n", "variable lines"),
        (b"Title: t\nPlotname: Operating Point\nFlags: real\nNo. Variables: x\n", "expected a count"),
        (b"Title: t\nPlotname: Operating Point\nFlags: real\nNo. Variables: 1\nNo. Points: 1\n"
         b"Variables:\n\t0\tout\tvoltage\nValues:\n 0\tnot-a-number\n", "bad number"),
    ],
)
def test_malformed_files_raise_netdae_errors(text, message):
    with pytest.raises(NetdaeError, match=message):
        parse_raw(text, "bad.raw")


def test_missing_file_raises_netdae_error(tmp_path):
    with pytest.raises(NetdaeError, match="cannot read raw file"):
        read_raw(tmp_path / "absent.raw")


def test_signal_names():
    assert signal_name("V(OUT)", "voltage") == "v(out)"
    assert signal_name("xa.x1.mid", "voltage") == "v(xa.x1.mid)"
    assert signal_name("l.xa.x1.l1#branch", "current") == "i(l.xa.x1.l1)"
    assert signal_name("@r1[i]", "current") == "@r1[i]"


@pytest.mark.parametrize("binary", [True, False])
@pytest.mark.parametrize("keep", [0.0, 0.4, 0.999])
def test_a_truncated_file_is_refused_with_the_counts(tmp_path, binary, keep):
    # a tran plot of 50 points cut inside its data, as a failed write leaves it
    tran = _sample_results()[1]
    data = format_raw([tran], binary=binary, date="now")
    body = data.index(b"Binary:\n" if binary else b"Values:\n") + 8
    cut = data[: body + int(keep * (len(data) - body))]
    if not binary:
        cut = cut[: cut.rindex(b"\n") + 1]  # whole lines: the count of points is unambiguous
    # complete points: rows of 3 doubles (binary), groups of index + 3 numbers (ascii)
    found = (len(cut) - body) // 24 if binary else len(cut[body:].split()) // 4
    (tmp_path / "cut.raw").write_bytes(cut)
    with pytest.raises(NetdaeError, match=rf"cut.raw:\d+: plot 'Transient Analysis' is incomplete: the header "
                                          rf"announces 50 points, the file holds {found} complete point"):
        read_raw(tmp_path / "cut.raw")
    partial = read_raw(tmp_path / "cut.raw", partial=True)[0]
    np.testing.assert_array_equal(partial.t, tran.t[:found])


def test_a_truncated_plot_before_another_is_refused_even_when_partial():
    op, tran = _sample_results()[:2]
    first = format_raw([tran], date="now")
    cut = first[: len(first) - 30] + format_raw([op], date="now")
    with pytest.raises(NetdaeError, match="incomplete and another plot follows"):
        parse_raw(cut, "two.raw", partial=True)


class _NumpyWithFromstring:
    """numpy as PySpice 1.5 expects it: ``fromstring`` of binary data (removed in NumPy 2)."""

    def __getattr__(self, name):
        return getattr(np, name)

    @staticmethod
    def fromstring(data, count=-1, dtype=float):
        return np.frombuffer(data, dtype=dtype, count=count).copy()


def _pyspice_raw(monkeypatch, data: bytes, points: int):
    pytest.importorskip("PySpice")
    import PySpice.Spice.RawFile as abc
    from PySpice.Spice.NgSpice.RawFile import RawFile

    monkeypatch.setattr(abc, "np", _NumpyWithFromstring())
    return RawFile(data, points)


@pytest.mark.parametrize("analysis", ["op", "tran", "ac", "dc"])
def test_pyspice_s_raw_file_parser_reads_the_pyspice_flavour(monkeypatch, analysis):
    result = {r.analysis: r for r in _sample_results()}[analysis]
    if analysis == "dc":  # one sweep: PySpice knows no nested sweeps
        result = Result("dc", axes={"v1": result.axes["v1"][:3]}, signals={"v(out)": result["v(out)"][:3]})
    points = len(next(iter(result.signals.values())))
    data = format_raw(result, title="Warning: written by netdae", date="now", flavour="pyspice", temp=50)
    raw = _pyspice_raw(monkeypatch, data, points)
    assert raw.plot_name == PLOTNAME_OF[analysis]
    assert raw.title == raw.circuit_name == "warning: written by netdae"
    assert float(raw.temperature) == 50 and float(raw.nominal_temperature) == 27
    expected = dict(result.axes) | dict(result.signals)
    if analysis == "dc":
        expected["v(v-sweep)"] = expected.pop("v1")
    assert sorted(raw.variables) == sorted(expected)
    for name, values in expected.items():
        np.testing.assert_array_equal(raw.variables[name].data, values)
    # and netdae reads its own PySpice flavour back, the temperatures included
    (again,) = parse_raw(data, "pyspice.raw")
    assert again.source.temp == 50 and again.source.circuit == "warning: written by netdae"
    for name, values in result.signals.items():
        np.testing.assert_array_equal(again.signals[name], values)


def test_pyspice_reads_a_transient_as_pyspice_waveforms(monkeypatch):
    # the whole path PySpice takes after its server run: RawFile -> to_analysis()
    pytest.importorskip("PySpice")
    from PySpice.Spice.Netlist import Circuit

    circuit = Circuit("rc")
    circuit.V(1, "in", circuit.gnd, 1)
    circuit.R(1, "in", "out", 1e3)
    circuit.C(1, "out", circuit.gnd, 1e-6)
    t = np.linspace(0.0, 5e-3, 11)
    result = Result("tran", axes={"time": t},
                    signals={"v(in)": np.ones_like(t), "v(out)": 1 - np.exp(-t / 1e-3), "i(v1)": -np.exp(-t / 1e-3) * 1e-3})
    raw = _pyspice_raw(monkeypatch, format_raw(result, title="rc", flavour="pyspice"), len(t))
    raw.simulation = SimpleNamespace(circuit=circuit)  # all fix_case() asks of a simulation
    analysis = raw.to_analysis()
    np.testing.assert_array_equal(np.asarray(analysis.time), t)
    np.testing.assert_array_equal(np.asarray(analysis.nodes["out"]), result["v(out)"])
    np.testing.assert_array_equal(np.asarray(analysis.branches["V1"]), result["i(v1)"])


@pytest.mark.parametrize("kwargs, message", [
    ({"binary": False}, "binary raw files only"),
    ({"results": "two"}, "one plot per raw file"),
    ({"results": "res-sweep"}, "vector type 'res-sweep' is not one PySpice reads"),
])
def test_what_pyspice_cannot_read_is_refused(kwargs, message):
    results = _sample_results()[1]
    if kwargs.pop("results", None) == "two":
        results = _sample_results()[:2]
    elif "binary" not in kwargs:
        results = Result("dc", axes={"res-sweep": np.arange(3.0)}, signals={"v(out)": np.arange(3.0)})
    with pytest.raises(NetdaeError, match=message):
        format_raw(results, flavour="pyspice", **kwargs)


@pytest.mark.parametrize("binary", [False, True])
def test_an_ac_scale_with_an_infinite_imaginary_part_keeps_its_frequencies(binary):
    # ngspice 39 leaves the imaginary part of the ac scale uninitialised; where that memory held an
    # infinity, re + 1j * im made the real part NaN too (1j * inf is nan + inf j): every frequency NaN
    freqs, imag = [10.0, 100.0], [float("inf"), float("-inf")]
    head = (b"Title: t\nDate: x\nPlotname: AC Analysis\nFlags: complex\nNo. Variables: 2\nNo. Points: 2\n"
            b"Variables:\n\t0\tfrequency\tfrequency\n\t1\tv(out)\tvoltage\n")
    if binary:
        body = b"Binary:\n" + np.array([[f, i, 0.5, -0.25] for f, i in zip(freqs, imag)], dtype="<f8").tobytes()
    else:
        body = b"Values:\n" + b"".join(f" {k}\t{f!r},{i!r}\n\t0.5,-0.25\n".encode() for k, (f, i) in
                                       enumerate(zip(freqs, imag)))
    (ac,) = parse_raw(head + body)
    np.testing.assert_array_equal(ac.axis, freqs)
    np.testing.assert_array_equal(ac["v(out)"], [0.5 - 0.25j, 0.5 - 0.25j])
    assert any("imaginary part" in n for n in ac.notes)


def test_a_plot_without_variables_is_an_empty_result():
    # ngspice's .pz of a circuit without finite poles or zeros (a resistive divider) writes a plot of no
    # vectors, 'No. Variables: 0', and nothing after 'Binary:'; it was refused as unreadable
    header = ("Title: pz\nDate: d\nPlotname: Pole-Zero Analysis\nFlags: real\nNo. Variables: 0\nNo. Points: 1\n"
              "Variables:\nBinary:\n")
    (result,) = parse_raw(header.encode())
    assert result.analysis == "pz" and not result.signals
