"""Which of two disagreeing operating points satisfies netdae's equations (the current-law check).

When ``netdae compare`` finds netdae's ``.op`` and ngspice's apart (or a source
sweep's ``.dc``, at the point where they differ most), the two
points are put into netdae's own DC equations ``phi(x) = 0``: each row's
residual is measured, as the operating point's stopping test measures it
(:func:`netdae.dae.sparse.residual_small`), against ``reltol`` times the
magnitude of the row's branch currents plus ``abstol`` (a branch row: its
voltages plus ``vntol``). A point whose residual is within that in every row
is a solution of netdae's equations; one whose current law is off by a large
multiple of its tolerance at a node is not a solution of them: a Newton
iteration that stopped early (SPICE's update test on a node at a high
potential allows several thermal voltages) or a model that differs. The note
says which rows, by how much, and in whose equations: netdae's models, so a
model difference shows up too and the note does not judge ngspice's own
equations.

ngspice does not write the internal nodes of devices with series resistances
(``d1#internal``): a point without them gets them from their own rows, the
current laws of those nodes solved by Newton's method with every other
unknown held at the point's value (from netdae's values of them); the other
rows are then checked. A point that lacks any other unknown, or whose
internal nodes do not converge, gets no note.
"""

from __future__ import annotations

import numpy as np

__all__ = ["current_law_note", "current_law_errors", "worst_sweep_point"]

#: Rows named in a note.
MOST_NAMED = 3


def current_law_errors(system, x: np.ndarray, reltol: float, abstol: float,
                       vntol: float) -> tuple[np.ndarray, np.ndarray]:
    """Each row's residual of ``phi(x, 0) = 0``, and in units of its tolerance.

    Parameters
    ----------
    system : MnaSystem
        A DC system (:func:`netdae.analyses.prepared.prepare` with ``MODE_DC``).
    x : ndarray, shape (n,)
    reltol, abstol, vntol : float

    Returns
    -------
    residual : ndarray, shape (n,)
        ``phi(x, 0)`` (amperes in a node's row, volts in a branch's).
    ratio : ndarray, shape (n,)
        ``|phi_i|`` over its tolerance in the operating point's residual test
        (:func:`netdae.dae.sparse.residual_tolerance`: ``reltol m_i + RESIDUAL_ROUNDING (|J| |x|)_i +
        atol_i``, ``m`` the magnitude of the row's branch currents); inf where the equations are not
        finite at ``x``.
    """
    from ..dae.sparse import residual_tolerance
    from ..dae.system import KIND_VOLTAGE

    x = np.asarray(x, dtype=float)
    ev = system.evaluate(x, 0.0, jacobian=True)
    paired = np.asarray(system.kinds == KIND_VOLTAGE)
    if not (ev.ok and np.all(np.isfinite(ev.phi)) and np.all(np.isfinite(ev.dphi))):
        return np.asarray(ev.phi, dtype=float), np.full(system.n, np.inf)
    tol = residual_tolerance(system.pattern, ev.dphi, x, reltol, np.where(paired, abstol, vntol), paired)
    return np.asarray(ev.phi, dtype=float), np.abs(ev.phi) / tol


def current_law_note(circuit, netdae_point: dict, ngspice_point: dict, overrides: dict,
                     sources: dict | None = None) -> str | None:
    """A note on which of the two points solves netdae's DC equations, or None.

    Parameters
    ----------
    circuit : Circuit
    netdae_point, ngspice_point : dict of str to float
        Each simulator's operating point by signal name (``v(node)``, ``i(source)``).
    overrides : dict
        The comparison's tolerance overrides (``reltol``, ``abstol``, ``vntol``).
    sources : dict of str to float, optional
        Independent sources' DC values at the point (a ``.dc`` sweep's point).

    Returns
    -------
    str or None
        None when ngspice's point lacks an unknown of netdae's system (an internal
        node), when the system cannot be built, or when both points solve the equations
        (then the difference is not in the current laws).
    """
    from ..analyses.op import steady_options
    from ..analyses.prepared import prepare
    from ..errors import NetdaeError

    try:
        system = prepare(circuit).system
        opts = steady_options(circuit, **overrides)
        for name, value in (sources or {}).items():
            system.sources.set_value(name, float(value))
    except (NetdaeError, KeyError):
        return None
    names = list(system.names)
    if any(name not in netdae_point for name in names):
        return None
    missing = [k for k, name in enumerate(names) if name not in ngspice_point]
    if any("#" not in names[k] or not names[k].startswith("v(") for k in missing):
        return None  # only a device's internal node is completed from its own row
    errors, residuals = {}, {}
    for side, point in (("netdae", netdae_point), ("ngspice", ngspice_point)):
        x = np.array([float(point.get(name, netdae_point[name])) for name in names])
        if side == "ngspice" and missing:
            x = _internal_nodes(system, x, np.array(missing), opts)
            if x is None:
                return None
        residuals[side], errors[side] = current_law_errors(system, x, opts.reltol, opts.abstol, opts.vntol)
        if side == "ngspice" and missing:  # solved for: not a check of ngspice's point
            errors[side][missing] = 0.0
    off = {side: np.flatnonzero(e > 1.0) for side, e in errors.items()}
    if not any(rows.size for rows in off.values()):
        return None
    parts = []
    for side in ("ngspice", "netdae"):
        e, r, rows = errors[side], residuals[side], off[side]
        if not rows.size:
            parts.append(f"{side}'s point solves them (every row within its tolerance)")
            continue
        worst = rows[np.argsort(-e[rows])][:MOST_NAMED]
        named = ", ".join(f"{_row(names[i])} off by {abs(r[i]):.3g} {'A' if names[i].startswith('v(') else 'V'} "
                          f"({e[i]:.3g}x its tolerance)" for i in worst)
        more = f" and {rows.size - worst.size} more" if rows.size > worst.size else ""
        parts.append(f"{side}'s point leaves {named}{more}")
    return ("current-law check in netdae's equations (its models, reltol times each row's branch currents): "
            + "; ".join(parts) + " (a point off by many tolerances is not a solution of these equations: a "
            "Newton iteration that stopped early, or a model that differs)")


def worst_sweep_point(curves: dict, names: list) -> int:
    """The point of a ``.dc`` comparison where the two sweeps differ most, in each signal's scale.

    Parameters
    ----------
    curves : dict
        The comparison's ``curves``: ``values`` maps a signal to its ``(netdae, ngspice)`` arrays.
    names : list of (str, float)
        The compared signals and their scales.

    Returns
    -------
    int
    """
    worst = None
    for name, scale in names:
        a, b = curves["values"][name]
        err = np.abs(np.asarray(a, dtype=float) - np.asarray(b, dtype=float)) / scale
        worst = err if worst is None else np.maximum(worst, err)
    return int(np.argmax(worst))


#: Newton iterations for the internal nodes of a point that lacks them.
INTERNAL_MAXITER = 50


def _internal_nodes(system, x: np.ndarray, rows: np.ndarray, opts) -> np.ndarray | None:
    """``x`` with the unknowns ``rows`` (internal nodes) solved from their own current laws, the others held.

    Each starts at the potential of the held node its row is most strongly tied to (the
    terminal behind a series resistance); then netdae's Newton iteration
    (:func:`netdae.dae.newton.newton`, full Newton, SPICE's stopping test) on ``phi[rows](x) = 0``
    over ``x[rows]``, the devices limiting their junctions as in an operating point. Returns None
    when it does not converge.
    """
    from ..dae.newton import LuCache, SpiceTest, newton
    from ..dae.sparse import SparsePattern
    from ..dae.system import KIND_VOLTAGE

    x = x.copy()
    pattern = system.pattern
    pos = np.full(system.n, -1)
    pos[rows] = np.arange(rows.size)
    slots = np.flatnonzero((pos[pattern.rows] >= 0) & (pos[pattern.cols] >= 0))
    sub_rows, sub_cols = pos[pattern.rows[slots]], pos[pattern.cols[slots]]
    sub = SparsePattern.from_coo(rows.size, [sub_rows], [sub_cols])
    sub_slots = sub.slots(sub_rows, sub_cols)
    # start each at the node it is most strongly tied to among the held ones (a series resistance)
    ev = system.evaluate(x, 0.0, jacobian=True)
    volts = np.asarray(system.kinds == KIND_VOLTAGE)
    held = np.flatnonzero((pos[pattern.rows] >= 0) & (pos[pattern.cols] < 0) & volts[pattern.cols]
                          & np.isfinite(ev.dphi))
    for r in rows:
        ties = held[pattern.rows[held] == r]
        if ties.size:
            x[r] = x[pattern.cols[ties[np.argmax(np.abs(ev.dphi[ties]))]]]
    state = [None]  # the devices' limiting, from the starting point on

    def fun(xs, jacobian):
        x[rows] = xs
        ev = system.evaluate(x, 0.0, jacobian=True, state=state[0])
        if not (ev.ok and np.all(np.isfinite(ev.phi[rows])) and np.all(np.isfinite(ev.dphi))):
            return None, None, False, False
        state[0] = ev.state
        return ev.phi[rows], sub.scatter(sub_slots, ev.dphi[slots]), True, bool(ev.limited)

    x_atol = np.full(rows.size, opts.vntol)
    stop = SpiceTest(sub, opts.reltol, x_atol, np.full(rows.size, opts.abstol), np.ones(rows.size, dtype=bool))
    res = newton(fun, x[rows], LuCache(sub), 1.0 / x_atol, maxiter=INTERNAL_MAXITER, jacobian="always", stop=stop)
    if not res.converged:
        return None
    x[rows] = res.x
    return x


def _row(name: str) -> str:
    """How a row is named: a node's current law, or a branch's voltage equation."""
    if name.startswith("v(") and name.endswith(")"):
        return f"the current law of node {name[2:-1]}"
    if name.startswith("i(") and name.endswith(")"):
        return f"the voltage equation of {name[2:-1]}"
    return f"row {name}"
