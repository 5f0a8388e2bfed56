"""Result: signals by ngspice names, differences, dB and phase, repr, JSON schema, pandas and xarray."""

from __future__ import annotations

import json
import sys

import numpy as np
import pytest

import netdae
from netdae.results import Result

from conftest import NETLISTS

RC = NETLISTS / "rc_lowpass.cir"  # R = 1k, C = 1u: H(f) = 1 / (1 + j f / fc), fc = 1 / (2 pi RC)
FC = 1.0 / (2 * np.pi * 1e-3)


@pytest.fixture(scope="module")
def rc_results():
    return netdae.run(RC)


@pytest.fixture(scope="module")
def divider():
    return netdae.run(NETLISTS / "voltage_divider.cir")  # 10 V over 10k + 5k: v(out) = v(in) / 3


def test_vdb_and_vp_against_the_closed_form(rc_results):
    ac = rc_results[1]
    f = ac.axis
    h = 1.0 / (1.0 + 1j * f / FC)
    np.testing.assert_allclose(ac.vdb("out"), 20 * np.log10(np.abs(h)), rtol=0, atol=1e-9)
    np.testing.assert_allclose(ac.vp("out"), -np.degrees(np.arctan(f / FC)), rtol=0, atol=1e-9)
    # the voltage across R1 against the closed form: v(in) - v(out) = 1 - h
    np.testing.assert_allclose(ac.v("in", "out"), 1 - h, rtol=1e-12, atol=0)
    np.testing.assert_allclose(ac.vdb("in", "out"), 20 * np.log10(np.abs(1 - h)), atol=1e-9)
    with pytest.raises(ValueError, match="AC results"):
        rc_results[0].vdb("out")


def test_vp_unwrap():
    phase = np.exp(-1j * np.radians([90.0, 170.0, 190.0, 270.0]))
    r = Result("ac", axes={"frequency": np.arange(4.0)}, signals={"v(a)": phase})
    np.testing.assert_allclose(r.vp("a"), [-90.0, -170.0, 170.0, 90.0], atol=1e-12)
    np.testing.assert_allclose(r.vp("a", unwrap=True), [-90.0, -170.0, -190.0, -270.0], atol=1e-12)


def test_differences_and_currents_by_ngspice_names(divider):
    op = divider[0]
    vin, vout = op["v(in)"][0], op["v(out)"][0]
    assert vout == pytest.approx(vin / 3, rel=1e-12)
    for name in ("v(in,out)", "V(In, Out)", "v(in , out)"):
        assert op[name][0] == pytest.approx(2 * vin / 3, rel=1e-12)
    assert op.v("in", "out")[0] == op["v(in,out)"][0] and op.v("out", "gnd")[0] == vout
    assert op.v("0")[0] == 0.0 and op["v(0,out)"][0] == -vout
    assert op.i("V1")[0] == op["i(v1)"][0] == pytest.approx(-vin / 15e3, rel=1e-12)
    assert "v(in,out)" in op and "v(in,nowhere)" not in op and 3 not in op
    with pytest.raises(KeyError, match="node voltage v\\(nowhere\\) is not in the result"):
        op["v(in,nowhere)"]
    with pytest.raises(KeyError, match="bad signal name"):
        op["vdb(out)"]


def test_subset_keys_canonical_names(divider):
    dc = divider[1].subset(["V(OUT, gnd)", "v(in,out)"])
    assert dc.names() == ["v(out)", "v(in,out)"]
    np.testing.assert_allclose(dc["v(in,out)"], 2 * dc["v(out)"], rtol=1e-12, atol=1e-15)


def test_repr_is_short(rc_results, divider):
    tran, ac = rc_results
    assert repr(ac) == ("<Result ac: 51 points, frequency 1 to 1e+05 Hz; 3 signals (v(in), v(out), i(v1)); ok>")
    assert repr(divider[0]) == "<Result op: 1 point; 3 signals (v(in), v(out), i(v1)); ok>"
    failed = Result("tran", axes={"time": np.zeros(2)}, signals={f"v(n{k})": np.zeros(2) for k in range(9)},
                    status=-1, message="BDF failed")
    assert repr(failed).endswith("9 signals (v(n0), v(n1), v(n2), v(n3), ...); FAILED: BDF failed>")
    html = tran._repr_html_()
    assert html.count("<tr>") == 4 and "v(out)" in html and "<table>" in html


def test_to_dict_has_one_schema(rc_results, divider):
    results = [*divider, *rc_results]
    assert [r.analysis for r in results] == ["op", "dc", "tran", "ac"]
    docs = [json.loads(json.dumps(r.to_dict())) for r in results]
    assert len({tuple(d) for d in docs}) == 1
    op, dc, tran, ac = docs
    assert op["values"]["signals"]["v(out)"] == [pytest.approx(10 / 3, rel=1e-12)] and op["points"] == 1
    assert dc["values"] is None and dc["axes"] == ["v1"] and dc["points"] == 11
    assert ac["values"] is None
    full = rc_results[1].to_dict(values=True)
    assert full["values"]["signals"]["v(out)"][0] == [pytest.approx(1 / (1 + (1 / FC) ** 2)),
                                                      pytest.approx(-(1 / FC) / (1 + (1 / FC) ** 2))]
    assert tran["stats"]["steps"] > 0 and isinstance(tran["stats"]["integrator"], dict)


def test_to_pandas(rc_results, divider):
    pytest.importorskip("pandas")
    tran, ac = rc_results
    df = tran.to_pandas()
    assert df.index.name == "time" and list(df.columns) == tran.names() and len(df) == tran.points
    np.testing.assert_array_equal(df["v(out)"].to_numpy(), tran["v(out)"])
    assert ac.to_pandas()["v(out)"].dtype.kind == "c"
    op = divider[0].to_pandas()
    assert len(op) == 1 and op["v(out)"].iloc[0] == divider[0]["v(out)"][0]
    nested = Result("dc", axes={"v1": np.array([0.0, 1.0, 0.0, 1.0]), "v2": np.array([0.0, 0.0, 5.0, 5.0])},
                    signals={"v(a)": np.arange(4.0)})
    df = nested.to_pandas()
    assert df.index.names == ["v1", "v2"] and df.loc[(1.0, 5.0), "v(a)"] == 3.0


def test_to_xarray(rc_results, divider):
    pytest.importorskip("xarray")
    ac = rc_results[1]
    ds = ac.to_xarray()
    assert ds["v(out)"].dims == ("frequency",) and ds.attrs["analysis"] == "ac"
    np.testing.assert_array_equal(ds["frequency"].to_numpy(), ac.axis)
    np.testing.assert_array_equal(ds["v(out)"].to_numpy(), ac["v(out)"])
    op = divider[0].to_xarray()
    assert op["v(out)"].dims == () and float(op["v(out)"]) == divider[0]["v(out)"][0]


@pytest.mark.parametrize("method, module", [("to_pandas", "pandas"), ("to_xarray", "xarray")])
def test_missing_optional_dependency_names_the_extra(method, module, monkeypatch, divider):
    monkeypatch.setitem(sys.modules, module, None)  # import now raises ImportError
    with pytest.raises(ImportError, match=r"pip install 'netdae\[results\]'"):
        getattr(divider[0], method)()
