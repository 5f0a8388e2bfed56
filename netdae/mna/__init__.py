"""Modified nodal analysis: circuit -> DAE ``d/dt q(x) = phi(x, t)``."""

from .assemble import assemble
from .layout import GND, Layout
from .sources import MODE_DC, MODE_TRAN, SourceVector
from .system import MnaSystem

__all__ = ["assemble", "MnaSystem", "Layout", "GND", "SourceVector", "MODE_DC", "MODE_TRAN"]
