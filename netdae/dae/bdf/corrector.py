"""The correctors of the FLC-BDF method and the rounding floor of their tolerances.

A linear system ``E x' = H x + c(t)`` is solved exactly by one solve with the
factorisation of ``cj E - H`` (:class:`LinearCorrector`); a nonlinear one by
modified Newton on the corrector (:class:`NonlinearCorrector`, IDA's rate test
and Jacobian reuse, :func:`netdae.dae.newton.newton`), written per row: in
charge form ``cj (q(x) - q_pred) + q'_pred - phi(x, t) = 0`` where the charge is
nonlinear (the history holds those charges), in correction form
``cj E (x - x_pred) + E x'_pred - phi(x, t) = 0`` where ``dq/dx = E`` is constant.
Both report a failure as a dict ``{"info": <newton info code>, "worst": <name or None>}``.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from ..newton import (CONDUCTANCE_FALL, INFO_EVALUATION, INFO_NONFINITE, INFO_SINGULAR, RESIDUAL_NU_MAX,
                      RESIDUAL_RATE_MAX, LuCache, conductance_fell, newton, residual_stalled)
from .arguments import rounding_signs
from .constants import (DCJ, DENSE_MATVEC_MAX, EPCON, EPS, JAC_AGE_MAX, RATE_AFTER_SETUP, RATE_AGE_MAX,
                        RATE_CJ_CHANGED, ROUNDING_FACTOR)
from .failures import nonfinite_unknown, worst_unknown

__all__ = ["RoundingFloor", "LinearCorrector", "NonlinearCorrector", "point_state"]


class RoundingFloor:
    """Tolerances raised to the rounding level of the corrector residual.

    The charge-form rows of the corrector residual hold ``cj (q(x) - q_pred)``:
    its rounding error ``eps cj |q|`` grows like ``1/h``. An unknown that only such a row fixes
    (the current of a voltage source driving a capacitor,
    ``i = cj (q - q_pred) + ...``) carries noise of ``eps |q| / h`` in every
    Newton correction and in every accepted value. Where that noise reaches
    the requested tolerance (a current near zero, whose tolerance is
    ``abstol``) the corrections stop contracting on a converged iterate, the
    step is cut, and a smaller step only raises the noise: the integration
    dies with the step size at the roundoff of t. The correction-form rows,
    ``cj E (x - x_pred) + E x'_pred``, subtract no charges, but x itself is
    known only to ``eps |x|``: a resolution of ``eps cj |E| |x|`` of the
    residual, the same ``1/h`` level for such a current (``i = cj C (v - v_pred)
    + C v'_pred`` with ``v`` exact to ``eps |v|``). The rounding error of the
    residual, ``eps (cj |dq/dx| |x| + |q'_pred|)`` per row (``|E| |x'_pred|``
    for ``|q'_pred|`` in a correction-form row), propagated to the unknowns
    through the current factorisation (one solve, two right-hand sides), is a
    floor below which no tolerance is attainable; the Newton and
    the error test use it (``ROUNDING_FACTOR`` times it) where it exceeds the
    requested tolerance. This is the same accuracy limit as the backward
    error of the corrector (Higham, *Accuracy and Stability of Numerical
    Algorithms*, 2nd ed., 2002, Section 7.1); where the tolerance is
    attainable the weights are unchanged.

    Parameters
    ----------
    pattern : SparsePattern
        The Jacobians' pattern.
    lu : LuCache
        The factorisation the floor is propagated through.
    """

    def __init__(self, pattern, lu: LuCache) -> None:
        self.pattern = pattern
        self.lu = lu
        self.abs_dq = None  # |dq/dx| at the last Jacobian evaluation (a CSC matrix)
        self._signs = None  # fixed +-1 signs and the (n, 2) right-hand sides
        self._rhs = None

    def keep(self, dq) -> None:
        """Keep ``|dq/dx|`` of a Jacobian evaluation (``data`` on the pattern)."""
        if self.abs_dq is None:
            self.abs_dq = self.pattern.matrix(np.abs(dq))
        else:
            np.abs(dq, out=self.abs_dq.data)

    def weights(self, w: np.ndarray, w_err: np.ndarray, x_pred, qp_pred, cj: float, xp_pred=None, column=None):
        """Newton and error-test weights with every tolerance raised to the rounding level.

        Parameters
        ----------
        w, w_err : ndarray, shape (n,)
            The Newton weights and the error-test weights (zero for untested unknowns).
        x_pred : ndarray, shape (n,)
            The predicted unknowns.
        qp_pred : ndarray, shape (m,)
            The predicted derivatives of the charges of the charge-form rows (all ``n``
            rows without ``column``).
        cj : float
        xp_pred : ndarray, shape (n,), optional
            The predicted derivatives of the unknowns (with ``column``).
        column : ndarray of int64, shape (n,), optional
            Each row's column among the charges (-1: a correction-form row;
            :func:`~netdae.dae.bdf.arguments.charge_columns`). None: every row in charge form
            (the probes' implicit-Euler steps).

        Returns
        -------
        (w_newton, w_err_step)
            ``w`` and ``w_err`` themselves when no floor applies (the common
            case), else new arrays.
        """
        lu = self.lu
        if self.abs_dq is None or not lu.ready:
            return w, w_err
        noise = self.abs_dq @ np.abs(x_pred)
        noise *= cj
        if column is None:
            noise += np.abs(qp_pred)
        else:
            charged = column >= 0
            noise[charged] += np.abs(qp_pred)[column[charged]]
            if not charged.all():
                noise[~charged] += (self.abs_dq @ np.abs(xp_pred))[~charged]
        noise *= ROUNDING_FACTOR * EPS
        # |J^-1| b is out of reach; rounding errors have no fixed sign, so take the
        # larger response to b and to b with fixed pseudo-random signs (a single
        # non-negative b can cancel, e.g. across a capacitor between two nodes)
        rhs = self._rhs
        n = w.size
        if rhs is None:
            rhs = self._rhs = np.empty((n, 2))
            self._signs = rounding_signs(n)
        rhs[:, 0] = noise
        np.multiply(noise, self._signs, out=rhs[:, 1])
        floor = np.abs(lu.solve(rhs)).max(axis=1)
        low = floor * w > 1.0
        if not low.any():
            return w, w_err
        w = w.copy()
        w[low] = 1.0 / floor[low]
        w_err = w_err.copy()
        w_err[low] = np.minimum(w_err[low], w[low])
        return w, w_err


class LinearCorrector:
    """The exact corrector of a linear system: one solve with the factorisation of ``cj E - H``.

    Parameters
    ----------
    system : DaeSystem
        With ``source(t)``.
    lu : LuCache
        Refactored exactly when ``cj`` changes (its tag is ``cj``).
    ev : Evaluation
        An evaluation with Jacobians: ``E = dq``, ``H = dphi`` (constant).
    stats : dict
        Counters updated here.

    Notes
    -----
    The residual ``E x'_pred - H x_pred - c(t)`` is one product with
    ``[-H | E]`` (dense below ``DENSE_MATVEC_MAX`` unknowns, where numpy beats
    the sparse call overhead) and one call of ``system.source``.
    """

    state_try = None  # no device limiting state

    def __init__(self, system, lu: LuCache, ev, stats: dict) -> None:
        self.system, self.lu, self.stats = system, lu, stats
        pattern = system.pattern
        self.e_data = np.array(ev.dq, dtype=float)
        self.h_data = np.array(ev.dphi, dtype=float)
        stacked = sp.hstack([-pattern.matrix(self.h_data), pattern.matrix(self.e_data)]).tocsr()
        self.residual_op = stacked.toarray() if system.n <= DENSE_MATVEC_MAX else stacked

    def solve(self, t_new: float, pred: np.ndarray, cj: float, w: np.ndarray, check_finite: bool):
        """x_{n+1} from the prediction ``pred`` (shape (2, n)): ``(True, x_new)`` or ``(False, failure)``.

        A non-finite solution is reported only with ``check_finite`` (the fixed-step
        mode); otherwise it shows in the error norm (NaN propagates through the weights).
        """
        lu = self.lu
        if lu.tag != cj:
            if not lu.factor(cj * self.e_data - self.h_data, tag=cj):
                return False, {"info": INFO_SINGULAR, "worst": None}
        r = self.residual_op @ pred.reshape(-1)
        r -= self.system.source(t_new)
        d = lu.solve(r)
        st = self.stats
        st["evaluations"] += 1
        st["newton_iterations"] += 1
        st["factorizations"] = lu.factorizations
        x_new = pred[0] - d
        if check_finite and not np.all(np.isfinite(x_new)):
            return False, {"info": INFO_NONFINITE, "worst": worst_unknown(self.system.names, d, w, w)}
        return True, x_new


def point_state(system, state, point):
    """A limiting state re-based on a point: each family whose state is its controlling voltages
    (``limits_from_point``) takes its state from ``point`` (an evaluation without limiting there), the
    others keep ``state`` (switches' held states, behavioural comparisons, OSDI devices).

    After a Newton failure the stepper re-bases the accepted state on the accepted point (ngspice limits
    from the last converged point; the compiled loop's ``_point_state``). The state a step accepts is that
    of its last Newton evaluation, the iterate the last correction was computed at: a boost converter's
    diode accepted after one correction from 0.29 V to 0.69 V (tests/test_recovery.py) kept 0.29 V, and
    every later attempt limited the junction from there, about 0.1 V per iteration, failing on every
    step size.
    """
    families = getattr(system, "families", None)
    if state is None or point is None or not families or len(families) != len(state):
        return state
    return tuple(p if getattr(f, "limits_from_point", False) else s for f, s, p in zip(families, state, point))


class NonlinearCorrector:
    """Modified Newton on the corrector ``cj (q(x) - q_pred) + q'_pred = phi(x, t)``, row by row in charge
    or correction form.

    Rows whose charge is nonlinear (``rows``) are solved in charge form from the
    charges' own history, so the discretisation conserves their linear
    invariants; every other row, whose charge is ``(E x)_r`` with the constant
    ``E``, in IDA's correction form ``cj E (x - x_pred) + E x'_pred = phi(x, t)``
    with ``x'_pred`` from the unknowns' history. The two are equal in exact
    arithmetic. The charge form rounds at ``eps cj |q|``, growing like ``1/h``,
    and its charge history, updated apart from the unknowns', perturbs
    ``q'_pred`` by ``eps |q| / psi``, which changes with every step size (a large
    charge on a floating capacitor, a small step where a junction turns on);
    the correction form's arithmetic rounds at ``eps |E| |x'|`` and it keeps no
    second history (the resolution of x itself is :class:`RoundingFloor`'s).

    Parameters
    ----------
    system : DaeSystem
    lu : LuCache
        The Newton matrix ``cj dq - dphi`` (its tag is the ``cj`` it was made for).
    floor : RoundingFloor
        Keeps ``|dq|`` of every Jacobian evaluation.
    stats : dict
    maxiter : int
        Newton iterations per attempt.
    norm : {"rms", "max"}
    rows : ndarray of int64, shape (m,), optional
        The charge-form rows (:func:`~netdae.dae.bdf.arguments.charge_columns`); every row
        when None. With fewer than ``n``, ``system.E`` is the constant ``dq/dx`` of the others.
    rtol : float, optional
        Relative tolerance of the check of an iterate accepted with a Jacobian from an earlier
        step (with ``row_atol`` and ``atol``; no check without them).
    row_atol : ndarray, shape (n,), optional
        Absolute tolerance of each row (:func:`~netdae.dae.bdf.arguments.row_tolerances`).
    atol : ndarray, shape (n,), optional
        Absolute tolerance of each unknown.

    Attributes
    ----------
    rate : float
        The convergence rate carried from step to step (IDA).
    age : int
        Accepted steps since the factorised Jacobian was evaluated (the stepper counts them).
    state_try : object
        The devices' limiting state of the last attempt (the driver keeps it when the step is accepted).

    Notes
    -----
    The factorisation is kept while ``cj / cj_lu`` stays within
    ``[(1 - DCJ)/(1 + DCJ), (1 + DCJ)/(1 - DCJ)]`` and for at most ``JAC_AGE_MAX``
    accepted steps (CVODE's ``msbp``); a failure with a stale one
    is retried once with a fresh Jacobian at the same step size, and a failure
    with a fresh one once with full Newton (a Jacobian at every iterate: where a
    model's slope changes inside the step, as a MOS charge at its threshold, the
    modified iteration contracts slowly for every step size, and cutting the step
    would not end). After
    Newton the charges are evaluated exactly at the new point (one device
    pass without Jacobian): the history must hold ``q(x_new)`` itself, or
    every step injects the linearisation error into the charge of floating
    node groups. An iterate accepted with a Jacobian from an earlier step
    is evaluated with its Jacobian (not factored) and checked: where an entry
    of ``dphi/dx`` the factorisation holds fell by more than ``CONDUCTANCE_FALL``
    (:func:`~netdae.dae.newton.conductance_fell`) or the residual stalled
    (:func:`~netdae.dae.newton.residual_stalled`), the Jacobian was made at
    another operating point (a junction's conductance at a forward bias it
    has since left) and the correction understated the error by the ratio of
    the two conductances: the attempt is solved again with a fresh Jacobian,
    as after a failure; else a node that only capacitors hold would keep the
    current-law imbalance as a charge error.
    """

    def __init__(self, system, lu: LuCache, floor: RoundingFloor, stats: dict, maxiter: int, norm: str,
                 rows=None, *, rtol: float | None = None, row_atol=None, atol=None) -> None:
        self.system, self.lu, self.floor, self.stats = system, lu, floor, stats
        self.maxiter, self.norm = maxiter, norm
        self.rtol = rtol
        self.row_atol = None if row_atol is None else np.asarray(row_atol, dtype=float)
        self.atol = None if atol is None else np.asarray(atol, dtype=float)
        self._dphi_lu = None  # dphi/dx of the Jacobian the factorisation was made from
        # E and H on the pattern (None: a system without a linear part): the check's magnitudes
        try:
            self._eh = (np.array(system.pattern.data_of(system.E), dtype=float),
                        np.array(system.pattern.data_of(system.H), dtype=float))
        except NotImplementedError:
            self._eh = None
        self._pattern_arrays = (np.asarray(system.pattern.indptr, dtype=np.int64),
                                np.asarray(system.pattern.indices, dtype=np.int64))
        self.rate = RATE_AFTER_SETUP
        self.rate_age = 0
        self.age = 0
        self.state_try = None
        n = system.n
        self.rows = np.arange(n, dtype=np.int64) if rows is None else np.asarray(rows, dtype=np.int64)
        # E on the pattern (CSC): E v sums in the compiled loop's order
        pattern = system.pattern
        self.e_matrix = None if self.rows.size == n else pattern.matrix(np.array(pattern.data_of(system.E),
                                                                                 dtype=float))

    def _newton(self, fun, x_pred, cj, cjlast, setup, weights, full=False):
        if full:
            return newton(fun, x_pred, self.lu, weights, tol=EPCON, maxiter=self.maxiter, jacobian="always",
                          rate=RATE_AFTER_SETUP, scale=1.0, norm=self.norm, tag=cj)
        if setup:
            rate, jac, scale = RATE_AFTER_SETUP, "first", 1.0
        else:
            rate = RATE_CJ_CHANGED if cj != cjlast else self.rate
            jac, scale = "never", 2.0 / (1.0 + cj / self.lu.tag)
        return newton(fun, x_pred, self.lu, weights, tol=EPCON, maxiter=self.maxiter,
                      jacobian=jac, rate=rate, scale=scale, norm=self.norm, tag=cj)

    def solve(self, t_new: float, pred: np.ndarray, cj: float, cjlast: float, fresh: bool, state, w_newton):
        """Solve the corrector of one attempt.

        Parameters
        ----------
        t_new : float
        pred : ndarray, shape (2, n + m)
            ``[x_pred, q_pred; x'_pred, q'_pred]``, the charges of the ``m`` charge-form rows.
        cj, cjlast : float
            Leading coefficient of this attempt and of the previous one.
        fresh : bool
            Force a new Jacobian (the first step after a (re)start).
        state : object
            The devices' limiting state of the last accepted step.
        w_newton : ndarray, shape (n,)
            Weights of the Newton convergence test.

        Returns
        -------
        (True, (x_new, q_new)) or (False, failure dict)
            ``q_new``: the charges of the charge-form rows at ``x_new``, shape (m,).
        """
        n = self.system.n
        x_pred = pred[0, :n]
        xp_pred = pred[1, :n]
        q_pred = pred[0, n:]
        qp_pred = pred[1, n:]
        system = self.system
        st = self.stats
        floor = self.floor
        rows = self.rows
        e_matrix = self.e_matrix
        last = {}

        def residual(ev, x):
            if e_matrix is None:
                r = ev.q - q_pred
                r *= cj
                r += qp_pred
            else:
                # correction form cj E (x - x_pred) + E x'_pred, charge form in the charge rows
                v = x - x_pred
                v *= cj
                v += xp_pred
                r = e_matrix @ v
                rq = ev.q[rows] - q_pred
                rq *= cj
                rq += qp_pred
                r[rows] = rq
            r -= ev.phi
            return r

        def fun(x, jacobian):
            ev = system.evaluate(x, t_new, jacobian=jacobian, state=self.state_try)
            st["evaluations"] += 1
            self.state_try = ev.state
            last["ev"] = ev
            if jacobian:
                floor.keep(ev.dq)
                self._dphi_lu = np.array(ev.dphi, dtype=float)
            r = residual(ev, x)
            last["r"] = r.copy()  # the residual the next correction is computed from
            if not jacobian:
                return r, None, ev.ok, ev.limited
            st["jacobian_evaluations"] += 1
            return r, cj * ev.dq - ev.dphi, ev.ok, ev.limited

        check = self.row_atol is not None and self.rtol is not None and self.atol is not None

        def stale(x, ev):
            """The check of an iterate accepted with a Jacobian from an earlier step (``ev``: the
            evaluation at ``x`` with its Jacobian): an entry of the factorisation's ``dphi/dx`` fell
            by more than ``CONDUCTANCE_FALL``, or a row's residual stalled, measured against the
            magnitude of its terms, the charge terms, the currents and ``(cj |E| + |H| + cj |dq - E|
            + |dphi - H|) |x|``."""
            indptr, indices = self._pattern_arrays
            if self._dphi_lu is not None and conductance_fell(self._dphi_lu, ev.dphi, ev.dq, cj, indptr, indices,
                                                              self.row_atol, self.atol, CONDUCTANCE_FALL):
                return True
            r_new = residual(ev, x)
            mag = np.abs(r_new + ev.phi)
            mag += np.abs(ev.phi)
            if self._eh is None:
                a = np.abs(cj * ev.dq - ev.dphi)
            else:
                # the linear elements' terms and the devices' apart (a resistor's current and a
                # device's that cancel it in the Jacobian, at a fold, are both terms of the row)
                e, h = self._eh
                a = cj * (np.abs(e) + np.abs(ev.dq - e)) + np.abs(h) + np.abs(ev.dphi - h)
            mag += self.system.pattern.matrix(a) @ np.abs(x)
            return residual_stalled(last["r"], r_new, mag, self.rtol, self.row_atol, RESIDUAL_RATE_MAX,
                                    RESIDUAL_NU_MAX)

        def attempt(setup, full=False):
            """One Newton solve; a converged one's charges evaluated, and checked when its Jacobian is older."""
            self.state_try = state
            res = self._newton(fun, x_pred, cj, cjlast, setup, w_newton, full)
            if setup or full:
                self.age = 0
            if not res.converged:
                return res, None
            checked = check and not setup and not full
            # the check evaluates with the devices' limiting against the last iterate: a junction the
            # accepted correction moved further than its limiting allows is not converged (as SPICE,
            # which counts every limited iterate as not converged); unlimited, the values are x's own
            ev = system.evaluate(res.x, t_new, jacobian=checked, state=self.state_try if checked else None)
            st["evaluations"] += 1
            if checked and ev.ok:
                st["jacobian_evaluations"] += 1
                floor.keep(ev.dq)
                if ev.limited or stale(res.x, ev):
                    # accepted with a Jacobian made at another operating point: not converged
                    res.converged = False
            return res, ev

        lu = self.lu
        setup = (not lu.ready) or fresh
        if not setup:
            ratio = cj / lu.tag
            setup = ratio < (1.0 - DCJ) / (1.0 + DCJ) or ratio > (1.0 + DCJ) / (1.0 - DCJ)
            setup = setup or self.age >= JAC_AGE_MAX
        res, ev_new = attempt(setup)
        if not res.converged and not setup and res.info != INFO_EVALUATION:
            # stale Jacobian: retry once with a fresh one at the same step size
            st["newton_failures"] += 1
            st["newton_iterations"] += res.iterations
            res, ev_new = attempt(True)
        if not res.converged and res.info not in (INFO_EVALUATION, INFO_SINGULAR):
            # a fresh Jacobian failed too: full Newton (a model whose slope changes within
            # the step, as a MOS charge at its threshold) before a smaller step
            st["newton_failures"] += 1
            st["newton_iterations"] += res.iterations
            res, ev_new = attempt(True, full=True)
        st["newton_iterations"] += res.iterations
        st["factorizations"] = lu.factorizations
        if not res.converged:
            worst = system.names[res.worst] if res.worst >= 0 else None
            if res.info == INFO_EVALUATION and "ev" in last:
                worst = nonfinite_unknown(system.names, last["ev"]) or worst
            return False, {"info": res.info, "worst": worst}
        # a rate carried by solves that converged at their first correction was measured with an
        # older Jacobian at another point: after RATE_AGE_MAX of them it is assumed again
        self.rate_age = self.rate_age + 1 if res.iterations <= 1 else 0
        self.rate = res.rate
        if self.rate_age >= RATE_AGE_MAX:
            self.rate, self.rate_age = RATE_AFTER_SETUP, 0
        if not ev_new.ok:
            return False, {"info": INFO_EVALUATION, "worst": nonfinite_unknown(system.names, ev_new)}
        return True, (res.x, ev_new.q if e_matrix is None else ev_new.q[rows])
