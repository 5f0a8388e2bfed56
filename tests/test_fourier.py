"""``.four``: Fourier components of transient signals over their last period (netdae.analyses.fourier).

Closed forms for sums of sines, ngspice's own printed table for a clipping diode, and the bad
inputs (a period longer than the run, a zero frequency, no signal, an unknown node).
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys

import numpy as np
import pytest

import netdae
from netdae.analyses.fourier import components
from netdae.errors import NetlistError
from netdae.fourier import format_fourier

#: A fundamental of 1 V on 0.25 V DC, a second harmonic of 0.05 V as a cosine and a third of 0.1 V as a
#: sine lagging 30 degrees; THD = 100 sqrt(0.05^2 + 0.1^2) = 11.18 %.
HARMONICS = """sum of harmonics
B1 a 0 V=0.25 + sin(2*pi*1k*time) + 0.05*cos(2*pi*2k*time) + 0.1*sin(2*pi*3k*time - pi/6)
R1 a 0 1k
.tran 1u 3m
.four 1k v(a)
.end
"""

#: A diode clipping a sine: distortion that ngspice's .four measures on the same netlist.
CLIPPER = """clipper
V1 a 0 SIN(0 1 1k)
R1 a b 1k
D1 b 0 dmod
.model dmod d(is=1e-14)
.tran 1u 5m
.four 1k v(b)
.end
"""


def test_the_sums_are_ngspices_on_a_sampled_period():
    t = np.arange(200) / 200
    mag, phase, nmag, nphase, thd = components(1.0 - 3.0 * np.cos(2 * np.pi * t) + 0.3 * np.sin(4 * np.pi * t))
    assert mag[:3] == pytest.approx([1.0, 3.0, 0.3], abs=1e-12)
    assert phase[1] == pytest.approx(-90.0) and phase[2] == pytest.approx(0.0, abs=1e-9)  # against a sine
    assert nmag[2] == pytest.approx(0.1) and nphase[2] == pytest.approx(90.0)
    assert thd == pytest.approx(10.0)
    # no fundamental: no normalised values, no THD (not a division by zero)
    mag, _, nmag, _, thd = components(np.full(200, 2.0))
    assert mag[0] == 2.0 and np.isnan(nmag[1]) and np.isnan(thd)


def test_a_transients_harmonics_against_their_closed_form():
    res = netdae.simulate(netdae.load(HARMONICS))
    assert res.ok, res.message
    (f,) = res.fourier
    assert f.ok and f.signal == "v(a)" and f.fundamental == 1e3 and f.gridsize == 200
    assert (f.start, f.stop) == pytest.approx((2e-3, 3e-3))
    assert f.frequency.tolist() == [1e3 * k for k in range(10)]
    np.testing.assert_allclose(f.magnitude[:4], [0.25, 1.0, 0.05, 0.1], atol=1e-6)
    np.testing.assert_allclose(f.magnitude[4:], 0.0, atol=1e-6)
    np.testing.assert_allclose(f.phase[1:4], [0.0, 90.0, -30.0], atol=1e-4)
    assert f.thd == pytest.approx(100 * np.hypot(0.05, 0.1), rel=1e-5)
    text = format_fourier(f)
    assert text.startswith("Fourier analysis for v(a):\n  No. Harmonics: 10, THD: 11.18")


def _ngspice_table(text: str) -> np.ndarray:
    rows = re.findall(r"^\s*(\d+)\s+([-+0-9.e]+)\s+([-+0-9.e]+)\s+([-+0-9.e]+)\s+([-+0-9.e]+)\s+([-+0-9.e]+)\s*$",
                      text, flags=re.M)
    return np.array([[float(v) for v in row[1:]] for row in rows])


def test_the_clippers_spectrum_agrees_with_ngspices_four(tmp_path, ngspice_exe):
    path = tmp_path / "clipper.cir"
    path.write_text(CLIPPER)
    out = subprocess.run([ngspice_exe, "-b", str(path)], capture_output=True, text=True, timeout=120).stdout
    table = _ngspice_table(out.split("Fourier analysis for v(b)", 1)[1])
    thd_ngspice = float(re.search(r"THD: ([0-9.e+-]+) %", out).group(1))
    assert table.shape == (10, 5)
    (f,) = netdae.simulate(netdae.load(CLIPPER)).fourier
    # ngspice interpolates its output points linearly (steps of at most 1 us here), netdae samples its
    # dense output: the magnitudes agree to 1e-5 of the fundamental, the THD to 1e-4 of itself
    np.testing.assert_allclose(f.magnitude, table[:, 1], rtol=0, atol=1e-5 * table[1, 1])
    assert f.thd == pytest.approx(thd_ngspice, rel=1e-4)
    strong = table[:, 1] > 1e-2 * table[1, 1]  # phases of the harmonics above 1 % (a phase of ~0 is noise)
    np.testing.assert_allclose(np.abs(f.phase[strong]), np.abs(table[strong, 2]), atol=0.05)


def test_a_period_longer_than_the_run_fails_with_its_reason():
    res = netdae.simulate(netdae.load(HARMONICS.replace(".tran 1u 3m", ".tran 1u 0.5m")))
    assert res.ok
    (f,) = res.fourier
    assert not f.ok and "period 0.001 s is longer than the transient's interval [0, 0.0005] s" in f.reason
    assert format_fourier(f).startswith("Fourier analysis for v(a): failed: ")
    assert f.to_dict() == {"signal": "v(a)", "fundamental": 1e3, "status": "failed", "reason": f.reason}


def test_a_period_below_the_resolution_of_time_fails_with_its_reason():
    """.four 1e300 (ngspice takes it and prints a table of noise) sampled one instant 200 times: the norm. magnitudes
    and the THD were nan in a table that looked like a result."""
    res = netdae.simulate(netdae.load(HARMONICS.replace(".four 1k", ".four 1e300")))
    (f,) = res.fourier
    assert res.ok and not f.ok
    assert ("its period 1e-300 s is too short to sample at t = 0.003 s: 200 points over it are not distinct times"
            in f.reason)


@pytest.mark.parametrize("card, message", [
    (".four 0 v(a)", r":5:7: \.four: the fundamental frequency must be positive, got 0"),
    (".four 1k", r":5:9: \.four: expected a signal after the frequency"),
    (".four", r":5:6: \.four: expected the fundamental frequency"),
    (".four 1k v(a", r"\.four: "),
])
def test_a_malformed_four_card_is_a_located_error(card, message):
    with pytest.raises(NetlistError, match=message):
        netdae.load(HARMONICS.replace(".four 1k v(a)", card))


def test_an_unknown_signal_is_left_out_with_a_warning_and_the_rest_analysed():
    circuit = netdae.load(HARMONICS.replace(".four 1k v(a)", ".fourier 1k v(nowhere) v(a)"))
    assert any("no node 'nowhere' (not kept)" in d.message for d in circuit.diagnostics)
    assert [f.signal for f in netdae.simulate(circuit).fourier] == ["v(a)"]


def test_run_keeps_the_signals_a_four_card_reads_and_the_cli_prints_and_writes_them(tmp_path):
    results = netdae.run(netdae.load(HARMONICS.replace("R1 a 0 1k", "R1 a b 1k\nR2 b 0 1k")), save=["v(b)"])
    (tran,) = [r for r in results if r.analysis == "tran"]
    assert [f.signal for f in tran.fourier] == ["v(a)"] and tran.fourier[0].ok
    path = tmp_path / "h.cir"
    path.write_text(HARMONICS)
    cli = subprocess.run([sys.executable, "-m", "netdae", "run", str(path), "--json", "--out", str(tmp_path / "o")],
                         capture_output=True, text=True, timeout=300, env={**os.environ, "NETDAE_SERVER": "0"})
    assert cli.returncode == 0, cli.stderr
    doc = json.loads(cli.stdout)
    (f,) = doc["fourier"]["values"]
    assert f["signal"] == "v(a)" and f["thd_percent"] == pytest.approx(11.18, abs=0.01)
    assert f["harmonics"][2]["phase_deg"] == pytest.approx(90.0, abs=1e-3)
    # the same numbers in fourier.csv, one row per harmonic
    assert doc["fourier"]["file"] == str(tmp_path / "o" / "fourier.csv")
    rows = (tmp_path / "o" / "fourier.csv").read_text().splitlines()
    assert rows[0].startswith("signal,fundamental,harmonic,frequency,magnitude,phase_deg") and len(rows) == 11
    cells = rows[3].split(",")  # the second harmonic
    assert cells[:3] == ["v(a)", "1000.0", "2"] and float(cells[5]) == pytest.approx(90.0, abs=1e-3)


def test_a_failed_transient_is_not_analysed():
    # a behavioural source whose law is unbounded at 1 ms: the run stops there, before the analysed period
    res = netdae.simulate(netdae.load(HARMONICS.replace("R1 a 0 1k", "R1 a 0 1k\nB2 b 0 V=1/(1m-time)\nR2 b 0 1k")
                                      .replace(".four 1k v(a)", ".four 1k v(a) v(b)")))
    assert not res.ok
    assert [f.status for f in res.fourier] == ["failed", "failed"]
    assert res.fourier[0].reason.startswith("the transient failed: ")


def test_options_nfreqs_and_fourgridsize_are_read_as_ngspice_reads_them(tmp_path, ngspice_exe):
    """ngspice's .options set the variables its .four reads: with nfreqs=15 fourgridsize=400 it prints 15
    harmonics on 400 samples. netdae warned 'unknown option (neither netdae nor ngspice 39 knows it;
    ngspice 39 ignores it)' and printed 10 on 200."""
    text = CLIPPER.replace(".tran", ".options nfreqs=15 fourgridsize=400\n.tran")
    path = tmp_path / "clipper.cir"
    path.write_text(text)
    out = subprocess.run([ngspice_exe, "-b", str(path)], capture_output=True, text=True, timeout=120).stdout
    table = _ngspice_table(out.split("Fourier analysis for v(b)", 1)[1])
    assert "No. Harmonics: 15" in out and "Gridsize: 400" in out and table.shape == (15, 5)
    circuit = netdae.load(text)
    assert not any("unknown option" in d.message for d in circuit.diagnostics)
    (f,) = netdae.simulate(circuit).fourier
    assert f.frequency.size == 15 and f.gridsize == 400
    np.testing.assert_allclose(f.magnitude, table[:, 1], rtol=0, atol=1e-5 * table[1, 1])
    # a value below 1 keeps ngspice's default
    (g,) = netdae.simulate(netdae.load(CLIPPER.replace(".tran", ".options nfreqs=0\n.tran"))).fourier
    assert g.frequency.size == 10 and g.gridsize == 200
