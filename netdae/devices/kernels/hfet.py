"""ngspice's HFET1 and HFET2 (``Z`` cards of ``nhfet``/``phfet`` models, levels 5 and 6) as one compiled kernel.

These functions are the one statement of the model's equations: the compiled loop's kernel
:func:`eval_hfet` and the numpy family :class:`netdae.devices.hfet.HfetFamily` (which calls
:func:`hfet_dc` and :func:`hfet_charges` per instance) both evaluate them. The equations are
ngspice 39's ``hfetload.c`` (``hfeta``, ``leak``, ``diode``; HFET2's ``hfet2load.c`` is the same channel
with simpler gate diodes, selected by the ``level`` column), in complex arithmetic so that the
derivatives are exact (the complex step), one instance at a time, in type-normalised voltages
(``type * v``: +1 for ``nhfet``, -1 for ``phfet``).

Layout (packed by ``HfetFamily.compiled``)
------------------------------------------
``par`` columns ``P_*``: the per-instance constants at temperature (see ``HfetFamily._setup``).
``idx``: ``I_D, I_G, I_S`` and the internal nodes ``I_DP, I_SP, I_GP, I_SPP, I_DPP`` (drain', source',
gate', ``#gs``, ``#gd``); four slots per current dependence from ``S_CUR`` and per charge dependence
from ``S_CHG``, in the order of ``netdae.devices.hfet._CURRENT_DEPS`` and ``_CHARGE_DEPS``.
``vold``/``vnew``: ``V_GS, V_GD`` (type-normalised).
"""

from __future__ import annotations

import cmath
import math

import numpy as np

from ...dae.compiled import kernel
from ..junction import BOLTZMANN as _BOLTZ, CHARGE as _CHARGE
from . import FLAG_LIMITED, FLAG_NONFINITE, MODE_EVALUATE, MODE_INITIAL
from .junction import fetlim, pnjlim
from .scatter import add_charge, add_charge_slope, add_current, add_current_slope, is_zero

__all__ = ["eval_hfet", "hfet_dc", "hfet_charges", "hfet_mode", "PAR_KEYS", "N_PAR", "N_IDX", "N_STATE",
           "STEP", "NS_FLOOR", "OFF_DEPTH", "QUAD_PANELS", "QUAD_NODES"]

#: The complex step of the derivatives [V]: far below rounding of any bias.
STEP = 1e-30
#: ngspice's floor of the sheet charge ``nsm``: below it the channel is off.
NS_FLOOR = 1.0e-38
#: The gate charges' quadrature: where it starts (this many ``max(ETA, ETA1) vt`` below the lower of
#: VTO(T) and VT1), its panels and Gauss-Legendre points per panel.
OFF_DEPTH = 40.0
QUAD_PANELS = 24
QUAD_NODES = 4
_GL_X, _GL_W = np.polynomial.legendre.leggauss(QUAD_NODES)
_ABS = np.ascontiguousarray((np.arange(QUAD_PANELS)[:, None] + 0.5 * (_GL_X + 1.0)).ravel())
_WTS = np.ascontiguousarray(np.tile(0.5 * _GL_W, QUAD_PANELS))

#: The constants in ``par``, in column order (``HfetFamily._setup`` names them the same).
PAR_KEYS = ("vt", "temp", "eta", "tvto", "vsigmat", "vsigma", "sigma0", "delta2", "n0", "n02", "vt2", "eta2",
            "two", "nmax", "gamma", "gchi0", "rt", "rsi", "vl", "imax", "m", "tlambda", "eta1", "d1", "epsi",
            "vt1", "wl", "cf", "mc", "pm", "gatemod", "ck1", "ck2", "cm1", "cm2", "cm3", "mt1", "mt2", "talpha",
            "m2d", "m2s", "phib", "iso", "a1", "a2", "mv1", "gmin", "is1s", "is2s", "m1s", "rgs", "is1d",
            "is2d", "m1d", "rgd", "ggrwl", "del", "mult", "type", "cds", "gd", "gs", "gg", "gi", "gf", "low",
            "level", "jslw", "nemit", "vcrit")
(P_VT, P_TEMP, P_ETA, P_TVTO, P_VSIGMAT, P_VSIGMA, P_SIGMA0, P_DELTA2, P_N0, P_N02, P_VT2, P_ETA2, P_TWO, P_NMAX,
 P_GAMMA, P_GCHI0, P_RT, P_RSI, P_VL, P_IMAX, P_M, P_TLAMBDA, P_ETA1, P_D1, P_EPSI, P_VT1, P_WL, P_CF, P_MC,
 P_PM, P_GATEMOD, P_CK1, P_CK2, P_CM1, P_CM2, P_CM3, P_MT1, P_MT2, P_TALPHA, P_M2D, P_M2S, P_PHIB, P_ISO, P_A1,
 P_A2, P_MV1, P_GMIN, P_IS1S, P_IS2S, P_M1S, P_RGS, P_IS1D, P_IS2D, P_M1D, P_RGD, P_GGRWL, P_DEL, P_MULT, P_TYPE,
 P_CDS, P_GD, P_GS, P_GG, P_GI, P_GF, P_LOW, P_LEVEL, P_JSLW, P_NEMIT, P_VCRIT) = range(70)
N_PAR = 70
#: ngspice's ``CONSTvt0`` (the thermal voltage at 27 degC), HFET2's junction limiting's.
VT0 = _BOLTZ * (27.0 + 273.15) / _CHARGE
I_D, I_G, I_S, I_DP, I_SP, I_GP, I_SPP, I_DPP = range(8)
S_CUR = 8
N_CUR_DEPS = 11
S_CHG = S_CUR + 4 * N_CUR_DEPS
N_CHG_DEPS = 8
N_IDX = S_CHG + 4 * N_CHG_DEPS
V_GS, V_GD = 0, 1
N_STATE = 2
_U0, _A, _B, _C = -2.303, 2.221, 6.804, 1.685


@kernel
def _div(a, b):
    """``a / b`` with IEEE's outcome for a zero ``b`` (inf or nan, as ngspice's doubles give), complex."""
    if b.real == 0.0 and b.imag == 0.0:
        return complex(a.real / b.real, 0.0)
    return a / b


@kernel
def _diode_w(u):
    """ngspice's ``diode(u)`` of ``hfetload.c`` (an approximation of Lambert's W of ``exp(u)``), complex."""
    expu = cmath.exp(u)
    if u.real <= _U0:
        it = expu * (1.0 - expu)
    else:
        b = 0.5 * (u - _U0)
        it = u + _A * cmath.exp((_U0 - u) / _B) - cmath.log(b + cmath.sqrt(b * b + 0.25 * _C * _C))
    ut = it + cmath.log(it)
    b = u - ut
    c = 1.0 + it
    return it * (1.0 + b / c + 0.5 * b * b / c / c / c)


@kernel
def _leak(gmin, vt, v, rs, is1, is2, m1, m2):
    """ngspice's gate leakage current ``leak`` of ``hfetload.c`` (its current; complex)."""
    vt1 = vt * m1
    vt2 = vt * m2
    if v.real > -10.0 * vt1:
        vteff = vt1 + vt2
        iseff = is2 * (is1 / is2) ** (m1 / (m1 + m2))
        if rs > 0.0:
            unorm = (v + rs * is1) / vt1 + math.log(rs * is1 / vt1)
            i1 = vt1 * _diode_w(unorm) / rs - is1
            unorm = (v + rs * iseff) / vteff + math.log(rs * iseff / vteff)
            i2 = vteff * _diode_w(unorm) / rs - iseff
        else:
            i1 = is1 * (cmath.exp(v / vt1) - 1.0)
            i2 = iseff * (cmath.exp(v / vteff) - 1.0)
        if i1.real * i2.real != 0.0:
            ia = 1.0 / (1.0 / i1 + 1.0 / i2)
        else:
            ia = 0.5 * (i1 + i2)
        dvdi0 = rs + vt1 / (ia + is1) + vt2 / (ia + is2)
        v0 = rs * ia + vt1 * cmath.log(ia / is1 + 1.0) + vt2 * cmath.log(ia / is2 + 1.0)
        il = ia + (v - v0) / dvdi0
        if il.real < -is1:
            il = -is1 + 0.0 * v
        return il * 0.99999
    return gmin * v - is1


@kernel
def _gate_currents0(vgs, vgd, par, k):
    """GATEMOD=0: the gate-source and gate-drain currents (leakage and the GGR term), complex."""
    vt = par[k, P_VT]
    gmin = par[k, P_GMIN]
    dl = par[k, P_DEL]
    ggrwl = par[k, P_GGRWL]
    igs = 0.0 * vgs
    igd = 0.0 * vgd
    if par[k, P_IS1S] != 0.0 and par[k, P_IS2S] != 0.0:
        igs = _leak(gmin, vt, vgs, par[k, P_RGS], par[k, P_IS1S], par[k, P_IS2S], par[k, P_M1S], par[k, P_M2S])
    if par[k, P_IS1D] != 0.0 and par[k, P_IS2D] != 0.0:
        igd = _leak(gmin, vt, vgd, par[k, P_RGD], par[k, P_IS1D], par[k, P_IS2D], par[k, P_M1D], par[k, P_M2D])
    igs = igs + ggrwl * vgs * cmath.exp(-vgs * dl / vt)
    igd = igd + ggrwl * vgd * cmath.exp(-vgd * dl / vt)
    return igs, igd


@kernel
def _gate_currents6(vgs, vgd, par, k):
    """HFET2's gate diodes: ``JS L W/2 (exp(v/(N vt)) - 1) + GGR L W/2 v exp(-DEL v/vt)``, complex."""
    vt = par[k, P_VT]
    vtn = par[k, P_NEMIT] * vt
    jslw = par[k, P_JSLW]
    ggrwl = par[k, P_GGRWL]
    dl = par[k, P_DEL]
    igs = jslw * (cmath.exp(vgs / vtn) - 1.0) + ggrwl * vgs * cmath.exp(-vgs * dl / vt)
    igd = jslw * (cmath.exp(vgd / vtn) - 1.0) + ggrwl * vgd * cmath.exp(-vgd * dl / vt)
    return igs, igd


@kernel
def hfet_mode(vg, vds, par, k):
    """ngspice's ``hfeta`` at the mode's gate voltage and ``vds >= 0`` (complex).

    Returns
    -------
    (cdrain, capgs, capgd, cgs, cgd)
        The channel current, the gate capacitances and (GATEMOD=1 only, else 0) the gate-source and
        gate-drain currents of ``hfeta``; one device, without ``m``.
    """
    vt = par[k, P_VT]
    etavth = par[k, P_ETA] * vt
    vl = par[k, P_VL]
    rt = par[k, P_RT]
    rsi = par[k, P_RSI]
    tvto = par[k, P_TVTO]
    cf = par[k, P_CF]
    sigma0 = par[k, P_SIGMA0]
    vgt0 = vg - tvto
    s = cmath.exp((vgt0 - par[k, P_VSIGMAT]) / par[k, P_VSIGMA])
    sigma = sigma0 / (1.0 + s)
    vgt = vgt0 + sigma * vds
    u = 0.5 * vgt / vt - 1.0
    t = cmath.sqrt(par[k, P_DELTA2] + u * u)
    vgte = vt * (2.0 + u + t)
    b = cmath.exp(vgt / etavth)
    n0 = par[k, P_N0]
    if par[k, P_TWO] != 0.0:
        nsc = par[k, P_N02] * cmath.exp((vgt + tvto - par[k, P_VT2]) / (par[k, P_ETA2] * vt))
        nsn = 2.0 * n0 * cmath.log(1.0 + 0.5 * b)
        nsm = nsn * nsc / (nsn + nsc)
    else:
        nsc = 0.0 * vg
        nsn = 0.0 * vg
        nsm = 2.0 * n0 * cmath.log(1.0 + 0.5 * b)
    gatemod = par[k, P_GATEMOD] != 0.0
    zero = 0.0 * vg
    cgs = zero
    cgd = zero
    vsate = zero
    delvsatevgt = zero
    delvgtvgs = zero
    delvgtevgt = zero
    if not nsm.real < NS_FLOOR:
        gamma = par[k, P_GAMMA]
        c = (nsm / par[k, P_NMAX]) ** gamma
        q = (1.0 + c) ** (1.0 / gamma)
        ns = nsm / q
        gchi0 = par[k, P_GCHI0]
        gchi = gchi0 * ns
        gch = gchi / (1.0 + gchi * rt)
        gchim = gchi0 * nsm
        h = cmath.sqrt(1.0 + 2.0 * gchim * rsi + vgte * vgte / (vl * vl))
        p = 1.0 + gchim * rsi + h
        isatm = gchim * vgte / p
        g = (isatm / par[k, P_IMAX]) ** gamma
        isat = isatm / (1.0 + g) ** (1.0 / gamma)
        vsate = isat / gch
        mk = par[k, P_M]
        if vds.real > 0.0:
            d = (vds / vsate) ** mk
        else:
            d = zero
        e = (1.0 + d) ** (1.0 / mk)
        cdrain = gch * vds * (1.0 + par[k, P_TLAMBDA] * vds) / e
        # the capacitances (and, for GATEMOD=1, ngspice's chain of derivatives the gate currents use)
        delnsnsm = ns / nsm * (1.0 - c / (1.0 + c))
        delvgtevgt = 0.5 * (1.0 + u / t)
        delnsmvgt = n0 / etavth / (1.0 / b + 0.5)
        if par[k, P_TWO] != 0.0:
            delnsmvgt = nsc * (nsc * delnsmvgt + nsn * nsn / (par[k, P_ETA2] * vt)) / ((nsc + nsn) * (nsc + nsn))
        delvgtvgs = 1.0 - vds * sigma0 / par[k, P_VSIGMA] * s / ((1.0 + s) * (1.0 + s))
        if gatemod:
            a = 1.0 + gchi * rt
            pp = 1.0 / (a * a) * gchi0 * delnsnsm * delnsmvgt
            delisatisatm = isat / isatm * (1.0 - g / (1.0 + g))
            delisatmvgte = gchim * (p - vgte * vgte / (vl * vl * h)) / (p * p)
            delisatmgchim = vgte * (p - gchim * rsi * (1.0 + 1.0 / h)) / (p * p)
            delvsatevgt = (1.0 / gch * delisatisatm * (delisatmvgte * delvgtevgt + delisatmgchim * gchi0 * delnsmvgt)
                           - vsate / gch * pp)
        tmp = par[k, P_ETA1] * vt
        cg1 = 1.0 / (par[k, P_D1] / par[k, P_EPSI] + tmp * cmath.exp(-(vg - par[k, P_VT1]) / tmp))
        cgc = par[k, P_WL] * (_CHARGE * delnsnsm * delnsmvgt * delvgtvgs + cg1)
        mc = par[k, P_MC]
        if vds.real > 0.0:
            vdse = vds * (1.0 + (vds / vsate) ** mc) ** (-1.0 / mc)
        else:
            vdse = zero
        ratio = (vsate - vdse) / (2.0 * vsate - vdse)
        pm = par[k, P_PM]
        pe = pm + (1.0 - pm) * cmath.exp(-vds / vsate)
        capgs = cf + 2.0 * (2.0 / 3.0) * cgc * (1.0 - ratio * ratio) / (1.0 + pe)
        ratio = vsate / (2.0 * vsate - vdse)
        capgd = cf + 2.0 * pe * (2.0 / 3.0) * cgc * (1.0 - ratio * ratio) / (1.0 + pe)
    else:
        cdrain = zero
        capgs = cf + zero
        capgd = cf + zero
    if gatemod:
        temp = par[k, P_TEMP]
        phib = par[k, P_PHIB]
        iso = par[k, P_ISO]
        vkneet = par[k, P_CK1] * vsate + par[k, P_CK2]
        vmax = par[k, P_CM1] * vsate + par[k, P_CM2]
        mt2 = par[k, P_MT2]
        mt1 = par[k, P_MT1]
        a = _div(vds, vmax) ** mt2  # nan where the channel is off (vsate = 0), as in ngspice
        vdse = vds / (1.0 + a) ** (1.0 / mt2)
        c = _div(vdse, vkneet) ** mt1
        td = temp + par[k, P_TALPHA] * vdse * vdse / (1.0 + c) ** (1.0 / mt1)
        e = _BOLTZ / _CHARGE * td * par[k, P_M2D]
        cgd = iso * td * td * cmath.exp(-phib / (_BOLTZ * td)) * cmath.exp((vg - vdse) / e) \
            - iso * temp * temp * math.exp(-phib / (_BOLTZ * temp))
        vtn = vt * par[k, P_M2S]
        csat = iso * temp * temp * math.exp(-phib / (_BOLTZ * temp))
        if vg.real <= -5.0 * vt:
            cgs = (-csat / vg + par[k, P_GMIN]) * vg
        else:
            cgs = csat * (cmath.exp(vg / vtn) - 1.0) + par[k, P_GMIN] * vg
        a1 = par[k, P_A1]
        a2 = par[k, P_A2]
        if a1 != 0.0 or a2 != 0.0:
            mv1 = par[k, P_MV1]
            a = _div(vds, par[k, P_CM3] * vsate) ** mv1
            vdse = vds / (1.0 + a) ** (1.0 / mv1)
            cdrain = cdrain + a1 * ((1.0 + a2 * vgte * vdse) * cgd - cgs)
    return cdrain, capgs, capgd, cgs, cgd


@kernel
def _channel(vgs, vgd, par, k):
    """Currents d'->s', g'->s', g'->d' and the capacitances (capgs, capgd) at (vgs, vgd), complex.

    ngspice's mode: with ``vds < 0`` it evaluates ``hfeta`` at ``|vds|`` and negates the current,
    exchanging the capacitances; the gate voltage it passes is ``vgs`` in both modes (``vds > 0 ? vgs :
    vgd`` after ``vds`` was made positive).
    """
    vds = vgs - vgd
    inverse = vds.real < 0.0
    w = -vds if inverse else vds
    vg = vgs if w.real > 0.0 else vgd
    cdrain, capgs, capgd, cgs1, cgd1 = hfet_mode(vg, w, par, k)
    if par[k, P_LEVEL] == 6.0:
        igs, igd = _gate_currents6(vgs, vgd, par, k)
    elif par[k, P_GATEMOD] != 0.0:
        igs, igd = cgs1, cgd1
    else:
        igs, igd = _gate_currents0(vgs, vgd, par, k)
    if inverse:
        return -cdrain, igs, igd, capgd, capgs
    return cdrain, igs, igd, capgs, capgd


@kernel
def hfet_dc(vgs, vgd, par, k):
    """Channel current d'->s', gate currents and their derivatives at (vgs, vgd), one device, type-normalised.

    Returns
    -------
    (ich, ich_vgs, ich_vgd, igs, igs_vgs, igs_vgd, igd, igd_vgs, igd_vgd, capgs, capgd) : tuple of float
    """
    h = STEP
    i0, s0, d0, cs, cd = _channel(vgs + 0j, vgd + 0j, par, k)
    i1, s1, d1, _, _ = _channel(vgs + 1j * h, vgd + 0j, par, k)
    i2, s2, d2, _, _ = _channel(vgs + 0j, vgd + 1j * h, par, k)
    return (i0.real, i1.imag / h, i2.imag / h, s0.real, s1.imag / h, s2.imag / h, d0.real, d1.imag / h,
            d2.imag / h, cs.real, cd.real)


@kernel
def _charges(vgs, vgd, vgspp, vgdpp, par, k):
    """The gate charges of one device: ngspice's capacitances integrated along the gate voltage, complex.

    ``qgs = CF vgs'' + int (capgs - CF) du`` from deep below threshold to ``vgs''`` with the gate alone
    moving (``vds`` and the offset ``vgs - vgs''`` held), the same for ``qgd``.
    """
    vds = vgs - vgd
    low = par[k, P_LOW] - abs(par[k, P_SIGMA0]) * abs(vds.real)
    cf = par[k, P_CF]
    qgs = 0.0j
    qgd = 0.0j
    for branch in range(2):
        if branch == 0:
            far, here, ahead = vgspp, vgs, 0.0
        else:
            far, here, ahead = vgdpp, vgd, vds.real
        shift = here - far
        start = min(low - shift.real - ahead, far.real)
        width = (far - start) / QUAD_PANELS
        acc = 0.0j
        for j in range(_ABS.size):
            u = start + width * _ABS[j]
            gs_u = u + shift if branch == 0 else u + shift + vds
            _, _, _, cgs, cgd = _channel(gs_u, gs_u - vds, par, k)
            acc += ((cgs if branch == 0 else cgd) - cf) * _WTS[j]
        if branch == 0:
            qgs = cf * far + width * acc
        else:
            qgd = cf * far + width * acc
    return qgs, qgd


@kernel
def hfet_charges(vgs, vgd, vgspp, vgdpp, par, k):
    """The gate charges and their derivatives: (qgs, d/dvgs'', d/dvgs, d/dvgd, qgd, d/dvgd'', d/dvgs, d/dvgd)."""
    h = STEP
    qs, qd = _charges(vgs + 0j, vgd + 0j, vgspp + 0j, vgdpp + 0j, par, k)
    s0, d0 = _charges(vgs + 1j * h, vgd + 0j, vgspp + 0j, vgdpp + 0j, par, k)
    s1, d1 = _charges(vgs + 0j, vgd + 1j * h, vgspp + 0j, vgdpp + 0j, par, k)
    s2, _ = _charges(vgs + 0j, vgd + 0j, vgspp + 1j * h, vgdpp + 0j, par, k)
    _, d3 = _charges(vgs + 0j, vgd + 0j, vgspp + 0j, vgdpp + 1j * h, par, k)
    return (qs.real, s2.imag / h, s0.imag / h, s1.imag / h, qd.real, d3.imag / h, d0.imag / h, d1.imag / h)


@kernel
def hfet_limit(vgs_x, vgd_x, vgs_o, vgd_o, par, k):
    """ngspice's limiting: HFET1 fetlim of vgs and vgd against VTO(T); HFET2 pnjlim (``CONSTvt0``, its
    vcrit) first."""
    tvto = par[k, P_TVTO]
    if par[k, P_LEVEL] == 6.0:
        vgs_x, _ = pnjlim(vgs_x, vgs_o, VT0, par[k, P_VCRIT])
        vgd_x, _ = pnjlim(vgd_x, vgd_o, VT0, par[k, P_VCRIT])
    return fetlim(vgs_x, vgs_o, tvto), fetlim(vgd_x, vgd_o, tvto)


@kernel
def eval_hfet(x, mode, par, idx, vold, vnew, q, phi, dq, dphi, jacobian):
    """Add every HFET1 device's currents, charges and derivatives (see :mod:`netdae.devices.kernels`)."""
    count = par.shape[0]
    start = mode == MODE_INITIAL and is_zero(x)
    limited = start
    for k in range(count):
        tp = par[k, P_TYPE]
        gp = idx[k, I_GP]
        vgs_x = tp * (x[gp] - x[idx[k, I_SP]])
        vgd_x = tp * (x[gp] - x[idx[k, I_DP]])
        if start:
            vgs, vgd = vold[k, V_GS], vold[k, V_GD]
        elif mode == MODE_EVALUATE or mode == MODE_INITIAL:
            vgs, vgd = vgs_x, vgd_x
        else:
            vgs, vgd = hfet_limit(vgs_x, vgd_x, vold[k, V_GS], vold[k, V_GD], par, k)
            limited = limited or vgs != vgs_x or vgd != vgd_x
        vnew[k, V_GS] = vgs
        vnew[k, V_GD] = vgd
    bad = -1
    for k in range(count):
        d, g, s = idx[k, I_D], idx[k, I_G], idx[k, I_S]
        dp, sp, gp, spp, dpp = idx[k, I_DP], idx[k, I_SP], idx[k, I_GP], idx[k, I_SPP], idx[k, I_DPP]
        m = par[k, P_MULT]
        tp = par[k, P_TYPE]
        vgs, vgd = vnew[k, V_GS], vnew[k, V_GD]
        gi, gf = par[k, P_GI], par[k, P_GF]
        vspp = tp * (x[gp] - x[spp]) if gi > 0.0 else vgs
        vdpp = tp * (x[gp] - x[dpp]) if gf > 0.0 else vgd
        ich, i_vgs, i_vgd, igs, s_vgs, s_vgd, igd, d_vgs, d_vgd, _, _ = hfet_dc(vgs, vgd, par, k)
        qs, qs_pp, qs_gs, qs_gd, qd, qd_pp, qd_gs, qd_gd = hfet_charges(vgs, vgd, vspp, vdpp, par, k)
        ok = (math.isfinite(ich) and math.isfinite(igs) and math.isfinite(igd) and math.isfinite(qs)
              and math.isfinite(qd) and math.isfinite(i_vgs + i_vgd + s_vgs + s_vgd + d_vgs + d_vgd)
              and math.isfinite(qs_pp + qs_gs + qs_gd + qd_pp + qd_gs + qd_gd))
        if bad < 0 and not ok:
            bad = k
        if limited:
            dgs = tp * (x[gp] - x[sp]) - vgs
            dgd = tp * (x[gp] - x[dp]) - vgd
            dspp = 0.0 if gi > 0.0 else dgs
            ddpp = 0.0 if gf > 0.0 else dgd
            ich = ich + i_vgs * dgs + i_vgd * dgd
            igs = igs + s_vgs * dgs + s_vgd * dgd
            igd = igd + d_vgs * dgs + d_vgd * dgd
            qs = qs + qs_pp * dspp + qs_gs * dgs + qs_gd * dgd
            qd = qd + qd_pp * ddpp + qd_gs * dgs + qd_gd * dgd
        cds = m * par[k, P_CDS]
        add_current(phi, dp, sp, tp * m * ich)
        add_current(phi, gp, sp, tp * m * igs)
        add_current(phi, gp, dp, tp * m * igd)
        add_current(phi, d, dp, par[k, P_GD] * (x[d] - x[dp]))
        add_current(phi, s, sp, par[k, P_GS] * (x[s] - x[sp]))
        add_current(phi, g, gp, par[k, P_GG] * (x[g] - x[gp]))
        add_current(phi, spp, sp, gi * (x[spp] - x[sp]))
        add_current(phi, dpp, dp, gf * (x[dpp] - x[dp]))
        add_charge(q, gp, spp, tp * m * qs)
        add_charge(q, gp, dpp, tp * m * qd)
        add_charge(q, dp, sp, cds * (x[dp] - x[sp]))
        if jacobian:
            add_current_slope(dphi, idx, k, S_CUR, m * i_vgs)
            add_current_slope(dphi, idx, k, S_CUR + 4, m * i_vgd)
            add_current_slope(dphi, idx, k, S_CUR + 8, m * s_vgs)
            add_current_slope(dphi, idx, k, S_CUR + 12, m * s_vgd)
            add_current_slope(dphi, idx, k, S_CUR + 16, m * d_vgs)
            add_current_slope(dphi, idx, k, S_CUR + 20, m * d_vgd)
            add_current_slope(dphi, idx, k, S_CUR + 24, par[k, P_GD])
            add_current_slope(dphi, idx, k, S_CUR + 28, par[k, P_GS])
            add_current_slope(dphi, idx, k, S_CUR + 32, par[k, P_GG])
            add_current_slope(dphi, idx, k, S_CUR + 36, gi)
            add_current_slope(dphi, idx, k, S_CUR + 40, gf)
            add_charge_slope(dq, idx, k, S_CHG, m * qs_pp)
            add_charge_slope(dq, idx, k, S_CHG + 4, m * qs_gs)
            add_charge_slope(dq, idx, k, S_CHG + 8, m * qs_gd)
            add_charge_slope(dq, idx, k, S_CHG + 12, m * qd_pp)
            add_charge_slope(dq, idx, k, S_CHG + 16, m * qd_gs)
            add_charge_slope(dq, idx, k, S_CHG + 20, m * qd_gd)
            add_charge_slope(dq, idx, k, S_CHG + 24, cds)
            add_charge_slope(dq, idx, k, S_CHG + 28, -cds)
    flags = (FLAG_LIMITED if limited else 0) | (FLAG_NONFINITE if bad >= 0 else 0)
    return flags, bad
