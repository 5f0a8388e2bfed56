"""Stamps of the linear elements into the constant MNA matrices.

The DAE is ``d/dt q(x) = phi(x, t)`` with, for linear elements,
``q = E x`` and ``phi = H x + B u(t)``. Each function below stamps *all*
elements of one kind at once (array operations; the only per-element Python
is reading names at assembly time).

Equations and signs (ngspice's conventions)
-------------------------------------------
Node rows are Kirchhoff's current law written as "charge and current
*entering* the node": for node n, ``d/dt q_n = -(sum of currents leaving n)``.

=============  =================================================================
R  (a, b, G)   phi_a -= G (v_a - v_b),  phi_b += G (v_a - v_b)   (.ac: G from ac= when given)
C  (a, b, C)   q_a += C (v_a - v_b),    q_b -= C (v_a - v_b)
L  (a, b; k)   phi_a -= i_k, phi_b += i_k;   q_k = L i_k (+ M i_j),  phi_k = v_a - v_b
V  (a, b; k)   phi_a -= i_k, phi_b += i_k;   phi_k = v_a - v_b - V(t)
I  (a, b)      phi_a -= I(t), phi_b += I(t)   (current from a through the source to b)
E  (a,b,c,d;k) as V with phi_k = v_a - v_b - A (v_c - v_d)
G  (a,b,c,d)   phi_a -= g (v_c - v_d), phi_b += g (v_c - v_d)
F  (a, b; j)   phi_a -= f i_j, phi_b += f i_j   (j: the controlling V source)
H  (a, b; k,j) as V with phi_k = v_a - v_b - r i_j
OPAMP (a,b,c,d;k)  as V in the KCL rows; phi_k = v_c - v_d  (nullor: v_c = v_d)
K  (L1, L2, k) q_k1 += M i_k2, q_k2 += M i_k1 with M = k sqrt(L1 L2)  (L before m)
=============  =================================================================

With these signs ``E = diag(A_C C A_C^T, L, 0)`` is symmetric positive
semi-definite for passive circuits, and the DC matrix is ``-H``.
"""

from __future__ import annotations

from collections import defaultdict
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from ..circuit import Circuit, Element
from ..errors import CircuitError
from ..kinds import KINDS, Kind
from .junction import quadratic_factor
from .stamps import Triplets

#: The transmission line's two port currents (ngspice's names: ``t1#i1``, ``t1#i2``).
_TLINE = KINDS["tline"].currents

if TYPE_CHECKING:
    from ..mna.layout import Layout

__all__ = ["LinearStamps", "stamp_linear", "capacitances", "conductances", "inductances", "branch_names",
           "resistor_noise", "initial_currents", "add_initial_charges", "ZERO_RESISTANCE"]


def branch_names(el: Element) -> tuple[str, ...]:
    """The branch-current unknowns an element adds, by name (its kind's ``currents``; none for most kinds)."""
    return tuple(el.name + suffix for suffix in KINDS[el.kind].currents)


#: ngspice replaces a resistance of exactly zero by 1 milliohm (with a warning); so does netdae.
ZERO_RESISTANCE = 1e-3


@dataclass
class LinearStamps:
    """Constant parts of the MNA system.

    Attributes
    ----------
    E, H : Triplets
        Entries of dq/dx and dphi/dx.
    B : Triplets
        Source incidence, shape (n, number of independent sources): ``phi += B u(t)``.
    sources : list of Element
        Independent sources in column order of ``B``.
    notes : list of str
        What the user should know (e.g. a zero resistance replaced).
    H_ac : Triplets
        What ``.ac`` adds to dphi/dx: resistors with an ``ac=`` resistance
        conduct ``m / (ac factor scale)`` there instead of ``m / (R factor scale)``.
    D : Triplets
        The transmission lines' couplings: ``phi += D x(t - tau)`` in a transient
        (the wave arriving at each port), ``D x`` at DC.
    delay_rows, delay_tau : list of int, list of float
        The rows of ``D`` and each one's delay.
    delay_ic : list of float
        Each row's wave at the start of a ``uic`` transient (from the lines' ``ic=``).
    C_line : Triplets
        The lines' capacitance at DC, ``td / z0`` per line, half between each port's nodes: the
        charge a line holds at a uniform voltage. Not in the DAE (a line's charge travels in its
        waves), but conserved where a net is attached to the rest only through lines and
        capacitors (:mod:`netdae.analyses.op`).
    """

    E: Triplets
    H: Triplets
    B: Triplets
    sources: list[Element]
    notes: list[str]
    H_ac: Triplets
    D: Triplets = field(default_factory=Triplets)
    delay_rows: list = field(default_factory=list)
    delay_tau: list = field(default_factory=list)
    delay_ic: list = field(default_factory=list)
    C_line: Triplets = field(default_factory=Triplets)


def _temperature_factor(els: list[Element], temp: float, tnom: float) -> np.ndarray:
    """``1 + tc1 dT + tc2 dT^2`` per element, ``dT = T - tnom``; ``1.01^(tce dT)`` when ``tce`` is given.

    ``T`` is the instance's ``temp=`` when given (its ``dtemp=`` is then
    ignored, as ngspice does), else the circuit temperature plus ``dtemp=``
    (``restemp.c``, ``captemp.c``, ``indtemp.c``). ``tnom`` is the element's
    model's ``tnom`` when it has one (``params["tnom"]``), else the circuit's;
    a resistor's ``tce`` (instance or model) replaces the polynomial, as in
    ngspice's ``restemp.c``.
    """
    tc1 = np.array([el.params.get("tc1", 0.0) for el in els])
    tc2 = np.array([el.params.get("tc2", 0.0) for el in els])
    t = np.array([el.params["temp"] if "temp" in el.params else temp + el.params.get("dtemp", 0.0) for el in els])
    dt = t - np.array([el.params.get("tnom", tnom) for el in els])
    factor = quadratic_factor(tc1, tc2, dt)
    if any("tce" in el.params for el in els):
        has = np.array(["tce" in el.params for el in els])
        tce = np.array([el.params.get("tce", 0.0) for el in els])
        factor = np.where(has, 1.01 ** (tce * dt), factor)
    return factor


def _scale(els: list[Element]) -> np.ndarray:
    return np.array([el.params.get("scale", 1.0) for el in els])


def _multiplier(els: list[Element]) -> np.ndarray:
    return np.array([el.params.get("m", 1.0) for el in els])


def _values(els: list[Element]) -> np.ndarray:
    return np.array([el.value for el in els], dtype=float)


def _two_nodes(els: list[Element], layout: Layout) -> tuple[np.ndarray, np.ndarray]:
    a = layout.nodes_of([el.nodes[0] for el in els])
    b = layout.nodes_of([el.nodes[1] for el in els])
    return a, b


def _branches(els: list[Element], layout: Layout) -> np.ndarray:
    return np.array([layout.branch(el.name) for el in els], dtype=np.int64)


def conductances(els: list[Element], temp: float, tnom: float, *, ac: bool = False) -> np.ndarray:
    """Effective conductance of each resistor [S]: ``m / (R factor scale)``.

    Parameters
    ----------
    els : list of Element
        Resistors.
    temp, tnom : float
        Circuit and nominal temperature [degC].
    ac : bool
        The conductance of ``.ac`` analyses: ``R`` is the instance's ``ac=``
        resistance where given (ngspice's ``RESacConduct``), else its value.

    Returns
    -------
    ndarray, shape (len(els),)

    Notes
    -----
    A resistance of exactly zero counts as :data:`ZERO_RESISTANCE`, as in ngspice.
    """
    r = _values(els)
    if ac:
        r = np.array([el.params.get("ac", v) for el, v in zip(els, r)], dtype=float)
    return _multiplier(els) / _scaled_resistances(els, r, temp, tnom)


def _resistances_rounded(els: list[Element], temp: float, tnom: float) -> np.ndarray:
    """``R factor scale`` as :func:`conductances` computes it before its one division."""
    return _scaled_resistances(els, _values(els), temp, tnom)


def _scaled_resistances(els: list[Element], r: np.ndarray, temp: float, tnom: float) -> np.ndarray:
    """``R factor scale`` of resistances ``r`` (0 read as :data:`ZERO_RESISTANCE`).

    An infinite resistance (a model's zero width) is an open circuit, as in ngspice.

    Raises
    ------
    CircuitError
        Where the temperature factor or ``scale=`` makes the product zero or undefined (ngspice 39 divides
        by it: an infinite conductance), located at the element's card.
    """
    r = np.where(r == 0.0, ZERO_RESISTANCE, r)
    factor, scale = _temperature_factor(els, temp, tnom), _scale(els)
    out = r * factor * scale
    for k in np.flatnonzero((out == 0.0) | np.isnan(out)):
        el = els[k]
        raise CircuitError(f"{el.name}: its resistance {r[k]:g} ohm times its temperature factor "
                           f"{factor[k]:g} (tc1, tc2 or tce at its temperature) times scale={scale[k]:g} is "
                           f"{out[k]:g}: an infinite or undefined conductance", elements=(el.name,),
                           hint="check the element's scale= and temperature coefficients", location=el.location)
    return out


def resistor_noise(els: list[Element], circuit: Circuit, layout: Layout, x: np.ndarray):
    """The resistors' noise generators at the operating point (``.noise``), as ngspice 39's ``resnoise.c``.

    Per resistor, between its nodes: ``_thermal``, ``4 k T G`` with ``G`` the
    DC conductance (:func:`conductances`: m, scale, temperature coefficients;
    ``ac=`` is not used) and ``T`` the circuit temperature plus the
    instance's ``dtemp=`` (ngspice ignores dtemp, and uses the circuit
    temperature, when ``temp=`` is given); ``_1overf``,
    ``m KF |I/m|^AF / (A f^EF)`` with ``I = G v`` and the model's KF (0),
    AF (1), EF (1), ``A = (l - 2 short)^LF (w - 2 narrow)^WF`` when the
    instance gives ``l=`` or ``w=`` (else 1). Resistors with ``noisy=0`` are
    noiseless, and so are netdae's own internal resistors (named with ``#``).

    Parameters
    ----------
    els : list of Element
        The circuit's resistors.
    circuit : Circuit
    layout : Layout
    x : ndarray, shape (n + 1,)
        The extended operating point.

    Returns
    -------
    NoiseSources
    """
    from .base import flicker, noise_sources, thermal
    from .junction import KELVIN

    els = [el for el in els if el.params.get("noisy", 1.0) != 0.0 and "#" not in el.name]
    if not els:
        return noise_sources([], [])
    o = circuit.options
    g = conductances(els, o.temp, o.tnom)
    a, b = _two_nodes(els, layout)
    current = g * (x[a] - x[b])
    m = _multiplier(els)
    temp = np.array([o.temp + (0.0 if "temp" in el.params else el.params.get("dtemp", 0.0)) for el in els]) + KELVIN
    kf, af, ef, area = (np.zeros(len(els)), np.ones(len(els)), np.ones(len(els)), np.ones(len(els)))
    for k, el in enumerate(els):
        model = circuit.models.get(el.model) if el.model is not None else None
        if model is None:
            continue
        mp = model.params
        kf[k], af[k], ef[k] = mp.get("kf", 0.0), mp.get("af", 1.0), mp.get("ef", 1.0)
        if "l" in el.params or "w" in el.params:
            length = el.params.get("l", mp.get("l", 10e-6))
            width = el.params.get("w", mp.get("w", mp.get("defw", 10e-6)))
            short, narrow = mp.get("short", mp.get("dlr", 0.0)), mp.get("narrow", mp.get("dw", 0.0))
            if kf[k] != 0.0 and not (length - 2 * short > 0.0 and width - 2 * narrow > 0.0):
                raise CircuitError(f"{el.name}: model {model.name} leaves no noise area (l - 2 short = "
                                   f"{length - 2 * short:g} m, w - 2 narrow = {width - 2 * narrow:g} m) for its "
                                   "flicker noise", elements=(el.name,), hint="give l and w above 2 short and 2 narrow",
                                   location=el.location)
            area[k] = (length - 2 * short) ** mp.get("lf", 1.0) * (width - 2 * narrow) ** mp.get("wf", 1.0)
    m_safe = np.where(m != 0.0, m, 1.0)
    coefficient = np.where(kf != 0.0, m * flicker(kf, current / m_safe, af) / area, 0.0)
    return noise_sources([el.name for el in els], [
        ("_thermal", a, b, thermal(g, 1.0) * temp, 0.0, 1.0),
        ("_1overf", a, b, 0.0, coefficient, ef),
    ])


def _stamp_resistors(els, layout, st: LinearStamps, temp, tnom):
    for el in els:
        if el.value == 0.0:
            st.notes.append(f"{el.name}: resistance 0 replaced by {ZERO_RESISTANCE:g} ohm (as ngspice does)")
    rounded = _resistances_rounded(els, temp, tnom)
    m = _multiplier(els)
    g = m / rounded  # conductances(els, temp, tnom), from the one product it divides by
    a, b = _two_nodes(els, layout)
    # the exact structure reads a conductance as the reciprocal of the resistance it was rounded from (where
    # no multiplier enters: g = 1 / (R factor scale), one rounding), so that 1k beside a gain of 1000 is a
    # loop gain of exactly 1 there as in the netlist
    st.H.add_conductance(a, b, -g, recip=np.where(m == 1.0, -rounded, np.nan))
    with_ac = [k for k, el in enumerate(els) if "ac" in el.params]
    if with_ac:
        sub = [els[k] for k in with_ac]
        st.H_ac.add_conductance(a[with_ac], b[with_ac], g[with_ac] - conductances(sub, temp, tnom, ac=True))


def capacitances(els: list[Element], temp: float, tnom: float) -> np.ndarray:
    """Effective capacitance of each capacitor [F]: value, multiplier ``m``, ``scale`` and temperature coefficients."""
    return _values(els) * _multiplier(els) * _temperature_factor(els, temp, tnom) * _scale(els)


def inductances(els: list[Element], temp: float, tnom: float) -> np.ndarray:
    """Inductance of each inductor [H] before its multiplier: value, ``scale`` and temperature coefficients.

    This is ngspice's ``INDinduct`` (``indtemp.c``): the value a coupling
    ``K`` sees (``M = k sqrt(L1 L2)``); the branch law uses ``L / m``.
    """
    return _values(els) * _temperature_factor(els, temp, tnom) * _scale(els)


def initial_currents(circuit: Circuit, layout: Layout, x: np.ndarray) -> None:
    """Set the branch currents of inductors with ``ic=`` in ``x`` (ngspice's ``uic`` state).

    Parameters
    ----------
    x : ndarray, shape (n,)
        The unknowns, changed in place.
    """
    for el in circuit.elements:
        if el.kind == Kind.INDUCTOR and "ic" in el.params:
            x[layout.branch(el.name)] = el.params["ic"]


def add_initial_charges(circuit: Circuit, layout: Layout, x: np.ndarray, q: np.ndarray) -> None:
    """Give capacitors with ``ic=`` their initial charge (ngspice's ``uic`` state).

    ``q`` holds the charges of the state ``x``; each capacitor's charge
    ``C (ic - v)`` beyond what its node voltages ``v`` give is added to the
    charges of its two nodes, so the transient starts with the capacitor at
    ``ic`` whatever its nodes' voltages.

    Parameters
    ----------
    x : ndarray, shape (n,)
    q : ndarray, shape (n,)
        The charges at ``x``, changed in place.
    """
    caps = [el for el in circuit.elements if el.kind == Kind.CAPACITOR and "ic" in el.params]
    if not caps:
        return
    for el, c in zip(caps, capacitances(caps, circuit.options.temp, circuit.options.tnom)):
        a, b = layout.node(el.nodes[0]), layout.node(el.nodes[1])
        va = x[a] if a >= 0 else 0.0
        vb = x[b] if b >= 0 else 0.0
        dq = c * (el.params["ic"] - (va - vb))
        if a >= 0:
            q[a] += dq
        if b >= 0:
            q[b] -= dq


def _stamp_capacitors(els, layout, st: LinearStamps, temp, tnom):
    c = capacitances(els, temp, tnom)
    a, b = _two_nodes(els, layout)
    st.E.add_conductance(a, b, c)


def _stamp_branch_kcl(els, layout, st: LinearStamps) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """KCL part of a branch element: the branch current leaves node a, enters node b."""
    a, b = _two_nodes(els, layout)
    k = _branches(els, layout)
    st.H.add_incidence(a, b, k, row_sign=0.0, col_sign=-1.0)
    return a, b, k


def _stamp_inductors(els, layout, st: LinearStamps, temp, tnom):
    a, b, k = _stamp_branch_kcl(els, layout, st)
    st.H.add_incidence(a, b, k, row_sign=1.0, col_sign=0.0)
    st.E.add(k, k, inductances(els, temp, tnom) / _multiplier(els))


#: An inductance matrix is refused when an eigenvalue is below -COUPLING_ROUNDING times the largest:
#: a perfect coupling (|k| = 1) gives an eigenvalue of 0 up to the rounding of k sqrt(L1 L2).
COUPLING_ROUNDING = 1e-12


def _stamp_couplings(els, layout, st: LinearStamps, circuit: Circuit, inductors: list[Element], temp, tnom):
    """Mutual inductances ``M = k sqrt(L1 L2)`` of the temperature-corrected inductances.

    Each group of coupled inductors must be positive definite (checked, as
    ngspice's ``muttemp.c`` does, on the inductances before their multipliers).
    """
    value = dict(zip((ind.name for ind in inductors), inductances(inductors, temp, tnom)))
    groups: dict[str, set[str]] = {}
    mutual: dict[tuple[str, str], float] = defaultdict(float)
    for el in els:
        names = list(el.controls)
        inductors = [circuit.element(nm) for nm in names]
        for ind in inductors:
            if ind.kind != Kind.INDUCTOR:
                raise CircuitError(f"{el.name}: {ind.name} is not an inductor", elements=(el.name, ind.name))
        for i in range(len(inductors)):
            for j in range(i + 1, len(inductors)):
                li, lj = inductors[i], inductors[j]
                m = el.value * np.sqrt(abs(value[li.name] * value[lj.name]))
                mutual[(li.name, lj.name)] += m
                mutual[(lj.name, li.name)] += m
        merged = set(names)
        for nm in names:
            merged |= groups.get(nm, set())
        for nm in merged:
            groups[nm] = merged
    rows, cols, vals = [], [], []
    for (p, q), m in mutual.items():
        rows.append(layout.branch(p))
        cols.append(layout.branch(q))
        vals.append(m)
    st.E.add(np.array(rows, dtype=np.int64), np.array(cols, dtype=np.int64), np.array(vals))
    seen: set[int] = set()
    for group in groups.values():
        if id(group) in seen:
            continue
        seen.add(id(group))
        members = sorted(group)
        mat = np.array(
            [[value[p] if p == q else mutual.get((p, q), 0.0) for q in members] for p in members]
        )
        eig = np.linalg.eigvalsh(mat)
        if np.any(eig < -COUPLING_ROUNDING * np.max(np.abs(eig))):
            coupling_els = [el for el in els if set(el.controls) <= group]
            couplings = sorted(el.name for el in coupling_els)
            # located at the coupling written last: the one that closes the group
            located = [el for el in coupling_els if el.location is not None]
            last = max(located, key=lambda el: (el.location.file, el.location.line)) if located else None
            raise CircuitError(
                f"{last.name + ': ' if last is not None else ''}the inductance matrix of the coupled inductors "
                f"{', '.join(members)} is not positive definite (couplings {', '.join(couplings)})",
                elements=tuple(members) + tuple(couplings),
                hint="coupling factors must satisfy |k| < 1 and together describe a physical transformer",
                location=last.location if last is not None else None,
            )


def _stamp_vsources(els, layout, st: LinearStamps, col0: int):
    a, b, k = _stamp_branch_kcl(els, layout, st)
    st.H.add_incidence(a, b, k, row_sign=1.0, col_sign=0.0)
    cols = col0 + np.arange(len(els))
    st.B.add(k, cols, -1.0)


def _stamp_isources(els, layout, st: LinearStamps, col0: int):
    a, b = _two_nodes(els, layout)
    cols = col0 + np.arange(len(els))
    st.B.add(np.concatenate([a, b]), np.concatenate([cols, cols]), np.concatenate([-np.ones(len(els)), np.ones(len(els))]))


def _control_nodes(els, layout) -> tuple[np.ndarray, np.ndarray]:
    c = layout.nodes_of([el.nodes[2] for el in els])
    d = layout.nodes_of([el.nodes[3] for el in els])
    return c, d


def _control_branches(els, layout) -> np.ndarray:
    return np.array([layout.branch(el.controls[0]) for el in els], dtype=np.int64)


def _stamp_vcvs(els, layout, st: LinearStamps):
    a, b, k = _stamp_branch_kcl(els, layout, st)
    st.H.add_incidence(a, b, k, row_sign=1.0, col_sign=0.0)
    c, d = _control_nodes(els, layout)
    gain = _values(els)
    st.H.add(np.concatenate([k, k]), np.concatenate([c, d]), np.concatenate([-gain, gain]))


def _stamp_opamps(els, layout, st: LinearStamps):
    _, _, k = _stamp_branch_kcl(els, layout, st)
    c, d = _control_nodes(els, layout)
    one = np.ones(len(els))
    st.H.add(np.concatenate([k, k]), np.concatenate([c, d]), np.concatenate([one, -one]))


def _stamp_vccs(els, layout, st: LinearStamps):
    a, b = _two_nodes(els, layout)
    c, d = _control_nodes(els, layout)
    g = _values(els) * _multiplier(els)
    st.H.add(np.concatenate([a, a, b, b]), np.concatenate([c, d, c, d]), np.concatenate([-g, g, g, -g]))


def _stamp_cccs(els, layout, st: LinearStamps):
    a, b = _two_nodes(els, layout)
    j = _control_branches(els, layout)
    f = _values(els) * _multiplier(els)
    st.H.add(np.concatenate([a, b]), np.concatenate([j, j]), np.concatenate([-f, f]))


def _stamp_ccvs(els, layout, st: LinearStamps):
    a, b, k = _stamp_branch_kcl(els, layout, st)
    st.H.add_incidence(a, b, k, row_sign=1.0, col_sign=0.0)
    j = _control_branches(els, layout)
    st.H.add(k, j, -_values(els))


def _stamp_tlines(els, layout, st: LinearStamps):
    """Lossless lines by the method of characteristics (ngspice's TRA).

    With ``i1``, ``i2`` the currents entering the line at its ports and
    ``v1``, ``v2`` the port voltages, the line is
    ``v1 - z0 i1 = (v2 + z0 i2)(t - td)`` and ``v2 - z0 i2 = (v1 + z0 i1)(t - td)``:
    each branch row is a resistance z0 (here, in H) behind the wave that left
    the other port a delay ago (``D``, applied to the delayed solution).
    """
    for port, (pos, neg, other_pos, other_neg) in enumerate(((0, 1, 2, 3), (2, 3, 0, 1))):
        a = layout.nodes_of([el.nodes[pos] for el in els])
        b = layout.nodes_of([el.nodes[neg] for el in els])
        c = layout.nodes_of([el.nodes[other_pos] for el in els])
        d = layout.nodes_of([el.nodes[other_neg] for el in els])
        k = np.array([layout.branch(el.name + _TLINE[port]) for el in els], dtype=np.int64)
        j = np.array([layout.branch(el.name + _TLINE[1 - port]) for el in els], dtype=np.int64)
        z0 = np.array([el.params["z0"] for el in els])
        st.H.add_incidence(a, b, k, row_sign=1.0, col_sign=-1.0)
        st.H.add(k, k, -z0)
        st.D.add(np.concatenate([k, k, k]), np.concatenate([c, d, j]), np.concatenate([-np.ones(len(els)),
                                                                                       np.ones(len(els)), -z0]))
        st.delay_rows.extend(k.tolist())
        st.delay_tau.extend(el.params["td"] for el in els)
        st.C_line.add_conductance(a, b, np.array([el.params["td"] for el in els]) / (2.0 * z0))
        v, i = ("v2", "i2") if port == 0 else ("v1", "i1")
        st.delay_ic.extend(-(el.params.get(v, 0.0) + el.params["z0"] * el.params.get(i, 0.0)) for el in els)


def stamp_linear(circuit: Circuit, layout: Layout, by_kind: dict[str, list[Element]]) -> LinearStamps:
    """Stamp every linear element of ``circuit``.

    Parameters
    ----------
    circuit : Circuit
    layout : Layout
        With every node and every branch unknown already allocated.
    by_kind : dict of str to list of Element
        The circuit's elements grouped by kind.

    Returns
    -------
    LinearStamps

    Raises
    ------
    CircuitError
        For a coupling matrix that is not positive definite, or a K that
        names something other than an inductor.

    Notes
    -----
    Cost O(number of elements); the matrices are built once per circuit.
    """
    st = LinearStamps(Triplets(), Triplets(), Triplets(), [], [], Triplets())
    temp, tnom = circuit.options.temp, circuit.options.tnom
    get = lambda kind: by_kind.get(kind, [])  # noqa: E731
    if get("resistor"):
        _stamp_resistors(get("resistor"), layout, st, temp, tnom)
    if get("capacitor"):
        _stamp_capacitors(get("capacitor"), layout, st, temp, tnom)
    if get("inductor"):
        _stamp_inductors(get("inductor"), layout, st, temp, tnom)
    if get("coupling"):
        _stamp_couplings(get("coupling"), layout, st, circuit, get("inductor"), temp, tnom)
    if get("vsource"):
        _stamp_vsources(get("vsource"), layout, st, 0)
        st.sources.extend(get("vsource"))
    if get("isource"):
        _stamp_isources(get("isource"), layout, st, len(st.sources))
        st.sources.extend(get("isource"))
    if get("vcvs"):
        _stamp_vcvs(get("vcvs"), layout, st)
    if get("opamp"):
        _stamp_opamps(get("opamp"), layout, st)
    if get("vccs"):
        _stamp_vccs(get("vccs"), layout, st)
    if get("cccs"):
        _stamp_cccs(get("cccs"), layout, st)
    if get("ccvs"):
        _stamp_ccvs(get("ccvs"), layout, st)
    if get("tline"):
        _stamp_tlines(get("tline"), layout, st)
    return st
