"""The VDMOS family as one compiled kernel (the twin of :class:`netdae.devices.vdmos.VdmosFamily`).

Layout (packed by ``VdmosFamily.compiled``)
-------------------------------------------
``par`` columns ``P_*``: type, ``VON``, ``KP m`` at temperature, LAMBDA, THETA,
KSUBTHRES at temperature, SUBSHIFT, MTRIODE; the drain conductance, the
quasi-saturation flag, ``RD/m`` and ``RQ/m`` at temperature, ``|VQ|``, GMIN;
the source, gate, body-diode and drain-source conductances; CGS and the
gate-drain capacitance's ``s``, ``y``, ``A``; the body diode's saturation
current, ``N vt``, knee, ``vcrit``, breakdown flag, ``BV'``, ``NBV vt``, TT;
the family's charge and quasi-saturation flags; nine depletion coefficients
from ``P_DEP``.
``idx``: ``I_D, I_G, I_S`` and the internal ``I_DI, I_GI, I_SI, I_BI``; four
slots per current dependence from ``S_CUR`` and per charge dependence from
``S_CHG``, in the order of ``netdae.devices.vdmos._CURRENT_DEPS`` and
``_CHARGE_DEPS`` (the dummy slot where the family lacks one).
``vold``/``vnew``: ``V_GS, V_DS, V_D`` (the body diode), type-normalised.
"""

from __future__ import annotations

import math

from ...dae.compiled import kernel

from . import FLAG_LIMITED, FLAG_NONFINITE, MODE_EVALUATE, MODE_INITIAL
from .diode import junction_current, junction_limit
from .junction import depletion, fet_mode_limit
from .scatter import add_charge, add_charge_slope, add_current, add_current_slope, is_zero

__all__ = ["eval_vdmos", "channel_current", "gate_drain_charge", "drain_conductance"]

(P_TYPE, P_VON, P_BETA, P_LAMBDA, P_THETA, P_KSUB, P_SHIFT, P_MTR, P_GD0, P_QS, P_RD0, P_RQ, P_VQ, P_GMIN,
 P_GS, P_GG, P_GB, P_GDS, P_CGS, P_CGD_S, P_CGD_Y, P_A, P_ISAT, P_VTE, P_KNEE, P_VCRIT, P_HAS_BV, P_BV,
 P_VTEBRK, P_TT, P_CHARGE_FAMILY, P_QS_FAMILY, P_DEP) = range(33)
#: The depletion coefficients take nine columns from P_DEP.
N_PAR = P_DEP + 9
I_D, I_G, I_S, I_DI, I_GI, I_SI, I_BI = range(7)
#: Current dependences (id, vgs) (id, vds) (idio, vd) (ird, vrd) (irs, vrs) (irg, vrg) (irb, vrb)
#: (irds, vdsx) (ird, vdsx); charge dependences (qgs, vgs) (qgd, vgs) (qgd, vds) (qdio, vd): four slots each.
S_CUR = 7
N_CUR_DEPS = 9
S_CHG = S_CUR + 4 * N_CUR_DEPS
N_CHG_DEPS = 4
N_IDX = S_CHG + 4 * N_CHG_DEPS
V_GS, V_DS, V_D = 0, 1, 2
N_STATE = 3
_LOG2 = math.log(2.0)
#: As netdae.devices.vdmos: ln(cosh x) from sinh below this |x|, from exp above.
LOGCOSH_SWITCH = 1.0


@kernel
def channel_current(vgs, vds, par, k):
    """Channel current of instance ``k`` and its derivatives to (vgs, vds) (see
    :func:`netdae.devices.vdmos.channel_current`)."""
    fwd = vds >= 0.0
    u0 = (vgs if fwd else vgs - vds) - par[k, P_VON]
    ksub = par[k, P_KSUB]
    z = (u0 - par[k, P_SHIFT]) / ksub
    e = math.exp(-abs(z))
    sp = max(z, 0.0) + math.log1p(e)
    sig = 1.0 / (1.0 + e) if z >= 0.0 else e / (1.0 + e)
    u = ksub * sp
    mtr = par[k, P_MTR]
    w = abs(vds) * mtr
    beta, lam, theta = par[k, P_BETA], par[k, P_LAMBDA], par[k, P_THETA]
    t0 = 1.0 + lam * vds
    t1 = 1.0 + theta * vgs
    betap = beta * t0 / t1
    if u <= w:
        f, fu, fw = 0.5 * u * u, u, 0.0
    else:
        f, fu, fw = w * (u - 0.5 * w), w, u - w
    du_dvds = 0.0 if fwd else -sig
    dw_dvds = mtr if fwd else -mtr
    di_dvgs = -beta * theta * t0 / (t1 * t1) * f + betap * fu * sig
    di_dvds = beta * lam / t1 * f + betap * (fu * du_dvds + fw * dw_dvds)
    i = betap * f
    if fwd:
        return i, di_dvgs, di_dvds
    return -i, -di_dvgs, -di_dvds


@kernel
def gate_drain_charge(v, s, y, a):
    """Gate-drain charge and capacitance (see :func:`netdae.devices.vdmos.gate_drain_charge`)."""
    av = a * v
    if v > 0.0:
        c = s * math.tanh(av) + y
        if a == 0.0:
            return y * v, c
        ax = abs(av)
        if ax > LOGCOSH_SWITCH:
            lc = ax + math.log1p(math.exp(-2.0 * ax)) - _LOG2
        else:
            half = math.sinh(ax * 0.5)
            lc = math.log1p(2.0 * half * half)
        return y * v + s * (lc / a), c
    c = s * math.atan(av) + y
    if a == 0.0:
        return y * v, c
    ax = abs(av)
    if ax > 1.0:
        inv = 1.0 / ax
        lsq = 2.0 * math.log(ax) + math.log1p(inv * inv)
    else:
        lsq = math.log1p(ax * ax)
    return y * v + s * (v * math.atan(av) - lsq / (2.0 * a)), c


@kernel
def drain_conductance(vdsx, forward, par, k):
    """The drain resistance's conductance of instance ``k`` and its derivative to the outer vdsx
    (see ``VdmosFamily.drain_conductance``)."""
    gd0 = par[k, P_GD0]
    if par[k, P_QS_FAMILY] == 0.0:
        return gd0, 0.0
    rq, vq = par[k, P_RQ], par[k, P_VQ]
    rdq = par[k, P_RD0] + rq * vdsx / (vdsx + vq)
    if par[k, P_QS] != 0.0 and forward and rdq > 0.0:
        inv = 1.0 / rdq
        den = vdsx + vq
        return inv + par[k, P_GMIN], -inv * inv * rq * vq / (den * den)
    return gd0, 0.0


@kernel
def _finite4(a, b, c, d):
    return math.isfinite(a) and math.isfinite(b) and math.isfinite(c) and math.isfinite(d)


@kernel
def eval_vdmos(x, mode, par, idx, vold, vnew, q, phi, dq, dphi, jacobian):
    """Add every VDMOS's currents, charges and derivatives (see :mod:`netdae.devices.kernels`)."""
    count = par.shape[0]
    start = mode == MODE_INITIAL and is_zero(x)
    limited = start
    for k in range(count):
        tp = par[k, P_TYPE]
        si = idx[k, I_SI]
        vgs_x = tp * (x[idx[k, I_GI]] - x[si])
        vds_x = tp * (x[idx[k, I_DI]] - x[si])
        vd_x = tp * (x[idx[k, I_BI]] - x[idx[k, I_D]])
        if start:
            vgs, vds, vd = vold[k, V_GS], vold[k, V_DS], vold[k, V_D]
        elif mode == MODE_EVALUATE or mode == MODE_INITIAL:
            vgs, vds, vd = vgs_x, vds_x, vd_x
        else:
            vgs, vds = fet_mode_limit(vgs_x, vds_x, vold[k, V_GS], vold[k, V_DS], par[k, P_VON])
            vd, _ = junction_limit(vd_x, vold[k, V_D], par[k, P_VTE], par[k, P_VCRIT], par[k, P_HAS_BV] != 0.0,
                                   par[k, P_BV], par[k, P_VTEBRK])
            limited = limited or vgs != vgs_x or vds != vds_x or vd != vd_x
        vnew[k, V_GS] = vgs
        vnew[k, V_DS] = vds
        vnew[k, V_D] = vd
    bad = -1
    for k in range(count):
        d, g, s = idx[k, I_D], idx[k, I_G], idx[k, I_S]
        di, gi, si, bi = idx[k, I_DI], idx[k, I_GI], idx[k, I_SI], idx[k, I_BI]
        tp = par[k, P_TYPE]
        vgs, vds, vd = vnew[k, V_GS], vnew[k, V_DS], vnew[k, V_D]
        cdrain, d_vgs, d_vds = channel_current(vgs, vds, par, k)
        cdio, gdio = junction_current(vd, par[k, P_ISAT], par[k, P_VTE], par[k, P_KNEE], par[k, P_HAS_BV] != 0.0,
                                      par[k, P_BV], par[k, P_VTEBRK], par[k, P_GMIN])
        vrd = x[d] - x[di]
        gdr, dgdr = drain_conductance(tp * (x[d] - x[s]), vds >= 0.0, par, k)
        gsr, ggr, gbr, gds = par[k, P_GS], par[k, P_GG], par[k, P_GB], par[k, P_GDS]
        i_d = tp * cdrain
        i_dio = tp * cdio
        i_rd = gdr * vrd
        ok = _finite4(i_d, i_dio, i_rd, d_vgs) and _finite4(d_vds, gdio, gdr, dgdr)
        charged = par[k, P_CHARGE_FAMILY] != 0.0
        q_gs = q_gd = q_dio = c_gs = c_gd = c_dio = 0.0
        if charged:
            c_gs = par[k, P_CGS]
            q_gs = tp * (c_gs * vgs)
            qgd, c_gd = gate_drain_charge(vgs - vds, par[k, P_CGD_S], par[k, P_CGD_Y], par[k, P_A])
            q_gd = tp * qgd
            qdep, cdep = depletion(vd, par[k, P_DEP], par[k, P_DEP + 1], par[k, P_DEP + 2], par[k, P_DEP + 3],
                                   par[k, P_DEP + 4], par[k, P_DEP + 5], par[k, P_DEP + 6], par[k, P_DEP + 7],
                                   par[k, P_DEP + 8])
            tt = par[k, P_TT]
            q_dio = tp * (tt * cdio + qdep)
            c_dio = tt * gdio + cdep
            ok = ok and _finite4(q_gs, q_gd, q_dio, c_gd) and math.isfinite(c_dio)
        if bad < 0 and not ok:
            bad = k
        if limited:
            dgs = (x[gi] - x[si]) - tp * vgs
            dds = (x[di] - x[si]) - tp * vds
            dd = (x[bi] - x[d]) - tp * vd
            i_d = i_d + (d_vgs * dgs + d_vds * dds)
            i_dio = i_dio + gdio * dd
            q_gs = q_gs + c_gs * dgs
            q_gd = q_gd + (c_gd * dgs + (-c_gd) * dds)
            q_dio = q_dio + c_dio * dd
        add_current(phi, di, si, i_d)
        add_current(phi, bi, d, i_dio)
        add_current(phi, d, di, i_rd)
        add_current(phi, s, si, gsr * (x[s] - x[si]))
        add_current(phi, g, gi, ggr * (x[g] - x[gi]))
        add_current(phi, s, bi, gbr * (x[s] - x[bi]))
        add_current(phi, d, s, gds * (x[d] - x[s]))
        if charged:
            add_charge(q, gi, si, q_gs)
            add_charge(q, gi, di, q_gd)
            add_charge(q, bi, d, q_dio)
        if jacobian:
            add_current_slope(dphi, idx, k, S_CUR, d_vgs)
            add_current_slope(dphi, idx, k, S_CUR + 4, d_vds)
            add_current_slope(dphi, idx, k, S_CUR + 8, gdio)
            add_current_slope(dphi, idx, k, S_CUR + 12, gdr)
            add_current_slope(dphi, idx, k, S_CUR + 16, gsr)
            add_current_slope(dphi, idx, k, S_CUR + 20, ggr)
            add_current_slope(dphi, idx, k, S_CUR + 24, gbr)
            add_current_slope(dphi, idx, k, S_CUR + 28, gds)
            add_current_slope(dphi, idx, k, S_CUR + 32, tp * dgdr * vrd)
            if charged:
                add_charge_slope(dq, idx, k, S_CHG, c_gs)
                add_charge_slope(dq, idx, k, S_CHG + 4, c_gd)
                add_charge_slope(dq, idx, k, S_CHG + 8, -c_gd)
                add_charge_slope(dq, idx, k, S_CHG + 12, c_dio)
    flags = (FLAG_LIMITED if limited else 0) | (FLAG_NONFINITE if bad >= 0 else 0)
    return flags, bad
