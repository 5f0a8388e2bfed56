"""Running netlists in ngspice: closed forms, both backends, names, failures.

Values are checked against hand computations and closed forms, never against
the code under test; the two backends are checked against each other to the
last bit (the binary raw file and the shared library hold the same doubles).
"""

from __future__ import annotations

import math
import os
import re
import subprocess
import sys

import numpy as np
import pytest

from netdae.errors import NgspiceError
from netdae.ngspice import (
    INSTALL_HINT,
    OPAMP_GAIN,
    available,
    ngspice_version,
    run_ngspice,
    run_ngspice_file,
)
from netdae.ngspice.shared import library_path

pytestmark = pytest.mark.ngspice

needs_library = pytest.mark.skipif(
    library_path() is None, reason=f"ngspice's shared library is not installed ({INSTALL_HINT})"
)
BACKENDS = [pytest.param("shared", marks=needs_library), "subprocess"]

R, C = 1e3, 1e-6
TAU = R * C
F_CORNER = 1 / (2 * math.pi * TAU)

DIVIDER_OP = "divider\nV1 in 0 1\nR1 in out 1k\nR2 out 0 3k\n.op\n.end\n"

RC_STEP = "rc step\nV1 in 0 DC 1\nR1 in out 1k\nC1 out 0 1u IC=0\n.tran 20u 5m uic\n.end\n"

RC_AC = f"rc low-pass\nV1 in 0 DC 0 AC 1\nR1 in out 1k\nC1 out 0 1u\n.ac lin 1 {F_CORNER!r} {F_CORNER!r}\n.end\n"

HIERARCHY = """hierarchy
V1 in 0 DC 2 AC 1 SIN(0 1 1k)
Xa in 0 outer
.subckt outer p q
R1 p mid 1k
X1 mid q inner
.ends
.subckt inner a b
L1 a mid 1m
R2 mid b 1k
.ends
.op
.tran 10u 1m
.ac dec 3 10 10k
.dc V1 0 2 0.5
.end
"""


@pytest.mark.parametrize("backend", BACKENDS)
def test_divider_operating_point_by_hand(backend):
    run = run_ngspice(DIVIDER_OP, backend=backend)
    op = run.result("op")
    assert op.axes == {}
    np.testing.assert_allclose(op["v(in)"], [1.0], rtol=1e-15)
    np.testing.assert_allclose(op["v(out)"], [0.75], rtol=1e-14)  # 1 V * 3k / 4k
    np.testing.assert_allclose(op["i(v1)"], [-1 / 4000], rtol=1e-14)  # into the + node: negative
    assert run.backend == backend and re.fullmatch(r"ngspice-\d+", run.version)
    assert op.source.ngspice_version == run.version and op.source.backend == backend


@pytest.mark.parametrize("backend", BACKENDS)
def test_rc_step_response_against_the_closed_form(backend):
    tran = run_ngspice(RC_STEP, backend=backend).result("tran")
    t = tran.t
    # with 'uic' ngspice 39 reports no point at t = 0: its first is the first step
    assert 0.0 < t[0] < 1e-6 and t[-1] == pytest.approx(5e-3, rel=1e-12)
    # ngspice's accepted time points, not the 20u print grid
    assert not np.allclose(np.diff(t), 20e-6)
    error = np.abs(tran["v(out)"] - (1 - np.exp(-t / TAU)))
    # ngspice's error control: reltol 1e-3 of the 1 V signal
    assert error.max() < 1e-3 * 1.0
    np.testing.assert_allclose(tran["i(v1)"], -(1 - tran["v(out)"]) / R, rtol=1e-9, atol=1e-15)
    assert tran.tolerances["reltol"] == 1e-3


@pytest.mark.parametrize("backend", BACKENDS)
def test_rc_lowpass_at_its_corner(backend):
    ac = run_ngspice(RC_AC, backend=backend).result("ac")
    np.testing.assert_allclose(ac.axis, [F_CORNER], rtol=1e-15)
    h = ac["v(out)"][0]
    assert abs(h) == pytest.approx(1 / math.sqrt(2), rel=1e-12)
    assert math.degrees(np.angle(h)) == pytest.approx(-45.0, rel=1e-12)


def test_ac_sweep_is_the_transfer_function_everywhere():
    netlist = "rc\nV1 in 0 AC 1\nR1 in out 1k\nC1 out 0 1u\n.ac dec 10 1 1meg\n.end\n"
    ac = run_ngspice(netlist).result("ac")
    assert len(ac.axis) == 61
    np.testing.assert_allclose(ac["v(out)"], 1 / (1 + 1j * ac.axis / F_CORNER), rtol=1e-12)


@pytest.mark.parametrize("backend", BACKENDS)
def test_dc_sweeps_are_linear_and_named_by_their_sources(backend):
    netlist = "dc\nV1 in 0 1\nV2 b 0 0\nR1 in out 1k\nR2 out b 3k\n.dc V1 0 2 0.25 V2 0 1 0.5\n.end\n"
    dc = run_ngspice(netlist, backend=backend).result("dc")
    assert list(dc.axes) == ["v1", "v2"]
    v1, v2 = dc.axes["v1"], dc.axes["v2"]
    np.testing.assert_array_equal(v1, np.tile(np.arange(9) * 0.25, 3))
    np.testing.assert_array_equal(v2, np.repeat([0.0, 0.5, 1.0], 9))
    np.testing.assert_allclose(dc["v(out)"], 0.75 * v1 + 0.25 * v2, rtol=1e-14, atol=1e-15)
    single = run_ngspice("dc\nI1 0 out 1m\nR1 out 0 2k\n.dc i1 0 1m 0.25m\n.end\n", backend=backend).result("dc")
    assert list(single.axes) == ["i1"]
    np.testing.assert_allclose(single["v(out)"], 2e3 * single.axis, rtol=1e-14, atol=1e-16)


@pytest.mark.parametrize("stop, values", [("4k7", [0.0, 1e3, 2e3, 3e3, 4e3]), ("1.5d3", [0.0, 1e3]),
                                          ("2.5meg", [0.0, 1e6, 2e6])])
def test_the_outer_sweep_is_rebuilt_with_ngspice_s_reading_of_numbers(stop, values):
    # v(b) = v2: ngspice's own values of the outer source are the oracle ('4k7' is 4000 in
    # ngspice 39, '1.5d3' is 1500, '2.5meg' is 2.5e6)
    step = "1meg" if "meg" in stop else "1k"
    netlist = f"dc\nV1 in 0 1\nV2 b 0 0\nR1 in out 1k\nR2 out b 3k\n.dc V1 0 1 0.5 V2 0 {stop} {step}\n.end\n"
    dc = run_ngspice(netlist, backend="subprocess").result("dc")
    assert list(dc.axes) == ["v1", "v2"]
    np.testing.assert_array_equal(dc.axes["v2"], np.repeat(values, 3))
    np.testing.assert_array_equal(dc.axes["v2"], dc["v(b)"])


@needs_library
def test_both_backends_give_the_same_doubles():
    shared = run_ngspice(HIERARCHY, backend="shared")
    batch = run_ngspice(HIERARCHY, backend="subprocess")
    assert [r.analysis for r in shared.results] == [r.analysis for r in batch.results] == ["ac", "dc", "op", "tran"]
    for a, b in zip(shared.results, batch.results):
        assert list(a.axes) == list(b.axes) and a.names() == b.names()
        for key in a.axes:
            assert a.axes[key].tobytes() == b.axes[key].tobytes()
        for key in a.signals:
            assert a.signals[key].tobytes() == b.signals[key].tobytes(), (a.analysis, key)


@pytest.mark.parametrize("backend", BACKENDS)
def test_hierarchical_names_are_normalised(backend):
    op = run_ngspice(HIERARCHY, backend=backend).result("op")
    assert sorted(op.names()) == sorted(["v(in)", "v(xa.mid)", "v(xa.x1.mid)", "i(l.xa.x1.l1)", "i(v1)"])
    # DC: L1 shorts, 2 V across 1k + 1k
    np.testing.assert_allclose(op["i(l.xa.x1.l1)"], [1e-3], rtol=1e-12)
    np.testing.assert_allclose(op["v(xa.mid)"], [1.0], rtol=1e-12)


def test_differentiator_runs_after_translation(netlists_dir):
    run = run_ngspice_file(netlists_dir / "differentiator.cir")
    assert any("ideal op-amp written as a VCVS" in note for note in run.notes)
    tran = run.result("tran")
    assert tran.t[-1] == pytest.approx(3e-3, rel=1e-12)
    assert any("VCVS" in note for note in tran.notes)
    # after the first step the finite-gain circuit follows v(out) = -(L/R) V'(t)
    # up to a relative 1/A and ngspice's truncation error
    late = tran.t > 0.1e-3
    exact = -1e-4 * 2 * math.pi * 1e3 * np.cos(2 * math.pi * 1e3 * tran.t[late])
    amplitude = 1e-4 * 2 * math.pi * 1e3
    assert np.abs(tran["v(out)"][late] - exact).max() < 1e-3 * amplitude
    # the op-amp's inputs are held together: v(minus) = -v(out)/A
    np.testing.assert_allclose(tran["v(minus)"][late], -tran["v(out)"][late] / OPAMP_GAIN, rtol=1e-6, atol=1e-15)


@pytest.mark.parametrize("backend", BACKENDS)
def test_ngspice_errors_surface_with_ngspice_s_message(backend):
    with pytest.raises(NgspiceError, match="could not find a valid modelname") as info:
        run_ngspice("bad\nV1 in 0 1\nQ1 out in 0 nomodel\n.op\n.end\n", backend=backend, source="bad.cir")
    assert "ngspice failed on bad.cir" in str(info.value)
    with pytest.raises(NgspiceError, match="TSTOP is invalid"):
        run_ngspice("bad\nV1 in 0 1\nR1 in 0 1k\n.tran 1u\n.end\n", backend=backend)
    with pytest.raises(NgspiceError, match="(?s)singular matrix.*timestep too small"):
        run_ngspice("loop\nV1 in 0 1\nV2 in 0 2\nR1 in 0 1k\n.op\n.end\n", backend=backend)
    # a failure leaves nothing behind for the next netlist
    assert run_ngspice(DIVIDER_OP, backend=backend).result("op")["v(out)"][0] == pytest.approx(0.75, rel=1e-14)


@pytest.mark.parametrize("backend", BACKENDS)
def test_singular_matrix_is_refused_unless_not_strict(backend):
    # node 'float' has only a capacitor: ngspice recovers with gmin stepping,
    # and the answer for v(out) is then wrong (it should be 1 V)
    netlist = "floating\nV1 in 0 1\nR1 in out 1k\nC1 out 0 1u\nC2 float 0 1u\nI1 float2 0 1m\n.op\n.end\n"
    with pytest.raises(NgspiceError, match="check node float"):
        run_ngspice(netlist, backend=backend)
    run = run_ngspice(netlist, backend=backend, strict=False)
    assert any("singular matrix" in w for w in run.warnings)


@needs_library
def test_several_netlists_in_one_process_do_not_leak_state():
    first = run_ngspice(RC_STEP, backend="shared").result("tran")
    tight = run_ngspice(RC_STEP, backend="shared", options={"reltol": 1e-7, "method": "gear"}).result("tran")
    assert len(tight.t) > len(first.t)
    divider = run_ngspice(DIVIDER_OP, backend="shared").result("op")
    again = run_ngspice(RC_STEP, backend="shared").result("tran")
    fresh = run_ngspice(RC_STEP, backend="subprocess").result("tran")
    # the same netlist twice, and after other circuits with other options,
    # gives what a fresh ngspice process gives
    assert again.t.tobytes() == first.t.tobytes() == fresh.t.tobytes()
    assert again["v(out)"].tobytes() == fresh["v(out)"].tobytes()
    assert divider["v(out)"][0] == pytest.approx(0.75, rel=1e-14)
    assert again.source.plot == "tran1"  # earlier plots were destroyed


@pytest.mark.parametrize("backend", BACKENDS)
def test_option_overrides_take_effect_and_are_noted(backend):
    run = run_ngspice(RC_STEP, backend=backend, options={"maxstep": 1e-5, "reltol": 1e-5})
    tran = run.result("tran")
    assert np.diff(tran.t).max() <= 1e-5 * (1 + 1e-9)
    assert tran.tolerances["reltol"] == 1e-5
    assert any("maximum step" in n for n in run.notes) and any("reltol=1e-05" in n for n in tran.notes)
    error = np.abs(tran["v(out)"] - (1 - np.exp(-tran.t / TAU)))
    assert error.max() < 1e-5


def test_interp_is_stripped_so_results_stay_at_accepted_points():
    plain = run_ngspice(RC_STEP).result("tran")
    run = run_ngspice(RC_STEP.replace(".end", ".options interp\n.end"))
    assert run.result("tran").t.tobytes() == plain.t.tobytes()
    assert any("interp removed" in n for n in run.notes)


def test_control_blocks_are_not_run():
    netlist = DIVIDER_OP.replace(".end", ".control\nrun\nprint v(out)\necho hello\n.endc\n.end")
    run = run_ngspice(netlist, backend="subprocess")
    assert [r.analysis for r in run.results] == ["op"]
    assert "v(out) =" not in run.stdout and "hello" not in run.stdout
    assert any(n.startswith("line 9: .control: 'echo hello' skipped") or ":9:1: .control: 'echo hello' skipped" in n
               for n in run.notes), run.notes


@pytest.mark.parametrize("backend", BACKENDS)
def test_timeout_stops_the_run_and_ngspice_stays_usable(backend):
    long_run = "long\nV1 in 0 SIN(0 1 1k)\nR1 in out 1k\nC1 out 0 1u\n.tran 1n 10 0 1n\n.end\n"
    with pytest.raises(NgspiceError, match="did not finish within 0.3 s"):
        run_ngspice(long_run, backend=backend, timeout=0.3)
    op = run_ngspice(DIVIDER_OP, backend=backend).result("op")
    assert op["v(out)"][0] == pytest.approx(0.75, rel=1e-14)


@needs_library
def test_version_and_availability():
    assert available()
    assert ngspice_version("shared") == ngspice_version("subprocess")
    assert re.fullmatch(r"ngspice-\d+", ngspice_version())


def test_no_analysis_is_an_error():
    with pytest.raises(NgspiceError, match="no analysis card"):
        run_ngspice("nothing\nR1 1 0 1k\n.end\n", backend="subprocess")


def test_unknown_backend():
    with pytest.raises(NgspiceError, match="unknown ngspice backend"):
        run_ngspice(DIVIDER_OP, backend="spectre")


SCRIPT = """
import sys
from netdae.errors import NgspiceError
from netdae.ngspice import run_ngspice, available
print("available", available())
try:
    run = run_ngspice("d\\nV1 in 0 1\\nR1 in 0 1k\\n.op\\n.end\\n", backend=sys.argv[1])
    print("backend", run.backend)
    print("notes", run.notes)
except NgspiceError as exc:
    print("error", exc)
"""


def _python(env_changes: dict, backend: str) -> str:
    env = dict(os.environ, **env_changes)
    done = subprocess.run(
        [sys.executable, "-c", SCRIPT, backend], env=env, capture_output=True, text=True, timeout=60,
        cwd=os.path.dirname(os.path.dirname(os.path.abspath(__file__))),
    )
    assert done.returncode == 0 and "Traceback" not in done.stderr, done.stderr
    return done.stdout


@needs_library
def test_a_library_that_exited_is_replaced_by_the_subprocess():
    script = (
        "from netdae.ngspice import run_ngspice, shared\n"
        "net = 'd\\nV1 in 0 1\\nR1 in 0 1k\\n.op\\n.end\\n'\n"
        "assert run_ngspice(net, backend='shared').backend == 'shared'\n"
        "shared._session.api.ngSpice_Command(b'quit')  # ngspice calls its exit callback\n"
        "run = run_ngspice(net)\n"
        "print(run.backend, run.notes[-1])\n"
    )
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    assert done.stdout.startswith("subprocess ") and "exited (status 0)" in done.stdout


def test_missing_ngspice_is_a_clear_error_with_the_install_command(tmp_path):
    out = _python({"PATH": str(tmp_path), "NGSPICE_LIBRARY_PATH": str(tmp_path / "libngspice.so")}, "auto")
    assert "available False" in out
    assert "error ngspice cannot be run" in out and INSTALL_HINT in out


def test_auto_falls_back_to_the_subprocess_and_says_so(tmp_path):
    out = _python({"NGSPICE_LIBRARY_PATH": str(tmp_path / "libngspice.so")}, "auto")
    assert "backend subprocess" in out
    assert "shared library cannot be used" in out
    out = _python({"NGSPICE_LIBRARY_PATH": str(tmp_path / "libngspice.so")}, "shared")
    assert "error" in out and "cannot load" in out
