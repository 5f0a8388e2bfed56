"""netdae: a SPICE-dialect circuit simulator that treats a netlist as a DAE.

The public API:

- :func:`load` -- read and elaborate a netlist into a :class:`Circuit`.
- :func:`analyze_index` -- the structure of the DAE: index, Kronecker form,
  the circuit reasons (an :class:`IndexReport`).
- :func:`simulate` -- run a transient analysis (a :class:`Result`).
- :func:`run` -- run every analysis of a netlist (a list of :class:`Result`).
- :func:`compare` -- run a netlist in netdae and ngspice and compare the
  waveforms (a :class:`Comparison`).
- :func:`sweep` -- parameter steps and Monte Carlo samples, on all cores or
  any executor (a :class:`SweepResult`).
- :func:`from_pyspice` -- a PySpice circuit as a netdae :class:`Circuit`.
- :func:`plot` -- a result as a matplotlib Figure.
- the errors: :class:`NetdaeError` and its subclasses :class:`NetlistError`,
  :class:`CircuitError`, :class:`SingularPencilError`,
  :class:`ConvergenceError`, :class:`NgspiceError`.

``import netdae`` is cheap (no numpy; the ``netdae`` command's hand-over to a
running server imports nothing else): every name but the errors is imported
on first use. Type checkers see every name through the static imports below.

Examples
--------
>>> import netdae
>>> r = netdae.simulate("netlists/rc_lowpass.cir", save=["v(out)"])
>>> r                                                   # doctest: +ELLIPSIS
<Result tran: ... points, time 0 to 0.005 s; 1 signal (v(out)); ok>
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from .errors import (
    CircuitError,
    ConvergenceError,
    NetdaeError,
    NetlistError,
    NgspiceError,
    SingularPencilError,
)

if TYPE_CHECKING:  # imported on first use at run time (they load numpy or dataclasses): see __getattr__
    from .analyses.runner import run, simulate
    from .circuit import Circuit
    from .measures import Measure
    from .analyses.index import IndexReport, analyze_index
    from .comparison import Comparison, compare
    from .io.pyspice import from_pyspice
    from .netlist import load
    from .plotting import plot
    from .results import Result
    from .sweeps import SweepResult, sweep

__version__ = "0.1.0"

__all__ = [
    "__version__",
    "load",
    "analyze_index",
    "simulate",
    "run",
    "compare",
    "sweep",
    "SweepResult",
    "from_pyspice",
    "plot",
    "Circuit",
    "Result",
    "IndexReport",
    "Comparison",
    "Measure",
    "NetdaeError",
    "NetlistError",
    "CircuitError",
    "SingularPencilError",
    "ConvergenceError",
    "NgspiceError",
]


def __getattr__(name: str):
    """The heavy public names, imported on first use (PEP 562)."""
    if name == "run":
        from .analyses.runner import run as value
    elif name == "simulate":
        from .analyses.runner import simulate as value
    elif name == "Circuit":
        from .circuit import Circuit as value
    elif name == "Measure":
        from .measures import Measure as value
    elif name == "load":
        from .netlist import load as value
    elif name == "analyze_index":
        from .analyses.index import analyze_index as value
    elif name == "IndexReport":
        from .analyses.index import IndexReport as value
    elif name == "compare":
        from .comparison import compare as value
    elif name == "Comparison":
        from .comparison import Comparison as value
    elif name == "from_pyspice":
        from .io.pyspice import from_pyspice as value
    elif name == "plot":
        from .plotting import plot as value
    elif name == "Result":
        from .results import Result as value
    elif name == "sweep":
        from .sweeps import sweep as value
    elif name == "SweepResult":
        from .sweeps import SweepResult as value
    else:
        raise AttributeError(f"module 'netdae' has no attribute {name!r}")
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
