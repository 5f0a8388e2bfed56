"""AC small-signal analysis (``.ac dec|oct|lin N fstart fstop``).

Linearise at the DC operating point: with the pencil (E, H) = (dq/dx,
dphi/dx) at x_op, the phasor X(omega) of every unknown solves

    (j omega E - H) X = B U

where U holds the sources' AC magnitudes and phases. The matrix pattern is
the same at every frequency, so the fill-reducing column ordering is computed
once and reused (only the numeric factorisation is repeated); small systems
are solved for all frequencies at once with a batched dense solve.

The poles of the transfer functions are the finite eigenvalues of the pencil,
which ``netdae index`` lists.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.sparse as sp

from ..circuit import AcAnalysis, Circuit
from ..errors import CircuitError, NetdaeError
from ..mna import MODE_DC
from ..netlist.steps import check_grid_size, grid
from ..results import Result, Statistics
from .op import circuit_operating_point, op_result, steady_options
from .prepared import prepare

__all__ = ["frequencies", "ac_analysis", "solve_ac", "linearize", "Linearization", "DENSE_AC_LIMIT"]

#: Relative pivot threshold of :func:`solve_ac`'s refactorisations: a pivot below this fraction of its
#: column's largest entry chooses new pivots. Tighter than the transient's 1e-3 (Sparse 1.3's, where
#: Newton's next iteration corrects a solve): an AC solution is used as solved. At 1e-3 a LAPLACE
#: block's response was 6e-11 off its closed form where it had fallen to 1e-5 of its peak, 1e-2: 1.5e-12,
#: 0.1: 6e-15 (dense LAPACK: 2.6e-15); the element growth per elimination step is at most 1/threshold.
AC_PIVOT_THRESHOLD = 0.1
#: Up to this many unknowns, :func:`solve_ac` solves all frequencies at once with dense LAPACK;
#: above, one compiled sparse refactorisation per frequency is the faster (1,201 frequencies of
#: RLC ladders: 14 unknowns 3.6 ms dense against 4.9 ms, 32: 13 against 6 ms, 62: 55 against 8 ms).
DENSE_AC_LIMIT = 16


def frequencies(card: AcAnalysis) -> np.ndarray:
    """The frequency grid of an ``.ac`` card, as ngspice builds it.

    ``dec``/``oct``: ``fstart * 10**(k/N)`` (resp. ``2**(k/N)``) up to fstop;
    ``lin``: N points from fstart to fstop inclusive.

    Raises
    ------
    NetdaeError
        For a non-positive point count or a start frequency that is not
        positive on a logarithmic grid, or fstop < fstart.

    Examples
    --------
    >>> frequencies(AcAnalysis("dec", 2, 1.0, 100.0)).round(6).tolist()
    [1.0, 3.162278, 10.0, 31.622777, 100.0]
    >>> frequencies(AcAnalysis("lin", 3, 10.0, 20.0)).tolist()
    [10.0, 15.0, 20.0]
    """
    n, f0, f1 = card.points, card.fstart, card.fstop
    if n < 1:
        raise NetdaeError(f".ac: the number of points must be at least 1 (got {n})")
    if f1 < f0:
        raise NetdaeError(f".ac: fstop ({f1:g}) is below fstart ({f0:g})")
    try:
        if card.variation == "lin":
            check_grid_size(n)
            return np.array([f0]) if n == 1 else np.linspace(f0, f1, n)
        if f0 <= 0:
            raise NetdaeError(f".ac {card.variation}: fstart must be positive (got {f0:g})")
        return grid(card.variation, f0, f1, n)
    except ValueError as exc:  # more points than a grid may have
        where = getattr(card, "location", None)
        raise NetdaeError(f"{where}: .ac {card.variation}: {exc}" if where is not None
                          else f".ac {card.variation}: {exc}") from None


def solve_ac(E: sp.spmatrix, H: sp.spmatrix, b: np.ndarray, freqs: np.ndarray, delays=()) -> np.ndarray:
    """Phasors X(f) solving ``(j 2 pi f E - H + sum (1 - exp(-j 2 pi f tau)) D_tau) X = b`` for every frequency.

    Parameters
    ----------
    E, H : sparse, shape (n, n)
        ``H`` the DC Jacobian (transmission lines joining their ports).
    b : ndarray of complex, shape (n,)
    freqs : ndarray, shape (m,)
    delays : sequence of (float, sparse (n, n))
        The transmission lines' couplings by delay (:meth:`netdae.mna.system.Delays.by_delay`):
        at frequency f a line's far port arrives as ``exp(-j 2 pi f tau) D x``.

    Returns
    -------
    ndarray of complex, shape (m, n)

    Raises
    ------
    CircuitError
        When the matrix is singular at some frequency (names the frequency).

    Notes
    -----
    Dense batched solve (O(m n^3)) up to ``DENSE_AC_LIMIT`` unknowns; above,
    the compiled sparse LU (:class:`netdae.dae.compiled.lu.SparseLU`, complex):
    the pivot order SuperLU chooses at the first frequency, refactored at the
    next ones (ngspice's reuse of its pivots) until a pivot falls below
    :data:`AC_PIVOT_THRESHOLD` of its column, which chooses new ones. Cost per frequency: the
    factorisation's flops and about 20 us of Python.
    """
    n = E.shape[0]
    w = 2j * np.pi * np.asarray(freqs, dtype=float)
    if n == 0:
        return np.zeros((w.size, 0), dtype=complex)
    if n <= DENSE_AC_LIMIT:
        Ed, Hd = E.toarray(), H.toarray()
        mats = w[:, None, None] * Ed[None] - Hd[None]
        for tau, D in delays:
            mats = mats + (1.0 - np.exp(-w * tau))[:, None, None] * D.toarray()[None]
        try:
            return np.linalg.solve(mats, np.broadcast_to(b, (w.size, n))[..., None])[..., 0]
        except np.linalg.LinAlgError:
            pass  # fall through to the sparse path, which names the frequency
    from ..dae.compiled.lu import SparseLU
    from ..dae.sparse import SparsePattern

    pattern = SparsePattern.from_matrices(E, H, *(D for _, D in delays))
    e, h = _on(pattern, E), _on(pattern, H)
    d = [(tau, _on(pattern, D)) for tau, D in delays]
    lu = SparseLU(pattern, dtype=complex, threshold=AC_PIVOT_THRESHOLD)
    out = np.empty((w.size, n), dtype=complex)
    rhs = np.asarray(b, dtype=complex)
    for k, wk in enumerate(w):
        a = wk * e - h
        for tau, dk in d:
            a += (1.0 - np.exp(-wk * tau)) * dk
        if not lu.factor(a):
            raise CircuitError(
                f"the AC matrix (j omega E - H) is singular at f = {freqs[k]:g} Hz",
                hint="a loop of voltage sources/inductors or a cutset of current sources/capacitors, "
                "or a pole of the circuit exactly at this frequency",
            )
        out[k] = lu.solve(rhs)
    return out


def _on(pattern, M) -> np.ndarray:
    """The values of ``M`` (real or complex) laid out in ``pattern``."""
    M = sp.csc_matrix(M)
    if np.iscomplexobj(M.data):
        return pattern.data_of(M.real.tocsc()) + 1j * pattern.data_of(M.imag.tocsc())
    return pattern.data_of(M)


@dataclass
class Linearization:
    """A circuit linearised at its DC operating point: what ``.ac``, ``.pz`` and ``.tf`` solve.

    Attributes
    ----------
    prepared : Prepared
        The circuit and its system (DC source values).
    op : SteadyResult
        The operating point.
    options : SteadyOptions
        The tolerances it was solved with.
    E : sparse, shape (n, n)
        ``dq/dx`` at the operating point.
    H : sparse, shape (n, n)
        ``dphi/dx`` at the operating point, with the resistors' DC values and
        the transmission lines joining their ports (what ``.tf`` solves: ``-H``
        is the DC matrix).
    """

    prepared: Any
    op: Any
    options: Any
    E: sp.spmatrix
    H: sp.spmatrix

    @property
    def system(self):
        """The assembled circuit (DC source values): ``prepared.system``."""
        return self.prepared.system

    @property
    def delays(self) -> list:
        """The transmission lines' couplings by delay, for :func:`solve_ac` (empty without lines)."""
        d = self.system.delays
        return d.by_delay() if d is not None else []

    @property
    def H_ac(self) -> sp.spmatrix:
        """``H`` with the resistors' ``ac=`` values (what ``.ac`` and ``.pz`` use)."""
        return self.H + self.system.H_ac


def linearize(circuit: Circuit, **overrides) -> Linearization:
    """Assemble ``circuit``, solve its DC operating point and linearise there.

    Parameters
    ----------
    circuit : Circuit
    **overrides
        Operating-point tolerances (``reltol``, ...).

    Returns
    -------
    Linearization

    Raises
    ------
    CircuitError, ConvergenceError
        When the operating point cannot be computed.
    """
    prepared = prepare(circuit, mode=MODE_DC)
    opts = steady_options(circuit, **overrides)
    op = circuit_operating_point(prepared, opts)
    E, H = prepared.system.steady_form().jacobians(op.x, 0.0)
    return Linearization(prepared, op, opts, E, H)


def ac_analysis(circuit: Circuit, card: AcAnalysis, **overrides) -> Result:
    """Run an ``.ac`` analysis.

    Parameters
    ----------
    circuit : Circuit
    card : AcAnalysis
    **overrides
        Operating-point tolerances (``reltol``, ...).

    Returns
    -------
    Result
        ``analysis == "ac"``, axis ``frequency`` [Hz], complex phasors per
        unknown; ``operating_point`` holds the operating point.

    Raises
    ------
    CircuitError, ConvergenceError
    """
    t0 = time.perf_counter()
    lin = linearize(circuit, **overrides)
    system, op, opts, E, H = lin.system, lin.op, lin.options, lin.E, lin.H_ac  # resistors' ac= values
    b = system.B @ system.sources.ac
    freqs = frequencies(card)
    X = solve_ac(E, H, b, freqs, lin.delays)
    notes = list(system.notes)
    if not np.any(system.sources.ac):
        notes.append("no source has an AC value (ac mag [phase]): every phasor is zero")
    return Result(
        "ac",
        axes={"frequency": freqs},
        signals={name: X[:, i] for i, name in enumerate(system.names)},
        stats=Statistics(points=int(freqs.size), wall_time=time.perf_counter() - t0,
                         newton_iterations=op.iterations, **system.describe()),
        message="ok",
        tolerances={"reltol": opts.reltol, "vntol": opts.vntol, "abstol": opts.abstol},
        notes=notes,
        operating_point=op_result(system, op, 0.0, opts),
    )
