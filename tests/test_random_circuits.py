"""Random linear circuits against ngspice 39: operating point, AC and transient at tight settings.

Circuits of R, C, L, V, I, E, F, G and H elements are drawn with a fixed seed: a
spanning tree of resistors, inductors and voltage sources first (every node has a
DC path to ground), then random elements of every kind between random nodes, one
sine source driving the transient and an AC source. Each netlist is run by netdae
and by ngspice (``netdae.compare(..., tight=True)``) and every analysis must agree
within the comparison's tolerance (1e-3 of each signal's scale; 1e-2 for transients,
:data:`TRAN_RTOL`, where ngspice's step control is the limit; where ngspice stops at tight settings, "timestep too
small" on an index-1 circuit netdae runs, the circuit is counted apart: ngspice's default
settings are then too coarse to judge netdae by; an unstable circuit, a finite eigenvalue of
the pencil in the right half-plane, is compared without its transient, which grows without
bound, as is one of index 3 or more, whose unknowns follow second derivatives of the input:
netdae solves it exactly through its decoupled form, ngspice's integration formulas diverge
there). A netlist netdae refuses must be one whose
equations have no unique solution (a loop of voltage sources and inductors, a
cutset of current sources and capacitors; ngspice then reports a singular matrix
): netdae's refusal must say so, ngspice must stop on it too, and the share of
circuits compared is held above a floor, so the test fails if netdae starts
refusing circuits it should run.

The default run compares a handful of circuits; ``pytest -m fuzz`` (``make fuzz``)
runs the long fixed-seed suite.
"""

from __future__ import annotations

import numpy as np
import pytest

from netdae.errors import CircuitError, NgspiceError, SingularPencilError
from netdae.ngspice import run_ngspice

pytestmark = pytest.mark.ngspice

KINDS = ["r"] * 6 + ["c"] * 3 + ["l"] * 2 + ["v", "i", "e", "g", "f", "h"]


def _value(rng, lo, hi):
    return float(10 ** rng.uniform(np.log10(lo), np.log10(hi)))


def random_netlist(rng: np.random.Generator, index: int) -> str:
    """One random linear netlist (text) with .op, .ac and .tran cards."""
    nodes = [f"n{k}" for k in range(1, int(rng.integers(2, 7)))]
    lines = [f"random linear circuit {index}"]
    vsources: list[str] = []
    counts: dict[str, int] = {}

    def name(letter):
        counts[letter] = counts.get(letter, 0) + 1
        return f"{letter}{counts[letter]}"

    def element(letter, a, b):
        nm = name(letter)
        if letter == "r":
            lines.append(f"{nm} {a} {b} {_value(rng, 10, 1e5):.6g}")
        elif letter == "c":
            lines.append(f"{nm} {a} {b} {_value(rng, 1e-12, 1e-6):.6g}")
        elif letter == "l":
            lines.append(f"{nm} {a} {b} {_value(rng, 1e-6, 1e-2):.6g}")
        elif letter == "v":
            lines.append(f"{nm} {a} {b} dc {rng.uniform(-5, 5):.4g}")
            vsources.append(nm)
        elif letter == "i":
            lines.append(f"{nm} {a} {b} dc {rng.uniform(-1e-3, 1e-3):.4g}")
        elif letter in "eg":
            c, d = rng.choice(["0", *nodes], 2, replace=False)
            gain = rng.uniform(-2, 2) * (1.0 if letter == "e" else 1e-3)
            lines.append(f"{nm} {a} {b} {c} {d} {gain:.4g}")
        else:  # f, h: controlled by a voltage source's current
            gain = rng.uniform(-2, 2) * (1.0 if letter == "f" else 1e3)
            lines.append(f"{nm} {a} {b} {rng.choice(vsources)} {gain:.4g}")

    # a spanning tree of DC paths: each node joins an earlier one (or ground)
    for k, node in enumerate(nodes):
        other = "0" if k == 0 else str(rng.choice(["0", *nodes[:k]]))
        element(str(rng.choice(["r"] * 6 + ["l"])), node, other)
    # the source that drives the small-signal and transient analyses
    lines.append(f"vin {rng.choice(nodes)} 0 dc 0 ac 1 sin(0 1 {_value(rng, 1e4, 1e5):.4g})")
    vsources.append("vin")
    for _ in range(int(rng.integers(2, 8))):
        letter = str(rng.choice(KINDS))
        if letter in "fh" and not vsources:
            letter = "r"
        a, b = rng.choice(["0", *nodes], 2, replace=False)
        element(letter, a, b)
    lines += [".options method=gear", ".op", ".ac dec 5 10 10meg", ".tran 2u 200u", ".end"]
    return "\n".join(lines) + "\n"


#: The transients' tolerance (of each signal's range). ngspice's own step control is the limit here:
#: on a lightly damped RLC circuit (seed 1, circuit 37) ngspice at reltol=1e-6 is 2.5e-3 (gear) to
#: 3.4e-3 (trap) of the range from the solution solve_ivp gives at rtol=1e-12, netdae 5.6e-7.
TRAN_RTOL = 1e-2

#: Messages of refusals that mean "no unique solution" (the structure, not a missing feature).
SINGULAR_WORDS = ("singular", "no unique", "undetermined", "loop", "cutset", "no DC path", "index")


def _compare_all(seed: int, count: int) -> dict[str, int]:
    import netdae
    from netdae.comparison import compare

    rng = np.random.default_rng(seed)
    tally = {"agree": 0, "refused": 0, "ngspice_failed": 0, "unstable": 0, "index3": 0}
    for k in range(count):
        text = random_netlist(rng, k)
        try:
            report = netdae.analyze_index(netdae.load(text), check_consistency=False)
            if np.any(np.real(report.finite_eigenvalues) > 0):  # an active circuit growing without bound
                text = text.replace(".tran 2u 200u\n", "")
                tally["unstable"] += 1
            elif report.index is not None and report.index >= 3:  # ngspice differentiates no input twice
                text = text.replace(".tran 2u 200u\n", "")
                tally["index3"] += 1
            results = netdae.run(netdae.load(text))
        except (CircuitError, SingularPencilError) as exc:
            assert any(w in str(exc) for w in SINGULAR_WORDS), (text, str(exc))
            with pytest.raises(NgspiceError):  # a singular circuit: ngspice stops too ("singular matrix")
                run_ngspice(text, backend="subprocess")
            tally["refused"] += 1
            continue
        assert all(r.status >= 0 for r in results), (text, [r.message for r in results])
        result = compare(text, tight=True)
        if result.ngspice_error is not None:  # ngspice's step control at tight settings (timestep too small)
            tally["ngspice_failed"] += 1
            continue
        failures = [item for item in result.analyses if item.passed is False and (
            item.analysis != "tran" or item.error or max(s.max_rel for s in item.signals) > TRAN_RTOL)]
        assert not failures, (text, [(i.analysis, i.error, [(s.name, s.max_rel) for s in i.signals
                                                                if s.passed is False]) for i in failures])
        tally["agree"] += 1
    return tally


@pytest.mark.parametrize("seed", [20261127])
def test_a_few_random_circuits_agree_with_ngspice(seed):
    tally = _compare_all(seed, 8)
    assert tally["agree"] >= 3, tally


@pytest.mark.fuzz
@pytest.mark.parametrize("seed", [1, 2])
def test_many_random_circuits_agree_with_ngspice(seed):
    tally = _compare_all(seed, 100)
    assert tally["agree"] >= 40, tally
