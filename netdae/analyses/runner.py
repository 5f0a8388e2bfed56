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

__all__ = ["run", "analysis_name", "unused_options"]


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
    names = save if save is not None else circuit.saves
    unused = unused_options(circuit)
    results = []
    for card in circuit.analyses:
        kind = analysis_name(card)
        if kind == "tran":
            from .tran import transient

            res = transient(circuit, card, save=names, progress=progress, **options)
        else:
            if kind == "op":
                from .op import operating_point

                res = operating_point(circuit, **options)
            elif kind == "dc":
                from .dc import dc_sweep

                res = dc_sweep(circuit, card, **options)
            else:
                from .ac import ac_analysis

                res = ac_analysis(circuit, card, **options)
            if names:
                try:
                    res = res.subset(names)
                except KeyError as exc:
                    raise NetdaeError(f"cannot save: {exc.args[0]}") from None
        if unused:
            res.notes.append(unused)
        results.append(res)
    return results


def unused_options(circuit: Circuit) -> str | None:
    """A note naming the ``.options`` netdae does not use, or None.

    ``chgtol`` and ``itl4`` have SPICE meanings netdae's integrator does not
    share (it controls the error of the unknowns, and its Newton iteration per
    step is limited by its own convergence test); the options netdae does not
    know are kept as written in ``Options.extra``.
    """
    o = circuit.options
    names = sorted(o.extra)
    if o.chgtol != type(o)().chgtol:
        names.insert(0, "chgtol")
    if o.itl4 != type(o)().itl4:
        names.insert(0, "itl4")
    if not names:
        return None
    return "options not used by netdae: " + ", ".join(names)
