"""netdae against ngspice on the same netlist, signal by signal.

:func:`compare` runs a netlist's analyses in netdae and in ngspice (through
:mod:`netdae.ngspice`, which translates netdae's extensions and says so) and
measures the difference at ngspice's own points:

- ``.tran``: netdae's dense output evaluated at ngspice's accepted time
  points; per signal the largest absolute error, the largest error relative
  to the signal's range, the RMS error and where the worst error occurs. An
  inconsistent start (ngspice begins an index-2 circuit at its DC operating
  point) is reported as an initial jump and excluded from the verdict,
  explicitly;
- ``.ac``: netdae's phasors at ngspice's frequencies; relative magnitude
  error, dB and phase errors;
- ``.dc``: per sweep point; ``.op``: per unknown.

Modules: :mod:`~netdae.comparison.metrics` (the error definitions),
:mod:`~netdae.comparison.analyses` (one analysis), :mod:`~netdae.comparison.run`
(running both simulators), :mod:`~netdae.comparison.model` (the result and its
JSON), :mod:`~netdae.comparison.report` (text), :mod:`~netdae.comparison.plot`
(PNG), :mod:`~netdae.comparison.header` (what a validation netlist states about
itself).

Examples
--------
>>> import netdae
>>> c = netdae.compare("netlists/bode_rc_rlc.cir")  # doctest: +SKIP
>>> c.passed, c.analysis("ac").worst.max_rel < 1e-9  # doctest: +SKIP
(True, True)
"""

from __future__ import annotations

from .header import NetlistHeader, Tolerance, parse_header, read_header
from .model import AnalysisComparison, Comparison, SignalComparison
from .report import format_comparison
from .run import DEFAULT_TOLERANCE, TIGHT_NETDAE, TIGHT_NGSPICE, compare

__all__ = [
    "compare",
    "Comparison",
    "AnalysisComparison",
    "SignalComparison",
    "Tolerance",
    "NetlistHeader",
    "parse_header",
    "read_header",
    "format_comparison",
    "DEFAULT_TOLERANCE",
    "TIGHT_NETDAE",
    "TIGHT_NGSPICE",
]
