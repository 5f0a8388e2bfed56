"""The level-1 JFET family as one compiled kernel (the twin of :class:`netdae.devices.jfet.JfetFamily`).

Layout (packed by ``JfetFamily.compiled``)
------------------------------------------
``par`` columns ``P_*``: type, ``vt``, ``vcrit``, the gate junctions'
saturation current (area and m included), knee ``-3 vt`` and ``m GMIN``,
``VTO(T)``, ``BETA`` (temperature, area and m included), LAMBDA, B, the
doping-tail factor ``(1 - B)/(PB - VTO)``, the series conductances, the
family's charge flag, and two blocks of nine depletion coefficients
(gate-source, gate-drain).
``idx``: ``I_D, I_G, I_S``, the internal drain and source ``I_DI, I_SI``;
four slots per current dependence from ``S_CUR`` and per charge dependence
from ``S_CHG``, in the order of ``netdae.devices.jfet._CURRENT_DEPS`` and
``_CHARGE_DEPS``.
``vold``/``vnew``: ``V_GS, V_GD``, type-normalised.
"""

from __future__ import annotations

import math

from ...dae.compiled import kernel

from . import FLAG_LIMITED, FLAG_NONFINITE, MODE_EVALUATE, MODE_INITIAL
from .junction import depletion, gate_junction_limit, ideal_junction
from .scatter import add_charge, add_charge_slope, add_current, add_current_slope, is_zero

__all__ = ["eval_jfet", "channel_current", "drain_current", "jfet_limit"]

(P_TYPE, P_VT, P_VCRIT, P_ISAT, P_KNEE, P_GMIN, P_VTO, P_BETA, P_LAMBDA, P_B, P_BFAC, P_GD, P_GS,
 P_CHARGE_FAMILY, P_DEP_GS) = range(15)
P_DEP_GD = P_DEP_GS + 9
N_PAR = P_DEP_GD + 9
I_D, I_G, I_S, I_DI, I_SI = range(5)
#: Current dependences (id, vgs) (id, vgd) (igs, vgs) (igd, vgd) (ird, vrd) (irs, vrs); charge
#: dependences (qgs, vgs) (qgd, vgd): four slots each.
S_CUR = 5
N_CUR_DEPS = 6
S_CHG = S_CUR + 4 * N_CUR_DEPS
N_CHG_DEPS = 2
N_IDX = S_CHG + 4 * N_CHG_DEPS
V_GS, V_GD = 0, 1
N_STATE = 2


@kernel
def channel_current(u, w, beta, lam, b, bfac):
    """The mode's drain current and its derivatives (see :func:`netdae.devices.jfet.channel_current`).

    Returns
    -------
    (i, di_du, di_dw) : tuple of float
    """
    if u <= 0.0:
        return 0.0, 0.0, 0.0
    p = beta * (1.0 + lam * w)
    if u < w:
        fu = u * u * (b + bfac * u)
        return p * fu, p * u * (2.0 * b + 3.0 * bfac * u), beta * lam * fu
    r = u - w
    flin = w * ((u + r) * b + bfac * (u * u + u * r + r * r))
    return (p * flin, p * w * (2.0 * b + 3.0 * bfac * (u + r)),
            p * r * (2.0 * b + 3.0 * bfac * r) + beta * lam * flin)


@kernel
def drain_current(vgs, vgd, par, k):
    """Channel current of instance ``k`` and its derivatives to (vgs, vgd) (``JfetFamily.drain_current``)."""
    vds = vgs - vgd
    vto = par[k, P_VTO]
    if vds >= 0.0:
        i, di_du, di_dw = channel_current(vgs - vto, abs(vds), par[k, P_BETA], par[k, P_LAMBDA], par[k, P_B],
                                          par[k, P_BFAC])
        return i, di_du + di_dw, -di_dw
    i, di_du, di_dw = channel_current(vgd - vto, abs(vds), par[k, P_BETA], par[k, P_LAMBDA], par[k, P_B],
                                      par[k, P_BFAC])
    return -i, di_dw, -(di_du + di_dw)


@kernel
def _gate_junction(v, par, k):
    i, g = ideal_junction(v, par[k, P_ISAT], par[k, P_VT], par[k, P_KNEE])
    gmin = par[k, P_GMIN]
    return i + gmin * v, g + gmin


@kernel
def jfet_limit(vgs_x, vgd_x, vgs_o, vgd_o, par, k):
    """ngspice's JFET limiting of instance ``k``: both gate junctions with one ``vt`` and ``vcrit``
    (``JfetFamily.limit``)."""
    vt, vcrit = par[k, P_VT], par[k, P_VCRIT]
    return gate_junction_limit(vgs_x, vgd_x, vgs_o, vgd_o, vt, vcrit, vt, vcrit, par[k, P_VTO])


@kernel
def _depletion_at(v, par, k, col):
    return depletion(v, par[k, col], par[k, col + 1], par[k, col + 2], par[k, col + 3], par[k, col + 4],
                     par[k, col + 5], par[k, col + 6], par[k, col + 7], par[k, col + 8])


@kernel
def _finite4(a, b, c, d):
    return math.isfinite(a) and math.isfinite(b) and math.isfinite(c) and math.isfinite(d)


@kernel
def eval_jfet(x, mode, par, idx, vold, vnew, q, phi, dq, dphi, jacobian):
    """Add every JFET's currents, charges and derivatives (see :mod:`netdae.devices.kernels`)."""
    count = par.shape[0]
    start = mode == MODE_INITIAL and is_zero(x)
    limited = start
    for k in range(count):
        tp, g = par[k, P_TYPE], idx[k, I_G]
        vgs_x = tp * (x[g] - x[idx[k, I_SI]])
        vgd_x = tp * (x[g] - x[idx[k, I_DI]])
        if start:
            vgs, vgd = vold[k, V_GS], vold[k, V_GD]
        elif mode == MODE_EVALUATE or mode == MODE_INITIAL:
            vgs, vgd = vgs_x, vgd_x
        else:
            vgs, vgd = jfet_limit(vgs_x, vgd_x, vold[k, V_GS], vold[k, V_GD], par, k)
            limited = limited or vgs != vgs_x or vgd != vgd_x
        vnew[k, V_GS] = vgs
        vnew[k, V_GD] = vgd
    bad = -1
    for k in range(count):
        d, g, s, di, si = idx[k, I_D], idx[k, I_G], idx[k, I_S], idx[k, I_DI], idx[k, I_SI]
        tp = par[k, P_TYPE]
        vgs, vgd = vnew[k, V_GS], vnew[k, V_GD]
        cdrain, d_vgs, d_vgd = drain_current(vgs, vgd, par, k)
        igs, ggs = _gate_junction(vgs, par, k)
        igd, ggd = _gate_junction(vgd, par, k)
        gdr, gsr = par[k, P_GD], par[k, P_GS]
        i_d = tp * cdrain
        i_gs = tp * igs
        i_gd = tp * igd
        i_rd = gdr * (x[d] - x[di])
        i_rs = gsr * (x[s] - x[si])
        ok = _finite4(i_d, i_gs, i_gd, i_rd) and _finite4(i_rs, d_vgs, d_vgd, ggs) and _finite4(ggd, gdr, gsr, 0.0)
        charged = par[k, P_CHARGE_FAMILY] != 0.0
        q_gs = q_gd = c_gs = c_gd = 0.0
        if charged:
            q_gs, c_gs = _depletion_at(vgs, par, k, P_DEP_GS)
            q_gd, c_gd = _depletion_at(vgd, par, k, P_DEP_GD)
            q_gs, q_gd = tp * q_gs, tp * q_gd
            ok = ok and _finite4(q_gs, q_gd, c_gs, c_gd)
        if bad < 0 and not ok:
            bad = k
        if limited:
            dgs = (x[g] - x[si]) - tp * vgs
            dgd = (x[g] - x[di]) - tp * vgd
            i_d = i_d + (d_vgs * dgs + d_vgd * dgd)
            i_gs = i_gs + ggs * dgs
            i_gd = i_gd + ggd * dgd
            q_gs = q_gs + c_gs * dgs
            q_gd = q_gd + c_gd * dgd
        add_current(phi, di, si, i_d)
        add_current(phi, g, si, i_gs)
        add_current(phi, g, di, i_gd)
        add_current(phi, d, di, i_rd)
        add_current(phi, s, si, i_rs)
        if charged:
            add_charge(q, g, si, q_gs)
            add_charge(q, g, di, q_gd)
        if jacobian:
            add_current_slope(dphi, idx, k, S_CUR, d_vgs)
            add_current_slope(dphi, idx, k, S_CUR + 4, d_vgd)
            add_current_slope(dphi, idx, k, S_CUR + 8, ggs)
            add_current_slope(dphi, idx, k, S_CUR + 12, ggd)
            add_current_slope(dphi, idx, k, S_CUR + 16, gdr)
            add_current_slope(dphi, idx, k, S_CUR + 20, gsr)
            if charged:
                add_charge_slope(dq, idx, k, S_CHG, c_gs)
                add_charge_slope(dq, idx, k, S_CHG + 4, c_gd)
    flags = (FLAG_LIMITED if limited else 0) | (FLAG_NONFINITE if bad >= 0 else 0)
    return flags, bad
