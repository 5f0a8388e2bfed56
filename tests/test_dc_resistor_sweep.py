""".dc over a resistor's value (ngspice's ``res-sweep``): the divider's closed form and ngspice 39's numbers.

ngspice 39 sweeps a resistor's resistance at ``tnom`` and applies its temperature
coefficients, ``scale`` and ``m`` at every point (measured: ``tc1=0.01`` at 50 degC
turns 1 kohm into 1.23 kohm); netdae re-assembles the circuit at each point with
the element's value replaced, so the same formulas apply.
"""

from __future__ import annotations

import re
import subprocess

import numpy as np
import pytest

import netdae
from netdae.errors import NetlistError
from netdae.netlist import load

DIVIDER = """divider
V1 a 0 1
R1 a b 1k
R2 b 0 1k {extra}
.dc r2 1k 3k 500 v1 1 2 1
.temp 50
.end
"""


@pytest.mark.parametrize("extra, effective", [
    ("", lambda r: r),
    ("tc1=0.01 tc2=1e-4 m=2", lambda r: r * (1 + 0.01 * 23 + 1e-4 * 23 ** 2) / 2),
    ("scale=2", lambda r: 2 * r),
])
def test_the_divider_follows_the_swept_resistance(extra, effective):
    r = next(x for x in netdae.run(load(DIVIDER.format(extra=extra))) if x.analysis == "dc")
    r2, v1 = r.axes["r2"], r.axes["v1"]
    assert r2.tolist() == [1000.0, 1500.0, 2000.0, 2500.0, 3000.0] * 2 and v1.tolist() == [1.0] * 5 + [2.0] * 5
    reff = effective(r2)
    np.testing.assert_allclose(r.v("b"), v1 * reff / (1000.0 + reff), rtol=1e-12)


@pytest.mark.ngspice
def test_ngspice_39_gives_the_same_values(tmp_path):
    text = DIVIDER.format(extra="tc1=0.01 tce=0.5 m=2").replace(".end", ".print dc v(b)\n.end")
    (tmp_path / "d.cir").write_text(text)
    out = subprocess.run(["ngspice", "-b", "d.cir"], capture_output=True, text=True, timeout=60, cwd=tmp_path).stdout
    ng = [float(m.group(2)) for m in re.finditer(r"^\s*(\d+)\s+\S+\s+(\S+)\s*$", out, re.M)]
    r = next(x for x in netdae.run(load(text)) if x.analysis == "dc")
    assert len(ng) == 10
    np.testing.assert_allclose(r.v("b"), ng, rtol=1e-6)  # ngspice prints 7 digits here


@pytest.mark.parametrize("card, message", [
    (".dc r2 -1k 1k 500", r"a resistance sweep from -1000 to 1000 reaches 0 ohm"),
    (".dc c1 1n 2n 1n", r"sweep source 'c1' is a capacitor"),
])
def test_bad_resistance_sweeps_are_located_errors(card, message):
    with pytest.raises(NetlistError, match=message) as err:
        load(f"t\nV1 a 0 1\nR1 a b 1k\nR2 b 0 1k\nC1 b 0 1n\n{card}\n.end\n")
    assert err.value.location.line == 6
