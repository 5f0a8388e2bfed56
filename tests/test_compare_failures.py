"""``netdae.compare``: honest failure reports, paths with blanks, and a bounded ngspice run."""

from __future__ import annotations

import inspect
import math
import os
import time

import pytest

import netdae
from netdae.comparison import compare
from netdae.ngspice.shared import library_path

pytestmark = pytest.mark.ngspice

needs_library = pytest.mark.skipif(library_path() is None, reason="ngspice's shared library is not installed")
BACKENDS = [pytest.param("shared", marks=needs_library), "subprocess"]

# netdae fails at t = 0 on this diode (n = 0.1, a 100 V edge: Newton, then, after
# the impasse restart, the error test) while ngspice gets through; the output starts at 0.5 ms, so none of ngspice's
# points lies in the interval netdae computed before it failed.
NETDAE_FAILS = """diode netdae cannot start
V1 in 0 PULSE(-100 100 0 1p 1p 1m 2m)
D1 in out dmod
R1 out 0 1
.model dmod d is=1e-30 n=0.1
.tran 1u 1m 0.5m
.end
"""


def test_netdae_s_own_failure_is_reported_first():
    comparison = compare(NETDAE_FAILS)
    (tran,) = comparison.analyses
    assert not comparison.passed
    assert tran.error.startswith("netdae's transient failed: ")
    assert "BDF failed" in tran.error and "t=0" in tran.error


RC = """rc in a directory with a blank
.include "models dir/rc.inc"
V1 in 0 PULSE(0 1 0 1u 1u 1m 2m)
X1 in out rc
.tran 10u 3m
.end
"""
RC_INC = ".subckt rc a b\nR1 a b 1k\nC1 b 0 1u\n.ends\n"


@pytest.mark.parametrize("backend", BACKENDS)
def test_a_netlist_in_a_directory_with_blanks_compares(tmp_path, backend):
    folder = tmp_path / "my circuits"
    (folder / "models dir").mkdir(parents=True)
    (folder / "models dir" / "rc.inc").write_text(RC_INC)
    path = folder / "rc net.cir"
    path.write_text(RC)
    comparison = compare(path, backend=backend)
    assert comparison.ngspice_error is None, comparison.ngspice_error
    assert comparison.backend == backend and comparison.passed
    (tran,) = comparison.analyses
    # the closed form of the step response through both simulators: ngspice's own
    # points are there, and the comparison judged v(out)
    assert tran.points > 100 and any(s.name == "v(out)" for s in tran.signals)


LONG = """long transient
V1 in 0 SIN(0 1 1k)
R1 in out 1k
C1 out 0 1u
.tran 1n 10 0 1n
.end
"""


def _ngspice_children() -> list[int]:
    """Processes named ngspice whose parent is this process."""
    found = []
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            with open(f"/proc/{entry}/stat") as handle:
                stat = handle.read()
        except OSError:
            continue
        name = stat[stat.index("(") + 1 : stat.rindex(")")]
        ppid = int(stat[stat.rindex(")") + 2 :].split()[1])
        if name == "ngspice" and ppid == os.getpid():
            found.append(int(entry))
    return found


@pytest.mark.parametrize("backend", BACKENDS)
def test_timeout_stops_ngspice_and_fails_the_comparison(backend, monkeypatch):
    # netdae would take long on this transient too: compare only what the timeout is about
    import netdae.comparison.run as run_module

    monkeypatch.setattr(run_module, "_compare_card", _no_netdae)
    start = time.perf_counter()
    comparison = compare(LONG, backend=backend, timeout=0.5)
    assert time.perf_counter() - start < 20
    assert not comparison.passed
    assert "did not finish within 0.5 s" in comparison.ngspice_error
    assert _ngspice_children() == []


def _no_netdae(kind, circuit, card, ng, tol, *args, **kwargs):
    from netdae.comparison.model import AnalysisComparison

    return AnalysisComparison(kind, tolerance=tol, error="ngspice failed on the netlist" if ng is None else "x")


def test_timeout_must_be_positive():
    with pytest.raises(netdae.errors.NgspiceError, match="positive"):
        compare(RC_SIMPLE, timeout=0)
    assert compare(RC_SIMPLE, timeout=math.inf).passed


RC_SIMPLE = "rc\nV1 in 0 1\nR1 in out 1k\nR2 out 0 1k\n.op\n.end\n"


def test_compare_signature_is_explicit_and_documented():
    sig = inspect.signature(netdae.compare)
    kinds = {p.kind for name, p in sig.parameters.items() if name != "netlist"}
    assert kinds == {inspect.Parameter.KEYWORD_ONLY}
    assert sig.parameters["timeout"].default is None
    for name in sig.parameters:
        assert f"{name} :" in netdae.compare.__doc__, name


@pytest.mark.ngspice
def test_several_dc_and_ac_cards_pair_with_their_own_results():
    """ngspice 39 runs several .dc (and .ac) cards last to first: each card is compared with its own sweep."""
    from netdae.comparison import compare

    deck = """two sweeps each
v1 a 0 dc 1 ac 1
r1 a b 1k
c1 b 0 1u
r2 b 0 2k
.dc v1 0 1 0.5
.dc v1 0 1 0.1
.ac dec 2 1 1k
.ac dec 5 1 1k
.end
"""
    items = compare(deck).analyses
    assert [(i.analysis, i.points) for i in items] == [("dc", 3), ("dc", 11), ("ac", 7), ("ac", 16)]
    assert all(i.passed for i in items)


@pytest.mark.ngspice
def test_dc_sweep_whose_stop_ngspice_drops_is_compared_at_its_points():
    """ngspice adds the step repeatedly: `.dc v1 0 60 0.1` ends at 59.9 there (600 points), at 60 in netdae."""
    from netdae.comparison import compare

    item = compare("t\nv1 a 0 1\nr1 a b 1k\nr2 b 0 2k\n.dc v1 0 60 0.1\n.end\n").analyses[0]
    assert item.passed and item.points == 600 and item.error is None
    assert any("leaves out 1 of netdae's" in n for n in item.notes)


# ngspice stops its transient here (sqrt of a negative control, "timestep too small" at 1.5 ms);
# its .ac runs. netdae's own run is made and measured: the .ac gain is 0.5 (the divider), the
# transient's value at 0.5 ms is 1 V (sqrt(1) before the input falls below zero at 1 ms + ...).
NGSPICE_FAILS = """transient that fails midway
v1 in 0 dc 1 ac 1 pwl(0 1 1m 1 2m -1)
r1 in a 1k
r2 a 0 1k
b1 out 0 v=sqrt(v(in))
r3 out 0 1k
.ac lin 3 1k 3k
.tran 10u 2m
.meas ac g find vm(a) at=2k
.meas tran v05 find v(out) at=0.5m
.end
"""


@pytest.mark.parametrize("backend", BACKENDS)
def test_where_ngspice_fails_netdae_still_runs_and_measures(backend):
    c = compare(NGSPICE_FAILS, backend=backend)
    assert not c.passed and c.ngspice_error
    for a in c.analyses:  # not judged: ngspice has no result; netdae's run is said
        assert a.error.startswith("ngspice failed on the netlist")
        assert any(n.startswith("netdae ran on its own") for n in a.notes), a.notes
    got = {m.name: m.netdae for m in c.measures}
    assert got["v05"].value == pytest.approx(1.0, rel=1e-9)
    assert got["g"].value == pytest.approx(0.5, rel=1e-12)


# a PARAM measurement of one that failed: ngspice cannot substitute it, says so in numparam's
# words and goes on (the run is fine, the measurement 'failed')
PARAM_OF_FAILED = """param of a failed measurement
v1 1 0 pulse(0 1 0 1n 1n 1m 2m)
r1 1 2 1k
c1 2 0 1u
.tran 1u 2m
.meas tran t1 when v(2)=5
.meas tran e param='t1*2'
.end
"""


@pytest.mark.parametrize("backend", BACKENDS)
def test_a_param_of_a_failed_measurement_does_not_fail_ngspice_s_run(backend):
    c = compare(PARAM_OF_FAILED, backend=backend)
    assert c.ngspice_error is None, c.ngspice_error
    assert c.passed
    e = next(m for m in c.measures if m.name == "e")
    assert e.ngspice.status == "failed" and "Undefined parameter [t1]" in e.ngspice.reason
    assert "cannot compute substitute" not in e.ngspice.reason.lower()


SWITCH_AC = """a switch that is on at the operating point, in .ac
V1 in 0 DC 0 AC 1
VC ctl 0 DC 2
S1 in a ctl 0 sw
R1 a 0 1k
.model sw SW(VT=1 RON=10 ROFF=1meg)
.ac lin 3 1k 3k
.end
"""


@pytest.mark.ngspice
def test_an_ac_disagreement_with_a_switch_on_names_ngspices_roff():
    # the switch is on (VC = 2 > VT = 1): v(a) = 1k / (1k + RON) = 0.990 (netdae); ngspice 39 takes ROFF in its
    # AC matrix whatever the state, 1k / (1k + 1meg) = 9.99e-4. The comparison fails, and now says why.
    import numpy as np

    (res,) = netdae.run(SWITCH_AC)
    assert np.allclose(np.abs(np.asarray(res["v(a)"])), 1e3 / (1e3 + 10.0), rtol=1e-9)
    comparison = netdae.compare(SWITCH_AC, backend="subprocess")
    item = comparison.analysis("ac")
    assert item.passed is False
    ng = [s for s in item.signals if s.name == "v(a)"][0]
    assert abs(ng.ngspice) == pytest.approx(1e3 / (1e3 + 1e6), rel=1e-6)
    assert any(n.startswith("the circuit has switches (s1): ngspice 39's .ac takes each as open (ROFF)")
               for n in item.notes)
