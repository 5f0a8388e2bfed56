"""Instance parameters of R, C and L, numbers and titles, against ngspice 39.

Every key the reader accepts on an R, C or L card must act as in ngspice:
``ac=`` (the AC resistance), ``scale=``, ``dtemp=``, ``temp=`` (which makes
ngspice ignore ``dtemp=``), ``tc1=``, ``tc2=``, ``m=``; a coupling ``K`` sees the
temperature-corrected inductances. Each test runs the same netlist in ngspice
(``print`` with 12 digits) and in netdae and compares the values.
"""

from __future__ import annotations

import re
import subprocess
from pathlib import Path

import numpy as np
import pytest

import netdae
from netdae.netlist import load

pytestmark = pytest.mark.ngspice

#: ngspice prints 12 significant digits here; both solve the same small linear system.
RTOL = 1e-9


def ngspice_print(netlist: str, names: list[str], tmp_path: Path) -> dict[str, complex]:
    """Run ``netlist`` in ngspice and return the printed values of ``names``."""
    text = netlist.rstrip() + "\n.control\nset numdgt=12\nrun\nprint " + " ".join(names) + "\n.endc\n.end\n"
    cir = tmp_path / "p.cir"
    cir.write_bytes(text.encode("utf-8"))
    proc = subprocess.run(["ngspice", "-b", str(cir)], capture_output=True, text=True, timeout=60,
                          cwd=tmp_path)
    out: dict[str, complex] = {}
    for line in proc.stdout.splitlines():
        m = re.match(r"\s*(\S+) = (\S+?)(?:,(\S+))?\s*$", line)
        if m and m.group(1) in names:
            out[m.group(1)] = complex(float(m.group(2)), float(m.group(3) or 0.0))
    assert set(out) == set(names), proc.stdout + proc.stderr
    return out


def netdae_values(netlist: str, names: list[str]) -> dict[str, complex]:
    result = netdae.run(load(netlist))[0]
    return {name: complex(result.signals[name.replace("#branch", "")][-1]) for name in names}


def _agree(netlist: str, names: list[str], tmp_path: Path) -> None:
    ref = ngspice_print(netlist, names, tmp_path)
    got = netdae_values(netlist, [n.replace("#branch", "") for n in names])
    for name in names:
        key = name.replace("#branch", "")
        assert abs(got[key] - ref[name]) <= RTOL * abs(ref[name]) + 1e-15, (name, got[key], ref[name])


OP_RESISTORS = """resistor parameters
V1 1 0 1
V2 2 0 1
V3 3 0 1
V4 4 0 1
R1 1 0 1k scale=2 dtemp=10 tc1=0.01
R2 2 0 1k temp=50 dtemp=10 tc1=0.01 tc2=1e-4
R3 3 0 1k m=3 scale=0.5 tc=0.002, 1e-5 dtemp=-30
R4 4 0 1k ac=5k
.op
"""


def test_resistor_scale_dtemp_temp_in_op(tmp_path):
    # ac= must not change the operating point
    _agree(OP_RESISTORS, ["i(v1)", "i(v2)", "i(v3)", "i(v4)"], tmp_path)


AC_PARTITION = """resistor ac= in .ac
V1 in 0 dc 1 ac 1
R1 in out 1k ac=2k
R2 out 0 1k ac=3k scale=2 dtemp=5 tc1=0.01 m=2
C1 out 0 1n
R3 in x 1k
R4 x 0 1k
{analysis}
"""


@pytest.mark.parametrize("freq", [1e3, 1e5, 1e6])
def test_resistor_ac_value_used_by_ac_analysis(freq, tmp_path):
    _agree(AC_PARTITION.format(analysis=f".ac lin 1 {freq} {freq}"), ["v(out)", "v(x)"], tmp_path)


def test_resistor_ac_value_not_used_by_op(tmp_path):
    _agree(AC_PARTITION.format(analysis=".op"), ["v(out)"], tmp_path)


AC_CAP_IND = """capacitor and inductor parameters
V1 1 0 ac 1
C1 1 2 1u scale=3 dtemp=20 tc1=0.01 m=2
R1 2 0 100
V2 3 0 ac 1
L1 3 4 1m m=2 scale=3 dtemp=20 tc1=0.01
R2 4 0 1
V3 5 0 ac 1
C2 5 6 1u temp=80 dtemp=20 tc1=0.01 tc2=1e-4
R3 6 0 100
.ac lin 1 159.15494309189535 159.15494309189535
"""


def test_capacitor_and_inductor_scale_dtemp_in_ac(tmp_path):
    _agree(AC_CAP_IND, ["i(v1)", "i(v2)", "i(v3)"], tmp_path)


AC_COUPLED = """coupled inductors at another temperature
V2 3 0 ac 1
L2 3 4 1m m=2 scale=2 tc1=0.01 temp=127
R2 4 0 1
L3 5 0 4m dtemp=10 tc1=0.02
R3 5 0 1e9
K1 L2 L3 0.5
.ac lin 1 159.15494309189535 159.15494309189535
"""


def test_coupling_uses_temperature_corrected_inductances(tmp_path):
    _agree(AC_COUPLED, ["i(v2)", "v(5)"], tmp_path)


def test_coupling_factor_survives_temperature_correction():
    """tc1=0.01 at 127 C doubles both inductances; M/sqrt(L1 L2) must stay k (closed form)."""
    from netdae.mna import assemble

    c = load("k\nV1 1 0 1\nL1 1 0 1m tc1=0.01\nL2 2 0 1m tc1=0.01\nR2 2 0 1\nK1 L1 L2 0.5\n"
             ".options temp=127\n.op\n")
    system = assemble(c)
    E = system.E.toarray()
    i1, i2 = system.names.index("i(l1)"), system.names.index("i(l2)")
    assert E[i1, i1] == pytest.approx(2e-3, rel=1e-12)
    assert E[i2, i2] == pytest.approx(2e-3, rel=1e-12)
    assert E[i1, i2] / np.sqrt(E[i1, i1] * E[i2, i2]) == pytest.approx(0.5, rel=1e-12)


MICRO = """micro sign
V1 1 0 1
R1 1 0 2\u00b5
R2 1 0 3\u03bc
R3 1 0 {2\u00b5*1e6}
B1 2 0 V=2\u00b5F*1e6
R4 2 0 1k
.param p=5\u00b5
R5 1 0 {p*1e6}
.op
"""


def test_micro_sign_reads_as_ngspice(tmp_path):
    names = ["@r1[resistance]", "@r2[resistance]", "@r3[resistance]", "@r5[resistance]", "v(2)"]
    ref = ngspice_print(MICRO, names, tmp_path)
    c = load(MICRO)
    assert c.element("r1").value == pytest.approx(ref["@r1[resistance]"].real, rel=1e-12)
    assert c.element("r2").value == pytest.approx(ref["@r2[resistance]"].real, rel=1e-12)
    assert c.element("r3").value == pytest.approx(ref["@r3[resistance]"].real, rel=1e-12)
    assert c.element("r5").value == pytest.approx(ref["@r5[resistance]"].real, rel=1e-12)
    assert netdae_values(MICRO, ["v(2)"])["v(2)"] == pytest.approx(ref["v(2)"], rel=1e-12)


def test_latin1_micro_byte_reads_as_ngspice(tmp_path):
    text = b"latin-1 micro\nV1 1 0 1\nR1 1 0 2\xb5\n.op\n"
    ref = ngspice_print(text.decode("latin-1"), ["@r1[resistance]"], tmp_path)  # written back as UTF-8 µ
    path = tmp_path / "latin.cir"
    path.write_bytes(text)
    assert load(path).element("r1").value == pytest.approx(ref["@r1[resistance]"].real, rel=1e-12)


def test_bad_number_keeps_ngspice_reading_with_a_located_warning(tmp_path):
    text = "bad number\nV1 1 0 1\nR1 1 0 1.2.3k\n.op\n"
    ref = ngspice_print(text, ["@r1[resistance]"], tmp_path)
    c = load(text)
    assert c.element("r1").value == pytest.approx(ref["@r1[resistance]"].real, rel=1e-12)
    warnings = [d for d in c.diagnostics if d.severity == "warning"]
    assert len(warnings) == 1
    assert (warnings[0].location.line, warnings[0].location.column) == (3, 8)
    assert "'.3k' ignored" in warnings[0].message


@pytest.mark.parametrize("first, title", [(".title my circuit", "my circuit"), (".TITLE\tOther", "Other"),
                                          (".title", "")])
def test_title_card_on_the_first_line(first, title, tmp_path):
    text = f"{first}\nV1 1 0 1\nR1 1 0 1k\n.op\n"
    proc = subprocess.run(["ngspice", "-b", "/dev/stdin"], input=text + ".end\n", capture_output=True,
                          text=True, timeout=60, cwd=tmp_path)
    shown = re.search(r"Circuit: (.*)", proc.stdout).group(1).strip()
    c = load(text)
    assert c.title.lower() == shown.lower() == title.lower()
    assert [e.name for e in c.elements] == ["v1", "r1"]


def test_a_three_argument_limit_is_the_clamp_with_a_warning_about_ngspice():
    # ngspice 39: limit(2, -0.5, 0.8) in a .param is its Monte Carlo limit(nom, avar) (1.5 or 2.5), and
    # limit(v(x), -0.5, 0.8) in a B source is 0; netdae clamps, and says so where it is written
    from netdae.netlist import load

    c = load("t\n.param lp={limit(2, -0.5, 0.8)}\nV1 x 0 1\nB1 o 0 V=limit(v(x), -0.5, 0.8)\nR1 o 0 1k\n"
             "R2 x 0 {lp}\n.op\n.end\n")
    warned = [(d.location.line, d.message) for d in c.diagnostics if d.severity == "warning"]
    assert [line for line, _ in warned] == [2, 4]
    assert all("is the clamp in netdae, but not in ngspice 39" in text for _, text in warned)
    assert next(el for el in c.elements if el.name == "r2").value == 0.8
