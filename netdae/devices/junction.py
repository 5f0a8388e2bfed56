"""pn-junction physics shared by the diode, the BJT and the MOSFET.

Every function works on numpy arrays (one entry per device instance) and
reproduces ngspice 39's equations for SPICE level-1 junctions:

- :func:`ideal_junction`: the junction current with ngspice's reverse-bias
  form ``-Is (1 + (3 vte / (e v))^3)`` below ``-3 vte`` (``dioload.c``,
  ``bjtload.c``);
- :class:`Depletion`: the depletion charge whose derivative is
  ngspice's depletion capacitance, including the linear extrapolation of the
  capacitance above ``FC * VJ`` (``FC = 0`` gives the BJT substrate form);
- :func:`pnjlim`, :func:`fetlim`, :func:`limvds`: ngspice's Newton limiting
  of junction and FET voltages (``devsup.c``);
- temperature scaling of saturation currents, junction potentials and
  zero-bias capacitances (``diotemp.c``, ``bjttemp.c``, ``mos1temp.c``).

Physical constants are ngspice's (``const.h``) so that results compare to
the last digit.

References
----------
.. [1] L. W. Nagel, *SPICE2: A computer program to simulate semiconductor
   circuits*, UCB/ERL M520, 1975, Ch. 3 (limiting) and App. (models).
.. [2] P. Antognetti, G. Massobrio, *Semiconductor Device Modeling with
   SPICE*, 2nd ed., McGraw-Hill 1993, Ch. 1-4.
.. [3] ngspice 39 sources: ``src/spicelib/devices/devsup.c``,
   ``dio/diotemp.c``, ``bjt/bjttemp.c``, ``mos1/mos1temp.c``.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = [
    "CHARGE",
    "BOLTZMANN",
    "K_OVER_Q",
    "REFTEMP",
    "KELVIN",
    "EPSMIN",
    "thermal_voltage",
    "energy_gap",
    "pb_factor",
    "scale_junction",
    "saturation_exponent",
    "quadratic_factor",
    "vcrit",
    "ideal_junction",
    "Depletion",
    "pnjlim",
    "fetlim",
    "limvds",
    "fet_mode_limit",
]

#: Elementary charge [C] (ngspice's CHARGE, CODATA 2014).
CHARGE = 1.6021766208e-19
#: Boltzmann constant [J/K] (ngspice's CONSTboltz).
BOLTZMANN = 1.38064852e-23
#: k/q [V/K].
K_OVER_Q = BOLTZMANN / CHARGE
#: 0 degC in kelvin.
KELVIN = 273.15
#: ngspice's reference temperature of its band-gap formulas, 27 degC [K].
REFTEMP = 27.0 + KELVIN
#: Smallest saturation current ngspice accepts (CKTepsmin) [A].
EPSMIN = 1e-28
#: Band gap of silicon at 0 K in ngspice's formula [eV], and its coefficients.
_EG0 = 1.16
_EG_ALPHA = 7.02e-4
_EG_BETA = 1108.0
#: ngspice's 1.1150877 eV: the silicon gap at REFTEMP used to normalise pbfact.
_EG_REF = 1.1150877
#: Temperature coefficient of the zero-bias capacitance in ngspice's formula [1/K].
_CJ_TEMPCO = 400e-6
#: ngspice limits a junction's reverse-bias region at three thermal voltages.
_REVERSE_KNEE = 3.0
#: Limiting (devsup.c): two thermal voltages, and the FET voltage steps [V].
_FET_ON_MARGIN = 3.5
_FET_MIDDLE_UP = 4.0
_FET_MIDDLE_DOWN = 0.5
_FET_OFF_UP = 0.5
_FET_TWO = 2.0
_VDS_HIGH = 3.5
_VDS_UP = 4.0
_VDS_DOWN = -0.5
_VDS_FLOOR = 2.0


def thermal_voltage(temp_k):
    """kT/q [V] at ``temp_k`` kelvin."""
    return K_OVER_Q * np.asarray(temp_k, dtype=float)


def energy_gap(temp_k):
    """ngspice's silicon band gap ``1.16 - 7.02e-4 T^2 / (T + 1108)`` [eV]."""
    t = np.asarray(temp_k, dtype=float)
    return _EG0 - _EG_ALPHA * t * t / (t + _EG_BETA)


def pb_factor(temp_k):
    """ngspice's ``pbfact``: the built-in-potential shift at temperature T [V].

    ``-2 vt (1.5 ln(T/REFTEMP) + q (-Eg(T)/(2 k T) + Eg_ref/(2 k REFTEMP)))``.
    """
    t = np.asarray(temp_k, dtype=float)
    vt = K_OVER_Q * t
    arg = -energy_gap(t) / (2.0 * BOLTZMANN * t) + _EG_REF / (BOLTZMANN * (REFTEMP + REFTEMP))
    return -2.0 * vt * (1.5 * np.log(t / REFTEMP) + CHARGE * arg)


def scale_junction(cj0, grading, vj, tnom_k, temp_k):
    """Zero-bias capacitance and built-in potential at temperature (ngspice ``tlevc = 0``).

    Parameters
    ----------
    cj0 : array_like
        Zero-bias capacitance at ``tnom`` [F].
    grading : array_like
        Grading coefficient M of this capacitance.
    vj : array_like
        Built-in potential at ``tnom`` [V].
    tnom_k, temp_k : array_like
        Nominal and device temperature [K].

    Returns
    -------
    cj : ndarray
        Capacitance at ``temp``.
    vj_t : ndarray
        Built-in potential at ``temp``.

    Notes
    -----
    ``pbo = (vj - pbfact(Tnom)) / (Tnom/REFTEMP)`` is the potential referred
    to REFTEMP; ``vj_t = pbfact(T) + (T/REFTEMP) pbo``; the capacitance is
    divided by ``1 + M (4e-4 (Tnom - REFTEMP) - (vj - pbo)/pbo)`` and
    multiplied by ``1 + M (4e-4 (T - REFTEMP) - (vj_t - pbo)/pbo)``, exactly
    as ``diotemp.c``, ``bjttemp.c`` and ``mos1temp.c`` do.
    """
    tnom_k = np.asarray(tnom_k, dtype=float)
    temp_k = np.asarray(temp_k, dtype=float)
    vj = np.asarray(vj, dtype=float)
    grading = np.asarray(grading, dtype=float)
    pbo = (vj - pb_factor(tnom_k)) / (tnom_k / REFTEMP)
    gma_old = (vj - pbo) / pbo
    cj = np.asarray(cj0, dtype=float) / (1.0 + grading * (_CJ_TEMPCO * (tnom_k - REFTEMP) - gma_old))
    vj_t = pb_factor(temp_k) + (temp_k / REFTEMP) * pbo
    gma_new = (vj_t - pbo) / pbo
    cj = cj * (1.0 + grading * (_CJ_TEMPCO * (temp_k - REFTEMP) - gma_new))
    return cj, vj_t


def saturation_exponent(eg, xti, tnom_k, temp_k):
    """``(T/Tnom - 1) Eg / vt(T) + XTI ln(T/Tnom)``: ln of the IS temperature factor.

    A saturation current with emission coefficient N scales by
    ``exp(saturation_exponent / N)`` (the diode divides by N; the BJT's IS
    does not, its ISE/ISC divide by NE/NC).
    """
    tnom_k = np.asarray(tnom_k, dtype=float)
    temp_k = np.asarray(temp_k, dtype=float)
    ratio = temp_k / tnom_k
    return (ratio - 1.0) * np.asarray(eg, dtype=float) / thermal_voltage(temp_k) + np.asarray(xti, dtype=float) * np.log(ratio)


def quadratic_factor(c1, c2, dt):
    """ngspice's temperature factor ``1 + c1 dT + c2 dT^2`` of a parameter (``TC1``/``TC2``, ``TRS1``/``TRS2`` ...).

    ``dT`` is the device temperature minus its nominal one; the coefficients
    and ``dT`` are scalars or arrays (broadcast).
    """
    return 1.0 + c1 * dt + c2 * dt * dt


def vcrit(vte, isat):
    """SPICE's critical voltage ``vte ln(vte / (sqrt(2) Is))`` [V] (limiting threshold)."""
    vte = np.asarray(vte, dtype=float)
    return vte * np.log(vte / (math.sqrt(2.0) * np.asarray(isat, dtype=float)))


def ideal_junction(v, isat, vte, knee):
    """Junction current and conductance as ngspice computes them.

    ``i = Is (exp(v/vte) - 1)`` for ``v >= -3 vte``; below, ngspice's smooth
    reverse form ``i = -Is (1 + a)``, ``a = (3 vte / (e v))^3``, whose value
    and slope match the exponential at ``v = -3 vte``.

    Parameters
    ----------
    v : ndarray
        Junction voltage [V].
    isat : ndarray or float
        Saturation current [A] (0 gives 0).
    vte : ndarray or float
        Emission coefficient times thermal voltage [V].
    knee : ndarray or float
        ``-3 vte``, precomputed by the caller.

    Returns
    -------
    i, g : ndarray
        Current [A] and its derivative [S].

    Notes
    -----
    Call inside ``np.errstate``: a large forward voltage overflows to inf,
    which the caller reports as a failed evaluation. When every junction is
    above the knee (the usual case) only the exponential branch is computed.
    ``expm1`` keeps the current's relative accuracy near zero bias (ngspice's
    ``exp - 1`` loses it to an absolute ``eps Is``, which a BDF step of
    1e-17 s turns into noise above ``abstol``).
    """
    reverse = v < knee
    if not reverse.any():
        em1 = np.expm1(v / vte)
        return isat * em1, isat * (em1 + 1.0) / vte
    em1 = np.expm1(np.where(reverse, 0.0, v / vte))
    vr = np.where(reverse, v, -1.0)
    a = _REVERSE_KNEE * vte / (vr * math.e)
    a = a * a * a
    i = np.where(reverse, -isat * (1.0 + a), isat * em1)
    g = np.where(reverse, isat * _REVERSE_KNEE * a / vr, isat * (em1 + 1.0) / vte)
    return i, g


class Depletion:
    """Depletion charge q(v) and capacitance dq/dv of graded junctions.

    Below ``fc * vj``: ``q = vj cj0 (1 - (1 - v/vj)^(1-m)) / (1 - m)``, the
    integral of ``cj0 (1 - v/vj)^-m``. Above, ngspice extrapolates the
    capacitance linearly, ``c = cj0 / F2 (F3 + m v / vj)`` with
    ``F2 = (1 - fc)^(1+m)``, ``F3 = 1 - fc (1 + m)``, and the charge is its
    integral, continuous at ``fc * vj`` (``cj0 F1`` there,
    ``F1 = vj (1 - (1 - fc)^(1-m)) / (1 - m)``). ``fc = 0`` gives the BJT
    substrate junction (``q = cj0 v (1 + m v / (2 vj))`` for v >= 0).

    Parameters
    ----------
    cj0, vj, m, fc : array_like
        Zero-bias capacitance [F], built-in potential [V], grading
        coefficient (< 1), forward-bias coefficient (< 1), per junction.

    Notes
    -----
    The coefficients are computed once; a call costs about ten numpy
    operations when every junction is below ``fc * vj``.

    Examples
    --------
    >>> dep = Depletion(1e-12, 0.8, 0.5, 0.5)
    >>> q, c = dep(np.array([-1.0, 0.0, 0.6]))
    >>> np.round(c * 1e12, 12).tolist()  # cj0 / sqrt(1 + 1/0.8), cj0, cj0 / 0.5^1.5 (0.25 + 0.5 * 0.6/0.8)
    [0.666666666667, 1.0, 1.767766952966]
    """

    def __init__(self, cj0, vj, m, fc):
        n = np.broadcast(np.asarray(cj0), np.asarray(vj), np.asarray(m), np.asarray(fc)).shape
        self.cj0 = np.broadcast_to(np.asarray(cj0, dtype=float), n).copy()
        self.vj = np.broadcast_to(np.asarray(vj, dtype=float), n).copy()
        self.m = np.broadcast_to(np.asarray(m, dtype=float), n).copy()
        fc = np.broadcast_to(np.asarray(fc, dtype=float), n)
        self.active = bool(np.any(self.cj0 != 0.0))
        self.vfc = fc * self.vj
        self.q_scale = self.vj * self.cj0 / (1.0 - self.m)
        xfc = np.log1p(-fc)
        self.q_fc = self.cj0 * self.vj * (1.0 - np.exp((1.0 - self.m) * xfc)) / (1.0 - self.m)
        self.czf2 = self.cj0 / np.exp((1.0 + self.m) * xfc)
        self.f3 = 1.0 - fc * (1.0 + self.m)
        self.m_over_vj = self.m / self.vj

    def __call__(self, v):
        """Charge and capacitance at junction voltages ``v`` (same shape as the coefficients)."""
        # 1 - (1 - v/vj)^(1-m) = -expm1((1-m) log1p(-v/vj)): relative accuracy near
        # v = 0, where the difference of two numbers near 1 would leave an absolute
        # error eps * q_scale, noise of eps q_scale / h in the junction current
        below = v < self.vfc
        if below.all():
            return self._graded(v)
        q_below, c_below = self._graded(np.where(below, v, 0.0))
        dv = v - self.vfc
        q_above = self.q_fc + self.czf2 * dv * (self.f3 + 0.5 * self.m_over_vj * (v + self.vfc))
        c_above = self.czf2 * (self.f3 + self.m_over_vj * v)
        return np.where(below, q_below, q_above), np.where(below, c_below, c_above)

    def _graded(self, v):
        """Charge and capacitance of the graded junction (valid below ``fc * vj``)."""
        lx = np.log1p(-v / self.vj)
        return -self.q_scale * np.expm1((1.0 - self.m) * lx), self.cj0 * np.exp(-self.m * lx)


def pnjlim(vnew, vold, vt, vcrit_):
    """SPICE's pn-junction voltage limiting (``DEVpnjlim``), vectorised.

    A forward step beyond ``vcrit`` larger than ``2 vt`` is replaced by a
    logarithmic one; a reverse step is limited to ``-vold - 1`` (from a
    forward-biased ``vold``) or ``2 vold - 1``.

    Parameters
    ----------
    vnew : ndarray
        Junction voltage from the Newton iterate.
    vold : ndarray
        Limited junction voltage of the previous iteration.
    vt : ndarray or float
        (Emission coefficient times) thermal voltage.
    vcrit_ : ndarray or float
        Critical voltage.

    Returns
    -------
    v : ndarray
        Limited voltage (``vnew`` itself when nothing is limited).
    changed : ndarray of bool or None
        Where the limit applied (ngspice's ``icheck``); None when nowhere.

    Examples
    --------
    >>> v, c = pnjlim(np.array([1.0, 0.3, -5.0]), np.array([0.6, 0.2, 0.0]), 0.025, 0.6)
    >>> np.round(v, 6).tolist(), c.tolist()
    ([0.715976, 0.3, -1.0], [True, False, True])
    """
    forward = (vnew > vcrit_) & (np.abs(vnew - vold) > vt + vt)
    negative = vnew < 0.0
    any_forward = forward.any()
    if not any_forward and not negative.any():
        return vnew, None
    v = vnew
    changed = forward
    if any_forward:
        arg = (vnew - vold) / vt
        up = vold + vt * (2.0 + np.log(np.where(arg > 2.0, arg - 2.0, 1.0)))
        down = vold - vt * (2.0 + np.log(np.where(arg < -2.0, 2.0 - arg, 1.0)))
        from_off = vt * np.log(np.where(vnew > 0.0, vnew / vt, 1.0))
        v = np.where(forward, np.where(vold > 0.0, np.where(arg > 0.0, up, down), from_off), vnew)
    floor = np.where(vold > 0.0, -vold - 1.0, 2.0 * vold - 1.0)
    reverse = negative & (vnew < floor) & ~forward
    if reverse.any():
        v = np.where(reverse, floor, v)
        changed = forward | reverse
    if not changed.any():
        return vnew, None
    return v, changed


def fetlim(vnew, vold, vto):
    """SPICE's gate-voltage limiting of a FET (``DEVfetlim``), vectorised.

    Parameters
    ----------
    vnew, vold : ndarray
        New and previous gate-source (or gate-drain) voltage [V].
    vto : ndarray
        Threshold voltage of the previous iteration [V].

    Returns
    -------
    ndarray
        The limited voltage.
    """
    vtsthi = np.abs(_FET_TWO * (vold - vto)) + _FET_TWO
    vtstlo = np.abs(vold - vto) + 1.0
    vtox = vto + _FET_ON_MARGIN
    delv = vnew - vold
    # on and staying well on (vold >= vto + 3.5)
    going_off = np.where(vnew >= vtox, np.where(-delv > vtstlo, vold - vtstlo, vnew),
                         np.maximum(vnew, vto + _FET_TWO))
    staying_on = np.where(delv >= vtsthi, vold + vtsthi, vnew)
    strongly_on = np.where(delv <= 0.0, going_off, staying_on)
    # just above threshold
    middle = np.where(delv <= 0.0, np.maximum(vnew, vto - _FET_MIDDLE_DOWN), np.minimum(vnew, vto + _FET_MIDDLE_UP))
    # off
    vtemp = vto + _FET_OFF_UP
    off_up = np.where(vnew <= vtemp, np.where(delv > vtstlo, vold + vtstlo, vnew), vtemp)
    off = np.where(delv <= 0.0, np.where(-delv > vtsthi, vold - vtsthi, vnew), off_up)
    return np.where(vold >= vto, np.where(vold >= vtox, strongly_on, middle), off)


def limvds(vnew, vold):
    """SPICE's drain-source voltage limiting (``DEVlimvds``), vectorised."""
    high = np.where(vnew > vold, np.minimum(vnew, 3.0 * vold + _VDS_FLOOR),
                    np.where(vnew < _VDS_HIGH, np.maximum(vnew, _VDS_FLOOR), vnew))
    low = np.where(vnew > vold, np.minimum(vnew, _VDS_UP), np.maximum(vnew, _VDS_DOWN))
    return np.where(vold >= _VDS_HIGH, high, low)


def fet_mode_limit(vgs_x, vds_x, vgs_o, vds_o, von):
    """SPICE's MOSFET limiting of (vgs, vds) in the mode of the previous iteration, vectorised.

    Normal mode last time (``vds_o >= 0``): ``fetlim`` on vgs, then
    ``limvds`` on vds; reverse mode: ``fetlim`` on vgd, then ``-limvds(-vds)``
    (``mos1load.c``, ``vdmosload.c``). Type-normalised voltages.

    Parameters
    ----------
    vgs_x, vds_x : ndarray
        The iterate's gate-source and drain-source voltages.
    vgs_o, vds_o : ndarray
        Those of the previous iteration (limited).
    von : ndarray
        The threshold voltage ``fetlim`` limits around.

    Returns
    -------
    vgs, vds : ndarray
        The limited voltages (the iterate's own where nothing was limited).
    """
    vgd_x = vgs_x - vds_x
    vgdo = vgs_o - vds_o
    # normal mode last time: limit vgs, then vds
    g1 = fetlim(vgs_x, vgs_o, von)
    d1 = limvds(np.where(g1 != vgs_x, g1 - vgd_x, vds_x), vds_o)
    # reverse mode last time: limit vgd, then -vds
    gd2 = fetlim(vgd_x, vgdo, von)
    d2 = -limvds(-np.where(gd2 != vgd_x, vgs_x - gd2, vds_x), -vds_o)
    g2 = np.where((gd2 != vgd_x) | (d2 != vds_x), gd2 + d2, vgs_x)
    forward_old = vds_o >= 0.0
    return np.where(forward_old, g1, g2), np.where(forward_old, d1, d2)
