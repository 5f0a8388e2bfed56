"""Sweeps, corners and Monte Carlo: :func:`sweep` and its :class:`SweepResult`.

- :mod:`~netdae.sweeps.plan`: the axes (``.step`` cards, ``params=``), samples and rows;
- :mod:`~netdae.sweeps.worker`: one row elaborated, simulated and measured (what executors run);
- :mod:`~netdae.sweeps.result`: the table and the waveforms over (row, point);
- :mod:`~netdae.sweeps.api`: :func:`sweep`, the executors and chunking.
"""

from __future__ import annotations

from .api import sweep
from .plan import Axis, Plan, Row, make_plan
from .result import SweepResult

__all__ = ["sweep", "SweepResult", "Plan", "Axis", "Row", "make_plan"]
