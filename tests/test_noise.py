"""Small-signal noise analysis (.noise): closed forms, ngspice's conventions, errors, ngspice itself."""

from __future__ import annotations

import math

import numpy as np
import pytest

import netdae
from netdae.analyses.noise import integrate_power_law
from netdae.errors import CircuitError, NetlistError
from netdae.netlist import load

K = 1.38064852e-23
Q = 1.6021766208e-19
T = 300.15  # 27 C


def noise_of(text: str, **kw):
    (res,) = [r for r in netdae.run(text, **kw) if r.analysis == "noise"]
    return res


# -- closed forms ----------------------------------------------------------------------------------------------------

def test_rc_lowpass_density_and_kt_over_c():
    r, c = 1e3, 1e-9
    res = noise_of(f"rc\nV1 in 0 dc 0 ac 1\nR1 in out {r}\nC1 out 0 {c}\n.noise v(out) v1 dec 20 1 1e12\n")
    f = res.axis
    w = 2 * np.pi * f * r * c
    expected = np.sqrt(4 * K * T * r / (1 + w * w))
    np.testing.assert_allclose(res["onoise_spectrum"], expected, rtol=1e-12)
    # the gain from V1 is the same low-pass: the input-referred density is R's own
    np.testing.assert_allclose(res["inoise_spectrum"], np.sqrt(4 * K * T * r), rtol=1e-12)
    # the integrated output noise is kT/C (the band reaches far above the corner 159 kHz)
    total = res.noise_totals["onoise_total"]
    assert total ** 2 == pytest.approx(K * T / c, rel=2e-3)
    assert res.noise.contributions["r1"]["share"] == pytest.approx(1.0)


def test_divider_is_the_parallel_resistance():
    r1, r2 = 1e3, 3e3
    res = noise_of(f"div\nV1 in 0 dc 1 ac 1\nR1 in out {r1}\nR2 out 0 {r2}\n.noise v(out) v1 lin 5 1k 5k\n")
    rp = r1 * r2 / (r1 + r2)
    np.testing.assert_allclose(res["onoise_spectrum"], math.sqrt(4 * K * T * rp), rtol=1e-12)
    gain = r2 / (r1 + r2)
    np.testing.assert_allclose(res["inoise_spectrum"], math.sqrt(4 * K * T * rp) / gain, rtol=1e-12)
    # white noise over 1k..5k: sqrt(4 k T Rp (5k - 1k))
    assert res.noise_totals["onoise_total"] == pytest.approx(math.sqrt(4 * K * T * rp * 4e3), rel=1e-12)
    assert res.noise.input_unit == "V"


def test_temperature_and_dtemp_of_resistors():
    res = noise_of("t\nI1 0 a dc 0 ac 1\nR1 a 0 1k dtemp=50\n.options temp=100\n.noise v(a) i1 oct 1 1 4\n")
    np.testing.assert_allclose(res["onoise_spectrum"], math.sqrt(4 * K * (373.15 + 50) * 1e3), rtol=1e-12)
    # ngspice ignores dtemp when temp= is given, and so does its resistor noise
    res = noise_of("t\nI1 0 a dc 0 ac 1\nR1 a 0 1k temp=50 dtemp=10\n.noise v(a) i1 oct 1 1 4\n")
    np.testing.assert_allclose(res["onoise_spectrum"], math.sqrt(4 * K * T * 1e3), rtol=1e-12)
    # an I source input: the input-referred noise is a current, 1/|Z| of the output's
    np.testing.assert_allclose(res["inoise_spectrum"], res["onoise_spectrum"] / 1e3, rtol=1e-12)
    assert res.noise.input_unit == "A"


def test_noiseless_resistor_and_flicker_of_a_resistor_model():
    res = noise_of("t\nI1 0 a dc 1m ac 1\nR1 a 0 1k noisy=0\nR2 a 0 1k rm l=10u w=2u\n"
                   ".model rm r kf=1e-20 af=2 ef=1.5 lf=1 wf=1 short=1u narrow=0.5u\n.noise v(a) i1 dec 2 1 100 1\n")
    assert "onoise_r1_thermal" not in res.signals and "onoise_r2_1overf" in res.signals
    f = res.axis
    current = 0.5e-3  # half of I1 through R2
    area = (10e-6 - 2e-6) * (2e-6 - 1e-6)
    flicker = 1e-20 * current ** 2 / area / f ** 1.5
    rp = 500.0  # R1 still conducts: the output impedance is 1k || 1k
    np.testing.assert_allclose(res["onoise_r2_1overf"], np.sqrt(flicker) * rp, rtol=1e-12)
    np.testing.assert_allclose(res["onoise_r2_thermal"], math.sqrt(4 * K * T / 1e3) * rp, rtol=1e-12)


def test_diode_shot_and_flicker_noise():
    res = noise_of("d\nI1 0 a dc 1m ac 1\nD1 a 0 dm\n.model dm d is=1e-14 n=1.2 kf=1e-15 af=1.3\n"
                   ".noise v(a) i1 dec 3 1 1meg 1\n")
    vd = float(res.operating_point["v(a)"][0])  # the operating point the analysis linearised at
    vte = 1.2 * K * T / Q
    i = 1e-14 * (math.exp(vd / vte) - 1) + 1e-12 * vd  # 1 mA to Newton's accuracy
    assert i == pytest.approx(1e-3, rel=1e-3)
    gd = 1e-14 / vte * math.exp(vd / vte) + 1e-12  # gmin in parallel, as ngspice's
    rd = 1.0 / gd
    f = res.axis
    np.testing.assert_allclose(res["onoise_d1_id"], math.sqrt(2 * Q * i) * rd, rtol=1e-9)
    np.testing.assert_allclose(res["onoise_d1_1overf"], np.sqrt(1e-15 * i ** 1.3 / f) * rd, rtol=1e-9)
    assert not np.any(res["onoise_d1_rs"])  # no RS
    # the input-referred noise of a current input: the noise current itself
    np.testing.assert_allclose(res["inoise_spectrum"], np.sqrt(2 * Q * i + 1e-15 * i ** 1.3 / f), rtol=1e-9)


def test_bjt_collector_shot_noise_dominates_a_common_emitter_stage():
    """At a grounded emitter and a low-impedance base, the collector's noise is 2 q Ic R_L^2 plus R_L's own."""
    res = noise_of("ce\nVCC vcc 0 5\nVB b 0 dc 0.65 ac 1\nRC vcc c 1k\nQ1 c b 0 qm\n.model qm npn is=1e-15 bf=100\n"
                   ".noise v(c) vb dec 1 10 100 1\n")
    vt = K * T / Q
    vbe = float(res.operating_point["v(b)"][0])
    vbc = vbe - float(res.operating_point["v(c)"][0])  # about -4 V: the reverse cubic, ngspice's
    cbe = 1e-15 * math.expm1(vbe / vt)
    cbc = -1e-15 * (1 + (3 * vt / (math.e * vbc)) ** 3)
    ic = cbe - cbc - cbc / 1.0 - 1e-12 * vbc  # BR = 1, GMIN across b-c
    rout = 1 / (1e-3 + 1e-12)  # RC, and GMIN from the collector to the held base
    np.testing.assert_allclose(res["onoise_q1_ic"], math.sqrt(2 * Q * ic) * rout, rtol=1e-8)
    np.testing.assert_allclose(res["onoise_rc"], math.sqrt(4 * K * T * 1e-3) * rout, rtol=1e-8)
    assert not np.any(res["onoise_q1_ib"])  # the base's noise current flows into the ideal source VB


def test_mosfet_channel_thermal_noise_is_eight_thirds_kt_gm():
    res = noise_of("m\nVDD d 0 5\nVG g 0 dc 2 ac 1\nM1 d g 0 0 nm l=1u w=10u\n.model nm nmos vto=1 kp=100u\n"
                   ".noise v(d) vg dec 1 10 100 1\n")
    gm = 100e-6 * 10 * (2 - 1)  # beta (vgs - vto) in saturation
    # the output is the ideal supply: the drain's noise current sees no impedance, so the output is v(d)=0:
    assert not np.any(res["onoise_m1_id"])
    res = noise_of("m\nVDD vdd 0 5\nVG g 0 dc 2 ac 1\nRD vdd d 1k\nM1 d g 0 0 nm l=1u w=10u\n"
                   ".model nm nmos vto=1 kp=100u\n.noise v(d) vg dec 1 10 100 1\n")
    # (the bulk-drain junction's GMIN parallels RD: 1e-9 relative)
    np.testing.assert_allclose(res["onoise_m1_id"], math.sqrt(8 / 3 * K * T * gm) * 1e3, rtol=1e-8)
    # referred to the gate: sqrt(8kT/(3 gm)) and RD's 4kT/RD / gm^2
    expected = math.sqrt(8 / 3 * K * T / gm + 4 * K * T / 1e3 / gm ** 2)
    np.testing.assert_allclose(res["inoise_spectrum"], expected, rtol=1e-8)


def test_power_law_integration_is_exact_for_power_laws():
    f = np.geomspace(1.0, 1e4, 9)
    for k in (0.0, -1.0, -2.0, 0.5, 1.3):
        density = 3e-17 * f ** k
        exact = 3e-17 * (math.log(1e4) if k == -1 else (1e4 ** (k + 1) - 1) / (k + 1))
        assert integrate_power_law(density[:, None], f).sum() == pytest.approx(exact, rel=1e-12)
    # a steep rise from nothing (a density at ngspice's floor, 1e-38) at 1 GHz stays finite (ngspice's
    # exponentials overflow there): the power law through the floor and 1e-18
    g = np.array([1e9, 1.2589e9])
    piece = integrate_power_law(np.array([[0.0], [1e-18]]), g)[0, 0]
    assert np.isfinite(piece) and 0 < piece < 1e-18 * (g[1] - g[0])


def test_summary_points_and_single_frequency():
    res = noise_of("t\nV1 in 0 dc 0 ac 1\nR1 in 0 1k\nR2 in out 1k\nC1 out 0 1u\n.noise v(out) v1 dec 10 1 1k 3\n")
    np.testing.assert_allclose(res.axis, np.geomspace(1.0, 1e3, 31)[::3], rtol=1e-12)
    assert any("every 3-th frequency" in n for n in res.notes)
    single = noise_of("t\nV1 in 0 dc 0 ac 1\nR1 in out 1k\nC1 out 0 1u\n.noise v(out) v1 lin 1 100 100\n")
    assert single.axis.tolist() == [100.0] and single.noise_totals == {}  # ngspice writes no integrated noise
    for sweep in ("lin 1 100 200", "lin 5 100 100", "dec 3 100 100"):
        single = noise_of(f"t\nV1 in 0 dc 0 ac 1\nR1 in out 1k\nC1 out 0 1u\n.noise v(out) v1 {sweep}\n")
        assert single.axis.tolist() == [100.0] and single.noise_totals == {}, sweep


@pytest.mark.parametrize("summary", ["31", "1e99"])
def test_a_summary_beyond_the_sweep_keeps_the_first_frequency(summary):
    """ngspice writes the first frequency's spectra for a pts_per_summary not below the point count; 1e99 was an
    OverflowError reported as a bug in netdae (numpy's modulus holds no integer that large)."""
    text = f"t\nV1 in 0 dc 0 ac 1\nR1 in out 1k\nC1 out 0 1u\n.noise v(out) v1 dec 10 1 1k {summary}\n"
    res = noise_of(text)
    assert res.axis.tolist() == [1.0] and set(res.noise_totals) >= {"onoise_total", "inoise_total"}
    every = noise_of(text.replace(f" {summary}\n", "\n"))
    assert res.noise_totals["onoise_total"] == pytest.approx(every.noise_totals["onoise_total"], rel=1e-12)
    assert any(f"is not below the sweep's 31 frequencies: the spectra hold the first one only" in n
               for n in res.notes), res.notes


def test_behavioural_sources_are_noiseless_and_switches_are_resistors():
    res = noise_of("b\nV1 in 0 dc 1 ac 1\nB1 out 0 V=2*V(in)\nR1 out 0 1k\n.noise v(out) v1 dec 1 1 10 1\n")
    assert not np.any(res["onoise_r1"])  # B1 is an ideal source across R1: nothing reaches the output
    assert "onoise_b1" not in res.signals
    res = noise_of("s\nV1 in 0 dc 0 ac 1\nVC c 0 1\nR1 in a 1k noisy=0\nS1 a 0 c 0 sm\n"
                   ".model sm sw vt=0.5 ron=100 roff=1meg\n.noise v(a) v1 dec 1 1 10 1\n")
    rp = 1 / (1 / 1e3 + 1 / 100)
    np.testing.assert_allclose(res["onoise_s1"], math.sqrt(4 * K * T / 100) * rp, rtol=1e-12)


def test_save_print_csv_raw_and_control_block(tmp_path):
    from netdae.io.csv import read_csv
    from netdae.io.raw import read_raw, write_raw

    text = ("t\nV1 in 0 dc 0 ac 1\nR1 in out 1k\nC1 out 0 1u\n.control\nnoise v(out) v1 dec 5 1 1k\n.endc\n"
            ".print noise onoise_spectrum\n.save v(out)\n.op\n.end\n")
    res, op = netdae.run(text)
    assert res.names() == ["onoise_spectrum"] and op.names() == ["v(out)"]
    write_raw(tmp_path / "n.raw", [res], binary=False)
    (back,) = read_raw(tmp_path / "n.raw")
    assert back.analysis == "noise" and back.noise_totals == res.noise_totals
    np.testing.assert_array_equal(back["onoise_spectrum"], res["onoise_spectrum"])
    assert read_csv  # the CSV side: test_command_line_writes_spectra_and_totals


def test_command_line_writes_spectra_and_totals(tmp_path):
    import os
    import subprocess
    import sys

    net = tmp_path / "rc.cir"
    net.write_text("rc\nV1 in 0 dc 0 ac 1\nR1 in out 1k\nC1 out 0 1u\n.noise v(out) v1 dec 5 1 1k\n.end\n")
    out = subprocess.run([sys.executable, "-m", "netdae", "run", str(net), "--out", str(tmp_path / "o")],
                         capture_output=True, text=True, env={**os.environ, "NETDAE_SERVER": "0"})
    assert out.returncode == 0, out.stderr
    assert "onoise_total = " in out.stdout
    from netdae.io.csv import read_csv

    totals = read_csv(tmp_path / "o" / "noise_total.csv")
    assert totals.analysis == "noise" and set(totals.noise_totals) == {"onoise_total", "inoise_total"}
    assert read_csv(tmp_path / "o" / "noise.csv").analysis == "noise"
    out = subprocess.run([sys.executable, "-m", "netdae", "check", str(net)], capture_output=True, text=True,
                         env={**os.environ, "NETDAE_SERVER": "0"})
    assert out.returncode == 0 and ".noise v(out) v1 dec 5 1 1000" in out.stdout, out.stdout + out.stderr


# -- bad input ----------------------------------------------------------------------------------------------------------

BASE = "t\nV1 in 0 dc 0 ac 1\nR1 in out 1k\nC1 out 0 1u\nI1 0 out 0\nR2 out 0 1k\n"


@pytest.mark.parametrize("card, message, at", [
    (".noise v(out) r1 dec 10 1 1k", r"input source 'r1' is a resistor, not an independent V or I source", "r1"),
    (".noise v(out) vx dec 10 1 1k", r"input source 'vx' names no element", "vx"),
    (".noise v(out) i1 dec 10 1 1k", r"input source 'i1' has no AC value", "i1"),
    (".noise v(nowhere) v1 dec 10 1 1k", r"output node 'nowhere' is not a node", "nowhere"),
    (".noise v(out,out) v1 dec 10 1 1k", r"identically zero", "out,"),
    (".noise v(out) v1 dec 10 0 1k", r"fstart must be > 0", " 0 1k"),
    (".noise v(out) v1 lin 10 -1 1k", r"fstart must be > 0", "-1"),
    (".noise v(out) v1 dec 0 1 1k", r"points must be a positive integer", "0 1 1k"),
    (".noise v(out) v1 dec 10 1k 1", r"fstop 1 is below fstart 1000", "1\n"),
    (".noise v(out) v1 dec 10 1 1k 1.5", r"pts_per_summary must be a non-negative integer", "1.5"),
    (".noise i(v1) v1 dec 10 1 1k", r"expected the output voltage v\(node\)", "i(v1)"),
    (".noise v(out) v1 log 10 1 1k", r"expected the sweep type dec, oct or lin", "log"),
    (".noise v(out) v1 dec 10 1", r"expected points, fstart, fstop", "\n"),
    (".noise v(out)", r"missing the input source", "\n"),
])
def test_bad_cards_are_located(card, message, at):
    with pytest.raises(NetlistError, match=message) as exc:
        load(BASE + card + "\n.end\n")
    column = (card + "\n").index(at) + 1 + (at[0] == " ")
    assert (exc.value.location.line, exc.value.location.column) == (7, column)


# -- against ngspice 39 ---------------------------------------------------------------------------------------------

RC = "rc\nV1 in 0 dc 0 ac 1\nR1 in out 1k\nR2 out 0 3k\nC1 out 0 1u\n.noise v(out) V1 dec 10 1 100k 1\n.end\n"
CE = """ce
VCC vcc 0 12
VIN in 0 dc 0 ac 1
RS in b1 600
C1 b1 b 10u
RB1 vcc b 47k
RB2 b 0 10k
RC vcc c 4.7k
RE e 0 1k
CE e 0 100u
Q1 c b e qmod area=1.5 m=2
CL c out 10u
RL out 0 100k
.model qmod NPN is=1e-15 bf=150 vaf=80 rb=200 rc=5 re=1 ikf=50m cje=5p cjc=2p tf=0.3n kf=1e-15 af=1.1
.noise v(out) VIN dec 4 10 100meg 1
.end
"""
MOS = """mos
VDD vdd 0 5
VG g 0 dc 1.5 ac 1
RD vdd d 10k
M1 d g s 0 nch l=2u w=20u m=2
RSS s 0 500
.model nch NMOS vto=0.7 kp=50u lambda=0.02 gamma=0.4 rd=30 rs=20 cgso=1n cgdo=1n kf=1e-25 af=1.3
.noise v(d) VG dec 4 10 1g 1
.end
"""
JFET = """jfet
VDD vdd 0 15
VIN in 0 dc 0 ac 1
RG in g 1meg
RD vdd d 3.3k
J1 d g s jmod area=1.5 m=2
RS s 0 470
CS s 0 100u
.model jmod NJF vto=-2 beta=1m lambda=0.01 rd=10 rs=15 cgs=3p cgd=1p kf=1e-16 af=1.0 {nlev}
.noise v(d) VIN dec 4 10 100meg 1
.end
"""
DIODE = """diode
V1 in 0 dc 5 ac 1
R1 in a 4.7k
D1 a 0 dx
C1 a 0 10n
.model dx D is=1e-14 n=1.5 rs=20 cjo=2p kf=1e-14 af=1.2
.noise v(a) V1 dec 5 1 100meg 1
.end
"""
RESISTOR = """resistor flicker
I1 0 a dc 1m ac 1
R1 a b 1k rmod l=10u w=2u dtemp=20
R2 b 0 2k rmod
C1 a 0 1u
.model rmod r kf=1e-20 af=1.7 ef=1.1 lf=0.9 wf=1.2 short=0.1u narrow=0.2u
.noise v(a) I1 dec 5 1 1meg 1
.end
"""


@pytest.mark.ngspice
@pytest.mark.parametrize("text", [RC, CE, MOS, JFET.format(nlev=""), JFET.format(nlev="nlev=3 gdsnoi=1.5"), DIODE,
                                  RESISTOR], ids=["rc", "ce", "mos", "jfet", "jfet-nlev3", "diode", "resistor"])
def test_matches_ngspice(text):
    """Every density (each generator's, with pts_per_summary 1) and every total within 1e-6 of ngspice 39's."""
    from netdae.ngspice import run_ngspice

    theirs = run_ngspice(text, backend="subprocess").result("noise")
    ours = noise_of(text)
    np.testing.assert_allclose(ours.axis, theirs.axis, rtol=1e-12)
    assert set(ours.names()) == set(theirs.names())
    for name in theirs.names():
        a, b = ours[name], theirs[name]
        floor = 1e-9 * np.max(np.abs(b))
        assert np.all(np.abs(a - b) <= 1e-6 * np.maximum(np.abs(b), floor)), name
    assert set(ours.noise_totals) == set(theirs.noise_totals)
    for name, value in theirs.noise_totals.items():
        assert ours.noise_totals[name] == pytest.approx(value, rel=1e-6, abs=1e-30), name


@pytest.mark.ngspice
def test_diode_series_resistance_noise_differs_from_ngspice_with_area_deliberately():
    """ngspice 39 counts area and m into RS's noise conductance twice (and m thrice); netdae 4kT area m/RS."""
    from netdae.ngspice import run_ngspice

    text = DIODE.replace("D1 a 0 dx", "D1 a 0 dx area=2 m=3")
    theirs = run_ngspice(text, backend="subprocess").result("noise")
    ours = noise_of(text)
    np.testing.assert_allclose(ours["onoise_d1_id"], theirs["onoise_d1_id"], rtol=1e-6)
    np.testing.assert_allclose(ours["onoise_d1_rs"] ** 2 * 2 * 3 * 3, theirs["onoise_d1_rs"] ** 2, rtol=1e-6)


@pytest.mark.ngspice
def test_compare_passes_and_pairs_cards_as_ngspice_runs_them():
    from netdae.comparison import compare

    from netdae.comparison.plot import comparison_figure

    comparison = compare(RC)
    item = comparison.analyses[0]
    assert item.analysis == "noise" and item.passed and item.points == 51
    fig = comparison_figure(comparison)  # densities drawn over decades; the totals have no curve
    assert fig.axes[0].get_xscale() == "log" and "onoise" in fig.axes[0].get_title() + fig.axes[2].get_title()
    names = {s.name for s in item.signals}
    assert {"onoise_spectrum", "inoise_spectrum", "onoise_total", "inoise_total", "onoise_r1_thermal"} <= names
    # ngspice 39 runs .noise cards last to first: each card is paired with its own result
    two = RC.replace(".end", ".noise v(in,out) V1 lin 3 10 30\n.end")
    first, second = compare(two).analyses
    assert first.passed and second.passed and (first.points, second.points) == (51, 3)


def test_compare_noise_at_the_frequencies_both_have():
    from netdae.comparison.header import Tolerance
    from netdae.comparison.smallsignal import compare_noise
    from netdae.metadata import NoiseInfo
    from netdae.results import Result

    f = np.array([1.0, 10.0, 100.0, 1000.0])
    nd = Result("noise", axes={"frequency": f}, signals={"onoise_spectrum": 1e-9 / np.sqrt(f)},
                noise=NoiseInfo(totals={"onoise_total": 2e-8, "inoise_total": 1.0}))
    ng = Result("noise", axes={"frequency": f[::2]}, signals={"onoise_spectrum": 1e-9 / np.sqrt(f[::2]) * (1 + 1e-4)},
                noise=NoiseInfo(totals={"onoise_total": 2e-8 * (1 + 2e-3), "inoise_total": 1.0}))
    item = compare_noise(nd, ng, tol=Tolerance(1e-3))
    assert item.points == 2 and any("at the 2 frequencies both have" in n for n in item.notes)
    by_name = {s.name: s for s in item.signals}
    assert by_name["onoise_spectrum"].passed and by_name["onoise_spectrum"].max_rel == pytest.approx(1e-4, rel=1e-3)
    assert not by_name["onoise_total"].passed and by_name["inoise_total"].passed
    assert not item.passed


def test_sweep_records_the_integrated_noise_per_row():
    res = netdae.sweep("rc\nV1 in 0 dc 0 ac 1\nR1 in out {r}\nC1 out 0 1n\n.param r=1k\n"
                       ".noise v(out) v1 dec 20 1 1e12\n", params={"r": [1e3, 4e3]}, workers=1)
    # kT/C whatever R is; the input-referred noise grows as sqrt(R)
    np.testing.assert_allclose(res.measures["onoise_total"] ** 2, K * T / 1e-9, rtol=2e-3)
    assert res.measures["inoise_total"][1] / res.measures["inoise_total"][0] == pytest.approx(2.0, rel=2e-3)


def test_a_resistor_model_without_noise_area_is_refused():
    with pytest.raises(CircuitError, match=r":3:1: r1: model rm leaves no noise area"):
        noise_of("t\nI1 0 a dc 1m ac 1\nR1 a 0 1k rm l=1u w=2u\n.model rm r kf=1e-20 short=1u\n"
                 ".noise v(a) i1 dec 1 1 10\n")
