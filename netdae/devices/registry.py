"""Which device family evaluates which element kind.

Linear kinds are stamped by :mod:`netdae.devices.linear`; every other kind
must have a nonlinear family listed here.
"""

from __future__ import annotations

from .base import DeviceFamily
from .behavioral import BehaviouralFamily
from .bjt import BjtFamily
from .diode import DiodeFamily
from .jfet import JfetFamily
from .mosfet import MosfetFamily
from .switch import SwitchFamily
from .vdmos import VdmosFamily

__all__ = ["FAMILIES", "LAZY_FAMILIES", "family_for"]

#: Nonlinear device families, in evaluation order.
FAMILIES: tuple[type[DeviceFamily], ...] = (DiodeFamily, BjtFamily, MosfetFamily, JfetFamily, SwitchFamily,
                                            BehaviouralFamily, VdmosFamily)
#: Families imported when a circuit has their kind (ctypes and the OSDI loader only for N elements).
LAZY_FAMILIES = {"osdi": ("netdae.devices.osdi.family", "OsdiFamily")}


def family_for(kind: str) -> type[DeviceFamily] | None:
    """The family class for an element kind, or None."""
    for fam in FAMILIES:
        if kind in fam.kinds:
            return fam
    lazy = LAZY_FAMILIES.get(kind)
    if lazy is not None:
        import importlib

        return getattr(importlib.import_module(lazy[0]), lazy[1])
    return None
