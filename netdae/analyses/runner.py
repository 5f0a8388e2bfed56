"""Run every analysis a netlist asks for, in netlist order.

This is what ``netdae run FILE`` and :func:`netdae.run` do: dispatch each
``.op``, ``.dc``, ``.ac`` and ``.tran`` card of the circuit to its analysis
and collect the :class:`~netdae.results.Result` objects.
"""

from __future__ import annotations

from typing import Any

from ..circuit import AcAnalysis, Circuit, DcAnalysis, OpAnalysis, TranAnalysis
from ..errors import NetdaeError
from ..results import Result

__all__ = ["run", "analysis_name"]


def analysis_name(card: Any) -> str:
    """``"op"``, ``"dc"``, ``"ac"`` or ``"tran"`` for an analysis card."""
    if isinstance(card, OpAnalysis):
        return "op"
    if isinstance(card, DcAnalysis):
        return "dc"
    if isinstance(card, AcAnalysis):
        return "ac"
    if isinstance(card, TranAnalysis):
        return "tran"
    raise TypeError(f"not an analysis card: {card!r}")


def run(circuit: Circuit | str, *, save: list[str] | None = None, progress=None, **options) -> list[Result]:
    """Run the analyses of a circuit.

    Parameters
    ----------
    circuit : Circuit or str
        An elaborated circuit, or a netlist path/text for :func:`netdae.load`.
    save : list of str, optional
        Signals to keep (``v(out)``, ``i(v1)``); default: the netlist's
        ``.save``/``.print``/``.probe`` signals, or everything.
    progress : callable, optional
        ``progress(t, tstop, steps)`` for transients (see :func:`~netdae.analyses.tran.transient`).
    **options
        Tolerance overrides (``reltol``, ``abstol``, ``vntol``) passed to every analysis.

    Returns
    -------
    list of Result
        One per analysis card, in netlist order.

    Raises
    ------
    NetlistError, CircuitError, ConvergenceError
        Bad input or a failed operating point; a transient that fails
        mid-way returns a Result with a failure status instead.
    """
    if isinstance(circuit, str):
        from ..netlist import load

        circuit = load(circuit)
    if not circuit.analyses:
        raise NetdaeError(
            f"{circuit.path}: the netlist has no analysis card (.op, .dc, .ac or .tran); nothing to run"
        )
    results = []
    for card in circuit.analyses:
        kind = analysis_name(card)
        if kind == "op":
            from .op import operating_point

            results.append(operating_point(circuit, **options))
        elif kind == "dc":
            from .dc import dc_sweep

            results.append(dc_sweep(circuit, card, **options))
        elif kind == "ac":
            from .ac import ac_analysis

            results.append(ac_analysis(circuit, card, **options))
        else:
            from .tran import transient

            results.append(transient(circuit, card, save=save, progress=progress, **options))
    return results
