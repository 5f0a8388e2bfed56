"""Shared helpers of the topology tests: circuits from tuples, a reference MNA.

The reference MNA below is written independently of netdae's assembler
(dense numpy, textbook stamps) so that it can serve as an oracle for the
structural statements: pencil regularity, Kronecker index (SLICOT ag08bd),
singularity of the DC matrix, dependence on source derivatives.
"""

from __future__ import annotations

import numpy as np
import pytest

from netdae.circuit import GROUND, Circuit, Element, Model


def mk(name: str, kind: str, nodes, value=None, **kw) -> Element:
    """An element from a tuple: ``mk("c1", "capacitor", ("a", "0"), 1e-6)``."""
    return Element(name, kind, tuple(nodes), value, **kw)


def circuit(*elements: Element, models: dict[str, Model] | None = None, title: str = "test") -> Circuit:
    """A circuit whose node list is every non-ground node in order of appearance."""
    nodes: list[str] = []
    for el in elements:
        for n in el.nodes:
            if n != GROUND and n not in nodes:
                nodes.append(n)
    return Circuit(title, list(elements), nodes, models=dict(models or {}))


def reference_mna(c: Circuit):
    """Dense MNA ``E x' = H x + B u`` of R, C, L, V, I, E (vcvs), G (vccs), op-amp.

    Returns
    -------
    E, H : ndarray, shape (N, N)
    B : ndarray, shape (N, number of independent sources)
    names : list of str
        ``v(node)`` for node potentials, ``i(element)`` for branch currents.
    """
    nodes = [n for n in c.nodes]
    pos = {n: i for i, n in enumerate(nodes)}
    branch = [el for el in c.elements if el.kind in ("inductor", "vsource", "vcvs", "opamp")]
    sources = [el for el in c.elements if el.kind in ("vsource", "isource")]
    n, N = len(nodes), len(nodes) + len(branch)
    E, H, B = np.zeros((N, N)), np.zeros((N, N)), np.zeros((N, len(sources)))
    bpos = {el.name: n + k for k, el in enumerate(branch)}
    spos = {el.name: k for k, el in enumerate(sources)}

    def inc(a: str, b: str) -> np.ndarray:
        vec = np.zeros(N)
        if a != GROUND:
            vec[pos[a]] += 1.0
        if b != GROUND:
            vec[pos[b]] -= 1.0
        return vec

    for el in c.elements:
        a = inc(el.nodes[0], el.nodes[1])
        if el.kind == "resistor":
            H -= np.outer(a, a) / el.value
        elif el.kind == "capacitor":
            E += el.value * np.outer(a, a)
        elif el.kind in ("inductor", "vsource", "vcvs", "opamp"):
            k = bpos[el.name]
            H[:, k] -= a  # the branch current leaves n+ and enters n-
            if el.kind == "inductor":
                E[k, k] = el.value
                H[k] += a
            elif el.kind == "vsource":
                H[k] += a
                B[k, spos[el.name]] = -1.0
            elif el.kind == "vcvs":
                H[k] += a - el.value * inc(el.nodes[2], el.nodes[3])
            else:
                H[k] += inc(el.nodes[2], el.nodes[3])
        elif el.kind == "isource":
            B[:, spos[el.name]] -= a
        elif el.kind == "vccs":
            H -= el.value * np.outer(a, inc(el.nodes[2], el.nodes[3]))
        else:
            raise ValueError(el.kind)
    names = [f"v({x})" for x in nodes] + [f"i({el.name})" for el in branch]
    return E, H, B, names


def pencil_structure(E: np.ndarray, H: np.ndarray) -> tuple[bool, int | None]:
    """(regular, Kronecker index) of ``lambda E - H`` by SLICOT ag08bd."""
    from slycot import ag08bd

    N = E.shape[0]
    _, _, nrank, _, _, _, infe, _ = ag08bd(
        l=N, n=N, m=0, p=0, A=H.copy(), E=E.copy(), B=np.zeros((N, 1)), C=np.zeros((1, N)), D=np.zeros((1, 1))
    )
    if nrank < N:
        return False, None
    return True, int(max(infe, default=0))


def drazin_index(E: np.ndarray, H: np.ndarray, rng: np.random.Generator, rtol: float = 1e-9) -> int:
    """Index of a regular pencil as the Drazin index of ``(mu E - H)^-1 E`` (random mu)."""
    N = E.shape[0]
    mu = rng.uniform(0.5, 1.5)
    Eh = np.linalg.solve(mu * E - H, E)
    power, ranks = np.eye(N), []
    for _ in range(N + 2):
        ranks.append(np.linalg.matrix_rank(power, tol=rtol * max(1.0, np.linalg.norm(power, 2))))
        if len(ranks) >= 2 and ranks[-1] == ranks[-2]:
            return len(ranks) - 2
        power = power @ Eh
    raise AssertionError("rank sequence did not settle")


def derivative_dependent(E: np.ndarray, H: np.ndarray, B: np.ndarray, names: list[str]) -> set[str]:
    """Unknowns whose response to the sources contains their first derivative.

    ``X(s) = (sE - H)^-1 B = M0 + M1 s + O(1/s)`` for an index-2 pencil; the
    rows of ``M1`` that are not zero. Estimated from two large s (element
    values are O(1), so the O(1/s) rest is far below the threshold).
    """
    if B.shape[1] == 0:
        return set()
    s1, s2 = 1e6, 2e6
    x1 = np.linalg.solve(s1 * E - H, B)
    x2 = np.linalg.solve(s2 * E - H, B)
    m1 = (x2 - x1) / (s2 - s1)
    return {names[i] for i in np.flatnonzero(np.abs(m1).max(axis=1) > 1e-6)}


def test_finding_vocabulary_is_closed():
    """A finding's kind and severity are enums; a value outside the vocabulary is refused."""
    import json

    from netdae.topology.report import Finding, FindingKind, Severity

    f = Finding("cv_loop", "warning", "m")
    assert f.kind is FindingKind.CV_LOOP and f.severity is Severity.WARNING
    assert f.kind == "cv_loop" and json.loads(json.dumps(f.to_dict()))["severity"] == "warning"
    with pytest.raises(ValueError):
        Finding("cv-loop", "warning", "m")
    with pytest.raises(ValueError):
        Finding("cv_loop", "fatal", "m")
