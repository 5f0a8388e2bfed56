"""Text-level translation for ngspice: op-amps, options, control blocks, messages."""

from __future__ import annotations

import pytest

from netdae.errors import NetlistError, NgspiceError
from netdae.ngspice.translate import (
    OPAMP_GAIN,
    classify_output,
    dc_sweeps,
    effective_tolerances,
    override_options,
    translate_for_ngspice,
)


def test_opamp_becomes_a_high_gain_vcvs_in_any_case_and_with_comments():
    text = "t\nV1 in 0 1\nE1 out 0 0 minus OpAmp ; ideal\neA o2 0 p m opamp $ also ideal\n.end\n"
    out, notes = translate_for_ngspice(text)
    lines = out.splitlines()
    assert lines[2] == f"E1 out 0 0 minus {OPAMP_GAIN!r}"
    assert lines[3] == f"eA o2 0 p m {OPAMP_GAIN!r}"
    assert [n.split(":")[0] for n in notes] == ["line 3", "line 4"]
    assert "E1" in notes[0] and "VCVS of gain 1e+06" in notes[0]


def test_opamp_on_continuation_lines_inside_a_subcircuit():
    text = (
        "t\n.subckt amp a b\n* comment between card and continuation\nE9 b 0\n\n+ 0 a\n+ OPAMP\n"
        "R1 a b 1k\n.ends\nXu in out amp\n.end\n"
    )
    out, notes = translate_for_ngspice(text, opamp_gain=1e9)
    lines = out.splitlines()
    assert "E9 b 0 0 a 1000000000.0" in lines
    assert not any(line.startswith("+") for line in lines)
    assert "R1 a b 1k" in lines  # the rest untouched
    assert notes[0].startswith("lines 4-7: E9 (in subcircuit amp)")


def test_other_e_cards_are_untouched():
    text = "t\nE1 out 0 in 0 10\nE2 x 0 value={v(in)*2}\nE3 opamp 0 a b 5\n.end\n"
    out, notes = translate_for_ngspice(text)
    assert out == text and notes == []


@pytest.mark.parametrize("card", ["E1 out 0 minus OPAMP", "E1 out 0 0 minus OPAMP 1e5"])
def test_malformed_opamp_card_is_a_netlist_error_with_location(card):
    with pytest.raises(NetlistError) as info:
        translate_for_ngspice(f"t\nV1 in 0 1\n{card}\n.end\n", source="amp.cir")
    assert info.value.location.file == "amp.cir" and info.value.location.line == 3
    assert info.value.expected == "Ename out+ out- in+ in- OPAMP"


def test_interp_and_filetype_are_removed_with_notes_other_options_kept():
    text = "t\n.options reltol=1e-4 INTERP filetype = ascii\n.option interp\n.end\n"
    out, notes = translate_for_ngspice(text)
    assert out.splitlines() == ["t", ".options reltol=1e-4", ".end"]
    assert len(notes) == 3
    assert "INTERP removed" in notes[0] and "wrong values" in notes[0]
    assert "filetype=ascii removed" in notes[1]
    assert notes[2].startswith("line 3: .options interp removed")


def test_control_blocks_are_removed_with_a_note():
    text = "t\nR1 1 0 1k\n.control\nrun\nquit\n.endc\n.op\n.end\n"
    out, notes = translate_for_ngspice(text)
    assert out.splitlines() == ["t", "R1 1 0 1k", ".op", ".end"]
    assert ".control: 'quit' skipped" in notes[0] and notes[0].startswith("<string>:5:1")
    with pytest.raises(NetlistError, match=".control block without .endc"):
        translate_for_ngspice("t\n.control\nrun\n.end\n")


def test_includes_and_library_sections_are_expanded_by_netdae(tmp_path):
    (tmp_path / "models").mkdir()
    (tmp_path / "models" / "d.lib").write_text("* diode\n.model dm d is=1e-14\n+ n=1.5 ; ideality\n")
    (tmp_path / "x.lib").write_text(".lib tt\n.param rval=1k\n.endl\n.lib ff\n.param rval=2k\n.endl\n")
    text = "t\n.include models/d.lib\n.lib 'x.lib' tt\nE1 o 0 a b opamp\nR1 a o {rval}\n.lib section\nR9 1 0 1\n.endl\n.op\n"
    out, notes = translate_for_ngspice(text, base_dir=tmp_path)
    assert out.splitlines() == ["t", ".model dm d is=1e-14 n=1.5", ".param rval=1k", f"E1 o 0 a b {OPAMP_GAIN!r}",
                                "R1 a o {rval}", ".op", ".end"]
    assert any(n.startswith("line 4: E1") for n in notes)
    # the main file's own section, which nothing reads, is left out with a warning (ngspice 39 refuses it)
    assert any("no '.lib FILE section' reads" in n for n in notes)
    with pytest.raises(NetlistError, match="not found"):
        translate_for_ngspice("t\n.include missing.lib\n.op\n", base_dir=tmp_path)


def test_override_inserts_before_end_and_validates():
    text = "t\nR1 1 0 1k\n.tran 1u 1m\n.subckt s a\n.ends\n.control\nrun\n.endc\n.END\n"
    out, notes = override_options(text, reltol=1e-6, abstol=1e-15, vntol=1e-9, method="gear")
    lines = out.splitlines()
    assert lines[-2:] == [".options reltol=1e-06 abstol=1e-15 vntol=1e-09 method=gear", ".END"]
    assert notes == ["line 9: inserted before .end: .options reltol=1e-06 abstol=1e-15 vntol=1e-09 method=gear"]
    with pytest.raises(NgspiceError, match="unknown ngspice option 'maxstp'"):
        override_options(text, maxstp=1e-9)
    with pytest.raises(NgspiceError, match="method"):
        override_options(text, method="euler")


def test_override_without_end_appends_and_after_end_options_go_last():
    out, _ = override_options("t\nR1 1 0 1k\n.op", reltol=1e-5)
    assert out.splitlines()[-1] == ".options reltol=1e-05"
    # ngspice 39 reads cards after .end, and the last .options card wins
    out, notes = override_options("t\n.op\n.end\n.options reltol=1e-2\n", reltol=1e-5)
    assert out.splitlines()[-1] == ".options reltol=1e-05"
    assert "after the last .options card" in notes[0]


def test_maxstep_goes_into_every_tran_card():
    text = "t\n.tran 1u 1m\n.TRAN 1u\n+ 2m 0.5m uic\n.tran 1n 1u 0 1n\n.end\n"
    out, notes = override_options(text, maxstep=5e-8)
    assert out.splitlines()[1:4] == [".tran 1u 1m 0 5e-08", ".TRAN 1u 2m 0.5m 5e-08 uic", ".tran 1n 1u 0 5e-08"]
    assert len(notes) == 3
    with pytest.raises(NgspiceError, match="no .tran"):
        override_options("t\n.op\n.end\n", maxstep=1e-9)


def test_dc_sweeps_and_tolerances():
    text = "t\n.dc V1 0 1 0.1 i2 0 2m 1m\n.options reltol=1e-4 method=Gear\n.options vntol=1u\n.end\n"
    (card,) = dc_sweeps(text)
    assert card.sources == ("v1", "i2")
    assert card.ranges == ((0.0, 1.0, 0.1), (0.0, 2e-3, 1e-3))
    tolerances, method = effective_tolerances(text)
    assert tolerances["reltol"] == 1e-4 and tolerances["vntol"] == 1e-6 and tolerances["abstol"] == 1e-12
    assert method == "gear"


@pytest.mark.parametrize(
    "text, value",
    [("1k", 1e3), ("2.5MEG", 2.5e6), ("10uF", 1e-5), ("-3e-3", -3e-3), (".5n", 5e-10),
     ("1a", 1.0), ("1.5d2", 150.0), ("4k7", 4000.0), ("1M", 1e-3)],
)
def test_numbers_are_read_as_ngspice_reads_them(text, value):
    # ngspice 39's INPevaluate: no atto suffix, 'd' exponents, no RKM codes, M is milli
    (card,) = dc_sweeps(f"t\n.dc v1 0 {text} 1\n.end\n")
    assert card.ranges[0][1] == pytest.approx(value, rel=1e-15)
    tolerances, _ = effective_tolerances(f"t\n.options abstol={text}\n")
    assert tolerances["abstol"] == pytest.approx(value, rel=1e-15)


def test_classify_output_of_real_ngspice_failures():
    # stderr of ngspice 39 for a netlist with a missing model
    stderr = [
        "warning, can't find model 'nomodel' from line",
        "    q1 out in 0 nomodel",
        "Error on line 4 or its substitute:",
        "  q1 out in 0 nomodel",
        "could not find a valid modelname",
        "    Simulation interrupted due to error!",
        "",
        "Error: circuit not parsed.",
        "Note: no resource usage information for 'time',",
        "\tor no active circuit available",
    ]
    errors, warnings = classify_output(stderr, [])
    assert errors[:3] == ["Error on line 4 or its substitute:", "q1 out in 0 nomodel", "could not find a valid modelname"]
    assert "Error: circuit not parsed." in errors
    assert warnings == ["warning, can't find model 'nomodel' from line", "q1 out in 0 nomodel"]


def test_singular_matrix_is_an_error_only_when_strict():
    stderr = [
        "Warning: singular matrix:  check node float",
        "Note: Starting dynamic gmin stepping",
        "Trying gmin =   1.0000E-03 Note: One successful gmin step",
        "Note: Transient op finished successfully",
    ]
    errors, _ = classify_output(stderr, [])
    assert errors == ["Warning: singular matrix:  check node float"]
    errors, warnings = classify_output(stderr, [], strict=False)
    assert errors == [] and warnings[0].startswith("Warning: singular matrix")
    assert not any("Trying gmin" in w for w in warnings)


def test_harmless_notes_are_not_errors():
    stderr = ["Note: v1: dc value used for op instead of transient time=0 value.", "Warning: r2: resistance to low, set to 1 mOhm"]
    errors, warnings = classify_output(stderr, ["Note: No compatibility mode selected!", "Circuit: t"])
    assert errors == [] and warnings == stderr


def test_end_is_the_last_card_and_nothing_follows_it():
    out, notes = translate_for_ngspice("t\nR1 1 0 1k\n.op")
    assert out.splitlines() == ["t", "R1 1 0 1k", ".op", ".end"] and notes == []
    # netdae's reader ends the netlist at .end (ngspice 39 would read on): the rest is dropped, with a note
    out, notes = translate_for_ngspice("t\nR1 1 0 1k\n.op\n.END\nR2 1 0 2k\n.tran 1u 1m\n")
    assert out.splitlines() == ["t", "R1 1 0 1k", ".op", ".end"]
    assert notes == ["line 4: the 2 card(s) or block(s) after .end are not passed to ngspice (netdae's reader "
                     "ends the netlist at .end; ngspice 39 would read them)"]
    text = "t\nR1 1 0 1k\n.op\n.end\n* trailing comment\n"
    assert translate_for_ngspice(text) == ("t\nR1 1 0 1k\n.op\n.end\n", [])


def test_coupling_of_three_inductors_becomes_one_card_per_pair():
    from netdae.ngspice import translate_for_ngspice

    text = "t\nL1 a 0 1m\nL2 b 0 2m\nL3 c 0 3m\nK1 L1 L2 L3 0.5\n.end\n"
    out, notes = translate_for_ngspice(text)
    lines = [ln.lower() for ln in out.splitlines()]
    assert "k1_l1_l2 l1 l2 0.5" in lines and "k1_l1_l3 l1 l3 0.5" in lines and "k1_l2_l3 l2 l3 0.5" in lines
    assert not any(ln.startswith("k1 ") for ln in lines)
    assert any("3 inductors" in n and "3 K cards" in n for n in notes)


@pytest.mark.ngspice
def test_three_coil_transformer_agrees_with_ngspice():
    import netdae

    text = """three coupled coils
V1 in 0 SIN(0 1 1k)
R1 in a 10
L1 a 0 10m
L2 b 0 20m
L3 c 0 5m
R2 b 0 100
R3 c 0 50
K1 L1 L2 L3 0.8
.tran 10u 3m
.end
"""
    comparison = netdae.compare(text, tight=True, tol=1e-3)
    assert comparison.passed, comparison


@pytest.mark.parametrize("func", [
    ".func fact(n) {n <= 1 ? 1 : n*fact(n-1)}",
    ".FUNC Fact (n) = {n <= 1 ? 1 : n * FACT(n - 1)}",
])
def test_a_self_calling_func_is_not_handed_to_ngspice(func):
    """ngspice 39 expands such a .func without end and stops with a segmentation fault (measured: exit
    status 139 in batch mode; the shared library took `netdae compare` down with it)."""
    text = f"t\n{func}\nV1 in 0 1\nR1 in 0 {{fact(4)*10}}\n.op\n.end\n"
    with pytest.raises(NgspiceError, match=r"line 2: \.func fact calls itself: .*segmentation fault"):
        translate_for_ngspice(text)


def test_funcs_calling_each_other_are_left_to_ngspice():
    """ngspice 39 refuses those itself ("Undefined parameter [g]"), without crashing."""
    text = "t\n.func f(x) {x > 1 ? g(x-1) : 1}\n.func g(x) {2*f(x)}\n.func h(x) {sqrt(x)}\nR1 a 0 1k\n.end\n"
    out, _ = translate_for_ngspice(text)
    assert ".func g(x) {2*f(x)}" in out
