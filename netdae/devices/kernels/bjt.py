"""The Gummel-Poon BJT family as one compiled kernel (the twin of :class:`netdae.devices.bjt.BjtFamily`).

Layout (packed by ``BjtFamily.compiled``)
-----------------------------------------
``par`` columns ``P_*``: type and multiplier factors, the four junctions'
saturation currents, ``N vt`` and knees, the Early and roll-off factors
(``P_ROLLOFF`` selects the family's form of ``qb``: none, square root, the
NKF family's square root, NKF power), BF, BR, the series conductances and
the base resistance, the limiting ``vt`` and ``vcrit``, the charge
parameters, and four blocks of nine depletion coefficients (be, bc, bx,
substrate). The ``*_FAMILY`` columns carry the numpy family's family-wide
decisions (charges present, TF present, base resistance varying) so that
both evaluate the same expressions.
``idx``: the terminals ``I_C, I_B, I_E, I_S``, the internal nodes
``I_CI, I_BI, I_EI`` and the substrate's connection ``I_SC``; then four
slots per current dependence from ``S_CUR`` and per charge dependence from
``S_CHG``, in the order of ``netdae.devices.bjt._CURRENT_DEPS`` and
``_CHARGE_DEPS``.
``vold``/``vnew``: ``V_BE, V_BC, V_SUB``, type-normalised.
"""

from __future__ import annotations

import math

from ...dae.compiled import kernel

from . import FLAG_LIMITED, FLAG_NONFINITE, MODE_EVALUATE, MODE_INITIAL
from .junction import depletion, ideal_junction, pnjlim
from .scatter import add_charge, add_charge_slope, add_current, add_current_slope, is_zero

__all__ = ["eval_bjt", "transport", "base_resistance"]

(P_TYPE, P_TTYPE, P_M, P_TM, P_TTM_GMIN, P_GMIN,
 P_IS_BE, P_VTF, P_KNEE_F, P_ISE, P_VTE, P_KNEE_E, P_IS_BC, P_VTR, P_KNEE_R, P_ISC, P_VTC, P_KNEE_C,
 P_INV_VAF, P_INV_VAR, P_INV_IKF, P_INV_IKR, P_NKF, P_ROLLOFF, P_BF, P_BR,
 P_GC, P_GE, P_GX0, P_RB, P_RBM, P_IRB, P_RB_FAMILY,
 P_VT, P_VCRIT, P_VCRIT_SUB,
 P_CHARGE_FAMILY, P_TF_FAMILY, P_TF, P_TR, P_XTF, P_OVTF, P_ITF, P_QSIGN, P_QSIGN_SUB,
 P_DEP_BE) = range(46)
P_DEP_BC = P_DEP_BE + 9
P_DEP_BX = P_DEP_BC + 9
P_DEP_SUB = P_DEP_BX + 9
N_PAR = P_DEP_SUB + 9
#: P_ROLLOFF values: qb = q1 (no IKF/IKR in the family), the square-root form, the square
#: root as the NKF family writes it, the NKF power.
ROLLOFF_NONE, ROLLOFF_SQRT, ROLLOFF_SQRT_NKF, ROLLOFF_POWER = 0, 1, 2, 3
I_C, I_B, I_E, I_S, I_CI, I_BI, I_EI, I_SC = range(8)
#: Current dependences (ic, vbe) (ic, vbc) (ib, vbe) (ib, vbc) (isub, vsub) (irb, vrb) (irb, vbe)
#: (irb, vbc) (irc, vrc) (ire, vre); charge dependences (qbe, vbe) (qbe, vbc) (qbc, vbc) (qbx, vbx)
#: (qsub, vsub): four slots each.
S_CUR = 8
N_CUR_DEPS = 10
S_CHG = S_CUR + 4 * N_CUR_DEPS
N_CHG_DEPS = 5
N_IDX = S_CHG + 4 * N_CHG_DEPS
V_BE, V_BC, V_SUB = 0, 1, 2
N_STATE = 3
#: As netdae.devices.bjt: IRB formula constants (144/pi^2, 24/pi^2) and its floor on ib/IRB.
IRB_C1 = 14.59025
IRB_C2 = 2.4317
IRB_FLOOR = 1e-9


@kernel
def transport(vbe, vbc, par, k):
    """Gummel-Poon currents of instance ``k`` at type-normalised (vbe, vbc).

    Returns
    -------
    tuple of float
        ``ic, ib, dic_dvbe, dic_dvbc, dib_dvbe, dib_dvbc, cbe, gbe, cbc, gbc, qb,
        dqbdve, dqbdvc`` (see ``BjtFamily.transport``).
    """
    gmin = par[k, P_GMIN]
    cbe, gbe = ideal_junction(vbe, par[k, P_IS_BE], par[k, P_VTF], par[k, P_KNEE_F])
    cben, gben = ideal_junction(vbe, par[k, P_ISE], par[k, P_VTE], par[k, P_KNEE_E])
    cbc, gbc = ideal_junction(vbc, par[k, P_IS_BC], par[k, P_VTR], par[k, P_KNEE_R])
    cbcn, gbcn = ideal_junction(vbc, par[k, P_ISC], par[k, P_VTC], par[k, P_KNEE_C])
    cben, gben = cben + gmin * vbe, gben + gmin
    cbcn, gbcn = cbcn + gmin * vbc, gbcn + gmin
    inv_vaf, inv_var = par[k, P_INV_VAF], par[k, P_INV_VAR]
    inv_ikf, inv_ikr = par[k, P_INV_IKF], par[k, P_INV_IKR]
    q1 = 1.0 / (1.0 - inv_vaf * vbc - inv_var * vbe)
    rolloff = par[k, P_ROLLOFF]
    sq, dsq = 1.0, 0.0
    if rolloff != ROLLOFF_NONE:
        arg = max(0.0, 1.0 + 4.0 * (inv_ikf * cbe + inv_ikr * cbc))
        if arg != 0.0:
            if rolloff == ROLLOFF_SQRT:
                sq = math.sqrt(arg)
                dsq = 0.5 / sq
            elif rolloff == ROLLOFF_SQRT_NKF:
                sq = math.sqrt(arg)
                dsq = 0.5 * sq / arg
            else:
                nkf = par[k, P_NKF]
                sq = arg ** nkf
                dsq = nkf * sq / arg
    qb = q1 * (1.0 + sq) / 2.0
    dqbdve = q1 * (qb * inv_var + 2.0 * dsq * inv_ikf * gbe)
    dqbdvc = q1 * (qb * inv_vaf + 2.0 * dsq * inv_ikr * gbc)
    ict = (cbe - cbc) / qb
    go = (gbc + (cbe - cbc) * dqbdvc / qb) / qb
    gm = (gbe - (cbe - cbc) * dqbdve / qb) / qb - go
    bf, br = par[k, P_BF], par[k, P_BR]
    gpi = gbe / bf + gben
    gmu = gbc / br + gbcn
    ic = ict - cbc / br - cbcn
    ib = cbe / bf + cben + cbc / br + cbcn
    return ic, ib, gm + go, -go - gmu, gpi, gmu, cbe, gbe, cbc, gbc, qb, dqbdve, dqbdvc


@kernel
def base_resistance(ib, dib_dvbe, dib_dvbc, qb, dqbdve, dqbdvc, par, k):
    """Base conductance ``gx`` of instance ``k`` and its derivatives to (vbe, vbc) (``BjtFamily.base_resistance``)."""
    rbm = par[k, P_RBM]
    rbpi = par[k, P_RB] - rbm
    irb = par[k, P_IRB]
    if irb != 0.0:
        ratio = ib / irb
        a = max(ratio, IRB_FLOOR)
        s = math.sqrt(1.0 + IRB_C1 * a)
        sa = math.sqrt(a)
        z = (s - 1.0) / IRB_C2 / sa
        tz = math.tan(z)
        h = (tz - z) / (z * tz * tz)
        dh = (tz * tz * z * tz * tz - (tz - z) * (tz * tz + 2.0 * z * tz * (1.0 + tz * tz))) / (z * z * tz ** 4.0)
        dz = (IRB_C1 * sa / (2.0 * s) - (s - 1.0) / (2.0 * sa)) / (IRB_C2 * a)
        dr_dib = 0.0 if ratio < IRB_FLOOR else 3.0 * rbpi * dh * dz / irb
        rbb = rbm + 3.0 * rbpi * h
        drbb_dve = dr_dib * dib_dvbe
        drbb_dvc = dr_dib * dib_dvbc
    else:
        rbb = rbm + rbpi / qb
        drbb_dve = -rbpi / (qb * qb) * dqbdve
        drbb_dvc = -rbpi / (qb * qb) * dqbdvc
    gx = 1.0 / rbb if rbb != 0.0 else 0.0
    return gx, -gx * gx * drbb_dve, -gx * gx * drbb_dvc


@kernel
def _depletion_at(v, par, k, col):
    return depletion(v, par[k, col], par[k, col + 1], par[k, col + 2], par[k, col + 3], par[k, col + 4],
                     par[k, col + 5], par[k, col + 6], par[k, col + 7], par[k, col + 8])


@kernel
def _finite(a, b, c, d, e, f):
    return math.isfinite(a) and math.isfinite(b) and math.isfinite(c) and math.isfinite(d) \
        and math.isfinite(e) and math.isfinite(f)


@kernel
def eval_bjt(x, mode, par, idx, vold, vnew, q, phi, dq, dphi, jacobian):
    """Add every BJT's currents, charges and derivatives (see :mod:`netdae.devices.kernels`)."""
    count = par.shape[0]
    start = mode == MODE_INITIAL and is_zero(x)
    limited = start
    for k in range(count):
        tp, ttp = par[k, P_TYPE], par[k, P_TTYPE]
        bi = idx[k, I_BI]
        vbe_x = tp * (x[bi] - x[idx[k, I_EI]])
        vbc_x = tp * (x[bi] - x[idx[k, I_CI]])
        vsub_x = ttp * (x[idx[k, I_S]] - x[idx[k, I_SC]])
        if start:
            vbe, vbc, vsub = vold[k, V_BE], vold[k, V_BC], vold[k, V_SUB]
        elif mode == MODE_EVALUATE or mode == MODE_INITIAL:
            vbe, vbc, vsub = vbe_x, vbc_x, vsub_x
        else:
            vt, vcrit = par[k, P_VT], par[k, P_VCRIT]
            vbe, c1 = pnjlim(vbe_x, vold[k, V_BE], vt, vcrit)
            vbc, c2 = pnjlim(vbc_x, vold[k, V_BC], vt, vcrit)
            vsub, c3 = pnjlim(vsub_x, vold[k, V_SUB], vt, par[k, P_VCRIT_SUB])
            limited = limited or c1 or c2 or c3
        vnew[k, V_BE] = vbe
        vnew[k, V_BC] = vbc
        vnew[k, V_SUB] = vsub
    bad = -1
    for k in range(count):
        c, b, e, s = idx[k, I_C], idx[k, I_B], idx[k, I_E], idx[k, I_S]
        ci, bi, ei, sc = idx[k, I_CI], idx[k, I_BI], idx[k, I_EI], idx[k, I_SC]
        tp, ttp = par[k, P_TYPE], par[k, P_TTYPE]
        m, tm = par[k, P_M], par[k, P_TM]
        vbe, vbc, vsub = vnew[k, V_BE], vnew[k, V_BC], vnew[k, V_SUB]
        ic, ib, dic_dvbe, dic_dvbc, dib_dvbe, dib_dvbc, cbe, gbe, cbc, gbc, qb, dqbdve, dqbdvc = \
            transport(vbe, vbc, par, k)
        v_rb = x[b] - x[bi]
        gc, ge = par[k, P_GC], par[k, P_GE]
        i_c = tm * ic
        i_b = tm * ib
        i_sub = par[k, P_TTM_GMIN] * vsub
        i_rc = gc * (x[c] - x[ci])
        i_re = ge * (x[e] - x[ei])
        d0, d1, d2, d3 = m * dic_dvbe, m * dic_dvbc, m * dib_dvbe, m * dib_dvbc
        d4 = m * par[k, P_GMIN]
        d5 = par[k, P_GX0]
        d6, d7 = 0.0, 0.0
        if par[k, P_RB_FAMILY] != 0.0:
            gx, dgx_dve, dgx_dvc = base_resistance(ib, dib_dvbe, dib_dvbc, qb, dqbdve, dqbdvc, par, k)
            d5 = m * gx
            d6 = tm * v_rb * dgx_dve
            d7 = tm * v_rb * dgx_dvc
        i_rb = d5 * v_rb
        ok = _finite(i_c, i_b, i_sub, i_rb, i_rc, i_re) and _finite(d0, d1, d2, d3, d4, d5) \
            and _finite(d6, d7, gc, ge, 0.0, 0.0)
        charged = par[k, P_CHARGE_FAMILY] != 0.0
        q_be = q_bc = q_bx = q_sub = 0.0
        c_be = c_bebc = c_bc = c_bx = c_sub = 0.0
        if charged:
            q_be, c_be = _depletion_at(vbe, par, k, P_DEP_BE)
            q_bc, c_bc = _depletion_at(vbc, par, k, P_DEP_BC)
            q_bx, c_bx = _depletion_at(tp * (x[b] - x[ci]), par, k, P_DEP_BX)
            q_sub, c_sub = _depletion_at(vsub, par, k, P_DEP_SUB)
            tr = par[k, P_TR]
            q_bc += tr * cbc
            c_bc += tr * gbc
            if par[k, P_TF_FAMILY] != 0.0:
                tf, itf, ovtf = par[k, P_TF], par[k, P_ITF], par[k, P_OVTF]
                argtf = par[k, P_XTF] * math.exp(vbc * ovtf)
                arg2 = argtf
                if itf != 0.0:
                    temp = cbe / (cbe + itf)
                    argtf = argtf * temp * temp
                    arg2 = argtf * (3.0 - temp - temp)
                arg3 = cbe * argtf * ovtf
                cbe_mod = cbe * (1.0 + argtf) / qb
                gbe_mod = (gbe * (1.0 + arg2) - cbe_mod * dqbdve) / qb
                geqcb = tf * (arg3 - cbe_mod * dqbdvc) / qb
                if tf != 0.0 and vbe > 0.0:
                    q_be += tf * cbe_mod
                    c_be += tf * gbe_mod
                    c_bebc = geqcb
                else:
                    q_be += tf * cbe
                    c_be += tf * gbe
            qs, qs_sub = par[k, P_QSIGN], par[k, P_QSIGN_SUB]
            q_be, q_bc, q_bx, q_sub = q_be * qs, q_bc * qs, q_bx * qs, q_sub * qs_sub
            c_be, c_bebc, c_bc, c_bx, c_sub = c_be * m, c_bebc * m, c_bc * m, c_bx * m, c_sub * m
            ok = ok and _finite(q_be, q_bc, q_bx, q_sub, c_be, c_bebc) and _finite(c_bc, c_bx, c_sub, 0.0, 0.0, 0.0)
        if bad < 0 and not ok:
            bad = k
        if limited:
            dbe = (x[bi] - x[ei]) - tp * vbe
            dbc = (x[bi] - x[ci]) - tp * vbc
            dsub = (x[s] - x[sc]) - ttp * vsub
            i_c = i_c + (d0 * dbe + d1 * dbc)
            i_b = i_b + (d2 * dbe + d3 * dbc)
            i_sub = i_sub + d4 * dsub
            i_rb = i_rb + (d6 * dbe + d7 * dbc)
            q_be = q_be + (c_be * dbe + c_bebc * dbc)
            q_bc = q_bc + c_bc * dbc
            q_sub = q_sub + c_sub * dsub
        add_current(phi, ci, ei, i_c)
        add_current(phi, bi, ei, i_b)
        add_current(phi, s, sc, i_sub)
        add_current(phi, b, bi, i_rb)
        add_current(phi, c, ci, i_rc)
        add_current(phi, e, ei, i_re)
        if charged:
            add_charge(q, bi, ei, q_be)
            add_charge(q, bi, ci, q_bc)
            add_charge(q, b, ci, q_bx)
            add_charge(q, s, sc, q_sub)
        if jacobian:
            add_current_slope(dphi, idx, k, S_CUR, d0)
            add_current_slope(dphi, idx, k, S_CUR + 4, d1)
            add_current_slope(dphi, idx, k, S_CUR + 8, d2)
            add_current_slope(dphi, idx, k, S_CUR + 12, d3)
            add_current_slope(dphi, idx, k, S_CUR + 16, d4)
            add_current_slope(dphi, idx, k, S_CUR + 20, d5)
            add_current_slope(dphi, idx, k, S_CUR + 24, d6)
            add_current_slope(dphi, idx, k, S_CUR + 28, d7)
            add_current_slope(dphi, idx, k, S_CUR + 32, gc)
            add_current_slope(dphi, idx, k, S_CUR + 36, ge)
            if charged:
                add_charge_slope(dq, idx, k, S_CHG, c_be)
                add_charge_slope(dq, idx, k, S_CHG + 4, c_bebc)
                add_charge_slope(dq, idx, k, S_CHG + 8, c_bc)
                add_charge_slope(dq, idx, k, S_CHG + 12, c_bx)
                add_charge_slope(dq, idx, k, S_CHG + 16, c_sub)
    flags = (FLAG_LIMITED if limited else 0) | (FLAG_NONFINITE if bad >= 0 else 0)
    return flags, bad
