"""The level-1 diode family as one compiled kernel (the twin of :class:`netdae.devices.diode.DiodeFamily`).

Layout (packed by ``DiodeFamily.compiled``)
-------------------------------------------
``par`` columns ``P_*``: the saturation current, ``N vt``, ``vcrit``, the
reverse knee ``-3 N vt``, GMIN, the breakdown flag, ``BV'``, ``NBV vt``,
TT, the series conductance, the family's charge flag, the nine
depletion coefficients from ``P_DEP``, and the knee currents IKF and IKR
(area and m included; 0: none).
``idx`` columns: anode ``I_A``, internal anode ``I_I`` (the anode itself
without RS), cathode ``I_K``; slots ``S_J`` of the junction (current and
charge on ``vd``) and ``S_R`` of the series resistance.
``vold``/``vnew``: ``V_VD``, the junction voltage.
"""

from __future__ import annotations

import math

from ...dae.compiled import kernel

from ..diode import KNEE_MIN_CURRENT
from . import FLAG_LIMITED, FLAG_NONFINITE, MODE_EVALUATE, MODE_INITIAL
from .junction import depletion, ideal_junction, pnjlim
from .scatter import add_charge, add_charge_slope, add_current, add_current_slope, is_zero

__all__ = ["eval_diode", "diode_limit", "diode_current", "junction_limit", "junction_current", "knee_current"]

P_ISAT, P_VTE, P_VCRIT, P_KNEE, P_GMIN, P_HAS_BV, P_BV, P_VTEBRK, P_TT, P_GS, P_CHARGE, P_DEP = range(12)
#: The depletion coefficients take nine columns from P_DEP; the knee currents follow.
P_IKF = P_DEP + 9
P_IKR = P_IKF + 1
N_PAR = P_IKR + 1
I_A, I_I, I_K, S_J, S_R = 0, 1, 2, 3, 7
N_IDX = S_R + 4
V_VD = 0
N_STATE = 1
#: ngspice starts limiting in breakdown 10 (NBV vt) above -BV (as netdae.devices.diode).
BREAKDOWN_LIMIT_MARGIN = 10.0


@kernel
def junction_limit(vd, vold, vte, vcrit, has_bv, bv, vtebrk):
    """A diode junction's limiting with breakdown (see :func:`netdae.devices.diode.junction_limit`).

    Returns
    -------
    (v, changed) : (float, bool)
    """
    if has_bv and vd < min(0.0, -bv + BREAKDOWN_LIMIT_MARGIN * vtebrk):
        vb, changed = pnjlim(-(vd + bv), -(vold + bv), vtebrk, vcrit)
        return -(vb + bv), changed
    return pnjlim(vd, vold, vte, vcrit)


@kernel
def junction_current(vd, isat, vte, knee, has_bv, bv, vtebrk, gmin):
    """A diode junction's current (GMIN included) and conductance (see
    :func:`netdae.devices.diode.junction_current`)."""
    if has_bv and vd < -bv and vd < knee:
        evrev = math.exp(-(bv + vd) / vtebrk)
        cd, gd = -isat * evrev, isat * evrev / vtebrk
    else:
        cd, gd = ideal_junction(vd, isat, vte, knee)
    return cd + gmin * vd, gd + gmin


@kernel
def knee_current(cd, gd, vd, gmin, knee, ikf, ikr):
    """High injection: the junction current ``c`` (GMIN's part set apart) becomes ``c / (1 + sqrt(c / IKF))``
    forward (``vd >= knee``), ``c / (1 + sqrt(c / -IKR))`` reverse, with its conductance by the chain
    rule (see :func:`netdae.devices.diode.knee_current`)."""
    c = cd - gmin * vd
    g = gd - gmin
    if vd >= knee:
        if ikf > 0.0 and c > KNEE_MIN_CURRENT:
            s = math.sqrt(c / ikf)
            g = ((1.0 + s) * g - c * g / (2.0 * s * ikf)) / (1.0 + 2.0 * s + c / ikf)
            c = c / (1.0 + s)
    elif ikr > 0.0 and c < -KNEE_MIN_CURRENT:
        s = math.sqrt(-c / ikr)
        g = ((1.0 + s) * g + c * g / (2.0 * s * ikr)) / (1.0 + 2.0 * s - c / ikr)
        c = c / (1.0 + s)
    return c + gmin * vd, g + gmin


@kernel
def diode_limit(vd, vold, par, k):
    """ngspice's diode limiting of instance ``k``: pnjlim, shifted by BV' in deep reverse bias."""
    return junction_limit(vd, vold, par[k, P_VTE], par[k, P_VCRIT], par[k, P_HAS_BV] != 0.0, par[k, P_BV],
                          par[k, P_VTEBRK])


@kernel
def diode_current(vd, par, k):
    """Current (GMIN included) and conductance of instance ``k`` at junction voltage ``vd``."""
    return junction_current(vd, par[k, P_ISAT], par[k, P_VTE], par[k, P_KNEE], par[k, P_HAS_BV] != 0.0,
                            par[k, P_BV], par[k, P_VTEBRK], par[k, P_GMIN])


@kernel
def eval_diode(x, mode, par, idx, vold, vnew, q, phi, dq, dphi, jacobian):
    """Add every diode's current, charge and derivatives (see :mod:`netdae.devices.kernels`)."""
    count = par.shape[0]
    start = mode == MODE_INITIAL and is_zero(x)
    limited = start
    # pass 1: the junction voltages to evaluate at (the family's limiting decision is shared)
    for k in range(count):
        vd_x = x[idx[k, I_I]] - x[idx[k, I_K]]
        if start:
            vd = vold[k, V_VD]
        elif mode == MODE_EVALUATE or mode == MODE_INITIAL:
            vd = vd_x
        else:
            vd, changed = diode_limit(vd_x, vold[k, V_VD], par, k)
            limited = limited or changed
        vnew[k, V_VD] = vd
    bad = -1
    for k in range(count):
        a, i, c = idx[k, I_A], idx[k, I_I], idx[k, I_K]
        vd = vnew[k, V_VD]
        cd, gd = diode_current(vd, par, k)
        if par[k, P_IKF] > 0.0 or par[k, P_IKR] > 0.0:
            cd, gd = knee_current(cd, gd, vd, par[k, P_GMIN], par[k, P_KNEE], par[k, P_IKF], par[k, P_IKR])
        charged = par[k, P_CHARGE] != 0.0
        qd = 0.0
        cq = 0.0
        if charged:
            qdep, cdep = depletion(vd, par[k, P_DEP], par[k, P_DEP + 1], par[k, P_DEP + 2], par[k, P_DEP + 3],
                                   par[k, P_DEP + 4], par[k, P_DEP + 5], par[k, P_DEP + 6], par[k, P_DEP + 7],
                                   par[k, P_DEP + 8])
            tt = par[k, P_TT]
            qd = tt * cd + qdep
            cq = tt * gd + cdep
        if bad < 0 and not (math.isfinite(cd) and math.isfinite(gd) and math.isfinite(qd) and math.isfinite(cq)):
            bad = k
        cd_out, qd_out = cd, qd
        if limited:
            dv = (x[i] - x[c]) - vd
            cd_out = cd + gd * dv
            qd_out = qd + cq * dv
        add_current(phi, i, c, cd_out)
        gs = par[k, P_GS]
        if gs != 0.0:
            add_current(phi, a, i, gs * (x[a] - x[i]))
        if charged:
            add_charge(q, i, c, qd_out)
        if jacobian:
            add_current_slope(dphi, idx, k, S_J, gd)
            if gs != 0.0:
                add_current_slope(dphi, idx, k, S_R, gs)
            if charged:
                add_charge_slope(dq, idx, k, S_J, cq)
    flags = (FLAG_LIMITED if limited else 0) | (FLAG_NONFINITE if bad >= 0 else 0)
    return flags, bad
