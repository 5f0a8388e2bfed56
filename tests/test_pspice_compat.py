"""ngspice's PSpice compatibility mode (``set ngbehavior=ps|psa|...``): where the mode comes from,
each translation against a closed form and against ngspice 39 run in the same mode, and the
located refusals outside the mode.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import netdae
from netdae.analyses.op import operating_point
from netdae.errors import NetlistError
from netdae.netlist import load, parse
from netdae.netlist.compat import (PSWITCH_R_CONTROL, find_behavior, parse_behavior, read_spiceinit)
from netdae.netlist.reader import read_deck
from netdae.ngspice.batch import spiceinit

#: Pass criterion of the comparisons with ngspice, in units of the comparison's tolerance.
TOLERANCE = 1e-3


def _agree(text_or_path, behavior, analysis="tran", tol=TOLERANCE, **kw):
    """compare() in the mode; every signal within ``tol`` of its scale."""
    from netdae.comparison import compare

    result = compare(text_or_path, behavior=behavior, tol=tol, **kw)
    assert result.ngspice_error is None, result.ngspice_error
    item = result.analysis(analysis, 0)
    worst = max(item.signals, key=lambda s: s.max_rel)
    assert item.passed, (item.error, [(s.name, s.max_rel, s.passed) for s in item.signals if not s.passed])
    return worst.max_rel / tol


# --- the mode: values, .spiceinit, scope ------------------------------------------------------------------------

@pytest.mark.parametrize("value, ps, lt, all_", [("ps", True, False, False), ("psa", True, False, True),
                                                ("ltpsa", True, True, True), ("lta", False, True, True),
                                                ("ltps", True, True, False), ("PSA", True, False, True),
                                                ("hsps", True, False, False), ("spe", False, False, False)])
def test_values_read_as_ngspice_sets_its_flags(value, ps, lt, all_):
    b = parse_behavior(value)
    assert (b.pspice, b.ltspice, b.all) == (ps, lt, all_)


def test_no_mode_and_bad_values():
    assert parse_behavior("") is None and parse_behavior("mc") is None and parse_behavior("zz") is None
    with pytest.raises(NetlistError, match="expected letters"):
        parse_behavior("ps;shell ls")


def test_spiceinit_gives_the_mode_and_a_note_per_other_line(tmp_path):
    init = tmp_path / ".spiceinit"
    init.write_text("* start-up\nset noaskquit\nshell touch executed\nset ngbehavior=ps\nsource x.cir\n"
                    "set num_threads=4 ngbehavior=psa\n")
    behavior, notes = read_spiceinit(str(init))
    assert behavior.value == "psa" and behavior.location.line == 6
    ignored = {n.location.line: n.message for n in notes}
    assert sorted(ignored) == [2, 3, 5, 6]
    assert "'shell touch executed' ignored" in ignored[3] and "set num_threads=4" in ignored[6]
    assert not (tmp_path / "executed").exists()


def test_spiceinit_unset_clears_the_mode(tmp_path):
    init = tmp_path / ".spiceinit"
    init.write_text("set ngbehavior=psa\nunset ngbehavior\n")
    assert read_spiceinit(str(init))[0] is None


def test_spiceinit_next_to_the_netlist_then_the_working_directory(tmp_path, monkeypatch):
    here, there = tmp_path / "cwd", tmp_path / "netlist"
    here.mkdir()
    there.mkdir()
    monkeypatch.chdir(here)
    (here / ".spiceinit").write_text("set ngbehavior=ps\n")
    assert find_behavior(str(there))[0].value == "ps"
    (there / ".spiceinit").write_text("set ngbehavior=psa\n")
    assert find_behavior(str(there))[0].value == "psa"
    netlist = there / "t.cir"
    netlist.write_text("t\nB1 1 0 V={1&1}\nR1 1 0 1\n.op\n")
    assert load(str(netlist)).netlist.behavior.value == "psa"
    assert load(str(netlist), behavior="psa").netlist.behavior.location is None
    with pytest.raises(NetlistError, match="logical and"):
        load(str(netlist), behavior="")


LOGIC = "logic\nV8 8 0 {v8}\nV9 9 0 {v9}\nB1 1 0 V=~(~v(9)&v(8)) + (v(8)|v(9))*0.5\nR1 1 0 1k\n.op\n"


@pytest.mark.parametrize("v8, v9", [(0, 0), (0, 1), (1, 0), (1, 1)])
def test_logical_operators_in_the_mode(v8, v9):
    text = LOGIC.replace("{v8}", str(v8)).replace("{v9}", str(v9))
    x = operating_point(load(text, behavior="psa"))
    expected = float(not ((not v9) and v8)) + 0.5 * float(v8 or v9)
    assert x["v(1)"][0] == expected


def test_logical_operators_refused_outside_the_mode_with_the_way_to_turn_it_on():
    with pytest.raises(NetlistError) as info:
        load(LOGIC.replace("{v8}", "1").replace("{v9}", "0"), behavior="")
    assert "(PSpice's logical not)" in str(info.value) and "ngbehavior=psa" in str(info.value)
    assert info.value.location.line == 4 and info.value.location.column == 10  # the inner '~'


def test_a_translated_card_keeps_its_locations():
    # '&' became '&&' before the bad token: the error still points at its own column
    text = "t\n.param a=1\n.param b={a&a + ) }\n"
    with pytest.raises(NetlistError) as info:
        parse(text, behavior="psa")
    assert (info.value.location.line, info.value.location.column) == (3, 17)
    with pytest.raises(NetlistError) as info:  # on a continuation line, after insertions on both lines
        parse("t\n.param a=1\n.param b={a&a|a\n+  + a&a ) }\n", behavior="psa")
    assert (info.value.location.line, info.value.location.column) == (4, 10)


def test_ps_translates_included_files_only(tmp_path):
    (tmp_path / "lib.inc").write_text(".param p = {1 & 1}\n.subckt one o\nB1 o 0 V={~0}\nR1 o 0 1\n.ends\n")
    main = tmp_path / "main.cir"
    main.write_text("t\n.include lib.inc\nX1 1 one\n.op\n")
    x = operating_point(load(str(main), behavior="ps"))
    assert x["v(1)"][0] == 1.0
    main.write_text("t\n.include lib.inc\nX1 1 one\nB2 2 0 V={1 & 1}\nR2 2 0 1\n.op\n")
    with pytest.raises(NetlistError, match="logical and") as info:
        load(str(main), behavior="ps")
    assert info.value.location.line == 4
    assert operating_point(load(str(main), behavior="psa"))["v(2)"][0] == 1.0


def test_dollar_starts_no_comment_in_the_mode():
    text = "t\nV1 1 0 1 $ a comment in ngspice\n.op\n"
    assert load(text, behavior="").element("v1").source.dc == 1.0
    with pytest.raises(NetlistError):
        load(text, behavior="psa")


def test_lib_is_read_as_include_in_the_mode(tmp_path):
    (tmp_path / "m.lib").write_text(".model dd d is=1e-14\n")
    main = tmp_path / "main.cir"
    main.write_text("t\n.lib m.lib\nD1 1 0 dd\nI1 0 1 1m\n.op\n")
    assert load(str(main), behavior="psa").models["dd"].params["is"] == 1e-14
    main.write_text("t\n.lib m.lib typ\nD1 1 0 dd\nI1 0 1 1m\n.op\n")
    with pytest.raises(NetlistError, match="read as '.include file'"):
        load(str(main), behavior="psa")


def test_predefined_parameters():
    text = "t\nV1 1 0 {vt}\nR1 1 0 1\nV2 2 0 {gmin}\nR2 2 0 1\n.subckt s o\nV1 o 0 {temp}\nR1 o 0 1\n.ends\nX1 3 s\n.op\n"
    x = operating_point(load(text, behavior="psa"))
    assert x["v(1)"][0] == pytest.approx((27 + 273.15) * 8.6173303e-5, rel=1e-15)
    assert x["v(2)"][0] == 1e-12 and x["v(3)"][0] == pytest.approx(27.0)


# --- AKO models -------------------------------------------------------------------------------------------------

AKO = """ako
.model qbase npn(is=1e-15 bf=50 vaf=80)
.model qk ako:qbase npn(bf=150 ikf=0.1)
V1 c 0 5
VB b 0 0.7
Q1 c b 0 qk
.op
"""


def test_ako_model_is_a_copy_with_the_changes():
    c = load(AKO, behavior="psa")
    assert c.models["qk"].type == "npn"
    assert {k: c.models["qk"].params[k] for k in ("is", "bf", "vaf", "ikf")} == {"is": 1e-15, "bf": 150.0,
                                                                                   "vaf": 80.0, "ikf": 0.1}


def test_ako_chains_and_subcircuits():
    text = (".model a ako:b npn(bf=1)\n.model b ako:c npn(vaf=2)\n.model c npn(is=3)\n"
            ".subckt s c b e\n.model d ako:c npn(bf=4)\nQ1 c b e d\n.ends\nX1 1 2 0 s\nV1 1 0 1\nV2 2 0 0.5\n"
            "Q2 1 2 0 a\n.op\n")
    c = load("t\n" + text, behavior="psa")
    assert {k: c.models["a"].params[k] for k in ("bf", "vaf", "is")} == {"bf": 1.0, "vaf": 2.0, "is": 3.0}
    assert {k: c.models["x1:d"].params[k] for k in ("bf", "is")} == {"bf": 4.0, "is": 3.0}


def test_ako_errors_are_located():
    with pytest.raises(NetlistError, match="no model 'qnone'") as info:
        load(AKO.replace("ako:qbase", "ako:qnone"), behavior="psa")
    assert info.value.location.line == 3
    with pytest.raises(NetlistError, match="differs from the type 'npn'"):
        load(AKO.replace("ako:qbase npn", "ako:qbase pnp"), behavior="psa")
    with pytest.raises(NetlistError, match="PSpice AKO model") as info:
        load(AKO, behavior="")
    assert "ngbehavior=psa" in str(info.value)


@pytest.mark.ngspice
def test_ako_model_agrees_with_ngspice():
    assert _agree(AKO, "psa", analysis="op") < 1.0


# --- PSpice's switches ------------------------------------------------------------------------------------------

VSWITCH = """vswitch
V1 c 0 0
V2 a 0 1
R1 a d 1k
S1 d 0 c 0 swn
.model swn vswitch(von=0.7 voff=0.3 ron=10 roff=1e5)
.dc V1 -0.2 1.2 0.01
"""


def _pswitch_r(x, on, off, ron, roff):
    """PSpice's switch resistance: ln r a cubic between (off, roff) and (on, ron), flat at both ends."""
    s = min(max((x - off) / (on - off), 0.0), 1.0)
    return roff * (ron / roff) ** (3 * s**2 - 2 * s**3)


def test_vswitch_resistance_is_pspices_law():
    (res,) = netdae.run(load(VSWITCH, behavior="psa"))
    vc = np.asarray(res.axis)
    # the control port's 1 TOhm resistor loads V1 only
    expected = [1.0 * r / (1e3 + r) for r in (_pswitch_r(x, 0.7, 0.3, 10.0, 1e5) for x in vc)]
    np.testing.assert_allclose(res["v(d)"], expected, rtol=1e-9)
    assert load(VSWITCH, behavior="psa").element("s1#rc").value == PSWITCH_R_CONTROL


def test_vswitch_with_vt_vh_is_ngspices_switch():
    c = load(VSWITCH.replace("von=0.7 voff=0.3", "vt=0.5 vh=0.1"), behavior="psa")
    assert c.element("s1").kind == "vswitch" and c.models["swn"].type == "sw"


def test_switch_models_outside_the_mode_and_bad_ones():
    with pytest.raises(NetlistError, match="PSpice's voltage-controlled switch") as info:
        load(VSWITCH, behavior="")
    assert "ngbehavior=psa" in str(info.value)
    with pytest.raises(NetlistError, match="needs von/voff") as info:
        load(VSWITCH.replace("von=0.7 voff=0.3 ", ""), behavior="psa")
    assert info.value.location.line == 6
    with pytest.raises(NetlistError, match="roff=-1: a resistance") as info:
        load(VSWITCH.replace("roff=1e5", "roff=-1"), behavior="psa")
    assert info.value.location.line == 6
    with pytest.raises(NetlistError, match="ion equals ioff"):
        load(ISWITCH.replace("ion=2m", "ion=0"), behavior="psa")


ISWITCH = """iswitch
I1 0 c PWL(0 -1m 1 3m)
VS c 0 0
V2 a 0 1
R1 a d 1k
W1 d 0 VS swi
.model swi iswitch(ion=2m ioff=0 ron=10 roff=1e5)
.tran 1m 1
"""


def test_iswitch_resistance_is_aswitchs_law():
    (res,) = netdae.run(load(ISWITCH.replace(".tran 1m 1", ".dc I1 -1m 3m 0.1m"), behavior="psa"))
    ic = np.asarray(res.axis)
    r = np.clip(10.0 * np.exp(math.log(1e5 / 10.0) * (2e-3 - ic) / 2e-3), 10.0, 1e5)
    np.testing.assert_allclose(res["v(d)"], r / (1e3 + r), rtol=1e-9)


@pytest.mark.ngspice
@pytest.mark.parametrize("text", [VSWITCH.replace("V1 c 0 0", "V1 c 0 PWL(0 -0.2 1 1.2)").replace(
    ".dc V1 -0.2 1.2 0.01", ".tran 1m 1"), ISWITCH], ids=["vswitch", "iswitch"])
def test_pspice_switches_agree_with_ngspice(text):
    assert _agree(text, "psa") < 1.0


@pytest.mark.ngspice
def test_pspice_switches_agree_with_ngspice_through_the_subprocess():
    text = VSWITCH.replace("V1 c 0 0", "V1 c 0 PWL(0 -0.2 1 1.2)").replace(".dc V1 -0.2 1.2 0.01", ".tran 1m 1")
    assert _agree(text, "psa", backend="subprocess") < 1.0


# --- other translations -----------------------------------------------------------------------------------------

def test_model_translations():
    text = ("t\n.model m1 nmos level=6 vto=0.7\n.model q1 npn(bf=100 dev=5% t_abs=50)\n"
            ".model q2 lpnp(bf=20)\n.op\n")
    cards = {m.name: m for m in parse(text, behavior="psa").top.models.values()}
    assert cards["m1"].params["level"][0] == 8 and cards["m1"].strings["version"][0] == "3.2.4"
    assert "dev" not in cards["q1"].params and "temp" in cards["q1"].params and "t_abs" not in cards["q1"].params
    assert cards["q2"].type == "pnp" and cards["q2"].params["subs"][0] == -1


def test_bracketed_substrate_node():
    text = "t\nV1 c 0 5\nV2 b 0 0.7\nQ1 c b 0 [sub] qq 2\nRS sub 0 1k\n.model qq npn\n.op\n"
    q = load(text, behavior="psa").element("q1")
    assert q.nodes == ("c", "b", "0", "sub") and q.params["area"] == 2.0


@pytest.mark.ngspice
def test_model_tolerances_and_substrate_agree_with_ngspice():
    text = ("t\nV1 c 0 5\nV2 b 0 0.7\nQ1 c b 0 [sub] qq 2\nRS sub 0 1k\nI1 0 a 1m\nD1 a 0 dd\n"
            ".model qq npn(is=1e-16 bf=120 dev=5% lot=10%)\n.model dd d(is=1e-14 n=1.5 dev=5%)\n.op\n")
    assert _agree(text, "psa", analysis="op") < 1.0


TABLE = "table\nV1 1 0 {x}\nE1 2 0 VALUE={TABLE(V(1), 0, 0, 1, 2, 2, 3)}\nR2 2 0 1k\n.op\n"


@pytest.mark.parametrize("x, y", [(0.5, 1.0), (1.5, 2.5), (0.0, 0.0), (2.0, 3.0)])
def test_table_in_value_is_a_pwl(x, y):
    v = operating_point(load(TABLE.replace("{x}", str(x)), behavior="psa"))["v(2)"][0]
    assert v == pytest.approx(y, rel=1e-12)


@pytest.mark.ngspice
def test_table_agrees_with_ngspice():
    assert _agree(TABLE.replace("{x}", "1.5"), "psa", analysis="op") < 1.0


@pytest.mark.ngspice
@pytest.mark.parametrize("v9", [0, 1])
def test_logic_agrees_with_ngspice(v9):
    text = LOGIC.replace("{v8}", "0").replace("{v9}", str(v9)).replace(".op", ".dc V8 -1 1 0.25")
    assert _agree(text, "psa", analysis="dc") < 1.0


def test_the_ngspice_start_up_file_sets_only_the_mode():
    assert spiceinit("psa").splitlines()[1:] == ["set ngbehavior=psa"]
    with pytest.raises(netdae.errors.NgspiceError):
        spiceinit("ps\nshell ls")


def test_the_deck_for_ngspice_is_read_in_the_mode_but_not_translated():
    deck = read_deck(LOGIC, behavior="psa", translate=False)
    assert any("~(~v(9)&v(8))" in c.text for c in deck.cards) and deck.behavior.ngspice_value == "psa"
    assert parse_behavior("ps").ngspice_value == "psa" and parse_behavior("lt").ngspice_value == "lta"


def test_functions_and_params_commas():
    text = ("t\n.subckt s a params: x=1, y={max(2, 3)}\nR1 a 0 {x + y + stp(1) + pwrs(-2, 2) + pwr(-2, 2)}\n.ends\n"
            "X1 1 s params: x=3, y=4\nV1 1 0 1\n.op\n")
    assert load(text, behavior="psa").element("r.x1.r1").value == 3 + 4 + 1 - 4 + 4  # pwr as pow in the mode
    with pytest.raises(NetlistError):
        load(text, behavior="")


@pytest.mark.ngspice
def test_functions_agree_with_ngspice():
    # (ngspice's parameters know no u(), so stp() only in the B source)
    text = ("t\nV1 1 0 {pwr(-2, 2) + pwrs(-2, 3)}\nR1 1 0 1\nV3 3 0 -2\nR3 3 0 1\n"
            "B2 2 0 V=pwr(-3, 2) + pwrs(v(3), 2) + stp(v(3) + 3)\nR2 2 0 1\n.op\n")
    assert _agree(text, "psa", analysis="op") < 1.0


@pytest.mark.ngspice
def test_a_vendor_library_in_ps_mode_from_spiceinit_agrees_with_ngspice(tmp_path, monkeypatch):
    """``set ngbehavior=ps`` next to the netlist: the included library is translated (AKO, VSWITCH,
    ``|``), the main file is not, and ngspice runs in the mode too."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / ".spiceinit").write_text("* netlist's start-up file\nset ngbehavior=ps\nset noaskquit\n")
    (tmp_path / "vendor.lib").write_text(
        ".subckt gate in out vdd\n"
        "S1 out 0 in 0 swn\nR1 vdd out 10k\nC1 out 0 1p\n"
        "B1 flag 0 V={(v(vdd) > 1) | (v(vdd) < -5)}\nR2 flag 0 1k\n"
        ".model swn vswitch(von=1.5 voff=0.5 ron=100 roff=1e8)\n"
        ".ends\n"
        ".model qb npn(is=1e-15 bf=80)\n.model qa ako:qb npn(bf=200)\n")
    main = tmp_path / "main.cir"
    main.write_text("library in ps mode\n.include vendor.lib\nV1 in 0 PULSE(0 2 10n 50n 50n 100n 300n)\n"
                    "VDD vdd 0 3\nX1 in out vdd gate\nRB vdd b 200k\nQ1 vdd b e qa\nRE e 0 1k\n.tran 1n 300n\n")
    circuit = load(str(main))
    assert circuit.netlist.behavior.value == "ps" and not circuit.netlist.behavior.all
    notes = [str(d) for d in circuit.diagnostics]
    assert any("'set noaskquit' ignored" in n for n in notes)
    assert circuit.models["qa"].params["bf"] == 200.0 and circuit.models["qa"].params["is"] == 1e-15
    assert _agree(str(main), None, tight=True) < 1.0  # (tight: the switched RC edge at ngspice's default steps is off by 0.5 %)


def test_command_line_option(tmp_path, capsys):
    from netdae.cli import main

    netlist = tmp_path / "logic.cir"
    netlist.write_text(LOGIC.replace("{v8}", "1").replace("{v9}", "0"))
    assert main(["check", str(netlist), "--ngbehavior", "psa"]) == 0
    assert main(["check", str(netlist)]) != 0
    assert "logical not" in capsys.readouterr().err


# --- LTspice's mode ---------------------------------------------------------------------------------------------

LTSPICE = ("lt\nV1 1 0 0\nB1 2 0 V=uplim(v(1), 3, 0.5) + dnlim(v(1), -3, 0.5)\nR2 2 0 1k noiseless\n"
           "B3 3 0 V=uplim_tanh(v(1), 2, 0.25) + dnlim_tanh(v(1), -2, 0.25)\nR3 3 0 1k\n.backanno\n.dc V1 -5 5 0.25\n")


def _uplim(x, pos, z):
    return min(x, pos - z) + (1 - (min(max(0, x - pos + z), 2 * z) / 2 / z - 1) ** 2) * z


def _dnlim(x, neg, z):
    return max(x, neg + z) - (1 - (min(max(0, -x + neg + z), 2 * z) / 2 / z - 1) ** 2) * z


def test_ltspice_functions_and_cards():
    c = load(LTSPICE, behavior="lta")
    assert c.element("r2").params["noisy"] == 0.0
    assert any(".backanno dropped" in d.message for d in c.diagnostics)
    (res,) = netdae.run(c)
    x = np.asarray(res.axis)
    np.testing.assert_allclose(res["v(2)"], [_uplim(v, 3, 0.5) + _dnlim(v, -3, 0.5) for v in x], rtol=1e-12, atol=1e-15)
    with pytest.raises(NetlistError, match="uplim"):
        load(LTSPICE.replace(".backanno\n", ""), behavior="ps")


def test_ltspice_ideal_diode_is_refused_by_name():
    with pytest.raises(NetlistError, match="sidiode") as info:
        load("t\n.model dd d(ron=1 roff=1e6 vfwd=0.7)\nD1 1 0 dd\nV1 1 0 1\n.op\n", behavior="lta")
    assert (info.value.location.line, info.value.location.column) == (2, 19)


@pytest.mark.ngspice
def test_ltspice_functions_agree_with_ngspice():
    assert _agree(LTSPICE, "lta", analysis="dc") < 1.0
