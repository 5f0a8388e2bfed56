"""ngspice's four switch states (``swload.c``), shared by the switch family and its kernel.

A module without numba, so that the numpy family (reading and analysing a
circuit, ``netdae check``/``index``) does not load the compiled engine.
"""

from __future__ import annotations

__all__ = ["REALLY_OFF", "REALLY_ON", "HYST_OFF", "HYST_ON"]

#: The control outside the hysteresis band (off, on) and inside it (off, on); ``*_ON`` conduct.
REALLY_OFF, REALLY_ON, HYST_OFF, HYST_ON = 0.0, 1.0, 2.0, 3.0
