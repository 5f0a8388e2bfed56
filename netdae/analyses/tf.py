"""Small-signal DC transfer function (``.tf outvar insrc``).

The circuit is linearised at its DC operating point
(:func:`netdae.analyses.ac.linearize`; DC resistances, as ngspice's ``.tf``):
``0 = H dx + b du`` for a change ``du`` of the input source's value, so the
response to a unit input is ``x1 = M^-1 b`` with the DC matrix ``M = -H``
and ``b`` the source's column of ``B``. Every other independent source is
zeroed (V sources shorted, I sources open). Three numbers, named and defined
as ngspice 39 defines them (``tfanal.c``):

``transfer_function``
    the output per unit input: ``v(a) - v(b)`` or the branch current of
    ``i(x)``, from ``x1``;
``<src>#input_impedance``
    seen by the input source: ``-1 / i(src)`` for a V source (its branch
    current per volt; ``1e20`` when that is below 1e-20 A, ngspice's
    "infinite"), ``v(n-) - v(n+)`` per ampere for an I source (it pushes its
    current into ``n-``);
``output_impedance_at_v(a,b)`` (voltage output)
    the voltage across the output port per unit current driven into ``a``
    and out of ``b``, inputs zeroed;
``<x>#output_impedance`` (current output ``i(x)``)
    the impedance seen by a voltage source in series with the branch of
    ``x``: ``-1 / i(x)`` per volt, as for the input (the input's impedance
    when ``x`` is the input source, as in ngspice). ngspice 39 computes
    ``1 / max(1e-20, i(x))`` instead, which is ``1e20`` for every branch
    whose current per series volt is negative, i.e. for every passive load:
    netdae does not copy that, and ``netdae compare`` says so rather than
    judging this number.

A singular DC matrix (a node without a DC path, a loop of voltage sources) is
refused with the structural reason. Sparse LU, two solves.
"""

from __future__ import annotations

import time

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..circuit import Circuit, TfAnalysis
from ..errors import CircuitError
from ..kinds import Kind
from ..results import Result, Statistics
from ..signals import parse_signal
from .op import op_result

__all__ = ["tf_analysis", "transfer", "INFINITE_IMPEDANCE", "tf_names", "output_selector"]

#: What ngspice reports for an infinite impedance (and netdae with it).
INFINITE_IMPEDANCE = 1e20
#: Below this current per volt [A/V] an impedance is reported as infinite (ngspice's threshold).
_NO_CURRENT = 1e-20


def tf_names(card: TfAnalysis) -> tuple[str, str, str]:
    """ngspice's names of the three results (lower case).

    Examples
    --------
    >>> tf_names(TfAnalysis("v(out)", "v1", written="v(out,0)"))
    ('transfer_function', 'v1#input_impedance', 'output_impedance_at_v(out,0)')
    >>> tf_names(TfAnalysis("i(vl)", "i1"))[2]
    'vl#output_impedance'
    """
    out = card.written or card.output
    if out.startswith("i("):
        last = f"{parse_signal(out).args[0]}#output_impedance"
    else:
        last = f"output_impedance_at_{out}"
    return "transfer_function", f"{card.source}#input_impedance", last


def output_selector(system, output: str) -> tuple[np.ndarray, int | None]:
    """The vector ``c`` with ``c . x`` the output of ``.tf`` or ``.sens``, and the output's branch.

    Parameters
    ----------
    system : MnaSystem
    output : str
        ``v(a)``, ``v(a,b)`` or ``i(x)`` (canonical).

    Returns
    -------
    c : ndarray, shape (n,)
        ``e_a - e_b`` (ground left out) or ``e_k`` of the branch current.
    branch : int or None
        The branch of a current output.
    """
    sig = parse_signal(output)
    c = np.zeros(system.n)
    if sig.kind == "v":
        for node, sign in zip(sig.args, (1.0, -1.0)):
            k = system.node_index(node)
            if k >= 0:
                c[k] += sign
        return c, None
    branch = system.layout.branch(sig.args[0])
    c[branch] = 1.0
    return c, branch


def _impedance(current: float) -> float:
    return INFINITE_IMPEDANCE if abs(current) < _NO_CURRENT else -1.0 / current


def transfer(M, b, out, *, input_kind: str, input_index, output_kind: str, output_branch: int | None = None,
             same_source: bool = False) -> tuple[float, float, float]:
    """Transfer function, input and output impedance of a linear DC system ``M x = b u``.

    Parameters
    ----------
    M : sparse or array, shape (n, n)
        The DC matrix (``-H``).
    b : ndarray, shape (n,)
        The input source's column (``dphi/du``).
    out : ndarray, shape (n,)
        Selects the output from x: ``e_a - e_b`` for ``v(a,b)``, ``e_k`` for
        a branch current.
    input_kind : {"v", "i"}
        A V source (``input_index`` its branch) or an I source
        (``input_index`` its ``(n+, n-)`` unknowns, -1 for ground).
    output_kind : {"v", "i"}
    output_branch : int, optional
        The branch of a current output.
    same_source : bool
        The output is the input source's own current.

    Returns
    -------
    transfer, z_in, z_out : float

    Raises
    ------
    RuntimeError
        When ``M`` is singular (SuperLU's message).

    Examples
    --------
    A divider, 1k from the source's node to ``out``, 3k to ground
    (unknowns ``v(in)``, ``v(out)``, ``i(v1)``):

    >>> M = np.array([[1e-3, -1e-3, 1.0], [-1e-3, 1e-3 + 1/3e3, 0.0], [-1.0, 0.0, 0.0]])
    >>> [round(v, 9) for v in transfer(M, np.array([0, 0, -1.0]), np.array([0, 1.0, 0]), input_kind="v",
    ...                                input_index=2, output_kind="v")]
    [0.75, 4000.0, 750.0]
    """
    lu = spla.splu(sp.csc_matrix(M, dtype=float))
    x1 = lu.solve(np.asarray(b, dtype=float))
    tf = float(out @ x1)
    if input_kind == "v":
        z_in = _impedance(float(x1[input_index]))
    else:
        pos, neg = input_index
        z_in = float((x1[neg] if neg >= 0 else 0.0) - (x1[pos] if pos >= 0 else 0.0))
    if same_source:
        return tf, z_in, z_in
    if output_kind == "v":
        x2 = lu.solve(np.asarray(out, dtype=float))  # a unit current into a, out of b
        return tf, z_in, float(out @ x2)
    series = np.zeros(M.shape[0])
    series[output_branch] = -1.0  # a unit voltage in series with the branch (a V source's column)
    x2 = lu.solve(series)
    return tf, z_in, _impedance(float(x2[output_branch]))


def tf_analysis(circuit: Circuit, card: TfAnalysis, **overrides) -> Result:
    """Run a ``.tf`` analysis.

    Parameters
    ----------
    circuit : Circuit
    card : TfAnalysis
    **overrides
        Operating-point tolerances (``reltol``, ...).

    Returns
    -------
    Result
        ``analysis == "tf"``, no axis, three real signals of one point named
        as ngspice names them (:func:`tf_names`); ``operating_point`` the
        operating point, ``card`` the ``.tf`` card.

    Raises
    ------
    CircuitError, ConvergenceError
        No operating point, or a singular DC matrix (with its reason).
    """
    from .ac import linearize

    t0 = time.perf_counter()
    lin = linearize(circuit, **overrides)
    system = lin.system
    src = circuit.element(card.source)
    col = list(system.sources.names).index(card.source)
    b = np.asarray(system.B[:, [col]].toarray()).ravel()
    sig = parse_signal(card.output)
    out, out_branch = output_selector(system, card.output)
    if src.kind == Kind.VSOURCE:
        kind, index = "v", system.layout.branch(src.name)
    else:
        kind, index = "i", (system.node_index(src.nodes[0]), system.node_index(src.nodes[1]))
    notes = list(system.notes)
    if sig.kind == "i" and circuit.element(sig.args[0]).kind == Kind.OPAMP:
        raise CircuitError(f".tf: the output i({sig.args[0]}) is an ideal op-amp's output current, whose branch "
                           "equation is the op-amp's input constraint: no series impedance is defined",
                           elements=(sig.args[0],), hint="measure a V source (0 V) in series with the output")
    try:
        tf, z_in, z_out = transfer(-lin.H, b, out, input_kind=kind, input_index=index, output_kind=sig.kind,
                                   output_branch=out_branch,
                                   same_source=sig.kind == "i" and sig.args[0] == card.source)
    except RuntimeError:
        from ..topology import dc_singularity_explanation

        why = dc_singularity_explanation(circuit)
        if why is not None:
            raise CircuitError(f".tf: the DC matrix is singular: {why.message}", elements=why.elements,
                               nodes=why.nodes, hint=why.hint) from None
        raise CircuitError(".tf: the DC matrix of the linearised circuit is singular",
                           hint="a node without a DC path to ground, or a loop of voltage sources") from None
    names = tf_names(card)
    if z_in == INFINITE_IMPEDANCE:
        notes.append(f"{names[1]}: no DC current flows through {card.source}: infinite, reported as 1e20 as "
                     "ngspice does")
    if z_out == INFINITE_IMPEDANCE:
        notes.append(f"{names[2]}: infinite, reported as 1e20 as ngspice does")
    return Result(
        "tf",
        signals={name: np.array([value]) for name, value in zip(names, (tf, z_in, z_out))},
        stats=Statistics(wall_time=time.perf_counter() - t0, newton_iterations=lin.op.iterations,
                         **system.describe()),
        message="ok",
        tolerances={"reltol": lin.options.reltol, "vntol": lin.options.vntol, "abstol": lin.options.abstol},
        notes=notes,
        operating_point=op_result(system, lin.op, 0.0, lin.options), card=card,
    )
