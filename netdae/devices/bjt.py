"""The Gummel-Poon bipolar transistor (SPICE level 1, NPN and PNP) as ngspice 39 computes it.

Syntax: ``Qname c b e [s] model [area] [areab=] [areac=] [m=M] [off] [temp=T] [dtemp=dT]``
with ``.model name NPN|PNP (IS BF NF VAF IKF ISE NE BR NR VAR IKR ISC NC RB IRB RBM RE RC
CJE VJE MJE TF XTF VTF ITF CJC VJC MJC XCJC TR CJS VJS MJS XTB EG XTI FC NKF SUBS TNOM)``.
A three-terminal instance has its substrate at ground.

Equations (type-normalised: for a PNP every voltage and current changes sign)
---------------------------------------------------------------------------
Junction currents (``bjtload.c``), :func:`~netdae.devices.junction.ideal_junction`
with the reverse-bias cubic::

    cbe = IS (e^{vbe/NF vt} - 1)     cben = ISE (e^{vbe/NE vt} - 1) + GMIN vbe
    cbc = IS (e^{vbc/NR vt} - 1)     cbcn = ISC (e^{vbc/NC vt} - 1) + GMIN vbc

Base charge ``q1 = 1 / (1 - vbc/VAF - vbe/VAR)``,
``q2 = cbe/IKF + cbc/IKR``, ``qb = q1 (1 + (1 + 4 q2)^NKF) / 2`` (NKF = 1/2:
a square root). Terminal currents::

    ic = (cbe - cbc)/qb - cbc/BR - cbcn         (collector -> emitter)
    ib = cbe/BF + cben + cbc/BR + cbcn          (base -> emitter)

Base resistance ``RBM + (RB - RBM)/qb``, or with IRB ngspice's
``RBM + 3 (RB - RBM) (tan z - z) / (z tan^2 z)``,
``z = (sqrt(1 + 144 ib / (pi^2 IRB)) - 1) / (24/pi^2 sqrt(ib/IRB))``;
RC and RE constant. A substrate current ``GMIN vsub`` flows from the
substrate to the collector (vertical, ``SUBS=1``, NPN default) or to the base
(lateral, ``SUBS=-1``, PNP default).

Charges: ``qbe = TF cbe' + qdep(vbe; CJE)`` with
``cbe' = cbe (1 + XTF e^{vbc/(1.44 VTF)} (cbe/(cbe+ITF))^2) / qb`` for
``vbe > 0`` (``cbe' = cbe`` otherwise, as ngspice), ``qbc = TR cbc +
qdep(vbc; XCJC CJC)`` at the internal base, ``qbx = qdep(vbx; (1-XCJC) CJC)``
from the external base to the collector, ``qsub = qdep(vsub; CJS, FC=0)``.
Their derivatives are ngspice's ``capbe`` (with the transcapacitance
``geqcb`` to vbc), ``capbc``, ``capbx``, ``capsub``.

Area and temperature (``bjttemp.c``, ``tlev = tlevc = 0``): ``IS`` times
``area`` and ``exp((T/Tnom - 1) EG/vt + XTI ln(T/Tnom))``; ``ISE`` times
``area`` and the same exponent over NE divided by ``(T/Tnom)^XTB``; ``ISC``
likewise times ``areab`` (vertical) or ``areac`` (lateral); ``BF``, ``BR``
times ``(T/Tnom)^XTB``; ``IKF``, ``IKR``, ``ITF``, ``IRB`` times area;
``RB``, ``RBM``, ``RE``, ``RC`` over area; ``CJE`` times area, ``CJC``
times areab/areac, ``CJS`` times areac/areab, with VJ/CJ by
:func:`~netdae.devices.junction.scale_junction`. ``ISE``/``ISC`` above 1e-4
are taken as multiples of IS (SPICE2's C2/C4). As in ngspice 39 the
base-collector saturation current is ``IS * area * areab`` (vertical) or
``IS * area * areac`` (lateral): with ``area != 1`` it scales with area
twice. The instance multiplier ``m`` multiplies every current and charge.
``TLEV=1`` makes XTB's factor ``1 + XTB dT``; the coefficients of
:data:`TEMPERATURE_COEFFICIENTS` multiply their parameter by
``1 + c1 dT + c2 dT^2`` (``dT = T - Tnom``), BF and BR only when one of theirs
is given (then instead of XTB's factor).

Newton: ``pnjlim`` on vbe and vbc (``vt``, ``vcrit = vt ln(vt/(sqrt 2 IS area))``)
and on vsub (critical voltage 50 V, as ngspice without ISS); the first
iteration from a zero iterate starts at ``vbe = vcrit``, ``vbc = 0``
(all 0 for ``off``).

Not implemented (rejected with an error): excess phase PTF, quasi-saturation
(RCO ...), ISS/NS, IBE/IBC, ``TLEV=3``, ``TLEVC``.
Noise (``.noise``, :meth:`BjtFamily.noise`, ngspice's ``bjtnoise.c``): thermal
noise of RC, RB (the bias-dependent ``1/gx``) and RE, shot noise of ``ic``
and ``ib``, flicker noise ``KF |ib|^AF / f`` (times m). Accepted without
effect: SOA limits; the instance
``icvbe``/``icvce``, which ngspice uses only for the first iterate of a
``uic`` transient.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import CircuitError
from .base import (Accumulator, DeviceFamily, NoiseSources, SlotMap, flicker, noise_sources, series_nodes, shot,
                   start_from_device_ic, thermal)
from .companion import BranchStamps, LimitState, starting_voltages
from .junction import KELVIN, Depletion, ideal_junction, pnjlim, quadratic_factor, saturation_exponent, \
    scale_junction, thermal_voltage, vcrit
from .modelcard import ParameterTable, gather, instance_values, require_positive, resolve_model

__all__ = ["BjtFamily", "BJT_PARAMETERS"]

#: The parameters ngspice 39 scales by ``1 + c1 dT + c2 dT^2`` (``dT = T - Tnom``, ``bjttemp.c``), each with the
#: names of its two coefficients. BF and BR take this factor instead of ``XTB``'s only when one of theirs is given.
TEMPERATURE_COEFFICIENTS = tuple(
    f"t{p}{k}" for p in ("bf", "br", "ikf", "ikr", "irb", "nc", "ne", "nf", "nr", "rb", "rc", "re", "rm",
                         "vaf", "var", "itf", "tf", "tr", "mje", "mjc", "mjs") for k in (1, 2)
)


BJT_PARAMETERS = ParameterTable(
    "bipolar transistor (Gummel-Poon, level 1)",
    defaults={
        "level": 1.0, "is": 1e-16, "bf": 100.0, "nf": 1.0, "vaf": 0.0, "ikf": 0.0, "ise": 0.0, "ne": 1.5,
        "br": 1.0, "nr": 1.0, "var": 0.0, "ikr": 0.0, "isc": 0.0, "nc": 2.0, "rb": 0.0, "irb": 0.0,
        "rbm": None, "re": 0.0, "rc": 0.0, "cje": 0.0, "vje": 0.75, "mje": 0.33, "tf": 0.0, "xtf": 0.0,
        "vtf": 0.0, "itf": 0.0, "ptf": 0.0, "cjc": 0.0, "vjc": 0.75, "mjc": 0.33, "xcjc": 1.0, "tr": 0.0,
        "cjs": 0.0, "vjs": 0.75, "mjs": 0.0, "xtb": 0.0, "eg": 1.11, "xti": 3.0, "fc": 0.5, "nkf": None,
        "subs": None, "tnom": None, "tlev": 0.0,
        **{name: 0.0 for name in TEMPERATURE_COEFFICIENTS},
    },
    aliases={"va": "vaf", "ik": "ikf", "c2": "ise", "vb": "var", "c4": "isc", "pe": "vje", "me": "mje",
             "pc": "vjc", "mc": "mjc", "csub": "cjs", "ccs": "cjs", "ps": "vjs", "ms": "mjs", "tref": "tnom",
             "nk": "nkf", "trb": "trb1", "trc": "trc1", "tre": "tre1"},
    inert=frozenset({"npn", "pnp", "kf", "af", "vbe_max", "vbc_max", "vce_max", "pd_max", "ic_max", "ib_max",
                     "te_max"}),
    family="bjt",
    grading=frozenset({"mje", "mjc", "mjs"}),
)

_INSTANCE = {"area": 1.0, "areab": None, "areac": None, "m": 1.0, "off": 0.0, "temp": None, "dtemp": 0.0,
             "icvbe": None, "icvce": None}
#: ngspice limits FC to 0.9999 and the grading coefficients to 0.999.
FC_MAX = 0.9999
GRADING_MAX = 0.999
#: ISE/ISC above this are SPICE2's C2/C4: multiples of IS.
LEAK_AS_FACTOR = 1e-4
#: ngspice's critical voltage for the substrate junction without ISS [V].
SUBSTRATE_VCRIT = 50.0
#: VTF enters as exp(vbc / (1.44 VTF)).
VTF_SCALE = 1.44
#: Constants of ngspice's IRB base-resistance formula (144/pi^2, 24/pi^2) and its floor on ib/IRB.
IRB_C1 = 14.59025
IRB_C2 = 2.4317
IRB_FLOOR = 1e-9
VERTICAL, LATERAL = 1.0, -1.0

# control rows
_VBE, _VBC, _VBX, _VSUB, _VRB, _VRC, _VRE = range(7)
# current rows
_IC, _IB, _ISUB, _IRB, _IRC, _IRE = range(6)
_CURRENT_DEPS = [(_IC, _VBE), (_IC, _VBC), (_IB, _VBE), (_IB, _VBC), (_ISUB, _VSUB), (_IRB, _VRB),
                 (_IRB, _VBE), (_IRB, _VBC), (_IRC, _VRC), (_IRE, _VRE)]
_CHARGE_DEPS = [(0, _VBE), (0, _VBC), (1, _VBC), (2, _VBX), (3, _VSUB)]


def _inverse(value: np.ndarray, scale: np.ndarray | float = 1.0) -> np.ndarray:
    """``1/(value*scale)`` where value != 0, else 0 (SPICE's 'infinite' default)."""
    nz = value != 0.0
    return np.where(nz, 1.0 / np.where(nz, value * scale, 1.0), 0.0)


class BjtFamily(DeviceFamily):
    """All bipolar transistors of a circuit, evaluated in one vectorised pass.

    Raises
    ------
    CircuitError
        Missing or mistyped model, unsupported parameter or level.
    """

    limits_from_point = True

    shareable = True


    def __init__(self, elements, circuit) -> None:
        super().__init__(elements, circuit)
        opts = circuit.options
        self.gmin = float(opts.gmin)
        rows = []
        for el in self.elements:
            model = resolve_model(el, circuit, ("npn", "pnp"))
            mv = BJT_PARAMETERS.read(model)
            if mv["level"] != 1.0:
                raise CircuitError(f"{el.name}: bipolar model {model.name} has level {mv['level']:g}; "
                                   "netdae implements the Gummel-Poon level 1", elements=(el.name,))
            if mv["ptf"] != 0.0:
                at = model.locations.get("ptf", model.location)
                raise CircuitError(f"{el.name}: model {model.name}: excess phase (PTF) is not supported by "
                                   "netdae", elements=(el.name,), hint="remove PTF", location=at)
            if mv["tlev"] not in (0.0, 1.0):
                at = model.locations.get("tlev", model.location)
                raise CircuitError(f"{el.name}: model {model.name} has tlev={mv['tlev']:g}; netdae implements "
                                   "tlev=0 and tlev=1", elements=(el.name,), location=at)
            if len(el.nodes) not in (3, 4):
                raise CircuitError(f"{el.name}: a bipolar transistor has 3 or 4 nodes", elements=(el.name,))
            inst = instance_values(el, _INSTANCE, "bipolar transistor")
            row = {k: mv[k] for k in BJT_PARAMETERS.defaults if k not in ("rbm", "nkf", "subs", "tnom", "level")}
            row["type"] = 1.0 if model.type.lower() == "npn" else -1.0
            row["subs"] = mv.get("subs", VERTICAL if row["type"] > 0 else LATERAL)
            if row["subs"] not in (VERTICAL, LATERAL):
                row["subs"] = VERTICAL if row["type"] > 0 else LATERAL
            row["rbm"] = mv.get("rbm", mv["rb"])
            row["nkf"] = mv.get("nkf", np.nan)
            row["fc"] = min(row["fc"], FC_MAX) if mv.given("fc") else 0.5
            row["tnom"] = mv.get("tnom", opts.tnom) + KELVIN
            row["temp"] = inst.get("temp", opts.temp + inst["dtemp"]) + KELVIN
            row["area"] = inst["area"]
            row["areab"] = inst.get("areab", inst["area"])
            row["areac"] = inst.get("areac", inst["area"])
            row["mult"] = inst["m"]
            row["off"] = inst["off"]
            require_positive(el, row, (("area", "area"), ("areab", "areab"), ("areac", "areac"), ("mult", "m")))
            for key in ("ise", "isc"):
                if row[key] > LEAK_AS_FACTOR:
                    row[key] *= row["is"]
            row["kf"], row["af"] = model.params.get("kf", 0.0), model.params.get("af", 1.0)
            # BF, BR follow their own coefficients when one is given (even 0), else XTB's factor (bjttemp.c)
            row["own_bf"] = float(mv.given("tbf1") or mv.given("tbf2"))
            row["own_br"] = float(mv.given("tbr1") or mv.given("tbr2"))
            rows.append(row)
        self._setup(rows)

    def _setup(self, rows) -> None:
        g = lambda name: gather(rows, name)  # noqa: E731
        temp, tnom = g("temp"), g("tnom")
        area, areab, areac = g("area"), g("areab"), g("areac")
        self.type = g("type")
        subs = g("subs")
        self.ttype = self.type * subs
        vertical = subs == VERTICAL
        area_bc = np.where(vertical, areab, areac)
        area_sub = np.where(vertical, areac, areab)
        self.mult = g("mult")
        self.kf, self.af = g("kf"), g("af")
        self.vt = thermal_voltage(temp)
        factlog = saturation_exponent(g("eg"), g("xti"), tnom, temp)
        dt = temp - tnom
        tf = lambda name: quadratic_factor(g(f"t{name}1"), g(f"t{name}2"), dt)  # noqa: E731
        bfactor = np.where(g("tlev") == 0.0, np.exp(np.log(temp / tnom) * g("xtb")), 1.0 + g("xtb") * dt)
        self.is_be = area * g("is") * np.exp(factlog)
        self.is_bc = self.is_be * area_bc
        # the leakage currents' temperature exponents use NE, NC at tnom, their emission voltages NE, NC at T
        self.ise = area * g("ise") * np.exp(factlog / g("ne")) / bfactor
        self.isc = g("isc") * np.exp(factlog / g("nc")) / bfactor * area_bc
        self.vtf, self.vtr = g("nf") * tf("nf") * self.vt, g("nr") * tf("nr") * self.vt
        self.vte, self.vtc = g("ne") * tf("ne") * self.vt, g("nc") * tf("nc") * self.vt
        self.bf = g("bf") * np.where(g("own_bf") != 0.0, tf("bf"), bfactor)
        self.br = g("br") * np.where(g("own_br") != 0.0, tf("br"), bfactor)
        self.inv_vaf, self.inv_var = _inverse(g("vaf") * tf("vaf")), _inverse(g("var") * tf("var"))
        self.inv_ikf, self.inv_ikr = _inverse(g("ikf") * tf("ikf"), area), _inverse(g("ikr") * tf("ikr"), area)
        self.nkf = g("nkf")
        self.gc = self.mult * _inverse(g("rc") * tf("rc")) * area
        self.ge = self.mult * _inverse(g("re") * tf("re")) * area
        self.rb, self.rbm = g("rb") * tf("rb") / area, g("rbm") * tf("rm") / area
        self.irb = g("irb") * tf("irb") * area
        self.vcrit = vcrit(self.vt, self.is_be)
        fc = g("fc")
        self.fc = fc
        mje, mjc, mjs = (np.minimum(g(k) * tf(k), GRADING_MAX) for k in ("mje", "mjc", "mjs"))
        cje, self.vje = scale_junction(g("cje"), mje, g("vje"), tnom, temp)
        cjc, self.vjc = scale_junction(g("cjc"), mjc, g("vjc"), tnom, temp)
        cjs, self.vjs = scale_junction(g("cjs"), mjs, g("vjs"), tnom, temp)
        xcjc = g("xcjc")
        # the four depletion charges of all devices stacked: be, bc (internal), bx (external), substrate
        self.depletion = Depletion(
            np.concatenate([cje * area, cjc * area_bc * xcjc, cjc * area_bc * (1.0 - xcjc), cjs * area_sub]),
            np.concatenate([self.vje, self.vjc, self.vjc, self.vjs]),
            np.concatenate([mje, mjc, mjc, mjs]),
            np.concatenate([fc, fc, fc, np.zeros_like(fc)]),
        )
        self.tf, self.tr = g("tf") * tf("tf"), g("tr") * tf("tr")
        self.xtf = g("xtf")
        vtf = g("vtf")
        self.ovtf = _inverse(vtf, VTF_SCALE)
        self.itf = g("itf") * tf("itf") * area
        self.off = g("off") != 0.0
        self.rb_varies = bool(np.any((self.rb != self.rbm) & (self.rb > 0.0)))
        # the four junction currents of all devices stacked: cbe, cben, cbc, cbcn
        self.j_isat = np.concatenate([self.is_be, self.ise, self.is_bc, self.isc])
        self.j_vte = np.concatenate([self.vtf, self.vte, self.vtr, self.vtc])
        self.j_knee = -3.0 * self.j_vte
        # limiting of vbe, vbc, vsub stacked
        self.lim_vt = np.tile(self.vt, 3)
        self.lim_vcrit = np.concatenate([self.vcrit, self.vcrit, np.full_like(self.vcrit, SUBSTRATE_VCRIT)])
        self.has_rolloff = bool(np.any(self.inv_ikf != 0.0) or np.any(self.inv_ikr != 0.0))
        self.has_nkf = bool(np.any(np.isfinite(self.nkf)))
        self.has_tf = bool(np.any(self.tf != 0.0))
        self.has_charge = bool(self.depletion.active or self.has_tf or np.any(self.tr != 0))

    # -- topology ----------------------------------------------------------
    def uic_start(self, x: np.ndarray, given: set[int]) -> list[str]:
        """The base and collector behind their resistances at ``icvbe`` and ``icvce`` above the emitter (ngspice's
        BJTicVBE, BJTicVCE)."""
        return start_from_device_ic(self.elements, x, given, self.ei, [("icvbe", self.bi), ("icvce", self.ci)])

    def add_nodes(self, layout) -> None:
        els = self.elements
        self.c = layout.nodes_of([el.nodes[0] for el in els])
        self.b = layout.nodes_of([el.nodes[1] for el in els])
        self.e = layout.nodes_of([el.nodes[2] for el in els])
        self.s = layout.nodes_of([el.nodes[3] if len(el.nodes) == 4 else "0" for el in els])

        self.ci = series_nodes(layout, els, self.c, self.gc, "collcx")
        self.bi = series_nodes(layout, els, self.b, self.rb, "base")
        self.ei = series_nodes(layout, els, self.e, self.ge, "emitter")
        self.sub_con = np.where(self.ttype * self.type > 0, self.ci, self.bi)

    def coordinates(self, layout):
        controls = [(self.bi, self.ei), (self.bi, self.ci), (self.b, self.ci), (self.s, self.sub_con),
                    (self.b, self.bi), (self.c, self.ci), (self.e, self.ei)]
        currents = [(self.ci, self.ei), (self.bi, self.ei), (self.s, self.sub_con), (self.b, self.bi),
                    (self.c, self.ci), (self.e, self.ei)]
        charges = [(self.bi, self.ei), (self.bi, self.ci), (self.b, self.ci), (self.s, self.sub_con)]
        self.stamps = BranchStamps(len(self.elements), controls, currents, charges if self.has_charge else [],
                                   _CURRENT_DEPS, _CHARGE_DEPS if self.has_charge else [])
        return self.stamps.coordinates()

    def bind(self, slots: SlotMap, n: int) -> None:
        self.stamps.bind(slots, n)
        count = len(self.elements)
        m = self.mult
        self._tm = self.type * m
        self._ttm_gmin = self.ttype * m * self.gmin
        self._cur = np.zeros((6, count))
        self._dcur = np.zeros((len(_CURRENT_DEPS), count))
        self._dcur[4] = m * self.gmin
        # constant base resistance (no RBM/IRB dependence): gx = 1 / RB
        self._dcur[5] = m * np.where(self.rb > 0.0, 1.0 / np.where(self.rb > 0.0, self.rb, 1.0), 0.0)
        self._dcur[8], self._dcur[9] = self.gc, self.ge
        rows = 4 if self.has_charge else 0
        self._q = np.zeros((rows, count))
        self._dq = np.zeros((len(_CHARGE_DEPS) if self.has_charge else 0, count))
        self._charge_sign = (np.stack([self.type, self.type, self.type, self.ttype]) * m)[:rows]

    def junction_nodes(self) -> list[tuple[str, str]]:
        pairs = []
        for el in self.elements:
            c, b, e = el.nodes[:3]
            pairs += [(b, e), (b, c)]
            if len(el.nodes) == 4:
                pairs.append((el.nodes[3], c))
        return pairs

    # -- Newton support ----------------------------------------------------
    def initial_state(self) -> LimitState:
        """SPICE's ``MODEINITJCT``: vbe = vcrit, vbc = vsub = 0 (all 0 when ``off``)."""
        zero = np.zeros_like(self.vcrit)
        return LimitState(np.stack([np.where(self.off, 0.0, self.vcrit), zero, zero]), initial=True)

    def limit(self, vn: np.ndarray, vold: np.ndarray) -> tuple[np.ndarray, bool]:
        """pnjlim on (vbe, vbc, vsub), type-normalised, against the previous values."""
        v, changed = pnjlim(vn.ravel(), vold.ravel(), self.lim_vt, self.lim_vcrit)
        return v.reshape(vn.shape), changed is not None

    def transport(self, vbe, vbc):
        """Gummel-Poon currents and their derivatives at type-normalised (vbe, vbc).

        The voltages have the instances on their last axis (shape (N,) or
        (T, N)).

        Returns
        -------
        dict of ndarray
            ``ic, ib`` and ``dic_dvbe, dic_dvbc, dib_dvbe, dib_dvbc``, plus the
            intermediate ``cbe, gbe, cbc, gbc, qb, dqbdve, dqbdvc`` the charges use
            and ngspice's small-signal ``gm, go, gpi, gmu`` (per unit m).
        """
        n = vbe.shape[-1]
        i4, g4 = ideal_junction(np.concatenate([vbe, vbe, vbc, vbc], axis=-1), self.j_isat, self.j_vte,
                                self.j_knee)
        cbe, cben, cbc, cbcn = (i4[..., j * n:(j + 1) * n] for j in range(4))
        gbe, gben, gbc, gbcn = (g4[..., j * n:(j + 1) * n] for j in range(4))
        cben, gben = cben + self.gmin * vbe, gben + self.gmin
        cbcn, gbcn = cbcn + self.gmin * vbc, gbcn + self.gmin
        q1 = 1.0 / (1.0 - self.inv_vaf * vbc - self.inv_var * vbe)
        if self.has_rolloff:
            arg = np.maximum(0.0, 1.0 + 4.0 * (self.inv_ikf * cbe + self.inv_ikr * cbc))
            if self.has_nkf:
                nkf_given = np.isfinite(self.nkf)
                nkf = np.where(nkf_given, self.nkf, 0.5)
                sq = np.where(arg != 0.0, np.where(nkf_given, arg ** nkf, np.sqrt(arg)), 1.0)
                dsq = np.where(arg != 0.0, nkf * sq / np.where(arg != 0.0, arg, 1.0), 0.0)
            else:
                sq = np.sqrt(arg)
                sq = np.where(arg != 0.0, sq, 1.0)  # ngspice keeps 1 where the argument is exactly 0
                dsq = np.where(arg != 0.0, 0.5 / sq, 0.0)  # d(sq)/d(arg)
        else:
            sq, dsq = 1.0, 0.0
        qb = q1 * (1.0 + sq) / 2.0
        dqbdve = q1 * (qb * self.inv_var + 2.0 * dsq * self.inv_ikf * gbe)
        dqbdvc = q1 * (qb * self.inv_vaf + 2.0 * dsq * self.inv_ikr * gbc)
        ict = (cbe - cbc) / qb
        go = (gbc + (cbe - cbc) * dqbdvc / qb) / qb
        gm = (gbe - (cbe - cbc) * dqbdve / qb) / qb - go
        gpi = gbe / self.bf + gben
        gmu = gbc / self.br + gbcn
        return {
            "ic": ict - cbc / self.br - cbcn, "ib": cbe / self.bf + cben + cbc / self.br + cbcn,
            "dic_dvbe": gm + go, "dic_dvbc": -go - gmu, "dib_dvbe": gpi, "dib_dvbc": gmu,
            "cbe": cbe, "gbe": gbe, "cbc": cbc, "gbc": gbc, "qb": qb, "dqbdve": dqbdve, "dqbdvc": dqbdvc,
            "gm": gm, "go": go, "gpi": gpi, "gmu": gmu,
        }

    def base_resistance(self, tr) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Base-resistance conductance ``gx`` and its derivatives to (vbe, vbc).

        ``RBM + (RB - RBM)/qb`` without IRB, ngspice's tangent formula with it;
        0 where RB = 0.
        """
        rbpi = self.rb - self.rbm
        qb = tr["qb"]
        rbb = self.rbm + rbpi / qb
        drbb_dve = -rbpi / (qb * qb) * tr["dqbdve"]
        drbb_dvc = -rbpi / (qb * qb) * tr["dqbdvc"]
        with_irb = self.irb != 0.0
        if np.any(with_irb):
            ratio = tr["ib"] / np.where(with_irb, self.irb, 1.0)
            clamped = ratio < IRB_FLOOR
            a = np.maximum(ratio, IRB_FLOOR)
            s = np.sqrt(1.0 + IRB_C1 * a)
            sa = np.sqrt(a)
            z = (s - 1.0) / IRB_C2 / sa
            tz = np.tan(z)
            h = (tz - z) / (z * tz * tz)
            dh = (tz * tz * z * tz * tz - (tz - z) * (tz * tz + 2.0 * z * tz * (1.0 + tz * tz))) / (z * z * tz ** 4)
            dz = (IRB_C1 * sa / (2.0 * s) - (s - 1.0) / (2.0 * sa)) / (IRB_C2 * a)
            dr_dib = np.where(clamped, 0.0, 3.0 * rbpi * dh * dz / np.where(with_irb, self.irb, 1.0))
            rbb = np.where(with_irb, self.rbm + 3.0 * rbpi * h, rbb)
            drbb_dve = np.where(with_irb, dr_dib * tr["dib_dvbe"], drbb_dve)
            drbb_dvc = np.where(with_irb, dr_dib * tr["dib_dvbc"], drbb_dvc)
        nz = rbb != 0.0
        gx = np.where(nz, 1.0 / np.where(nz, rbb, 1.0), 0.0)
        return gx, -gx * gx * drbb_dve, -gx * gx * drbb_dvc

    def charges(self, vbe, vbc, vbx, vsub, tr, q=None, dq=None) -> None:
        """Junction charges (qbe, qbc, qbx, qsub) and their derivatives, type-normalised.

        Written into ``q`` (4, N) and ``dq`` (5, N), by default ``self._q``
        and ``self._dq``: dqbe/dvbe, dqbe/dvbc, dqbc/dvbc, dqbx/dvbx,
        dqsub/dvsub (with voltages of shape (T, N): (4, T, N) and (5, T, N)).
        """
        q = self._q if q is None else q
        dq = self._dq if dq is None else dq
        n = vbe.shape[-1]
        qj, cj = self.depletion(np.concatenate([vbe, vbc, vbx, vsub], axis=-1))
        q[:] = np.moveaxis(qj.reshape(qj.shape[:-1] + (4, n)), -2, 0)
        cj = np.moveaxis(cj.reshape(cj.shape[:-1] + (4, n)), -2, 0)
        dq[0] = cj[0]
        dq[1] = 0.0
        dq[2] = cj[1]
        dq[3] = cj[2]
        dq[4] = cj[3]
        q[1] += self.tr * tr["cbc"]
        dq[2] += self.tr * tr["gbc"]
        if not self.has_tf:
            return
        cbe, gbe, qb = tr["cbe"], tr["gbe"], tr["qb"]
        tf_on = (self.tf != 0.0) & (vbe > 0.0)
        argtf = self.xtf * np.exp(vbc * self.ovtf)
        arg2 = argtf
        with_itf = self.itf != 0.0
        temp = cbe / np.where(with_itf, cbe + self.itf, 1.0)
        argtf = np.where(with_itf, argtf * temp * temp, argtf)
        arg2 = np.where(with_itf, argtf * (3.0 - temp - temp), arg2)
        arg3 = cbe * argtf * self.ovtf
        cbe_mod = cbe * (1.0 + argtf) / qb
        gbe_mod = (gbe * (1.0 + arg2) - cbe_mod * tr["dqbdve"]) / qb
        geqcb = self.tf * (arg3 - cbe_mod * tr["dqbdvc"]) / qb
        q[0] += self.tf * np.where(tf_on, cbe_mod, cbe)
        dq[0] += self.tf * np.where(tf_on, gbe_mod, gbe)
        dq[1] = np.where(tf_on, geqcb, 0.0)

    def quantities(self, x, dxdt=None):
        """ngspice's bipolar quantities (``@q1[ic]``, ``@q1[gm]`` ...) at solutions ``x``, shape (T, N) each.

        Currents flow into the terminals, with their real sign (a PNP's
        ``ic`` is negative when it conducts), in a transient with the
        charges' currents; ``is`` is the substrate current out of the
        substrate terminal (ngspice's sign), so ``ic + ib + ie - is = 0``.
        ``vbe``, ``vbc`` are the internal junction voltages, type-normalised;
        ``gm, gpi, gmu, go`` ngspice's small-signal conductances of the
        transport model (:meth:`transport`), ``gx`` the base resistance's
        (:meth:`base_resistance`), ``cpi, cmu, cbx, csub`` the charges'
        derivatives and ``qbe, qbc, qbx, qsub`` the charges (type-normalised),
        all times the multiplier m; ``p`` the power the terminals deliver to
        the device, the sum of each terminal's current times its voltage
        (series resistances included; in a transient with the charges'
        currents).
        """
        v = self.stamps.voltages_at(x)
        tp, ttp, m = self.type, self.ttype, self.mult
        vbe, vbc, vbx, vsub = tp * v[_VBE], tp * v[_VBC], tp * v[_VBX], ttp * v[_VSUB]
        shape = (4,) + vbe.shape
        with np.errstate(all="ignore"):
            tr = self.transport(vbe, vbc)
            q, dq = np.zeros(shape), np.zeros((5,) + vbe.shape)
            if self.has_charge:
                self.charges(vbe, vbc, vbx, vsub, tr, q, dq)
            q, dq = q * m, dq * m
            if self.rb_varies:
                gx = m * self.base_resistance(tr)[0]
            else:
                gx = np.broadcast_to(self._dcur[5], vbe.shape)
        i_c = self._tm * tr["ic"]  # collector to emitter, inside
        i_b = self._tm * tr["ib"]  # internal base to emitter
        i_sub = self._ttm_gmin * vsub  # substrate to the collector (vertical) or base (lateral)
        if dxdt is not None and self.has_charge:
            # dq (m included) is also the derivative of the real charges to the real voltages
            dq_be, dq_bc, dq_bx, dq_sub = self.stamps.charge_rates(dq, self.stamps.voltages_at(dxdt))
        else:
            dq_be = dq_bc = dq_bx = dq_sub = 0.0
        vertical = self.ttype * self.type > 0
        sub = i_sub + dq_sub
        ic = i_c - dq_bc - dq_bx - np.where(vertical, sub, 0.0)
        ib = i_b + dq_be + dq_bc + dq_bx - np.where(vertical, 0.0, sub)
        ie = -(i_c + i_b + dq_be)
        xx = np.atleast_2d(x)
        ve = xx[:, self.e]
        # the power the terminals deliver to the device (series resistances included)
        p = ic * (xx[:, self.c] - ve) + ib * (xx[:, self.b] - ve) - sub * (xx[:, self.s] - ve)
        return {
            "ic": ic, "ib": ib, "ie": ie, "is": -sub, "p": p, "vbe": vbe, "vbc": vbc,
            "gm": m * tr["gm"], "gpi": m * tr["gpi"], "gmu": m * tr["gmu"], "go": m * tr["go"], "gx": gx,
            "cpi": dq[0], "cmu": dq[2], "cbx": dq[3], "csub": dq[4],
            "qbe": q[0], "qbc": q[1], "qbx": q[2], "qsub": q[3],
        }

    def compiled(self, slots: SlotMap, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Pack the family for :func:`netdae.devices.kernels.bjt.eval_bjt` (after ``bind``).

        Returns
        -------
        par : ndarray, shape (N, kernels.bjt.N_PAR)
        idx : ndarray of int64, shape (N, kernels.bjt.N_IDX)
        vold0 : ndarray, shape (N, 3)
            The initial state's (vbe, vbc, vsub) (:meth:`initial_state`).
        """
        from .kernels import bjt as kb
        from .kernels.packing import columns, dependence_blocks, depletion_columns, node_columns

        count = len(self.elements)
        par = columns(count, kb.N_PAR, {
            kb.P_TYPE: self.type, kb.P_TTYPE: self.ttype, kb.P_M: self.mult, kb.P_TM: self._tm,
            kb.P_TTM_GMIN: self._ttm_gmin, kb.P_GMIN: self.gmin,
            kb.P_INV_VAF: self.inv_vaf, kb.P_INV_VAR: self.inv_var, kb.P_INV_IKF: self.inv_ikf,
            kb.P_INV_IKR: self.inv_ikr, kb.P_NKF: np.where(np.isfinite(self.nkf), self.nkf, 0.5),
            kb.P_BF: self.bf, kb.P_BR: self.br, kb.P_GC: self.gc, kb.P_GE: self.ge, kb.P_GX0: self._dcur[5],
            kb.P_RB: self.rb, kb.P_RBM: self.rbm, kb.P_IRB: self.irb, kb.P_RB_FAMILY: self.rb_varies,
            kb.P_VT: self.vt, kb.P_VCRIT: self.vcrit, kb.P_VCRIT_SUB: self.lim_vcrit[2 * count:],
            kb.P_CHARGE_FAMILY: self.has_charge, kb.P_TF_FAMILY: self.has_tf, kb.P_TF: self.tf, kb.P_TR: self.tr,
            kb.P_XTF: self.xtf, kb.P_OVTF: self.ovtf, kb.P_ITF: self.itf,
            kb.P_QSIGN: self.type * self.mult, kb.P_QSIGN_SUB: self.ttype * self.mult,
        })
        # the four junction currents: isat, N vt, knee of cbe, cben, cbc, cbcn
        for j, base in enumerate((kb.P_IS_BE, kb.P_ISE, kb.P_IS_BC, kb.P_ISC)):
            part = slice(j * count, (j + 1) * count)
            par[:, base] = self.j_isat[part]
            par[:, base + 1] = self.j_vte[part]
            par[:, base + 2] = self.j_knee[part]
        if self.has_rolloff:
            par[:, kb.P_ROLLOFF] = (np.where(np.isfinite(self.nkf), kb.ROLLOFF_POWER, kb.ROLLOFF_SQRT_NKF)
                                    if self.has_nkf else kb.ROLLOFF_SQRT)
        for j, base in enumerate((kb.P_DEP_BE, kb.P_DEP_BC, kb.P_DEP_BX, kb.P_DEP_SUB)):
            par[:, base:base + 9] = depletion_columns(self.depletion, slice(j * count, (j + 1) * count))
        idx = node_columns(count, kb.N_IDX, {
            kb.I_C: self.c, kb.I_B: self.b, kb.I_E: self.e, kb.I_S: self.s, kb.I_CI: self.ci, kb.I_BI: self.bi,
            kb.I_EI: self.ei, kb.I_SC: self.sub_con}, n)
        st = self.stamps
        controls = list(zip(st.ctrl_p, st.ctrl_m))
        dependence_blocks(idx, kb.S_CUR, slots, _CURRENT_DEPS, list(zip(st.cur_a, st.cur_b)), controls)
        dependence_blocks(idx, kb.S_CHG, slots, _CHARGE_DEPS, [(self.bi, self.ei), (self.bi, self.ci),
                                                                (self.b, self.ci), (self.s, self.sub_con)],
                          controls, where=np.full(count, self.has_charge))
        return par, idx, self.initial_state().v.T.copy()

    def noise(self, x: np.ndarray, temp: float) -> NoiseSources:
        """ngspice's Gummel-Poon noise (``bjtnoise.c``) at the operating point ``x`` (extended).

        Generators: ``_rc``, ``_rb``, ``_re`` thermal noise of the collector,
        base (its bias-dependent conductance ``gx``) and emitter resistances
        (each between its outer and internal node); ``_ic`` shot noise of the
        collector current (internal collector to internal emitter); ``_ib``
        shot noise and ``_1overf`` flicker noise ``m KF |ib|^AF / f`` of the
        base current of one device (internal base to internal emitter). ``m`` multiplies
        every generator, as ngspice's.
        """
        v = self.stamps.voltages(x)
        tr = self.transport(self.type * v[_VBE], self.type * v[_VBC])
        if self.rb_varies:
            gx = self.base_resistance(tr)[0]
        else:
            gx = np.where(self.rb > 0.0, 1.0 / np.where(self.rb > 0.0, self.rb, 1.0), 0.0)
        m = self.mult
        names = [el.name for el in self.elements]
        return noise_sources(names, [
            ("_rc", self.ci, self.c, thermal(self.gc, temp), 0.0, 1.0),
            ("_rb", self.bi, self.b, thermal(m * gx, temp), 0.0, 1.0),
            ("_re", self.ei, self.e, thermal(self.ge, temp), 0.0, 1.0),
            ("_ic", self.ci, self.ei, shot(m * tr["ic"]), 0.0, 1.0),
            ("_ib", self.bi, self.ei, shot(m * tr["ib"]), 0.0, 1.0),
            ("_1overf", self.bi, self.ei, 0.0, m * flicker(self.kf, tr["ib"], self.af), 1.0),
        ])

    def evaluate(self, x, t, acc: Accumulator, state, jacobian):
        v = self.stamps.voltages(x)
        tp, ttp = self.type, self.ttype
        vn_x = np.stack([tp * v[_VBE], tp * v[_VBC], ttp * v[_VSUB]])
        with np.errstate(all="ignore"):
            start = starting_voltages(state, x, vn_x)
            if start is not None:
                vn, changed = start
            else:
                vn, changed = self.limit(vn_x, state.v)
            vbe, vbc, vsub = vn
            tr = self.transport(vbe, vbc)
            m = self.mult
            cur, dcur = self._cur, self._dcur
            vrb = v[_VRB]
            np.multiply(self._tm, tr["ic"], out=cur[_IC])
            np.multiply(self._tm, tr["ib"], out=cur[_IB])
            np.multiply(self._ttm_gmin, vsub, out=cur[_ISUB])
            np.multiply(self.gc, v[_VRC], out=cur[_IRC])
            np.multiply(self.ge, v[_VRE], out=cur[_IRE])
            np.multiply(m, tr["dic_dvbe"], out=dcur[0])
            np.multiply(m, tr["dic_dvbc"], out=dcur[1])
            np.multiply(m, tr["dib_dvbe"], out=dcur[2])
            np.multiply(m, tr["dib_dvbc"], out=dcur[3])
            if self.rb_varies:
                gx, dgx_dve, dgx_dvc = self.base_resistance(tr)
                dcur[5] = m * gx
                dcur[6] = self._tm * vrb * dgx_dve
                dcur[7] = self._tm * vrb * dgx_dvc
            np.multiply(dcur[5], vrb, out=cur[_IRB])
            if self.has_charge:
                self.charges(vbe, vbc, tp * v[_VBX], vsub, tr)
                self._q *= self._charge_sign
                self._dq *= m
            delta = None
            if changed:
                acc.limited = True
                delta = np.zeros_like(v)
                delta[_VBE] = v[_VBE] - tp * vbe
                delta[_VBC] = v[_VBC] - tp * vbc
                delta[_VSUB] = v[_VSUB] - ttp * vsub
            self.stamps.add(acc, cur, dcur, self._q, self._dq, delta=delta, jacobian=jacobian)
            total = float(cur.sum() + dcur.sum()) + (float(self._q.sum() + self._dq.sum()) if self.has_charge else 0.0)
            if not math.isfinite(total):
                acc.ok = False
        return LimitState(vn)
