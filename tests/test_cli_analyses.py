"""The command line for analyses: run, index, demo; errors in circuit terms, never a traceback."""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest

from netdae.cli import main

from conftest import NETLISTS


def cli(capsys, *argv):
    status = main([*map(str, argv)])
    out, err = capsys.readouterr()
    return status, out, err


def write(tmp_path, name, text):
    path = tmp_path / name
    path.write_text(text)
    return path


def test_run_op_table_and_json(tmp_path, capsys):
    path = write(tmp_path, "div.cir", "divider\nV1 a 0 9\nR1 a b 2k\nR2 b 0 1k\n.op\n.end\n")
    status, out, _ = cli(capsys, "run", path)
    assert status == 0
    row = next(line for line in out.splitlines() if line.startswith("v(b)"))
    assert float(row.split()[1]) == pytest.approx(3.0, rel=1e-12)
    status, out, _ = cli(capsys, "run", path, "--json")
    doc = json.loads(out)
    values = doc["op"]["values"]["signals"]
    assert values["v(b)"] == [pytest.approx(3.0, rel=1e-12)]
    assert values["i(v1)"] == [pytest.approx(-3e-3, rel=1e-12)]


def test_run_writes_files_for_every_analysis(tmp_path, capsys):
    path = write(tmp_path, "rc.cir", """rc
V1 in 0 DC 1 AC 1 PULSE(0 1 0 1u 1u 1m 2m)
R1 in out 1k
C1 out 0 1u
.op
.dc V1 0 2 1
.ac dec 2 10 1k
.tran 10u 1m
.end
""")
    out_dir = tmp_path / "res"
    status, out, _ = cli(capsys, "run", path, "--out", out_dir, "--plot")
    assert status == 0
    for name in ("op.csv", "dc.csv", "ac.csv", "tran.csv", "dc.png", "ac.png", "tran.png"):
        assert (out_dir / name).stat().st_size > 0, name
    with open(out_dir / "ac.csv") as fh:
        rows = list(csv.DictReader(fh))
    assert list(rows[0])[:3] == ["frequency", "re(v(in))", "im(v(in))"]
    f = np.array([float(r["frequency"]) for r in rows])
    h = np.array([float(r["re(v(out))"]) + 1j * float(r["im(v(out))"]) for r in rows])
    np.testing.assert_allclose(h, 1 / (1 + 2j * np.pi * f * 1e-3), rtol=1e-12)
    with open(out_dir / "dc.csv") as fh:
        rows = list(csv.DictReader(fh))
    assert list(rows[0])[0] == "v1" and [float(r["v(out)"]) for r in rows] == [0.0, 1.0, 2.0]
    with open(out_dir / "tran.csv") as fh:
        header = next(csv.reader(fh))
    assert header[0] == "time" and "v(out)" in header


def test_run_raw_format_reads_back(tmp_path, capsys):
    from netdae.io.raw import read_raw

    out_dir = tmp_path / "raw"
    status, _, _ = cli(capsys, "run", NETLISTS / "differentiator.cir", "--out", out_dir, "--format", "raw")
    assert status == 0
    (res,) = read_raw(out_dir / "tran.raw")
    t = res.t
    np.testing.assert_allclose(res["v(out)"], -1e-4 * 2 * np.pi * 1e3 * np.cos(2 * np.pi * 1e3 * t), atol=2e-3)


def test_index_text_and_json(capsys):
    status, out, _ = cli(capsys, "index", NETLISTS / "differentiator.cir")
    assert status == 0
    assert "index: 2" in out and "v(out)" in out and "index2" in out
    assert "INCONSISTENT" in out
    status, out, _ = cli(capsys, "index", NETLISTS / "cv_loop_capacitors.cir", "--json")
    doc = json.loads(out)
    for key in ("regular", "index", "method", "n_unknowns", "n_dynamic", "rank_E", "infinite_blocks",
                "tolerance", "unknowns", "topology", "consistent_initial_values", "messages"):
        assert key in doc, key
    assert doc["index"] == 2 and doc["method"] == "kronecker" and doc["regular"] is True
    assert doc["unknowns"]["i(v1)"] == "index2"
    assert doc["topology"]["cv_loops"] == [["v1", "c1", "c2"]]
    assert any("v1" in m and "c1" in m for m in doc["messages"])


def test_index_at_t0_and_topological_method(capsys):
    status, out, _ = cli(capsys, "index", NETLISTS / "rc_lowpass.cir", "--at", "t0", "--method", "topological",
                         "--json")
    doc = json.loads(out)
    assert status == 0 and doc["method"] == "topological" and doc["index"] == 1 and doc["at"] == "t0"


@pytest.mark.parametrize("text, words", [
    ("vloop\nV1 a 0 1\nV2 a 0 2\nR1 a 0 1k\n.op\n.end\n", ("v1", "v2", "loop")),
    ("floating\nV1 a 0 1\nR1 a b 1k\nC1 b c 1u\nG1 0 c a 0 1m\n.op\n.end\n", ("no DC path", "g1")),
    ("charged\nV1 a 0 1\nR1 a b 1k\nC1 b c 1u\nI1 0 c 1m\n.op\n.end\n", ("no DC operating point", "i1")),
    ("icut\nI1 0 a 1m\nI2 a b 1m\nR1 b 0 1k\n.op\n.end\n", ("i1", "i2", "current source")),
])
def test_singular_circuits_are_explained_in_circuit_terms(tmp_path, capsys, text, words):
    path = write(tmp_path, "bad.cir", text)
    status, out, err = cli(capsys, "run", path)
    assert status == 2 and out == ""
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err
    for w in words:
        assert w in err, (w, err)


def test_netlist_error_is_one_line_with_location(tmp_path, capsys):
    path = write(tmp_path, "bad.cir", "bad\nR1 a 0\n.op\n.end\n")
    status, _, err = cli(capsys, "run", path)
    assert status == 2
    assert err.startswith(f"netdae: error: {path}:2:") and len(err.strip().splitlines()) == 1


def test_no_analysis_is_an_error(tmp_path, capsys):
    path = write(tmp_path, "none.cir", "nothing\nR1 a 0 1k\n.end\n")
    status, _, err = cli(capsys, "run", path)
    assert status == 2 and "no analysis" in err


@pytest.mark.ngspice
def test_demo_tells_the_whole_story(tmp_path, capsys):
    status, out, _ = cli(capsys, "demo", NETLISTS / "differentiator.cir", "--out", tmp_path)
    assert status == 0
    for marker in ("index: 2", "initial values made consistent", "netdae vs ngspice", "PASS"):
        assert marker in out, marker
    for name in ("tran.csv", "tran.png", "compare.png"):
        assert (tmp_path / name).stat().st_size > 0


def test_demo_finds_its_netlist_from_any_directory(tmp_path, monkeypatch):
    """netdae demo without a file, run outside the repository, looked for netlists/differentiator.cir in the working
    directory ('not found'); it takes netdae's own copy."""
    from netdae.cli.demo import DEFAULT_NETLIST, _default_netlist

    monkeypatch.chdir(tmp_path)
    assert _default_netlist(DEFAULT_NETLIST) == str(NETLISTS / "differentiator.cir")
    (tmp_path / "netlists").mkdir()
    (tmp_path / "netlists" / "differentiator.cir").write_text("mine\n")
    assert _default_netlist(DEFAULT_NETLIST) == DEFAULT_NETLIST  # a file of that name here is the user's
    assert _default_netlist("other.cir") == "other.cir"


def test_export_matrices_npz_and_matrix_market(tmp_path, capsys):
    import scipy.io

    from netdae.io.matrices import load_npz_matrices
    from netdae.mna import assemble

    path = NETLISTS / "differentiator.cir"
    status, out, err = cli(capsys, "run", path, "--export", tmp_path / "m.npz")
    assert status == 0 and f"wrote {tmp_path / 'm.npz'}" in err
    got = load_npz_matrices(tmp_path / "m.npz")
    system = assemble(__import__("netdae").load(path))
    assert got["names"] == list(system.names) and got["sources"] == ["v1"] and not got["linearized"]
    np.testing.assert_array_equal(got["E"].toarray(), system.E.toarray())
    np.testing.assert_array_equal(got["H"].toarray(), system.H.toarray())
    np.testing.assert_array_equal(got["B"].toarray(), system.B.toarray())
    status, _, err = cli(capsys, "run", path, "--export", tmp_path / "m.mtx")
    assert status == 0
    assert [line.split()[1] for line in err.splitlines() if line.startswith("wrote")] == [
        str(tmp_path / f"m.{part}") for part in ("E.mtx", "H.mtx", "B.mtx", "names.txt")]
    H = scipy.io.mmread(str(tmp_path / "m.H.mtx")).toarray()
    np.testing.assert_array_equal(H, system.H.toarray())
    assert (tmp_path / "m.names.txt").read_text().split()[:len(system.names)] == list(system.names)
