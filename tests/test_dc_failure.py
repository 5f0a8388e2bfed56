"""A ``.dc`` point that fails stops the sweep and keeps the points before it, as a failed result.

ngspice 39 does the same: ``doAnalyses: DC: ...; v1 = -0.5: trouble with node "b"``, ``dc simulation(s)
aborted``, and the sweep's plot holds the points solved before.
"""

from __future__ import annotations

import numpy as np
import pytest

import netdae
from netdae.cli import main as cli_main
from netdae.errors import ConvergenceError
from netdae.io.csv import read_csv

SQRT = """square root of the swept voltage: undefined below 0 V
V1 a 0 1
R1 a 0 1k
B1 b 0 V=sqrt(v(a))
R2 b 0 1k
.dc V1 {sweep}
.op
.end
"""

#: A level-1 MOSFET whose PHI's temperature law turns negative at 280 degC: refused at the element there.
HOT = """level-1 MOSFET heated
Vd d 0 1
Vg g 0 2
Rd d x 1k
M1 x g 0 0 mm
.model mm nmos level=1 phi=0.6
.dc temp 0 400 100
.end
"""


def test_a_failed_dc_point_keeps_the_points_before_it():
    dc, op = netdae.run(SQRT.format(sweep="1 -1 -0.5"))
    assert op.analysis == "op" and op.ok  # the analyses after it still run
    assert dc.analysis == "dc" and not dc.ok and dc.status < 0
    assert dc.axis.tolist() == [1.0, 0.5, 0.0] and dc.stats.points == 3
    assert dc.message.startswith(".dc at v1 = -0.5: ")
    assert "the sweep stopped at point 4 of 5; the 3 points before it are kept" in dc.message
    whole = netdae.run(SQRT.format(sweep="1 0 -0.5"))[0]
    assert whole.ok
    np.testing.assert_array_equal(dc["v(b)"], whole["v(b)"])


def test_a_failed_dc_temp_point_keeps_the_temperatures_before_it():
    (dc,) = netdae.run(HOT)
    assert not dc.ok and dc.axes["temp"].tolist() == [0.0, 100.0, 200.0]
    assert dc.message.startswith(".dc at temp = 300: ")
    assert "m1: the surface potential PHI at 300 degC" in dc.message
    assert "the sweep stopped at point 4 of 5" in dc.message


def test_a_dc_sweep_whose_first_point_fails_is_an_error():
    """Nothing computed: the failure is raised, as a transient whose start fails."""
    with pytest.raises(ConvergenceError, match=r"^\.dc at v1 = -1: "):
        netdae.run(SQRT.format(sweep="-1 1 0.5"))


def test_netdae_run_writes_the_points_of_a_failed_dc_and_says_where_it_stopped(tmp_path, capsys):
    path = tmp_path / "sqrt.cir"
    path.write_text(SQRT.format(sweep="1 -1 -0.5"))
    assert cli_main(["run", str(path), "--out", str(tmp_path / "out")]) == 1
    captured = capsys.readouterr()
    part = read_csv(tmp_path / "out" / "dc.csv")
    assert part.axis.tolist() == [1.0, 0.5, 0.0]
    assert f"{tmp_path / 'out' / 'dc.csv'} holds the 3 points up to v1 = 0: .dc at v1 = -0.5: " in captured.err
    assert ".dc: .dc at v1 = -0.5: " in captured.out
    assert (tmp_path / "out" / "op.csv").exists()


def test_compare_puts_netdaes_failed_sweep_first():
    """ngspice's sweep of five points against netdae's three before its failed point: the comparison's error
    says netdae's failure first, then that the sweeps differ."""
    from netdae.comparison.analyses import compare_dc
    from netdae.results import Result

    ng = Result("dc", axes={"v1": np.array([1.0, 0.5, 0.0, -0.5, -1.0])}, signals={"v(b)": np.zeros(5)})
    nd = Result("dc", axes={"v1": np.array([1.0, 0.5, 0.0])}, signals={"v(b)": np.zeros(3)}, status=-1,
                message=".dc at v1 = -0.5: no convergence")
    item = compare_dc(nd, ng, tol=None)
    assert item.error == ("netdae's .dc failed: .dc at v1 = -0.5: no convergence; therefore: the sweeps differ: "
                          "netdae has 3 points, ngspice 5")
