"""Values of ``.meas`` cards written as ngspice reads them: expressions without braces."""

from __future__ import annotations

import pytest

from netdae.analyses.runner import run
from netdae.errors import NetlistError

PWL = """unbraced values
.param vh=0.5 t0=1m
V1 in 0 PWL(0 0 4m 1)
R1 in 0 1k
.tran 10u 4m
.meas tran a WHEN v(in)=vh*0.6
.meas tran b TRIG v(in) VAL=vh*0.2 RISE=1 TARG v(in) VAL=vh RISE=1
.meas tran c FIND v(in) AT=t0*3
.meas tran d MAX v(in) FROM=t0/2 TO=t0*2
.end
"""


def test_values_without_braces_are_expressions():
    """ngspice 39 reads ``VAL=vh*0.2``, ``WHEN v(x)=vh*0.6`` and ``AT=t0*3`` as expressions of .params."""
    (res,) = run(PWL)
    m = {x.name: x for x in res.measures}
    assert m["a"].value == pytest.approx(1.2e-3, rel=1e-12)      # v(in) = t/4m reaches 0.3 at 1.2 ms
    assert m["b"].value == pytest.approx(2e-3 - 0.4e-3, rel=1e-12)
    assert m["c"].value == pytest.approx(0.75, rel=1e-12)
    assert m["d"].value == pytest.approx(0.5, rel=1e-12) and m["d"].at == pytest.approx(2e-3, rel=1e-12)


def test_an_unknown_name_in_an_unbraced_value_is_located():
    with pytest.raises(NetlistError, match="unknown parameter 'foo'"):
        run(PWL.replace("vh*0.6", "foo*0.6"))
