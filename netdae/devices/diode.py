"""The junction diode, SPICE level 1, as ngspice 39 computes it.

Syntax: ``Dname anode cathode model [area] [m=M] [off] [temp=T] [dtemp=dT] [ic=V]``
with ``.model name D (IS= N= RS= TT= CJO= VJ= M= FC= BV= IBV= NBV= EG= XTI= TNOM= AREA=)``.

Equations (``vd`` the voltage across the junction, behind RS)
--------------------------------------------------------------
Current (``dioload.c``), ``Is = IS * area * m`` at temperature, ``vte = N kT/q``::

    vd >= -3 vte                 id = Is (exp(vd/vte) - 1)
    -BV <= vd < -3 vte           id = -Is (1 + (3 vte / (e vd))^3)
    vd < -BV  (BV given)         id = -Is exp(-(BV' + vd) / (NBV kT/q))
    always                       id += GMIN vd

``BV'`` is BV adjusted (``diotemp.c``) so that the breakdown current at
``-BV`` is ``m * IBV``: the root of
``Is (exp((BV - BV')/(NBV vt)) - 1 + BV'/vt) = m IBV``, found by ngspice's
fixed-point iteration (25 steps, tolerance ``reltol * m IBV``).

Charge: ``q = TT * id + qdep(vd)``, the depletion charge of
:class:`~netdae.devices.junction.Depletion` with ``CJO * area * m``,
``VJ``, ``M`` at temperature and ``FC`` (capacitance ``TT gd + cdep``).

Series resistance ``RS / (area m)`` to an internal node ``<name>#internal``
when RS > 0.

Temperature (device ``temp``, else ``.options temp`` + ``dtemp``; ``TNOM``
else ``.options tnom``): ``Is ~ exp((T/Tnom - 1) EG/(N vt) + XTI/N ln(T/Tnom))``,
``VJ``/``CJO`` by :func:`~netdae.devices.junction.scale_junction`. As
ngspice: ``IS >= 1e-28``, ``M <= 0.9``, ``VJ`` at temperature at most ``1/FC``.
Temperature coefficients (``dT = T - Tnom``): ``RS``, ``TT``, ``M`` times
``1 + c1 dT + c2 dT^2`` (``TRS``/``TRS1`` and ``TRS2``, ``TTT1``/``TTT2``,
``TM1``/``TM2``); ``BV - TCV dT`` (``TLEV=0``) or ``BV (1 - TCV dT)``
(``TLEV=1``) before the IBV adjustment.

Newton: ``pnjlim`` on ``vd`` with ``vcrit = vte ln(vte / (sqrt 2 Is))``,
in the breakdown region on ``-(vd + BV')`` with ``NBV vt``; the first
iteration from a zero iterate starts at ``vcrit`` (0 for ``off``).

Noise (``.noise``, :meth:`DiodeFamily.noise`, ngspice's ``dionoise.c``):
thermal noise of RS, shot noise ``2 q |id|`` of the junction current and
flicker noise ``KF m |id/m|^AF / f``. Accepted without effect:
safe-operating-area limits (``FV_MAX`` ...). The instance ``ic`` is only used by ngspice for
the first iterate of a ``uic`` transient and does not change any solution.
High injection (``IKF``, ``IKR``, area and m scaled, as ngspice 39): a
forward junction current ``c`` becomes ``c / (1 + sqrt(c / IKF))``, a reverse
one (below ``-3 N vt``, breakdown included) ``c / (1 + sqrt(c / -IKR))``
(:func:`knee_current`), and the diffusion charge ``TT id`` follows the
current with the knee, as in ngspice 39 (a transient through breakdown and
forward recovery agrees with it to its printed digits; with the current
without the knee, the ``cdb`` of older ngspice sources, it was 17 mV off).
Any other parameter (sidewall,
tunnelling, recombination, level 3, ``TLEVC``) is rejected with an error.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import CircuitError
from .base import Accumulator, DeviceFamily, NoiseSources, SlotMap, flicker, noise_sources, shot, thermal
from .companion import BranchStamps, LimitState, starting_voltages
from .junction import (
    EPSMIN,
    KELVIN,
    Depletion,
    ideal_junction,
    pnjlim,
    quadratic_factor,
    saturation_exponent,
    scale_junction,
    thermal_voltage,
    vcrit,
)
from .modelcard import ParameterTable, gather, instance_values, require_positive, resolve_model

__all__ = ["DiodeFamily", "DIODE_PARAMETERS", "breakdown_voltage", "junction_limit", "junction_current", "knee_current",
           "diode_structure", "diode_branches"]

DIODE_PARAMETERS = ParameterTable(
    "diode (level 1)",
    defaults={
        "level": 1.0, "is": 1e-14, "n": 1.0, "rs": 0.0, "tt": 0.0, "cjo": 0.0, "vj": 1.0, "m": 0.5,
        "fc": 0.5, "bv": None, "ibv": 1e-3, "nbv": None, "eg": 1.11, "xti": 3.0, "tnom": None, "area": 1.0,
        "ikf": 0.0, "ikr": 0.0, "tlev": 0.0, "tcv": 0.0, "trs": 0.0, "trs2": 0.0, "ttt1": 0.0, "ttt2": 0.0,
        "tm1": 0.0, "tm2": 0.0,
    },
    aliases={"js": "is", "cj0": "cjo", "cj": "cjo", "pb": "vj", "mj": "m", "ib": "ibv", "tref": "tnom", "ik": "ikf",
             "trs1": "trs"},
    inert=frozenset({"kf", "af", "fv_max", "bv_max", "id_max", "pd_max", "te_max"}),
    family="diode",
    grading=frozenset({"m"}),
)

#: Instance parameters and their defaults (None: absent unless given).
_INSTANCE = {"area": None, "m": 1.0, "off": 0.0, "temp": None, "dtemp": 0.0, "ic": None}
#: ngspice caps the grading coefficient at 0.9 (``DIOgradingCoeffMax``).
GRADING_MAX = 0.9
#: ngspice caps the forward-bias depletion coefficient FC at 0.95 (diotemp.c; ln(1 - fc) needs fc < 1).
FC_MAX = 0.95
#: Breakdown adjustment: ngspice's iteration limit.
BREAKDOWN_ITERATIONS = 25
#: ngspice starts limiting in breakdown 10 (NBV vt) above -BV.
_BREAKDOWN_LIMIT_MARGIN = 10.0
#: ngspice's reverse-region knee (3 vte).
_REVERSE_KNEE = 3.0
#: ngspice applies a knee current only to a junction current beyond this magnitude [A].
KNEE_MIN_CURRENT = 1e-18


def breakdown_voltage(bv, ibv, isat, nbv_vt, vt, reltol):
    """ngspice's breakdown voltage adjusted to the breakdown current (vectorised).

    Parameters
    ----------
    bv : ndarray
        Breakdown voltage BV [V].
    ibv : ndarray
        Current at breakdown, already times the multiplier m [A].
    isat : ndarray
        Saturation current at temperature (area and m included) [A].
    nbv_vt : ndarray
        NBV times the thermal voltage [V].
    vt : ndarray
        Thermal voltage [V].
    reltol : float
        The circuit's relative tolerance (ngspice's stopping test uses it).

    Returns
    -------
    ndarray
        The adjusted breakdown voltage ``BV'``.

    Notes
    -----
    When ``ibv < isat * bv / vt`` ngspice keeps BV; otherwise it iterates
    ``BV' = BV - NBV vt ln(ibv/isat + 1 - BV'/vt)`` at most 25 times,
    stopping where the breakdown current is within ``reltol * ibv``.
    """
    bv = np.asarray(bv, dtype=float)
    xbv = bv.copy()
    iterate = ~(ibv < isat * bv / vt)
    if not np.any(iterate):
        return xbv
    tol = reltol * ibv
    x = np.where(iterate, bv - nbv_vt * np.log(1.0 + ibv / isat), bv)
    active = iterate.copy()
    for _ in range(BREAKDOWN_ITERATIONS):
        # only the iterating entries: on the others x = BV may exceed vt (ibv/isat + 1) (their log would be
        # of a negative number, and its value is discarded anyway)
        x_new = bv - nbv_vt * np.log(np.where(active, ibv / isat + 1.0 - x / vt, 1.0))
        x = np.where(active, x_new, x)
        xcbv = isat * (np.exp((bv - x) / nbv_vt) - 1.0 + x / vt)
        active &= ~(np.abs(xcbv - ibv) <= tol)
        if not np.any(active):
            break
    return np.where(iterate, x, xbv)


def junction_limit(vd, vold, vte, vcrit_, has_bv, bv, vtebrk, any_bv=True):
    """ngspice's limiting of a diode junction with breakdown (``dioload.c``), vectorised.

    ``pnjlim`` on ``vd``; where BV is given and ``vd < min(0, -BV' + 10 NBV vt)``,
    ``pnjlim`` on ``-(vd + BV')`` with ``NBV vt`` instead.

    Parameters
    ----------
    vd, vold : ndarray
        The iterate's and the previous iteration's junction voltages.
    vte, vcrit_ : ndarray
        ``N vt`` and the critical voltage.
    has_bv : ndarray of bool
        Where a breakdown voltage is given.
    bv, vtebrk : ndarray
        ``BV'`` (:func:`breakdown_voltage`) and ``NBV vt``.
    any_bv : bool
        ``has_bv.any()``, precomputed by the caller.

    Returns
    -------
    v : ndarray
        The limited voltages.
    changed : ndarray of bool or None
        Where they changed (None: nowhere).
    """
    vf, cf = pnjlim(vd, vold, vte, vcrit_)
    if not any_bv:
        return vf, cf
    in_breakdown = has_bv & (vd < np.minimum(0.0, -bv + _BREAKDOWN_LIMIT_MARGIN * vtebrk))
    if not in_breakdown.any():
        return vf, cf
    vb, cb = pnjlim(-(vd + bv), -(vold + bv), vtebrk, vcrit_)
    no = np.zeros(vd.shape, dtype=bool)
    changed = np.where(in_breakdown, no if cb is None else cb, no if cf is None else cf)
    return np.where(in_breakdown, -(vb + bv), vf), (changed if changed.any() else None)


def junction_current(vd, isat, vte, knee, has_bv, bv, vtebrk, gmin, any_bv=True):
    """A diode junction's current (GMIN included) and conductance with breakdown (``dioload.c``).

    ``Is (exp(vd/vte) - 1)`` above ``knee = -3 vte``, ngspice's reverse cubic
    below (:func:`~netdae.devices.junction.ideal_junction`), and where BV is
    given, below both ``-BV'`` and the knee, ``-Is exp(-(BV' + vd)/(NBV vt))``;
    plus ``GMIN vd``.

    Returns
    -------
    cd, gd : ndarray
    """
    cd, gd = ideal_junction(vd, isat, vte, knee)
    if any_bv:
        brk = has_bv & (vd < -bv) & (vd < knee)
        if brk.any():
            evrev = np.exp(np.where(brk, -(bv + vd) / vtebrk, 0.0))
            cd = np.where(brk, -isat * evrev, cd)
            gd = np.where(brk, isat * evrev / vtebrk, gd)
    return cd + gmin * vd, gd + gmin


def knee_current(cd, gd, vd, gmin, knee, ikf, ikr):
    """High injection of a diode junction (ngspice's ``IKF``/``IKR``, ``dioload.c``), vectorised.

    With ``c = cd - GMIN vd`` the junction's own current: forward (``vd >=
    knee``) and above 1e-18 A where ``IKF > 0``, ``c / (1 + s)`` with ``s =
    sqrt(c / IKF)``; reverse and below -1e-18 A where ``IKR > 0``, the same
    with ``s = sqrt(-c / IKR)``; the conductance by the chain rule,
    ``g ((1 + s) - c / (2 s IK)) / (1 + s)^2``; GMIN's part added back.

    Parameters
    ----------
    cd, gd, vd : ndarray, shape (N,)
        :func:`junction_current`'s current and conductance at ``vd``.
    gmin : float
    knee : ndarray
        ``-3 N vt``.
    ikf, ikr : ndarray
        The knee currents, area and m included (0: none).

    Returns
    -------
    cd, gd : ndarray
    """
    c, g = cd - gmin * vd, gd - gmin
    fwd = (vd >= knee) & (ikf > 0.0) & (c > KNEE_MIN_CURRENT)
    rev = (vd < knee) & (ikr > 0.0) & (c < -KNEE_MIN_CURRENT)
    if fwd.any() or rev.any():
        ik = np.where(fwd, ikf, np.where(rev, -ikr, 1.0))
        on = fwd | rev
        s = np.sqrt(np.where(on, c / ik, 1.0))
        g = np.where(on, ((1.0 + s) * g - c * g / (2.0 * s * ik)) / (1.0 + 2.0 * s + c / ik), g)
        c = np.where(on, c / (1.0 + s), c)
    return c + gmin * vd, g + gmin


def diode_structure(values) -> tuple[bool, bool]:
    """What a diode's model makes of its structure: (series resistance, junction charge).

    Parameters
    ----------
    values : mapping
        The model's values (:meth:`ParameterTable.read` of :data:`DIODE_PARAMETERS`).

    Returns
    -------
    (bool, bool)
        RS > 0: an internal node ``<name>#internal`` between RS and the
        junction; CJO or TT nonzero: the junction stores charge.
    """
    return values["rs"] > 0.0, values["cjo"] != 0.0 or values["tt"] != 0.0


def diode_branches(circuit, el) -> tuple[tuple[int, int | str, int | str], ...]:
    """The topological analysis's branches of one diode (its kind's ``topology`` hook, :mod:`netdae.kinds`).

    Returns
    -------
    tuple of (class, a, b)
        ``a``/``b`` a position in ``el.nodes`` or the suffix of an internal
        node: the series resistance (anode to ``#internal``) when RS > 0, the
        junction (resistive), and its charge (capacitive) when it has one.
    """
    from ..kinds import CAPACITIVE, RESISTIVE

    model = circuit.models.get(el.model) if el.model else None
    series, charge = diode_structure(DIODE_PARAMETERS.read(model)) if model is not None else (False, False)
    junction: int | str = "#internal" if series else 0
    branches: list[tuple[int, int | str, int | str]] = [(RESISTIVE, 0, junction)] if series else []
    branches.append((RESISTIVE, junction, 1))
    if charge:
        branches.append((CAPACITIVE, junction, 1))
    return tuple(branches)


class DiodeFamily(DeviceFamily):
    """All diodes of a circuit, evaluated in one vectorised pass.

    Parameters
    ----------
    elements : list of Element
        The ``diode`` elements.
    circuit : Circuit

    Raises
    ------
    CircuitError
        Missing or mistyped model, unsupported parameter, level other than 1.
    """

    limits_from_point = True

    shareable = True


    def __init__(self, elements, circuit) -> None:
        super().__init__(elements, circuit)
        opts = circuit.options
        self.gmin = float(opts.gmin)
        rows = []
        for el in self.elements:
            model = resolve_model(el, circuit, ("d",))
            mv = DIODE_PARAMETERS.read(model)
            if mv["level"] != 1.0:
                raise CircuitError(f"{el.name}: diode model {model.name} has level {mv['level']:g}; "
                                   "netdae implements level 1", elements=(el.name,))
            inst = instance_values(el, _INSTANCE, "diode")
            if mv["tlev"] not in (0.0, 1.0):
                at = model.locations.get("tlev", model.location)
                raise CircuitError(f"{el.name}: diode model {model.name} has tlev={mv['tlev']:g}; netdae "
                                   "implements tlev=0 and tlev=1 (as ngspice 39: they differ only in TCV's breakdown "
                                   "voltage)", elements=(el.name,), location=at)
            row = {k: mv[k] for k in ("is", "n", "rs", "tt", "cjo", "vj", "m", "fc", "ibv", "eg", "xti", "ikf",
                                      "ikr", "tlev", "tcv", "trs", "trs2", "ttt1", "ttt2", "tm1", "tm2")}
            row["bv"] = mv.get("bv", np.nan)
            row["nbv"] = mv.get("nbv", mv["n"])
            row["tnom"] = mv.get("tnom", opts.tnom) + KELVIN
            row["temp"] = inst.get("temp", opts.temp + inst["dtemp"]) + KELVIN
            row["area"] = inst.get("area", mv["area"])
            row["mult"] = inst["m"]
            row["off"] = inst["off"]
            require_positive(el, row, (("area", "area"), ("mult", "m")))
            row["kf"], row["af"] = model.params.get("kf", 0.0), model.params.get("af", 1.0)
            row["series"], row["charge"] = (float(fact) for fact in diode_structure(mv))
            rows.append(row)
        self._setup(rows, opts.reltol)

    def _setup(self, rows, reltol: float) -> None:
        g = lambda name: gather(rows, name)  # noqa: E731
        temp, tnom = g("temp"), g("tnom")
        dt = temp - tnom
        area = g("area") * g("mult")
        n = g("n")
        self.vt = thermal_voltage(temp)
        self.vte = n * self.vt
        grading = np.minimum(g("m") * quadratic_factor(g("tm1"), g("tm2"), dt), GRADING_MAX)
        cj, vj = scale_junction(g("cjo") * area, grading, g("vj"), tnom, temp)
        self.isat = np.maximum(g("is"), EPSMIN) * area * np.exp(saturation_exponent(g("eg"), g("xti"), tnom, temp) / n)
        self.vcrit = vcrit(self.vte, self.isat)
        fc = np.minimum(g("fc"), FC_MAX)
        self.depletion = Depletion(cj, np.where(fc * vj > 1.0, 1.0 / fc, vj), grading, fc)
        self.tt = g("tt") * quadratic_factor(g("ttt1"), g("ttt2"), dt)
        rs, series = g("rs") * quadratic_factor(g("trs"), g("trs2"), dt), g("series") != 0.0
        self.gs = np.where(series, area / np.where(series, rs, 1.0), 0.0)
        bv, tcv = g("bv"), g("tcv")
        bv = np.where(g("tlev") == 0.0, bv - tcv * dt, bv * (1.0 - tcv * dt))
        self.has_bv = np.isfinite(bv)
        self.vtebrk = g("nbv") * self.vt
        self.knee = -_REVERSE_KNEE * self.vte
        self.bv = np.where(self.has_bv, breakdown_voltage(np.where(self.has_bv, bv, 0.0), g("mult") * g("ibv"),
                                                          self.isat, self.vtebrk, self.vt, reltol), 0.0)
        self.off = g("off") != 0.0
        self.mult = g("mult")
        self.kf, self.af = g("kf"), g("af")
        self.has_rs = bool(np.any(self.gs > 0.0))
        self.any_bv = bool(np.any(self.has_bv))
        self.has_tt = bool(np.any(self.tt != 0.0))
        self.has_charge = bool(np.any(g("charge") != 0.0))  # the topology's fact too (diode_branches)
        self.ikf, self.ikr = np.maximum(g("ikf"), 0.0) * area, np.maximum(g("ikr"), 0.0) * area
        self.has_knee = bool(np.any(self.ikf > 0.0) or np.any(self.ikr > 0.0))

    # -- topology ----------------------------------------------------------
    def add_nodes(self, layout) -> None:
        self.anode = layout.nodes_of([el.nodes[0] for el in self.elements])
        self.cathode = layout.nodes_of([el.nodes[1] for el in self.elements])
        inner = [layout.add_node(f"{el.name}#internal", internal=True, beside=int(a)) if gs > 0.0 else a
                 for el, gs, a in zip(self.elements, self.gs, self.anode)]
        self.inner = np.array(inner, dtype=np.int64)

    def coordinates(self, layout):
        junction = (self.inner, self.cathode)
        controls, currents, deps = [junction], [junction], [(0, 0)]
        if self.has_rs:
            controls.append((self.anode, self.inner))
            currents.append((self.anode, self.inner))
            deps.append((1, 1))
        charges = [junction] if self.has_charge else []
        self.stamps = BranchStamps(len(self.elements), controls, currents, charges, deps,
                                   [(0, 0)] if self.has_charge else [])
        return self.stamps.coordinates()

    def bind(self, slots: SlotMap, n: int) -> None:
        self.stamps.bind(slots, n)
        count = len(self.elements)
        self._cur = np.zeros((2 if self.has_rs else 1, count))
        self._dcur = np.zeros((2 if self.has_rs else 1, count))
        if self.has_rs:
            self._dcur[1] = self.gs
        self._q = np.zeros((1 if self.has_charge else 0, count))
        self._dq = np.zeros((1 if self.has_charge else 0, count))

    def junction_nodes(self) -> list[tuple[str, str]]:
        return [(el.nodes[0], el.nodes[1]) for el in self.elements]

    # -- Newton support ----------------------------------------------------
    def initial_state(self) -> LimitState:
        """SPICE's ``MODEINITJCT``: ``vd = vcrit`` (0 for ``off`` diodes)."""
        return LimitState(np.where(self.off, 0.0, self.vcrit)[None, :], initial=True)

    def limit(self, vd: np.ndarray, vold: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
        """ngspice's diode limiting: pnjlim, shifted by BV' in deep reverse bias.

        Returns the limited voltages and where they changed (None: nowhere).
        """
        return junction_limit(vd, vold, self.vte, self.vcrit, self.has_bv, self.bv, self.vtebrk, self.any_bv)

    def current(self, vd: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Diode current (GMIN and the high-injection knee included) and conductance at junction voltage ``vd``."""
        cd, gd = junction_current(vd, self.isat, self.vte, self.knee, self.has_bv, self.bv, self.vtebrk, self.gmin,
                                  self.any_bv)
        if self.has_knee:
            return knee_current(cd, gd, vd, self.gmin, self.knee, self.ikf, self.ikr)
        return cd, gd

    def charge(self, vd: np.ndarray, cd: np.ndarray, gd: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Junction charge ``TT id + qdep(vd)`` and its derivative."""
        qdep, cdep = self.depletion(vd)
        if self.has_tt:
            return self.tt * cd + qdep, self.tt * gd + cdep
        return qdep, cdep

    def quantities(self, x, dxdt=None):
        """ngspice's diode quantities (``@d1[id]`` ...) at solutions ``x``, shape (T, N) each.

        ``vd`` is the junction voltage, behind RS; ``id`` (and its alias ``c``)
        the current from anode to cathode, in a transient with the charge's
        current ``cd dvd/dt``; ``gd`` and ``cd`` the junction's conductance and
        capacitance (:meth:`current`, :meth:`charge`); ``p`` the power of the
        diode with its series resistance, ``vd id + id^2 RS`` (as ngspice 39).
        """
        vd = self.stamps.voltages_at(x)[0]
        with np.errstate(all="ignore"):
            cd, gd = self.current(vd)
            if self.has_charge:
                q, c = self.charge(vd, cd, gd)
            else:
                q, c = np.zeros_like(vd), np.zeros_like(vd)
        i = cd
        if dxdt is not None and self.has_charge:
            i = cd + self.stamps.charge_rates(c[None], self.stamps.voltages_at(dxdt))[0]
        rs = np.where(self.gs > 0.0, 1.0 / np.where(self.gs > 0.0, self.gs, 1.0), 0.0)
        return {"vd": vd, "id": i, "c": i, "gd": gd, "cd": c, "charge": q, "p": i * (vd + i * rs)}

    def compiled(self, slots: SlotMap, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Pack the family for :func:`netdae.devices.kernels.diode.eval_diode` (after ``bind``).

        Returns
        -------
        par : ndarray, shape (N, kernels.diode.N_PAR)
        idx : ndarray of int64, shape (N, kernels.diode.N_IDX)
        vold0 : ndarray, shape (N, 1)
            The initial state's junction voltages (:meth:`initial_state`).
        """
        from .kernels import diode as kd
        from .kernels.packing import columns, dependence_slots, depletion_columns, node_columns

        count = len(self.elements)
        par = columns(count, kd.N_PAR, {
            kd.P_ISAT: self.isat, kd.P_VTE: self.vte, kd.P_VCRIT: self.vcrit, kd.P_KNEE: self.knee,
            kd.P_GMIN: self.gmin, kd.P_HAS_BV: self.has_bv, kd.P_BV: self.bv, kd.P_VTEBRK: self.vtebrk,
            kd.P_TT: self.tt, kd.P_GS: self.gs, kd.P_CHARGE: self.has_charge, kd.P_IKF: self.ikf,
            kd.P_IKR: self.ikr})
        par[:, kd.P_DEP:kd.P_DEP + 9] = depletion_columns(self.depletion)
        idx = node_columns(count, kd.N_IDX, {kd.I_A: self.anode, kd.I_I: self.inner, kd.I_K: self.cathode}, n)
        idx[:, kd.S_J:kd.S_J + 4] = dependence_slots(slots, self.inner, self.cathode, self.inner, self.cathode)
        idx[:, kd.S_R:kd.S_R + 4] = dependence_slots(slots, self.anode, self.inner, self.anode, self.inner,
                                                            where=self.gs > 0.0)
        return par, idx, self.initial_state().v.T.copy()

    def noise(self, x: np.ndarray, temp: float) -> NoiseSources:
        """ngspice's diode noise (``dionoise.c``) at the operating point ``x`` (extended).

        Generators, each between two nodes: ``_rs`` thermal noise of the series
        resistance (anode to internal node), ``_id`` shot noise ``2 q |id|`` and
        ``_1overf`` flicker noise ``KF m |id/m|^AF / f`` of the junction current
        ``id`` (GMIN included, as ngspice's), internal node to cathode.
        """
        cd, _ = self.current(x[self.inner] - x[self.cathode])
        names = [el.name for el in self.elements]
        return noise_sources(names, [
            ("_rs", self.inner, self.anode, thermal(self.gs, temp), 0.0, 1.0),
            ("_id", self.inner, self.cathode, shot(cd), 0.0, 1.0),
            ("_1overf", self.inner, self.cathode, 0.0, self.mult * flicker(self.kf, cd / self.mult, self.af), 1.0),
        ])

    def evaluate(self, x, t, acc: Accumulator, state, jacobian):
        v = self.stamps.voltages(x)
        vd_x = v[0]
        with np.errstate(all="ignore"):
            start = starting_voltages(state, x, v[:1])
            if start is None:
                vd, changed = self.limit(vd_x, state.v[0])
            else:
                vd, changed = start[0][0], (True if start[1] else None)
            cd, gd = self.current(vd)
            cur, dcur = self._cur, self._dcur
            cur[0] = cd
            dcur[0] = gd
            if self.has_rs:
                np.multiply(self.gs, v[1], out=cur[1])
            if self.has_charge:
                q, c = self.charge(vd, cd, gd)
                self._q[0] = q
                self._dq[0] = c
            delta = None
            if changed is not None:
                acc.limited = True
                delta = np.zeros_like(v)
                delta[0] = vd_x - vd
            self.stamps.add(acc, cur, dcur, self._q, self._dq, delta=delta, jacobian=jacobian)
            if not math.isfinite(float(cd.sum() + gd.sum()) + (float(q.sum() + c.sum()) if self.has_charge else 0.0)):
                acc.ok = False
        return LimitState(vd[None, :])
