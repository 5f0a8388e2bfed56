"""Figures people can read, checked on the matplotlib Figure objects (Agg, nothing shown).

Oracles: closed-form transfer functions for the dB range, the circuit's own
structure for rails and internal nodes, and the rendered geometry (window
extents) for overlapping text.
"""

from __future__ import annotations

import numpy as np
import pytest

matplotlib = pytest.importorskip("matplotlib")
matplotlib.use("Agg")

from matplotlib.figure import Figure  # noqa: E402
from matplotlib.ticker import EngFormatter  # noqa: E402

from netdae.netlist import load  # noqa: E402
from netdae.plotting import MAGNITUDE_FLOOR, MAX_CURVES, plot, plot_result  # noqa: E402
from netdae.results import Result  # noqa: E402

FC = 1e3


def _lowpass(zero: bool = True) -> Result:
    f = np.logspace(0, 6, 61)
    signals = {"v(out)": 1 / (1 + 1j * f / FC), "v(in)": np.ones_like(f) + 0j}
    if zero:
        signals["v(gnd_ref)"] = np.zeros_like(f, dtype=complex)  # e.g. a node held at 0 V
        signals["i(noise)"] = np.where(f > 1e5, 1e-30, 1.0) + 0j  # drops to rounding noise
    return Result("ac", axes={"frequency": f}, signals=signals)


def _labels(ax) -> list[str]:
    return [line.get_label() for line in ax.get_lines()]


def test_plot_returns_a_figure_without_saving_it(tmp_path):
    fig = plot(_lowpass(zero=False), title="low-pass")
    assert isinstance(fig, Figure)
    assert list(tmp_path.iterdir()) == []
    assert len(fig.axes) == 2 and len(fig.axes[0].get_lines()) == 2


def test_the_db_axis_spans_the_data_not_a_floor_of_zeros():
    result = _lowpass()
    fig = plot(result)
    magnitude = fig.axes[0]
    bottom, top = magnitude.get_ylim()
    # the deepest meaningful magnitude is the low-pass at 1 MHz: -60 dB (closed form)
    deepest = 20 * np.log10(abs(1 / (1 + 1j * 1e6 / FC)))
    assert deepest - 10 < bottom < deepest
    assert 0 < top < 10
    # the zero signal is named, not drawn; the noise part of i(noise) is not drawn
    assert "v(gnd_ref) (zero)" in _labels(magnitude)
    noise = next(line for line in magnitude.get_lines() if line.get_label() == "i(noise)")
    y = np.asarray(noise.get_ydata())
    assert np.all(np.isnan(y[result.axis > 1e5])) and np.all(np.isfinite(y[result.axis <= 1e5]))
    assert 1e-30 < MAGNITUDE_FLOOR


def test_axes_carry_si_prefixes():
    t = np.linspace(0.0, 2e-3, 101)
    tran = Result("tran", axes={"time": t}, signals={"v(out)": 0.5e-3 * np.sin(1e4 * t), "i(v1)": 2e-6 * np.cos(1e4 * t)})
    volts, amps = plot(tran).axes
    assert isinstance(amps.xaxis.get_major_formatter(), EngFormatter)
    assert amps.xaxis.get_major_formatter()(1.5e-3) == "1.5 ms"
    assert volts.yaxis.get_major_formatter()(-250e-6) == "−250 µV"
    assert amps.yaxis.get_major_formatter()(2e-6) == "2 µA"
    ac = plot(_lowpass(zero=False))
    assert ac.axes[1].xaxis.get_major_formatter()(1e4) == "10 kHz"
    dc = Result("dc", axes={"v1": np.linspace(0, 1, 5)}, signals={"v(out)": np.linspace(0, 0.5, 5)})
    assert plot(dc).axes[0].xaxis.get_major_formatter()(0.25) == "250 mV"


RAILS = """rails and an internal diode node
VCC vcc 0 5
VEE 0 vee 5
VIN in 0 SIN(0 1 1k)
R1 vcc a 1k
D1 a in dmod
R2 in vee 1k
.model dmod D(IS=1e-14 RS=10)
.tran 10u 2m
.end
"""


def test_supply_rails_and_internal_nodes_are_left_out_and_named():
    from netdae import simulate

    circuit = load(RAILS)
    result = simulate(circuit)
    assert {"v(vcc)", "v(vee)", "v(d1#internal)"} <= set(result.signals)
    fig = plot(result, circuit=circuit)
    drawn = {label for ax in fig.axes for label in _labels(ax)}
    assert drawn.isdisjoint({"v(vcc)", "v(vee)", "v(d1#internal)"})
    assert {"v(a)", "v(in)", "i(vcc)"} <= drawn  # the sine source's node and supply currents stay
    note = fig.get_suptitle()
    assert "2 supply rails (v(vcc), v(vee))" in note and "1 internal device node" in note
    every = plot(result, circuit=circuit, rails=True, internal=True)
    assert {"v(vcc)", "v(vee)", "v(d1#internal)"} <= {label for ax in every.axes for label in _labels(ax)}
    chosen = plot(result, circuit=circuit, signals=["v(vcc)", "v(a,in)"])
    assert _labels(chosen.axes[0]) == ["v(vcc)", "v(a,in)"]


def test_many_curves_get_distinct_colours():
    t = np.linspace(0.0, 1.0, 20)
    n = 15
    result = Result("tran", axes={"time": t}, signals={f"v(n{k})": k * t for k in range(n)})
    (ax,) = plot(result).axes
    styles = [(tuple(np.round(matplotlib.colors.to_rgba(line.get_color()), 6)), line.get_linestyle())
              for line in ax.get_lines()]
    assert len(styles) == n
    assert len({colour for colour, _ in styles}) == n


def test_curves_beyond_the_limit_are_named_not_silently_dropped():
    t = np.linspace(0.0, 1.0, 5)
    result = Result("tran", axes={"time": t}, signals={f"v(n{k})": k * t for k in range(MAX_CURVES + 3)})
    fig = plot(result)
    assert len(fig.axes[0].get_lines()) == MAX_CURVES
    assert "3 more curves" in fig.get_suptitle()


def _overlaps(a, b) -> bool:
    return a.x0 < b.x1 and b.x0 < a.x1 and a.y0 < b.y1 and b.y0 < a.y1


def test_a_long_title_does_not_overlap_the_panels():
    t = np.linspace(0.0, 1e-3, 50)
    result = Result("tran", axes={"time": t}, signals={"v(out)": t, "i(v1)": -t})
    fig = plot(result, title="a very long netlist title " * 8)
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    canvas = FigureCanvasAgg(fig)
    canvas.draw()  # lays the figure out (constrained layout)
    renderer = canvas.get_renderer()
    title = fig._suptitle.get_window_extent(renderer)
    assert title.height > 2 * fig._suptitle.get_fontsize()  # wrapped onto several lines
    for ax in fig.axes:
        assert not _overlaps(title, ax.get_tightbbox(renderer))
    for upper, lower in zip(fig.axes, fig.axes[1:]):
        assert not _overlaps(upper.get_window_extent(renderer), lower.get_tightbbox(renderer))


def test_plot_result_writes_the_format_of_the_suffix_and_refuses_unknown_ones(tmp_path):
    from netdae.errors import NetdaeError

    result = _lowpass(zero=False)
    assert plot_result(result, tmp_path / "bode.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert plot_result(result, tmp_path / "bode.svg").read_text().lstrip().startswith("<?xml")
    with pytest.raises(NetdaeError, match=r"unknown image format '\.xyz'"):
        plot_result(result, tmp_path / "bode.xyz")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bode.png", "bode.svg"]


def test_an_operating_point_cannot_be_plotted():
    from netdae.errors import NetdaeError

    with pytest.raises(NetdaeError, match="cannot plot a 'op' result"):
        plot(Result("op", signals={"v(a)": np.array([1.0])}))


def test_arguments_of_the_wrong_type_say_what_is_expected():
    """plot(None) was an AttributeError ('NoneType' object has no attribute 'analysis'), signals=5 Python's
    "'int' object is not iterable"; one signal's name may be given as a string, as save= takes it."""
    with pytest.raises(TypeError, match=r"result must be a Result \(of netdae.run or netdae.simulate\), not NoneType"):
        plot(None)
    with pytest.raises(TypeError, match="signals must be a string or a list of strings, not int"):
        plot(_lowpass(), signals=5)
    fig = plot(_lowpass(), signals="v(out)")
    assert _labels(fig.axes[0]) == ["v(out)"]
