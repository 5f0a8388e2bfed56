"""The VDMOS power MOSFET (three-terminal ``M`` with a ``vdmos`` model) as ngspice 39 computes it.

Syntax: ``Mname d g s model [m=M] [off] [ic=vds,vgs] [icvds=v] [icvgs=v] [temp=T] [dtemp=dT]``
with ``.model name VDMOS [pchan|nchan] (VTO KP LAMBDA THETA MTRIODE KSUBTHRES SUBSHIFT RQ VQ
RD RS RG RDS CGDMIN CGDMAX A CGS IS N RB CJO VJ M FC TT BV IBV NBV EG XTI TNOM TCVTH MU ...)``;
``pchan`` makes a p-channel device (ngspice reads the flag anywhere after ``vdmos``), and
LTspice's annotations ``Vds= Ron= Qg= mfg=`` are dropped, as ngspice's reader drops them.
The self-heating model (five nodes and ``thermal``) is refused by the reader.

Equations (type-normalised: for ``pchan`` every voltage and current changes sign)
------------------------------------------------------------------------------
Channel (``vdmosload.c``), between the internal drain and source. The mode's
overdrive ``u0 = vgs - VON`` (``vds >= 0``) or ``vgd - VON`` (``vds < 0``),
``VON = type VTO(T)``, is softened for weak inversion::

    u = KSUBTHRES ln(1 + exp((u0 - SUBSHIFT) / KSUBTHRES))

and with ``w = MTRIODE |vds|`` and ``beta' = KP m (1 + LAMBDA vds) / (1 + THETA vgs)``
(``vds`` and ``vgs`` signed, in either mode, as ngspice writes them)::

    id = beta' u^2 / 2          u <= w   (saturation)
       = beta' w (u - w / 2)    u > w    (triode)

from the mode's drain to its source. Its derivatives are exact (ngspice's
``gm`` and ``gds`` of the reverse mode are not the derivatives of its current;
the solutions are the same).

Series resistances to internal nodes when non-zero: ``RD / m`` (``<name>#drain``),
``RS / m`` (``<name>#source``), ``RG / m`` (``<name>#gate``), the body diode's
``RB / m`` (``<name>#body``); ``RDS / m`` between the outer drain and source
(ngspice's 1e-15 S when RDS is not given). Quasi-saturation (RQ and VQ both
given, RD > 0, normal mode): the drain resistance is
``RD/m + RQ/m vdsx / (vdsx + |VQ|)`` with ``vdsx`` the outer drain-source
voltage, its conductance plus GMIN.

Capacitances (not multiplied by ``m``, as in ngspice 39): CGS constant between
the internal gate and source; between the internal gate and drain, with
``s = (CGDMAX - CGDMIN) / (1 + pi/2)``, ``y = CGDMAX - s``::

    Cgd(vgd) = s tanh(A vgd) + y     vgd > 0
             = s atan(A vgd) + y     vgd <= 0

whose charge netdae integrates exactly (``y v + s ln(cosh(A v))/A``, resp.
``y v + s (v atan(A v) - ln(1 + A^2 v^2)/(2A))``), where ngspice integrates the
capacitance by its average over each time step.

Body diode from the source (behind RB) to the outer drain: ngspice's diode
(:func:`~netdae.devices.diode.junction_current`: IS, N, the reverse cubic,
breakdown BV with IBV and NBV), GMIN, the depletion charge of CJO, VJ, M, FC
(:class:`~netdae.devices.junction.Depletion`) and the transit charge ``TT id``.

Temperature (``vdmostemp.c``; device ``temp``, else ``.options temp`` + ``dtemp``;
``TNOM`` else ``.options tnom``): ``KP (T/Tnom)^MU``; ``VTO - type TCVTH (T - Tnom)``;
``KSUBTHRES (1 + TKSUBTHRES1 dT + TKSUBTHRES2 dT^2)``; ``RD (T/Tnom)^TEXP0`` when
TEXP0 is given, else ``RD (1 + TRD1 dT + TRD2 dT^2)``; ``RQ (T/Tnom)^TEXP1``;
RG, RS, RB with their TRG*, TRS*, TRB* polynomials; the body diode's IS (EG, XTI, N),
VJ and CJO (:func:`~netdae.devices.junction.scale_junction`) and BV (adjusted to IBV
by :func:`~netdae.devices.diode.breakdown_voltage`).

Newton (``vdmosload.c``): ``fetlim``/``limvds`` on (vgs, vds) in the previous mode
(:func:`~netdae.devices.junction.fet_mode_limit`) around ``VON``, the diode's
``pnjlim`` (:func:`~netdae.devices.diode.junction_limit`) on its voltage. The first
iteration from a zero iterate starts at ``vgs = type VTO + 0.1``, ``vds = 0`` (the
instance ``ic=`` values when given, 0 for ``off``) and the diode at its ``vcrit``.

Accepted without effect: noise (KF, AF), PHI (checked positive), the safe-operating-area
limits, the thermal network (RTHJC, RTHCA, CTHJ: used only with thermal nodes).
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import CircuitError, NetlistError
from .base import Accumulator, DeviceFamily, SlotMap, series_nodes
from .companion import BranchStamps, LimitState, starting_voltages
from .diode import breakdown_voltage, junction_current, junction_limit
from .junction import EPSMIN, KELVIN, Depletion, fet_mode_limit, quadratic_factor, saturation_exponent, \
    scale_junction, thermal_voltage, vcrit
from .modelcard import ParameterTable, gather, instance_values, require_positive, resolve_model

__all__ = ["VdmosFamily", "VDMOS_PARAMETERS", "channel_current", "gate_drain_charge"]

VDMOS_PARAMETERS = ParameterTable(
    "VDMOS",
    defaults={
        "vto": 0.0, "kp": 1.0, "phi": 0.6, "lambda": 0.0, "theta": 0.0, "rd": 0.0, "rs": 0.0, "rg": 0.0,
        "tnom": None, "rq": None, "vq": None, "mtriode": 1.0, "tcvth": 0.0, "mu": -1.5, "texp0": None,
        "texp1": 0.3, "trd1": 0.0, "trd2": 0.0, "trg1": 0.0, "trg2": 0.0, "trs1": 0.0, "trs2": 0.0,
        "trb1": 0.0, "trb2": 0.0, "subshift": 0.0, "ksubthres": 0.1, "tksubthres1": 0.0, "tksubthres2": 0.0,
        "bv": None, "ibv": 1e-10, "nbv": 1.0, "rds": None, "rb": 0.0, "n": 1.0, "tt": 0.0, "eg": 1.11,
        "xti": 3.0, "is": 1e-14, "vj": 0.8, "cjo": 0.0, "m": 0.5, "fc": 0.5, "cgdmin": 0.0, "cgdmax": 0.0,
        "a": 1.0, "cgs": 0.0, "pchan": 0.0,
    },
    aliases={"vth0": "vto", "vtotc": "tcvth", "bex": "mu"},
    inert=frozenset({"kf", "af", "vdmos", "vdmosn", "vdmosp", "nchan", "rthjc", "rthca", "cthj", "vgs_max",
                     "vgd_max", "vds_max", "vgsr_max", "vgdr_max", "pd_max", "id_max", "idr_max", "te_max",
                     "rth_ext", "derating"}),
    family="vdmos",
    grading=frozenset({"m"}),
)

#: Instance parameters and their defaults (None: absent unless given).
_INSTANCE = {"m": 1.0, "off": 0.0, "icvds": 0.0, "icvgs": 0.0, "temp": None, "dtemp": 0.0}
#: ngspice's drain-source shunt when RDS is not given [S] (not multiplied by m).
RDS_DEFAULT_CONDUCTANCE = 1e-15
#: MODEINITJCT starts the gate this far above the threshold [V].
INIT_OVERDRIVE = 0.1
#: ngspice limits FC to 0.95 and EG to at least 0.1 eV (with warnings).
FC_MAX = 0.95
EG_MIN = 0.1
#: ngspice limits the body diode's depletion corner FC VJ(T) to 2.5 V inconsistently (its F1 keeps the
#: unlimited VJ); netdae refuses a card that reaches it.
DEPLETION_CORNER_MAX = 2.5
#: Reverse-bias knee of the body diode (3 N vt).
_REVERSE_KNEE = 3.0

# controls: the first three are limited (type-normalised internally)
_VGS, _VDS, _VD, _VRD, _VRS, _VRG, _VRB, _VDSX = range(8)
_ID, _IDIO, _IRD, _IRS, _IRG, _IRB, _IRDS = range(7)
_QGS, _QGD, _QDIO = range(3)
#: Current dependences; the last (the quasi-saturating drain resistance on vdsx) only with RQ and VQ.
_CURRENT_DEPS = [(_ID, _VGS), (_ID, _VDS), (_IDIO, _VD), (_IRD, _VRD), (_IRS, _VRS), (_IRG, _VRG), (_IRB, _VRB),
                 (_IRDS, _VDSX), (_IRD, _VDSX)]
_CHARGE_DEPS = [(_QGS, _VGS), (_QGD, _VGS), (_QGD, _VDS), (_QDIO, _VD)]


def _softplus(z):
    """``ln(1 + exp(z))`` and its derivative, without overflow."""
    e = np.exp(-np.abs(z))
    sp = np.maximum(z, 0.0) + np.log1p(e)
    sig = np.where(z >= 0.0, 1.0 / (1.0 + e), e / (1.0 + e))
    return sp, sig


def channel_current(vgs, vds, von, beta, lam, theta, ksub, shift, mtr):
    """The channel current (drain to source) and its derivatives to (vgs, vds), vectorised.

    Parameters
    ----------
    vgs, vds : ndarray
        Type-normalised internal gate-source and drain-source voltages.
    von : ndarray
        ``type VTO(T)``.
    beta, lam, theta, ksub, shift, mtr : ndarray
        ``KP m`` at temperature, LAMBDA, THETA, KSUBTHRES at temperature, SUBSHIFT, MTRIODE.

    Returns
    -------
    i, di_dvgs, di_dvds : ndarray

    Examples
    --------
    >>> i, gm, gds = channel_current(np.array([5.0, 5.0]), np.array([10.0, 0.5]), 3.0, 2.0, 0.0, 0.0,
    ...                              1e-3, 0.0, 1.0)
    >>> np.round(i, 9).tolist(), np.round(gm, 9).tolist(), np.round(gds, 9).tolist()  # saturation, triode
    ([4.0, 1.75], [4.0, 1.0], [0.0, 3.0])
    """
    fwd = vds >= 0.0
    u0 = np.where(fwd, vgs, vgs - vds) - von
    sp, sig = _softplus((u0 - shift) / ksub)
    u = ksub * sp
    w = np.abs(vds) * mtr
    t0 = 1.0 + lam * vds
    t1 = 1.0 + theta * vgs
    betap = beta * t0 / t1
    sat = u <= w
    f = np.where(sat, 0.5 * u * u, w * (u - 0.5 * w))
    fu = np.where(sat, u, w)
    fw = np.where(sat, 0.0, u - w)
    du_dvds = np.where(fwd, 0.0, -sig)
    dw_dvds = np.where(fwd, mtr, -mtr)
    di_dvgs = -beta * theta * t0 / (t1 * t1) * f + betap * fu * sig
    di_dvds = beta * lam / t1 * f + betap * (fu * du_dvds + fw * dw_dvds)
    i = betap * f
    return np.where(fwd, i, -i), np.where(fwd, di_dvgs, -di_dvgs), np.where(fwd, di_dvds, -di_dvds)


#: Below this |A vgd|, ln(cosh) is computed as ln(1 + 2 sinh^2(x/2)) (relative accuracy near 0), above as
#: |x| - ln 2 + ln(1 + exp(-2|x|)) (no overflow).
_LOGCOSH_SWITCH = 1.0


def _logcosh(x):
    """``ln(cosh(x))`` without overflow, to relative accuracy near 0."""
    ax = np.abs(x)
    big = ax > _LOGCOSH_SWITCH
    half = np.sinh(np.where(big, 0.0, ax) * 0.5)
    return np.where(big, ax + np.log1p(np.exp(-2.0 * ax)) - math.log(2.0), np.log1p(2.0 * half * half))


def _log1p_square(x):
    """``ln(1 + x^2)`` without overflow."""
    ax = np.abs(x)
    big = ax > 1.0
    inv = 1.0 / np.where(big, ax, 1.0)
    small = np.where(big, 0.0, ax)
    return np.where(big, 2.0 * np.log(np.where(big, ax, 1.0)) + np.log1p(inv * inv), np.log1p(small * small))


def gate_drain_charge(v, s, y, a):
    """ngspice's gate-drain capacitance at ``v`` (vgd) and its exact charge integral from 0.

    Parameters
    ----------
    v : ndarray
        Type-normalised internal gate-drain voltage.
    s, y, a : ndarray
        ``(CGDMAX - CGDMIN)/(1 + pi/2)``, ``CGDMAX - s`` and A.

    Returns
    -------
    q, c : ndarray

    Examples
    --------
    >>> q, c = gate_drain_charge(np.array([-1e9, 0.0, 1e9]), 1.0, 2.0, 1.0)
    >>> np.round(c, 8).tolist()  # y - s pi/2, y, y + s (far from vgd = 0)
    [0.42920367, 2.0, 3.0]
    """
    av = a * v
    pos = v > 0.0
    lin = a == 0.0
    a_safe = np.where(lin, 1.0, a)
    f_pos = _logcosh(av) / a_safe
    f_neg = v * np.arctan(av) - _log1p_square(av) / (2.0 * a_safe)
    f = np.where(lin, 0.0, np.where(pos, f_pos, f_neg))
    c = s * np.where(pos, np.tanh(av), np.arctan(av)) + y
    return y * v + s * f, c


class VdmosFamily(DeviceFamily):
    """All VDMOS transistors of a circuit, evaluated in one vectorised pass.

    Raises
    ------
    CircuitError
        Missing or mistyped model, a non-positive multiplier, a body diode whose
        depletion corner ``FC VJ(T)`` exceeds 2.5 V.
    NetlistError
        At the model's value: PHI or KSUBTHRES not positive, a grading M of 1 or more,
        negative resistances or capacitances (:data:`~netdae.devices.modelcard.NONNEGATIVE`).
    """

    limits_from_point = True

    shareable = True


    def __init__(self, elements, circuit) -> None:
        super().__init__(elements, circuit)
        opts = circuit.options
        self.gmin = float(opts.gmin)
        rows = []
        for el in self.elements:
            model = resolve_model(el, circuit, ("vdmos",))
            mv = VDMOS_PARAMETERS.read(model)
            if len(el.nodes) != 3:
                raise CircuitError(f"{el.name}: a VDMOS has 3 nodes (d g s)", elements=(el.name,), location=el.location)
            self._check_model(model, mv)
            inst = instance_values(el, _INSTANCE, "VDMOS")
            row = {k: mv[k] for k in ("vto", "kp", "lambda", "theta", "rd", "rs", "rg", "mtriode", "tcvth", "mu",
                                      "texp1", "trd1", "trd2", "trg1", "trg2", "trs1", "trs2", "trb1", "trb2",
                                      "subshift", "ksubthres", "tksubthres1", "tksubthres2", "ibv", "nbv", "rb",
                                      "n", "tt", "xti", "vj", "cjo", "m", "cgdmin", "cgdmax", "a", "cgs")}
            row["type"] = -1.0 if mv["pchan"] != 0.0 else 1.0
            row["texp0"] = mv.get("texp0", np.nan)
            row["qs"] = 1.0 if mv.given("rq") and mv.given("vq") and mv["rd"] > 0.0 else 0.0
            row["rq"] = mv.get("rq", 0.0)
            row["vq"] = abs(mv.get("vq", 0.0))
            row["rds"] = mv.get("rds", np.nan)
            row["bv"] = abs(mv.get("bv", np.nan))
            row["is"] = max(mv["is"], EPSMIN)
            row["eg"] = max(mv["eg"], EG_MIN)
            row["fc"] = min(mv["fc"], FC_MAX)
            row["tnom"] = mv.get("tnom", opts.tnom) + KELVIN
            row["temp"] = inst.get("temp", opts.temp + inst["dtemp"]) + KELVIN
            row["mult"] = inst["m"]
            row["off"] = inst["off"]
            row["icvds"], row["icvgs"] = inst["icvds"], inst["icvgs"]
            require_positive(el, row, (("mult", "m"),))
            rows.append(row)
        self._setup(rows, opts.reltol)
        corner = self.depletion.vfc
        for el, c in zip(self.elements, corner):
            if c > DEPLETION_CORNER_MAX:
                raise CircuitError(f"{el.name}: model {el.model}: the body diode's FC VJ = {c:g} V at "
                                   f"temperature exceeds {DEPLETION_CORNER_MAX:g} V, where ngspice 39 limits VJ "
                                   "inconsistently", elements=(el.name,), hint="give a junction potential VJ "
                                   "of a few tenths of a volt", location=el.location)

    @staticmethod
    def _check_model(model, mv) -> None:
        """Values the equations cannot take, located at the model's value."""
        for name, bad, need in (("phi", not mv["phi"] > 0.0, "> 0 (ngspice stops at it)"),
                                ("ksubthres", not mv["ksubthres"] > 0.0, "> 0 (it divides the overdrive)"),
                                ("m", not mv["m"] < 1.0, "< 1 (the body diode's grading coefficient)")):
            if bad:
                raise NetlistError(f"model {model.name}: {name}={mv[name]:g} is impossible for a VDMOS: {name} "
                                   f"must be {need}", model.locations.get(name, model.location),
                                   hint="check the sign and the scale suffix of the value")

    def _setup(self, rows, reltol: float) -> None:
        g = lambda name: gather(rows, name)  # noqa: E731
        temp, tnom = g("temp"), g("tnom")
        mult = g("mult")
        ratio = temp / tnom
        dt = temp - tnom
        tp = self.type = g("type")
        self.vt = thermal_voltage(temp)
        # channel
        self.beta = g("kp") * mult * ratio ** g("mu")
        self.von = tp * (g("vto") - tp * g("tcvth") * dt)
        self.init_vgs = tp * g("vto") + INIT_OVERDRIVE
        self.ksub = g("ksubthres") * quadratic_factor(g("tksubthres1"), g("tksubthres2"), dt)
        self.shift = g("subshift")
        self.lam = g("lambda")
        self.theta = g("theta")
        self.mtr = g("mtriode")
        # series resistances (ngspice keeps the unscaled value when the temperature makes it non-positive)
        rd = g("rd")
        texp0 = g("texp0")
        rd_factor = np.where(np.isfinite(texp0), ratio ** np.where(np.isfinite(texp0), texp0, 0.0),
                             quadratic_factor(g("trd1"), g("trd2"), dt))
        self.rd0 = rd / mult * rd_factor
        has_rd = rd > 0.0
        self.gd0 = np.where(has_rd, np.where(self.rd0 > 0.0, 1.0 / np.where(self.rd0 > 0.0, self.rd0, 1.0),
                                             mult / np.where(has_rd, rd, 1.0)), 0.0)
        self.qs = g("qs") != 0.0
        self.rq = g("rq") / mult * ratio ** g("texp1")
        self.vq = g("vq")
        self.gs = self._conductance(g("rs"), mult, quadratic_factor(g("trs1"), g("trs2"), dt))
        self.gg = self._conductance(g("rg"), mult, quadratic_factor(g("trg1"), g("trg2"), dt))
        self.gb = self._conductance(g("rb"), mult, quadratic_factor(g("trb1"), g("trb2"), dt))
        rds = g("rds")
        self.gds = np.where(np.isfinite(rds) & (rds > 0.0), mult / np.where(rds > 0.0, rds, 1.0),
                            RDS_DEFAULT_CONDUCTANCE)
        # gate capacitances (ngspice 39 does not multiply them by m)
        self.cgs = g("cgs")
        self.cgd_s = (g("cgdmax") - g("cgdmin")) / (1.0 + math.pi / 2.0)
        self.cgd_y = g("cgdmax") - self.cgd_s
        self.a = g("a")
        # body diode
        n = g("n")
        self.vte = n * self.vt
        self.isat = mult * g("is") * np.exp(saturation_exponent(g("eg"), g("xti"), tnom, temp) / n)
        self.vcrit = vcrit(self.vte, self.isat)
        self.knee = -_REVERSE_KNEE * self.vte
        grading = g("m")
        cj, vj = scale_junction(g("cjo") * mult, grading, g("vj"), tnom, temp)
        self.depletion = Depletion(cj, vj, grading, g("fc"))
        self.tt = g("tt")
        bv = g("bv")
        self.has_bv = np.isfinite(bv)
        self.any_bv = bool(np.any(self.has_bv))
        self.vtebrk = g("nbv") * self.vt
        self.bv = np.where(self.has_bv, breakdown_voltage(np.where(self.has_bv, bv, 0.0), g("ibv"), self.isat,
                                                          self.vtebrk, self.vt, reltol), 0.0)
        self.off = g("off") != 0.0
        self.ic = np.stack([tp * g("icvgs"), tp * g("icvds")])
        self.has_qs = bool(np.any(self.qs))
        self.has_charge = bool(self.depletion.active or np.any(self.tt != 0.0) or np.any(self.cgs != 0.0)
                               or np.any(self.cgd_s != 0.0) or np.any(self.cgd_y != 0.0))

    @staticmethod
    def _conductance(r, mult, factor) -> np.ndarray:
        """``m / (R factor)`` where R > 0, else 0 (no resistance)."""
        nz = r > 0.0
        return np.where(nz, mult / np.where(nz, r, 1.0) / factor, 0.0)

    # -- topology ----------------------------------------------------------
    def add_nodes(self, layout) -> None:
        els = self.elements
        self.d, self.g, self.s = (layout.nodes_of([el.nodes[i] for el in els]) for i in range(3))

        self.di = series_nodes(layout, els, self.d, self.gd0, "drain")
        self.gi = series_nodes(layout, els, self.g, self.gg, "gate")
        self.si = series_nodes(layout, els, self.s, self.gs, "source")
        self.bi = series_nodes(layout, els, self.s, self.gb, "body")

    def _controls(self):
        return [(self.gi, self.si), (self.di, self.si), (self.bi, self.d), (self.d, self.di), (self.s, self.si),
                (self.g, self.gi), (self.s, self.bi), (self.d, self.s)]

    def _charge_nodes(self):
        return [(self.gi, self.si), (self.gi, self.di), (self.bi, self.d)]

    def _deps(self):
        return _CURRENT_DEPS if self.has_qs else _CURRENT_DEPS[:-1]

    def coordinates(self, layout):
        currents = [(self.di, self.si), (self.bi, self.d), (self.d, self.di), (self.s, self.si), (self.g, self.gi),
                    (self.s, self.bi), (self.d, self.s)]
        charges = self._charge_nodes() if self.has_charge else []
        self.stamps = BranchStamps(len(self.elements), self._controls(), currents, charges, self._deps(),
                                   _CHARGE_DEPS if self.has_charge else [])
        return self.stamps.coordinates()

    def bind(self, slots: SlotMap, n: int) -> None:
        self.stamps.bind(slots, n)
        count = len(self.elements)
        self._cur = np.zeros((7, count))
        self._dcur = np.zeros((len(self._deps()), count))
        self._dcur[4], self._dcur[5], self._dcur[6], self._dcur[7] = self.gs, self.gg, self.gb, self.gds
        rows = 3 if self.has_charge else 0
        self._q = np.zeros((rows, count))
        self._dq = np.zeros((4 if self.has_charge else 0, count))

    def junction_nodes(self) -> list[tuple[str, str]]:
        return [(el.nodes[0], el.nodes[2]) for el in self.elements]

    # -- Newton support ----------------------------------------------------
    def initial_state(self) -> LimitState:
        """SPICE's ``MODEINITJCT``: (vgs, vds) = (type VTO + 0.1, 0), the ``ic=`` values when one is
        non-zero, 0 for ``off``; the body diode at ``vcrit``."""
        no_ic = ~np.any(self.ic != 0.0, axis=0)
        start = np.where(no_ic, np.stack([self.init_vgs, np.zeros_like(self.init_vgs)]), self.ic)
        start = np.where(self.off, 0.0, start)
        return LimitState(np.concatenate([start, self.vcrit[None, :]]), initial=True)

    def limit(self, vn: np.ndarray, vold: np.ndarray) -> tuple[np.ndarray, bool]:
        """ngspice's VDMOS limiting of (vgs, vds, vd), type-normalised."""
        vgs, vds = fet_mode_limit(vn[0], vn[1], vold[0], vold[1], self.von)
        vd, _ = junction_limit(vn[2], vold[2], self.vte, self.vcrit, self.has_bv, self.bv, self.vtebrk, self.any_bv)
        v = np.stack([vgs, vds, vd])
        return v, bool(np.any(v != vn))

    def drain_current(self, vgs: np.ndarray, vds: np.ndarray):
        """Channel current (internal drain to source) and its derivatives to (vgs, vds), type-normalised."""
        return channel_current(vgs, vds, self.von, self.beta, self.lam, self.theta, self.ksub, self.shift, self.mtr)

    def drain_conductance(self, vdsx: np.ndarray, forward: np.ndarray):
        """The drain resistance's conductance and its derivative to the outer ``vdsx`` (type-normalised)."""
        if not self.has_qs:
            return self.gd0, np.zeros_like(self.gd0)
        rdq = self.rd0 + self.rq * vdsx / (vdsx + self.vq)
        quasi = self.qs & forward
        pos = quasi & (rdq > 0.0)
        inv = 1.0 / np.where(pos, rdq, 1.0)
        g = np.where(pos, inv + self.gmin, self.gd0)
        den = vdsx + self.vq
        dg = np.where(pos, -inv * inv * self.rq * self.vq / np.where(pos, den * den, 1.0), 0.0)
        return g, dg

    def compiled(self, slots: SlotMap, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Pack the family for :func:`netdae.devices.kernels.vdmos.eval_vdmos` (after ``bind``).

        Returns
        -------
        par : ndarray, shape (N, kernels.vdmos.N_PAR)
        idx : ndarray of int64, shape (N, kernels.vdmos.N_IDX)
        vold0 : ndarray, shape (N, 3)
            The initial state's (vgs, vds, vd) (:meth:`initial_state`).
        """
        from .kernels import vdmos as kv
        from .kernels.packing import columns, dependence_blocks, depletion_columns, node_columns

        count = len(self.elements)
        par = columns(count, kv.N_PAR, {
            kv.P_TYPE: self.type, kv.P_VON: self.von, kv.P_BETA: self.beta, kv.P_LAMBDA: self.lam,
            kv.P_THETA: self.theta, kv.P_KSUB: self.ksub, kv.P_SHIFT: self.shift, kv.P_MTR: self.mtr,
            kv.P_GD0: self.gd0, kv.P_QS: self.qs, kv.P_RD0: self.rd0, kv.P_RQ: self.rq, kv.P_VQ: self.vq,
            kv.P_GMIN: self.gmin, kv.P_GS: self.gs, kv.P_GG: self.gg, kv.P_GB: self.gb, kv.P_GDS: self.gds,
            kv.P_CGS: self.cgs, kv.P_CGD_S: self.cgd_s, kv.P_CGD_Y: self.cgd_y, kv.P_A: self.a,
            kv.P_ISAT: self.isat, kv.P_VTE: self.vte, kv.P_KNEE: self.knee, kv.P_VCRIT: self.vcrit,
            kv.P_HAS_BV: self.has_bv, kv.P_BV: self.bv, kv.P_VTEBRK: self.vtebrk, kv.P_TT: self.tt,
            kv.P_CHARGE_FAMILY: self.has_charge, kv.P_QS_FAMILY: self.has_qs,
        })
        par[:, kv.P_DEP:kv.P_DEP + 9] = depletion_columns(self.depletion)
        idx = node_columns(count, kv.N_IDX, {
            kv.I_D: self.d, kv.I_G: self.g, kv.I_S: self.s, kv.I_DI: self.di, kv.I_GI: self.gi,
            kv.I_SI: self.si, kv.I_BI: self.bi}, n)
        st = self.stamps
        controls = list(zip(st.ctrl_p, st.ctrl_m))
        present = len(self._deps())
        dependence_blocks(idx, kv.S_CUR, slots, _CURRENT_DEPS, list(zip(st.cur_a, st.cur_b)), controls,
                          where=[np.full(count, j < present) for j in range(len(_CURRENT_DEPS))])
        dependence_blocks(idx, kv.S_CHG, slots, _CHARGE_DEPS, self._charge_nodes(), controls,
                          where=np.full(count, self.has_charge))
        return par, idx, self.initial_state().v.T.copy()

    def evaluate(self, x, t, acc: Accumulator, state, jacobian):
        v = self.stamps.voltages(x)
        tp = self.type
        vn_x = tp * v[:3]
        with np.errstate(all="ignore"):
            start = starting_voltages(state, x, vn_x)
            if start is not None:
                vn, changed = start
            else:
                vn, changed = self.limit(vn_x, state.v)
            vgs, vds, vd = vn
            cdrain, d_vgs, d_vds = self.drain_current(vgs, vds)
            cdio, gdio = junction_current(vd, self.isat, self.vte, self.knee, self.has_bv, self.bv, self.vtebrk,
                                          self.gmin, self.any_bv)
            gdr, dgdr = self.drain_conductance(tp * v[_VDSX], vds >= 0.0)
            cur, dcur = self._cur, self._dcur
            np.multiply(tp, cdrain, out=cur[_ID])
            np.multiply(tp, cdio, out=cur[_IDIO])
            np.multiply(gdr, v[_VRD], out=cur[_IRD])
            np.multiply(self.gs, v[_VRS], out=cur[_IRS])
            np.multiply(self.gg, v[_VRG], out=cur[_IRG])
            np.multiply(self.gb, v[_VRB], out=cur[_IRB])
            np.multiply(self.gds, v[_VDSX], out=cur[_IRDS])
            dcur[0] = d_vgs
            dcur[1] = d_vds
            dcur[2] = gdio
            dcur[3] = gdr
            if self.has_qs:
                dcur[8] = tp * dgdr * v[_VRD]
            if self.has_charge:
                qgd, cgd = gate_drain_charge(vgs - vds, self.cgd_s, self.cgd_y, self.a)
                qdep, cdep = self.depletion(vd)
                q, dq = self._q, self._dq
                np.multiply(tp, self.cgs * vgs, out=q[_QGS])
                np.multiply(tp, qgd, out=q[_QGD])
                np.multiply(tp, self.tt * cdio + qdep, out=q[_QDIO])
                dq[0] = self.cgs
                dq[1] = cgd
                np.negative(cgd, out=dq[2])
                dq[3] = self.tt * gdio + cdep
            delta = None
            if changed:
                acc.limited = True
                delta = np.zeros_like(v)
                delta[:3] = v[:3] - tp * vn
            self.stamps.add(acc, cur, dcur, self._q, self._dq, delta=delta, jacobian=jacobian)
            total = float(cur.sum() + dcur.sum()) + (float(self._q.sum() + self._dq.sum()) if self.has_charge else 0.0)
            if not math.isfinite(total):
                acc.ok = False
        return LimitState(vn)
