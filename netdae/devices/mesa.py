"""ngspice's MESA MESFET (``Z`` cards, ``.model ... nmf level=2, 3, 4``) as ngspice 39 computes it.

Syntax: ``Zname d g s model [area] [off] [l=L] [w=W] [m=M] [ic=vds,vgs] [icvds=v] [icvgs=v] [td=T] [ts=T]
[dtemp=dT]`` with ``.model name NMF level=2 (VTO LAMBDA BETA VS RD RS RG RI RF RDI RSI PHIB ASTAR GGR DEL
XCHI N ETA M MC ALPHA SIGMA0 VSIGMAT VSIGMA MU THETA D ND DELTA TC ...)``. ngspice implements the N
channel only: a ``pmf`` card runs as ``nmf`` (ngspice says "Only nmf model type supported, set to nmf").
Levels 3 and 4 share everything but the channel (below: "Levels 3 and 4"); any other level is refused.

Equations (level 2, ``mesaload.c``'s ``mesa1`` and ``mesatemp.c``)
------------------------------------------------------------------
With ``vt = k Ts/q`` and the mode's gate voltage ``vg`` (``vgs``; ``vgd`` with source and drain
exchanged when ``vds < 0``) and ``w = |vds|``::

    vgt   = vg - VTO(T) + sigma w,   sigma = SIGMA0 / (1 + exp((vg - VTO(T) - VSIGMAT)/VSIGMA))
    mu    = MU(T) + THETA vgt,        beta = 2 eps VS ZETA W / D / (vpo + 3 VS L / mu)
    vgte  = vt/2 (2 + u + sqrt(DELTA^2 + u^2)),  u = vgt/vt - 1      (a smooth max(vgt, vt))
    ns    = 1 / (1/(ND D (1 - sqrt(1 - vgte/vpo))) + exp(-vgt/(ETA vt))/n0),  vpo = q ND D^2 / (2 eps)
    gch   = gchi/(1 + gchi (RSI + RDI)),   gchi = q W/L mu ns
    isat  = isata isatb/(isata + isatb),   isata = 2 beta vgte^2 / ((1 + a RSI + sqrt(1 + 2 a RSI)) (1 + TC vgte)),
            a = 2 beta vgte,  isatb = q n0 vt W/L mu exp(vgt/(ETA vt))
    vsate = isat/gch,  mm = M + ALPHA vgte
    id    = gch w (1 + LAMBDA w) / (1 + (w/vsate)^mm)^(1/mm)

(``n0 = eps ETA vt/(q D)``, ``eps`` GaAs's ``12.244 eps0``). ``id`` is 0 where ``ns < 1e-38``. The
derivatives netdae uses are the exact derivatives of this current (to rounding, by the complex step);
ngspice's ``gm`` and ``gds`` are the same in normal mode, but in the inverse mode ngspice loads the
normal mode's derivatives unchanged (a Newton matrix that is not the Jacobian; the solution is the same).

Gate diodes (Schottky, with a reverse-breakdown-like term)::

    igs = CSATFS (exp(vgs/(N vt)) - 1) + GGRWL vgs exp(-DEL vgs/vt) + GMIN vgs

(``CSATFS = ASTAR Ts^2 exp(-PHIB(T)/(k Ts)) L W / 2``, ``GGRWL = GGR L W exp(XCHI (Ts - Tnom))``), the
same for ``igd`` with ``vgd`` and ``Td``. netdae's conductance is the exact derivative
(``GGRWL exp(arg) (1 + arg)``, ``arg = -DEL v/vt``); ngspice's ``ggs`` writes ``(1 - arg)`` (again the
solution is the same). ``AG`` adds ``AG (igs - igd)`` from source to drain.

Gate capacitances (ngspice's, from the same bias)::

    cgs = CF + 2/3 cgc (1 - ((vsate - vdse)/(2 vsate - vdse))^2)
    cgd = CF + 2/3 cgc (1 - (vsate/(2 vsate - vdse))^2)

with ``CF = eps W / 2``, ``cgc = eps W L / D / (sqrt(1 - vgt/vpo) + exp(-vgt/(ETA vt)))`` and
``vdse = w (1 + (w/vsate)^MC)^(-1/MC)`` (swapped in the inverse mode). These are Meyer-like
capacitances, not the derivatives of any charge: ngspice integrates ``i = C(v) dv/dt`` on the
branches gate to ``s''`` and gate to ``d''``. netdae's charge form is ``qgs = cgs(x) vgs''``,
``qgd = cgd(x) vgd''`` (a charge whose derivative to its own branch voltage at zero bias and where the
capacitance is constant, i.e. below threshold (``CF`` alone) and at ``cgd`` in saturation, is ngspice's
capacitance); ``@z1[cgs]`` and ``@z1[cgdq]`` give ngspice's capacitances themselves.

Series resistances (``mesasetup.c``): ``RD``, ``RS``, ``RG`` to ``<name>#drain``, ``#source``,
``#gate``; ``RI`` from the internal source to ``#gs`` and ``RF`` from the internal drain to ``#gd``
(the gate charges' far ends); ``RSI``, ``RDI`` enter the current only. Each is ``R (1 + RTC1 dT +
RTC2 dT^2)`` with ``dT`` the source (drain for RD, RDI, RF) temperature less TNOM.

Temperature: ``Ts``, ``Td`` the instance's ``ts``, ``td`` (Celsius), else ``.options temp + dtemp``;
``VTO(T) = VTO - TVTO (Ts - Tnom)``, ``PHIB(T) = PHIB - PHIB1 (Ts - Tnom)``, ``ETA(T) = ETA (1 +
Ts/TETA0) + TETA1/Ts``, ``LAMBDA(T) = LAMBDA (1 - Ts/TLAMBDA)``, ``MU(T) = MU (Ts/TMU)^XTM0`` (with
``MU1``, ``MU2``: ``1/(1/MU(T) + 1/(MU1 (TMU/Ts)^XTM1 + MU2 (TMU/Ts)^XTM2))``).

Levels 3 and 4 (``mesa2`` and ``mesa3`` of ``mesaload.c``)
----------------------------------------------------------
The same gate diodes, resistances, temperatures, mode exchange, ``vgt`` (with ``SIGMA``), capacitance
partition (``cgs``, ``cgd`` from ``cgc``, ``vsate``, ``vdse``) and saturation law ``id = gch w (1 +
LAMBDA w)/(1 + (w/vsate)^M)^(1/M)`` (``M`` alone: no ``ALPHA``); the mobility is ``MU(T)`` without
``THETA`` and ``gchi = q W/L MU(T) ns``.

Level 3 (the delta-doped channel): ``vgte`` as level 2; ``vpou = q NDU DU^2/(2 eps)``, ``vpod = q NDELTA
TH (2 DU + TH)/(2 eps)``, ``vpo = vpou + vpod``; the doped layers' sheet charge ``nsa`` and capacitance
``ca`` (four branches, chosen by ``vgt`` against ``vpod`` and ``vgte`` against ``vpo`` or ``vpod``:
``NDELTA TH + NDU DU (1 - r)``, ``r = sqrt((vpo - vgte)/vpou)``, or ``NDELTA TH (1 - DU/TH (r - 1))``,
``r = sqrt(1 + NDU/NDELTA (vpod - vgte)/vpou)``, ``ca = eps/(DU r)``; past the ends ``NDELTA TH +
NDU DU`` and ``NDELTA (TH - DU)`` with ``ca = eps/DU``), in series with ``nsb = eps ETA vt/(q (DU +
TH)) exp(vgt/(ETA vt))``: ``ns = nsa nsb/(nsa + nsb)``
(off below ``1e-38``), ``cgc = W L ca cb/(ca + cb)``, ``cb = eps/(DU + TH) exp(vgt/(ETA vt))``;
``isat = isata isatb/(isata + isatb)`` with level 2's ``isata`` but ``a = 2 BETA vgte`` (the card's
``BETA``) and ``isatb = q n0 vt W/L exp(vgt/(ETA vt))``, ``n0 = eps ETA vt/(q DU)``.

Level 4 (the sheet-charge-limited channel): ``vgte = vt (2 + u + sqrt(DELTA^2 + u^2))``, ``u = vgt/(2
vt) - 1``; ``nsm = 2 n0 ln(1 + exp(vgt/(ETA vt))/2)`` (off below ``1e-38``), ``n0 = EPSI ETA vt/(2 q D)``;
``ns = nsm/(1 + c)^(1/GAMMA)``, ``c = (nsm/NMAX)^GAMMA``; ``isatm = gchim vgte/(1 + gchim RSI + sqrt(1 +
2 gchim RSI' + (vgte/vl)^2))`` with ``gchim = q W/L MU(T) nsm``, ``vl = VS L/MU(T)`` and ``RSI'`` the
card's ``RSI`` without its temperature coefficients (ngspice writes ``model->MESArsi`` there);
``isat = isatm/(1 + (isatm/imax)^GAMMA)^(1/GAMMA)``, ``imax = q NMAX VS W``; ``cgc = W L/(D/(CAS
EPSI) + ETA vt/(CBS q n0) exp(-vgt/(ETA vt)))/(1 + c)^(1 + 1/GAMMA)``; the fringe ``CF = EPSI W/2``.

ngspice's ``gm``, ``gds`` at levels 3 and 4 are the derivatives of its current in the normal mode, but
for level 4's ``RSI'``: with ``RTC1``, ``RTC2`` and ``Ts != TNOM`` ngspice's ``gm`` differentiates as if
``RSI' = RSI(T)`` (measured: 6e-3 off the slope of its own current at 120 degC). Its ``.ac`` at level
4 loads ``gm = gds = 0``: ``mesaacl.c`` rebuilds them from fields (``delidgch0``, ``gm0`` ...) that only
``mesa1`` and ``mesa2`` set, so a level-4 channel carries no small-signal current in ngspice's ``.ac``.
netdae's small-signal matrix is the Jacobian at every level.

``m`` multiplies every current, conductance and charge (ngspice leaves it off the right-hand side of the
charges' far nodes ``#gs``, ``#gd`` in a transient; netdae scales them consistently). An area on the Z
card is refused, as ngspice 39 stops at it (MESA has no area parameter). ``KS`` (sidegating through the
source node's absolute voltage) is refused when non-zero.
"""

from __future__ import annotations

import math

import numpy as np

from ..circuit import Model
from ..errors import CircuitError, NetlistError
from .base import Accumulator, DeviceFamily, SlotMap, series_nodes
from .companion import BranchStamps, GateJunctionLimits, LimitState, starting_voltages
from .junction import BOLTZMANN, CHARGE, K_OVER_Q, KELVIN, quadratic_factor
from .modelcard import ParameterTable, gather, instance_values, require_positive, resolve_model

__all__ = ["MesaFamily", "MESA_PARAMETERS", "mesa2_channel", "mesa3_channel", "mesa4_channel", "mesa_channel",
           "LEVELS", "gate_diode", "EPS_GAAS", "NS_FLOOR", "STEP",
           "OFF_DEPTH", "QUAD_PANELS", "QUAD_ABSCISSAE", "QUAD_WEIGHTS"]

#: GaAs's permittivity as ngspice writes it [F/m].
EPS_GAAS = 12.244 * 8.85418e-12
#: ngspice's floor of the sheet charge: below it the channel is off.
NS_FLOOR = 1.0e-38
#: ngspice's default of the parameters read in degrees Celsius that it stores in kelvin (TLAMBDA, TETA0:
#: DBL_MAX; TMU: 300.15 K); None: ``.options temp``.
_HUGE = 1.7976931348623157e308

MESA_PARAMETERS = ParameterTable(
    "MESFET (MESA, levels 2-4)",
    defaults={
        "level": 2.0, "vto": -1.26, "d": 0.12e-6, "du": 0.035e-6, "lambda": 0.045, "lambdahf": None, "vs": 1.5e5,
        "beta": 0.0085, "eta": 1.73, "m": 2.5, "mc": 3.0, "alpha": 0.0, "sigma0": 0.081, "vsigmat": 1.01,
        "vsigma": 0.1, "mu": 0.23, "theta": 0.0, "mu1": 0.0, "mu2": 0.0, "nd": 2.0e23, "ndu": 1e22,
        "ndelta": 6e24, "th": 0.01e-6, "delta": 5.0, "tc": 0.0, "rd": 0.0, "rs": 0.0, "rg": 0.0, "ri": 0.0,
        "rf": 0.0, "rdi": 0.0, "rsi": 0.0, "phib": 0.5, "phib1": 0.0, "astar": 4.0e4, "ggr": 40.0, "del": 0.04,
        "xchi": 0.033, "n": 1.0, "tvto": 0.0, "tlambda": None, "teta0": None, "teta1": 0.0 - KELVIN,
        "tmu": 27.0, "xtm0": 0.0, "xtm1": 0.0, "xtm2": 0.0, "ks": 0.0, "vsg": 0.0, "tf": None, "flo": 0.0,
        "delfo": 0.0, "ag": 0.0, "rtc1": 0.0, "rtc2": 0.0, "zeta": 1.0, "nmax": 2e16, "gamma": 3.0,
        "epsi": EPS_GAAS, "cas": 1.0, "cbs": 1.0,
    },
    aliases={"vt0": "vto", "tphib": "phib1", "tggr": "xchi", "alphat": "tvto"},
    inert=frozenset({"nmf", "pmf"}),
    family="mesa",
)

#: Instance parameters and their defaults (None: absent unless given).
_INSTANCE = {"l": 1e-6, "w": 20e-6, "m": 1.0, "off": 0.0, "icvds": None, "icvgs": None, "td": None, "ts": None,
             "dtemp": 0.0}

# controls: vgs, vgd (limited), vgs'', vgd'' (the charges' branches), then the five series resistors
_VGS, _VGD, _VGSPP, _VGDPP, _VRD, _VRS, _VRG, _VRI, _VRF = range(9)
_ID, _IGS, _IGD, _IRD, _IRS, _IRG, _IRI, _IRF = range(8)
_CURRENT_DEPS = [(_ID, _VGS), (_ID, _VGD), (_IGS, _VGS), (_IGD, _VGD), (_IRD, _VRD), (_IRS, _VRS),
                 (_IRG, _VRG), (_IRI, _VRI), (_IRF, _VRF)]
_CHARGE_DEPS = [(0, _VGSPP), (0, _VGS), (0, _VGD), (1, _VGDPP), (1, _VGS), (1, _VGD)]
#: The complex step of the derivatives [V]: far below rounding of any bias.
STEP = 1e-30
#: The gate charges' quadrature: where it starts (this many ``ETA vt`` below VTO(T)), its panels and
#: their Gauss-Legendre points (abscissae in units of a panel's width from the start, and weights).
OFF_DEPTH = 40.0
QUAD_PANELS = 24
QUAD_NODES = 4
_GL_X, _GL_W = np.polynomial.legendre.leggauss(QUAD_NODES)
QUAD_ABSCISSAE = (np.arange(QUAD_PANELS)[:, None] + 0.5 * (_GL_X + 1.0)).ravel()
QUAD_WEIGHTS = np.tile(0.5 * _GL_W, QUAD_PANELS)


def mesa2_channel(vg, w, p):
    """Level 2's drain current and gate capacitances of the mode (``mesa1`` of ngspice), vectorised.

    Parameters
    ----------
    vg : ndarray (float or complex)
        The mode's gate voltage (``vgs``, or ``vgd`` in the inverse mode) [V].
    w : ndarray (float or complex)
        The mode's drain-source voltage ``|vds|`` [V].
    p : dict of ndarray
        The family's per-instance constants (:attr:`MesaFamily.channel`).

    Returns
    -------
    i, cgs, cgd : ndarray
        The current from the mode's drain to its source and the mode's gate-source and gate-drain
        capacitances (one device, without ``m``). Complex inputs give complex outputs whose
        imaginary parts carry the derivatives (the complex step); branches follow the real parts.
    """
    vt = p["vt"]
    etavth = p["eta"] * vt
    vpo = p["vpo"]
    vgt0 = vg - p["vto"]
    s = np.exp((vgt0 - p["vsigmat"]) / p["vsigma"])
    sigma = p["sigma0"] / (1.0 + s)
    vgt = vgt0 + sigma * w
    mu = p["mu"] + p["theta"] * vgt
    vl = p["vs"] / mu * p["l"]
    beta = p["beta"] / (vpo + 3.0 * vl)
    u = vgt / vt - 1.0
    vgte = 0.5 * vt * (2.0 + u + np.sqrt(p["delta2"] + u * u))
    a = 2.0 * beta * vgte
    b = np.exp(-vgt / etavth)
    above = vgte.real > vpo
    sqrt1 = np.where(above, 0.0, np.sqrt(np.where(above, 0.0, 1.0 - vgte / vpo)))
    ns = 1.0 / (1.0 / (p["nd"] * p["d"] * (1.0 - sqrt1)) + b / p["n0"])
    off = ~(ns.real >= NS_FLOOR)
    gchi = p["gchi0"] * mu * ns
    gch = gchi / (1.0 + gchi * p["rt"])
    rsi = p["rsi"]
    dd = 1.0 + a * rsi + np.sqrt(1.0 + 2.0 * a * rsi)
    e = 1.0 + p["tc"] * vgte
    isata = a * vgte / (dd * e)
    isatb = p["isatb0"] * mu * np.exp(vgt / etavth)
    isat = isata * isatb / (isata + isatb)
    vsate = isat / gch
    ratio = w / vsate
    positive = w.real > 0.0
    safe = np.where(positive, ratio, 1.0)
    vdse = np.where(positive, w * (1.0 + safe ** p["mc"]) ** (-1.0 / p["mc"]), 0.0 * w)
    mm = p["m"] + p["alpha"] * vgte
    g = np.where(positive, safe ** mm, 0.0 * w)
    h = (1.0 + g) ** (1.0 / mm)
    i = gch * w / h * (1.0 + p["lambda"] * w)
    tq = np.where(vgt.real > vpo, 0.0, np.sqrt(np.where(vgt.real > vpo, 1.0, 1.0 - vgt / vpo)))
    cgc = p["wl_eps_d"] / (tq + b)
    den = 2.0 * vsate - vdse
    cs = (vsate - vdse) / den
    cd = vsate / den
    cgs = p["cf"] + 2.0 / 3.0 * cgc * (1.0 - cs * cs)
    cgd = p["cf"] + 2.0 / 3.0 * cgc * (1.0 - cd * cd)
    zero = 0.0 * vg
    return (np.where(off, zero, i), np.where(off, p["cf"] + zero, cgs), np.where(off, p["cf"] + zero, cgd))


def _mode_bias(vg, w, p):
    """The mode's ``vgt`` (threshold and ``SIGMA`` feedback applied) and ``ETA vt``, common to all levels."""
    etavth = p["eta"] * p["vt"]
    vgt0 = vg - p["vto"]
    s = np.exp((vgt0 - p["vsigmat"]) / p["vsigma"])
    return vgt0 + p["sigma0"] / (1.0 + s) * w, etavth


def _saturation(gch, isat, w, lam, mc, mm, cgc, cf):
    """The drain current and the gate capacitances from the channel's conductance and saturation current.

    ``vsate = isat/gch``; ``id = gch w (1 + LAMBDA w)/(1 + (w/vsate)^mm)^(1/mm)``; ``cgs``, ``cgd`` the
    Meyer-like partition of ``cgc`` with ``vdse = w (1 + (w/vsate)^MC)^(-1/MC)`` (every level's tail).
    """
    vsate = isat / gch
    positive = w.real > 0.0
    safe = np.where(positive, w / vsate, 1.0)
    vdse = np.where(positive, w * (1.0 + safe ** mc) ** (-1.0 / mc), 0.0 * w)
    g = np.where(positive, safe ** mm, 0.0 * w)
    i = gch * w / (1.0 + g) ** (1.0 / mm) * (1.0 + lam * w)
    den = 2.0 * vsate - vdse
    cs = (vsate - vdse) / den
    cd = vsate / den
    return i, cf + 2.0 / 3.0 * cgc * (1.0 - cs * cs), cf + 2.0 / 3.0 * cgc * (1.0 - cd * cd)


def mesa3_channel(vg, w, p):
    """Level 3's drain current and gate capacitances of the mode (``mesa2`` of ngspice), vectorised.

    The delta-doped channel: a sheet charge ``nsa`` of the doped layers (``NDELTA``, ``TH``, ``NDU``,
    ``DU``) in series with the subthreshold ``nsb = nsb0 exp(vgt/(ETA vt))``; the mobility is ``MU(T)``
    (no ``THETA``), the saturation current's ``beta`` the card's ``BETA``, no ``ALPHA``. Arguments and
    returns as :func:`mesa2_channel`.
    """
    vt = p["vt"]
    vgt, etavth = _mode_bias(vg, w, p)
    t = vgt / vt - 1.0
    vgte = 0.5 * vt * (2.0 + t + np.sqrt(p["delta2"] + t * t))
    a = 2.0 * p["beta0"] * vgte
    vpo, vpod, vpou = p["vpo"], p["vpod"], p["vpou"]
    ndelta, th, ndu, du = p["ndelta"], p["th"], p["ndu"], p["du"]
    upper = vgt.real > vpod
    full = vgte.real > vpo  # above the doped layers' pinch-off: both layers fully open
    r1 = np.sqrt(np.where(upper & ~full, (vpo - vgte) / vpou, 1.0))
    nsa1 = np.where(full, ndelta * th + ndu * du, ndelta * th + ndu * du * (1.0 - r1))
    ca1 = np.where(full, EPS_GAAS / du + 0.0 * vgte, EPS_GAAS / du / r1)
    past = (vpod - vgte).real < 0.0
    r2 = np.sqrt(np.where(~upper & ~past, 1.0 + ndu / ndelta * (vpod - vgte) / vpou, 1.0))
    nsa2 = np.where(past, ndelta * th * (1.0 - du / th) + 0.0 * vgte, ndelta * th * (1.0 - du / th * (r2 - 1.0)))
    ca2 = np.where(past, EPS_GAAS / du + 0.0 * vgte, EPS_GAAS / du / r2)
    nsa = np.where(upper, nsa1, nsa2)
    ca = np.where(upper, ca1, ca2)
    b = np.exp(vgt / etavth)
    cb = EPS_GAAS / (du + th) * b
    nsb = p["nsb0"] * b
    ns = nsa * nsb / (nsa + nsb)
    off = ~(ns.real >= NS_FLOOR)
    gchi = p["gchi0"] * p["mu"] * ns
    gch = gchi / (1.0 + gchi * p["rt"])
    rsi = p["rsi"]
    dd = 1.0 + a * rsi + np.sqrt(1.0 + 2.0 * a * rsi)
    e = 1.0 + p["tc"] * vgte
    isata = a * vgte / (dd * e)
    isatb = p["isatb0"] * b
    isat = isata * isatb / (isata + isatb)
    cgc = p["wl"] * ca * cb / (ca + cb)
    i, cgs, cgd = _saturation(gch, isat, w, p["lambda"], p["mc"], p["m"], cgc, p["cf"])
    zero = 0.0 * vg
    return (np.where(off, zero, i), np.where(off, p["cf"] + zero, cgs), np.where(off, p["cf"] + zero, cgd))


def mesa4_channel(vg, w, p):
    """Level 4's drain current and gate capacitances of the mode (``mesa3`` of ngspice), vectorised.

    The sheet charge ``nsm = 2 n0 ln(1 + exp(vgt/(ETA vt))/2)`` limited by ``NMAX`` (``ns = nsm/(1 +
    (nsm/NMAX)^GAMMA)^(1/GAMMA)``); the saturation current ``gchim vgte/(1 + gchim RSI + sqrt(1 + 2
    gchim RSI' + (vgte/vl)^2))`` (``RSI'``: the card's RSI without its temperature coefficients, as
    ngspice writes it), limited by ``imax = q NMAX VS W`` the same way; ``vgte`` a smooth ``max(vgt, 2
    vt)``; the permittivity ``EPSI``. Arguments and returns as :func:`mesa2_channel`.
    """
    vt = p["vt"]
    vgt, etavth = _mode_bias(vg, w, p)
    mu = p["mu"]
    vl = p["vs"] / mu * p["l"]
    u = 0.5 * vgt / vt - 1.0
    vgte = vt * (2.0 + u + np.sqrt(p["delta2"] + u * u))
    b = np.exp(vgt / etavth)
    nsm = 2.0 * p["n0"] * np.log(1.0 + 0.5 * b)
    off = ~(nsm.real >= NS_FLOOR)
    nsm = np.where(off, 1.0, nsm)  # (off: any positive value, replaced below)
    gamma = p["gamma"]
    c = (nsm / p["nmax"]) ** gamma
    ns = nsm / (1.0 + c) ** (1.0 / gamma)
    gchi = p["gchi0"] * mu * ns
    gch = gchi / (1.0 + gchi * p["rt"])
    gchim = p["gchi0"] * mu * nsm
    h = np.sqrt(1.0 + 2.0 * gchim * p["rsi0"] + vgte * vgte / (vl * vl))
    isatm = gchim * vgte / (1.0 + gchim * p["rsi"] + h)
    isat = isatm / (1.0 + (isatm / p["imax"]) ** gamma) ** (1.0 / gamma)
    cgcm = 1.0 / (p["cgca"] + p["cgcb"] * np.exp(-vgt / etavth))
    cgc = p["wl"] * cgcm / (1.0 + c) ** (1.0 + 1.0 / gamma)
    i, cgs, cgd = _saturation(gch, isat, w, p["lambda"], p["mc"], p["m"], cgc, p["cf"])
    zero = 0.0 * vg
    return (np.where(off, zero, i), np.where(off, p["cf"] + zero, cgs), np.where(off, p["cf"] + zero, cgd))


#: Each level's mode function.
CHANNELS = {2: mesa2_channel, 3: mesa3_channel, 4: mesa4_channel}
#: The MESA levels netdae evaluates (ngspice's 2, 3 and 4: one source file, three channel models).
LEVELS = tuple(CHANNELS)


def mesa_channel(vg, w, p):
    """The mode's current and capacitances of every instance at its own level (:data:`CHANNELS`).

    ``p["level"]`` chooses each instance's equations; only the levels present are evaluated.
    Arguments and returns as :func:`mesa2_channel`.
    """
    level = np.broadcast_to(p["level"], np.broadcast(vg, p["level"]).shape)
    present = [lv for lv in LEVELS if np.any(level == lv)]
    if len(present) == 1:
        return CHANNELS[present[0]](vg, w, p)
    out = [np.zeros(level.shape, dtype=np.result_type(vg, w, float)) for _ in range(3)]
    for lv in present:
        parts = CHANNELS[lv](vg, w, p)
        for k in range(3):
            out[k] = np.where(level == lv, parts[k], out[k])
    return tuple(out)


def gate_diode(v, csat, ggrwl, vte, vtn, dl):
    """A gate diode's current (GMIN excluded) at ``v`` (float or complex, for the complex step).

    ``csat (exp(v/vte) - 1) + ggrwl v exp(-dl v/vtn)`` with ``vte = N vt`` and ``vtn = vt``.
    """
    return csat * (np.exp(v / vte) - 1.0) + ggrwl * v * np.exp(-dl * v / vtn)


def _read_params(model: Model) -> dict:
    """The card's values as ngspice stores them (PHIB in joule, temperatures in kelvin)."""
    mv = MESA_PARAMETERS.read(model)
    out = {k: mv[k] for k in MESA_PARAMETERS.defaults if MESA_PARAMETERS.defaults[k] is not None}
    for key in ("lambdahf", "tlambda", "teta0", "tf"):
        out[key] = mv.get(key, math.nan)
    for key in ("tlambda", "teta0", "teta1", "tmu", "tf"):
        out[key] = out[key] + KELVIN  # ngspice reads these in Celsius and stores kelvin
    for key, default in (("tlambda", _HUGE), ("teta0", _HUGE)):
        if not math.isfinite(out[key]):
            out[key] = default
    out["phib"] *= CHARGE
    out["phib1"] *= CHARGE
    return out


class MesaFamily(GateJunctionLimits, DeviceFamily):
    """All MESA MESFETs of a circuit (levels 2, 3, 4, mixed), evaluated in one vectorised pass.

    Raises
    ------
    CircuitError
        Missing or mistyped model, non-positive ``l``, ``w`` or ``m``, non-zero ``KS``.
    NetlistError
        A level other than 2, 3 or 4 (elaboration refuses it first, naming the levels that run).
    """

    limits_from_point = True

    shareable = True

    def __init__(self, elements, circuit) -> None:
        super().__init__(elements, circuit)
        opts = circuit.options
        self.gmin = float(opts.gmin)
        tnom = opts.tnom + KELVIN
        rows = []
        for el in self.elements:
            model = resolve_model(el, circuit, ("nmf", "pmf"))
            level = model.params.get("level", 2.0)
            if level not in LEVELS:
                raise NetlistError(f"{el.name}: model {model.name}: MESFET level {level:g} is not a level of "
                                   "ngspice's MESA", model.locations.get("level", model.location),
                                   expected="a MESA model of level " + ", ".join(f"{lv}" for lv in LEVELS))
            mv = _read_params(model)
            if mv["ks"] != 0.0:
                raise CircuitError(f"{el.name}: model {model.name}: KS={mv['ks']:g} (sidegating through the "
                                   "source node's absolute voltage) is not implemented by netdae",
                                   elements=(el.name,), hint="remove KS (ngspice's default is 0)", location=el.location)
            if len(el.nodes) != 3:
                raise CircuitError(f"{el.name}: a MESFET has 3 nodes (d g s)", elements=(el.name,),
                                   location=el.location)
            inst = instance_values(el, _INSTANCE, "MESFET (MESA)")
            temp = opts.temp + KELVIN + inst["dtemp"]
            row = dict(mv)
            row["ts"] = inst["ts"] + KELVIN if "ts" in inst else temp
            row["td"] = inst["td"] + KELVIN if "td" in inst else temp
            if not math.isfinite(row["tf"]):
                row["tf"] = opts.temp + KELVIN
            row["tnom"] = tnom
            row["l"], row["w"], row["mult"], row["off"] = inst["l"], inst["w"], inst["m"], inst["off"]
            require_positive(el, row, (("l", "l"), ("w", "w"), ("mult", "m")))
            rows.append(row)
        self._setup(rows)

    def _setup(self, rows) -> None:
        g = lambda name: gather(rows, name)  # noqa: E731
        ts, td, tnom = g("ts"), g("td"), g("tnom")
        length, width = g("l"), g("w")
        vt = K_OVER_Q * ts
        self.vts, self.vtd = vt, K_OVER_Q * td
        n = g("n")
        self.vtes, self.vted = n * self.vts, n * self.vtd
        mu = g("mu") * (ts / g("tmu")) ** g("xtm0")
        mupo = g("mu1") * (g("tmu") / ts) ** g("xtm1") + g("mu2") * (g("tmu") / ts) ** g("xtm2")
        plain = (g("mu1") == 0.0) & (g("mu2") == 0.0)
        mu = np.where(plain, mu, 1.0 / (1.0 / mu + 1.0 / np.where(plain, 1.0, mupo)))
        d, du, th = g("d"), g("du"), g("th")
        level = g("level")
        two = level == 2.0
        # pinch-off: level 2's uniform layer; levels 3, 4: the undoped layer's and the delta layer's
        vpou = CHARGE * g("ndu") * du * du / 2.0 / EPS_GAAS
        vpod = CHARGE * g("ndelta") * th * (2.0 * du + th) / 2.0 / EPS_GAAS
        vpo = np.where(two, CHARGE * g("nd") * d * d / 2.0 / EPS_GAAS, vpou + vpod)
        eta = g("eta") * (1.0 + ts / g("teta0")) + g("teta1") / ts
        epsi = g("epsi")
        n0 = np.where(level == 4.0, epsi * eta * vt / 2.0 / CHARGE / d,
                      EPS_GAAS * eta * vt / CHARGE / np.where(level == 3.0, du, d))
        self.vto = g("vto") - g("tvto") * (ts - tnom)
        phib = g("phib") - g("phib1") * (ts - tnom)
        lw = length * width
        self.csatfs = 0.5 * g("astar") * ts * ts * np.exp(-phib / (BOLTZMANN * ts)) * lw
        self.csatfd = 0.5 * g("astar") * td * td * np.exp(-phib / (BOLTZMANN * td)) * lw
        self.ggrwl = g("ggr") * lw * np.exp(g("xchi") * (ts - tnom))
        self.dl = g("del")
        with np.errstate(divide="ignore"):
            self.vcrits = np.where(self.csatfs != 0.0, self.vts * np.log(self.vts / (math.sqrt(2.0) * self.csatfs)),
                                   _HUGE)
            self.vcritd = np.where(self.csatfd != 0.0, self.vtd * np.log(self.vtd / (math.sqrt(2.0) * self.csatfd)),
                                   _HUGE)

        def scaled(r, t):
            dt = t - tnom
            return np.where(r != 0.0, r * quadratic_factor(g("rtc1"), g("rtc2"), dt), 0.0)

        def conductance(r):
            nz = r != 0.0
            return np.where(nz, 1.0 / np.where(nz, r, 1.0), 0.0)

        self.mult = g("mult")
        m = self.mult
        self.gd = conductance(scaled(g("rd"), td)) * m
        self.gs = conductance(scaled(g("rs"), ts)) * m
        self.gg = conductance(scaled(g("rg"), ts)) * m
        self.gi = conductance(scaled(g("ri"), ts)) * m
        self.gf = conductance(scaled(g("rf"), td)) * m
        rsi, rdi = scaled(g("rsi"), ts), scaled(g("rdi"), td)
        self.ag = g("ag")
        self.channel = {
            "vt": vt, "eta": eta, "vpo": vpo, "vto": self.vto, "vsigmat": g("vsigmat"), "vsigma": g("vsigma"),
            "sigma0": g("sigma0"), "mu": mu, "theta": g("theta"), "vs": g("vs"), "l": length,
            "beta": 2.0 * EPS_GAAS * g("vs") * g("zeta") * width / d, "delta2": g("delta") ** 2, "nd": g("nd"),
            "d": d, "n0": n0, "gchi0": CHARGE * width / length, "rt": rsi + rdi, "rsi": rsi, "tc": g("tc"),
            "isatb0": CHARGE * n0 * vt * width / length, "mc": g("mc"), "m": g("m"), "alpha": g("alpha"),
            "lambda": g("lambda") * (1.0 - ts / g("tlambda")), "wl_eps_d": width * length * EPS_GAAS / d,
            "cf": 0.5 * np.where(level == 4.0, epsi, EPS_GAAS) * width,
            # levels 3 and 4
            "level": level, "beta0": g("beta"), "vpod": vpod, "vpou": vpou, "ndelta": g("ndelta"), "th": th,
            "ndu": g("ndu"), "du": du, "nsb0": EPS_GAAS * eta * vt / CHARGE / (du + th), "wl": width * length,
            "nmax": g("nmax"), "gamma": g("gamma"), "imax": CHARGE * g("nmax") * g("vs") * width,
            "rsi0": g("rsi"), "cgca": d / (g("cas") * epsi), "cgcb": eta * vt / (CHARGE * n0 * g("cbs")),
        }
        self._columns = {k: np.asarray(v)[:, None] for k, v in self.channel.items()}
        self.off = g("off") != 0.0
        self.lim_vt = np.concatenate([self.vtes, self.vted])
        self.lim_vcrit = np.concatenate([self.vcrits, self.vcritd])
        self.lim_vto = np.tile(self.vto, 2)

    # -- topology ----------------------------------------------------------
    def add_nodes(self, layout) -> None:
        els = self.elements
        self.d, self.g, self.s = (layout.nodes_of([el.nodes[i] for el in els]) for i in range(3))
        self.di = series_nodes(layout, els, self.d, self.gd, "drain")
        self.si = series_nodes(layout, els, self.s, self.gs, "source")
        self.gi_node = series_nodes(layout, els, self.g, self.gg, "gate")
        self.sii = series_nodes(layout, els, self.si, self.gi, "gs")
        self.dii = series_nodes(layout, els, self.di, self.gf, "gd")

    def coordinates(self, layout):
        gp = self.gi_node
        controls = [(gp, self.si), (gp, self.di), (gp, self.sii), (gp, self.dii), (self.d, self.di),
                    (self.s, self.si), (self.g, gp), (self.sii, self.si), (self.dii, self.di)]
        currents = [(self.di, self.si), (gp, self.si), (gp, self.di), (self.d, self.di), (self.s, self.si),
                    (self.g, gp), (self.sii, self.si), (self.dii, self.di)]
        charges = [(gp, self.sii), (gp, self.dii)]
        self.stamps = BranchStamps(len(self.elements), controls, currents, charges, _CURRENT_DEPS, _CHARGE_DEPS)
        return self.stamps.coordinates()

    def bind(self, slots: SlotMap, n: int) -> None:
        self.stamps.bind(slots, n)
        count = len(self.elements)
        self._dcur = np.zeros((len(_CURRENT_DEPS), count))
        for j, gr in zip(range(4, 9), (self.gd, self.gs, self.gg, self.gi, self.gf)):
            self._dcur[j] = gr


    # -- the model ---------------------------------------------------------
    def _channel(self, vgs, vgd, p=None):
        """Current d'->s' (one device, no AG) and the capacitances (cgs, cgd) at (vgs, vgd), any dtype.

        ``p``: the constants shaped to broadcast with the voltages (default :attr:`channel`).
        """
        vds = vgs - vgd
        inverse = vds.real < 0.0
        vg = np.where(inverse, vgd, vgs)
        w = np.where(inverse, -vds, vds)
        i, cgs, cgd = mesa_channel(vg, w, self.channel if p is None else p)
        return np.where(inverse, -i, i), np.where(inverse, cgd, cgs), np.where(inverse, cgs, cgd)

    def _gate_charges(self, vgs, vgd, vgspp, vgdpp):
        """The channel's gate charges: ngspice's capacitances integrated along the gate voltage (any dtype).

        ``qgs = CF vgs'' + int Cch_gs du`` from deep below threshold (where the channel's share of the
        capacitance is below ``exp(-40)`` of its scale) to ``vgs''`` with the gate alone moving (``vds`` and
        the offsets ``vgs - vgs''``, ``vgd - vgd''`` held), the same for ``qgd``; composite Gauss-Legendre
        (:data:`QUAD_PANELS` panels of :data:`QUAD_NODES` points).
        """
        p = self.channel
        col = self._columns
        vds = vgs - vgd
        # the start and its dependence on the bias, kept in the complex step: the rule's nodes then move
        # with the bias as they do in real arithmetic (the Jacobian is the derivative of this quadrature)
        low = self.vto - OFF_DEPTH * p["eta"] * p["vt"] - np.abs(p["sigma0"]) * np.where(vds.real < 0.0, -vds, vds)
        out = []
        for branch, (far, here, ahead) in enumerate(((vgspp, vgs, -vds), (vgdpp, vgd, vds))):
            shift = here - far  # the branch's control less the charge's own voltage (RI, RF)
            below = low - shift - np.where(ahead.real > 0.0, ahead, 0.0 * ahead)
            start = np.where(below.real < far.real, below, far)
            width = (far - start) / QUAD_PANELS
            u = start[..., None] + width[..., None] * QUAD_ABSCISSAE
            gs_u = u + (shift if branch == 0 else shift + vds)[..., None]
            _, cgs, cgd = self._channel(gs_u, gs_u - vds[..., None], col)
            c = (cgs if branch == 0 else cgd) - col["cf"]
            out.append(p["cf"] * far + width * (c * QUAD_WEIGHTS).sum(axis=-1))
        return out[0], out[1]

    def _diodes(self, vgs, vgd):
        igs = gate_diode(vgs, self.csatfs, self.ggrwl, self.vtes, self.vts, self.dl) + self.gmin * vgs
        igd = gate_diode(vgd, self.csatfd, self.ggrwl, self.vted, self.vtd, self.dl) + self.gmin * vgd
        return igs, igd

    def dc(self, vgs, vgd):
        """Currents, capacitances and their derivatives at (vgs, vgd), one device (``m`` excluded).

        Returns
        -------
        dict of ndarray
            ``ich`` (d' to s', AG's term included) with ``ich_vgs``, ``ich_vgd``; ``igs``, ``ggs``,
            ``igd``, ``ggd``; ``cgs``, ``cgd`` with their derivatives ``cgs_vgs`` ...; ``cdrain``
            (the channel alone) with ngspice's mode derivatives ``gm``, ``gds``.
        """
        vgs = np.asarray(vgs, dtype=float)
        vgd = np.asarray(vgd, dtype=float)
        h = STEP
        with np.errstate(all="ignore"):
            i0, cs0, cd0 = self._channel(vgs, vgd)
            i1, cs1, cd1 = self._channel(vgs + 1j * h, vgd + 0j)
            i2, cs2, cd2 = self._channel(vgs + 0j, vgd + 1j * h)
            igs, igd = self._diodes(vgs, vgd)
            ggs = self._diodes(vgs + 1j * h, vgd)[0].imag / h
            ggd = self._diodes(vgs, vgd + 1j * h)[1].imag / h
        out = {"cdrain": i0.real, "cd_vgs": i1.imag / h, "cd_vgd": i2.imag / h, "igs": igs, "ggs": ggs,
               "igd": igd, "ggd": ggd, "cgs": cs0.real, "cgd": cd0.real, "cgs_vgs": cs1.imag / h,
               "cgs_vgd": cs2.imag / h, "cgd_vgs": cd1.imag / h, "cgd_vgd": cd2.imag / h}
        ag = self.ag
        out["ich"] = out["cdrain"] - ag * (igs - igd)
        out["ich_vgs"] = out["cd_vgs"] - ag * ggs
        out["ich_vgd"] = out["cd_vgd"] + ag * ggd
        # ngspice's gm, gds: derivatives to the mode's gate voltage and |vds| (normal mode: to vgs and vds)
        fwd = vgs - vgd >= 0.0
        d_vg = np.where(fwd, out["cd_vgs"] + out["cd_vgd"], -(out["cd_vgs"] + out["cd_vgd"]))
        out["gm"] = d_vg
        out["gds"] = np.where(fwd, -out["cd_vgd"], -out["cd_vgs"])
        return out

    def charges(self, vgs, vgd, vgspp, vgdpp):
        """The gate charges (one device) and their derivatives to (vgs'', vgs, vgd) and (vgd'', vgs, vgd).

        Returns
        -------
        qgs, qgd : ndarray
        dqgs, dqgd : tuple of three ndarray
        """
        h = STEP
        args = [np.asarray(a, dtype=float) + 0j for a in (vgs, vgd, vgspp, vgdpp)]
        with np.errstate(all="ignore"):
            qgs, qgd = self._gate_charges(*args)
            slopes = []
            for k in range(4):
                stepped = list(args)
                stepped[k] = stepped[k] + 1j * h
                a, b = self._gate_charges(*stepped)
                slopes.append((a.imag / h, b.imag / h))
        return (qgs.real, qgd.real, (slopes[2][0], slopes[0][0], slopes[1][0]),
                (slopes[3][1], slopes[0][1], slopes[1][1]))

    def quantities(self, x, dxdt=None):
        """ngspice's MESA quantities (``@z1[cd]``, ``@z1[gm]`` ...) at solutions ``x``, shape (T, N) each.

        ``cd`` is ngspice's drain current (channel less gate-drain diode, as ``@z1[cd]``: without
        AG's term, which the terminal current carries), ``cg`` the gate current, ``cs`` ``-(cd + cg)``,
        all into the device, times ``m``; ``gm``, ``gds`` the mode's derivatives of the channel current, ``ggs``, ``ggd`` the
        diodes' conductances, ``cgs``, ``cgdq`` ngspice's gate capacitances (what ngspice prints as
        ``@z1[qgs]``, ``@z1[qgd]`` after an operating point), ``qgs``, ``qgd`` netdae's gate charges.
        """
        v = self.stamps.voltages_at(x)
        vgs, vgd = v[_VGS], v[_VGD]
        r = self.dc(vgs, vgd)
        m = self.mult
        cd = (r["cdrain"] - r["igd"]) * m  # ngspice's cd: without AG's term
        cg = (r["igs"] + r["igd"]) * m
        qgs, qgd, dqs, dqd = self.charges(vgs, vgd, v[_VGSPP], v[_VGDPP])
        if dxdt is not None:
            dv = self.stamps.voltages_at(dxdt)
            i_qgs = (dqs[0] * dv[_VGSPP] + dqs[1] * dv[_VGS] + dqs[2] * dv[_VGD]) * m
            i_qgd = (dqd[0] * dv[_VGDPP] + dqd[1] * dv[_VGS] + dqd[2] * dv[_VGD]) * m
            cg = cg + i_qgs + i_qgd
            cd = cd - i_qgd
        return {"cd": cd, "cg": cg, "cs": -(cd + cg), "vgs": vgs, "vgd": vgd, "gm": r["gm"] * m,
                "gds": r["gds"] * m, "ggs": r["ggs"] * m, "ggd": r["ggd"] * m, "cgs": r["cgs"] * m,
                "cgdq": r["cgd"] * m, "qgs": qgs * m, "qgd": qgd * m}

    def compiled(self, slots: SlotMap, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Pack the family for :func:`netdae.devices.kernels.mesa.eval_mesa` (after ``bind``).

        Returns
        -------
        par : ndarray, shape (N, kernels.mesa.N_PAR)
        idx : ndarray of int64, shape (N, kernels.mesa.N_IDX)
        vold0 : ndarray, shape (N, 2)
            The initial state's (vgs, vgd) (:meth:`initial_state`).
        """
        from .kernels import mesa as km
        from .kernels.packing import columns, dependence_blocks, node_columns

        count = len(self.elements)
        par = columns(count, km.N_PAR, {
            **{col: self.channel[key] for col, key in enumerate(km.CHANNEL_KEYS)},
            km.P_MULT: self.mult, km.P_CSATFS: self.csatfs, km.P_CSATFD: self.csatfd, km.P_GGRWL: self.ggrwl,
            km.P_VTES: self.vtes, km.P_VTED: self.vted, km.P_VTS: self.vts, km.P_VTD: self.vtd, km.P_DEL: self.dl,
            km.P_AG: self.ag, km.P_GMIN: self.gmin, km.P_VCRITS: self.vcrits, km.P_VCRITD: self.vcritd,
            km.P_GD: self.gd, km.P_GS: self.gs, km.P_GG: self.gg, km.P_GI: self.gi, km.P_GF: self.gf,
        })
        idx = node_columns(count, km.N_IDX, {
            km.I_D: self.d, km.I_G: self.g, km.I_S: self.s, km.I_DP: self.di, km.I_SP: self.si,
            km.I_GP: self.gi_node, km.I_SPP: self.sii, km.I_DPP: self.dii}, n)
        st = self.stamps
        controls = list(zip(st.ctrl_p, st.ctrl_m))
        dependence_blocks(idx, km.S_CUR, slots, _CURRENT_DEPS, list(zip(st.cur_a, st.cur_b)), controls)
        dependence_blocks(idx, km.S_CHG, slots, _CHARGE_DEPS, list(zip(st.chg_a, st.chg_b)), controls)
        return par, idx, self.initial_state().v.T.copy()

    def evaluate(self, x, t, acc: Accumulator, state, jacobian):
        v = self.stamps.voltages(x)
        vn_x = v[:2]
        with np.errstate(all="ignore"):
            start = starting_voltages(state, x, vn_x)
            if start is not None:
                vn, changed = start
            else:
                vn, changed = self.limit(vn_x, state.v)
            vgs, vgd = vn
            r = self.dc(vgs, vgd)
            m = self.mult
            count = vgs.size
            cur = np.empty((8, count))
            cur[_ID] = r["ich"] * m
            cur[_IGS] = r["igs"] * m
            cur[_IGD] = r["igd"] * m
            cur[_IRD] = self.gd * v[_VRD]
            cur[_IRS] = self.gs * v[_VRS]
            cur[_IRG] = self.gg * v[_VRG]
            cur[_IRI] = self.gi * v[_VRI]
            cur[_IRF] = self.gf * v[_VRF]
            dcur = self._dcur
            dcur[0] = r["ich_vgs"] * m
            dcur[1] = r["ich_vgd"] * m
            dcur[2] = r["ggs"] * m
            dcur[3] = r["ggd"] * m
            # the charges' far ends: vgs'' and vgd'' (equal to the limited vgs, vgd without RI, RF)
            vspp = np.where(self.gi > 0.0, v[_VGSPP], vgs)
            vdpp = np.where(self.gf > 0.0, v[_VGDPP], vgd)
            qgs, qgd, dqs, dqd = self.charges(vgs, vgd, vspp, vdpp)
            q = np.stack([qgs * m, qgd * m])
            dq = np.stack([dqs[0] * m, dqs[1] * m, dqs[2] * m, dqd[0] * m, dqd[1] * m, dqd[2] * m])
            delta = None
            if changed:
                acc.limited = True
                delta = np.zeros_like(v)
                delta[:2] = v[:2] - vn
                delta[_VGSPP] = np.where(self.gi > 0.0, 0.0, delta[0])
                delta[_VGDPP] = np.where(self.gf > 0.0, 0.0, delta[1])
            self.stamps.add(acc, cur, dcur, q, dq, delta=delta, jacobian=jacobian)
            total = float(cur.sum() + dcur.sum() + q.sum() + dq.sum())
            if not math.isfinite(total):
                acc.ok = False
        return LimitState(vn)
