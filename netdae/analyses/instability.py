"""Unstable circuits in the transient: the notes that say so.

Two situations, both read from the pencil ``(dq/dx, dphi/dx)`` at a point:

- a **linear circuit whose run failed** because its solution grows without
  bound (an eigenvalue in the right half-plane; :func:`growth_note`);
- a **run that stayed at an unstable operating point** (an astable
  multivibrator, a latch, an oscillator built symmetric): the DC operating
  point is an equilibrium, so the exact solution from it stays there, and
  netdae's arithmetic, which adds no noise to a symmetric circuit, keeps it
  there; a real circuit (and ngspice, through the rounding noise of its
  trapezoidal steps, often) leaves it within some tens of the growing mode's
  time constant (:func:`held_equilibrium_note`).

Numerics only: the functions take arrays and return text.
"""

from __future__ import annotations

import numpy as np

#: A linear circuit's failed run is put down to its instability when a mode grows by more than
#: e**UNSTABLE_GROWTH over it (1e13: the solution has left every scale the tolerances were set for).
UNSTABLE_GROWTH = 30.0

#: A run that stayed at its operating point is warned about when a mode there grows by more than
#: e**HELD_GROWTH over the run (150 times): visibly unstable on the run's time scale, whatever started it.
HELD_GROWTH = 5.0

#: A run that ran away at BDF orders 3-5 is run again at the A-stable orders 1-2 only when no eigenvalue of
#: the circuit's pencil at its start grows by more than e**PASSIVE_GROWTH over the run: then no mode of the
#: circuit there can make its solution grow, and the growth was the integrator's.
PASSIVE_GROWTH = 1.0

#: How many node voltages of the growing mode the note names, and the smallest share of its largest
#: component a named one has (a node a source fixes has rounding noise there).
MODE_NODES = 3
MODE_SHARE = 1e-3


def _eigenvalue_text(lam: complex) -> str:
    return f"{lam.real:.4g}" + (f" +- {abs(lam.imag):.4g}j" if lam.imag != 0.0 else "")


def growth_note(eigenvalues, span: float) -> str:
    """A failure note for a linear circuit that is unstable: an eigenvalue with positive real part.

    Parameters
    ----------
    eigenvalues : array_like of complex or None
        The pencil's finite eigenvalues (1/s).
    span : float
        The time integrated (s).

    Returns
    -------
    str
        ``""`` when no eigenvalue grows by more than ``exp(UNSTABLE_GROWTH)`` over ``span``, else a text
        to append to the failure message (it starts with a space).

    Examples
    --------
    >>> growth_note([-1.0, 2e3], 1e-3)
    ''
    >>> "the eigenvalue 2e+05 1/s in the right half-plane" in growth_note([-1.0, 2e5], 1e-3)
    True
    """
    eig = np.asarray([] if eigenvalues is None else eigenvalues, dtype=complex)
    if not eig.size or span <= 0.0:
        return ""
    worst = complex(eig[np.argmax(eig.real)])
    if worst.real * span <= UNSTABLE_GROWTH:
        return ""
    return (f" (the circuit is unstable: its pencil has the eigenvalue {_eigenvalue_text(worst)} 1/s in the right "
            f"half-plane, so its solution grows as exp({worst.real:.4g} t), by e^{worst.real * span:.0f} up to "
            "this time; look for a controlled source whose gain makes the circuit active)")


def growing_eigenvalue(E, H, span: float, growth: float = PASSIVE_GROWTH) -> complex | None:
    """The eigenvalue of the pencil ``lambda E - H`` that grows most over ``span``, when it grows by more than
    ``exp(growth)``; else None.

    Parameters
    ----------
    E, H : array_like or sparse, shape (n, n)
        ``dq/dx`` and ``dphi/dx`` at a point.
    span : float
        The time (s).
    growth : float
        The exponent of the growth that counts.

    Returns
    -------
    complex or None

    Raises
    ------
    numpy.linalg.LinAlgError
        When QZ or the staircase's SVD does not converge.

    Notes
    -----
    Cost: the pencil's finite eigenvalues (a staircase and QZ, O(n^3)).

    Examples
    --------
    An RLC tank with a 1 ohm series resistance (unknowns v, i; C = 1u, L = 1m) decays; with -1 ohm it grows:

    >>> E = [[1e-6, 0.0], [0.0, 1e-3]]
    >>> growing_eigenvalue(E, [[0.0, -1.0], [1.0, -1.0]], 1e-2) is None
    True
    >>> round(growing_eigenvalue(E, [[0.0, -1.0], [1.0, 1.0]], 1e-2).real)
    500
    """
    worst = _largest_real_part(E, H)[3]
    return worst if worst is not None and worst.real * span > growth else None


def _largest_real_part(E, H) -> tuple[np.ndarray, np.ndarray, bool, complex | None]:
    """``(E, H)`` as dense arrays, whether the pencil is regular, and its finite eigenvalue of the largest real
    part (None: it has none), from :func:`netdae.dae.pencil.finite_eigenvalues`."""
    from ..dae.pencil import finite_eigenvalues

    E = E.toarray() if hasattr(E, "toarray") else np.asarray(E, dtype=float)
    H = H.toarray() if hasattr(H, "toarray") else np.asarray(H, dtype=float)
    spec = finite_eigenvalues(E, H)
    eig = spec.eigenvalues
    return E, H, spec.regular, complex(eig[np.argmax(eig.real)]) if eig.size else None


def stayed(X, x0, rtol: float, atol) -> bool:
    """Whether every point of ``X`` lies within the tolerances of ``x0``.

    Parameters
    ----------
    X : ndarray, shape (m, k)
        Recorded values of k unknowns.
    x0 : ndarray, shape (k,)
        Their values at the start.
    rtol : float
    atol : ndarray, shape (k,)
        Absolute tolerances (vntol for voltages, abstol for currents).

    Examples
    --------
    >>> stayed(np.array([[1.0, 2.0], [1.0, 2.0005]]), np.array([1.0, 2.0]), 1e-3, np.array([1e-6, 1e-6]))
    True
    """
    X = np.asarray(X, dtype=float)
    x0 = np.asarray(x0, dtype=float)
    if X.size == 0:
        return False
    return bool(np.all(np.abs(X - x0) <= rtol * np.abs(x0) + atol))


def held_equilibrium_note(E, H, names, x0, span: float, watched=None) -> str | None:
    """A warning for a run that stayed at its operating point when that point is unstable.

    Parameters
    ----------
    E, H : array_like or sparse, shape (n, n)
        ``dq/dx`` and ``dphi/dx`` at the operating point ``x0``.
    names : sequence of str, length n
        The unknowns' names (``v(node)``, ``i(branch)``).
    x0 : ndarray, shape (n,)
    span : float
        The time the run covered (s).
    watched : array_like of int, optional
        The unknowns seen to stay (the saved ones); the growing mode's largest component must be one
        of them (else the run may have left the point where nobody looked).

    Returns
    -------
    str or None
        None when no finite eigenvalue grows by more than ``exp(HELD_GROWTH)`` over ``span``, or
        when the mode's largest component is not watched.

    Notes
    -----
    Cost: the pencil's finite eigenvalues (a staircase and QZ, O(n^3)) and, when one grows, an SVD of
    ``H - lambda E`` for its mode (O(n^3)); meant for the dense sizes of the transient's structure
    analysis.
    """
    E, H, regular, lam = _largest_real_part(E, H)
    if not regular or lam is None:
        return None
    if not lam.real * span > HELD_GROWTH:
        return None
    # the mode: the right singular vector of H - lambda E with the smallest singular value
    _, _, vh = np.linalg.svd(H - lam * E)
    mode = np.abs(vh[-1].conj())
    if watched is not None and int(np.argmax(mode)) not in set(np.asarray(watched).tolist()):
        return None
    big = MODE_SHARE * float(mode.max())
    nodes = [i for i in np.argsort(-mode) if names[i].startswith("v(") and mode[i] > big][:MODE_NODES]
    where = f"; mostly {', '.join(names[i] for i in nodes)}" if nodes else ""
    first = names[nodes[0]] if nodes else None
    hint = (f"give {first} an initial value off its {x0[nodes[0]]:.6g} V: .ic {first}=... is held in the operating "
            "point and released at t = 0; or kick the circuit with a source that changes after t = 0"
            if first else "kick the circuit with a source that changes after t = 0, or start it with .ic values")
    return (f"warning: the transient stayed at the DC operating point, which is unstable: a mode grows there as "
            f"exp(t / {1.0 / lam.real:.3g} s) (the pencil's eigenvalue {_eigenvalue_text(lam)} 1/s{where}), by "
            f"e^{lam.real * span:.3g} over the run, but the circuit starts exactly on the equilibrium and netdae adds "
            "no noise to leave it; a real circuit leaves it within some tens of that time, and ngspice's "
            f"rounding noise often starts it too (hint: {hint})")
