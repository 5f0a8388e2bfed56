"""``netdae compare``: exit status, JSON, PNG, and the missing/failing ngspice cases.

The circuits are chosen so that the expected differences are known by hand:
an inverting amplifier whose ideal op-amp becomes a VCVS of gain A = 1e6 in
ngspice differs by the finite-gain factor 1/(1 + 11/A), i.e. 1.1e-5 relative.
"""

from __future__ import annotations

import json
import os
import stat

import pytest

import netdae
import netdae.ngspice as bridge
from netdae.cli import main

OPAMP_GAIN = bridge.OPAMP_GAIN
NOISE_GAIN = 11.0  # 1 + R2/R1 of the inverting amplifier below
#: Relative error of the finite-gain output, |(-10 V) / (1 + 11/A) - (-10 V)| / (10 V).
FINITE_GAIN_ERROR = (NOISE_GAIN / OPAMP_GAIN) / (1 + NOISE_GAIN / OPAMP_GAIN)

AMPLIFIER = """inverting amplifier
V1 in 0 DC 0.5
R1 in minus 1k
R2 minus out 10k
E1 out 0 0 minus opamp
.op
.dc V1 -1 1 0.5
.end
"""

BODE = """rc bode
V1 in 0 DC 0 AC 1
R1 in out 1k
C1 out 0 100n
.ac dec 10 10 100k
.end
"""


@pytest.fixture
def amplifier(tmp_path):
    path = tmp_path / "amp.cir"
    path.write_text(AMPLIFIER)
    return path


def run_cli(capsys, *argv):
    status = main(["compare", *map(str, argv)])
    out, err = capsys.readouterr()
    return status, out, err


@pytest.mark.ngspice
def test_pass_exit_status_and_table(amplifier, capsys):
    status, out, _ = run_cli(capsys, amplifier)
    assert status == 0
    assert "PASS" in out and ".op: pass" in out and ".dc: pass" in out
    assert "ideal op-amp written as a VCVS" in out  # the translation is listed
    lines = [line.split() for line in out.splitlines() if line.strip().startswith(("v(", "i("))]
    op_rows = lines[:5]
    assert op_rows[0][0] == "v(minus)"  # worst first: the virtual ground, against the floor


@pytest.mark.ngspice
def test_fail_exit_status_when_out_of_tolerance(amplifier, capsys):
    # the finite gain's 1.1e-5 relative error on v(out) exceeds 1e-6
    status, out, _ = run_cli(capsys, amplifier, "--tol", "1e-6", "--signals", "v(out)")
    assert status == 1 and "FAIL" in out


@pytest.mark.ngspice
def test_json_fields_and_finite_gain_error(amplifier, capsys):
    status, out, _ = run_cli(capsys, amplifier, "--json", "--exclude", "v(minus)")
    assert status == 0
    doc = json.loads(out)
    assert doc["pass"] is True and doc["tolerance_source"] == "default"
    assert doc["ngspice"]["version"].startswith("ngspice-") and doc["ngspice"]["backend"] in ("shared", "subprocess")
    assert any("ideal op-amp" in note for note in doc["ngspice"]["translations"])
    assert doc["ngspice"]["opamp_gain"] == OPAMP_GAIN
    op = next(a for a in doc["analyses"] if a["analysis"] == "op")
    assert op["excluded"] == ["v(minus)"]
    assert op["netdae_tolerances"]["reltol"] == 1e-3 and op["ngspice_tolerances"]["reltol"] == 1e-3
    out_row = next(s for s in op["signals"] if s["signal"] == "v(out)")
    assert out_row["netdae"] == pytest.approx(-5.0, rel=1e-12)
    assert out_row["max_rel"] == pytest.approx(FINITE_GAIN_ERROR, rel=1e-6)
    for key in ("max_abs", "max_rel", "rms", "at", "scale", "scale_from", "pass"):
        assert key in out_row
    dc = next(a for a in doc["analyses"] if a["analysis"] == "dc")
    assert dc["points"] == 5 and dc["axis"] == "v1"
    worst = dc["signals"][0]
    assert worst["at"]["v1"] in (-1.0, 1.0)  # the finite-gain error is largest at the ends


@pytest.mark.ngspice
def test_tight_uses_the_larger_gain(amplifier, capsys):
    status, out, _ = run_cli(capsys, amplifier, "--json", "--tight", "--signals", "v(out)")
    doc = json.loads(out)
    assert status == 0 and doc["tight"] is True and doc["ngspice"]["opamp_gain"] == 1e9
    assert doc["ngspice"]["options"]["reltol"] == 1e-6
    op = next(a for a in doc["analyses"] if a["analysis"] == "op")
    assert op["netdae_tolerances"]["reltol"] == 1e-6
    assert op["signals"][0]["max_rel"] == pytest.approx(NOISE_GAIN / 1e9, rel=1e-3)


@pytest.mark.ngspice
def test_png_written(tmp_path, capsys):
    netlist = tmp_path / "bode.cir"
    netlist.write_text(BODE)
    png = tmp_path / "out.png"
    status, _, err = run_cli(capsys, netlist, "--plot", png)
    assert status == 0 and f"wrote {png}" in err
    data = png.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 1000


@pytest.mark.ngspice
@pytest.mark.skipif(not os.path.exists("/dev/full") or not stat.S_ISCHR(os.stat("/dev/full").st_mode),
                    reason="no /dev/full device")
def test_a_plot_onto_a_full_disk_still_prints_the_comparison(tmp_path, capsys):
    netlist = tmp_path / "bode.cir"
    netlist.write_text(BODE)
    status, out, err = run_cli(capsys, netlist, "--plot", "/dev/full")
    assert status == 2 and "bug in netdae" not in err
    assert ".ac: pass" in out
    assert err.strip().splitlines()[-1] == "netdae: error: cannot write /dev/full: the disk is full"
    assert stat.S_ISCHR(os.stat("/dev/full").st_mode)  # written into, not replaced by the plot


@pytest.mark.ngspice
def test_operating_point_only_cannot_be_plotted(amplifier, tmp_path, capsys):
    op_only = tmp_path / "op.cir"
    op_only.write_text(AMPLIFIER.replace(".dc V1 -1 1 0.5\n", ""))
    status, _, err = run_cli(capsys, op_only, "--plot", tmp_path / "x.png")
    assert status == 2 and "nothing to plot" in err


@pytest.mark.ngspice
def test_ngspice_failure_is_reported_not_raised(tmp_path, capsys):
    # netdae knows pi in .param expressions; ngspice 39 (no compatibility mode) does not
    netlist = tmp_path / "pi.cir"
    netlist.write_text("pi\n.param w={2*pi*1k}\nV1 in 0 1\nR1 in out {w}\nR2 out 0 1k\n.op\n.end\n")
    # ngspice exits on this error: the subprocess backend keeps the shared library usable for other tests
    status, out, _ = run_cli(capsys, netlist, "--backend", "subprocess")
    assert status == 1
    assert "ngspice failed" in out and "pi" in out
    comparison = netdae.compare(netlist, backend="subprocess")
    assert comparison.passed is False and comparison.ngspice_error
    assert comparison.analyses[0].error == "ngspice failed on the netlist"


def test_missing_ngspice_gives_the_install_command(amplifier, capsys, monkeypatch):
    monkeypatch.setattr(bridge, "available", lambda: False)
    status, out, err = run_cli(capsys, amplifier)
    assert status == 2 and out == ""
    assert "apt-get install ngspice" in err and "Traceback" not in err


def test_bad_tolerance_is_an_error(amplifier, capsys):
    status, _, err = run_cli(capsys, amplifier, "--tol", "-1")
    assert status == 2 and "argument --tol: expected a positive number, got '-1'" in err


@pytest.mark.ngspice
def test_unknown_signal_is_an_error(amplifier, capsys):
    status, _, err = run_cli(capsys, amplifier, "--signals", "v(nowhere)")
    assert status == 2 and "v(nowhere)" in err


def test_a_netlist_that_cannot_be_read_is_said_as_every_command_says_it(tmp_path, capsys):
    """compare read the file itself first, with its own words ('cannot read netlist: No such file or directory')."""
    status, _, err = run_cli(capsys, tmp_path / "missing.cir")
    assert status == 2 and f"netlist file '{tmp_path / 'missing.cir'}' not found (hint: check the file name" in err
    status, _, err = run_cli(capsys, tmp_path)
    assert status == 2 and f"netlist file '{tmp_path}' is a directory" in err
    with pytest.raises(TypeError, match="source must be a file name or netlist text, not NoneType"):
        netdae.compare(None)


def test_netdae_compare_is_the_function_whatever_the_import_order():
    import netdae.comparison as package

    assert netdae.compare is package.compare
    assert callable(netdae.compare)
