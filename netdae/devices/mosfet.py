"""The Shichman-Hodges MOSFET (SPICE level 1, NMOS and PMOS) as ngspice 39 computes it.

Syntax: ``Mname d g s b model [l=L] [w=W] [ad=] [as=] [pd=] [ps=] [nrd=] [nrs=] [m=M] [off]
[icvds=] [icvgs=] [icvbs=] [temp=T] [dtemp=dT]`` with ``.model name NMOS|PMOS (LEVEL=1 VTO KP
GAMMA PHI LAMBDA RD RS CBD CBS IS PB CGSO CGDO CGBO RSH CJ MJ CJSW MJSW JS TOX LD U0 FC NSUB TPG
NSS TNOM)``. Defaults of L, W, AD, AS: ``.options defl defw defad defas`` (ngspice: 100 um,
100 um, 0, 0).

Equations (type-normalised: for a PMOS every voltage and current changes sign)
----------------------------------------------------------------------------
``mos1load.c``: the device runs in normal mode (``vds >= 0``) or with
source and drain exchanged. With ``vgs'``, ``vbs'``, ``vds' >= 0`` the
voltages of that mode::

    sarg = sqrt(PHI - vbs')                        vbs' <= 0
         = max(0, sqrt(PHI) - vbs' / (2 sqrt(PHI)))  vbs' > 0   (ngspice's clamp)
    von  = VBI + GAMMA sarg,   vgst = vgs' - von,  beta = KP m W / (L - 2 LD)
    id   = 0                                        vgst <= 0
         = beta (1 + LAMBDA vds') vgst^2 / 2        0 < vgst <= vds'
         = beta (1 + LAMBDA vds') vds' (vgst - vds'/2)   otherwise

flowing from the mode's drain to its source. The body-effect derivative is
the exact one (ngspice's ``gmbs`` uses ``GAMMA / (2 sarg)`` also for
``vbs' > 0``, a slightly different Jacobian with the same solution).
Bulk junctions: ``ibs = IS_s (exp(vbs/vt) - 1) + GMIN vbs`` for
``vbs > -3 vt``, ``GMIN vbs - IS_s`` below (the same for bd), ``IS_s = m IS``
or ``m JS AS`` (``m JS AD`` for the drain) when JS, AD and AS are non-zero.

Charges (netdae is charge based, ``d/dt q(x)``):

- bulk junctions: ``qdep`` of :class:`~netdae.devices.junction.Depletion`
  with ``CBD`` (or ``CJ AD``) and ``CJSW PD`` (MJ, MJSW, PB, FC), times m,
  exactly ngspice's charge;
- overlaps: ``CGSO m W vgs``, ``CGDO m W vgd``, ``CGBO m Leff vgb``, exact;
- intrinsic gate charge when TOX is given (``Cox = 3.9 eps0 / TOX m W Leff``):
  ngspice uses Meyer's capacitances, which are not the derivatives of any
  charge and do not conserve charge. netdae uses the charge-conserving
  :func:`gate_charges`: in strong inversion the long-channel gate charge
  ``(2/3) Cox (A^2 + AB + B^2)/(A + B)`` (``A = vgs' - von``,
  ``B = max(vgd' - von, 0)``), whose derivatives are exactly Meyer's
  ``Cgs``/``Cgd``, split between source and drain by the Ward-Dutton
  partition (40/60 in saturation, 50/50 at vds = 0); below threshold a
  gate-bulk charge whose derivative is Meyer's total gate capacitance
  (``Cox`` in accumulation, ``-Cox vgst/PHI`` in depletion, ramping to
  ``2/3 Cox`` at threshold). See ``docs/devices.md`` for the measured effect.

Temperature (``mos1temp.c``): ``KP (T/Tnom)^-1.5``, ``PHI`` and ``VBI`` by
the band-gap formulas, ``IS``/``JS`` times ``exp(-Eg(T)/vt + Eg(Tnom)/vt_nom)``,
junction capacitances and ``PB`` by
:func:`~netdae.devices.junction.scale_junction`. With TOX and no KP:
``KP = U0 Cox 1e-4``; with NSUB: PHI, GAMMA and VTO as ngspice derives them.

Noise (``.noise``, :meth:`MosfetFamily.noise`, ngspice 39's ``mos1noi.c``):
thermal noise of RD and RS, channel thermal noise ``4 k T (2/3) |gm|``
and flicker noise ``KF |id|^AF / (f W m Leff Cox^2)`` (``Cox`` of
``TOX = 1e-7`` m when TOX is not given; ngspice 39's MOS1 has no NLEV).

Newton: ngspice's ``fetlim`` on vgs (or vgd in reverse mode) against the
previous threshold, ``limvds`` on vds, ``pnjlim`` on vbs (or vbd); the first
iteration from a zero iterate starts at ``vbs = -1``, ``vgs = VTO(T)``,
``vds = 0`` (or ``icvds``, ``icvgs``, ``icvbs``; all 0 for ``off``).
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import CircuitError
from .base import (Accumulator, DeviceFamily, NoiseSources, SlotMap, flicker, noise_sources, series_nodes,
                   start_from_device_ic, thermal)
from .companion import BranchStamps, LimitState, starting_voltages
from .junction import (
    CHARGE,
    K_OVER_Q,
    KELVIN,
    REFTEMP,
    Depletion,
    energy_gap,
    fet_mode_limit,
    pb_factor,
    pnjlim,
    scale_junction,
)
from .modelcard import GRADING_LIMIT, ParameterTable, gather, instance_values, require_positive, resolve_model

__all__ = ["MosfetFamily", "MOS1_PARAMETERS", "gate_charges", "drain_current"]

MOS1_PARAMETERS = ParameterTable(
    "MOSFET (level 1)",
    defaults={
        "level": 1.0, "vto": 0.0, "kp": 2e-5, "gamma": 0.0, "phi": 0.6, "lambda": 0.0, "rd": 0.0, "rs": 0.0,
        "cbd": 0.0, "cbs": 0.0, "is": 1e-14, "pb": 0.8, "cgso": 0.0, "cgdo": 0.0, "cgbo": 0.0, "rsh": 0.0,
        "cj": 0.0, "mj": 0.5, "cjsw": 0.0, "mjsw": 0.5, "js": 0.0, "tox": 0.0, "ld": 0.0, "u0": 600.0,
        "fc": 0.5, "nsub": None, "tpg": 1.0, "nss": 0.0, "tnom": None,
    },
    aliases={"vt0": "vto", "uo": "u0", "tref": "tnom"},
    inert=frozenset({"nmos", "pmos", "kf", "af"}),
    family="mosfet",
    grading=frozenset({"mj", "mjsw"}),
    grading_max=GRADING_LIMIT,
    fc_below_one=True,
)

_INSTANCE = {"l": None, "w": None, "ad": None, "as": None, "pd": 0.0, "ps": 0.0, "nrd": 1.0, "nrs": 1.0,
             "m": 1.0, "off": 0.0, "icvds": 0.0, "icvgs": 0.0, "icvbs": 0.0, "temp": None, "dtemp": 0.0}
#: ngspice's default L, W [m], AD, AS [m^2] (``.options defl defw defad defas``).
DEFAULT_L = 1e-4
DEFAULT_W = 1e-4
#: Permittivities ngspice's MOS1 uses: SiO2 (3.9 eps0) and Si (11.7 eps0) [F/m].
EPS0_MOS1 = 8.854214871e-12
EPS_OX = 3.9 * EPS0_MOS1
EPS_SI = 11.70 * EPS0_MOS1
#: Intrinsic carrier density of silicon in ngspice's PHI formula [1/m^3], and cm^-3 -> m^-3.
NI_SI = 1.45e16
PER_CM3 = 1e6
PER_CM2 = 1e4
#: Mobility in cm^2/Vs times this gives m^2/Vs.
CM2_TO_M2 = 1e-4
#: Smallest PHI ngspice derives from NSUB [V], and its work-function constants [eV].
PHI_MIN = 0.1
WORKFUNCTION_METAL = 3.2
WORKFUNCTION_SI = 3.25
#: The oxide thickness ngspice's MOS1 noise assumes when TOX is not given [m].
NOISE_TOX = 1e-7
#: ngspice's cap on exp() arguments of the bulk diodes.
MAX_EXP_ARG = 709.0
#: fetlim and limvds leave every step of at most this size unchanged [V] (devsup.c: their
#: smallest thresholds are 0.5 V), so they are skipped when no control moves further.
FET_QUIET_STEP = 0.5
#: Reverse-bias knee of the bulk diodes (3 vt) and the initial vbs of MODEINITJCT [V].
_BULK_KNEE = 3.0
_INIT_VBS = -1.0

# controls: vgs, vds, vbs (type-normalised internally), the two series resistors
_VGS, _VDS, _VBS, _VRD, _VRS = range(5)
_ID, _IBS, _IBD, _IRD, _IRS = range(5)
_CURRENT_DEPS = [(_ID, _VGS), (_ID, _VDS), (_ID, _VBS), (_IBS, _VBS), (_IBD, _VBS), (_IBD, _VDS),
                 (_IRD, _VRD), (_IRS, _VRS)]
# charge branches referenced to the internal source: q_g, q_d, q_b on (node, s')
_CHARGE_DEPS = [(j, k) for j in range(3) for k in (_VGS, _VDS, _VBS)]


def _first(a, b):
    """The normal-mode choice of a mode-dependent quantity (every device in normal mode)."""
    return a


def drain_current(vgs, vds, vbs, beta, lam, vbi, gamma, phi):
    """Level-1 drain current in the mode's own (normalised) voltages, ``vds >= 0``.

    Parameters
    ----------
    vgs, vds, vbs : ndarray
        Gate-source, drain-source (>= 0) and bulk-source voltage of the mode.
    beta, lam, vbi, gamma, phi : ndarray
        ``KP W/Leff`` (m included), LAMBDA, built-in voltage (type-normalised
        ``VBI``), GAMMA, PHI (at temperature).

    Returns
    -------
    cdrain, gm, gds, gmbs, von, dvon : ndarray
        Current and its derivatives to vgs, vds, vbs; threshold voltage and
        its derivative to vbs.
    """
    sphi = np.sqrt(phi)
    neg = vbs <= 0.0
    sarg_neg = np.sqrt(phi - np.where(neg, vbs, 0.0))
    sarg_pos = sphi - vbs / (sphi + sphi)
    sarg = np.where(neg, sarg_neg, np.maximum(0.0, sarg_pos))
    dsarg = np.where(neg, -0.5 / sarg_neg, np.where(sarg_pos > 0.0, -0.5 / sphi, 0.0))
    von = vbi + gamma * sarg
    dvon = gamma * dsarg
    vgst = vgs - von
    betap = beta * (1.0 + lam * vds)
    on = vgst > 0.0
    sat = on & (vgst <= vds)
    lin = on & ~sat
    cdrain = np.where(sat, 0.5 * betap * vgst * vgst, np.where(lin, betap * vds * (vgst - 0.5 * vds), 0.0))
    gm = np.where(sat, betap * vgst, np.where(lin, betap * vds, 0.0))
    gds = np.where(sat, 0.5 * lam * beta * vgst * vgst,
                   np.where(lin, betap * (vgst - vds) + lam * beta * vds * (vgst - 0.5 * vds), 0.0))
    gmbs = -gm * dvon
    return cdrain, gm, gds, gmbs, von, dvon


def _bulk_function(a, phi):
    """Gate-bulk part of the intrinsic gate charge per Cox, and its derivative, vs vgst ``a``.

    ``F' = 1`` for a <= -PHI, ``-a/PHI`` up to -PHI/2, ``2/3 + a/(3 PHI)`` up to
    0 and 0 above, written with two clipped variables (no branches):
    ``F = min(a + PHI, 0) + G1(u1) - G1(-PHI/2) + G2(u2)`` with
    ``u1 = clip(a, -PHI, -PHI/2)``, ``u2 = clip(a, -PHI/2, 0)``,
    ``G1(u) = -u^2/(2 PHI)``, ``G2(u) = 2u/3 + u^2/(6 PHI)``.
    """
    half = 0.5 * phi
    u1 = np.minimum(np.maximum(a, -phi), -half)
    u2 = np.minimum(np.maximum(a, -half), 0.0)
    f = np.minimum(a + phi, 0.0) + (half * half - u1 * u1) / (2.0 * phi) + u2 * (2.0 / 3.0 + u2 / (6.0 * phi))
    df = (u2 / 3.0 - u1) / phi + (1.0 / 6.0) - (2.0 / 3.0) * (a > 0.0)
    return f, df


def gate_charges(a, b, phi):
    """Charge-conserving intrinsic charges of the level-1 MOSFET, per unit Cox.

    Parameters
    ----------
    a, b : ndarray
        ``vgs' - von`` and ``vgd' - von`` of the mode (``b <= a``).
    phi : ndarray
        Surface potential PHI (at temperature).

    Returns
    -------
    qg, qs, qd, qb : ndarray
        Gate, source, drain and bulk charge divided by Cox (they sum to 0).
    dqg, dqs, dqd : tuple of two ndarray
        Derivatives of qg, qs, qd to ``a`` and ``b`` (``qb = -qg - qs - qd``).

    Notes
    -----
    With ``A = max(a, 0)``, ``B = max(b, 0)`` the channel charge of the
    long-channel model is ``-(2/3)(A^2 + AB + B^2)/(A + B)``; the
    Ward-Dutton partition (charge weighted by the distance from the drain)
    gives the source ``(2/15)(3A^3 + 6A^2 B + 4AB^2 + 2B^3)/(A+B)^2`` of it
    and the drain ``(2/15)(2A^3 + 4A^2 B + 6AB^2 + 3B^3)/(A+B)^2`` (60/40 in
    saturation, halves at B = A). ``d qg/d a`` and ``d qg/d b`` are exactly
    Meyer's ``Cgs``/``Cgd`` in strong inversion. The bulk carries
    ``-F(a)`` with ``F' = 1`` (a <= -PHI), ``-a/PHI`` (down to -PHI/2),
    ``2/3 + a/(3 PHI)`` (up to threshold), Meyer's total gate capacitance
    below threshold.

    Examples
    --------
    >>> qg, qs, qd, qb, *_ = gate_charges(np.array([1.0]), np.array([-1.0]), np.array([0.6]))
    >>> round(float(qg[0]), 15), round(float(qs[0] / (qs[0] + qd[0])), 15)
    (0.666666666666667, 0.6)
    """
    A = np.maximum(a, 0.0)
    B = np.maximum(b, 0.0)
    A2, B2, AB = A * A, B * B, A * B
    s = A + B
    s = s + (s == 0.0)  # A = B = 0 gives 0/1: every numerator below vanishes there
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
    return (p + f, -ps, ps - p, -f, (dp_da + df, dp_db), (-dps_da, -dps_db),
            (dps_da - dp_da, dps_db - dp_db))


class MosfetFamily(DeviceFamily):
    """All level-1 MOSFETs of a circuit, evaluated in one vectorised pass.

    Raises
    ------
    CircuitError
        Missing or mistyped model, unsupported parameter or level, a
        non-positive effective channel length, PHI <= 0, NSUB below ni.
    """

    limits_from_point = True

    shareable = True


    def __init__(self, elements, circuit) -> None:
        super().__init__(elements, circuit)
        opts = circuit.options
        self.gmin = float(opts.gmin)
        defaults = dict(_INSTANCE)
        defaults["l"] = float(opts.extra.get("defl", DEFAULT_L))
        defaults["w"] = float(opts.extra.get("defw", DEFAULT_W))
        defaults["ad"] = float(opts.extra.get("defad", 0.0))
        defaults["as"] = float(opts.extra.get("defas", 0.0))
        rows = []
        for el in self.elements:
            model = resolve_model(el, circuit, ("nmos", "pmos"))
            mv = MOS1_PARAMETERS.read(model)
            if mv["level"] != 1.0:
                raise CircuitError(f"{el.name}: MOSFET model {model.name} has level {mv['level']:g}; "
                                   "netdae implements level 1", elements=(el.name,))
            if len(el.nodes) != 4:
                raise CircuitError(f"{el.name}: a MOSFET has 4 nodes (d g s b)", elements=(el.name,))
            inst = instance_values(el, defaults, "MOSFET")
            row = self._model_row(el, mv, model.type.lower() == "nmos", opts)
            row.update({k: inst[k] for k in ("l", "w", "ad", "as", "pd", "ps", "nrd", "nrs", "off",
                                              "icvds", "icvgs", "icvbs")})
            row["mult"] = inst["m"]
            require_positive(el, row, (("mult", "m"),))
            row["temp"] = inst.get("temp", opts.temp + inst["dtemp"]) + KELVIN
            row["leff"] = row["l"] - 2.0 * row["ld"]
            row["kf"], row["af"] = model.params.get("kf", 0.0), model.params.get("af", 1.0)
            if row["leff"] <= 0.0:
                raise CircuitError(f"{el.name}: effective channel length L - 2 LD = {row['leff']:g} m is not "
                                   f"positive (l = {row['l']:g} m, model {model.name}'s ld = {row['ld']:g} m)",
                                   elements=(el.name,), hint="give l more than twice ld (ngspice 39 warns "
                                   "'effective channel length less than zero' and does not converge)",
                                   location=el.location)
            rows.append(row)
        self._setup(rows)

    @staticmethod
    def _model_row(el, mv, nmos: bool, opts) -> dict:
        """Model values after ngspice's preprocessing (``mos1temp.c``, model part)."""
        row = {k: mv[k] for k in MOS1_PARAMETERS.defaults if k not in ("nsub", "tnom", "level")}
        row["type"] = 1.0 if nmos else -1.0
        row["tnom"] = mv.get("tnom", opts.tnom) + KELVIN
        for key in ("cbd", "cbs", "cj", "cjsw", "rd", "rs", "rsh"):
            row[key + "_given"] = float(mv.given(key))
        if row["phi"] <= 0.0:
            raise CircuitError(f"{el.name}: model {mv.model.name}: PHI must be positive", elements=(el.name,))
        tox = row["tox"]
        row["cox"] = EPS_OX / tox if tox != 0.0 else 0.0
        if row["cox"] and not mv.given("kp"):
            row["kp"] = row["u0"] * row["cox"] * CM2_TO_M2
        if row["cox"] and mv.given("nsub"):
            nsub = mv["nsub"]
            tnom = row["tnom"]
            vtnom = K_OVER_Q * tnom
            egfet1 = float(energy_gap(tnom))
            if nsub * PER_CM3 <= NI_SI:
                at = mv.model.locations.get("nsub", mv.model.location)
                raise CircuitError(f"{el.name}: model {mv.model.name}: nsub={nsub:g} cm^-3 is below the "
                                   f"intrinsic density of silicon ({NI_SI / PER_CM3:.3g} cm^-3)", elements=(el.name,),
                                   hint="check the scale suffix: nsub is in cm^-3 (ngspice 39 stops at it too)",
                                   location=at)
            if not mv.given("phi"):
                row["phi"] = max(PHI_MIN, 2.0 * vtnom * math.log(nsub * PER_CM3 / NI_SI))
            fermis = row["type"] * 0.5 * row["phi"]
            wkfng = WORKFUNCTION_METAL
            if row["tpg"] != 0.0:
                fermig = row["type"] * row["tpg"] * 0.5 * egfet1
                wkfng = WORKFUNCTION_SI + 0.5 * egfet1 - fermig
            wkfngs = wkfng - (WORKFUNCTION_SI + 0.5 * egfet1 + fermis)
            if not mv.given("gamma"):
                row["gamma"] = math.sqrt(2.0 * EPS_SI * CHARGE * nsub * PER_CM3) / row["cox"]
            if not mv.given("vto"):
                vfb = wkfngs - row["nss"] * PER_CM2 * CHARGE / row["cox"]
                row["vto"] = vfb + row["type"] * (row["gamma"] * math.sqrt(row["phi"]) + row["phi"])
        return row

    def _setup(self, rows) -> None:
        g = lambda name: gather(rows, name)  # noqa: E731
        temp, tnom = g("temp"), g("tnom")
        self.type = g("type")
        m = g("mult")
        w, leff = g("w"), g("leff")
        vt = K_OVER_Q * temp
        self.vt = vt
        vtnom = K_OVER_Q * tnom
        ratio = temp / tnom
        egfet, egfet1 = energy_gap(temp), energy_gap(tnom)
        phi = g("phi")
        phio = (phi - pb_factor(tnom)) / (tnom / REFTEMP)
        self.phi = (temp / REFTEMP) * phio + pb_factor(temp)
        for k in np.flatnonzero(~(self.phi > 0.0)):
            # the temperature law of PHI (mos1temp.c) leaves it negative far above tnom: sqrt(PHI) is undefined
            el = self.elements[k]
            raise CircuitError(f"{el.name}: the surface potential PHI at {temp[k] - KELVIN:g} degC is "
                               f"{self.phi[k]:g} V, not positive (PHI = {phi[k]:g} V at tnom = "
                               f"{tnom[k] - KELVIN:g} degC)", elements=(el.name,),
                               hint="the level-1 model's temperature law does not reach this temperature "
                                    "(ngspice 39 computes NaN currents there); check .temp, temp= and dtemp=",
                                    location=el.location)
        gamma = g("gamma")
        self.gamma = gamma
        vbi = g("vto") - self.type * gamma * np.sqrt(phi) + 0.5 * (egfet1 - egfet) + self.type * 0.5 * (self.phi - phi)
        self.vbi_n = vbi * self.type
        self.vto_t = vbi + self.type * gamma * np.sqrt(self.phi)
        self.beta = g("kp") / (ratio * np.sqrt(ratio)) * m * w / leff
        self.lam = g("lambda")
        sat_scale = np.exp(-egfet / vt + egfet1 / vtnom)
        is_t, js_t = g("is") * sat_scale, g("js") * sat_scale
        ad, as_ = g("ad"), g("as")
        use_js = (js_t != 0.0) & (ad != 0.0) & (as_ != 0.0)
        self.isat_d = np.where(use_js, js_t * m * ad, m * is_t)
        self.isat_s = np.where(use_js, js_t * m * as_, m * is_t)
        root2 = math.sqrt(2.0)
        self.vcrit_d = vt * np.log(vt / (root2 * self.isat_d))
        self.vcrit_s = vt * np.log(vt / (root2 * self.isat_s))
        # bulk junction capacitances
        mj, mjsw, pb = g("mj"), g("mjsw"), g("pb")
        cbd, self.pb = scale_junction(g("cbd"), mj, pb, tnom, temp)
        cbs, _ = scale_junction(g("cbs"), mj, pb, tnom, temp)
        cj, _ = scale_junction(g("cj"), mj, pb, tnom, temp)
        cjsw, _ = scale_junction(g("cjsw"), mjsw, pb, tnom, temp)
        cj_given, cjsw_given = g("cj_given") != 0.0, g("cjsw_given") != 0.0
        self.czbd = np.where(g("cbd_given") != 0.0, cbd * m, np.where(cj_given, cj * m * ad, 0.0))
        self.czbs = np.where(g("cbs_given") != 0.0, cbs * m, np.where(cj_given, cj * m * as_, 0.0))
        self.czbdsw = np.where(cjsw_given, cjsw * g("pd") * m, 0.0)
        self.czbssw = np.where(cjsw_given, cjsw * g("ps") * m, 0.0)
        fc = g("fc")
        # the source and drain junctions of all devices stacked: entries [0, N) source, [N, 2N) drain
        pb2, fc2 = np.tile(self.pb, 2), np.tile(fc, 2)
        self.dep_bottom = Depletion(np.concatenate([self.czbs, self.czbd]), pb2, np.tile(mj, 2), fc2)
        self.dep_side = Depletion(np.concatenate([self.czbssw, self.czbdsw]), pb2, np.tile(mjsw, 2), fc2)
        self.isat_sd = np.concatenate([self.isat_s, self.isat_d])
        self.vcrit_sd = np.concatenate([self.vcrit_s, self.vcrit_d])
        self.vt2 = np.tile(vt, 2)
        # overlap and oxide capacitances
        self.cgso = g("cgso") * m * w
        self.cgdo = g("cgdo") * m * w
        self.cgbo = g("cgbo") * m * leff
        self.cox = g("cox") * leff * m * w
        # flicker noise: KF / (W m Leff Cox^2), Cox per area of TOX = 1e-7 m when TOX is not given (mos1noi.c)
        cox_area = np.where(g("cox") == 0.0, EPS_OX / NOISE_TOX, g("cox"))
        kf, size = g("kf"), w * m * leff * cox_area * cox_area
        self.flicker_scale = np.where(kf != 0.0, kf / np.where(size != 0.0, size, 1.0), 0.0)
        self.af = g("af")
        # series resistances (ngspice: RD/RS when given, else RSH times squares)
        self.gd = self._series(g("rd"), g("rd_given"), g("rsh"), g("nrd"), m)
        self.gs = self._series(g("rs"), g("rs_given"), g("rsh"), g("nrs"), m)
        self.off = g("off") != 0.0
        self.ic = np.stack([g("icvgs"), g("icvds"), g("icvbs")]) * self.type
        self.has_charge = bool(self.dep_bottom.active or self.dep_side.active or np.any(self.cgso > 0)
                               or np.any(self.cgdo > 0) or np.any(self.cgbo > 0) or np.any(self.cox > 0))
        self.has_cox = bool(np.any(self.cox > 0))

    @staticmethod
    def _series(r, r_given, rsh, squares, m) -> np.ndarray:
        by_r = np.where(r != 0.0, m / np.where(r != 0.0, r, 1.0), 0.0)
        sheet = rsh * squares
        by_sheet = np.where(sheet != 0.0, m / np.where(sheet != 0.0, sheet, 1.0), 0.0)
        return np.where(r_given != 0.0, by_r, by_sheet)

    def uic_start(self, x: np.ndarray, given: set[int]) -> list[str]:
        """The drain (behind its resistance), gate and bulk at ``icvds``, ``icvgs``, ``icvbs`` above the source
        (behind its resistance), as ngspice 39 starts a level-1 MOSFET under ``uic`` (MOS1icVDS ...)."""
        return start_from_device_ic(self.elements, x, given, self.si,
                                    [("icvds", self.di), ("icvgs", self.g), ("icvbs", self.b)])

    # -- topology ----------------------------------------------------------
    def add_nodes(self, layout) -> None:
        els = self.elements
        self.d, self.g, self.s, self.b = (layout.nodes_of([el.nodes[i] for el in els]) for i in range(4))

        self.di = series_nodes(layout, els, self.d, self.gd, "drain")
        self.si = series_nodes(layout, els, self.s, self.gs, "source")

    def coordinates(self, layout):
        controls = [(self.g, self.si), (self.di, self.si), (self.b, self.si), (self.d, self.di),
                    (self.s, self.si)]
        currents = [(self.di, self.si), (self.b, self.si), (self.b, self.di), (self.d, self.di),
                    (self.s, self.si)]
        charges = [(self.g, self.si), (self.di, self.si), (self.b, self.si)] if self.has_charge else []
        self.stamps = BranchStamps(len(self.elements), controls, currents, charges, _CURRENT_DEPS,
                                   _CHARGE_DEPS if self.has_charge else [])
        return self.stamps.coordinates()

    def bind(self, slots: SlotMap, n: int) -> None:
        self.stamps.bind(slots, n)
        count = len(self.elements)
        self._cur = np.zeros((5, count))
        self._dcur = np.zeros((8, count))
        self._dcur[6], self._dcur[7] = self.gd, self.gs
        rows = 3 if self.has_charge else 0
        self._q = np.zeros((rows, count))
        self._dq = np.zeros((3 * rows, count))
        # derivatives of the overlap charges to (vgs, vds, vbs): constant
        cgs, cgd, cgb = self.cgso, self.cgdo, self.cgbo
        self._dq_overlap = np.stack([cgs + cgd + cgb, -cgd, -cgb, -cgd, cgd, 0.0 * cgd, -cgb, 0.0 * cgb, cgb])

    def junction_nodes(self) -> list[tuple[str, str]]:
        pairs = []
        for el in self.elements:
            d, _, s, b = el.nodes
            pairs += [(d, s), (b, d), (b, s)]
        return pairs

    # -- Newton support ----------------------------------------------------
    def initial_state(self) -> LimitState:
        """SPICE's ``MODEINITJCT``: vbs = -1, vgs = VTO(T), vds = 0 unless icvds/icvgs/icvbs are given."""
        no_ic = ~np.any(self.ic != 0.0, axis=0)
        start = np.where(no_ic, np.stack([self.type * self.vto_t, np.zeros_like(self.phi),
                                          np.full_like(self.phi, _INIT_VBS)]), self.ic)
        start = np.where(self.off, 0.0, start)
        return LimitState(start, initial=True, extra=np.zeros_like(self.phi))

    def limit(self, vn: np.ndarray, state: LimitState) -> tuple[np.ndarray, bool]:
        """ngspice's MOS1 limiting of (vgs, vds, vbs), type-normalised."""
        vgs_x, vds_x, vbs_x = vn
        vgs_o, vds_o, vbs_o = state.v
        von = state.extra
        vgd_x = vgs_x - vds_x
        vgdo = vgs_o - vds_o
        quiet = (np.abs(vn[:2] - state.v[:2]).max() <= FET_QUIET_STEP
                 and np.abs(vgd_x - vgdo).max() <= FET_QUIET_STEP)
        if quiet:
            vgs, vds = vgs_x, vds_x
        else:
            vgs, vds = fet_mode_limit(vgs_x, vds_x, vgs_o, vds_o, von)
        # bulk junction on the side that is the source now
        n = vbs_x.size
        vb_l, _ = pnjlim(np.concatenate([vbs_x, vbs_x - vds_x]), np.concatenate([vbs_o, vbs_o - vds_o]),
                         self.vt2, self.vcrit_sd)
        vbs_l, vbd_l = vb_l[:n], vb_l[n:]
        fwd = vds >= 0.0
        vbs_rev = np.where((vbd_l != vbs_x - vds_x) | (vds != vds_x), vbd_l + vds, vbs_x)
        vbs = np.where(fwd, vbs_l, vbs_rev)
        changed = bool(np.any(vgs != vgs_x) or np.any(vds != vds_x) or np.any(vbs != vbs_x))
        return np.stack([vgs, vds, vbs]), changed

    def compiled(self, slots: SlotMap, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Pack the family for :func:`netdae.devices.kernels.mosfet.eval_mosfet` (after ``bind``).

        Returns
        -------
        par : ndarray, shape (N, kernels.mosfet.N_PAR)
        idx : ndarray of int64, shape (N, kernels.mosfet.N_IDX)
        vold0 : ndarray, shape (N, 4)
            The initial state's (vgs, vds, vbs) and threshold (:meth:`initial_state`).
        """
        from .kernels import mosfet as km
        from .kernels.packing import columns, dependence_blocks, depletion_columns, node_columns

        count = len(self.elements)
        par = columns(count, km.N_PAR, {
            km.P_TYPE: self.type, km.P_BETA: self.beta, km.P_LAMBDA: self.lam, km.P_VBI: self.vbi_n,
            km.P_GAMMA: self.gamma, km.P_PHI: self.phi, km.P_VT: self.vt, km.P_ISAT_S: self.isat_s,
            km.P_ISAT_D: self.isat_d, km.P_VCRIT_S: self.vcrit_s, km.P_VCRIT_D: self.vcrit_d, km.P_GMIN: self.gmin,
            km.P_CGSO: self.cgso, km.P_CGDO: self.cgdo, km.P_CGBO: self.cgbo, km.P_COX: self.cox,
            km.P_GD: self.gd, km.P_GS: self.gs, km.P_CHARGE_FAMILY: self.has_charge,
            km.P_BOTTOM_FAMILY: self.dep_bottom.active, km.P_SIDE_FAMILY: self.dep_side.active,
            km.P_COX_FAMILY: self.has_cox,
        })
        source, drain = slice(0, count), slice(count, 2 * count)
        for col, dep, part in ((km.P_DEP_BS, self.dep_bottom, source), (km.P_DEP_BD, self.dep_bottom, drain),
                               (km.P_DEP_SS, self.dep_side, source), (km.P_DEP_SD, self.dep_side, drain)):
            par[:, col:col + 9] = depletion_columns(dep, part)
        idx = node_columns(count, km.N_IDX, {
            km.I_D: self.d, km.I_G: self.g, km.I_S: self.s, km.I_B: self.b, km.I_DI: self.di,
            km.I_SI: self.si}, n)
        st = self.stamps
        controls = list(zip(st.ctrl_p, st.ctrl_m))
        dependence_blocks(idx, km.S_CUR, slots, _CURRENT_DEPS, list(zip(st.cur_a, st.cur_b)), controls)
        dependence_blocks(idx, km.S_CHG, slots, _CHARGE_DEPS, [(self.g, self.si), (self.di, self.si),
                                                                (self.b, self.si)], controls,
                          where=np.full(count, self.has_charge))
        start = self.initial_state()
        return par, idx, np.column_stack([start.v.T, start.extra])

    def quantities(self, x, dxdt=None):
        """ngspice's MOSFET quantities (``@m1[id]``, ``@m1[gm]`` ...) at solutions ``x``, shape (T, N) each.

        As ngspice's MOS1, currents and voltages are type-normalised (a PMOS
        gives those of the equivalent NMOS); ``von`` and ``vdsat``, the
        threshold and saturation voltages (``max(vgs - von, 0)`` of the
        mode), have their real sign. The currents flow into the terminals
        (``id + ig + ib + is = 0``), in a transient with the charges'
        currents (:meth:`charges`). ``gm, gds, gmbs`` are the derivatives of
        the channel current of the mode (:func:`drain_current`), ``gbd, gbs``,
        ``cbd, cbs`` the bulk junctions', and ``cgs, cgd, cgb`` the
        derivatives ``-dQg/dVs``, ``-dQg/dVd``, ``-dQg/dVb`` of netdae's gate
        charge (overlaps included); ``p`` the power the terminals deliver to
        the device (each terminal's current times its voltage, series
        resistances included).
        """
        v = self.stamps.voltages_at(x)
        tp = self.type
        vgs, vds, vbs = tp * v[_VGS], tp * v[_VDS], tp * v[_VBS]
        vgd, vbd = vgs - vds, vbs - vds
        fwd = vds >= 0.0

        def select(a, b):
            return np.where(fwd, a, b)

        n = vgs.shape[-1]
        q, dq = np.zeros((3,) + vgs.shape), np.zeros((9,) + vgs.shape)
        with np.errstate(all="ignore"):
            cdrain, gm, gds, gmbs, von, dvon = drain_current(select(vgs, vgd), np.abs(vds), select(vbs, vbd),
                                                             self.beta, self.lam, self.vbi_n, self.gamma, self.phi)
            ibs, gbs, ibd, gbd = self.bulk_diodes(vbs, vbd)
            cj = np.zeros(vgs.shape[:-1] + (2 * n,))
            for dep in (self.dep_bottom, self.dep_side):
                if dep.active:
                    cj = cj + dep(np.concatenate([vbs, vbd], axis=-1))[1]
            if self.has_charge:
                self.charges(vgs, vds, vbs, vgd, vbd, fwd, select, von, dvon, q, dq)
        rate_g = rate_d = rate_b = 0.0
        if dxdt is not None and self.has_charge:
            # the real charges are tp q and their derivatives to the real voltages dq
            rate_g, rate_d, rate_b = tp * self.stamps.charge_rates(dq, self.stamps.voltages_at(dxdt))
        i_d = select(cdrain, -cdrain) - ibd + rate_d
        i_g = rate_g + np.zeros_like(vgs)
        i_b = ibd + ibs + rate_b
        xx = np.atleast_2d(x)
        vs = xx[:, self.s]
        # the power the terminals deliver (type-normalised currents times real voltages, times the type)
        p = tp * (i_d * (xx[:, self.d] - vs) + i_g * (xx[:, self.g] - vs) + i_b * (xx[:, self.b] - vs))
        return {
            "id": i_d, "is": -(i_d + i_g + i_b), "ig": i_g, "ib": i_b, "ibd": ibd, "ibs": ibs, "p": p,
            "vgs": vgs, "vds": vds, "vbs": vbs, "vbd": vbd,
            "von": tp * von, "vdsat": tp * np.maximum(select(vgs, vgd) - von, 0.0),
            "gm": gm, "gds": gds, "gmb": gmbs, "gmbs": gmbs, "gbd": gbd, "gbs": gbs,
            "cbd": cj[..., n:], "cbs": cj[..., :n],
            "cgs": dq[0] + dq[1] + dq[2], "cgd": -dq[1], "cgb": -dq[2],
        }

    def bulk_diodes(self, vbs, vbd):
        """Bulk-source and bulk-drain diode currents and conductances (GMIN included)."""
        v = np.concatenate([vbs, vbd], axis=-1)
        vt = self.vt2
        rev = v <= -_BULK_KNEE * vt
        ev = np.exp(np.minimum(MAX_EXP_ARG, v / vt))
        isat = self.isat_sd
        i = np.where(rev, -isat, isat * (ev - 1.0)) + self.gmin * v
        g = np.where(rev, 0.0, isat * ev / vt) + self.gmin
        n = vbs.shape[-1]
        return i[..., :n], g[..., :n], i[..., n:], g[..., n:]

    def noise(self, x: np.ndarray, temp: float) -> NoiseSources:
        """ngspice 39's level-1 MOSFET noise (``mos1noi.c``) at the operating point ``x`` (extended).

        Generators: ``_rd``, ``_rs`` thermal noise of the drain and source
        resistances (outer to internal node); ``_id`` channel thermal noise
        ``4 k T (2/3) |gm|`` and ``_1overf`` flicker noise
        ``KF |id|^AF / (f W m Leff Cox^2)``, internal drain to internal source,
        ``id`` being ngspice's ``MOS1cd``: the channel current in the drain's
        direction minus the bulk-drain junction current.
        """
        v = self.stamps.voltages(x)
        vgs, vds, vbs = self.type * v[:3]
        vgd, vbd = vgs - vds, vbs - vds
        fwd = vds >= 0.0
        with np.errstate(all="ignore"):
            cdrain, gm, *_ = drain_current(np.where(fwd, vgs, vgd), np.abs(vds), np.where(fwd, vbs, vbd),
                                           self.beta, self.lam, self.vbi_n, self.gamma, self.phi)
            ibd = self.bulk_diodes(vbs, vbd)[2]
        cd = np.where(fwd, cdrain, -cdrain) - ibd
        names = [el.name for el in self.elements]
        return noise_sources(names, [
            ("_rd", self.di, self.d, thermal(self.gd, temp), 0.0, 1.0),
            ("_rs", self.si, self.s, thermal(self.gs, temp), 0.0, 1.0),
            ("_id", self.di, self.si, thermal(2.0 / 3.0 * np.abs(gm), temp), 0.0, 1.0),
            ("_1overf", self.di, self.si, 0.0, flicker(self.flicker_scale, cd, self.af), 1.0),
        ])

    def evaluate(self, x, t, acc: Accumulator, state, jacobian):
        v = self.stamps.voltages(x)
        tp = self.type
        vn_x = tp * v[:3]
        with np.errstate(all="ignore"):
            start = starting_voltages(state, x, vn_x)
            if start is not None:
                vn, changed = start
            else:
                vn, changed = self.limit(vn_x, state)
            vgs, vds, vbs = vn
            vgd, vbd = vgs - vds, vbs - vds
            fwd = vds >= 0.0
            select = _first if fwd.all() else (lambda a, b: np.where(fwd, a, b))
            # the mode's own voltages
            cdrain, gm, gds, gmbs, von, dvon = drain_current(select(vgs, vgd), np.abs(vds), select(vbs, vbd),
                                                             self.beta, self.lam, self.vbi_n, self.gamma, self.phi)
            ibs, gbs, ibd, gbd = self.bulk_diodes(vbs, vbd)
            cur, dcur = self._cur, self._dcur
            cur[0] = select(tp, -tp) * cdrain
            np.multiply(tp, ibs, out=cur[1])
            np.multiply(tp, ibd, out=cur[2])
            np.multiply(self.gd, v[_VRD], out=cur[3])
            np.multiply(self.gs, v[_VRS], out=cur[4])
            dcur[0] = select(gm, -gm)
            dcur[1] = select(gds, gm + gds + gmbs)
            dcur[2] = select(gmbs, -gmbs)
            dcur[3] = gbs
            dcur[4] = gbd
            np.negative(gbd, out=dcur[5])
            if self.has_charge:
                self.charges(vgs, vds, vbs, vgd, vbd, fwd, select, von, dvon)
                self._q *= tp
            delta = None
            if changed:
                acc.limited = True
                delta = np.zeros_like(v)
                delta[:3] = v[:3] - tp * vn
            self.stamps.add(acc, cur, dcur, self._q, self._dq, delta=delta, jacobian=jacobian)
            total = float(cur.sum() + dcur.sum()) + (float(self._q.sum() + self._dq.sum()) if self.has_charge else 0.0)
            if not math.isfinite(total):
                acc.ok = False
        return LimitState(vn, extra=von)

    def charges(self, vgs, vds, vbs, vgd, vbd, fwd, select, von, dvon, q=None, dq=None) -> None:
        """Node charges (q_g, q_d, q_b) referred to the source, and their derivatives to (vgs, vds, vbs).

        Type-normalised, written into ``q`` (3, N) and ``dq`` (9, N, row-major:
        charge, control), by default ``self._q`` and ``self._dq`` (with
        voltages of shape (T, N): (3, T, N) and (9, T, N)); see the module
        docstring.
        """
        q = self._q if q is None else q
        dq = self._dq if dq is None else dq
        dq[:] = self._dq_overlap.reshape(self._dq_overlap.shape[:1] + (1,) * (dq.ndim - 2) + (-1,))
        vgb = vgs - vbs
        np.multiply(self.cgso, vgs, out=q[0])
        q[0] += self.cgdo * vgd + self.cgbo * vgb
        np.multiply(-self.cgdo, vgd, out=q[1])
        np.multiply(-self.cgbo, vgb, out=q[2])
        n = vbs.shape[-1]
        vb = None
        for dep in (self.dep_bottom, self.dep_side):
            if dep.active:
                vb = np.concatenate([vbs, vbd], axis=-1) if vb is None else vb
                qj, cj = dep(vb)
                qbs, qbd, cbs, cbd = qj[..., :n], qj[..., n:], cj[..., :n], cj[..., n:]
                q[1] -= qbd
                q[2] += qbd + qbs
                dq[4] += cbd
                dq[5] -= cbd
                dq[7] -= cbd
                dq[8] += cbd + cbs
        if not self.has_cox:
            return
        a = select(vgs, vgd) - von
        b = select(vgd, vgs) - von
        cg, cs, cd, cb, (g_a, g_b), (s_a, s_b), (d_a, d_b) = gate_charges(a, b, self.phi)
        cox = self.cox
        # the device's drain is the mode's drain in normal mode, its source in reverse
        q[0] += cox * cg
        q[1] += cox * select(cd, cs)
        q[2] += cox * cb
        # derivatives of (gate, device drain, device source) charges to a, b; then to the controls:
        # a = u1 - von(u3), b = u2 - von(u3) with u the mode's (vgs', vgd', vbs')
        d_a_all = np.stack([g_a, select(d_a, s_a), select(s_a, d_a)])
        d_b_all = np.stack([g_b, select(d_b, s_b), select(s_b, d_b)])
        d_ab = d_a_all + d_b_all
        d3 = -d_ab * dvon
        ctrl = cox * np.stack([d_ab, select(-d_b_all, -d_a_all - d3), d3], axis=1)  # (charge, control, N)
        dq3 = dq.reshape((3, 3) + dq.shape[1:])
        dq3[0] += ctrl[0]
        dq3[1] += ctrl[1]
        # bulk: qb_int = -(qg_int + qd_int + qs_int)
        dq3[2] -= ctrl.sum(axis=0)
