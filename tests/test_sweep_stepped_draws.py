"""A Monte Carlo sweep that steps a value which itself draws: the step replaces the variation, with a warning."""

from __future__ import annotations

import numpy as np

import netdae

RC = """rc
.param rr={{gauss(1k,0.1,3)}} rnom=1k
V1 in 0 DC 1 AC 1
R1 in out {r1}
C1 out 0 {c1}
.ac dec 10 10 1meg
.meas ac f3db WHEN vdb(out)=-3
.end
"""


def _sweep(params, r1="{rr}", c1="100n"):
    return netdae.sweep(RC.format(r1=r1, c1=c1), params=params, samples=3, seed=2, workers=1)


def test_stepping_a_drawn_parameter_warns_and_its_samples_are_alike():
    res = _sweep({"rr": [1e3, 2e3]})
    notes = [n for n in res.notes if "varies from one Monte Carlo sample" in n]
    assert len(notes) == 1 and notes[0].startswith("warning: the stepped rr ") and "rnom" in notes[0]
    f = res.measures["f3db"].reshape(2, 3)
    assert np.all(f == f[:, :1])  # the samples of a point are alike: the step replaced the only draw


def test_stepping_a_drawn_element_warns():
    res = _sweep({"r1": [1e3, 2e3]}, r1="{agauss(1k,100,1)}", c1="{agauss(100n,10n,1)}")
    assert any(n.startswith("warning: the stepped r1 ") for n in res.notes)
    f = res.measures["f3db"].reshape(2, 3)
    assert np.ptp(f, axis=1).min() > 0  # the capacitor still varies


def test_stepping_the_nominal_of_a_draw_does_not_warn():
    res = _sweep({"rnom": [1e3, 2e3]}, r1="{gauss(rnom,0.1,3)}")
    assert not [n for n in res.notes if "varies from one Monte Carlo sample" in n]
    f = res.measures["f3db"].reshape(2, 3)
    assert np.ptp(f, axis=1).min() > 0
