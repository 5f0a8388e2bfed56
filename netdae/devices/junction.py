"""pn-junction physics shared by the diode, the BJT and the MOSFET.

Every function works on numpy arrays (one entry per device instance) and
reproduces ngspice 39's equations for SPICE level-1 junctions:

- :func:`ideal_junction`: the junction current with ngspice's reverse-bias
  form ``-Is (1 + (3 vte / (e v))^3)`` below ``-3 vte`` (``dioload.c``,
  ``bjtload.c``);
- :func:`depletion_charge`: the depletion charge whose derivative is
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
    "vcrit",
    "ideal_junction",
    "depletion_charge",
    "pnjlim",
    "fetlim",
    "limvds",
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


def vcrit(vte, isat):
    """SPICE's critical voltage ``vte ln(vte / (sqrt(2) Is))`` [V] (limiting threshold)."""
    vte = np.asarray(vte, dtype=float)
    return vte * np.log(vte / (math.sqrt(2.0) * np.asarray(isat, dtype=float)))


def ideal_junction(v, isat, vte):
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

    Returns
    -------
    i, g : ndarray
        Current [A] and its derivative [S].

    Notes
    -----
    Call inside ``np.errstate``: a large forward voltage overflows to inf,
    which the caller reports as a failed evaluation.
    """
    forward = v >= -_REVERSE_KNEE * vte
    ev = np.exp(np.where(forward, v / vte, 0.0))
    vr = np.where(forward, -1.0, v)
    a = _REVERSE_KNEE * vte / (vr * math.e)
    a = a * a * a
    i = np.where(forward, isat * (ev - 1.0), -isat * (1.0 + a))
    g = np.where(forward, isat * ev / vte, isat * _REVERSE_KNEE * a / vr)
    return i, g


def depletion_charge(v, cj0, vj, m, fc):
    """Depletion charge q(v) and capacitance dq/dv of a graded junction.

    Below ``fc * vj``: ``q = vj cj0 (1 - (1 - v/vj)^(1-m)) / (1 - m)``, the
    integral of ``cj0 (1 - v/vj)^-m``. Above, ngspice extrapolates the
    capacitance linearly, ``c = cj0 / F2 (F3 + m v / vj)`` with
    ``F2 = (1 - fc)^(1+m)``, ``F3 = 1 - fc (1 + m)``, and the charge is its
    integral, continuous at ``fc * vj``. ``fc = 0`` gives the BJT substrate
    junction (``q = cj0 v (1 + m v / (2 vj))`` for v >= 0).

    Parameters
    ----------
    v : ndarray
    cj0, vj, m, fc : ndarray or float
        Zero-bias capacitance [F], built-in potential [V], grading
        coefficient (< 1), forward-bias coefficient (< 1).

    Returns
    -------
    q, c : ndarray
        Charge [C] and capacitance [F]; zero where ``cj0 == 0``.
    """
    vfc = fc * vj
    below = v < vfc
    arg = 1.0 - np.where(below, v, 0.0) / vj
    sarg = np.exp(-m * np.log(arg))
    q_below = vj * cj0 * (1.0 - arg * sarg) / (1.0 - m)
    c_below = cj0 * sarg
    f1 = vj * (1.0 - np.exp((1.0 - m) * np.log1p(-fc))) / (1.0 - m)
    f2 = np.exp((1.0 + m) * np.log1p(-fc))
    f3 = 1.0 - fc * (1.0 + m)
    czf2 = cj0 / f2
    q_above = cj0 * f1 + czf2 * (f3 * (v - vfc) + (m / (vj + vj)) * (v * v - vfc * vfc))
    c_above = czf2 * (f3 + m * v / vj)
    return np.where(below, q_below, q_above), np.where(below, c_below, c_above)


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
        Limited voltage.
    changed : ndarray of bool
        Where the limit applied (ngspice's ``icheck``).

    Examples
    --------
    >>> v, c = pnjlim(np.array([1.0, 0.3, -5.0]), np.array([0.6, 0.2, 0.0]), 0.025, 0.6)
    >>> np.round(v, 6).tolist(), c.tolist()
    [[0.682238, 0.3, -1.0], [True, False, True]]
    """
    vnew = np.asarray(vnew, dtype=float)
    forward = (vnew > vcrit_) & (np.abs(vnew - vold) > vt + vt)
    arg = (vnew - vold) / vt
    up = vold + vt * (2.0 + np.log(np.where(arg > 2.0, arg - 2.0, 1.0)))
    down = vold - vt * (2.0 + np.log(np.where(arg < -2.0, 2.0 - arg, 1.0)))
    from_off = vt * np.log(np.where(vnew > 0.0, vnew / vt, 1.0))
    v_fwd = np.where(vold > 0.0, np.where(arg > 0.0, up, down), from_off)
    floor = np.where(vold > 0.0, -vold - 1.0, 2.0 * vold - 1.0)
    reverse = ~forward & (vnew < 0.0) & (vnew < floor)
    v = np.where(forward, v_fwd, np.where(reverse, floor, vnew))
    return v, forward | reverse


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
