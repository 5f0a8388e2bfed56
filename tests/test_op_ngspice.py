"""The operating point of every linear netlist agrees with ngspice to 1e-9 relative.

A linear circuit's operating point is one sparse solve in both simulators, so
they must agree to rounding: 1e-9 of each value, or 1e-9 of the largest value
of the same kind (volts or amperes) for values that are zero in exact
arithmetic (an op-amp's virtual ground). netdae's ideal op-amp becomes a VCVS
of gain 1e12 for ngspice, whose finite-gain error (about noise gain / 1e12) is
far below that.
"""

from __future__ import annotations

import re

import numpy as np
import pytest

import netdae
from netdae.analyses.op import operating_point
from netdae.kinds import STAMPED_KINDS

from conftest import NETLISTS

#: Gain of the ideal op-amp's VCVS in ngspice for this comparison.
OPAMP_GAIN = 1e12
REL = 1e-9


def _linear(path) -> bool:
    return all(el.kind in STAMPED_KINDS for el in netdae.load(path).elements)


LINEAR = [p for p in sorted(NETLISTS.glob("*.cir")) if _linear(p)]
ANALYSIS = re.compile(r"^\s*\.(op|tran|ac|dc)\b", re.IGNORECASE)


def op_only(text: str) -> str:
    """The netlist with its analysis cards replaced by a single .op."""
    lines = [ln for ln in text.splitlines() if not ANALYSIS.match(ln)]
    end = next((i for i, ln in enumerate(lines) if ln.strip().lower() == ".end"), len(lines))
    return "\n".join(lines[:end] + [".op", ".end"]) + "\n"


@pytest.mark.ngspice
@pytest.mark.parametrize("path", LINEAR, ids=[p.stem for p in LINEAR])
def test_linear_operating_point_agrees_with_ngspice(path):
    from netdae.ngspice import run_ngspice

    ours = operating_point(netdae.load(path))
    theirs = run_ngspice(op_only(path.read_text()), opamp_gain=OPAMP_GAIN, source=str(path),
                         workdir=path.parent).result("op")
    common = [name for name in ours.names() if name in theirs]
    assert len(common) == len(ours.names())  # ngspice reports every unknown netdae has
    scale = {"v": max(abs(float(ours[n][0])) for n in common if n.startswith("v(")),
             "i": max((abs(float(ours[n][0])) for n in common if n.startswith("i(")), default=0.0)}
    for name in common:
        a, b = float(ours[name][0]), float(theirs[name][0])
        bound = REL * max(abs(a), abs(b)) + REL * scale[name[0]] + 1e-300
        assert abs(a - b) <= bound, (name, a, b)
    assert np.isfinite([float(v[0]) for v in ours.signals.values()]).all()
