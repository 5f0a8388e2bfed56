"""The level-1 MOSFET family as one compiled kernel (the twin of :class:`netdae.devices.mosfet.MosfetFamily`).

Layout (packed by ``MosfetFamily.compiled``)
--------------------------------------------
``par`` columns ``P_*``: type, ``beta``, LAMBDA, ``VBI`` (type-normalised),
GAMMA, PHI, the bulk diodes' ``vt``, saturation currents and critical
voltages (source, drain), GMIN, the overlap capacitances, ``Cox``, the
series conductances, and four blocks of nine depletion coefficients
(bottom source, bottom drain, sidewall source, sidewall drain). The
``*_FAMILY`` columns carry the numpy family's family-wide decisions
(charges, the two depletion kinds, the intrinsic gate charge).
``idx``: ``I_D, I_G, I_S, I_B``, the internal drain and source ``I_DI,
I_SI``; four slots per current dependence from ``S_CUR`` and per charge
dependence from ``S_CHG`` in the order of ``netdae.devices.mosfet._CURRENT_DEPS``
and ``_CHARGE_DEPS``.
``vold``/``vnew``: ``V_GS, V_DS, V_BS`` (type-normalised) and ``V_VON``,
the threshold voltage the next iteration's ``fetlim`` uses.
"""

from __future__ import annotations

import math

from ...dae.compiled import kernel

from . import FLAG_LIMITED, FLAG_NONFINITE, MODE_EVALUATE, MODE_INITIAL, MODE_LIMIT
from .junction import depletion, fet_mode_limit, pnjlim
from .scatter import add_charge, add_charge_slope, add_current, add_current_slope, is_zero

__all__ = ["eval_mosfet", "drain_current", "gate_charges", "mosfet_limit"]

(P_TYPE, P_BETA, P_LAMBDA, P_VBI, P_GAMMA, P_PHI, P_VT, P_ISAT_S, P_ISAT_D, P_VCRIT_S, P_VCRIT_D, P_GMIN,
 P_CGSO, P_CGDO, P_CGBO, P_COX, P_GD, P_GS, P_CHARGE_FAMILY, P_BOTTOM_FAMILY, P_SIDE_FAMILY, P_COX_FAMILY,
 P_DEP_BS) = range(23)
P_DEP_BD = P_DEP_BS + 9
P_DEP_SS = P_DEP_BD + 9
P_DEP_SD = P_DEP_SS + 9
N_PAR = P_DEP_SD + 9
I_D, I_G, I_S, I_B, I_DI, I_SI = range(6)
#: Current dependences (id, vgs) (id, vds) (id, vbs) (ibs, vbs) (ibd, vbs) (ibd, vds) (ird, vrd)
#: (irs, vrs); charge dependences (q_g, q_d, q_b) x (vgs, vds, vbs), row-major: four slots each.
S_CUR = 6
N_CUR_DEPS = 8
S_CHG = S_CUR + 4 * N_CUR_DEPS
N_CHG_DEPS = 9
N_IDX = S_CHG + 4 * N_CHG_DEPS
V_GS, V_DS, V_BS, V_VON = 0, 1, 2, 3
N_STATE = 4
#: As netdae.devices.mosfet: fetlim/limvds leave steps up to this size unchanged; the bulk
#: diodes' knee (3 vt) and exp() cap.
FET_QUIET_STEP = 0.5
BULK_KNEE = 3.0
MAX_EXP_ARG = 709.0


@kernel
def drain_current(vgs, vds, vbs, beta, lam, vbi, gamma, phi):
    """Level-1 drain current of the mode (``vds >= 0``), see :func:`netdae.devices.mosfet.drain_current`.

    Returns
    -------
    (cdrain, gm, gds, gmbs, von, dvon) : tuple of float
    """
    sphi = math.sqrt(phi)
    if vbs <= 0.0:
        sarg = math.sqrt(phi - vbs)
        dsarg = -0.5 / sarg
    else:
        sarg_pos = sphi - vbs / (sphi + sphi)
        sarg = max(0.0, sarg_pos)
        dsarg = -0.5 / sphi if sarg_pos > 0.0 else 0.0
    von = vbi + gamma * sarg
    dvon = gamma * dsarg
    vgst = vgs - von
    betap = beta * (1.0 + lam * vds)
    cdrain = gm = gds = 0.0
    if vgst > 0.0:
        if vgst <= vds:
            cdrain = 0.5 * betap * vgst * vgst
            gm = betap * vgst
            gds = 0.5 * lam * beta * vgst * vgst
        else:
            cdrain = betap * vds * (vgst - 0.5 * vds)
            gm = betap * vds
            gds = betap * (vgst - vds) + lam * beta * vds * (vgst - 0.5 * vds)
    return cdrain, gm, gds, -gm * dvon, von, dvon


@kernel
def _bulk_function(a, phi):
    half = 0.5 * phi
    u1 = min(max(a, -phi), -half)
    u2 = min(max(a, -half), 0.0)
    f = min(a + phi, 0.0) + (half * half - u1 * u1) / (2.0 * phi) + u2 * (2.0 / 3.0 + u2 / (6.0 * phi))
    df = (u2 / 3.0 - u1) / phi + (1.0 / 6.0) - (2.0 / 3.0) * (1.0 if a > 0.0 else 0.0)
    return f, df


@kernel
def gate_charges(a, b, phi):
    """Charge-conserving intrinsic charges per Cox, see :func:`netdae.devices.mosfet.gate_charges`.

    Returns
    -------
    tuple of float
        ``qg, qs, qd, qb, dqg_da, dqg_db, dqs_da, dqs_db, dqd_da, dqd_db``.
    """
    A = max(a, 0.0)
    B = max(b, 0.0)
    A2, B2, AB = A * A, B * B, A * B
    s = A + B
    s = s + (1.0 if s == 0.0 else 0.0)
    s2 = s * s
    s3 = s2 * s
    two3, two15 = 2.0 / 3.0, 2.0 / 15.0
    p = two3 * (A2 + AB + B2) / s
    dp_da = two3 * (A2 + 2.0 * AB) / s2
    dp_db = two3 * (B2 + 2.0 * AB) / s2
    ns = A2 * (3.0 * A + 6.0 * B) + B2 * (4.0 * A + 2.0 * B)
    ps = two15 * ns / s2
    dps_da = two15 * ((9.0 * A2 + 12.0 * AB + 4.0 * B2) * s - 2.0 * ns) / s3
    dps_db = two15 * ((6.0 * A2 + 8.0 * AB + 6.0 * B2) * s - 2.0 * ns) / s3
    f, df = _bulk_function(a, phi)
    return p + f, -ps, ps - p, -f, dp_da + df, dp_db, -dps_da, -dps_db, dps_da - dp_da, dps_db - dp_db


@kernel
def _bulk_diode(v, isat, vt, gmin):
    ev = math.exp(min(MAX_EXP_ARG, v / vt))
    if v <= -BULK_KNEE * vt:
        return -isat + gmin * v, 0.0 + gmin
    return isat * (ev - 1.0) + gmin * v, isat * ev / vt + gmin


@kernel
def mosfet_limit(vgs_x, vds_x, vbs_x, vgs_o, vds_o, vbs_o, von, quiet, par, k):
    """ngspice's MOS1 limiting of instance ``k`` (type-normalised), see ``MosfetFamily.limit``.

    ``quiet``: the family's decision that no control moved more than
    :data:`FET_QUIET_STEP` (fetlim and limvds are then skipped).

    Returns
    -------
    (vgs, vds, vbs) : tuple of float
    """
    if quiet:
        vgs, vds = vgs_x, vds_x
    else:
        vgs, vds = fet_mode_limit(vgs_x, vds_x, vgs_o, vds_o, von)
    vt = par[k, P_VT]
    if vds >= 0.0:
        vbs, _ = pnjlim(vbs_x, vbs_o, vt, par[k, P_VCRIT_S])
    else:
        vbd, _ = pnjlim(vbs_x - vds_x, vbs_o - vds_o, vt, par[k, P_VCRIT_D])
        vbs = vbd + vds if (vbd != vbs_x - vds_x or vds != vds_x) else vbs_x
    return vgs, vds, vbs


@kernel
def _depletion_at(v, par, k, col):
    return depletion(v, par[k, col], par[k, col + 1], par[k, col + 2], par[k, col + 3], par[k, col + 4],
                     par[k, col + 5], par[k, col + 6], par[k, col + 7], par[k, col + 8])


@kernel
def _finite3(a, b, c):
    return math.isfinite(a) and math.isfinite(b) and math.isfinite(c)


@kernel
def _quiet(x, par, idx, vold):
    """The family's decision: no vgs, vds or vgd moved more than FET_QUIET_STEP since ``vold``."""
    for k in range(par.shape[0]):
        tp, si = par[k, P_TYPE], idx[k, I_SI]
        vgs = tp * (x[idx[k, I_G]] - x[si])
        vds = tp * (x[idx[k, I_DI]] - x[si])
        vgs_o, vds_o = vold[k, V_GS], vold[k, V_DS]
        if abs(vgs - vgs_o) > FET_QUIET_STEP or abs(vds - vds_o) > FET_QUIET_STEP \
                or abs((vgs - vds) - (vgs_o - vds_o)) > FET_QUIET_STEP:
            return False
    return True


@kernel
def eval_mosfet(x, mode, par, idx, vold, vnew, q, phi, dq, dphi, jacobian):
    """Add every MOSFET's currents, charges and derivatives (see :mod:`netdae.devices.kernels`)."""
    count = par.shape[0]
    start = mode == MODE_INITIAL and is_zero(x)
    quiet = mode == MODE_LIMIT and _quiet(x, par, idx, vold)
    limited = start
    for k in range(count):
        tp, si = par[k, P_TYPE], idx[k, I_SI]
        vgs_x = tp * (x[idx[k, I_G]] - x[si])
        vds_x = tp * (x[idx[k, I_DI]] - x[si])
        vbs_x = tp * (x[idx[k, I_B]] - x[si])
        if start:
            vgs, vds, vbs = vold[k, V_GS], vold[k, V_DS], vold[k, V_BS]
        elif mode == MODE_EVALUATE or mode == MODE_INITIAL:
            vgs, vds, vbs = vgs_x, vds_x, vbs_x
        else:
            vgs, vds, vbs = mosfet_limit(vgs_x, vds_x, vbs_x, vold[k, V_GS], vold[k, V_DS], vold[k, V_BS],
                                         vold[k, V_VON], quiet, par, k)
            limited = limited or vgs != vgs_x or vds != vds_x or vbs != vbs_x
        vnew[k, V_GS] = vgs
        vnew[k, V_DS] = vds
        vnew[k, V_BS] = vbs
    bad = -1
    for k in range(count):
        d, g, s, b, di, si = idx[k, I_D], idx[k, I_G], idx[k, I_S], idx[k, I_B], idx[k, I_DI], idx[k, I_SI]
        tp = par[k, P_TYPE]
        vgs, vds, vbs = vnew[k, V_GS], vnew[k, V_DS], vnew[k, V_BS]
        vgd, vbd = vgs - vds, vbs - vds
        fwd = vds >= 0.0
        cdrain, gm, gds, gmbs, von, dvon = drain_current(vgs if fwd else vgd, abs(vds), vbs if fwd else vbd,
                                                         par[k, P_BETA], par[k, P_LAMBDA], par[k, P_VBI],
                                                         par[k, P_GAMMA], par[k, P_PHI])
        vnew[k, V_VON] = von
        vt, gmin = par[k, P_VT], par[k, P_GMIN]
        ibs, gbs = _bulk_diode(vbs, par[k, P_ISAT_S], vt, gmin)
        ibd, gbd = _bulk_diode(vbd, par[k, P_ISAT_D], vt, gmin)
        gdr, gsr = par[k, P_GD], par[k, P_GS]
        i_d = (tp if fwd else -tp) * cdrain
        i_bs = tp * ibs
        i_bd = tp * ibd
        i_rd = gdr * (x[d] - x[di])
        i_rs = gsr * (x[s] - x[si])
        d0 = gm if fwd else -gm
        d1 = gds if fwd else gm + gds + gmbs
        d2 = gmbs if fwd else -gmbs
        ok = _finite3(i_d, i_bs, i_bd) and _finite3(i_rd, i_rs, d0) and _finite3(d1, d2, gbs) \
            and _finite3(gbd, gdr, gsr)
        charged = par[k, P_CHARGE_FAMILY] != 0.0
        # charges (q_g, q_d, q_b) and their derivatives c_jk to (vgs, vds, vbs)
        q0 = q1 = q2 = 0.0
        c00 = c01 = c02 = c10 = c11 = c12 = c20 = c21 = c22 = 0.0
        if charged:
            cgs, cgd, cgb = par[k, P_CGSO], par[k, P_CGDO], par[k, P_CGBO]
            c00, c01, c02 = cgs + cgd + cgb, -cgd, -cgb
            c10, c11, c12 = -cgd, cgd, 0.0 * cgd
            c20, c21, c22 = -cgb, 0.0 * cgb, cgb
            vgb = vgs - vbs
            q0 = cgs * vgs
            q0 += cgd * vgd + cgb * vgb
            q1 = -cgd * vgd
            q2 = -cgb * vgb
            for family_col, col_s, col_d in ((P_BOTTOM_FAMILY, P_DEP_BS, P_DEP_BD), (P_SIDE_FAMILY, P_DEP_SS, P_DEP_SD)):
                if par[k, family_col] != 0.0:
                    qbs, cbs = _depletion_at(vbs, par, k, col_s)
                    qbd, cbd = _depletion_at(vbd, par, k, col_d)
                    q1 -= qbd
                    q2 += qbd + qbs
                    c11 += cbd
                    c12 -= cbd
                    c21 -= cbd
                    c22 += cbd + cbs
            if par[k, P_COX_FAMILY] != 0.0:
                a = (vgs if fwd else vgd) - von
                bb = (vgd if fwd else vgs) - von
                cg, cs, cd, cb, g_a, g_b, s_a, s_b, d_a, d_b = gate_charges(a, bb, par[k, P_PHI])
                cox = par[k, P_COX]
                q0 += cox * cg
                q1 += cox * (cd if fwd else cs)
                q2 += cox * cb
                # derivatives of the (gate, device drain, device source) charges to a and b
                ga, dra, sra = g_a, (d_a if fwd else s_a), (s_a if fwd else d_a)
                gb, drb, srb = g_b, (d_b if fwd else s_b), (s_b if fwd else d_b)
                gab, drab, srab = ga + gb, dra + drb, sra + srb
                g3, dr3, sr3 = -gab * dvon, -drab * dvon, -srab * dvon
                e00, e01, e02 = cox * gab, cox * (-gb if fwd else -ga - g3), cox * g3
                e10, e11, e12 = cox * drab, cox * (-drb if fwd else -dra - dr3), cox * dr3
                e20, e21, e22 = cox * srab, cox * (-srb if fwd else -sra - sr3), cox * sr3
                c00 += e00
                c01 += e01
                c02 += e02
                c10 += e10
                c11 += e11
                c12 += e12
                c20 -= e00 + e10 + e20
                c21 -= e01 + e11 + e21
                c22 -= e02 + e12 + e22
            q0, q1, q2 = q0 * tp, q1 * tp, q2 * tp
            ok = ok and _finite3(q0, q1, q2) and _finite3(c00, c01, c02) and _finite3(c10, c11, c12) \
                and _finite3(c20, c21, c22)
        if bad < 0 and not ok:
            bad = k
        if limited:
            dgs = (x[g] - x[si]) - tp * vgs
            dds = (x[di] - x[si]) - tp * vds
            dbs = (x[b] - x[si]) - tp * vbs
            i_d = i_d + (d0 * dgs + d1 * dds + d2 * dbs)
            i_bs = i_bs + gbs * dbs
            i_bd = i_bd + (gbd * dbs - gbd * dds)
            q0 = q0 + (c00 * dgs + c01 * dds + c02 * dbs)
            q1 = q1 + (c10 * dgs + c11 * dds + c12 * dbs)
            q2 = q2 + (c20 * dgs + c21 * dds + c22 * dbs)
        add_current(phi, di, si, i_d)
        add_current(phi, b, si, i_bs)
        add_current(phi, b, di, i_bd)
        add_current(phi, d, di, i_rd)
        add_current(phi, s, si, i_rs)
        if charged:
            add_charge(q, g, si, q0)
            add_charge(q, di, si, q1)
            add_charge(q, b, si, q2)
        if jacobian:
            add_current_slope(dphi, idx, k, S_CUR, d0)
            add_current_slope(dphi, idx, k, S_CUR + 4, d1)
            add_current_slope(dphi, idx, k, S_CUR + 8, d2)
            add_current_slope(dphi, idx, k, S_CUR + 12, gbs)
            add_current_slope(dphi, idx, k, S_CUR + 16, gbd)
            add_current_slope(dphi, idx, k, S_CUR + 20, -gbd)
            add_current_slope(dphi, idx, k, S_CUR + 24, gdr)
            add_current_slope(dphi, idx, k, S_CUR + 28, gsr)
            if charged:
                add_charge_slope(dq, idx, k, S_CHG, c00)
                add_charge_slope(dq, idx, k, S_CHG + 4, c01)
                add_charge_slope(dq, idx, k, S_CHG + 8, c02)
                add_charge_slope(dq, idx, k, S_CHG + 12, c10)
                add_charge_slope(dq, idx, k, S_CHG + 16, c11)
                add_charge_slope(dq, idx, k, S_CHG + 20, c12)
                add_charge_slope(dq, idx, k, S_CHG + 24, c20)
                add_charge_slope(dq, idx, k, S_CHG + 28, c21)
                add_charge_slope(dq, idx, k, S_CHG + 32, c22)
    flags = (FLAG_LIMITED if limited else 0) | (FLAG_NONFINITE if bad >= 0 else 0)
    return flags, bad
