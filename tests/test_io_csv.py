"""CSV results: layout named as ngspice names signals, exact round trips."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from netdae.errors import NetdaeError
from netdae.io.csv import format_csv, parse_csv, read_csv, write_csv
from netdae.results import Result


def _assert_same(a: Result, b: Result) -> None:
    assert a.analysis == b.analysis
    assert list(a.axes) == list(b.axes) and a.names() == b.names()
    for key in a.axes:
        np.testing.assert_array_equal(a.axes[key], b.axes[key])
    for key in a.signals:
        assert np.iscomplexobj(a.signals[key]) == np.iscomplexobj(b.signals[key])
        # bit for bit, signed zeros and nan included
        assert np.asarray(a.signals[key]).tobytes() == np.asarray(b.signals[key]).tobytes()


def test_layout_of_each_analysis():
    tran = Result("tran", axes={"time": np.array([0.0, 1e-9])}, signals={"v(out)": np.array([0.1, 0.2]), "i(v1)": np.array([-1e-3, 2e-3])})
    assert format_csv(tran).splitlines() == ["time,v(out),i(v1)", "0.0,0.1,-0.001", "1e-09,0.2,0.002"]
    op = Result("op", signals={"v(in)": np.array([1.0]), "i(l.xa.x1.l1)": np.array([0.5])})
    assert format_csv(op).splitlines() == ["v(in),i(l.xa.x1.l1)", "1.0,0.5"]
    dc = Result("dc", axes={"v1": np.array([0.0, 1.0]), "v2": np.array([5.0, 5.0])}, signals={"v(out)": np.array([0.0, 0.5])})
    assert format_csv(dc).splitlines()[0] == "v1,v2,v(out)"
    ac = Result("ac", axes={"frequency": np.array([10.0])}, signals={"v(out)": np.array([0.5 - 0.5j])})
    assert format_csv(ac).splitlines() == ["frequency,re(v(out)),im(v(out))", "10.0,0.5,-0.5"]


def test_full_precision_is_kept():
    x = np.nextafter(1.0 / 3.0, 1.0)  # not the double nearest to any short decimal
    r = Result("tran", axes={"time": np.array([0.1])}, signals={"v(a)": np.array([x])})
    assert float(format_csv(r).splitlines()[1].split(",")[1]) == x


def test_special_values_round_trip():
    values = np.array([np.nan, np.inf, -np.inf, -0.0, 5e-324, np.finfo(float).max])
    r = Result("tran", axes={"time": np.arange(6.0)}, signals={"v(a)": values})
    _assert_same(r, parse_csv(format_csv(r)))


finite = st.floats(allow_nan=False, allow_infinity=False, width=64)


@settings(max_examples=60, deadline=None)
@given(
    st.integers(1, 12).flatmap(
        lambda m: st.tuples(
            arrays(np.float64, m, elements=finite),
            arrays(np.float64, m, elements=finite),
            arrays(np.float64, m, elements=finite),
        )
    ),
    st.sampled_from(["tran", "ac", "dc", "dc2"]),
)
def test_round_trip_is_exact(columns, kind):
    axis, a, b = columns
    if kind == "tran":
        r = Result("tran", axes={"time": axis}, signals={"v(x1.mid)": a, "i(l.x1.l1)": b})
    elif kind == "ac":
        r = Result("ac", axes={"frequency": axis}, signals={"v(out)": a + 1j * b})
    elif kind == "dc":
        r = Result("dc", axes={"v1": axis}, signals={"v(out)": a, "i(v1)": b})
    else:
        r = Result("dc", axes={"v1": axis, "i2": a}, signals={"v(out)": b})
    _assert_same(r, parse_csv(format_csv(r)))


def test_op_round_trip_through_a_file(tmp_path):
    r = Result("op", signals={"v(in)": np.array([1.0]), "v(xa.x1.mid)": np.array([1 / 7]), "i(v1)": np.array([-2e-4])})
    write_csv(tmp_path / "op.csv", r)
    _assert_same(r, read_csv(tmp_path / "op.csv"))


def test_analysis_can_be_forced():
    text = "v1,v(out)\n0.0,1.0\n"
    assert parse_csv(text).analysis == "dc"
    with pytest.raises(NetdaeError, match="swept source"):
        parse_csv("v(out)\n1.0\n2.0\n", analysis="dc")


@pytest.mark.parametrize(
    "text, message",
    [
        ("", "empty CSV"),
        ("time,v(a)\n0.0\n", "1 fields, expected 2"),
        ("time,v(a)\n0.0,abc\n", "not a number"),
        ("frequency,re(v(a))\n1.0,2.0\n", r"not followed by 'im\(v\(a\)\)'"),
        ("v(a),v(a)\n1.0,1.0\n", "repeated column"),
        ("v(a)\n1.0\n2.0\n", "one row"),
    ],
)
def test_malformed_csv_raises_with_location(text, message):
    with pytest.raises(NetdaeError, match=message):
        parse_csv(text, "x.csv")


def test_mismatched_lengths_are_refused():
    r = Result("tran", axes={"time": np.arange(3.0)}, signals={"v(a)": np.arange(2.0)})
    with pytest.raises(NetdaeError, match="shape"):
        format_csv(r)
