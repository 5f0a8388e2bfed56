"""The MESA MESFET (levels 2, 3, 4) as one compiled kernel (the twin of :class:`netdae.devices.mesa.MesaFamily`).

The same equations as the family (``mesa2_channel``, ``mesa3_channel``, ``mesa4_channel`` chosen by the
instance's level, ``gate_diode``, the gate charges' quadrature), in
complex arithmetic for the complex-step derivatives, one instance at a time.

Layout (packed by ``MesaFamily.compiled``)
------------------------------------------
``par`` columns ``P_*``: the channel's constants (:attr:`MesaFamily.channel`, in :data:`CHANNEL_KEYS`
order), then the multiplier, the gate diodes' constants, AG, m GMIN, the limiting constants and the
five series conductances (``m`` included).
``idx``: ``I_D, I_G, I_S`` and the internal nodes ``I_DP, I_SP, I_GP, I_SPP, I_DPP`` (drain', source',
gate', ``#gs``, ``#gd``); four slots per current dependence from ``S_CUR`` and per charge dependence
from ``S_CHG``, in the order of ``netdae.devices.mesa._CURRENT_DEPS`` and ``_CHARGE_DEPS``.
``vold``/``vnew``: ``V_GS, V_GD``.
"""

from __future__ import annotations

import cmath
import math

import numpy as np

from ...dae.compiled import kernel
from ..mesa import EPS_GAAS, NS_FLOOR, OFF_DEPTH, QUAD_ABSCISSAE, QUAD_PANELS, QUAD_WEIGHTS, STEP

from . import FLAG_LIMITED, FLAG_NONFINITE, MODE_EVALUATE, MODE_INITIAL
from .junction import gate_junction_limit
from .scatter import add_charge, add_charge_slope, add_current, add_current_slope, is_zero

__all__ = ["eval_mesa", "CHANNEL_KEYS", "mesa_dc", "mesa_charges"]

#: The channel's constants in ``par``'s first columns (level 2's, then those of levels 3 and 4).
CHANNEL_KEYS = ("vt", "eta", "vpo", "vto", "vsigmat", "vsigma", "sigma0", "mu", "theta", "vs", "l", "beta",
                "delta2", "nd", "d", "n0", "gchi0", "rt", "rsi", "tc", "isatb0", "mc", "m", "alpha", "lambda",
                "wl_eps_d", "cf", "level", "beta0", "vpod", "vpou", "ndelta", "th", "ndu", "du", "nsb0", "wl",
                "nmax", "gamma", "imax", "rsi0", "cgca", "cgcb")
(P_VT, P_ETA, P_VPO, P_VTO, P_VSIGMAT, P_VSIGMA, P_SIGMA0, P_MU, P_THETA, P_VS, P_L, P_BETA, P_DELTA2, P_ND,
 P_D, P_N0, P_GCHI0, P_RT, P_RSI, P_TC, P_ISATB0, P_MC, P_M, P_ALPHA, P_LAMBDA, P_WLEPSD, P_CF, P_LEVEL, P_BETA0,
 P_VPOD, P_VPOU, P_NDELTA, P_TH, P_NDU, P_DU, P_NSB0, P_WL, P_NMAX, P_GAMMA, P_IMAX, P_RSI0, P_CGCA,
 P_CGCB) = range(43)
(P_MULT, P_CSATFS, P_CSATFD, P_GGRWL, P_VTES, P_VTED, P_VTS, P_VTD, P_DEL, P_AG, P_GMIN, P_VCRITS, P_VCRITD,
 P_GD, P_GS, P_GG, P_GI, P_GF) = range(43, 61)
N_PAR = 61
I_D, I_G, I_S, I_DP, I_SP, I_GP, I_SPP, I_DPP = range(8)
S_CUR = 8
N_CUR_DEPS = 9
S_CHG = S_CUR + 4 * N_CUR_DEPS
N_CHG_DEPS = 6
N_IDX = S_CHG + 4 * N_CHG_DEPS
V_GS, V_GD = 0, 1
N_STATE = 2
_ABS = np.ascontiguousarray(QUAD_ABSCISSAE)
_WTS = np.ascontiguousarray(QUAD_WEIGHTS)


@kernel
def _mode2(vg, w, par, k):
    """Level 2's current and capacitances of the mode (``netdae.devices.mesa.mesa2_channel``), complex."""
    vt = par[k, P_VT]
    etavth = par[k, P_ETA] * vt
    vpo = par[k, P_VPO]
    cf = par[k, P_CF]
    vgt0 = vg - par[k, P_VTO]
    s = cmath.exp((vgt0 - par[k, P_VSIGMAT]) / par[k, P_VSIGMA])
    sigma = par[k, P_SIGMA0] / (1.0 + s)
    vgt = vgt0 + sigma * w
    mu = par[k, P_MU] + par[k, P_THETA] * vgt
    vl = par[k, P_VS] / mu * par[k, P_L]
    beta = par[k, P_BETA] / (vpo + 3.0 * vl)
    u = vgt / vt - 1.0
    vgte = 0.5 * vt * (2.0 + u + cmath.sqrt(par[k, P_DELTA2] + u * u))
    a = 2.0 * beta * vgte
    b = cmath.exp(-vgt / etavth)
    sqrt1 = 0.0j if vgte.real > vpo else cmath.sqrt(1.0 - vgte / vpo)
    ns = 1.0 / (1.0 / (par[k, P_ND] * par[k, P_D] * (1.0 - sqrt1)) + b / par[k, P_N0])
    if not ns.real >= NS_FLOOR:
        return 0.0j * vg, cf + 0.0j * vg, cf + 0.0j * vg
    gchi = par[k, P_GCHI0] * mu * ns
    gch = gchi / (1.0 + gchi * par[k, P_RT])
    rsi = par[k, P_RSI]
    dd = 1.0 + a * rsi + cmath.sqrt(1.0 + 2.0 * a * rsi)
    e = 1.0 + par[k, P_TC] * vgte
    isata = a * vgte / (dd * e)
    isatb = par[k, P_ISATB0] * mu * cmath.exp(vgt / etavth)
    isat = isata * isatb / (isata + isatb)
    vsate = isat / gch
    mc = par[k, P_MC]
    mm = par[k, P_M] + par[k, P_ALPHA] * vgte
    if w.real > 0.0:
        ratio = w / vsate
        vdse = w * (1.0 + ratio ** mc) ** (-1.0 / mc)
        g = ratio ** mm
    else:
        vdse = 0.0 * w
        g = 0.0 * w
    h = (1.0 + g) ** (1.0 / mm)
    i = gch * w / h * (1.0 + par[k, P_LAMBDA] * w)
    tq = 0.0j if vgt.real > vpo else cmath.sqrt(1.0 - vgt / vpo)
    cgc = par[k, P_WLEPSD] / (tq + b)
    den = 2.0 * vsate - vdse
    cs = (vsate - vdse) / den
    cd = vsate / den
    return i, cf + 2.0 / 3.0 * cgc * (1.0 - cs * cs), cf + 2.0 / 3.0 * cgc * (1.0 - cd * cd)


@kernel
def _bias(vg, w, par, k):
    """The mode's ``vgt`` and ``ETA vt`` (``netdae.devices.mesa._mode_bias``), complex."""
    vgt0 = vg - par[k, P_VTO]
    s = cmath.exp((vgt0 - par[k, P_VSIGMAT]) / par[k, P_VSIGMA])
    return vgt0 + par[k, P_SIGMA0] / (1.0 + s) * w, par[k, P_ETA] * par[k, P_VT]


@kernel
def _saturation(gch, isat, w, par, k, cgc):
    """Current and capacitances from ``gch``, ``isat`` and ``cgc`` (``netdae.devices.mesa._saturation``)."""
    vsate = isat / gch
    mc = par[k, P_MC]
    mm = par[k, P_M]
    if w.real > 0.0:
        ratio = w / vsate
        vdse = w * (1.0 + ratio ** mc) ** (-1.0 / mc)
        g = ratio ** mm
    else:
        vdse = 0.0 * w
        g = 0.0 * w
    i = gch * w / (1.0 + g) ** (1.0 / mm) * (1.0 + par[k, P_LAMBDA] * w)
    den = 2.0 * vsate - vdse
    cs = (vsate - vdse) / den
    cd = vsate / den
    cf = par[k, P_CF]
    return i, cf + 2.0 / 3.0 * cgc * (1.0 - cs * cs), cf + 2.0 / 3.0 * cgc * (1.0 - cd * cd)


@kernel
def _mode3(vg, w, par, k):
    """Level 3's current and capacitances of the mode (``netdae.devices.mesa.mesa3_channel``), complex."""
    vt = par[k, P_VT]
    vgt, etavth = _bias(vg, w, par, k)
    t = vgt / vt - 1.0
    vgte = 0.5 * vt * (2.0 + t + cmath.sqrt(par[k, P_DELTA2] + t * t))
    a = 2.0 * par[k, P_BETA0] * vgte
    vpo, vpod, vpou = par[k, P_VPO], par[k, P_VPOD], par[k, P_VPOU]
    ndelta, th, ndu, du = par[k, P_NDELTA], par[k, P_TH], par[k, P_NDU], par[k, P_DU]
    if vgt.real > vpod:
        if vgte.real > vpo:
            nsa = ndelta * th + ndu * du + 0.0 * vgte
            ca = EPS_GAAS / du + 0.0 * vgte
        else:
            r = cmath.sqrt((vpo - vgte) / vpou)
            nsa = ndelta * th + ndu * du * (1.0 - r)
            ca = EPS_GAAS / du / r
    else:
        if (vpod - vgte).real < 0.0:
            nsa = ndelta * th * (1.0 - du / th) + 0.0 * vgte
            ca = EPS_GAAS / du + 0.0 * vgte
        else:
            r = cmath.sqrt(1.0 + ndu / ndelta * (vpod - vgte) / vpou)
            nsa = ndelta * th * (1.0 - du / th * (r - 1.0))
            ca = EPS_GAAS / du / r
    b = cmath.exp(vgt / etavth)
    cb = EPS_GAAS / (du + th) * b
    nsb = par[k, P_NSB0] * b
    ns = nsa * nsb / (nsa + nsb)
    cf = par[k, P_CF]
    if not ns.real >= NS_FLOOR:
        return 0.0j * vg, cf + 0.0j * vg, cf + 0.0j * vg
    gchi = par[k, P_GCHI0] * par[k, P_MU] * ns
    gch = gchi / (1.0 + gchi * par[k, P_RT])
    rsi = par[k, P_RSI]
    dd = 1.0 + a * rsi + cmath.sqrt(1.0 + 2.0 * a * rsi)
    e = 1.0 + par[k, P_TC] * vgte
    isata = a * vgte / (dd * e)
    isatb = par[k, P_ISATB0] * b
    isat = isata * isatb / (isata + isatb)
    cgc = par[k, P_WL] * ca * cb / (ca + cb)
    return _saturation(gch, isat, w, par, k, cgc)


@kernel
def _mode4(vg, w, par, k):
    """Level 4's current and capacitances of the mode (``netdae.devices.mesa.mesa4_channel``), complex."""
    vt = par[k, P_VT]
    vgt, etavth = _bias(vg, w, par, k)
    mu = par[k, P_MU]
    vl = par[k, P_VS] / mu * par[k, P_L]
    u = 0.5 * vgt / vt - 1.0
    vgte = vt * (2.0 + u + cmath.sqrt(par[k, P_DELTA2] + u * u))
    b = cmath.exp(vgt / etavth)
    nsm = 2.0 * par[k, P_N0] * cmath.log(1.0 + 0.5 * b)
    cf = par[k, P_CF]
    if not nsm.real >= NS_FLOOR:
        return 0.0j * vg, cf + 0.0j * vg, cf + 0.0j * vg
    gamma = par[k, P_GAMMA]
    c = (nsm / par[k, P_NMAX]) ** gamma
    ns = nsm / (1.0 + c) ** (1.0 / gamma)
    gchi = par[k, P_GCHI0] * mu * ns
    gch = gchi / (1.0 + gchi * par[k, P_RT])
    gchim = par[k, P_GCHI0] * mu * nsm
    h = cmath.sqrt(1.0 + 2.0 * gchim * par[k, P_RSI0] + vgte * vgte / (vl * vl))
    isatm = gchim * vgte / (1.0 + gchim * par[k, P_RSI] + h)
    isat = isatm / (1.0 + (isatm / par[k, P_IMAX]) ** gamma) ** (1.0 / gamma)
    cgcm = 1.0 / (par[k, P_CGCA] + par[k, P_CGCB] * cmath.exp(-vgt / etavth))
    cgc = par[k, P_WL] * cgcm / (1.0 + c) ** (1.0 + 1.0 / gamma)
    return _saturation(gch, isat, w, par, k, cgc)


@kernel
def _mode(vg, w, par, k):
    """The mode's current and capacitances at the instance's level (``netdae.devices.mesa.mesa_channel``)."""
    level = par[k, P_LEVEL]
    if level == 3.0:
        return _mode3(vg, w, par, k)
    if level == 4.0:
        return _mode4(vg, w, par, k)
    return _mode2(vg, w, par, k)


@kernel
def _channel(vgs, vgd, par, k):
    """Current d'->s' (no AG) and the capacitances at (vgs, vgd), complex (``MesaFamily._channel``)."""
    vds = vgs - vgd
    if vds.real < 0.0:
        i, cgs, cgd = _mode(vgd, -vds, par, k)
        return -i, cgd, cgs
    return _mode(vgs, vds, par, k)


@kernel
def _diode(v, csat, ggrwl, vte, vtn, dl, gmin):
    return csat * (cmath.exp(v / vte) - 1.0) + ggrwl * v * cmath.exp(-dl * v / vtn) + gmin * v


@kernel
def _charges(vgs, vgd, vgspp, vgdpp, par, k):
    """The gate charges of one device (``MesaFamily._gate_charges``), complex."""
    vds = vgs - vgd
    eta_vt = par[k, P_ETA] * par[k, P_VT]
    # complex throughout: the start moves with the bias in the complex step as in real arithmetic
    low = par[k, P_VTO] - OFF_DEPTH * eta_vt - abs(par[k, P_SIGMA0]) * (-vds if vds.real < 0.0 else vds)
    cf = par[k, P_CF]
    qgs = 0.0j
    qgd = 0.0j
    for branch in range(2):
        if branch == 0:
            far, here, ahead = vgspp, vgs, -vds
        else:
            far, here, ahead = vgdpp, vgd, vds
        shift = here - far
        below = low - shift - (ahead if ahead.real > 0.0 else 0.0j)
        start = below if below.real < far.real else far
        width = (far - start) / QUAD_PANELS
        acc = 0.0j
        for j in range(_ABS.size):
            u = start + width * _ABS[j]
            gs_u = u + shift if branch == 0 else u + shift + vds
            _, cgs, cgd = _channel(gs_u, gs_u - vds, par, k)
            acc += ((cgs if branch == 0 else cgd) - cf) * _WTS[j]
        if branch == 0:
            qgs = cf * far + width * acc
        else:
            qgd = cf * far + width * acc
    return qgs, qgd


@kernel
def mesa_dc(vgs, vgd, par, k):
    """Channel current d'->s' (AG included), gate diodes and their derivatives at (vgs, vgd), one device.

    Returns
    -------
    (ich, ich_vgs, ich_vgd, igs, ggs, igd, ggd) : tuple of float
    """
    h = STEP
    i0, _, _ = _channel(vgs + 0j, vgd + 0j, par, k)
    i1, _, _ = _channel(vgs + 1j * h, vgd + 0j, par, k)
    i2, _, _ = _channel(vgs + 0j, vgd + 1j * h, par, k)
    gmin = par[k, P_GMIN]
    igs = _diode(vgs + 0j, par[k, P_CSATFS], par[k, P_GGRWL], par[k, P_VTES], par[k, P_VTS], par[k, P_DEL], gmin)
    igd = _diode(vgd + 0j, par[k, P_CSATFD], par[k, P_GGRWL], par[k, P_VTED], par[k, P_VTD], par[k, P_DEL], gmin)
    ggs = _diode(vgs + 1j * h, par[k, P_CSATFS], par[k, P_GGRWL], par[k, P_VTES], par[k, P_VTS], par[k, P_DEL],
                 gmin).imag / h
    ggd = _diode(vgd + 1j * h, par[k, P_CSATFD], par[k, P_GGRWL], par[k, P_VTED], par[k, P_VTD], par[k, P_DEL],
                 gmin).imag / h
    ag = par[k, P_AG]
    return (i0.real - ag * (igs.real - igd.real), i1.imag / h - ag * ggs, i2.imag / h + ag * ggd,
            igs.real, ggs, igd.real, ggd)


@kernel
def mesa_charges(vgs, vgd, vgspp, vgdpp, par, k):
    """The gate charges and their derivatives: (qgs, d/dvgs'', d/dvgs, d/dvgd, qgd, d/dvgd'', d/dvgs, d/dvgd)."""
    h = STEP
    qs, qd = _charges(vgs + 0j, vgd + 0j, vgspp + 0j, vgdpp + 0j, par, k)
    s0, d0 = _charges(vgs + 1j * h, vgd + 0j, vgspp + 0j, vgdpp + 0j, par, k)
    s1, d1 = _charges(vgs + 0j, vgd + 1j * h, vgspp + 0j, vgdpp + 0j, par, k)
    s2, _ = _charges(vgs + 0j, vgd + 0j, vgspp + 1j * h, vgdpp + 0j, par, k)
    _, d3 = _charges(vgs + 0j, vgd + 0j, vgspp + 0j, vgdpp + 1j * h, par, k)
    return (qs.real, s2.imag / h, s0.imag / h, s1.imag / h, qd.real, d3.imag / h, d0.imag / h, d1.imag / h)


@kernel
def _mesa_limit(vgs_x, vgd_x, vgs_o, vgd_o, par, k):
    """ngspice's MESA limiting (``MesaFamily.limit``): each gate junction with its own ``N vt`` and ``vcrit``."""
    return gate_junction_limit(vgs_x, vgd_x, vgs_o, vgd_o, par[k, P_VTES], par[k, P_VCRITS], par[k, P_VTED],
                               par[k, P_VCRITD], par[k, P_VTO])


@kernel
def eval_mesa(x, mode, par, idx, vold, vnew, q, phi, dq, dphi, jacobian):
    """Add every MESA device's currents, charges and derivatives (see :mod:`netdae.devices.kernels`)."""
    count = par.shape[0]
    start = mode == MODE_INITIAL and is_zero(x)
    limited = start
    for k in range(count):
        gp = idx[k, I_GP]
        vgs_x = x[gp] - x[idx[k, I_SP]]
        vgd_x = x[gp] - x[idx[k, I_DP]]
        if start:
            vgs, vgd = vold[k, V_GS], vold[k, V_GD]
        elif mode == MODE_EVALUATE or mode == MODE_INITIAL:
            vgs, vgd = vgs_x, vgd_x
        else:
            vgs, vgd = _mesa_limit(vgs_x, vgd_x, vold[k, V_GS], vold[k, V_GD], par, k)
            limited = limited or vgs != vgs_x or vgd != vgd_x
        vnew[k, V_GS] = vgs
        vnew[k, V_GD] = vgd
    bad = -1
    for k in range(count):
        d, g, s = idx[k, I_D], idx[k, I_G], idx[k, I_S]
        dp, sp, gp, spp, dpp = idx[k, I_DP], idx[k, I_SP], idx[k, I_GP], idx[k, I_SPP], idx[k, I_DPP]
        m = par[k, P_MULT]
        vgs, vgd = vnew[k, V_GS], vnew[k, V_GD]
        gi, gf = par[k, P_GI], par[k, P_GF]
        vspp = x[gp] - x[spp] if gi > 0.0 else vgs
        vdpp = x[gp] - x[dpp] if gf > 0.0 else vgd
        ich, d_vgs, d_vgd, igs, ggs, igd, ggd = mesa_dc(vgs, vgd, par, k)
        qs, qs_pp, qs_gs, qs_gd, qd, qd_pp, qd_gs, qd_gd = mesa_charges(vgs, vgd, vspp, vdpp, par, k)
        i_d, i_gs, i_gd = m * ich, m * igs, m * igd
        q_gs, q_gd = m * qs, m * qd
        ok = (math.isfinite(i_d) and math.isfinite(i_gs) and math.isfinite(i_gd) and math.isfinite(d_vgs)
              and math.isfinite(d_vgd) and math.isfinite(ggs) and math.isfinite(ggd) and math.isfinite(q_gs)
              and math.isfinite(q_gd) and math.isfinite(qs_pp + qs_gs + qs_gd + qd_pp + qd_gs + qd_gd))
        if bad < 0 and not ok:
            bad = k
        if limited:
            dgs = (x[gp] - x[sp]) - vgs
            dgd = (x[gp] - x[dp]) - vgd
            dspp = 0.0 if gi > 0.0 else dgs
            ddpp = 0.0 if gf > 0.0 else dgd
            i_d = i_d + m * (d_vgs * dgs + d_vgd * dgd)
            i_gs = i_gs + m * ggs * dgs
            i_gd = i_gd + m * ggd * dgd
            q_gs = q_gs + m * (qs_pp * dspp + qs_gs * dgs + qs_gd * dgd)
            q_gd = q_gd + m * (qd_pp * ddpp + qd_gs * dgs + qd_gd * dgd)
        gd, gs, gg = par[k, P_GD], par[k, P_GS], par[k, P_GG]
        add_current(phi, dp, sp, i_d)
        add_current(phi, gp, sp, i_gs)
        add_current(phi, gp, dp, i_gd)
        add_current(phi, d, dp, gd * (x[d] - x[dp]))
        add_current(phi, s, sp, gs * (x[s] - x[sp]))
        add_current(phi, g, gp, gg * (x[g] - x[gp]))
        add_current(phi, spp, sp, gi * (x[spp] - x[sp]))
        add_current(phi, dpp, dp, gf * (x[dpp] - x[dp]))
        add_charge(q, gp, spp, q_gs)
        add_charge(q, gp, dpp, q_gd)
        if jacobian:
            add_current_slope(dphi, idx, k, S_CUR, m * d_vgs)
            add_current_slope(dphi, idx, k, S_CUR + 4, m * d_vgd)
            add_current_slope(dphi, idx, k, S_CUR + 8, m * ggs)
            add_current_slope(dphi, idx, k, S_CUR + 12, m * ggd)
            add_current_slope(dphi, idx, k, S_CUR + 16, gd)
            add_current_slope(dphi, idx, k, S_CUR + 20, gs)
            add_current_slope(dphi, idx, k, S_CUR + 24, gg)
            add_current_slope(dphi, idx, k, S_CUR + 28, gi)
            add_current_slope(dphi, idx, k, S_CUR + 32, gf)
            add_charge_slope(dq, idx, k, S_CHG, m * qs_pp)
            add_charge_slope(dq, idx, k, S_CHG + 4, m * qs_gs)
            add_charge_slope(dq, idx, k, S_CHG + 8, m * qs_gd)
            add_charge_slope(dq, idx, k, S_CHG + 12, m * qd_pp)
            add_charge_slope(dq, idx, k, S_CHG + 16, m * qd_gs)
            add_charge_slope(dq, idx, k, S_CHG + 20, m * qd_gd)
    flags = (FLAG_LIMITED if limited else 0) | (FLAG_NONFINITE if bad >= 0 else 0)
    return flags, bad
