"""The two-bit adding unit of the Test Set for IVP Solvers (problem "tba"), as published.

An oracle independent of netdae: the Test Set's equations of the circuit
(Mazzia, Magherini et al., Test Set for IVP Solvers, University of Bari,
release 2.4, problem tba, from Guenther and Rentrop) written node by node as
its description gives them, vectorised over a batch of states:

- ``currents(U, t)``: f(U, t), the static currents entering each of the 175
  nodes (its FCN), with the gate capacitances' input terms ``CGS * U'_in``
  of the nodes an input pulse drives through a gate;
- ``charges(U)``: g(U), the charge of each node (its GCN), with the
  published irregularities kept (a load's drain-side bulk charge
  ``CBDBS(U - VDD) U``, each NOR gate's node I+12 reading node I+14);
- ``inputs(t)``: the five input pulses and their slopes;
- ``input_charges(t)``: c(t), the part of g that netdae's capacitors to the
  input sources carry as ``-C U_in``: netdae's node charges are
  ``q = g(U) - c(t)`` and its right-hand side ``phi = f(U, t) - c'(t)``.

The formulation is ``y' = f(U, t), 0 = y - g(U)``; time in the Test Set's
scaled units (CTIME = 1e4). Every function accepts complex states (the
branches compare real parts), so derivatives follow by complex step.
A square root of a negative argument (the Test Set's IERR = -1) is NaN.
"""

from __future__ import annotations

import numpy as np

N = 175

CTIME = 1e4
STIFF = 5.0

#: The published constants (the scaled problem).
CONSTANTS = dict(
    rgs=40.0 / (CTIME * STIFF), rgd=40.0 / (CTIME * STIFF),
    rbs=100.0 / (CTIME * STIFF), rbd=100.0 / (CTIME * STIFF),
    cgs=0.6e-4 * CTIME, cgd=0.6e-4 * CTIME, cbd=2.4e-5 * CTIME,
    cload=0.0, cout=2e-4 * CTIME, delta=0.02, curis=1e-15 * CTIME * STIFF,
    vth=25.85, vdd=5.0, vbb=-2.5, phib=0.87,
)

#: (VT0, CGAMMA, PHI, BETA) of the transistor kinds NED = 0 (depletion load), 1, 2, 3
#: (enhancement, one, two and three in series).
MOS = {
    0: (-2.43, 0.2, 1.28, 53.5e-6 * CTIME * STIFF),
    1: (0.2, 0.035, 1.01, 4 * 43.7e-6 * CTIME * STIFF),
    2: (0.2, 0.035, 1.01, 8 * 43.7e-6 * CTIME * STIFF),
    3: (0.2, 0.035, 1.01, 12 * 43.7e-6 * CTIME * STIFF),
}

#: The input pulses V1, V2, V3, V4, CIN: (delay, rise, high, fall, period), low 0 V, high 5 V.
PULSES = (
    (0.0, 5.0, 5.0, 5.0, 20.0),
    (10.0, 5.0, 15.0, 5.0, 40.0),
    (30.0, 5.0, 35.0, 5.0, 80.0),
    (70.0, 5.0, 75.0, 5.0, 160.0),
    (150.0, 5.0, 155.0, 5.0, 320.0),
)
V1, V2, V3, V4, CIN = range(5)


def pulse(t, delay, rise, high, fall, period, low=0.0, top=5.0):
    """The Test Set's periodic trapezoid at times ``t``: (value, slope), each shaped as ``t``."""
    tm = np.mod(np.asarray(t, dtype=float), period)
    up, down = (top - low) / rise, (top - low) / fall
    v = np.select([tm > delay + rise + high + fall, tm > delay + rise + high, tm > delay + rise, tm > delay],
                  [low, (delay + rise + high + fall - tm) * down + low, top, (tm - delay) * up + low], low)
    d = np.select([tm > delay + rise + high + fall, tm > delay + rise + high, tm > delay + rise, tm > delay],
                  [0.0, -down, 0.0, up], 0.0)
    return v, d


def inputs(t):
    """The five inputs at time ``t`` (a scalar): values and slopes, arrays of shape (5,)."""
    vals = [pulse(t, *p) for p in PULSES]
    return np.array([float(v) for v, _ in vals]), np.array([float(d) for _, d in vals])


def _sqrt(x):
    """sqrt with NaN for a negative real part (the Test Set's IERR = -1), complex-step safe."""
    with np.errstate(invalid="ignore"):
        return np.where(np.real(x) < 0, np.nan, np.sqrt(x + 0j if np.iscomplexobj(x) else np.maximum(x, 0.0)))


def ids(ned, vds, vgs, vbs, vgd, vbd, c):
    """Shichman-Hodges drain current of a transistor of kind ``ned`` (negative for vds > 0)."""
    vt0, gam, phi, beta = MOS[ned]
    delta = c["delta"]
    vgst = vgs - (vt0 + gam * (_sqrt(phi - vbs) - np.sqrt(phi)))
    vgdt = vgd - (vt0 + gam * (_sqrt(phi - vbd) - np.sqrt(phi)))
    r = np.real
    plus = np.where(r(vgst) <= 0, 0.0,
                    np.where(r(vgst) <= r(vds), -beta * vgst ** 2 * (1 + delta * vds),
                             -beta * vds * (2 * vgst - vds) * (1 + delta * vds)))
    minus = np.where(r(vgdt) <= 0, 0.0,
                     np.where(r(vgdt) <= -r(vds), beta * vgdt ** 2 * (1 - delta * vds),
                              -beta * vds * (2 * vgdt + vds) * (1 - delta * vds)))
    return np.where(r(vds) > 0, plus, np.where(r(vds) < 0, minus, 0.0 * vds))


def ij(v, c):
    """A bulk pn-junction's current (IBS = IBD) at the bulk-to-diffusion voltage ``v``."""
    neg = np.real(v) <= 0
    return np.where(neg, -c["curis"] * (np.exp(np.where(neg, v, 0.0 * v) / c["vth"]) - 1), 0.0 * v)


def cbdbs(v, c):
    """The voltage-dependent bulk capacitance CBDBS(v)."""
    with np.errstate(invalid="ignore"):
        neg = c["cbd"] / np.sqrt(1 - np.where(np.real(v) <= 0, v, 0.0 * v) / c["phib"])
    return np.where(np.real(v) <= 0, neg, c["cbd"] * (1 + v / (2 * c["phib"])))


def _padded(U):
    """U with a leading dummy column, so ``Y[..., k]`` is the Test Set's U(k) (1-based)."""
    U = np.asarray(U)
    return np.concatenate([np.zeros(U.shape[:-1] + (1,), dtype=U.dtype), U], axis=-1)


# ------------------------------------------------------------------------ currents f(U, t)
def _load_currents(F, Y, i, c):
    """The depletion load of a gate starting at node ``i``: nodes i .. i+3."""
    vdd, vbb = c["vdd"], c["vbb"]
    t0 = ids(0, Y[..., i + 1] - Y[..., i], Y[..., i + 4] - Y[..., i], Y[..., i + 2] - Y[..., i + 4],
             Y[..., i + 4] - Y[..., i + 1], Y[..., i + 3] - vdd, c)
    F[..., i] = -(Y[..., i] - Y[..., i + 4]) / c["rgs"] - t0
    F[..., i + 1] = -(Y[..., i + 1] - vdd) / c["rgd"] + t0
    F[..., i + 2] = -(Y[..., i + 2] - vbb) / c["rbs"] + ij(Y[..., i + 2] - Y[..., i + 4], c)
    F[..., i + 3] = -(Y[..., i + 3] - vbb) / c["rbd"] + ij(Y[..., i + 3] - vdd, c)


def _switch_currents(F, Y, s, ned, u, ud, src, drn, c):
    """An enhancement transistor: source s, drain s+1, bulks s+2 (source side) and s+3 (drain
    side), gate voltage ``u`` (slope ``ud``), its source resistance to node ``src`` (0: ground),
    its drain resistance to node ``drn``."""
    vbb = c["vbb"]
    ysrc = Y[..., src] if src else 0.0
    t0 = ids(ned, Y[..., s + 1] - Y[..., s], u - Y[..., s], Y[..., s + 2] - ysrc, u - Y[..., s + 1],
             Y[..., s + 3] - Y[..., drn], c)
    F[..., s] = c["cgs"] * ud - (Y[..., s] - ysrc) / c["rgs"] - t0
    F[..., s + 1] = c["cgd"] * ud - (Y[..., s + 1] - Y[..., drn]) / c["rgd"] + t0
    F[..., s + 2] = -(Y[..., s + 2] - vbb) / c["rbs"] + ij(Y[..., s + 2] - ysrc, c)
    F[..., s + 3] = -(Y[..., s + 3] - vbb) / c["rbd"] + ij(Y[..., s + 3] - Y[..., drn], c)


def _out_node(Y, i, c, drains):
    """The current entering a gate's result node i+4 from its load and from the drain-side
    resistances and bulk junctions of the transistors ``drains`` (their first nodes)."""
    out = -(Y[..., i + 4] - Y[..., i]) / c["rgs"] - ij(Y[..., i + 2] - Y[..., i + 4], c)
    for s in drains:
        out = out - (Y[..., i + 4] - Y[..., s + 1]) / c["rgd"] - ij(Y[..., s + 3] - Y[..., i + 4], c)
    return out


def _coupling_node(Y, k, c, sources, drains):
    """The current entering an internal series node k from the source sides of ``sources`` and
    the drain sides of ``drains`` (transistors by their first nodes)."""
    out = 0.0
    for s in sources:
        out = out - (Y[..., k] - Y[..., s]) / c["rgs"] - ij(Y[..., s + 2] - Y[..., k], c)
    for s in drains:
        out = out - (Y[..., k] - Y[..., s + 1]) / c["rgd"] - ij(Y[..., s + 3] - Y[..., k], c)
    return out


def _nor(F, Y, i, u1, u2, c):
    _load_currents(F, Y, i, c)
    F[..., i + 4] = _out_node(Y, i, c, (i + 5, i + 9))
    _switch_currents(F, Y, i + 5, 1, *u1, 0, i + 4, c)
    _switch_currents(F, Y, i + 9, 1, *u2, 0, i + 4, c)


def _andoi(F, Y, i, u1, u2, u3, c):
    _load_currents(F, Y, i, c)
    F[..., i + 4] = _out_node(Y, i, c, (i + 5, i + 9))
    _switch_currents(F, Y, i + 5, 1, *u1, 0, i + 4, c)
    _switch_currents(F, Y, i + 9, 2, *u2, i + 13, i + 4, c)
    F[..., i + 13] = _coupling_node(Y, i + 13, c, (i + 9,), (i + 14,))
    _switch_currents(F, Y, i + 14, 2, *u3, 0, i + 13, c)


def _nand(F, Y, i, u1, u2, c):
    _load_currents(F, Y, i, c)
    F[..., i + 4] = _out_node(Y, i, c, (i + 5,))
    _switch_currents(F, Y, i + 5, 2, *u1, i + 9, i + 4, c)
    F[..., i + 9] = _coupling_node(Y, i + 9, c, (i + 5,), (i + 10,))
    _switch_currents(F, Y, i + 10, 2, *u2, 0, i + 9, c)


def _orani(F, Y, i, u1, u2, u3, c):
    _load_currents(F, Y, i, c)
    F[..., i + 4] = _out_node(Y, i, c, (i + 5,))
    _switch_currents(F, Y, i + 5, 2, *u1, i + 9, i + 4, c)
    F[..., i + 9] = _coupling_node(Y, i + 9, c, (i + 5,), (i + 10, i + 14))
    _switch_currents(F, Y, i + 10, 2, *u2, 0, i + 9, c)
    _switch_currents(F, Y, i + 14, 2, *u3, 0, i + 9, c)


def currents(U, t, constants=None, input_slopes=True):
    """The Test Set's f(U, t): the static currents entering each node.

    Parameters
    ----------
    U : array_like, shape (..., 175)
        Node voltages U(1) .. U(175) (real or complex).
    t : float
        Time (scaled).
    constants : dict, optional
        Overrides of :data:`CONSTANTS`.
    input_slopes : bool
        Include the gate capacitances' input terms ``CGS U'_in`` (the Test Set's f has them).

    Returns
    -------
    ndarray, shape (..., 175)
    """
    c = dict(CONSTANTS, **(constants or {}))
    Y = _padded(U)
    F = np.zeros_like(Y, dtype=np.result_type(Y, float))
    v, vd = inputs(t)
    if not input_slopes:
        vd = np.zeros(5)
    src = [(v[k], vd[k]) for k in range(5)]

    def node(k):
        return (Y[..., k], 0.0)

    _nor(F, Y, 1, src[V1], src[V2], c)
    _andoi(F, Y, 14, node(5), src[V2], src[V1], c)
    _nor(F, Y, 32, node(18), src[CIN], c)
    _andoi(F, Y, 45, node(36), src[CIN], node(18), c)
    _andoi(F, Y, 63, node(5), src[CIN], node(18), c)
    _nor(F, Y, 81, src[V3], src[V4], c)
    _andoi(F, Y, 94, node(85), src[V4], src[V3], c)
    _nand(F, Y, 112, node(67), node(98), c)
    _orani(F, Y, 126, node(116), node(67), node(98), c)
    # ANDOI gate 5: its result node 148 also takes the drain of the three series transistors
    _andoi(F, Y, 144, node(85), node(5), node(98), c)
    F[..., 148] += -(Y[..., 148] - Y[..., 163]) / c["rgd"] - ij(Y[..., 165] - Y[..., 148], c)
    # the three series transistors from node 148 to ground: gates U(98), U(18), CIN
    _switch_currents(F, Y, 162, 3, *node(98), 166, 148, c)
    F[..., 166] = _coupling_node(Y, 166, c, (162,), (167,))
    _switch_currents(F, Y, 167, 3, *node(18), 171, 166, c)
    F[..., 171] = _coupling_node(Y, 171, c, (167,), (172,))
    _switch_currents(F, Y, 172, 3, *src[CIN], 0, 171, c)
    return F[..., 1:]


# ------------------------------------------------------------------------ charges g(U)
def _load_charges(G, Y, i, c, drain_bulks):
    """The load's charges (nodes i .. i+3) and the result node i+4's, with the drain-side bulk
    junctions of the transistors whose bulk nodes are ``drain_bulks``."""
    cb = lambda v: cbdbs(v, c)  # noqa: E731
    y = lambda k: Y[..., k]  # noqa: E731
    G[..., i] += c["cgs"] * (y(i) - y(i + 4))
    G[..., i + 1] += c["cgd"] * (y(i + 1) - y(i + 4))
    G[..., i + 2] += cb(y(i + 2) - y(i + 4)) * (y(i + 2) - y(i + 4))
    G[..., i + 3] += cb(y(i + 3) - c["vdd"]) * y(i + 3)
    g = c["cgs"] * (y(i + 4) - y(i)) + c["cgd"] * (y(i + 4) - y(i + 1)) + cb(y(i + 2) - y(i + 4)) * (y(i + 4) - y(i + 2))
    for b in drain_bulks:
        g = g + cb(y(b) - y(i + 4)) * (y(i + 4) - y(b))
    G[..., i + 4] += g + c["cload"] * y(i + 4)


def _switch_charges(G, Y, s, src, drn, c, drain_node=None):
    """A transistor's own charges: gate capacitances of s, s+1 (to its gate, added by the caller's
    coupling), bulk charges of s+2 against ``src`` (0: ground) and s+3 against ``drn``."""
    cb = lambda v: cbdbs(v, c)  # noqa: E731
    y = lambda k: Y[..., k]  # noqa: E731
    ysrc = y(src) if src else 0.0
    G[..., s] += c["cgs"] * y(s)
    G[..., s + 1] += c["cgd"] * y(s + 1)
    G[..., s + 2] += cb(y(s + 2) - ysrc) * (y(s + 2) - ysrc)
    G[..., s + 3] += cb(y(s + 3) - y(drn)) * (y(s + 3) - y(drain_node if drain_node else drn))


def _series_node_charge(G, Y, k, c, bulks):
    cb = lambda v: cbdbs(v, c)  # noqa: E731
    y = lambda j: Y[..., j]  # noqa: E731
    for b in bulks:
        G[..., k] += cb(y(b) - y(k)) * (y(k) - y(b))
    G[..., k] += c["cload"] * y(k)


def _dnor(G, Y, i, c):
    _load_charges(G, Y, i, c, (i + 8, i + 12))
    _switch_charges(G, Y, i + 5, 0, i + 4, c)
    # published: node I+12's charge reads the next gate's node I+14
    _switch_charges(G, Y, i + 9, 0, i + 4, c, drain_node=i + 14)


def _dandoi(G, Y, i, c):
    _load_charges(G, Y, i, c, (i + 8, i + 12))
    _switch_charges(G, Y, i + 5, 0, i + 4, c)
    _switch_charges(G, Y, i + 9, i + 13, i + 4, c)
    _series_node_charge(G, Y, i + 13, c, (i + 11, i + 17))
    _switch_charges(G, Y, i + 14, 0, i + 13, c)


def _dnand(G, Y, i, c):
    _load_charges(G, Y, i, c, (i + 8,))
    _switch_charges(G, Y, i + 5, i + 9, i + 4, c)
    _series_node_charge(G, Y, i + 9, c, (i + 7, i + 13))
    _switch_charges(G, Y, i + 10, 0, i + 9, c)


def _dorani(G, Y, i, c):
    _load_charges(G, Y, i, c, (i + 8,))
    _switch_charges(G, Y, i + 5, i + 9, i + 4, c)
    _series_node_charge(G, Y, i + 9, c, (i + 7, i + 13, i + 17))
    _switch_charges(G, Y, i + 10, 0, i + 9, c)
    _switch_charges(G, Y, i + 14, 0, i + 9, c)


#: Gate capacitances between a result node and the transistors it drives: {node: first nodes
#: (sources) of the transistors whose gate it is}.
FANOUT = {5: (19, 68, 153), 18: (37, 59, 77, 167), 36: (50,), 67: (117, 136), 85: (99, 149),
          98: (122, 140, 158, 162), 116: (131,)}

#: The transistors an input pulse drives: {input: first nodes (sources)}.
INPUT_FANOUT = {V1: (6, 28), V2: (10, 23), V3: (86, 108), V4: (90, 103), CIN: (41, 54, 72, 172)}


def charges(U, constants=None):
    """The Test Set's g(U): the charge of each node.

    Parameters
    ----------
    U : array_like, shape (..., 175)
        Node voltages (real or complex).
    constants : dict, optional
        Overrides of :data:`CONSTANTS`.

    Returns
    -------
    ndarray, shape (..., 175)
    """
    c = dict(CONSTANTS, **(constants or {}))
    Y = _padded(U)
    G = np.zeros_like(Y, dtype=np.result_type(Y, float))
    y = lambda k: Y[..., k]  # noqa: E731
    for i in (1, 32, 81):
        _dnor(G, Y, i, c)
    for i in (14, 45, 63, 94, 144):
        _dandoi(G, Y, i, c)
    _dnand(G, Y, 112, c)
    _dorani(G, Y, 126, c)
    # the gate capacitances of the transistors a result node drives
    for out, sources in FANOUT.items():
        for s in sources:
            G[..., out] += c["cgs"] * (y(out) - y(s)) + c["cgd"] * (y(out) - y(s + 1))
            G[..., s] -= c["cgs"] * y(out)
            G[..., s + 1] -= c["cgd"] * y(out)
    # the output loads, and node 148's share of transistor 162's drain-side bulk charge
    for out in (49, 130, 148):
        G[..., out] += c["cout"] * y(out)
    G[..., 148] += cbdbs(y(165) - y(148), c) * (y(148) - y(165))
    _switch_charges(G, Y, 162, 166, 148, c)
    _switch_charges(G, Y, 167, 171, 166, c)
    _switch_charges(G, Y, 172, 0, 171, c)
    _series_node_charge(G, Y, 166, c, (164, 170))
    _series_node_charge(G, Y, 171, c, (169, 175))
    return G[..., 1:]


def input_charges(t, constants=None):
    """c(t) and c'(t), shape (175,) each: the input pulses' share of g (``CGS V_in`` at the source
    and ``CGD V_in`` at the drain of every transistor an input drives)."""
    c = dict(CONSTANTS, **(constants or {}))
    v, vd = inputs(t)
    out, slope = np.zeros(N), np.zeros(N)
    for k, sources in INPUT_FANOUT.items():
        for s in sources:
            out[s - 1] += c["cgs"] * v[k]
            out[s] += c["cgd"] * v[k]
            slope[s - 1] += c["cgs"] * vd[k]
            slope[s] += c["cgd"] * vd[k]
    return out, slope


def jacobian(fun, U, h=1e-30):
    """d fun / dU at a real state ``U`` (shape (175,)) by complex step: shape (175, 175)."""
    U = np.asarray(U, dtype=float)
    pert = U[None, :] + 1j * h * np.eye(U.size)
    return np.imag(fun(pert)).T / h
