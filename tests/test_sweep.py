"""Sweeps: .step cards, netdae.sweep on every executor, Monte Carlo statistics, failures, the CLI."""

from __future__ import annotations

import concurrent.futures as cf
import concurrent.futures.process
import json
import math
import multiprocessing
import re

import numpy as np
import pytest

import netdae
from netdae.cli import main as cli
from netdae.errors import NetdaeError, NetlistError
from netdae.netlist import load
from netdae.netlist.montecarlo import generator

DIVIDER = """divider
.param r2=1k
I1 0 a 1m
R1 a b 1k
R2 b 0 {r2}
.dc I1 0 1m 0.5m
.meas dc vb find v(b) at=1m
.meas dc va find v(a) at=1m
"""


# -- .step cards -------------------------------------------------------------------------
CE = """CE stage
VCC vcc 0 10
RB vcc b 470k
RC vcc c 2k
Q1 c b 0 mod1
D1 c x dmod
RX x 0 1meg
.model mod1 NPN(bf=100 is=1e-14)
.model dmod D(is=1e-14)
.op
"""


@pytest.mark.parametrize("card, name, values", [
    (".step NPN mod1(VAF) list 20 50 100", "mod1(vaf)", [20.0, 50.0, 100.0]),
    (".step mod1(bf) 50 150 50", "mod1(bf)", [50.0, 100.0, 150.0]),
    (".step list npn mod1(vaf) 30", "mod1(vaf)", [30.0]),
    (".step dec D dmod(is) 1e-15 1e-13 1", "dmod(is)", [1e-15, 1e-14, 1e-13]),
    (".step mod1:vaf list 40", "mod1(vaf)", [40.0]),  # Xyce's spelling
])
def test_model_parameter_steps(card, name, values):
    c = load(CE + card + "\n")
    (step,) = c.steps
    assert (step.target, step.name) == ("model", name)
    np.testing.assert_allclose(step.values, values, rtol=1e-12)


def test_a_stepped_model_parameter_equals_the_card_written_with_it():
    res = netdae.sweep(CE + ".step NPN mod1(VAF) list 20 100\n", save=["v(c)"])
    _, v = res.waveform("v(c)")
    for k, vaf in enumerate((20, 100)):
        (op,) = netdae.run(CE.replace("is=1e-14)", f"is=1e-14 vaf={vaf})", 1))
        assert v[k, 0] == op["v(c)"][0]
    res = netdae.sweep(CE, params={"dmod(is)": [1e-15, 1e-13]}, save=["v(x)"])
    _, v = res.waveform("v(x)")
    for k, isat in enumerate((1e-15, 1e-13)):
        (op,) = netdae.run(CE.replace("D(is=1e-14)", f"D(is={isat})"))
        assert v[k, 0] == op["v(x)"][0]


@pytest.mark.parametrize("card, message, token", [
    (".step NPN nomod(vaf) 1 2 1", r"no model 'nomod' to step \(models: dmod, mod1\)", "nomod"),
    (".step PNP mod1(vaf) 1 2 1", r"model 'mod1' is of type 'npn', not 'pnp'", "mod1"),
    (".step mod1(vbx) 1 2 1", r"model 'mod1' \(npn\) has no parameter 'vbx'", "mod1"),
    (".step NPN mod1 1 2 1", r"expected MODEL\(PARAM\) after the model type", "mod1"),
    (".step mod1(vaf 1 2 1", r"expected MODEL\(PARAM\)", "("),
])
def test_bad_model_parameter_steps_are_located(card, message, token):
    text = CE + card + "\n"
    with pytest.raises(NetlistError) as exc:
        load(text)
    err = exc.value
    assert re.search(message, err.message), err.message
    line = text.split("\n")[err.location.line - 1]
    assert err.location.column == line.index(token, 6) + 1, str(err)
@pytest.mark.parametrize("card, target, values", [
    (".step param r2 1k 3k 1k", "param", [1e3, 2e3, 3e3]),
    (".step param r2 lin 1k 3k 1k", "param", [1e3, 2e3, 3e3]),
    (".step lin param r2 3k 1k -1k", "param", [3e3, 2e3, 1e3]),
    (".step dec param r2 1k 100k 1", "param", [1e3, 1e4, 1e5]),
    (".step oct param r2 1k 4k 1", "param", [1e3, 2e3, 4e3]),
    (".step param r2 list 1k 5k 2k", "param", [1e3, 5e3, 2e3]),
    (".step r1 list 10 20", "element", [10.0, 20.0]),
    (".step i1 1m 2m 0.5m", "element", [1e-3, 1.5e-3, 2e-3]),
    (".step temp -40 60 50", "temp", [-40.0, 10.0, 60.0]),
    (".step r2 list {2*500}", "element", [1e3]),  # no "param": the element R2, not the .param r2
])
def test_step_cards(card, target, values):
    c = load(DIVIDER + card + "\n")
    (step,) = c.steps
    assert step.target == target
    np.testing.assert_allclose(step.values, values, rtol=1e-12)


@pytest.mark.parametrize("card, message, token", [
    (".step param r2 1k 3k -1k", r"does not lead from 1000 to 3000", "1k"),
    (".step param r2 1k 3k 0", r"does not lead", "1k"),
    (".step param r2 list", r"at least one value", None),
    (".step param r2 1k 3k", r"start stop increment \(2 values given\)", None),
    (".step dec param r2 1k 10k 2.5", r"positive integer", "1k"),
    (".step param nope 1 2 1", r"no top-level .param defines 'nope' \(defined: r2\)", "nope"),
    (".step nope 1 2 1", r"no parameter or element 'nope'", "nope"),
    (".step param temp 1 2 1", r"no top-level .param defines 'temp'", "temp"),
    (".step temp -300 0 100", r"temperature .*absolute zero|below absolute zero|-273", "-300"),
    # a draw would be made once: every row and Monte Carlo sample the same value
    (".step param r2 list 1k {agauss(1k,500,1)}", r"a .step value draws a random number \(agauss\(\)\)", "{agauss"),
    (".step param r2 1k {rr} 1k\n.param rr={2*q}\n.param q=unif(3k,0.1)",
     r"\(unif\(\) through .param q through .param rr\)", "{rr}"),
    (".step r1 list {f(1k)}\n.func f(x)={x*limit(1,0.1)}", r"\(limit\(\) through .func f\)", "{f"),
])
def test_bad_step_cards_are_located(card, message, token):
    text = DIVIDER + card + "\n"
    with pytest.raises(NetlistError) as exc:
        load(text)
    err = exc.value
    assert re.search(message, err.message), err.message
    assert err.location.line == 9
    line = text.split("\n")[8]
    assert err.location.column == (line.index(token, 6) + 1 if token else len(line) + 1), str(err)


def test_a_random_step_value_is_refused_with_a_hint_and_a_fixed_one_steps():
    text = DIVIDER + ".step param r2 list {agauss(1k,500,1)} 2k\n"
    with pytest.raises(NetlistError) as exc:  # was: --mc 3 ran three identical samples of one draw
        netdae.sweep(text, samples=3, workers=1)
    assert "--mc N" in exc.value.hint and "put the draw in a .param" in exc.value.hint
    # a parameter given a value draws nothing; limit(x, lo, hi) is the clamp, no draw
    c = load(DIVIDER + ".param rr=agauss(1k,500,1)\n.step param r2 list {rr} {limit(5k,1k,2k)}\n", params={"rr": 3e3})
    assert c.steps[0].values == (3e3, 2e3)


def test_stepping_what_the_dc_card_sweeps_is_a_located_warning():
    # .dc sets V1 at each of its points: the step cannot change the .dc result (v(b) = v1/2 at v1=1 in every row)
    text = "t\nV1 a 0 1\nR1 a b 1k\nR2 b 0 1k\n.dc V1 0 1 1\n.meas dc vb find v(b) at=1\n.step V1 0 1 0.5\n"
    c = netdae.load(text)
    (d,) = [d for d in c.diagnostics if "what the .dc card sweeps" in d.message]
    assert d.severity == "warning" and (d.location.line, d.location.column) == (7, 7)
    np.testing.assert_allclose(netdae.sweep(c, workers=1).measures["vb"], [0.5, 0.5, 0.5], rtol=1e-12)
    assert not [d for d in netdae.load(text.replace(".step V1", ".step R1")).diagnostics if "sweeps" in d.message]


def test_stepping_the_dc_value_of_a_source_with_a_transient_function_is_a_located_warning(tmp_path, capsys):
    # the transient follows the PULSE: three identical rows, and nothing said
    text = ("pulse\nV1 in 0 PULSE(0 1 0 1u 1u 1m 2m)\nR1 in out 1k\nC1 out 0 1u\n.tran 10u 1m\n"
            ".meas tran x find v(out) at=1m\n.step V1 list 1 5 10\n")
    c = netdae.load(text)
    (d,) = [d for d in c.diagnostics if "transient function" in d.message]
    assert d.severity == "warning" and (d.location.line, d.location.column) == (7, 7)
    assert d.message.startswith(".step: 'v1' has a PULSE transient function: the step sets its DC value, which the "
                                "operating point and the .dc, .ac and .noise analyses use")
    assert "changes nothing in the .tran result" in d.message
    res = netdae.sweep(text, workers=1)  # a netlist the sweep loads: its warnings are the result's notes
    np.testing.assert_allclose(res.measures["x"], [1 - math.exp(-1)] * 3, rtol=1e-3)
    assert res.notes == [str(d)]
    # the same axis given to the sweep: the same warning, without a place
    bare = text.replace(".step V1 list 1 5 10\n", "")
    assert netdae.sweep(bare, params={"V1": [1, 5]}, workers=1).notes == ["warning: " + d.message[len(".step: "):]]
    path = tmp_path / "p.cir"
    path.write_text(bare)
    assert cli(["sweep", str(path), "--workers", "1", "--out", str(tmp_path / "o"), "--no-plot",
                "--step", "v1=1,5"]) == 0
    assert "netdae: warning: 'v1' has a PULSE transient function" in capsys.readouterr().err
    # no warning where the step does reach the analyses: a DC source, no .tran, TRNOISE (adds its DC value)
    for other in (text.replace("PULSE(0 1 0 1u 1u 1m 2m)", "1"),
                  text.replace(".tran 10u 1m\n.meas tran x find v(out) at=1m",
                               ".ac dec 2 1 10\n.meas ac x find vm(out) at=1"),
                  text.replace("PULSE(0 1 0 1u 1u 1m 2m)", "DC 0 TRNOISE(1m 10u 0 0)")):
        assert not [d for d in netdae.load(other).diagnostics if "transient function" in d.message]


def test_the_measurements_of_an_analysis_left_out_are_left_out_of_the_table():
    text = ("rc\nV1 in 0 DC 0 AC 1 PULSE(0 1 0 1n 1n 1m 2m)\nR1 in out 1k\nC1 out 0 100n\n.ac dec 100 10 100k\n"
            ".tran 1u 1m\n.meas ac f3 when vdb(out)=-3\n.meas tran tr when v(out)=0.5\n")
    res = netdae.sweep(text, params={"r1": [1e3, 2e3]}, analyses=["ac"], workers=1)
    assert list(res.measures) == ["f3"] and not res.notes  # no 'tr' column of empty cells, no warning
    f3 = math.sqrt(10 ** 0.3 - 1) / (2 * math.pi * np.array([1e3, 2e3]) * 100e-9)  # |H| = 1/sqrt(1 + (w R C)^2)
    np.testing.assert_allclose(res.measures["f3"], f3, rtol=1e-3)  # straight lines between 100 points a decade


def test_the_cards_a_sweep_does_not_run_are_named_in_a_note(tmp_path, capsys):
    # .tf, .pz, .sens and .four give no measure of a row: they were left out without a word
    text = ("rc\n.param r=1k\nV1 in 0 1\nR1 in out {r}\nR2 out 0 1k\nC1 out 0 1n\n.tf v(out) V1\n"
            ".pz in 0 out 0 vol pz\n.sens v(out)\n.four 100k v(out)\n.tran 1u 10u\n.meas tran x find v(out) at=10u\n"
            ".step param r list 1k 3k\n")
    res = netdae.sweep(text, workers=1)
    np.testing.assert_allclose(res.measures["x"], [0.5, 0.25], rtol=1e-6)  # 1k / (r + 1k), settled after 20 tau
    assert res.errors == [None, None]
    (note,) = res.notes
    assert note.startswith("not run in the sweep: .tf (<string>:7:1), .pz (<string>:8:1), .sens (<string>:9:1), "
                           ".four (<string>:10:1): a sweep records measures per row")
    assert not netdae.sweep(text, workers=1, analyses=["tran"]).notes[0].count(".tf")  # asked: tran only
    assert not netdae.sweep(text.replace(".four 100k v(out)\n", ""), workers=1, analyses=["tran"]).notes
    path = tmp_path / "tf.cir"
    path.write_text(text)
    assert cli(["sweep", str(path), "--workers", "1", "--out", str(tmp_path / "o"), "--no-plot"]) == 0
    assert "not run in the sweep: .tf" in capsys.readouterr().err
    assert json.loads((tmp_path / "o" / "measures.json").read_text())["notes"] == [note.replace("<string>", str(path))]


def test_a_measure_given_to_the_sweep_that_replaces_or_is_not_made_is_a_located_warning(tmp_path, capsys):
    text = ("rc\nV1 in 0 DC 1 AC 1 PULSE(0 1 0 1u 1u 1m 2m)\nR1 in out {r}\nC1 out 0 1u\n.param r=1k\n"
            ".tran 10u 1m\n.ac dec 5 1k 1meg\n.meas tran x max v(out)\n.meas ac g find vm(out) at=1k\n")
    # columns are those of the text as given (the name x at 6), without the ".meas " netdae puts before it.
    # the added x (the minimum, 0 at t=0) replaced the netlist's x (the maximum, 1 - exp(-1)) without a word
    res = netdae.sweep(text, measures=["tran x min v(out)"], params={"r": [1e3, 2e3]}, workers=1)
    np.testing.assert_allclose(res.measures["x"], [0, 0], atol=1e-12)
    (warning,) = res.notes
    assert warning.startswith("<measures>:1:6: warning: .meas: measurement 'x' is defined again (before at "
                              "<string>:8)") and "a sweep's table read the last" in warning
    # a measure of an analysis the sweep does not run is not made: said, at its card
    res = netdae.sweep(text, measures=["ac g2 find vm(out) at=10k", "tran y min v(out)"], analyses=["ac"],
                       params={"r": [1e3, 2e3]}, workers=1)
    assert list(res.measures) == ["g", "g2"]
    np.testing.assert_allclose(res.measures["g"], 1 / np.sqrt(1 + (2 * np.pi * 1e3 * np.array([1e-3, 2e-3])) ** 2),
                               rtol=1e-9)
    assert res.notes == ["<measures>:2:6: warning: .meas: measurement 'y' measures the .tran analysis, which the "
                         "sweep does not run (it runs ac): it is not made"]
    path = tmp_path / "rc.cir"
    path.write_text(text)
    assert cli(["sweep", str(path), "--workers", "1", "--out", str(tmp_path / "o"), "--no-plot", "--step", "r=1k",
                "--analysis", "ac", "--meas", "tran y min v(out)", "--meas", "ac g find vm(out) at=2k"]) == 0
    err = capsys.readouterr().err
    assert "netdae: warning: <measures>:1:6: .meas: measurement 'y' measures the .tran analysis" in err
    assert "netdae: warning: <measures>:2:4: .meas: measurement 'g' is defined again (before at " in err


def test_run_refuses_a_stepped_netlist_and_names_the_sweep():
    with pytest.raises(NetdaeError, match=r"netdae sweep FILE --out DIR"):
        netdae.run(load(DIVIDER + ".step param r2 list 1k 2k\n"))


@pytest.mark.ngspice
def test_compare_runs_each_point_in_both_simulators(tmp_path, capsys):
    path = tmp_path / "s.cir"
    path.write_text(DIVIDER.replace("R2 b 0 {r2}", "R2 b 0 {r2} tc1=0.01") + ".step param r2 list 1k 3k\n"
                    ".step temp 27 77 50\n.end\n")
    cmp = netdae.compare(str(path))
    assert cmp.passed and [p.point for p in cmp.points] == [
        {"r2": 1e3, "temp": 27.0}, {"r2": 1e3, "temp": 77.0}, {"r2": 3e3, "temp": 27.0}, {"r2": 3e3, "temp": 77.0}]
    for p in cmp.points:  # the point's own values reached both simulators
        vb = next(m for m in p.measures if m.name == "vb")
        expected = 1e-3 * p.point["r2"] * (1 + 0.01 * (p.point["temp"] - 27))
        assert vb.netdae.value == pytest.approx(expected, rel=1e-9)
        assert vb.ngspice.value == pytest.approx(expected, rel=1e-6)
    assert cli(["compare", str(path)]) == 0
    out = capsys.readouterr().out
    assert "on 4 points of the .step cards: PASS" in out and "== point r2=3000, temp=77" in out
    path.write_text(DIVIDER + ".step r1 list 1k 2k\n")
    with pytest.raises(NetdaeError, match=r"steps an element"):
        netdae.compare(str(path))
    path.write_text(MC)
    with pytest.raises(NetdaeError, match=r"draws 1 Monte Carlo value"):
        netdae.compare(str(path))


# -- results against closed forms ---------------------------------------------------------
def test_nested_steps_match_the_divider_closed_form():
    c = load(DIVIDER + ".step param r2 list 1k 3k\n.step r1 list 500 1k 2k\n")
    res = netdae.sweep(c, workers=1)
    assert res.rows == 6 and res.failed == 0
    np.testing.assert_array_equal(res.params["r2"], [1e3, 1e3, 1e3, 3e3, 3e3, 3e3])  # first card outermost
    np.testing.assert_array_equal(res.params["r1"], [500, 1e3, 2e3] * 2)
    np.testing.assert_allclose(res.measures["vb"], 1e-3 * res.params["r2"], rtol=1e-9)
    np.testing.assert_allclose(res.measures["va"], 1e-3 * (res.params["r1"] + res.params["r2"]), rtol=1e-9)


def test_params_argument_adds_and_replaces_axes_and_temp_steps_the_temperature():
    c = load(DIVIDER.replace("R1 a b 1k", "R1 a b 1k tc1=0.01") + ".step param r2 list 1k 3k\n")
    res = netdae.sweep(c, params={"r2": [2e3], "temp": [27.0, 77.0]}, workers=1)
    assert [a.name for a in res.plan.axes] == ["r2", "temp"]
    r1 = 1e3 * (1 + 0.01 * (res.params["temp"] - 27.0))
    np.testing.assert_allclose(res.measures["va"], 1e-3 * (r1 + 2e3), rtol=1e-9)


MC = """current into a Monte Carlo resistor
I1 0 a 1m
R1 a 0 {agauss(1k, 50, 1)}
.dc I1 0 1m 0.5m
.meas dc va find v(a) at=1m
"""


def test_monte_carlo_rows_equal_independent_samples_and_have_the_expected_moments():
    res = netdae.sweep(MC, samples=300, seed=11, workers=1)
    va = res.measures["va"]
    assert res.rows == 300 and res.failed == 0 and res.seed == 11
    # v = 1 mA * R, R ~ N(1k, 50): mean 1 V, std 0.05 V
    assert abs(va.mean() - 1.0) < 3 * 0.05 / np.sqrt(300)
    assert abs(va.std(ddof=1) - 0.05) < 6 * 0.05 / np.sqrt(600)
    c = load(MC)
    for k in (0, 7, 299):
        assert va[k] == pytest.approx(1e-3 * c.variant(sample=k, seed=11).element("r1").value, rel=1e-12)


RC = """RC step
.param c=1u
V1 in 0 PULSE(0 1 0 1n 1n 1 2)
R1 in out 1k
C1 out 0 {c}
.tran 50u 3m
.meas tran t63 when v(out)=0.6321205588 rise=1
"""


def test_transient_sweep_measures_the_time_constant_and_keeps_waveforms_on_the_grid():
    res = netdae.sweep(RC, params={"c": [0.5e-6, 1e-6]}, save=["v(out)"], workers=1, reltol=1e-6)
    np.testing.assert_allclose(res.measures["t63"], 1e3 * res.params["c"], rtol=2e-4)
    grid, w = res.waveform("v(out)")
    assert grid.shape == (61,) and w.shape == (2, 61)
    tau = 1e3 * res.params["c"][:, None]
    np.testing.assert_allclose(w, 1 - np.exp(-np.maximum(grid - 1e-9, 0) / tau), atol=2e-4)
    with pytest.raises(KeyError, match="saved: tran:v\\(out\\)"):
        res.waveform("v(in)")


def _bridge_mc():
    return """bridge Monte Carlo
.param rl={agauss(1k, 50, 1)} cf={agauss(100u, 5u, 1)}
V1 ac 0 DC 12 SIN(0 12 50)
RS ac acs 1
D1 acs pos dm
D2 0 pos dm
D3 neg acs dm
D4 neg 0 dm
C1 pos neg {cf}
RL pos neg {rl}
.model dm d(is=7n rs=0.05 n=1.8 cjo=10p tt=100n)
.tran 100u 40m
.meas tran ripple pp v(pos,neg) from=20m to=40m
"""


@pytest.fixture(scope="module")
def serial_bridge():
    res = netdae.sweep(_bridge_mc(), samples=8, save=["v(pos,neg)"], workers=1)
    assert res.failed == 0 and np.isfinite(res.waves[("tran", "v(pos,neg)")]).all()
    assert np.unique(res.measures["ripple"]).size == 8
    return res


def test_process_pool_gives_the_serial_results_bit_for_bit(serial_bridge):
    ctx = multiprocessing.get_context("spawn")
    with cf.ProcessPoolExecutor(2, mp_context=ctx) as pool:
        res = netdae.sweep(_bridge_mc(), samples=8, save=["v(pos,neg)"], executor=pool)
    np.testing.assert_array_equal(res.measures["ripple"], serial_bridge.measures["ripple"])
    np.testing.assert_array_equal(res.waves[("tran", "v(pos,neg)")], serial_bridge.waves[("tran", "v(pos,neg)")])
    forked = netdae.sweep(_bridge_mc(), samples=8, save=["v(pos,neg)"], workers=2)
    assert forked.stats["executor"] == "ProcessPoolExecutor"
    np.testing.assert_array_equal(forked.measures["ripple"], serial_bridge.measures["ripple"])


@pytest.mark.slow
def test_dask_local_cluster_gives_the_serial_results_bit_for_bit(serial_bridge):
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) \
            as cluster, distributed.Client(cluster) as client:
        res = netdae.sweep(_bridge_mc(), samples=8, save=["v(pos,neg)"], executor=client.get_executor())
    np.testing.assert_array_equal(res.measures["ripple"], serial_bridge.measures["ripple"])
    np.testing.assert_array_equal(res.waves[("tran", "v(pos,neg)")], serial_bridge.waves[("tran", "v(pos,neg)")])


# -- failures, interruption, bad input ----------------------------------------------------------
def test_a_measure_that_fails_says_why_in_every_row():
    text = DIVIDER + ".meas dc never when v(b)=100\n.step param r2 list 1k -1k 2k\n"
    res = netdae.sweep(text, workers=1)
    assert res.failed == 0
    assert np.isnan(res.measures["never"]).all() and all(res.reasons["never"])
    np.testing.assert_allclose(res.measures["vb"], [1.0, -1.0, 2.0], rtol=1e-9)


def test_a_row_that_cannot_run_does_not_lose_the_sweep():
    text = "zero\n.param r=1k\nV1 a 0 1\nR1 a b {r}\nR2 b 0 1k\n.dc V1 0 1 0.5\n.meas dc ib find i(v1) at=1\n"
    res = netdae.sweep(text, params={"r": [2e3, 0.0, 1e3]}, workers=1)
    assert res.failed == 1 and "zero resistance" in res.errors[1] and res.errors[0] is None
    np.testing.assert_allclose(res.measures["ib"][[0, 2]], [-1 / 3e3, -1 / 2e3], rtol=1e-9)
    assert np.isnan(res.measures["ib"][1]) and "zero resistance" in res.reasons["ib"][1]
    assert res.failures() == {res.errors[1]: 1} and "1 of 3 rows failed" in res.notes[0]
    assert res.table()[1]["error"] == res.errors[1]


def test_interrupt_keeps_the_finished_rows():
    from netdae.sweeps.api import SERIAL_CHUNK

    def progress(done, total):
        raise KeyboardInterrupt  # Ctrl-C after the first chunk

    with pytest.raises(KeyboardInterrupt) as exc:
        netdae.sweep(MC, samples=SERIAL_CHUNK + 5, workers=1, progress=progress)
    res = exc.value.result
    assert res.stats["completed"] == SERIAL_CHUNK and res.failed == 5
    assert np.isfinite(res.measures["va"][:SERIAL_CHUNK]).all() and np.isnan(res.measures["va"][-5:]).all()
    assert res.errors[-1].startswith("not run") and "interrupted" in res.notes[0]


def test_interrupt_inside_a_chunk_keeps_the_rows_it_finished(monkeypatch):
    """Ctrl-C in the third row of a chunk run in this process: the first two are kept (the chunk's list was
    lost with the interrupt)."""
    import netdae.sweeps.worker as worker

    real, calls = worker.run_row, []

    def interrupted(job, row):
        calls.append(row.index)
        if len(calls) == 3:
            raise KeyboardInterrupt
        return real(job, row)

    monkeypatch.setattr(worker, "run_row", interrupted)
    with pytest.raises(KeyboardInterrupt) as exc:
        netdae.sweep(MC, samples=5, workers=1)
    res = exc.value.result
    assert res.stats["completed"] == 2 and res.failed == 3
    assert np.isfinite(res.measures["va"][:2]).all() and np.isnan(res.measures["va"][2:]).all()
    assert "interrupted: 2 of 5 rows finished, 3 not run" in res.notes[0]


#: A sweep of fast rows (tend=1u) and then slow ones (10 ms of 1 ns steps: seconds each), printing its
#: progress (rows done) on stdout so that the test interrupts it once the fast rows are done.
_SLOW = "slow rows\n.param tend=1u\nV1 in 0 SIN(0 1 1meg)\nR1 in out 1k\nC1 out 0 1n\n.tran 1n {tend}\n" \
        ".meas tran vmax max v(out)\n.end\n"
_REPORTING = """
import signal
import sys
# a command started from a terminal: Ctrl-C raises KeyboardInterrupt (a test run in the background by a shell
# without job control inherits SIGINT ignored, and Python then leaves it ignored)
signal.signal(signal.SIGINT, signal.default_int_handler)
import netdae.cli.sweep as command
class Reporting(command._Progress):
    def __call__(self, done, total):
        print("done", done, flush=True)
command._Progress = Reporting
from netdae.cli import main
sys.exit(main(sys.argv[1:]))
"""


@pytest.mark.skipif(not hasattr(__import__("os"), "killpg") or "fork" not in multiprocessing.get_all_start_methods(),
                    reason="POSIX process groups")
def test_ctrl_c_stops_the_running_workers_and_writes_the_finished_rows(tmp_path):
    """Ctrl-C (SIGINT to the process group, as a terminal sends it) while two workers run rows of seconds: the
    sweep stops within a few seconds, not when those rows end, and writes the six rows finished (the sixth
    finished inside a task whose second row was running), the four others as not run, and says so."""
    import os
    import signal
    import subprocess
    import sys
    import time

    path = tmp_path / "slow.cir"
    path.write_text(_SLOW)
    values = ",".join(["1u"] * 6 + ["10m"] * 4)
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1"}
    proc = subprocess.Popen([sys.executable, "-c", _REPORTING, "sweep", str(path), "--out", str(tmp_path / "out"),
                             "--step", f"tend={values}", "--workers", "2", "--no-plot"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env, start_new_session=True)
    try:
        # rows 0 (here, before the pool) and 1-4 (two tasks of two) are reported; row 5 shares a task with row 6
        for line in proc.stdout:
            if line.startswith("done") and int(line.split()[1]) >= 5:
                break
        time.sleep(0.5)  # row 5 (microseconds of circuit time) ends; rows 6 and 7 run for seconds
        sent = time.monotonic()
        os.killpg(proc.pid, signal.SIGINT)
        out, err = proc.communicate(timeout=60)
        elapsed = time.monotonic() - sent
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
    assert proc.returncode == 130, err
    assert elapsed < 6.0, elapsed
    assert "interrupted: 6 of 10 rows finished, 4 not run" in err and "Traceback" not in err
    rows = (tmp_path / "out" / "measures.csv").read_text().splitlines()
    assert len(rows) == 11
    assert sum("not run" in r for r in rows[1:]) == 4 and all("not run" not in r for r in rows[1:7])


class _LosingExecutor(cf.Executor):
    """Runs tasks in this process, but the second task's worker is lost (killed, or its cluster gone)."""

    def __init__(self, lost: BaseException) -> None:
        self.lost, self.calls = lost, 0

    def submit(self, fn, /, *args, **kwargs):
        fut = cf.Future()
        self.calls += 1
        if self.calls == 2:
            fut.set_exception(self.lost)
        else:
            fut.set_result(fn(*args, **kwargs))
        return fut


@pytest.mark.parametrize("lost, reason", [
    (cf.process.BrokenProcessPool("A process in the process pool was terminated abruptly"),
     "a worker process ended abruptly (killed, or out of memory)"),
    (OSError("Timed out trying to connect to tcp://127.0.0.1:8786"),
     "the task failed on its worker: OSError: Timed out trying to connect"),
    (MemoryError(), "the worker ran out of memory"),
])
def test_a_lost_worker_fails_its_rows_and_keeps_the_others(lost, reason):
    """A worker killed (the out-of-memory killer) or a cluster gone: those rows failed, never a lost sweep."""
    res = netdae.sweep(MC, samples=12, executor=_LosingExecutor(lost))
    lost_rows = [k for k, e in enumerate(res.errors) if e is not None]
    assert 0 < len(lost_rows) < 12 and all(reason in res.errors[k] for k in lost_rows)
    assert all(res.errors[k].startswith("not run") and "hint:" in res.errors[k] for k in lost_rows)
    kept = [k for k in range(12) if k not in lost_rows]
    serial = netdae.sweep(MC, samples=12, workers=1)
    np.testing.assert_array_equal(res.measures["va"][kept], serial.measures["va"][kept])
    assert np.isnan(res.measures["va"][lost_rows]).all()
    assert f"{len(lost_rows)} of 12 rows failed" in res.notes[0] and reason in res.notes[0]


def test_a_row_out_of_memory_is_a_failed_row(monkeypatch):
    """MemoryError in one row is that row's failure; the rows after it still run."""
    import netdae.analyses.runner as runner

    real, calls = runner.run, []

    def run(circuit, **kwargs):
        calls.append(1)
        if len(calls) == 2:
            raise MemoryError
        return real(circuit, **kwargs)

    monkeypatch.setattr(runner, "run", run)
    res = netdae.sweep(MC, samples=3, workers=1)
    assert res.failed == 1 and res.errors[1].startswith("out of memory") and "hint:" in res.errors[1]
    assert np.isfinite(res.measures["va"][[0, 2]]).all()


@pytest.mark.parametrize("kwargs, message", [
    ({"samples": 5}, r"draws nothing"),
    ({"params": {"nope": [1]}}, r"'nope' is neither a top-level .param"),
    ({"params": {"rr2": [1]}}, r"hint: did you mean r2\? name a .param, an element"),
    ({"params": {"r2": []}}, r"no values"),
    ({"params": {"r2": ["x"]}}, r"must be numbers"),
    ({"seed": -1}, r"seed: a seed is an integer from 0 to 18446744073709551615, not -1"),
    ({"seed": 2**64}, r"seed: a seed is an integer from 0 to 18446744073709551615, not 18446744073709551616"),
    ({"save": ["v(zz)"]}, r"no node 'zz'"),
    ({"analyses": ["sens"]}, r"unknown analysis 'sens'"),
    ({"workers": 0}, r"workers must be a positive integer"),
    ({"params": {"r1": [1e3]}, "samples": 0}, r"samples must be a positive integer"),
    ({"params": "r2"}, r"params must be a mapping"),
    ({"params": {"r2": [1e3]}, "analyses": ["ac"]}, r"the netlist has no ac analysis \(it has: dc\)"),
])
def test_bad_sweep_arguments(kwargs, message):
    with pytest.raises(NetdaeError, match=message):
        netdae.sweep(DIVIDER, **kwargs)


@pytest.mark.parametrize("kwargs, message", [
    ({"params": {"r2": [1e3]}, "save": 3}, r"save must be a string or a list of strings, not int"),
    ({"params": {"r2": [1e3]}, "measures": [None]}, r"measures must hold strings, not NoneType"),
])
def test_sweep_arguments_of_the_wrong_type(kwargs, message):
    """Argument types are checked as netdae.run checks them (one rule: netdae.analyses.runner.string_entries)."""
    with pytest.raises(TypeError, match=message):
        netdae.sweep(DIVIDER, **kwargs)


def test_one_string_is_one_entry():
    """measures=, save= and analyses= given as one string are one entry, not its characters."""
    res = netdae.sweep(DIVIDER, params={"r2": [1e3, 3e3]}, measures="dc vb2 find v(b) at=1m", save="v(b)",
                       analyses="dc", workers=1)
    np.testing.assert_allclose(res.measures["vb2"], [1.0, 3.0], rtol=1e-9)  # 1 mA through r2
    assert res.waves[("dc", "v(b)")].shape[0] == 2


def test_nothing_to_record_and_bad_measures():
    with pytest.raises(NetdaeError, match="nothing to record"):
        netdae.sweep("t\nV1 a 0 1\nR1 a 0 1k\n.op\n")
    with pytest.raises(NetlistError, match="<measures>:1"):
        netdae.sweep(DIVIDER, measures=["dc x find v(nowhere) at=1m"])


def test_tables_and_arrays():
    res = netdae.sweep(RC, params={"c": [1e-6, 2e-6]}, save=["v(out)"], workers=1)
    assert repr(res) == "<SweepResult 2 rows (c x2); measures: t63; 1 waveform; 0 failed>"
    frame = res.to_pandas()
    assert list(frame.columns) == ["c", "t63", "error"] and len(frame) == 2
    ds = res.to_xarray()
    assert ds["v(out)"].shape == (2, 61) and list(ds["c"].values) == [1e-6, 2e-6]
    doc = res.to_dict()
    assert doc["summary"]["t63"]["count"] == 2 and json.dumps(doc)


def test_a_seed_gives_the_same_draws_from_the_options_card_and_from_the_sweep(tmp_path, capsys):
    # .options seed=12345678901234567 was read through a float (...568) while seed= kept the integer
    seed = 12345678901234567
    text = ("mc\n.param r=agauss(1k,100,1)\nV1 in 0 1\nR1 in out {r}\nR2 out 0 1k\n.tran 1u 10u\n"
            ".meas tran x find v(out) at=10u\n")
    card = netdae.sweep(text + f".options seed={seed}\n", samples=4, workers=1)
    given = netdae.sweep(text, samples=4, seed=seed, workers=1)
    assert card.seed == given.seed == seed
    assert card.measures["x"].tobytes() == given.measures["x"].tobytes()
    other = netdae.sweep(text, samples=4, seed=seed + 1, workers=1).measures["x"]
    assert np.all(np.isfinite(other)) and not np.array_equal(other, given.measures["x"])
    r = 1e3 + 100 * np.array([generator((seed, k)).standard_normal() for k in range(4)])
    np.testing.assert_allclose(given.measures["x"], 1e3 / (r + 1e3), rtol=1e-9)  # the divider of each draw
    path = tmp_path / "mc.cir"
    path.write_text(text)
    assert cli(["sweep", str(path), "--workers", "1", "--out", str(tmp_path / "o"), "--no-plot", "--mc", "4",
                "--seed", str(seed)]) == 0
    doc = json.loads((tmp_path / "o" / "measures.json").read_text())
    assert doc["seed"] == seed and [row["x"] for row in doc["rows"]] == given.measures["x"].tolist()


# -- command line ----------------------------------------------------------------------------------
def test_cli_sweep_writes_the_table_json_and_plot(tmp_path, capsys):
    path = tmp_path / "mc.cir"
    path.write_text(MC)
    status = cli(["sweep", str(path), "--mc", "20", "--seed", "3", "--workers", "1", "--out", str(tmp_path / "o"),
                  "--step", "i1=1m,2m", "--save", "v(a)", "--waveforms"])
    assert status == 0
    out = capsys.readouterr().out
    assert "40 rows" in out and re.search(r"^va\s+40\s", out, re.M)
    lines = (tmp_path / "o" / "measures.csv").read_text().splitlines()
    assert lines[0] == "row,i1,sample,va,error" and len(lines) == 41
    doc = json.loads((tmp_path / "o" / "measures.json").read_text())
    assert doc["seed"] == 3 and doc["summary"]["va"]["count"] == 40
    assert (tmp_path / "o" / "sweep.png").stat().st_size > 0
    data = np.load(tmp_path / "o" / "waveforms.npz")
    assert data["dc:v(a)"].shape == (40, 3)


def test_cli_sweep_keeps_why_a_measurement_failed_in_a_row_that_ran(tmp_path, capsys):
    # v(b) = 1m * r2 at the last point: 0.5, 1, 2 V; WHEN v(b)=1.5 happens only for r2 = 2k (at 0.75 mA)
    path = tmp_path / "d.cir"
    path.write_text(DIVIDER + ".meas dc ihalf when v(b)=1.5\n.step param r2 list 0.5k 1k 2k\n")
    assert cli(["sweep", str(path), "--workers", "1", "--out", str(tmp_path / "o"), "--no-plot"]) == 0
    err = capsys.readouterr().err
    assert "measure ihalf failed in 2 of 3 rows: 2 x WHEN: v(b) never crosses 1.5" in err
    doc = json.loads((tmp_path / "o" / "measures.json").read_text())
    assert doc["failed"] == 0 and doc["measure_failures"] == {"ihalf": {"WHEN: v(b) never crosses 1.5 in [0, 0.001]": 2}}
    assert [row.get("reasons") for row in doc["rows"]] == [
        {"ihalf": "WHEN: v(b) never crosses 1.5 in [0, 0.001]"}] * 2 + [None]
    assert doc["rows"][2]["ihalf"] == pytest.approx(0.75e-3, rel=1e-12)


def test_cli_sweep_json_is_strict_json_when_a_measure_failed_in_every_row(tmp_path, capsys):
    """A statistic of a measure that failed in every row is null on stdout as in measures.json, not NaN
    (which JSON does not have: strict parsers refuse it)."""
    path = tmp_path / "d.cir"
    path.write_text(DIVIDER + ".meas dc never when v(b)=99\n.step param r2 list 0.5k 1k\n")
    assert cli(["sweep", str(path), "--workers", "1", "--out", str(tmp_path / "o"), "--no-plot", "--json"]) == 0

    def refuse(constant):
        raise ValueError(f"not JSON: {constant}")

    doc = json.loads(capsys.readouterr().out, parse_constant=refuse)
    assert doc["summary"]["never"]["count"] == 0 and doc["summary"]["never"]["mean"] is None


def test_cli_sweep_runs_only_the_noise_analysis_when_asked(tmp_path, capsys):
    path = tmp_path / "n.cir"
    path.write_text("noise of a divider\nV1 a 0 dc 1 ac 1\nR1 a b {r}\nR2 b 0 1k\n.param r=1k\n.op\n"
                    ".noise v(b) V1 dec 2 1k 10k\n.step param r list 1k 4k\n.end\n")
    assert cli(["sweep", str(path), "--workers", "1", "--out", str(tmp_path / "o"), "--no-plot",
                "--analysis", "noise"]) == 0
    doc = json.loads((tmp_path / "o" / "measures.json").read_text())
    # the output noise of R1 || R2 at 300.15 K: sqrt(4 k T R1 R2 / (R1 + R2)) over 1k..10k
    k, temp = 1.380649e-23, 300.15
    for row, r in zip(doc["rows"], (1e3, 4e3)):
        expected = math.sqrt(4 * k * temp * r * 1e3 / (r + 1e3) * 9e3)
        assert row["onoise_total"] == pytest.approx(expected, rel=1e-6)


def test_cli_sweep_prints_the_summary_when_its_files_cannot_be_written(tmp_path, capsys, monkeypatch):
    from netdae.errors import OutputFileError
    import netdae.io.sweep as io_sweep

    def full(out, result, waveforms=False):
        raise OutputFileError(str(out / "measures.json"), "the disk is full")

    monkeypatch.setattr(io_sweep, "write_sweep", full)
    path = tmp_path / "d.cir"
    path.write_text(DIVIDER + ".step param r2 list 1k 3k\n")
    assert cli(["sweep", str(path), "--workers", "1", "--out", str(tmp_path / "o")]) == 2
    captured = capsys.readouterr()
    assert re.search(r"^vb\s+2\s+2\s+1\.414\s+1\s+3$", captured.out, re.M)  # v(b) = 1 mA * r2: 1 V and 3 V
    assert "measures.json: the disk is full" in captured.err and "bug in netdae" not in captured.err
    assert not (tmp_path / "o" / "sweep.png").exists()


@pytest.mark.parametrize("argv, message", [
    (["--step", "r1"], "expected NAME=SPEC"),
    (["--step", "r1=1:2:-1"], "does not lead"),
    (["--mc", "0"], "positive integer"),
    (["--seed", "-2"], "argument --seed: a seed is an integer from 0 to 18446744073709551615, not -2"),
    (["--seed", "1.5"], "argument --seed: a seed is an integer from 0 to 18446744073709551615, not '1.5'"),
    (["--seed", "18446744073709551616"], "not 18446744073709551616"),
    (["--step", "r2=1k,abc"], "argument --step: r2=1k,abc: expected a number, got 'abc'"),
    # numbers a netlist would refuse or warn about: 1e999 was inf ('not finite (inf)' after the parse), 1e-999 a
    # zero resistance in every row, 1k2 a silent 1000
    (["--step", "r2=1e999"], "argument --step: r2=1e999: '1e999' is out of range (beyond a double)"),
    (["--step", "r2=1:1e-999:1"], "argument --step: r2=1:1e-999:1: '1e-999' is out of range (beyond a double)"),
    (["--step", "r2=1k2,2k"], "argument --step: r2=1k2,2k: expected a number, got '1k2' ('2' after the number "
                              "would be ignored)"),
])
def test_cli_sweep_usage_errors(tmp_path, capsys, argv, message):
    path = tmp_path / "d.cir"
    path.write_text(DIVIDER)
    assert cli(["sweep", str(path), "--out", str(tmp_path / "o"), *argv]) == 2
    assert message in capsys.readouterr().err


RLC_MC = """series RLC band-pass, Monte Carlo
.param r={agauss(50, 2.5, 1)} l={agauss(10m, 0.5m, 1)} c={agauss(1u, 0.05u, 1)}
V1 in 0 DC 0 AC 1
R1 in a {r}
L1 a b {l}
C1 b out {c}
R2 out 0 50
.ac dec 50 100 100k
.meas ac peak max vm(out)
.meas ac fpk max vm(out)
.meas ac fhi when vm(out)=0.3535533906 fall=1
"""


def test_linear_ac_rows_solved_together_equal_the_ordinary_path_and_the_closed_form(monkeypatch):
    import netdae.sweeps.linear as linear

    ordinary = []
    real = linear.run_row
    monkeypatch.setattr(linear, "run_row", lambda job, row: ordinary.append(row.index) or real(job, row))
    res = netdae.sweep(RLC_MC, samples=12, save=["v(out)"], workers=1)
    assert res.failed == 0
    assert ordinary == [0]  # the first row of the chunk; the others solved together
    c = load(RLC_MC)
    freqs, w = res.waveform("v(out)")
    for k in (0, 5, 11):
        one = netdae.run(c.variant(sample=k))[0]
        np.testing.assert_allclose(w[k], one["v(out)"], rtol=1e-11, atol=1e-15)
        assert res.measures["fhi"][k] == pytest.approx(one.measures[2].value, rel=1e-12)
        el = {e.name: e.value for e in c.variant(sample=k).elements}
        s = 2j * np.pi * freqs
        closed = el["r2"] / (el["r1"] + el["r2"] + s * el["l1"] + 1 / (s * el["c1"]))
        np.testing.assert_allclose(w[k], closed, rtol=1e-9)


def test_plots_draw_a_histogram_per_point_and_a_curve_per_row():
    from netdae.plotting import plot_sweep

    mc = netdae.sweep(MC, samples=10, params={"i1": [1e-3, 2e-3]}, workers=1)
    ax = plot_sweep(mc).axes[0]
    assert ax.get_legend_handles_labels()[1] == ["i1=0.001", "i1=0.002"]
    assert sum(p.get_height() for p in ax.patches) == 20
    steps = netdae.sweep(RC, params={"c": [1e-6, 2e-6, 3e-6]}, save=["v(out)"], workers=1)
    ax = plot_sweep(steps).axes[0]
    assert [ln.get_label() for ln in ax.get_lines()] == ["c=1e-06", "c=2e-06", "c=3e-06"]


def test_cli_sweep_rows_are_kept_when_the_out_directory_fills_up(tmp_path, capsys, monkeypatch):
    """The rows ran, --out then takes no file (the disk is full): they go to a temporary directory, said so."""
    import errno
    import tempfile

    import netdae.io.sweep as io_sweep
    from netdae.errors import OutputFileError

    real, calls = io_sweep.write_sweep, []

    def write_sweep(out, result, **kwargs):
        calls.append(out)
        if len(calls) == 1:
            raise OutputFileError(str(out / "measures.csv"), "the disk is full", errno.ENOSPC)
        return real(out, result, **kwargs)

    monkeypatch.setattr(io_sweep, "write_sweep", write_sweep)
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path / "tmp"))
    (tmp_path / "tmp").mkdir()
    path = tmp_path / "mc.cir"
    path.write_text(MC)
    out = tmp_path / "out"
    assert cli(["sweep", str(path), "--mc", "3", "--workers", "1", "--out", str(out), "--no-plot"]) == 2
    err = capsys.readouterr().err
    (rescued,) = (tmp_path / "tmp").iterdir()
    assert f"cannot write {out / 'measures.csv'}: the disk is full; the rows were written to {rescued} instead" in err
    assert err.strip().splitlines()[-1] == f"netdae: error: cannot write {out / 'measures.csv'}: the disk is full"
    rows = (rescued / "measures.csv").read_text().splitlines()
    assert len(rows) == 4 and rows[0].startswith("row,")


def test_cli_sweep_says_when_the_scheduler_cannot_be_reached(tmp_path, capsys, monkeypatch):
    pytest.importorskip("distributed")
    import netdae.cli.sweep as cli_sweep

    monkeypatch.setattr(cli_sweep, "SCHEDULER_TIMEOUT", 1.0)
    path = tmp_path / "mc.cir"
    path.write_text(MC)
    assert cli(["sweep", str(path), "--mc", "3", "--scheduler", "tcp://127.0.0.1:1", "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert "cannot reach the Dask scheduler at tcp://127.0.0.1:1" in err and "hint: start one there" in err
    assert not (tmp_path / "measures.csv").exists()
    for address, message in (("foo", "--scheduler 'foo' is not an address Dask can read"),
                             ("", "--scheduler: the address is empty")):
        assert cli(["sweep", str(path), "--mc", "3", "--scheduler", address, "--out", str(tmp_path)]) == 2
        err = capsys.readouterr().err
        assert message in err and "tcp://host:8786" in err and "bug in netdae" not in err


@pytest.mark.parametrize("name, step, column", [
    ("r2", ".step param r2 list 1k 2k", "the swept param r2"),
    ("row", "", "the row number"), ("error", "", "why a row failed"), ("sample", "", "the Monte Carlo sample"),
])
def test_a_measure_named_like_a_column_of_the_table_is_a_located_error(name, step, column):
    # it overwrote the column: measures.csv lost the stepped values (r2 = 1k, 2k read back as the measure)
    text = DIVIDER + f"{step}\n.meas dc {name} find v(b) at=0.5m\n"
    params = None if step else {"r2": [1e3, 2e3]}
    with pytest.raises(NetlistError) as exc:
        netdae.sweep(text, params=params, workers=1)
    line = text.splitlines().index(f".meas dc {name} find v(b) at=0.5m") + 1
    assert (exc.value.location.line, exc.value.location.column) == (line, len(".meas dc ") + 1)
    assert f"column '{name}' ({column})" in exc.value.message and "rename" in exc.value.hint
    # added measures are checked too, at their place in <measures>
    with pytest.raises(NetlistError, match=r"<measures>:1:.*column 'r2'"):
        netdae.sweep(DIVIDER, params={"r2": [1e3, 2e3]}, measures=["dc r2 find v(b) at=0.5m"], workers=1)


def test_the_command_lines_analyses_are_the_sweeps():
    from netdae.cli.sweep import ANALYSES
    from netdae.sweeps.worker import SWEPT_ANALYSES

    assert ANALYSES == SWEPT_ANALYSES
