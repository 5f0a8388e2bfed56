"""The netlist reader against ngspice 39: waveforms, names, and the example netlists.

Each test writes a netlist, runs ``ngspice -b -r out.raw`` (ascii raw file),
and compares what ngspice computed with what netdae read: source waveforms
at ngspice's own time points, hierarchical node and branch names, and the
operating-point semantics of sources with both a DC value and a function.
"""

from __future__ import annotations

import os
import re
import subprocess
from pathlib import Path

import numpy as np
import pytest

from netdae.netlist import load

pytestmark = pytest.mark.ngspice

NETLISTS = Path(__file__).resolve().parent.parent / "netlists"
#: Agreement expected between ngspice's double arithmetic and numpy's for the
#: same formula, relative to the signal's amplitude (both evaluate
#: identical closed forms; the raw file keeps 16 significant digits).
RTOL = 1e-9
#: ngspice may run a while on the larger example netlists.
TIMEOUT = 120


def run_ngspice(text: str, tmp_path: Path, name: str = "t") -> tuple[dict[str, np.ndarray], str]:
    """Run a netlist in ngspice; return the vectors of its (last) raw plot and its log."""
    cir = tmp_path / f"{name}.cir"
    raw = tmp_path / f"{name}.raw"
    cir.write_text(text)
    proc = subprocess.run(["ngspice", "-b", "-r", str(raw), str(cir)], capture_output=True, text=True,
                          timeout=TIMEOUT, cwd=tmp_path, env=os.environ | {"SPICE_ASCIIRAWFILE": "1"})
    log = proc.stdout + proc.stderr
    assert proc.returncode == 0, log
    return read_ascii_raw(raw), log


def read_ascii_raw(path: Path) -> dict[str, np.ndarray]:
    """The last plot of an ascii ngspice raw file as ``{name: values}``."""
    text = path.read_text()
    plots = text.split("Title:")[1:]
    body = plots[-1]
    nvars = int(re.search(r"No\. Variables:\s*(\d+)", body).group(1))
    npoints = int(re.search(r"No\. Points:\s*(\d+)", body).group(1))
    head, values = body.split("Values:\n", 1)
    names = [line.split()[1] for line in head.split("Variables:\n", 1)[1].strip().splitlines()]
    assert len(names) == nvars
    numbers = [float(tok) for i, tok in enumerate(values.split()) if i % (nvars + 1) != 0]
    data = np.array(numbers).reshape(npoints, nvars)
    return {name: data[:, k] for k, name in enumerate(names)}


# -- waveforms -----------------------------------------------------------------
TSTEP, TSTOP, TMAX = 0.1e-6, 40e-6, 0.05e-6

WAVES = {
    "pulse_full": "PULSE(0 1 1u 2u 3u 4u 12u)",
    "pulse_defaults": "PULSE(-1 2)",
    "pulse_zero_rise_means_default": "PULSE(0 1 5u 0 0 10u 20u)",
    "pulse_two_pulses": "PULSE(0 1 1u 2u 3u 4u 12u 2)",
    "pulse_commas_delay": "PULSE(1, -1, 2.5u, 1u, 0.5u, 3u, 7u)",
    "sin_full": "SIN(0.5 2 100k 3u 2e4 30)",
    "sin_defaults": "SIN(0 1)",
    "sin_bare": "SIN 0.25 1 75k 0 0 -90",
    "exp_full": "EXP(0 1 2u 3u 10u 4u)",
    "exp_defaults": "EXP(1 -1)",
    "pwl_plain": "PWL(0 0 10u 1 20u -1 30u 0.5)",
    "pwl_repeat_delay": "PWL(0 0 5u 1 10u 0.5 12u 1) r=5u td=3u",
    "pwl_repeat_all": "PWL(0 1 4u -1 6u 1) r=0",
    "pwl_late_start": "PWL(5u 1 15u 2)",
    "sffm_full": "SFFM(0.2 1 100k 3 20k 10 20)",
    "sffm_defaults": "SFFM(0 1)",
    "am_full": "AM(1 0.5 20k 200k 2u 0 45)",
    "am_defaults": "AM(1 0.5 0 50k)",
}


def _wave_netlist(waves: dict[str, str], letter: str = "V") -> str:
    lines = ["waveforms"]
    for k, spec in enumerate(waves.values(), start=1):
        if letter == "V":
            lines.append(f"V{k} n{k} 0 {spec}")
        else:
            lines.append(f"I{k} 0 n{k} {spec}")
        lines.append(f"R{k} n{k} 0 1")
    lines += [f".tran {TSTEP} {TSTOP} 0 {TMAX}", ".end", ""]
    return "\n".join(lines)


@pytest.mark.parametrize("letter", ["V", "I"])
def test_every_waveform_matches_ngspice_at_its_time_points(tmp_path, letter):
    # ngspice 39 has PWL r= and td= on voltage sources only
    waves = {k: v for k, v in WAVES.items() if letter == "V" or "=" not in v}
    text = _wave_netlist(waves, letter)
    vectors, _ = run_ngspice(text, tmp_path)
    circuit = load(text)
    t = vectors["time"]
    assert t.size > 400
    for k, name in enumerate(waves, start=1):
        wave = circuit.element(f"{letter.lower()}{k}").source.tran.resolved(TSTEP, TSTOP)
        ours = wave.value(t)
        theirs = vectors[f"v(n{k})"]
        scale = max(np.max(np.abs(theirs)), 1.0)
        err = np.max(np.abs(ours - theirs)) / scale
        assert err <= RTOL, f"{name}: max relative error {err:.3g}"


def test_pwl_step_takes_the_first_value_at_the_instant(tmp_path):
    text = "step\nV1 a 0 PWL(0 0 10u 1 10u 2 20u 0)\nR1 a 0 1\n.tran 1u 30u\n.end\n"
    vectors, log = run_ngspice(text, tmp_path)
    assert "non-increasing PWL time points" in log
    wave = load(text).element("v1").source.tran
    t = vectors["time"]
    at = int(np.argmin(np.abs(t - 10e-6)))
    assert t[at] == pytest.approx(10e-6, rel=1e-12)  # ngspice steps onto the corner
    assert vectors["v(a)"][at] == pytest.approx(1.0, abs=1e-12)
    corner = wave.times[1]
    assert wave.value(corner) == 1.0 and wave.value(corner * (1 + 1e-12)) == pytest.approx(2.0, abs=1e-6)
    ok = np.abs(t - 10e-6) > 1e-15
    np.testing.assert_allclose(wave.value(t[ok]), vectors["v(a)"][ok], rtol=0, atol=1e-9)


def test_operating_points_use_dc_or_the_function_at_zero(tmp_path):
    text = ("op vs tran start\n"
            "V1 a 0 0.5 SIN(1 1 1k 0 0 90)\n"  # .op: 0.5 (dc); tran start: 1 + sin(90 deg) = 2
            "V2 b 0 SIN(0.25 1 1k 0 0 30)\n"   # .op: the function at 0 = 0.75
            "V3 c 0 AC 1\n"                     # nothing given: 0
            "R1 a 0 1\nR2 b 0 1\nR3 c 0 1\n.op\n.end\n")
    vectors, _ = run_ngspice(text, tmp_path, "op")
    circuit = load(text)
    for name, node in (("v1", "a"), ("v2", "b"), ("v3", "c")):
        assert circuit.element(name).source.dc_value() == pytest.approx(vectors[f"v({node})"][0], abs=1e-12)
    tran_text = text.replace(".op", ".tran 1u 10u")
    vectors, _ = run_ngspice(tran_text, tmp_path, "tran")
    for name, node in (("v1", "a"), ("v2", "b"), ("v3", "c")):
        assert circuit.element(name).source.tran_value_at_zero() == pytest.approx(vectors[f"v({node})"][0],
                                                                                   abs=1e-12)


# -- numbers ------------------------------------------------------------------------
NUMBERS = ["10kOhm", "1M", "1MEG", "1mil", "2.2n", "1e-3", "1.5d2", "4k7", "1Farad", "1e3k", "3a", ".5",
           "1uF", "1x", "-2.5e+2m", "7T", "8G", "9p", "1.e2"]


def test_number_tokens_read_as_ngspice_reads_them(tmp_path):
    lines = ["numbers"] + [f"V{k} n{k} 0 {tok}" for k, tok in enumerate(NUMBERS, 1)] + [".op", ".end", ""]
    text = "\n".join(lines)
    vectors, _ = run_ngspice(text, tmp_path)
    circuit = load(text)
    for k, tok in enumerate(NUMBERS, 1):
        theirs = vectors[f"v(n{k})"][0]
        assert circuit.element(f"v{k}").source.dc == pytest.approx(theirs, rel=1e-15, abs=0), tok


PARAM_NUMBERS = ["10kOhm", "1M", "1MEG", "1mil", "2.2n", "1e3k", "3", ".5u", "2*1m"]


def test_bare_parameter_values_read_as_numparam_reads_them(tmp_path):
    params = " ".join(f"p{k}={tok}" for k, tok in enumerate(PARAM_NUMBERS, 1))
    lines = ["params", f".param {params}"] + [f"V{k} n{k} 0 {{p{k}}}" for k in range(1, len(PARAM_NUMBERS) + 1)]
    text = "\n".join(lines + [".op", ".end", ""])
    vectors, _ = run_ngspice(text, tmp_path)
    circuit = load(text)
    for k, tok in enumerate(PARAM_NUMBERS, 1):
        assert circuit.params[f"p{k}"] == pytest.approx(vectors[f"v(n{k})"][0], rel=1e-15), tok


PARAM_EXPRESSIONS = ["10kOhm", "1mil", "1meg", "-2**2", "2**3**2", "(-2)**3", "pow(-2,3)", "pwr(-2,3)",
                     "2*-3", "1?2:3", "0?2:3||1", "nint(2.5)", "int(-2.7)", "5%3", "!0", "2+3*4^2",
                     "log(100)", "1<2&&3>2", "1==1", "1!=2", "abs(-3)+sgn(-2)", "min(3,4)*max(1,2)",
                     "sqrt(16)+exp(0)+ln(1)+log10(1000)", "floor(2.5)+ceil(2.5)", "a*b+c", "sqr(3)",
                     "atan(1)*4", "sinh(1)-cosh(1)+tanh(0.5)"]
BEHAVIOURAL = ["-2**2", "2**3**2", "(-2)**3", "pow(-2,3)", "pwr(-2,3)", "1?2:3", "nint(2.5)", "u(0)+u(1)",
               "uramp(-1)+uramp(2)", "2+3*4^2", "log(100)", "1<2&&3>2", "(-8)^(1/3)", "1mil*1e6",
               "pi", "v(a)*2-v(a,b)", "a*v(b)"]


def test_expressions_evaluate_as_ngspice_evaluates_them(tmp_path):
    lines = ["expressions", ".param a=1.5 b=-2 c={a*b}"]
    for k, e in enumerate(PARAM_EXPRESSIONS, 1):
        lines.append(f"V{k} p{k} 0 {{{e}}}")
    lines += ["Va a 0 3", "Vb b 0 1"]
    for k, e in enumerate(BEHAVIOURAL, 1):
        lines += [f"B{k} q{k} 0 V={e}"]
    lines += [".op", ".end", ""]
    text = "\n".join(lines)
    vectors, _ = run_ngspice(text, tmp_path)
    circuit = load(text)
    for k, e in enumerate(PARAM_EXPRESSIONS, 1):
        assert circuit.element(f"v{k}").source.dc == pytest.approx(vectors[f"v(p{k})"][0], rel=1e-12), e
    from netdae.netlist.expr import Voltage, evaluate, transform, Const
    volts = {"a": 3.0, "b": 1.0}
    for k, e in enumerate(BEHAVIOURAL, 1):
        tree = circuit.element(f"b{k}").expr

        def leaf(n):
            if type(n) is Voltage:
                return Const(volts[n.pos] - (volts[n.neg] if n.neg else 0.0))
            return None

        ours = evaluate(transform(tree, leaf), None)
        assert ours == pytest.approx(vectors[f"v(q{k})"][0], rel=1e-12), e


# -- names ------------------------------------------------------------------------
HIERARCHY = """hierarchy
.global vdd
.subckt inner a b params: r=1k
R1 a mid {r}
L1 mid b 1m
Vs b c 0
Rc c 0 1
Rg vdd c 1meg
.model dm d is=1e-15
D1 c 0 dm
.ends inner
.subckt outer p n params: rr=2k
.subckt local a b
Rl a m 7
Ll m b 1u
Xdeep a m inner r=3
.ends
X1 p n inner r={rr}
X3 p n local
.ends
Xa in 0 outer
Xb in gnd outer rr=5k
V1 in 0 1
Vdd vdd 0 5
.op
.end
"""


def test_hierarchical_names_are_ngspices(tmp_path):
    text = HIERARCHY
    vectors, _ = run_ngspice(text, tmp_path)
    circuit = load(text)
    ours = {f"v({n})" for n in circuit.nodes}
    ours |= {f"i({e.name})" for e in circuit.elements if e.kind in ("vsource", "inductor")}
    assert ours == set(vectors) - {"time"} - {k for k in vectors if k.startswith("v(") and k[2:-1] == "0"}
    # local definitions are expanded first (l.xb.l.x3.ll), top-level ones where they are called
    assert {"v(xa.x3.xdeep.mid)", "i(l.xb.l.x3.ll)", "i(l.xa.x3.xdeep.l1)", "i(v.xb.x1.vs)"} <= ours
    assert circuit.element("r.xb.x3.xdeep.r1").value == 3.0
    assert circuit.element("r.xb.x1.r1").value == 5e3
    assert circuit.element("d.xa.x3.xdeep.d1").model == "xa.x3.xdeep:dm"


def test_model_names_are_ngspices(tmp_path):
    text = HIERARCHY.replace(".op\n", ".op\n.control\nshowmod d : is\n.endc\n")
    _, log = run_ngspice(text, tmp_path)
    theirs = set()
    for line in log.splitlines():
        m = re.match(r"\s+model\s+(.*)$", line)
        if m:
            theirs.update(m.group(1).split())
    assert set(load(HIERARCHY).models) == theirs == {"xa.x1:dm", "xa.x3.xdeep:dm", "xb.x1:dm", "xb.x3.xdeep:dm"}


# -- the example netlists -------------------------------------------------------------
EXTENSIONS = {
    "opamp": "the netdae ideal op-amp (E ... OPAMP) is translated into a VCVS with gain 1e6",
}


def _translated(path: Path) -> str:
    """The netlist with netdae extensions replaced by their ngspice equivalents."""
    text = path.read_text()
    return re.sub(r"(?im)^(\s*e\S*\s+\S+\s+\S+\s+\S+\s+\S+)\s+opamp\s*$", r"\1 1e6", text)


@pytest.mark.parametrize("path", sorted(NETLISTS.glob("*.cir")), ids=lambda p: p.name)
def test_example_netlists_parse_in_ngspice_and_netdae(path, tmp_path):
    text = _translated(path)
    circuit = load(path)
    proc = subprocess.run(["ngspice", "-b", "-r", str(tmp_path / "out.raw")], input=text, capture_output=True,
                          text=True, timeout=TIMEOUT, cwd=path.parent, env=os.environ | {"SPICE_ASCIIRAWFILE": "1"})
    log = proc.stdout + proc.stderr
    assert proc.returncode == 0, log
    bad = [line for line in log.splitlines()
           if re.search(r"\berror\b|unknown|can't find|not found|syntax", line, re.I)]
    assert not bad, "\n".join(bad)
    assert circuit.elements


def test_poly_sources_match_ngspice(tmp_path):
    text = ("poly\nVx x 0 0.7\nVy y 0 -1.3\nRx x 0 1\nRy y 0 2\n"
            "E1 e 0 POLY(2) x 0 y 0 1 2 3 4 5 6 7\n"       # up to the first cubic term: 7 x^3
            "Re e 0 1\n"
            "G1 g 0 POLY(1) x y 0.5 1 0.25\nRg g 0 1\n"
            "F1 f 0 POLY(2) vx vy 0 1 -1 0.5\nRf f 0 1\n"
            "H1 h 0 POLY(1) vy 2 0 0 1\nRh h 0 1\n.op\n.end\n")
    vectors, _ = run_ngspice(text, tmp_path)
    circuit = load(text)
    from netdae.netlist.expr import Const, Current, Voltage, evaluate, transform
    volts = {n[2:-1]: v[0] for n, v in vectors.items() if n.startswith("v(")}
    amps = {n[2:-1]: v[0] for n, v in vectors.items() if n.startswith("i(")}

    def value(name):
        def leaf(n):
            if type(n) is Voltage:
                return Const(volts[n.pos] - (volts[n.neg] if n.neg else 0.0))
            if type(n) is Current:
                return Const(amps[n.element])
            return None
        return evaluate(transform(circuit.element(name).expr, leaf), None)

    assert value("e1") == pytest.approx(volts["e"], rel=1e-12)
    assert value("h1") == pytest.approx(volts["h"], rel=1e-12)
    # a current source n+ -> n- draws its current out of n+: v = -I * R
    assert -value("g1") == pytest.approx(volts["g"], rel=1e-12)
    assert -value("f1") == pytest.approx(volts["f"], rel=1e-12)
