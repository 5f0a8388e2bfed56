"""ngspice's HFET1 and HFET2 heterostructure FETs (``Z`` cards, ``.model ... nhfet|phfet level=5|6``) as ngspice 39
computes them.

Syntax: ``Zname d g s model [off] [l=L] [w=W] [m=M] [ic=vds,vgs] [icvds=v] [icvgs=v] [temp=T] [dtemp=dT]``
with ``.model name NHFET|PHFET level=5 (VTO LAMBDA RD RS RG RDI RSI RGS RGD RI RF ETA M MC GAMMA SIGMA0
VSIGMAT VSIGMA MU DI DELTA VS NMAX DELTAD JS1D JS2D JS1S JS2S M1D M2D M1S M2S EPSI P CM3 A1 A2 MV1 KAPPA
DELF FGDS TF CDS PHIB TALPHA MT1 MT2 CK1 CK2 CM1 CM2 ASTAR ETA1 D1 VT1 ETA2 D2 VT2 GGR DEL GATEMOD
KLAMBDA KMU KVTO)``. ngspice chooses the device by the level, not the type: ``nhfet``/``phfet`` without a
level is its Statz MESFET; netdae runs levels 5 (HFET1) and 6 (HFET2) of the ``nhfet`` and ``phfet``
types and refuses the others by name.

HFET2 (level 6, ``hfet2load.c``; ``.model ... level=6 (VTO LAMBDA RD RS RDI RSI ETA ETA1 ETA2 D1 D2 VT1 VT2 M
MC GAMMA SIGMA0 VSIGMAT VSIGMA MU DI DELTA DELTAD VS NMAX EPSI P CF JS N GGR DEL KLAMBDA KMU KNMAX KVTO)``) is
HFET1's channel (below) with: no gate, ``RI``, ``RF`` resistances; gate diodes ``JS L W/2 (exp(v/(N vt)) - 1)
+ GGR L W/2 v exp(-DEL v/vt)`` (no GMIN); ``CF`` a parameter (default 0); ``NMAX(T) = NMAX - KNMAX (T -
Tnom)`` in the channel; ``VT1``, ``VT2`` defaulting from the card's ``VTO`` (not multiplied by the type);
ngspice's ``pnjlim`` (``CONSTvt0``, ``vcrit = vt ln(vt/(sqrt(2) 1e-11))``) before ``fetlim``; ``ETA``,
``MU``, ``VS`` defaulted for the N channel only (zero for a ``phfet`` card that does not give them, as in
ngspice); and its inverse flag cleared for every device.

Equations (``hfetload.c``'s ``hfeta``, ``leak``, ``diode`` and ``hfettemp.c``)
----------------------------------------------------------------------------
In type-normalised voltages (``type * v``), with ``vt = k T/q`` and ``w = |vds|``::

    vgt   = vg - VTO(T) + sigma w,   sigma = SIGMA0 / (1 + exp((vg - VTO(T) - VSIGMAT)/VSIGMA))
    vgte  = vt (2 + u + sqrt(DELTA^2 + u^2)),  u = vgt/(2 vt) - 1
    nsm   = 2 n0 ln(1 + exp(vgt/(ETA vt))/2)   (with ETA2 and D2 given: in parallel with
            n02 exp((vgt + VTO(T) - VT2)/(ETA2 vt)), ``nsm = nsn nsc/(nsn + nsc)``)
    ns    = nsm / (1 + (nsm/NMAX)^GAMMA)^(1/GAMMA),  gch = gchi/(1 + gchi (RSI + RDI)),  gchi = q W MU(T)/L ns
    isatm = gchim vgte / (1 + gchim RSI + sqrt(1 + 2 gchim RSI + (vgte/vl)^2)),  gchim = q W MU(T)/L nsm,
            vl = VS L / MU(T)
    isat  = isatm / (1 + (isatm/IMAX)^GAMMA)^(1/GAMMA),  IMAX = q NMAX VS W,  vsate = isat/gch
    id    = gch w (1 + LAMBDA(T) w) / (1 + (w/vsate)^M)^(1/M)

(``n0 = EPSI ETA vt / (2 q (DI + DELTAD))``); ``id`` is 0 where ``nsm < 1e-38``. The mode's gate
voltage ``vg`` is ``vgs`` in both modes: ngspice evaluates ``hfeta(vds > 0 ? vgs : vgd, |vds|)`` after
making ``vds`` positive, so the inverse mode (``vds < 0``) is ``-id(vgs, |vds|)``, not the exchanged device
(measured: ``i(vd)`` of a device at ``vgs = 0.5`` is ``-5.567538e-4`` at ``vds = 0.5`` and ``+5.567538e-4``
at ``vds = -0.5``). netdae computes the same currents; its derivatives are the exact ones (the complex
step), which are ngspice's ``gm`` and ``gds`` in the normal mode.

Gate currents, ``GATEMOD = 0`` (default): ``leak`` (a two-exponential diode, ``JS1S W L/2``,
``JS2S W L/2``, ``M1S``, ``M2S``, with the series resistance ``RGS`` through ngspice's closed-form
approximation ``diode()``, times 0.99999; zero when either current is zero) plus ``GGR L W/2 v
exp(-DEL v/vt)``, gate to source' and gate to drain' (``JS1D`` ... ``RGD``). ``GATEMOD = 1``: ngspice's
thermionic gate currents of ``hfeta`` (``ASTAR``, ``PHIB``, ``M2S``, ``M2D``, the hot-electron
temperature through ``TALPHA``, ``MT1``, ``MT2``, ``CK1``, ``CK2``, ``CM1``, ``CM2``) and the drain
correction ``A1``, ``A2`` (``MV1``, ``CM3``).

Gate capacitances (ngspice's, Meyer-like, gate' to ``#gs`` and to ``#gd``)::

    cgc   = W L (q dns/dvgt dvgt/dvg + 1/(D1/EPSI + ETA1 vt exp(-(vg - VT1)/(ETA1 vt))))
    capgs = CF + 4/3 cgc (1 - ((vsate - vdse)/(2 vsate - vdse))^2) / (1 + p)
    capgd = CF + 4/3 p cgc (1 - (vsate/(2 vsate - vdse))^2) / (1 + p),   p = P + (1 - P) exp(-w/vsate)

(``CF = EPSI W/2``, ``vdse = w (1 + (w/vsate)^MC)^(-1/MC)``, exchanged in the inverse mode;
``VT1`` defaults to ``VTO + q NMAX DI/EPSI``). As for MESA (:mod:`netdae.devices.mesa`), netdae's
charges are these capacitances integrated along the gate voltage (the drain-source voltage held), so
that their derivative to their own branch voltage is ngspice's capacitance; ``CDS`` is a linear
capacitance from drain' to source'.

Series resistances (``hfetsetup.c``): ``RD``, ``RS``, ``RG`` to ``<name>#drain``, ``#source``,
``#gate``; ``RI`` from the internal source to ``#gs`` and ``RF`` from the internal drain to ``#gd``
(the gate charges' far ends); ``RSI``, ``RDI`` enter the current only. None depends on temperature.

Temperature (``T`` the instance's ``temp``, else ``.options temp + dtemp``; ``Tnom`` from ``.options
tnom``): ``VTO(T) = VTO - KVTO (T - Tnom)``, ``MU(T) = MU - KMU (T - Tnom)``, ``LAMBDA(T) = LAMBDA +
KLAMBDA (T - Tnom)``, and ``vt``, ``n0``, ``n02`` through ``T``.

``phfet``: ngspice multiplies ``VTO`` by the type once (so a ``phfet`` card's ``VTO = -0.3`` is a
normalised threshold of 0.3) and every voltage and current by the type; the defaults of ``VTO``,
``ETA``, ``MU`` and ``VS`` are the P channel's (-0.15, 1.4, 0.03, 0.8e5).

Limiting: ngspice's ``fetlim`` of vgs and vgd against VTO(T); ``MODEINITJCT`` starts at ``vgs = vgd = -1``
(0 for ``off``). ``m`` multiplies every current, conductance and charge. ``KAPPA`` with a non-zero
``DELF`` (a frequency-dependent output conductance in ngspice's AC analysis only) is refused.

Not reproduced: ngspice 39's ``HFETAload`` keeps its ``inverse`` flag from one instance to the next in
the same load call (it is set when a device has ``vds < 0`` and never cleared), so that every later
instance of the call in its list is evaluated as inverted whatever its bias (measured: two devices at
``vgs = 0.5``, ``vds = +0.5`` and ``-0.5``: ngspice's forward one carries ``+3.52e-4`` A instead of
``-5.57e-4``). netdae evaluates each device in its own mode; single devices, and circuits whose devices
are all forward biased, agree.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import CircuitError, NetlistError
from .base import Accumulator, DeviceFamily, SlotMap, series_nodes
from .companion import BranchStamps, GateJunctionLimits, LimitState, starting_voltages
from .junction import CHARGE, K_OVER_Q, KELVIN
from .modelcard import ParameterTable, gather, instance_values, require_positive, resolve_model

__all__ = ["HfetFamily", "HFET_PARAMETERS", "HFET2_PARAMETERS", "HFET_LEVELS", "EPS_GAAS"]

#: GaAs's permittivity as ngspice writes it [F/m] (EPSI's default).
EPS_GAAS = 12.244 * 8.85418e-12
#: The HFET levels netdae implements (ngspice's HFET1 and HFET2).
HFET_LEVELS = (5.0, 6.0)

HFET_PARAMETERS = ParameterTable(
    "HFET (HFET1, level 5)",
    defaults={
        "level": 5.0, "vto": None, "lambda": 0.15, "rd": 0.0, "rs": 0.0, "rg": 0.0, "rdi": 0.0, "rsi": 0.0,
        "rgs": 90.0, "rgd": 90.0, "ri": 0.0, "rf": 0.0, "eta": None, "m": 3.0, "mc": 3.0, "gamma": 3.0,
        "sigma0": 0.057, "vsigmat": 0.3, "vsigma": 0.1, "mu": None, "di": 0.04e-6, "delta": 3.0, "vs": None,
        "nmax": 2e16, "deltad": 4.5e-9, "js1d": 1.0, "js2d": 1.15e6, "js1s": 1.0, "js2s": 1.15e6, "m1d": 1.32,
        "m2d": 6.9, "m1s": 1.32, "m2s": 6.9, "epsi": EPS_GAAS, "p": 1.0, "cm3": 0.17, "a1": 0.0, "a2": 0.0,
        "mv1": 3.0, "kappa": None, "delf": 0.0, "fgds": 0.0, "tf": None, "cds": 0.0, "phib": 0.5,
        "talpha": 1200.0, "mt1": 3.5, "mt2": 9.9, "ck1": 1.0, "ck2": 0.0, "cm1": 3.0, "cm2": 0.0,
        "astar": 4.0e4, "eta1": 2.0, "d1": 0.03e-6, "vt1": None, "eta2": None, "d2": None, "vt2": None,
        "ggr": 40.0, "del": 0.04, "gatemod": 0.0, "klambda": 0.0, "kmu": 0.0, "kvto": 0.0,
    },
    aliases={"vt0": "vto"},
    inert=frozenset({"nhfet", "phfet"}),
    family="hfet",
    levels=frozenset({5}),
)

HFET2_PARAMETERS = ParameterTable(
    "HFET (HFET2, level 6)",
    defaults={
        "level": 6.0, "vto": None, "cf": 0.0, "d1": 0.03e-6, "d2": 0.2e-6, "del": 0.04, "delta": 3.0,
        "deltad": 4.5e-9, "di": 0.04e-6, "epsi": EPS_GAAS, "eta": None, "eta1": 2.0, "eta2": 2.0, "gamma": 3.0,
        "ggr": 0.0, "js": 0.0, "klambda": 0.0, "kmu": 0.0, "knmax": 0.0, "kvto": 0.0, "lambda": 0.15, "m": 3.0,
        "mc": 3.0, "mu": None, "n": 5.0, "nmax": 2e16, "p": 1.0, "rd": 0.0, "rdi": 0.0, "rs": 0.0, "rsi": 0.0,
        "sigma0": 0.057, "vs": None, "vsigma": 0.1, "vsigmat": 0.3, "vt1": None, "vt2": None,
    },
    aliases={"vt0": "vto"},
    inert=frozenset({"nhfet", "phfet"}),
    family="hfet2",
    levels=frozenset({6}),
)
#: HFET2's type-dependent defaults (``hfet2setup.c`` sets ETA, MU and VS for the N channel only: a P-channel
#: card without them has zeros, as in ngspice).
_TYPE_DEFAULTS2 = {1: {"vto": 0.15, "eta": 1.28, "mu": 0.4, "vs": 1.5e5}, -1: {"vto": -0.15, "eta": 0.0, "mu": 0.0,
                                                                             "vs": 0.0}}
#: The P channel's defaults where they differ from the N channel's (``hfetsetup.c``).
_TYPE_DEFAULTS = {1: {"vto": 0.15, "eta": 1.28, "mu": 0.4, "vs": 1.5e5},
                  -1: {"vto": -0.15, "eta": 1.4, "mu": 0.03, "vs": 0.8e5}}
#: Instance parameters and their defaults (None: absent unless given).
_INSTANCE = {"l": 1e-6, "w": 20e-6, "m": 1.0, "off": 0.0, "icvds": None, "icvgs": None, "temp": None,
             "dtemp": 0.0}

# controls: vgs, vgd (limited), vgs'', vgd'' (the charges' branches), then the five series resistors
_VGS, _VGD, _VGSPP, _VGDPP, _VRD, _VRS, _VRG, _VRI, _VRF = range(9)
_ID, _IGS, _IGD, _IRD, _IRS, _IRG, _IRI, _IRF = range(8)
_CURRENT_DEPS = [(_ID, _VGS), (_ID, _VGD), (_IGS, _VGS), (_IGS, _VGD), (_IGD, _VGS), (_IGD, _VGD),
                 (_IRD, _VRD), (_IRS, _VRS), (_IRG, _VRG), (_IRI, _VRI), (_IRF, _VRF)]
_CHARGE_DEPS = [(0, _VGSPP), (0, _VGS), (0, _VGD), (1, _VGDPP), (1, _VGS), (1, _VGD), (2, _VGS), (2, _VGD)]


def _as_hfet1_row(row: dict) -> dict:
    """An HFET2 card's values in HFET1's names: no gate resistance nodes, no leakage, no GATEMOD; HFET2's
    own ``cf``, ``js``, ``n``, ``knmax`` kept."""
    out = dict(row)
    out.update({"rg": 0.0, "ri": 0.0, "rf": 0.0, "js1s": 0.0, "js1d": 0.0, "js2s": 0.0, "js2d": 0.0,
                "rgs": 0.0, "rgd": 0.0, "m1s": 1.0, "m1d": 1.0, "m2s": 1.0, "m2d": 1.0, "gatemod": 0.0,
                "cds": 0.0, "a1": 0.0, "a2": 0.0, "mv1": 3.0, "cm3": 0.17, "ck1": 1.0, "ck2": 0.0, "cm1": 3.0,
                "cm2": 0.0, "mt1": 3.5, "mt2": 9.9, "talpha": 1200.0, "phib": 0.5, "astar": 0.0})
    return out


class HfetFamily(GateJunctionLimits, DeviceFamily):
    """All HFET1 and HFET2 (levels 5, 6) devices of a circuit; the equations are :mod:`netdae.devices.kernels.hfet`'s.

    Raises
    ------
    CircuitError
        Non-positive ``l``, ``w`` or ``m``; ``KAPPA`` with a non-zero ``DELF``.
    NetlistError
        A level other than 5 and 6.
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
            model = resolve_model(el, circuit, ("nhfet", "phfet"))
            level = model.params.get("level", 1.0)
            if level not in HFET_LEVELS:
                raise NetlistError(f"{el.name}: model {model.name}: HFET level {level:g} is not implemented by "
                                   "netdae", model.locations.get("level", model.location),
                                   expected="an nhfet or phfet model of level 5 (HFET1)")
            table, typed = (HFET_PARAMETERS, _TYPE_DEFAULTS) if level == 5.0 else (HFET2_PARAMETERS, _TYPE_DEFAULTS2)
            mv = table.read(model)
            tp = -1 if model.type == "phfet" else 1
            row = dict(typed[tp])
            row.update({k: v for k, v in table.defaults.items() if v is not None})
            row.update(mv.given_values)
            if level == 6.0:
                row = _as_hfet1_row(row)
            row["type"] = float(tp)
            row["given"] = set(mv.given_values)
            if row.get("kappa") is not None and row.get("delf", 0.0) != 0.0:
                raise CircuitError(f"{el.name}: model {model.name}: KAPPA with DELF={row['delf']:g} (a "
                                   "frequency-dependent output conductance of ngspice's AC analysis) is not "
                                   "implemented by netdae", elements=(el.name,), hint="remove KAPPA or DELF",
                                   location=el.location)
            if len(el.nodes) != 3:
                raise CircuitError(f"{el.name}: an HFET has 3 nodes (d g s)", elements=(el.name,), location=el.location)
            inst = instance_values(el, _INSTANCE, "HFET")
            row["temp"] = inst["temp"] + KELVIN if "temp" in inst else opts.temp + KELVIN + inst["dtemp"]
            row["tnom"] = tnom
            row["l"], row["w"], row["mult"], row["off"] = inst["l"], inst["w"], inst["m"], inst["off"]
            require_positive(el, row, (("l", "l"), ("w", "w"), ("mult", "m")))
            rows.append(row)
        self._setup(rows)

    def _setup(self, rows) -> None:
        g = lambda name: gather(rows, name)  # noqa: E731
        count = len(rows)
        temp, tnom = g("temp"), g("tnom")
        dt = temp - tnom
        length, width = g("l"), g("w")
        tp = g("type")
        vt = K_OVER_Q * temp
        epsi = g("epsi")
        vto = g("vto") * tp  # hfettemp.c: the threshold times the type
        eta = g("eta")
        has = lambda name: np.array([name in r["given"] for r in rows])  # noqa: E731
        two = has("eta2") & has("d2")
        eta2 = np.array([r.get("eta2", 2.0) for r in rows])
        d2 = np.array([r.get("d2", 0.2e-6) for r in rows])
        level = g("level")
        six = level == 6.0
        raw_vto = g("vto")  # HFET2's VT1, VT2 default to the card's VTO (not multiplied by the type)
        vt2 = np.array([r.get("vt2", math.nan) for r in rows])
        vt2 = np.where(np.isnan(vt2), np.where(six, raw_vto, vto), vt2)
        vt1 = np.array([r.get("vt1", math.nan) for r in rows])
        vt1 = np.where(np.isnan(vt1), np.where(six, raw_vto, vto) + CHARGE * g("nmax") * g("di") / epsi, vt1)
        only6 = lambda name, default: gather(rows, name, default)  # noqa: E731  (HFET2's own names)
        tnmax = g("nmax") - only6("knmax", 0.0) * dt
        tmu = g("mu") - g("kmu") * dt
        tvto = vto - g("kvto") * dt
        self.tvto = tvto
        lw = length * width
        eta1 = g("eta1")

        def conductance(r):
            nz = r != 0.0
            return np.where(nz, 1.0 / np.where(nz, r, 1.0), 0.0)

        self.mult = g("mult")
        m = self.mult
        self.gd = conductance(g("rd")) * m
        self.gs = conductance(g("rs")) * m
        self.gg = conductance(g("rg")) * m
        self.gi = conductance(g("ri")) * m
        self.gf = conductance(g("rf")) * m
        self.type = tp
        self.par = {
            "vt": vt, "temp": temp, "eta": eta, "tvto": tvto, "vsigmat": g("vsigmat"), "vsigma": g("vsigma"),
            "sigma0": g("sigma0"), "delta2": g("delta") ** 2,
            "n0": epsi * eta * vt / 2.0 / CHARGE / (g("di") + g("deltad")),
            "n02": np.where(has("eta2"), epsi * eta2 * vt / 2.0 / CHARGE / d2, 0.0), "vt2": vt2, "eta2": eta2,
            "two": two.astype(float), "nmax": tnmax, "gamma": g("gamma"), "gchi0": CHARGE * width * tmu / length,
            "rt": g("rsi") + g("rdi"), "rsi": g("rsi"), "vl": g("vs") / tmu * length,
            "imax": CHARGE * tnmax * g("vs") * width, "m": g("m"), "tlambda": g("lambda") + g("klambda") * dt,
            "eta1": eta1, "d1": g("d1"), "epsi": epsi, "vt1": vt1, "wl": lw,
            "cf": np.where(six, only6("cf", 0.0), 0.5 * epsi * width),
            "mc": g("mc"), "pm": g("p"), "gatemod": g("gatemod"), "ck1": g("ck1"), "ck2": g("ck2"),
            "cm1": g("cm1"), "cm2": g("cm2"), "cm3": g("cm3"), "mt1": g("mt1"), "mt2": g("mt2"),
            "talpha": g("talpha"), "m2d": g("m2d"), "m2s": g("m2s"), "phib": g("phib") * CHARGE,
            "iso": g("astar") * lw / 2.0, "a1": g("a1"), "a2": g("a2"), "mv1": g("mv1"),
            "gmin": np.full(count, self.gmin), "is1s": g("js1s") * lw / 2.0, "is2s": g("js2s") * lw / 2.0,
            "m1s": g("m1s"), "rgs": g("rgs"), "is1d": g("js1d") * lw / 2.0, "is2d": g("js2d") * lw / 2.0,
            "m1d": g("m1d"), "rgd": g("rgd"), "ggrwl": g("ggr") * lw / 2.0, "del": g("del"), "mult": m,
            "type": tp, "cds": g("cds"), "gd": self.gd, "gs": self.gs, "gg": self.gg, "gi": self.gi,
            "gf": self.gf,
            "low": np.minimum(tvto, vt1) - 40.0 * np.maximum(eta, eta1) * vt,
            "level": level, "jslw": only6("js", 0.0) * lw / 2.0, "nemit": only6("n", 1.0),
            "vcrit": vt * np.log(vt / (math.sqrt(2.0) * 1e-11)),
        }
        from .kernels import hfet as kh

        self._par = np.ascontiguousarray(np.column_stack([np.broadcast_to(np.asarray(self.par[key], float),
                                                                          (count,)) for key in kh.PAR_KEYS]))
        self.off = g("off") != 0.0
        self.lim_vto = np.tile(tvto, 2)  # limiting (:meth:`limit`): HFET2's pnjlim first, then fetlim
        self.lim_six = np.tile(six, 2)
        self.lim_vcrit = np.tile(self.par["vcrit"], 2)

    def limit(self, vn: np.ndarray, vold: np.ndarray) -> tuple[np.ndarray, bool]:
        """ngspice's limiting of (vgs, vgd): HFET1 ``fetlim`` against VTO(T) alone (no junction limiting);
        HFET2 ``pnjlim`` (``CONSTvt0``, ``vt ln(vt/(sqrt(2) 1e-11))``) first."""
        from .junction import fetlim, pnjlim

        from .kernels.hfet import VT0

        flat, old = vn.ravel(), vold.ravel()
        v, _ = pnjlim(flat, old, np.full(flat.shape, VT0), self.lim_vcrit)
        v = fetlim(np.where(self.lim_six, v, flat), old, self.lim_vto).reshape(vn.shape)
        return v, bool(np.any(v != vn))

    # -- topology ----------------------------------------------------------
    def add_nodes(self, layout) -> None:
        els = self.elements
        self.d, self.g, self.s = (layout.nodes_of([el.nodes[i] for el in els]) for i in range(3))
        self.di = series_nodes(layout, els, self.d, self.gd, "drain")
        self.si = series_nodes(layout, els, self.s, self.gs, "source")
        self.gi_node = series_nodes(layout, els, self.g, self.gg, "gate")
        self.dii = series_nodes(layout, els, self.di, self.gf, "gd")
        self.sii = series_nodes(layout, els, self.si, self.gi, "gs")

    def coordinates(self, layout):
        gp = self.gi_node
        controls = [(gp, self.si), (gp, self.di), (gp, self.sii), (gp, self.dii), (self.d, self.di),
                    (self.s, self.si), (self.g, gp), (self.sii, self.si), (self.dii, self.di)]
        currents = [(self.di, self.si), (gp, self.si), (gp, self.di), (self.d, self.di), (self.s, self.si),
                    (self.g, gp), (self.sii, self.si), (self.dii, self.di)]
        charges = [(gp, self.sii), (gp, self.dii), (self.di, self.si)]
        self.stamps = BranchStamps(len(self.elements), controls, currents, charges, _CURRENT_DEPS, _CHARGE_DEPS)
        return self.stamps.coordinates()

    def bind(self, slots: SlotMap, n: int) -> None:
        self.stamps.bind(slots, n)

    # -- the model ---------------------------------------------------------
    def dc(self, vgs, vgd):
        """Currents and their derivatives at type-normalised (vgs, vgd), one device (``m`` excluded).

        Returns
        -------
        dict of ndarray
            ``ich`` (d' to s') with ``ich_vgs``, ``ich_vgd``; ``igs`` with ``igs_vgs``, ``igs_vgd``; ``igd``
            with ``igd_vgs``, ``igd_vgd``; ``capgs``, ``capgd`` (ngspice's capacitances); ``gm``, ``gds``
            (ngspice's: the mode's derivatives of the channel current).
        """
        from .kernels.hfet import hfet_dc

        vgs = np.atleast_1d(np.asarray(vgs, dtype=float))
        vgd = np.atleast_1d(np.asarray(vgd, dtype=float))
        keys = ("ich", "ich_vgs", "ich_vgd", "igs", "igs_vgs", "igs_vgd", "igd", "igd_vgs", "igd_vgd", "capgs",
                "capgd")
        out = {k: np.empty(vgs.shape) for k in keys}
        cols = self._par.shape[0]  # the last axis is the instance's (or broadcasts a single instance)
        with np.errstate(all="ignore"):
            for index in np.ndindex(vgs.shape):
                values = hfet_dc(float(vgs[index]), float(vgd[index]), self._par, index[-1] % cols)
                for key, value in zip(keys, values):
                    out[key][index] = value
        fwd = vgs - vgd >= 0.0
        total = out["ich_vgs"] + out["ich_vgd"]
        out["gm"] = np.where(fwd, total, -total)
        out["gds"] = -out["ich_vgd"]
        return out

    def charges(self, vgs, vgd, vgspp, vgdpp):
        """The gate charges (one device, type-normalised) and their derivatives to (vgs'', vgs, vgd), (vgd'', vgs, vgd).

        Returns
        -------
        qgs, qgd : ndarray
        dqgs, dqgd : tuple of three ndarray
        """
        from .kernels.hfet import hfet_charges

        arrays = [np.atleast_1d(np.asarray(a, dtype=float)) for a in (vgs, vgd, vgspp, vgdpp)]
        shape = arrays[0].shape
        cols = self._par.shape[0]
        out = np.empty((8,) + shape)
        with np.errstate(all="ignore"):
            for index in np.ndindex(shape):
                out[(slice(None),) + index] = hfet_charges(*(float(a[index]) for a in arrays), self._par,
                                                           index[-1] % cols)
        return out[0], out[4], (out[1], out[2], out[3]), (out[5], out[6], out[7])

    def evaluate(self, x, t, acc: Accumulator, state, jacobian):
        v = self.stamps.voltages(x)
        tp = self.type
        vn_x = v[:2] * tp
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
            cur[_ID] = r["ich"] * m * tp
            cur[_IGS] = r["igs"] * m * tp
            cur[_IGD] = r["igd"] * m * tp
            cur[_IRD] = self.gd * v[_VRD]
            cur[_IRS] = self.gs * v[_VRS]
            cur[_IRG] = self.gg * v[_VRG]
            cur[_IRI] = self.gi * v[_VRI]
            cur[_IRF] = self.gf * v[_VRF]
            dcur = np.stack([r["ich_vgs"] * m, r["ich_vgd"] * m, r["igs_vgs"] * m, r["igs_vgd"] * m,
                             r["igd_vgs"] * m, r["igd_vgd"] * m, self.gd, self.gs, self.gg, self.gi, self.gf])
            vspp = np.where(self.gi > 0.0, v[_VGSPP] * tp, vgs)
            vdpp = np.where(self.gf > 0.0, v[_VGDPP] * tp, vgd)
            qgs, qgd, dqs, dqd = self.charges(vgs, vgd, vspp, vdpp)
            cds = self.par["cds"] * m
            # the drain-source capacitance (linear) at the limited voltages, continued to x's by ``delta``
            q = np.stack([qgs * m * tp, qgd * m * tp, cds * tp * (vgs - vgd)])
            dq = np.stack([dqs[0] * m, dqs[1] * m, dqs[2] * m, dqd[0] * m, dqd[1] * m, dqd[2] * m, cds, -cds])
            delta = None
            if changed:
                acc.limited = True
                delta = np.zeros_like(v)
                delta[:2] = v[:2] - vn * tp
                delta[_VGSPP] = np.where(self.gi > 0.0, 0.0, delta[0])
                delta[_VGDPP] = np.where(self.gf > 0.0, 0.0, delta[1])
            self.stamps.add(acc, cur, dcur, q, dq, delta=delta, jacobian=jacobian)
            total = float(cur.sum() + dcur.sum() + q.sum() + dq.sum())
            if not math.isfinite(total):
                acc.ok = False
        return LimitState(vn)

    def quantities(self, x, dxdt=None):
        """ngspice's HFET quantities (``@z1[cd]``, ``@z1[gm]`` ...) at solutions ``x``, shape (T, N) each.

        ``cd`` is the drain current (channel less gate-drain current, as ngspice's ``cd``), ``cg`` the
        gate current, ``cs`` ``-(cd + cg)``, all into the device, times ``m``, and, as ngspice's, in
        type-normalised sign (a ``phfet``'s are those of the N-channel device it computes); ``vgs``,
        ``vgd`` the internal voltages (type-normalised); ``gm``, ``gds`` the mode's derivatives of the
        channel current; ``ggs``, ``ggd`` the gate currents' conductances; ``cgd`` the gate-drain current (ngspice's name); ``capgs``,
        ``capgd`` ngspice's gate capacitances; ``qgs``, ``qgd`` netdae's gate charges.
        """
        v = self.stamps.voltages_at(x)
        tp = self.type
        vgs, vgd = v[_VGS] * tp, v[_VGD] * tp
        r = self.dc(vgs, vgd)
        m = self.mult
        cd = (r["ich"] - r["igd"]) * m
        cg = (r["igs"] + r["igd"]) * m
        qgs, qgd, dqs, dqd = self.charges(vgs, vgd, v[_VGSPP] * tp, v[_VGDPP] * tp)
        if dxdt is not None:
            dv = self.stamps.voltages_at(dxdt) * tp
            i_qgs = (dqs[0] * dv[_VGSPP] + dqs[1] * dv[_VGS] + dqs[2] * dv[_VGD]) * m
            i_qgd = (dqd[0] * dv[_VGDPP] + dqd[1] * dv[_VGS] + dqd[2] * dv[_VGD]) * m
            i_ds = self.par["cds"] * m * (dv[_VGS] - dv[_VGD])
            cg = cg + i_qgs + i_qgd
            cd = cd - i_qgd + i_ds
        return {"cd": cd, "cg": cg, "cs": -(cd + cg), "vgs": vgs, "vgd": vgd, "gm": r["gm"] * m,
                "gds": r["gds"] * m, "ggs": r["igs_vgs"] * m, "ggd": r["igd_vgd"] * m,
                "cgd": r["igd"] * m, "capgs": r["capgs"] * m, "capgd": r["capgd"] * m,
                "qgs": qgs * m, "qgd": qgd * m}

    def compiled(self, slots: SlotMap, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Pack the family for :func:`netdae.devices.kernels.hfet.eval_hfet` (after ``bind``).

        Returns
        -------
        par : ndarray, shape (N, kernels.hfet.N_PAR)
        idx : ndarray of int64, shape (N, kernels.hfet.N_IDX)
        vold0 : ndarray, shape (N, 2)
            The initial state's (vgs, vgd) (:meth:`initial_state`).
        """
        from .kernels import hfet as kh
        from .kernels.packing import dependence_blocks, node_columns

        count = len(self.elements)
        idx = node_columns(count, kh.N_IDX, {
            kh.I_D: self.d, kh.I_G: self.g, kh.I_S: self.s, kh.I_DP: self.di, kh.I_SP: self.si,
            kh.I_GP: self.gi_node, kh.I_SPP: self.sii, kh.I_DPP: self.dii}, n)
        st = self.stamps
        controls = list(zip(st.ctrl_p, st.ctrl_m))
        dependence_blocks(idx, kh.S_CUR, slots, _CURRENT_DEPS, list(zip(st.cur_a, st.cur_b)), controls)
        dependence_blocks(idx, kh.S_CHG, slots, _CHARGE_DEPS, list(zip(st.chg_a, st.chg_b)), controls)
        return self._par.copy(), idx, self.initial_state().v.T.copy()
