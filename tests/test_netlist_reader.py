"""Files: .include and .lib from nested directories, cycles, missing files, text with a path."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from netdae.errors import NetlistError
from netdae.netlist import load, parse

DATA = Path(__file__).resolve().parent / "data" / "netlist"


def test_includes_resolve_relative_to_each_file():
    c = load(DATA / "main.cir")
    assert c.title == "Include and library fixture: an RC ladder split over several files"
    assert c.nodes == ["in", "mid", "out"]
    # sub/part.inc: subcircuit with continuation lines and inline comments inside
    assert c.element("r.x1.r1").value == 1e3 and c.element("r.x2.r1").value == 500.0  # rs={rlib}, fast corner
    assert c.element("c.x1.c1").value == pytest.approx(100e-9)
    # sub/deeper/leaf.inc and ../../common/models.inc, read inside the subcircuit
    assert c.element("r.x2.rleak").value == 10e6
    assert c.element("d.x1.dclamp").model == "x1:dclamp"
    assert c.models["x2:dclamp"].params == {"is": 1e-14, "n": 1.05, "rs": 0.5}
    # libs/corner.lib section fast, which includes libs/fast_params.inc
    assert c.params == {"rlib": 500.0, "clib": pytest.approx(47e-9, rel=1e-15)}


def test_locations_name_the_included_file():
    c = load(DATA / "main.cir")
    loc = c.element("d.x2.dclamp").location
    assert Path(loc.file) == DATA / "sub" / "deeper" / "leaf.inc" and (loc.line, loc.column) == (3, 1)
    r1 = c.element("r.x1.r1").location
    assert Path(r1.file).name == "part.inc" and r1.line == 5
    assert Path(c.models["x1:dclamp"].location.file).name == "models.inc"


def test_include_paths_are_relative_to_the_including_file_not_the_cwd(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert load(DATA / "main.cir").element("r.x2.rleak").value == 10e6
    rel = os.path.relpath(DATA / "main.cir", tmp_path)
    assert load(rel).element("r.x2.rleak").value == 10e6


def test_text_with_a_path_resolves_includes_from_that_directory():
    text = "t\n.include sub/part.inc\nX1 a 0 stage\nV1 a 0 1\n.end\n"
    c = load(text, path=str(DATA / "virtual.cir"))
    assert c.path.endswith("virtual.cir") and c.element("r.x1.r1").value == 1e3
    with pytest.raises(NetlistError, match="include file 'sub/part.inc' not found") as exc:
        load(text)
    assert (exc.value.location.file, exc.value.location.line, exc.value.location.column) == ("<string>", 2, 10)


def test_lib_sections_select_one_corner(tmp_path):
    (tmp_path / "top.cir").write_text(f"t\n.lib '{DATA / 'libs' / 'corner.lib'}' slow\nR1 a 0 {{rlib}}\n.end\n")
    c = load(tmp_path / "top.cir")
    assert c.params == {"rlib": 2e3, "clib": pytest.approx(220e-9, rel=1e-15)}


def test_lib_section_may_pull_another_section_of_its_file(tmp_path):
    (tmp_path / "top.cir").write_text(f"t\n.lib {DATA / 'libs' / 'self.lib'} outer\nR1 a 0 {{po + pi_}}\n.end\n")
    assert load(tmp_path / "top.cir").element("r1").value == 3.0


def test_a_section_defined_twice_reads_the_first_and_says_so(tmp_path):
    """ngspice 39 reads the first of two sections of one name and says nothing; netdae read it silently too."""
    (tmp_path / "corners.lib").write_text(".lib typ\nR2 a 0 1k\n.endl\n* again\n.lib typ\nR2 a 0 2k\n.endl\n")
    (tmp_path / "top.cir").write_text("t\nV1 a 0 1\n.lib corners.lib typ\nR1 a 0 1k\n.op\n.end\n")
    c = load(tmp_path / "top.cir")
    assert c.element("r2").value == 1e3
    (w,) = [d for d in c.diagnostics if d.severity == "warning"]
    assert Path(w.location.file).name == "corners.lib" and (w.location.line, w.location.column) == (5, 1)
    assert w.message == (f".lib typ: the library section is defined again in '{tmp_path / 'corners.lib'}' (first at "
                         "line 1): the first is read and this one ignored, as ngspice 39 does")


def test_words_after_the_file_name_are_ignored_with_a_warning(tmp_path):
    """'.include my file.inc' read 'my' (ngspice 39 too) and dropped 'file.inc' without a word."""
    (tmp_path / "r2.inc").write_text("R2 a 0 1k\n")
    (tmp_path / "c.lib").write_text(".lib typ\nR3 a 0 1k\n.endl\n")
    (tmp_path / "top.cir").write_text("t\nV1 a 0 1\n.include r2.inc extra\n.lib c.lib typ fast more\n.op\n.end\n")
    c = load(tmp_path / "top.cir")
    assert {e.name for e in c.elements} == {"v1", "r2", "r3"}
    warnings = [(d.location.line, d.location.column, d.message) for d in c.diagnostics if d.severity == "warning"]
    assert warnings == [
        (3, 17, ".include: 'extra' and what follows it ignored, as ngspice 39 ignores them (a file name with "
                "blanks needs quotes)"),
        (4, 16, ".lib: 'fast' and what follows it ignored, as ngspice 39 ignores them (a file name with blanks "
                "needs quotes)")]


def test_section_definitions_in_the_main_file_are_skipped():
    c = load("t\n.lib unused\nR9 a 0 9\n.endl\nR1 a 0 1\n.end\n")
    assert [e.name for e in c.elements] == ["r1"]
    (w,) = [d for d in c.diagnostics if d.severity == "warning"]
    assert (w.location.line, w.location.column) == (2, 6)
    assert w.message.startswith(".lib unused: no '.lib FILE unused' reads this library section, so its cards "
                                "(up to .endl) are not part of the circuit")


def test_a_section_of_the_main_file_read_through_a_reference_is_not_warned_about(tmp_path):
    (tmp_path / "top.cir").write_text("t\n.lib top.cir s\nR1 a 0 1\n.lib s\nR9 a 0 9\n.endl\n.end\n")
    c = load(tmp_path / "top.cir")
    assert [e.name for e in c.elements] == ["r9", "r1"]
    assert not [d for d in c.diagnostics if d.severity == "warning"]


def test_missing_section_lists_the_sections():
    with pytest.raises(NetlistError, match=r"section 'typ' not found in .*corner.lib' \(sections: fast, slow\)"):
        load(f"t\n.lib {DATA / 'libs' / 'corner.lib'} typ\n.end\n")


def test_include_cycle_names_the_chain():
    with pytest.raises(NetlistError) as exc:
        load(DATA / "cycle" / "a.cir")
    err = exc.value
    chain = err.message.split("include cycle: ")[1].split(" -> ")
    assert [Path(p).name for p in chain] == ["b.inc", "c.inc", "b.inc"]
    assert Path(err.location.file).name == "c.inc" and (err.location.line, err.location.column) == (1, 10)


def test_missing_main_file_and_directory():
    with pytest.raises(NetlistError, match="netlist file 'no/such.cir' not found"):
        load("no/such.cir")
    with pytest.raises(NetlistError, match="is a directory"):
        load(f"t\n.include {DATA}\n.end\n")


def test_quoted_names_keep_their_case(tmp_path):
    sub = tmp_path / "Mixed Case"
    sub.mkdir()
    (sub / "Part.INC").write_text("R1 a 0 5\n")
    c = load(f't\n.include "{sub / "Part.INC"}"\n.end\n')
    assert c.element("r1").value == 5.0


def test_parse_keeps_definitions_unevaluated():
    net = parse(DATA / "main.cir")
    stage = net.top.subckts["stage"]
    assert stage.ports == ("a", "b") and [d.name for d in stage.defaults] == ["rs", "cs"]
    assert [type(i).__name__ for i in net.top.items] == ["ElementCard", "InstanceCard", "InstanceCard"]
    assert net.files[0].endswith("main.cir") and len(net.files) == 6


@pytest.mark.parametrize("end", [".end=", ".end;", ".END\t", ".end = 1"])
def test_end_followed_by_punctuation_ends_the_netlist(end):
    """ngspice reads '.end=' as '.end' (found by the mutating fuzzer, where it crashed the parser)."""
    circuit = load(f"title\nV1 1 0 1\nR1 1 0 1k\n.op\n{end}\nR2 1 0 not-a-value\n")
    assert sorted(e.name for e in circuit.elements) == ["r1", "v1"]


def test_ends_and_endc_are_not_end():
    with pytest.raises(NetlistError, match="ends"):
        load("title\nV1 1 0 1\nR1 1 0 1k\n.ends\n.end\n")


@pytest.mark.ngspice
def test_cards_after_end_are_not_read_and_a_warning_says_ngspice_reads_them(tmp_path):
    # ngspice 39 reads on past .end (PySpice's astable.cir has its .control block there):
    # netdae reads nothing after .end, and says so at the .end instead of a bare 'no analysis card'
    import subprocess

    text = "t\nV1 a 0 1\nR1 a b 1k\nR3 b 0 1k\n.op\n.end\nR2 b 0 1k\n.control\nset numdgt=12\nop\nprint v(b)\n.endc\n"
    (tmp_path / "e.cir").write_text(text)
    out = subprocess.run(["ngspice", "-b", "e.cir"], capture_output=True, text=True, cwd=tmp_path, timeout=60).stdout
    ngspice_vb = float(next(line for line in out.splitlines() if line.startswith("v(b) = ")).split("=")[1])
    assert abs(ngspice_vb - 1 / 3) < 1e-9  # R2 after .end is in ngspice's circuit: 1 * (1k||1k) / (1k + 1k||1k)
    circuit = load(text)
    warnings = [d for d in circuit.diagnostics if d.severity == "warning" and "after .end" in d.message]
    assert len(warnings) == 1 and warnings[0].location.line == 6 and "'R2 b 0 1k'" in warnings[0].message
    assert sorted(e.name for e in circuit.elements) == ["r1", "r3", "v1"]
