"""Voltage- and current-controlled switches as compiled kernels (the twin of :class:`netdae.devices.switch.SwitchFamily`).

A switch is a conductance between n+ and n-: ``GON = 1/RON`` or ``GOFF =
1/ROFF`` by its *state*, one of ngspice's four (``swload.c``/``cswload.c``):
``REALLY_OFF``, ``REALLY_ON`` (the control outside the hysteresis band) and
``HYST_OFF``, ``HYST_ON`` (inside it); ``REALLY_ON`` and ``HYST_ON`` conduct.
The control ``c`` is ``v(nc+) - v(nc-)`` (S) or the branch current of the
controlling element (W), read as ``x[I_CP] - x[I_CM]`` (``I_CM`` ground for W).

How a state follows from the control (``vt``, ``vh`` the model's threshold
and hysteresis, ``IT``/``IH`` for W) and a reference state:
:func:`decide` (ngspice's ``MODEINITFLOAT``); :func:`junction_state`
(``MODEINITJCT``: the instance's ON/OFF flag); :func:`dc_state` (an operating
point: the reference is the previous iterate for S with ``vh > 0``, else
ngspice's ``CKTstate1``, which an operating point leaves at ``REALLY_OFF``).
A transient holds the state through each step and decides it between steps
(:func:`switch_step`).

Layout (packed by ``SwitchFamily.compiled``)
--------------------------------------------
``par`` columns ``P_*``: GON, GOFF, the threshold, the hysteresis, the ON flag,
and whether an operating point holds the previous iterate's state in the band.
``idx`` columns: n+ ``I_P``, n- ``I_M``, the control's ``I_CP``, ``I_CM``
(extended indices), and the four slots ``S_G`` of the conductance.
``vold``/``vnew``: ``V_STATE`` (0-3) and ``V_HOLD`` (1: the state is held, as
in a transient; 0: decided from the iterate in every mode, as in an operating
point).
"""

from __future__ import annotations

import math

from ...dae.compiled import kernel
from ...dae.compiled.events import EVENT_MIN_GAP, EVENT_TOGETHER, crossing_time, interpolate_state

from . import FLAG_LIMITED, FLAG_NONFINITE, MODE_EVALUATE, MODE_INITIAL
from .scatter import add_current, add_current_slope
from .switch_states import HYST_OFF, HYST_ON, REALLY_OFF, REALLY_ON

__all__ = ["eval_switch", "switch_at", "decide", "junction_state", "dc_state", "watch", "switched", "conducting",
           "switch_decide", "switch_step", "REALLY_OFF", "REALLY_ON", "HYST_OFF", "HYST_ON"]

P_GON, P_GOFF, P_VT, P_VH, P_ON, P_DC_HOLD = range(6)
N_PAR = 6
I_P, I_M, I_CP, I_CM, S_G = 0, 1, 2, 3, 4
N_IDX = S_G + 4
V_STATE, V_HOLD = 0, 1
N_STATE = 2


@kernel
def conducting(s):
    """True for the states that conduct with GON (``REALLY_ON``, ``HYST_ON``)."""
    return s == REALLY_ON or s == HYST_ON


@kernel
def junction_state(c, on, vt, vh):
    """ngspice's ``MODEINITJCT`` state: the ON/OFF flag, ``REALLY_*`` when the control agrees."""
    if on:
        if (vh >= 0.0 and c > vt + vh) or (vh < 0.0 and c > vt - vh):
            return REALLY_ON
        return HYST_ON
    if (vh >= 0.0 and c < vt - vh) or (vh < 0.0 and c < vt + vh):
        return REALLY_OFF
    return HYST_OFF


@kernel
def decide(c, ref, vt, vh):
    """ngspice's ``MODEINITFLOAT`` state at control ``c`` after state ``ref``.

    ``vh > 0``: on above ``vt + vh``, off below ``vt - vh``, ``ref`` in between.
    ``vh <= 0``: on above ``vt - vh``, off below ``vt + vh``; in between a
    ``HYST_*`` state stays, ``REALLY_ON`` becomes ``HYST_OFF`` and ``REALLY_OFF``
    ``HYST_ON`` (the band reverses the state of a control that enters it).
    """
    if vh > 0.0:
        if c > vt + vh:
            return REALLY_ON
        if c < vt - vh:
            return REALLY_OFF
        return ref
    if c > vt - vh:
        return REALLY_ON
    if c < vt + vh:
        return REALLY_OFF
    if ref == HYST_OFF or ref == HYST_ON:
        return ref
    if ref == REALLY_ON:
        return HYST_OFF
    return HYST_ON


@kernel
def dc_state(c, old, par, k):
    """Instance ``k``'s state in an operating point at control ``c``; ``old < 0``: no previous iterate.

    The reference is the previous iterate's state (else the ON/OFF flag's) for
    a voltage-controlled switch with ``vh > 0``, ``REALLY_OFF`` otherwise (ngspice
    reads ``CKTstate1`` there, which an operating point leaves at 0).
    """
    vt = par[k, P_VT]
    vh = par[k, P_VH]
    if par[k, P_DC_HOLD] != 0.0:
        ref = old if old >= 0.0 else junction_state(c, par[k, P_ON] != 0.0, vt, vh)
    else:
        ref = REALLY_OFF
    return decide(c, ref, vt, vh)


@kernel
def watch(s, vt, vh):
    """The threshold whose crossing changes the conductance in state ``s``, and its direction (+1 rising)."""
    if conducting(s):
        if vh <= 0.0 and s == HYST_ON:
            return vt + vh, -1.0
        return vt - vh, -1.0
    if vh <= 0.0 and s == HYST_OFF:
        return vt - vh, 1.0
    return vt + vh, 1.0


@kernel
def switched(s, vh):
    """The state just past the threshold :func:`watch` gives for state ``s``."""
    if vh > 0.0:
        return REALLY_OFF if conducting(s) else REALLY_ON
    if s == REALLY_OFF:
        return HYST_ON
    if s == HYST_OFF:
        return REALLY_ON
    if s == REALLY_ON:
        return HYST_OFF
    return REALLY_OFF


@kernel
def control(x, idx, k):
    """Instance ``k``'s control value at the extended iterate ``x``."""
    return x[idx[k, I_CP]] - x[idx[k, I_CM]]


@kernel
def eval_switch(x, mode, par, idx, vold, vnew, q, phi, dq, dphi, jacobian):
    """Add every switch's current and conductance (see :mod:`netdae.devices.kernels`).

    A held state (``vold[k, V_HOLD] != 0``) is used whatever the mode. Otherwise
    the state follows the control: :func:`dc_state` without history
    (``MODE_EVALUATE``), :func:`junction_state` (``MODE_INITIAL``), or
    :func:`dc_state` after ``vold``'s state (``MODE_LIMIT``), which reports a
    change of conductance as limited (another Newton iteration, as ngspice's
    ``CKTnoncon++``). Switches store no charge.
    """
    count = par.shape[0]
    limited = False
    bad = -1
    for k in range(count):
        hold = vold[k, V_HOLD]
        if hold != 0.0:
            s = vold[k, V_STATE]
        else:
            c = control(x, idx, k)
            if mode == MODE_EVALUATE:
                s = dc_state(c, -1.0, par, k)
            elif mode == MODE_INITIAL:
                s = junction_state(c, par[k, P_ON] != 0.0, par[k, P_VT], par[k, P_VH])
            else:
                s = dc_state(c, vold[k, V_STATE], par, k)
                if conducting(s) != conducting(vold[k, V_STATE]):
                    limited = True
        vnew[k, V_STATE] = s
        vnew[k, V_HOLD] = hold
        g = par[k, P_GON] if conducting(s) else par[k, P_GOFF]
        a = idx[k, I_P]
        b = idx[k, I_M]
        i = g * (x[a] - x[b])
        if bad < 0 and not math.isfinite(i):
            bad = k
        add_current(phi, a, b, i)
        if jacobian:
            add_current_slope(dphi, idx, k, S_G, g)
    flags = (FLAG_LIMITED if limited else 0) | (FLAG_NONFINITE if bad >= 0 else 0)
    return flags, bad


@kernel
def switch_decide(x, par, idx, sold, snew):
    """The states at an accepted point ``x`` after the held states ``sold``, into ``snew``.

    Returns how many switches change conductance.
    """
    changes = 0
    for k in range(par.shape[0]):
        s = decide(control(x, idx, k), sold[k, V_STATE], par[k, P_VT], par[k, P_VH])
        snew[k, V_STATE] = s
        snew[k, V_HOLD] = sold[k, V_HOLD]
        if conducting(s) != conducting(sold[k, V_STATE]):
            changes += 1
    return changes


@kernel
def switch_at(x, t, par, idx, sacc, snew, tcross):
    """The switches' states at the extended point ``x`` at ``t``, where an event without a step happens.

    A behavioural source's comparison changes at ``t`` itself (its held branch undefined past the
    change, :func:`netdae.devices.kernels.behavioural.lock_at`): a switch controlled by the same crossing
    settles in that event, not in a second one right after. The states are decided at ``x`` (the point
    of the change) from the held ones ``sacc``; ``tcross`` gets ``t`` for those that change conductance
    (inf for the others), and ``sacc`` the decided states. Returns how many change conductance.
    """
    changes = switch_decide(x, par, idx, sacc, snew)
    for j in range(par.shape[0]):
        tcross[j] = t if conducting(snew[j, V_STATE]) != conducting(sacc[j, V_STATE]) else math.inf
        sacc[j, V_STATE] = snew[j, V_STATE]
        sacc[j, V_HOLD] = snew[j, V_HOLD]
    return changes


@kernel
def switch_step(P, k, psi, t, t_new, n, par, idx, sacc, snew, tcross, xe, xw):
    """After an accepted step from ``t`` to ``t_new``: where it ends, and the switches' states there.

    ``P`` holds the step's updated differences (order ``k``) and ``psi``. The
    states at ``t_new`` are decided from the held ones ``sacc``; when a switch
    would change conductance, the time its control crossed the threshold is
    located on the step's interpolant (:func:`~netdae.dae.compiled.events.crossing_time`,
    at least ``EVENT_MIN_GAP`` of the step after ``t``), and the step ends at
    the first such crossing: ``xw`` receives the interpolated unknowns there.
    The switches crossing then (within ``EVENT_TOGETHER`` of the step) take the
    state past their threshold, the others keep their conductance (their
    crossing, if any, comes later).

    Parameters
    ----------
    tcross : ndarray, shape (N,)
        Work: each switch's crossing time (inf: none).
    xe : ndarray, shape (n + 1,)
        Work: the extended unknowns at the step's end.
    xw : ndarray, shape (n,)
        The unknowns at the event when it is before ``t_new`` (else untouched).

    Returns
    -------
    (t_end, switched) : (float, int)
        The step's end (``t_new`` or the event) and how many switches change
        conductance there (0: no event; ``snew`` then holds the decided states).
    """
    count = par.shape[0]
    for i in range(n):
        xe[i] = P[0, i]
    xe[n] = 0.0
    if switch_decide(xe, par, idx, sacc, snew) == 0:
        return t_new, 0
    h = t_new - t
    t_ev = t_new
    for j in range(count):
        tcross[j] = math.inf
        s = sacc[j, V_STATE]
        if conducting(snew[j, V_STATE]) != conducting(s):
            theta, direction = watch(s, par[j, P_VT], par[j, P_VH])
            tc = crossing_time(P, k, psi, t, t_new, idx[j, I_CP], idx[j, I_CM], n, theta, direction)
            tc = max(tc, t + EVENT_MIN_GAP * h)
            tcross[j] = tc
            if tc < t_ev:
                t_ev = tc
    if t_new - t_ev <= EVENT_TOGETHER * h or not t_ev > t:
        t_ev = t_new  # (a step too short for the gap to show in t: the event at its end)
    limit = t_ev + EVENT_TOGETHER * h
    if t_ev < t_new:
        interpolate_state(P, k, psi, t_ev - t_new, n, xw)
        for i in range(n):
            xe[i] = xw[i]
    changes = 0
    for j in range(count):
        s_old = sacc[j, V_STATE]
        s = decide(control(xe, idx, j), s_old, par[j, P_VT], par[j, P_VH])
        if tcross[j] <= limit:
            if conducting(s) == conducting(s_old):
                s = switched(s_old, par[j, P_VH])
            changes += 1
        elif conducting(s) != conducting(s_old):
            s = s_old
        snew[j, V_STATE] = s
        snew[j, V_HOLD] = sacc[j, V_HOLD]
    return t_ev, changes
