"""The junction FET (SPICE level 1, N and P channel) as ngspice 39 computes it.

Syntax: ``Jname d g s model [area] [off] [ic=vds,vgs] [temp=T] [dtemp=dT] [m=M]`` with
``.model name NJF|PJF (VTO BETA LAMBDA RD RS CGS CGD PB IS FC B TNOM TCV VTOTC BEX BETATCE
XTI EG)``. Level 2 (Parker-Skellern) is refused.

Equations (type-normalised: for a PJF every voltage and current changes sign)
---------------------------------------------------------------------------
``jfetload.c``, Shichman-Hodges with the Sydney University doping-tail
parameter B (``B = 1`` is the square law). The device runs in normal mode
(``vds >= 0``) or with source and drain exchanged; with ``u`` the mode's
gate overdrive (``vgs - VTO`` or ``vgd - VTO``) and ``w = |vds| >= 0``,
``f(u) = B u^2 + Bfac u^3``, ``Bfac = (1 - B) / (PB - VTO)`` (nominal PB and
VTO, as ngspice)::

    id = 0                                          u <= 0     (cutoff)
       = BETA (1 + LAMBDA w) f(u)                   0 < u < w  (saturation)
       = BETA (1 + LAMBDA w) (f(u) - f(u - w))      u >= w     (linear)

flowing from the mode's drain to its source. The linear form is evaluated as
``w ((2u - w) B + Bfac (u^2 + u (u - w) + (u - w)^2))``, exact near ``w = 0``.
Its derivatives are exact: ngspice's ``gm`` and ``gds`` are the derivatives
of this current.

Gate junctions: ``igs = IS_t (exp(vgs/vt) - 1) + GMIN vgs`` (gate to source),
the same for ``igd`` with vgd, with ngspice's reverse cubic below ``-3 vt``
(:func:`~netdae.devices.junction.ideal_junction`; the emission coefficient
is 1). Depletion charges ``qgs``, ``qgd`` with ``CGS``, ``CGD`` at
temperature, ``PB`` at temperature, grading 1/2 and ``FC`` (at most 0.95,
as ngspice), by :class:`~netdae.devices.junction.Depletion`.

``RD``, ``RS`` (when non-zero) to internal nodes ``<name>#drain``,
``<name>#source``, conductance ``area / R``. ``area`` multiplies BETA, IS,
CGS, CGD; the multiplier ``m`` multiplies every current, conductance and
charge (GMIN included).

Temperature (``jfettemp.c``; device ``temp``, else ``.options temp`` +
``dtemp``; ``TNOM`` else ``.options tnom``):

- ``IS_t = IS exp((T/Tnom - 1) EG/vt) (T/Tnom)^XTI``, the power only when XTI
  is given (ngspice's default XTI = 3 is not used otherwise);
- ``VTO_t = VTO + VTOTC (T - Tnom)`` when VTOTC is given, else
  ``VTO - TCV (T - Tnom)``;
- ``BETA_t = BETA 1.01^(BETATCE (T - Tnom))`` when BETATCE is given, else
  ``BETA (T/Tnom)^BEX``;
- ``PB``, ``CGS``, ``CGD`` by :func:`~netdae.devices.junction.scale_junction`
  with grading 1/2.

Newton (``jfetload.c``): ``pnjlim`` on vgs and on vgd (``vt``,
``vcrit = vt ln(vt / (sqrt 2 IS_t))`` without area), then ``fetlim`` of each
against ``VTO_t``; the first iteration from a zero iterate starts at
``vgs = vgd = -1`` (0 for ``off``).

Noise (``.noise``, :meth:`JfetFamily.noise`, ngspice's ``jfetnoi.c``): thermal
noise of RD and RS, channel thermal noise ``4 k T (2/3) |gm|`` (``NLEV < 3``,
ngspice's default 2) or, with ``NLEV = 3``, ``4 k T (2/3) beta vgst
(1 + a + a^2)/(1 + a) GDSNOI`` (``a = 1 - vds/vgst`` in the linear region, 0
in saturation), and flicker noise ``m KF |id|^AF / f`` (``id`` of one
device: the channel current less the gate-drain junction's). Accepted
without effect: the instance ``ic=vds,vgs``, which ngspice uses only for the first iterate of a
``uic`` transient.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import CircuitError
from .base import Accumulator, DeviceFamily, NoiseSources, SlotMap, flicker, noise_sources, series_nodes, thermal
from .companion import BranchStamps, GateJunctionLimits, LimitState, starting_voltages
from .junction import KELVIN, Depletion, ideal_junction, saturation_exponent, scale_junction, \
    thermal_voltage, vcrit
from .modelcard import ParameterTable, gather, instance_values, require_positive, resolve_model

__all__ = ["JfetFamily", "JFET_PARAMETERS", "channel_current"]

JFET_PARAMETERS = ParameterTable(
    "JFET (level 1)",
    defaults={
        "level": 1.0, "vto": -2.0, "beta": 1e-4, "lambda": 0.0, "rd": 0.0, "rs": 0.0, "cgs": 0.0, "cgd": 0.0,
        "pb": 1.0, "is": 1e-14, "fc": 0.5, "b": 1.0, "tnom": None, "tcv": 0.0, "vtotc": None, "bex": 0.0,
        "betatce": None, "xti": None, "eg": 1.11, "area": 1.0,
    },
    aliases={"vt0": "vto"},
    inert=frozenset({"njf", "pjf", "kf", "af", "nlev", "gdsnoi"}),
    family="jfet",
)

#: Instance parameters and their defaults (None: absent unless given).
_INSTANCE = {"area": None, "m": 1.0, "off": 0.0, "icvds": None, "icvgs": None, "temp": None, "dtemp": 0.0}
#: ngspice's default NLEV: the channel's thermal noise from gm (NLEV = 3: from the bias).
NOISE_LEVEL = 2.0
#: ngspice limits FC to 0.95 (with a warning) and grades the gate junctions with 1/2.
FC_MAX = 0.95
GRADING = 0.5
#: BETATCE is a percentage per kelvin: BETA 1.01^(BETATCE (T - Tnom)).
BETATCE_BASE = 1.01
#: ngspice's reverse-bias knee of the gate junctions (3 vt) and MODEINITJCT's vgs = vgd [V].
_REVERSE_KNEE = 3.0

# controls: vgs, vgd (type-normalised internally), the two series resistors
_VGS, _VGD, _VRD, _VRS = range(4)
_ID, _IGS, _IGD, _IRD, _IRS = range(5)
_CURRENT_DEPS = [(_ID, _VGS), (_ID, _VGD), (_IGS, _VGS), (_IGD, _VGD), (_IRD, _VRD), (_IRS, _VRS)]
_CHARGE_DEPS = [(0, _VGS), (1, _VGD)]


def channel_current(u, w, beta, lam, b, bfac):
    """Drain current of the mode and its derivatives, vectorised.

    Parameters
    ----------
    u : ndarray
        Gate overdrive of the mode: ``vgs - VTO`` (normal mode) or ``vgd - VTO``.
    w : ndarray
        Drain-source voltage of the mode, ``|vds| >= 0``.
    beta, lam, b, bfac : ndarray or float
        ``BETA`` (area and m included), LAMBDA, B and ``(1 - B)/(PB - VTO)``.

    Returns
    -------
    i, di_du, di_dw : ndarray
        The current from the mode's drain to its source and its derivatives.

    Examples
    --------
    >>> i, gu, gw = channel_current(np.array([1.0, 1.0]), np.array([3.0, 0.5]), 1e-3, 0.0, 1.0, 0.0)
    >>> (i * 1e3).tolist(), (gu * 1e3).tolist(), (gw * 1e3).tolist()  # saturation, linear
    ([1.0, 0.75], [2.0, 1.0], [0.0, 1.0])
    """
    p = beta * (1.0 + lam * w)
    on = u > 0.0
    sat = on & (u < w)
    lin = on & ~sat
    r = u - w
    fu = u * u * (b + bfac * u)
    flin = w * ((u + r) * b + bfac * (u * u + u * r + r * r))
    i = np.where(sat, p * fu, np.where(lin, p * flin, 0.0))
    di_du = np.where(sat, p * u * (2.0 * b + 3.0 * bfac * u),
                     np.where(lin, p * w * (2.0 * b + 3.0 * bfac * (u + r)), 0.0))
    di_dw = np.where(sat, beta * lam * fu,
                     np.where(lin, p * r * (2.0 * b + 3.0 * bfac * r) + beta * lam * flin, 0.0))
    return i, di_du, di_dw


class JfetFamily(GateJunctionLimits, DeviceFamily):
    """All level-1 JFETs of a circuit, evaluated in one vectorised pass.

    Raises
    ------
    CircuitError
        Missing or mistyped model, unsupported parameter, a non-positive
        area or multiplier, ``PB = VTO`` with ``B != 1`` (the doping-tail
        factor divides by their difference).
    """

    limits_from_point = True

    shareable = True


    def __init__(self, elements, circuit) -> None:
        super().__init__(elements, circuit)
        opts = circuit.options
        self.gmin = float(opts.gmin)
        rows = []
        for el in self.elements:
            model = resolve_model(el, circuit, ("njf", "pjf"))
            mv = JFET_PARAMETERS.read(model)
            if len(el.nodes) != 3:
                raise CircuitError(f"{el.name}: a JFET has 3 nodes (d g s)", elements=(el.name,), location=el.location)
            inst = instance_values(el, _INSTANCE, "JFET")
            row = {k: mv[k] for k in ("vto", "beta", "lambda", "rd", "rs", "cgs", "cgd", "pb", "is", "fc", "b",
                                      "tcv", "bex", "eg")}
            if row["pb"] == row["vto"] and row["b"] != 1.0:
                raise CircuitError(f"{el.name}: model {model.name}: PB = VTO = {row['pb']:g} V; the doping-"
                                   "tail factor (1 - B)/(PB - VTO) is undefined", elements=(el.name,),
                                   hint="give PB above VTO (PB is the gate junction potential)", location=el.location)
            row["type"] = 1.0 if model.type.lower() == "njf" else -1.0
            row["vtotc"] = mv.get("vtotc", np.nan)
            row["betatce"] = mv.get("betatce", np.nan)
            row["xti"] = mv.get("xti", 0.0)  # ngspice uses XTI only when it is given
            row["fc"] = min(row["fc"], FC_MAX)
            row["tnom"] = mv.get("tnom", opts.tnom) + KELVIN
            row["temp"] = inst.get("temp", opts.temp + inst["dtemp"]) + KELVIN
            row["area"] = inst.get("area", mv["area"])
            row["mult"] = inst["m"]
            row["off"] = inst["off"]
            for key, default in (("kf", 0.0), ("af", 1.0), ("nlev", NOISE_LEVEL), ("gdsnoi", 1.0)):
                row[key] = model.params.get(key, default)
            require_positive(el, row, (("area", "area"), ("mult", "m")))
            rows.append(row)
        self._setup(rows)

    def _setup(self, rows) -> None:
        g = lambda name: gather(rows, name)  # noqa: E731
        temp, tnom = g("temp"), g("tnom")
        scale = g("area") * g("mult")
        self.type = g("type")
        self.vt = thermal_voltage(temp)
        is_t = g("is") * np.exp(saturation_exponent(g("eg"), g("xti"), tnom, temp))
        self.vcrit = vcrit(self.vt, is_t)
        self.isat = is_t * scale
        self.knee = -_REVERSE_KNEE * self.vt
        self.gmin_m = self.gmin * g("mult")
        dtemp = temp - tnom
        vtotc = g("vtotc")
        self.vto = np.where(np.isfinite(vtotc), g("vto") + np.where(np.isfinite(vtotc), vtotc, 0.0) * dtemp,
                            g("vto") - g("tcv") * dtemp)
        betatce = g("betatce")
        beta_t = np.where(np.isfinite(betatce), g("beta") * BETATCE_BASE ** (np.where(np.isfinite(betatce),
                                                                                        betatce, 0.0) * dtemp),
                          g("beta") * (temp / tnom) ** g("bex"))
        self.beta = beta_t * scale
        self.lam = g("lambda")
        self.b = g("b")
        # B = 1 is the square law whatever PB - VTO is (ngspice's 0/0 when PB = VTO would be nan)
        tail = self.b != 1.0
        self.bfac = np.where(tail, (1.0 - self.b) / np.where(tail, g("pb") - g("vto"), 1.0), 0.0)
        cgs, pb_t = scale_junction(g("cgs"), GRADING, g("pb"), tnom, temp)
        cgd, _ = scale_junction(g("cgd"), GRADING, g("pb"), tnom, temp)
        self.pb = pb_t
        fc = g("fc")
        # the gate-source and gate-drain junctions of all devices stacked: [0, N) gs, [N, 2N) gd
        self.depletion = Depletion(np.concatenate([cgs * scale, cgd * scale]), np.tile(pb_t, 2), GRADING,
                                   np.tile(fc, 2))
        self.gd = self._conductance(g("rd"), scale)
        self.gs = self._conductance(g("rs"), scale)
        self.off = g("off") != 0.0
        self.mult = g("mult")
        self.kf, self.af, self.nlev, self.gdsnoi = g("kf"), g("af"), g("nlev"), g("gdsnoi")
        self.j_isat = np.tile(self.isat, 2)
        self.j_vt = self.lim_vt = np.tile(self.vt, 2)
        self.j_knee = np.tile(self.knee, 2)
        self.j_gmin = np.tile(self.gmin_m, 2)
        self.lim_vcrit = np.tile(self.vcrit, 2)
        self.lim_vto = np.tile(self.vto, 2)
        self.has_charge = self.depletion.active

    @staticmethod
    def _conductance(r, scale) -> np.ndarray:
        """``scale / R`` where R != 0, else 0 (no series resistance)."""
        nz = r != 0.0
        return np.where(nz, scale / np.where(nz, r, 1.0), 0.0)

    # -- topology ----------------------------------------------------------
    def add_nodes(self, layout) -> None:
        els = self.elements
        self.d, self.g, self.s = (layout.nodes_of([el.nodes[i] for el in els]) for i in range(3))

        self.di = series_nodes(layout, els, self.d, self.gd, "drain")
        self.si = series_nodes(layout, els, self.s, self.gs, "source")

    def coordinates(self, layout):
        controls = [(self.g, self.si), (self.g, self.di), (self.d, self.di), (self.s, self.si)]
        currents = [(self.di, self.si), (self.g, self.si), (self.g, self.di), (self.d, self.di), (self.s, self.si)]
        charges = [(self.g, self.si), (self.g, self.di)] if self.has_charge else []
        self.stamps = BranchStamps(len(self.elements), controls, currents, charges, _CURRENT_DEPS,
                                   _CHARGE_DEPS if self.has_charge else [])
        return self.stamps.coordinates()

    def bind(self, slots: SlotMap, n: int) -> None:
        self.stamps.bind(slots, n)
        count = len(self.elements)
        self._cur = np.zeros((5, count))
        self._dcur = np.zeros((len(_CURRENT_DEPS), count))
        self._dcur[4], self._dcur[5] = self.gd, self.gs
        rows = 2 if self.has_charge else 0
        self._q = np.zeros((rows, count))
        self._dq = np.zeros((rows, count))


    def drain_current(self, vgs: np.ndarray, vgd: np.ndarray):
        """Channel current (drain to source) and its derivatives to vgs and vgd, type-normalised.

        Returns
        -------
        cdrain, d_vgs, d_vgd : ndarray
        """
        vds = vgs - vgd
        fwd = vds >= 0.0
        u = np.where(fwd, vgs, vgd) - self.vto
        i, di_du, di_dw = channel_current(u, np.abs(vds), self.beta, self.lam, self.b, self.bfac)
        return (np.where(fwd, i, -i), np.where(fwd, di_du + di_dw, di_dw),
                np.where(fwd, -di_dw, -(di_du + di_dw)))

    def gate_junctions(self, vgs: np.ndarray, vgd: np.ndarray):
        """Gate-source and gate-drain junction currents and conductances (GMIN included)."""
        v = np.concatenate([vgs, vgd], axis=-1)
        i, gj = ideal_junction(v, self.j_isat, self.j_vt, self.j_knee)
        i = i + self.j_gmin * v
        gj = gj + self.j_gmin
        n = vgs.shape[-1]
        return i[..., :n], gj[..., :n], i[..., n:], gj[..., n:]

    def quantities(self, x, dxdt=None):
        """ngspice's JFET quantities (``@j1[id]``, ``@j1[gm]`` ...) at solutions ``x``, shape (T, N) each.

        As ngspice, currents and voltages are type-normalised (a PJF gives
        those of the equivalent NJF) and the currents flow into the
        terminals (``id + ig + is = 0``), in a transient with the gate
        charges' currents; ``igd`` is the gate-drain junction's current
        (with its charge's). ``gm`` and ``gds`` are the derivatives of the
        channel current of the mode (:func:`channel_current`), ``ggs``,
        ``ggd`` the gate junctions' conductances, ``qgs``, ``qgd`` their
        depletion charges; ``p`` the power the terminals deliver to the
        device (each terminal's current times its voltage, series
        resistances included).
        """
        v = self.stamps.voltages_at(x)
        tp = self.type
        vgs, vgd = tp * v[_VGS], tp * v[_VGD]
        vds = vgs - vgd
        fwd = vds >= 0.0
        n = vgs.shape[-1]
        with np.errstate(all="ignore"):
            cdrain, _, _ = self.drain_current(vgs, vgd)
            _, gm, gds = channel_current(np.where(fwd, vgs, vgd) - self.vto, np.abs(vds), self.beta, self.lam,
                                         self.b, self.bfac)
            igs, ggs, igd, ggd = self.gate_junctions(vgs, vgd)
            qj, cj = self.depletion(np.concatenate([vgs, vgd], axis=-1))
        rate_gs = rate_gd = 0.0
        if dxdt is not None and self.has_charge:
            dq = np.stack([cj[..., :n], cj[..., n:]])
            rate_gs, rate_gd = tp * self.stamps.charge_rates(dq, self.stamps.voltages_at(dxdt))
        i_gd = igd + rate_gd
        i_g = igs + rate_gs + i_gd
        i_d = cdrain - i_gd
        xx = np.atleast_2d(x)
        vs = xx[:, self.s]
        # the power the terminals deliver (type-normalised currents times real voltages, times the type)
        p = tp * (i_d * (xx[:, self.d] - vs) + i_g * (xx[:, self.g] - vs))
        return {
            "id": i_d, "ig": i_g, "is": -(i_d + i_g), "igd": i_gd, "p": p, "vgs": vgs, "vgd": vgd,
            "gm": gm, "gds": gds, "ggs": ggs, "ggd": ggd, "qgs": qj[..., :n], "qgd": qj[..., n:],
        }

    def compiled(self, slots: SlotMap, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Pack the family for :func:`netdae.devices.kernels.jfet.eval_jfet` (after ``bind``).

        Returns
        -------
        par : ndarray, shape (N, kernels.jfet.N_PAR)
        idx : ndarray of int64, shape (N, kernels.jfet.N_IDX)
        vold0 : ndarray, shape (N, 2)
            The initial state's (vgs, vgd) (:meth:`initial_state`).
        """
        from .kernels import jfet as kj
        from .kernels.packing import columns, dependence_blocks, depletion_columns, node_columns

        count = len(self.elements)
        par = columns(count, kj.N_PAR, {
            kj.P_TYPE: self.type, kj.P_VT: self.vt, kj.P_VCRIT: self.vcrit, kj.P_ISAT: self.isat,
            kj.P_KNEE: self.knee, kj.P_GMIN: self.gmin_m, kj.P_VTO: self.vto, kj.P_BETA: self.beta,
            kj.P_LAMBDA: self.lam, kj.P_B: self.b, kj.P_BFAC: self.bfac, kj.P_GD: self.gd, kj.P_GS: self.gs,
            kj.P_CHARGE_FAMILY: self.has_charge,
        })
        par[:, kj.P_DEP_GS:kj.P_DEP_GS + 9] = depletion_columns(self.depletion, slice(0, count))
        par[:, kj.P_DEP_GD:kj.P_DEP_GD + 9] = depletion_columns(self.depletion, slice(count, 2 * count))
        idx = node_columns(count, kj.N_IDX, {
            kj.I_D: self.d, kj.I_G: self.g, kj.I_S: self.s, kj.I_DI: self.di, kj.I_SI: self.si}, n)
        st = self.stamps
        controls = list(zip(st.ctrl_p, st.ctrl_m))
        dependence_blocks(idx, kj.S_CUR, slots, _CURRENT_DEPS, list(zip(st.cur_a, st.cur_b)), controls)
        dependence_blocks(idx, kj.S_CHG, slots, _CHARGE_DEPS, [(self.g, self.si), (self.g, self.di)], controls,
                          where=np.full(count, self.has_charge))
        return par, idx, self.initial_state().v.T.copy()

    def noise(self, x: np.ndarray, temp: float) -> NoiseSources:
        """ngspice's JFET noise (``jfetnoi.c``) at the operating point ``x`` (extended).

        Generators: ``_rd``, ``_rs`` thermal noise of the drain and source
        resistances (outer to internal node); ``_id`` the channel's thermal
        noise and ``_1overf`` flicker noise ``m KF |id|^AF / f``, internal
        drain to internal source. The channel's noise conductance is
        ``(2/3) |gm|`` (``gm`` the derivative of the channel current to the
        mode's gate voltage; NLEV < 3) or ngspice's NLEV = 3 expression, taken
        as 0 where that is negative (below threshold, where ngspice's is).
        """
        v = self.stamps.voltages(x)
        vgs, vgd = self.type * v[:2]
        vds = vgs - vgd
        fwd = vds >= 0.0
        with np.errstate(all="ignore"):
            _, di_du, _ = channel_current(np.where(fwd, vgs, vgd) - self.vto, np.abs(vds), self.beta, self.lam,
                                          self.b, self.bfac)
            cdrain = self.drain_current(vgs, vgd)[0]
            igd = self.gate_junctions(vgs, vgd)[2]
            vgst = vgs - self.vto
            alpha = np.where(vgst >= vds, 1.0 - vds / np.where(vgst != 0.0, vgst, 1.0), 0.0)
            level3 = 2.0 / 3.0 * self.beta * vgst * (1.0 + alpha + alpha * alpha) / (1.0 + alpha) * self.gdsnoi
        channel = np.where(self.nlev < 3.0, 2.0 / 3.0 * np.abs(di_du), np.maximum(level3, 0.0))
        m = self.mult
        names = [el.name for el in self.elements]
        return noise_sources(names, [
            ("_rd", self.di, self.d, thermal(self.gd, temp), 0.0, 1.0),
            ("_rs", self.si, self.s, thermal(self.gs, temp), 0.0, 1.0),
            ("_id", self.di, self.si, thermal(channel, temp), 0.0, 1.0),
            ("_1overf", self.di, self.si, 0.0, m * flicker(self.kf, (cdrain - igd) / m, self.af), 1.0),
        ])

    def evaluate(self, x, t, acc: Accumulator, state, jacobian):
        v = self.stamps.voltages(x)
        tp = self.type
        vn_x = tp * v[:2]
        with np.errstate(all="ignore"):
            start = starting_voltages(state, x, vn_x)
            if start is not None:
                vn, changed = start
            else:
                vn, changed = self.limit(vn_x, state.v)
            vgs, vgd = vn
            cdrain, d_vgs, d_vgd = self.drain_current(vgs, vgd)
            igs, ggs, igd, ggd = self.gate_junctions(vgs, vgd)
            cur, dcur = self._cur, self._dcur
            np.multiply(tp, cdrain, out=cur[_ID])
            np.multiply(tp, igs, out=cur[_IGS])
            np.multiply(tp, igd, out=cur[_IGD])
            np.multiply(self.gd, v[_VRD], out=cur[_IRD])
            np.multiply(self.gs, v[_VRS], out=cur[_IRS])
            dcur[0] = d_vgs
            dcur[1] = d_vgd
            dcur[2] = ggs
            dcur[3] = ggd
            if self.has_charge:
                qj, cj = self.depletion(np.concatenate([vgs, vgd]))
                n = vgs.size
                np.multiply(tp, qj[:n], out=self._q[0])
                np.multiply(tp, qj[n:], out=self._q[1])
                self._dq[0] = cj[:n]
                self._dq[1] = cj[n:]
            delta = None
            if changed:
                acc.limited = True
                delta = np.zeros_like(v)
                delta[:2] = v[:2] - tp * vn
            self.stamps.add(acc, cur, dcur, self._q, self._dq, delta=delta, jacobian=jacobian)
            total = float(cur.sum() + dcur.sum()) + (float(self._q.sum() + self._dq.sum()) if self.has_charge else 0.0)
            if not math.isfinite(total):
                acc.ok = False
        return LimitState(vn)
