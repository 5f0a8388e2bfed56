"""``DERIV`` of a dc or ac result at a point of its axis (ngspice 39 has no DERIV; closed forms here).

The lines between the points have two slopes at an inner point; the measurement takes the
derivative of the parabola through the point and its neighbours (the central difference on an
even grid), second order in the spacing, where the left line's slope was first order.
"""

from __future__ import annotations

import pytest

from netdae.analyses.runner import run

DIVIDER = """divider swept by its top resistor
V1 in 0 1
R1 in a 1k
R2 a 0 1k
.dc R1 {sweep}
.meas dc on_point DERIV v(a) AT=3k
.meas dc between DERIV v(a) AT=3050
.meas dc crossing DERIV v(a) WHEN v(a)=0.25
.end
"""


@pytest.mark.parametrize("sweep", ["100 10k 100", "10k 100 -100"])
def test_dc_derivative_on_a_point_is_second_order(sweep):
    (res,) = run(DIVIDER.format(sweep=sweep))
    m = {x.name: x.value for x in res.measures}
    # v(a) = 1k / (R1 + 1k): dv/dR1 = -1k / (R1 + 1k)^2
    assert m["on_point"] == pytest.approx(-1e3 / 4e3 ** 2, rel=1e-3)    # the left line's slope was 2.6 % off
    assert m["crossing"] == pytest.approx(-1e3 / 4e3 ** 2, rel=1e-3)    # v(a)=0.25 at R1=3k, a point
    assert m["between"] == pytest.approx(-1e3 / 4.05e3 ** 2, rel=1e-3)  # mid-line: the line's slope


RC_AC = """rc
V1 in 0 DC 0 AC 1
R1 in out 1k
C1 out 0 1u
.ac dec 50 1 100k
.meas ac s DERIV vm(out) AT=100
.end
"""


def test_ac_derivative_on_a_point_of_a_log_grid():
    (res,) = run(RC_AC)
    w0 = 1e3  # 1/(RC)
    f = 100.0
    # |H| = 1/sqrt(1 + (w/w0)^2), w = 2 pi f: d|H|/df = -(2 pi / w0)^2 f (1 + (w/w0)^2)^(-3/2)
    x = (2 * 3.141592653589793 * f / w0) ** 2
    exact = -(2 * 3.141592653589793 / w0) ** 2 * f * (1 + x) ** -1.5
    assert res.measures[0].value == pytest.approx(exact, rel=2e-3)
