"""pn-junction physics of one instance, as compiled scalar functions.

The scalar twins of :mod:`netdae.devices.junction` (which stays the
reference and documents every formula): the same operations in the same
order, so that a kernel built from them reproduces the numpy families to a
few ulps (the elementary functions ``exp``, ``log``, ``expm1``, ``log1p`` may
round differently in numpy's and the C library's implementations).

- :func:`ideal_junction`: ``Is (expm1(v/vte))`` above ``knee = -3 vte``,
  ngspice's reverse cubic below;
- :func:`depletion`: the depletion charge and capacitance from the
  coefficients a :class:`~netdae.devices.junction.Depletion` precomputes;
- :func:`pnjlim`, :func:`fetlim`, :func:`limvds`: ngspice's limiting
  (``devsup.c``), :func:`fet_mode_limit`, the MOSFETs' use of the last two, and
  :func:`gate_junction_limit`, the JFETs' and MESA's use of the first two.

Every function is a netdae kernel (:func:`netdae.dae.compiled.kernel`) with the numpy error model
(a division by zero gives inf or nan, as in the numpy families).
"""

from __future__ import annotations

import math

from ...dae.compiled import kernel

from ..junction import (
    _FET_MIDDLE_DOWN,
    _FET_MIDDLE_UP,
    _FET_OFF_UP,
    _FET_ON_MARGIN,
    _FET_TWO,
    _REVERSE_KNEE,
    _VDS_DOWN,
    _VDS_FLOOR,
    _VDS_HIGH,
    _VDS_UP,
)

__all__ = ["ideal_junction", "depletion", "pnjlim", "fetlim", "limvds", "fet_mode_limit", "gate_junction_limit"]


@kernel
def ideal_junction(v, isat, vte, knee):
    """Junction current and conductance at ``v`` (see :func:`netdae.devices.junction.ideal_junction`).

    Returns
    -------
    (i, g) : (float, float)
    """
    if v < knee:
        a = _REVERSE_KNEE * vte / (v * math.e)
        a = a * a * a
        return -isat * (1.0 + a), isat * _REVERSE_KNEE * a / v
    em1 = math.expm1(v / vte)
    return isat * em1, isat * (em1 + 1.0) / vte


@kernel
def depletion(v, cj0, vj, m, vfc, q_scale, q_fc, czf2, f3, m_over_vj):
    """Depletion charge and capacitance at ``v`` (see :class:`netdae.devices.junction.Depletion`).

    The arguments after ``v`` are a ``Depletion``'s per-junction attributes
    (``cj0, vj, m, vfc, q_scale, q_fc, czf2, f3, m_over_vj``).

    Returns
    -------
    (q, c) : (float, float)
    """
    if v < vfc:
        lx = math.log1p(-v / vj)
        return -q_scale * math.expm1((1.0 - m) * lx), cj0 * math.exp(-m * lx)
    dv = v - vfc
    return q_fc + czf2 * dv * (f3 + 0.5 * m_over_vj * (v + vfc)), czf2 * (f3 + m_over_vj * v)


@kernel
def pnjlim(vnew, vold, vt, vcrit):
    """SPICE's pn-junction limiting of one voltage (see :func:`netdae.devices.junction.pnjlim`).

    Returns
    -------
    (v, changed) : (float, bool)
        The limited voltage and whether the limit applied (ngspice's ``icheck``).
    """
    if vnew > vcrit and abs(vnew - vold) > vt + vt:
        if vold > 0.0:
            arg = (vnew - vold) / vt
            if arg > 0.0:
                return vold + vt * (2.0 + math.log(arg - 2.0 if arg > 2.0 else 1.0)), True
            return vold - vt * (2.0 + math.log(2.0 - arg if arg < -2.0 else 1.0)), True
        return vt * math.log(vnew / vt if vnew > 0.0 else 1.0), True
    if vnew < 0.0:
        floor = -vold - 1.0 if vold > 0.0 else 2.0 * vold - 1.0
        if vnew < floor:
            return floor, True
    return vnew, False


@kernel
def fetlim(vnew, vold, vto):
    """SPICE's FET gate-voltage limiting of one voltage (see :func:`netdae.devices.junction.fetlim`)."""
    vtsthi = abs(_FET_TWO * (vold - vto)) + _FET_TWO
    vtstlo = abs(vold - vto) + 1.0
    vtox = vto + _FET_ON_MARGIN
    delv = vnew - vold
    if vold >= vto:
        if vold >= vtox:
            if delv <= 0.0:
                if vnew >= vtox:
                    return vold - vtstlo if -delv > vtstlo else vnew
                return max(vnew, vto + _FET_TWO)
            return vold + vtsthi if delv >= vtsthi else vnew
        if delv <= 0.0:
            return max(vnew, vto - _FET_MIDDLE_DOWN)
        return min(vnew, vto + _FET_MIDDLE_UP)
    if delv <= 0.0:
        return vold - vtsthi if -delv > vtsthi else vnew
    vtemp = vto + _FET_OFF_UP
    if vnew <= vtemp:
        return vold + vtstlo if delv > vtstlo else vnew
    return vtemp


@kernel
def gate_junction_limit(vgs_x, vgd_x, vgs_o, vgd_o, vt_s, vcrit_s, vt_d, vcrit_d, vto):
    """A FET's gate junctions limited as SPICE's JFET and MESA do: pnjlim on each junction (its own
    ``N vt`` and ``vcrit``), then fetlim against VTO (see
    :meth:`netdae.devices.companion.GateJunctionLimits.limit`).

    Returns
    -------
    (vgs, vgd) : (float, float)
    """
    vgs, _ = pnjlim(vgs_x, vgs_o, vt_s, vcrit_s)
    vgd, _ = pnjlim(vgd_x, vgd_o, vt_d, vcrit_d)
    return fetlim(vgs, vgs_o, vto), fetlim(vgd, vgd_o, vto)


@kernel
def limvds(vnew, vold):
    """SPICE's drain-source voltage limiting of one voltage (see :func:`netdae.devices.junction.limvds`)."""
    if vold >= _VDS_HIGH:
        if vnew > vold:
            return min(vnew, 3.0 * vold + _VDS_FLOOR)
        if vnew < _VDS_HIGH:
            return max(vnew, _VDS_FLOOR)
        return vnew
    if vnew > vold:
        return min(vnew, _VDS_UP)
    return max(vnew, _VDS_DOWN)


@kernel
def fet_mode_limit(vgs_x, vds_x, vgs_o, vds_o, von):
    """SPICE's MOSFET limiting of (vgs, vds) (see :func:`netdae.devices.junction.fet_mode_limit`).

    Returns
    -------
    (vgs, vds) : (float, float)
    """
    vgd_x = vgs_x - vds_x
    if vds_o >= 0.0:
        vgs = fetlim(vgs_x, vgs_o, von)
        vds = limvds(vgs - vgd_x if vgs != vgs_x else vds_x, vds_o)
        return vgs, vds
    gd2 = fetlim(vgd_x, vgs_o - vds_o, von)
    vds = -limvds(-(vgs_x - gd2 if gd2 != vgd_x else vds_x), -vds_o)
    vgs = gd2 + vds if (gd2 != vgd_x or vds != vds_x) else vgs_x
    return vgs, vds
