"""Which device family evaluates which element kind: a view of :mod:`netdae.kinds`.

Stamped kinds are evaluated by :mod:`netdae.devices.linear`; every other kind
names its nonlinear family in its definition (``ElementKind.family``), imported
on first use (ctypes and the OSDI loader only for circuits with N elements).
"""

from __future__ import annotations

from ..kinds import KINDS, resolve
from .base import DeviceFamily

__all__ = ["family_for"]


def family_for(kind: str) -> type[DeviceFamily] | None:
    """The family class for an element kind, or None (a stamped kind, or not a kind)."""
    spec = KINDS.get(kind)
    if spec is None or spec.family is None:
        return None
    return resolve(spec.family)
