"""Random circuits of behavioural comparators: their laws hold at every point, their changes are events.

Each circuit, drawn with a fixed seed: a SIN input, a PULSE reference, a behavioural
source whose value is a comparison (of the input with a level or the reference, of an
RC node with a level, a conjunction of two comparisons, ``u()`` of a difference) choosing
between two levels, as a voltage source driving an RC or as a current into an RC, and
sometimes a second comparator reading the RC node. The properties, for both integrators
(:mod:`netdae.devices.kernels.behavioural`, "Locked outcomes"):

- the transient finishes, or stops for a reason the circuit has: its DC equations have
  no solution (a comparator whose output, through the resistor, contradicts its own
  input at DC: the operating point refuses), or its comparator slides (the output
  moves its input straight back across: named as chattering);
- where it finishes, every comparator's output equals its law evaluated on the
  dense output's own unknowns at every point away from the located events (the
  comparisons are held only between events, never wrong for a whole step);
- each event is an instant where some source's law changes value.

The default run draws :data:`DEFAULT`; ``pytest -m fuzz`` draws :data:`FUZZ`.
"""

from __future__ import annotations

import math
import random

import numpy as np
import pytest

import netdae
from netdae.errors import ConvergenceError
from netdae.netlist import load

DEFAULT = 6
FUZZ = 150
#: Points closer than this to an event are not checked (the law changes there).
EVENT_GUARD = 1e-9


def _circuit(rng: random.Random) -> tuple[str, list]:
    """A random netlist and its comparators ``(name, node, law, high, low)`` (voltage kind only)."""
    f = rng.choice([1e3, 5e3, 20e3])
    a = round(rng.uniform(-0.3, 0.3), 3)  # as the netlist writes it
    lines = [f"random comparator {rng.random():.6f}",
             f"V1 in 0 SIN({rng.uniform(-0.5, 0.5):.3f} {rng.uniform(0.5, 2):.3f} {f:g})",
             f"V2 ref 0 PULSE(0 1 {rng.uniform(0, 1) / f:.3e} {1e-3 / f:.3e} {1e-3 / f:.3e} "
             f"{rng.uniform(0.2, 0.5) / f:.3e} {rng.choice([1, 2, 3]) / f:.3e})"]
    law, text = rng.choice([
        (lambda v: v["in"] > a, f"v(in) > {a:.3f}"),
        (lambda v: v["in"] < v["ref"], "v(in) < v(ref)"),
        (lambda v: v["x"] > a, f"v(x) > {a:.3f}"),
        (lambda v: (v["in"] > a) and (v["ref"] < 0.5), f"(v(in) > {a:.3f}) && (v(ref) < 0.5)"),
        (lambda v: v["in"] - v["x"] > a, f"v(in) - v(x) > {a:.3f}"),
        (lambda v: (1.0 if v["in"] > a else 0.0 if v["in"] < a else 0.5) > 0.5, f"u(v(in) - {a:.3f}) > 0.5"),
    ])
    hi, lo = round(rng.uniform(1, 3), 3), round(rng.uniform(-1, 0.5), 3)
    comparators = []
    if rng.random() < 0.6:
        lines += [f"B1 out 0 V={{{text} ? {hi} : {lo}}}", f"R1 out x {rng.choice(['1k', '10k', '100'])}"]
        comparators.append(("out", law, hi, lo))
    else:
        lines += [f"B1 0 x I={{{text} ? {hi / 1e3:.3e} : {lo / 1e3:.3e}}}", f"R1 x 0 {rng.choice(['1k', '10k'])}"]
    lines.append(f"C1 x 0 {rng.choice(['10n', '100n', '1u'])}")
    if rng.random() < 0.4:
        b = round(rng.uniform(0, 1), 3)
        lines += [f"B2 y 0 V={{v(x) > {b} ? 1 : 0}}", "R2 y 0 1k"]
        comparators.append(("y", lambda v, b=b: v["x"] > b, 1.0, 0.0))
    lines += [f".tran {0.01 / f:.3e} {3 / f:.3e}", ".end"]
    return "\n".join(lines) + "\n", comparators


def _check(seed: int, engine: str, monkeypatch) -> None:
    monkeypatch.setenv("NETDAE_ENGINE", engine)
    text, comparators = _circuit(random.Random(seed))
    try:
        r = next(x for x in netdae.run(load(text)) if x.analysis == "tran")
    except ConvergenceError as exc:  # no DC solution: a comparator contradicting itself through R at DC
        assert "operating point did not converge" in str(exc), text
        return
    if not r.ok:
        assert "chatters" in r.message and "hysteresis" in r.message, text + r.message
        return
    events = np.array([t for t, _ in r.transient.events])
    t = np.linspace(0.0, float(r.t[-1]), 401)[1:]
    if events.size:
        t = t[np.min(np.abs(t[:, None] - events[None, :]), axis=1) > EVENT_GUARD]
    d = r.dense(t)
    for node, law, hi, lo in comparators:
        values = [{"in": d["v(in)"][k], "ref": d["v(ref)"][k], "x": d["v(x)"][k]} for k in range(t.size)]
        expected = np.array([hi if law(v) else lo for v in values])
        ok = np.isclose(d[f"v({node})"], expected, rtol=0, atol=1e-9)
        assert ok.all(), (text, node, t[~ok])


@pytest.mark.parametrize("engine", ["compiled", "python"])
@pytest.mark.parametrize("seed", range(DEFAULT))
def test_random_comparators(seed, engine, monkeypatch):
    _check(seed, engine, monkeypatch)


@pytest.mark.fuzz
@pytest.mark.parametrize("seed", range(DEFAULT, DEFAULT + FUZZ))
def test_random_comparators_fuzz(seed, monkeypatch):
    _check(seed, "compiled", monkeypatch)
