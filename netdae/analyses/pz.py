"""Pole-zero analysis (``.pz in+ in- out+ out- cur|vol pol|zer|pz``).

The circuit is linearised at its DC operating point exactly as for ``.ac``
(:func:`netdae.analyses.ac.linearize`, the resistors' ``ac=`` values
included): ``E x' = H x + b u``, ``y = c x``, with ``u`` the input the
card's port implies and ``y = v(out+) - v(out-)``.

The input port, as ngspice defines it (measured with ngspice 39: the poles
of ``cur`` are those of the circuit with the port open, those of ``vol``
with the port shorted):

``cur``
    a current source driving the port: ``b`` injects into ``in+`` and draws
    from ``in-``; the transfer function is an impedance (output voltage over
    input current);
``vol``
    a voltage source across the port: an independent V source of the circuit
    that already stands exactly across ``in+``/``in-`` is that source (its
    branch equation takes the input); otherwise one is added (an extra
    branch current and a branch equation ``v(in+) - v(in-) = u``). Its
    transfer function is a voltage gain.

Every other independent source keeps its small-signal value, zero: I
sources are open, V sources are shorts -- except a V source with an AC value
(``ac mag``), which ngspice's pole-zero analysis removes (an open circuit:
``vsrcpzld.c`` replaces its branch equation by ``i = 0``, the source being
taken for the stimulus the port stands for), and so does netdae. (An
``ac 0`` is not told apart from no ``ac``.)

Poles are the finite eigenvalues of the pencil ``s E - H`` (the natural
frequencies of the circuit with the input port so closed); zeros are the
finite eigenvalues of Rosenbrock's system pencil

    s [[E, 0], [0, 0]] - [[H, b], [c, 0]]

whose determinant is ``-det(s E - H) G(s)`` for the transfer function
``G(s) = c (s E - H)^-1 b``: zeros of the numerator, uncancelled, as
ngspice reports them (a mode the input does not excite or the output does
not see is both a pole and a zero). The eigenvalues at infinity of either
pencil are deflated structurally by the staircase of
:func:`netdae.dae.pencil.finite_eigenvalues`: rank decisions on the balanced
pencil at ``n * eps`` of its norm, the same decisions ``netdae index``
makes, rather than a cut-off on the QZ eigenvalues' magnitudes. Roots are in
rad/s (``s``), as ngspice prints them.

A singular pencil is refused with its structural reason: ``s E - H``
singular (a loop of voltage sources, which ``vol`` can close, a cutset of
current sources, a floating sub-network), or the Rosenbrock pencil singular,
which for one input and one output means ``G(s) = 0`` for every s.

Cost: dense, O(n^3) for n unknowns (a staircase of SVDs and one QZ per
pencil); refused above :data:`netdae.dae.pencil.DENSE_LIMIT` unknowns.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace

import numpy as np
import scipy.sparse as sp

from ..circuit import Circuit, Element, PzAnalysis
from ..errors import CircuitError, SingularPencilError
from ..kinds import Kind
from ..results import Result, Statistics
from .op import op_result

__all__ = ["PoleZero", "pz_analysis", "pole_zero", "port_system", "rosenbrock", "sort_roots", "conjugate_symmetric",
           "root_names",
           "format_root", "INPUT_SOURCE"]

#: Name of the voltage source ``.pz ... vol`` adds across the input port (in messages).
INPUT_SOURCE = "v.pz_input"


@dataclass
class PoleZero:
    """Poles and zeros of one input/output pair.

    Attributes
    ----------
    poles, zeros : ndarray of complex
        In rad/s, sorted by :func:`sort_roots`; None when not asked for.
    n_infinite_poles, n_infinite_zeros : int
        Eigenvalues at infinity the staircase removed from each pencil.
    notes : list of str
    """

    poles: np.ndarray | None
    zeros: np.ndarray | None
    n_infinite_poles: int = 0
    n_infinite_zeros: int = 0
    notes: list = None


def sort_roots(roots) -> np.ndarray:
    """Roots by increasing magnitude, a conjugate pair with its positive imaginary part first.

    Examples
    --------
    >>> sort_roots([-2.0, -1 - 1j, -1 + 1j]).tolist()
    [(-1+1j), (-1-1j), (-2+0j)]
    """
    r = np.asarray(roots, dtype=complex)
    if r.size == 0:
        return r
    mag = np.abs(r)
    scale = mag.max()
    if scale > 0:  # a conjugate pair's magnitudes may differ in the last bits
        mag = np.round(mag / scale, 9)
    return r[np.lexsort((-r.imag, mag))]


def conjugate_symmetric(roots) -> np.ndarray:
    """The roots of a real polynomial made exactly conjugate-symmetric.

    LAPACK's QZ returns a complex pair of a real pencil as ``alpha_j / beta_j``
    and ``alpha_{j+1} / beta_{j+1}`` with different ``beta``, so the two
    differ from conjugates in the last bits; each pair is replaced by the
    mean of one and the other's conjugate, and its conjugate.

    Examples
    --------
    >>> conjugate_symmetric([-1 + 2j, -1.5 - 2j, 3]).tolist()
    [(-1.25+2j), (-1.25-2j), (3+0j)]
    """
    r = np.array(roots, dtype=complex)
    upper = [k for k in range(r.size) if r[k].imag > 0]
    lower = [k for k in range(r.size) if r[k].imag < 0]
    for k in upper:
        if not lower:
            break
        j = min(lower, key=lambda m: abs(r[m] - np.conj(r[k])))
        lower.remove(j)
        mean = (r[k] + np.conj(r[j])) / 2
        r[k], r[j] = mean, np.conj(mean)
    return r


def root_names(kind: str, count: int) -> list[str]:
    """ngspice's vector names ``pole(1)``, ``pole(2)`` ... (or ``zero(k)``)."""
    return [f"{kind}({k + 1})" for k in range(count)]


def format_root(name: str, value: complex) -> str:
    """One root as ngspice prints it in batch mode: ``pole(1) = -5.00000e+02,3.161882e+04``.

    Examples
    --------
    >>> format_root("pole(1)", -500 + 31618.8235j)
    'pole(1) = -5.000000e+02,3.161882e+04'
    """
    return f"{name} = {value.real:.6e},{value.imag:.6e}"


def rosenbrock(E, H, b, c) -> tuple[np.ndarray, np.ndarray]:
    """Rosenbrock's system pencil of ``E x' = H x + b u``, ``y = c x``: ``(E_r, H_r)``.

    ``s E_r - H_r = [[s E - H, -b], [-c, 0]]``: its finite eigenvalues are the
    (invariant) zeros of the transfer function ``c (s E - H)^-1 b``.

    Parameters
    ----------
    E, H : array_like or sparse, shape (n, n)
    b, c : array_like, shape (n,)

    Returns
    -------
    E_r, H_r : ndarray, shape (n + 1, n + 1)
    """
    E = E.toarray() if sp.issparse(E) else np.asarray(E, dtype=float)
    H = H.toarray() if sp.issparse(H) else np.asarray(H, dtype=float)
    n = E.shape[0]
    Er = np.zeros((n + 1, n + 1))
    Hr = np.zeros((n + 1, n + 1))
    Er[:n, :n] = E
    Hr[:n, :n] = H
    Hr[:n, n] = b
    Hr[n, :n] = c
    return Er, Hr


def port_system(E, H, B, names: list[str], node_index, sources: list[str], elements, card: PzAnalysis,
                opened=()):
    """The linearisation closed by the card's input port: ``(E, H, b, c, how)``.

    Parameters
    ----------
    E, H : sparse, shape (n, n)
        The linearisation (``H`` with the ``ac=`` resistances).
    B : sparse, shape (n, m)
        The independent sources' input matrix (``dphi/du``).
    names : list of str
        The unknowns' names.
    node_index : callable
        Node name to unknown index (-1 for ground).
    sources : list of str
        The independent sources, in the column order of ``B``.
    elements : iterable of Element
        The circuit's elements (to find a V source across the input port).
    card : PzAnalysis
    opened : sequence of (str, int)
        V sources removed (their name and branch): the branch equation
        becomes ``i = 0``.

    Returns
    -------
    E, H : ndarray, shape (N, N)
        ``N = n``, or ``n + 1`` when a voltage source was added across the port.
    b, c : ndarray, shape (N,)
    how : str
        How the input was realised (for the result's notes).
    """
    E = E.toarray() if sp.issparse(E) else np.asarray(E, dtype=float)
    H = H.toarray() if sp.issparse(H) else np.asarray(H, dtype=float)
    n = E.shape[0]
    if opened:
        H = H.copy()
        for _, k in opened:
            H[k, :] = 0.0
            H[k, k] = 1.0
    gone = {name for name, _ in opened}

    def incidence(pos: str, neg: str, size: int) -> np.ndarray:
        v = np.zeros(size)
        for node, sign in ((pos, 1.0), (neg, -1.0)):
            k = node_index(node)
            if k >= 0:
                v[k] += sign
        return v

    port = f"{card.in_pos}-{card.in_neg}"
    if card.input_type == "cur":
        b = incidence(card.in_pos, card.in_neg, n)
        how = f"input: a current source driving the port {port} (the port is otherwise open)"
        c = incidence(card.out_pos, card.out_neg, n)
        return E, H, b, c, how
    across = [el for el in elements if el.kind == Kind.VSOURCE and el.name not in gone
              and set(el.nodes) == {card.in_pos, card.in_neg}]
    if across:
        name = across[0].name
        col = sources.index(name)
        b = np.asarray(B[:, [col]].toarray() if sp.issparse(B) else np.asarray(B)[:, [col]]).ravel()
        how = f"input: the voltage source {name} across the port {port}"
        return E, H, b, incidence(card.out_pos, card.out_neg, n), how
    a = incidence(card.in_pos, card.in_neg, n)
    Ea = np.zeros((n + 1, n + 1))
    Ha = np.zeros((n + 1, n + 1))
    Ea[:n, :n] = E
    Ha[:n, :n] = H
    Ha[:n, n] = -a  # the source's current leaves in+ and enters in-
    Ha[n, :n] = a  # its branch equation: v(in+) - v(in-) + u = 0
    b = np.zeros(n + 1)
    b[n] = 1.0
    how = f"input: a voltage source added across the port {port} (the port is shorted for the poles)"
    return Ea, Ha, b, incidence(card.out_pos, card.out_neg, n + 1), how


def pole_zero(E, H, b, c, *, what: str = "pz") -> PoleZero:
    """Poles and zeros of ``c (s E - H)^-1 b``, from the two pencils.

    Parameters
    ----------
    E, H : array_like, shape (n, n)
    b, c : array_like, shape (n,)
    what : {"pz", "pol", "zer"}

    Returns
    -------
    PoleZero

    Raises
    ------
    SingularPencilError
        When ``s E - H`` is singular, or (for zeros) when the transfer function
        is identically zero (the Rosenbrock pencil is singular).

    Examples
    --------
    The RC low-pass above: a pole at -1/RC, no zero (two at infinity).

    >>> E = [[0, 0, 0], [0, 1e-6, 0], [0, 0, 0]]
    >>> H = [[-1e-3, 1e-3, -1], [1e-3, -1e-3, 0], [1, 0, 0]]
    >>> pz = pole_zero(E, H, [0, 0, 1.0], [0, 1.0, 0])
    >>> pz.poles.real.round(6).tolist(), pz.zeros.tolist()
    ([-1000.0], [])
    """
    from ..dae.pencil import finite_eigenvalues

    notes: list[str] = []
    spec = finite_eigenvalues(E, H)
    if not spec.regular:
        raise SingularPencilError("the pencil s E - H of the linearised circuit is singular: det(s E - H) = 0 "
                                  "for every s, so poles are not defined",
                                  hint="look for loops of voltage sources or cutsets of current sources")
    notes += list(spec.notes)
    poles = sort_roots(conjugate_symmetric(spec.eigenvalues)) if what in ("pz", "pol") else None
    zeros = None
    n_inf_z = 0
    if what in ("pz", "zer"):
        zspec = finite_eigenvalues(*rosenbrock(E, H, np.asarray(b, dtype=float), np.asarray(c, dtype=float)))
        if not zspec.regular:
            raise SingularPencilError(
                "the transfer function from the input port to the output port is identically zero (the "
                "Rosenbrock system pencil is singular): every s is a zero",
                hint="the output port does not depend on the input; check the .pz nodes")
        notes += list(zspec.notes)
        zeros = sort_roots(conjugate_symmetric(zspec.eigenvalues))
        n_inf_z = zspec.n_infinite
    return PoleZero(poles, zeros, spec.n_infinite, n_inf_z, notes)


def _explain_singular(circuit: Circuit, card: PzAnalysis, added: bool) -> SingularPencilError:
    from ..topology import pencil_singularity_explanation

    target = circuit
    if added:
        source = Element(INPUT_SOURCE, "vsource", (card.in_pos, card.in_neg))
        target = replace(circuit, elements=[*circuit.elements, source])
    why = pencil_singularity_explanation(target)
    extra = (f" ({INPUT_SOURCE} is the voltage source .pz vol places across the input port "
             f"{card.in_pos}-{card.in_neg})") if added else ""
    if why is not None:
        return SingularPencilError(f".pz: {why.message}{extra}", elements=why.elements, nodes=why.nodes,
                                   hint=why.hint)
    return SingularPencilError(f".pz: the pencil s E - H of the linearised circuit is singular{extra}: "
                               "det(s E - H) = 0 for every s, so poles are not defined",
                               hint="look for loops of voltage sources or cutsets of current sources"
                               + ("; or use cur instead of vol" if added else ""))


def pz_analysis(circuit: Circuit, card: PzAnalysis, **overrides) -> Result:
    """Run a ``.pz`` analysis.

    Parameters
    ----------
    circuit : Circuit
    card : PzAnalysis
    **overrides
        Operating-point tolerances (``reltol``, ...).

    Returns
    -------
    Result
        ``analysis == "pz"``, no axis; one complex signal per root named as
        ngspice names them (``pole(1)``, ``pole(2)`` ..., ``zero(1)`` ...), each
        of one point; ``poles``, ``zeros`` (arrays, None when not asked for),
        ``operating_point`` the operating point.

    Raises
    ------
    SingularPencilError
        A singular pencil (module docstring), with the elements responsible.
    CircuitError, ConvergenceError
        No operating point; more unknowns than the dense analysis takes.
    """
    from ..dae.pencil import DENSE_LIMIT
    from .ac import linearize
    from .index import check_magnitudes

    t0 = time.perf_counter()
    lin = linearize(circuit, **overrides)
    system = lin.system
    if system.delays is not None:
        lines = sorted({el.name for el in circuit.elements if el.kind == Kind.TLINE})
        raise CircuitError(f".pz: the transmission lines {', '.join(lines[:5])} make the transfer function "
                           "transcendental (exp(-s td)): it has no finite set of poles and zeros",
                           elements=tuple(lines), hint="use .ac for the frequency response, or replace the "
                           "line by an LC ladder")
    if system.n + 1 > DENSE_LIMIT:
        raise CircuitError(f".pz: {system.n} unknowns: the pole-zero analysis is dense (O(n^3)) and takes at most "
                           f"{DENSE_LIMIT - 1}", hint="analyse a smaller sub-circuit")
    opened = [(el.name, system.layout.branch(el.name)) for el in circuit.elements
              if el.kind == Kind.VSOURCE and el.source is not None and el.source.ac_mag != 0.0]
    E, H, b, c, how = port_system(lin.E, lin.H_ac, system.B, list(system.names), system.node_index,
                                  list(system.sources.names), circuit.elements, card, opened)
    added = E.shape[0] > system.n
    check_magnitudes(lin.E, lin.H_ac, list(system.names), ".pz")
    try:
        pz = pole_zero(E, H, b, c, what=card.what)
    except SingularPencilError as exc:
        if "identically zero" in exc.message:
            raise SingularPencilError(f".pz: {exc.message}", hint=exc.hint) from None
        raise _explain_singular(circuit, card, added) from None
    signals: dict[str, np.ndarray] = {}
    for kind, roots in (("pole", pz.poles), ("zero", pz.zeros)):
        if roots is not None:
            signals.update({name: np.array([r]) for name, r in zip(root_names(kind, roots.size), roots)})
    notes = list(system.notes) + [how] + pz.notes
    if opened:
        notes.append("removed (open), as ngspice's pole-zero analysis removes V sources with an AC value: "
                     + ", ".join(name for name, _ in opened))
    counts = []
    if pz.poles is not None:
        counts.append(f"{pz.poles.size} finite pole(s), {pz.n_infinite_poles} eigenvalue(s) at infinity removed")
    if pz.zeros is not None:
        counts.append(f"{pz.zeros.size} finite zero(s), {pz.n_infinite_zeros} at infinity removed")
    notes.append("; ".join(counts))
    wall = time.perf_counter() - t0
    return Result(
        "pz",
        signals=signals,
        stats=Statistics(poles=None if pz.poles is None else int(pz.poles.size),
                         zeros=None if pz.zeros is None else int(pz.zeros.size),
                         wall_time=wall, newton_iterations=lin.op.iterations, **system.describe()),
        message="ok",
        tolerances={"reltol": lin.options.reltol, "vntol": lin.options.vntol, "abstol": lin.options.abstol},
        notes=notes,
        operating_point=op_result(system, lin.op, 0.0, lin.options), poles=pz.poles, zeros=pz.zeros,
        card=card,
    )
