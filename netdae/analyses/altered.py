"""The circuit an analysis runs on after a ``.control`` script's ``alter`` and ``altermod`` commands.

A script's analysis card carries every change in force when it runs
(:class:`~netdae.circuit.Alteration`, ``card.alter``; :mod:`netdae.netlist.control`).
The circuit it runs on is the netlist elaborated again the way a sweep's row
is (:func:`netdae.sweeps.worker.elaborate_row`): element values and model
parameters through ``values=`` (``{"r1": 2e3, "nmos1(vto)": 0.5}``), the same
parameter overrides, Monte Carlo sample and seed; a source function's new
parameters (``alter @v1[sin] [ 0 1 2k ]``, which a sweep cannot set) then
replace that source's transient function, as ngspice's ``alter`` replaces its
coefficients (``alter v1 ac = 2``: its AC magnitude); an instance parameter of a top-level element (``alter d1 area = 2``)
is written on its card in a copy of the netlist, which elaboration reads as the
card's own.
"""

from __future__ import annotations

import dataclasses

from ..circuit import Alteration, Circuit
from ..errors import NetlistError

__all__ = ["altered_circuit"]


def altered_circuit(circuit: Circuit, alter: tuple[Alteration, ...], cache: dict | None = None) -> Circuit:
    """``circuit`` with the changes ``alter`` applied (``circuit`` itself when there are none).

    Parameters
    ----------
    circuit : Circuit
        Elaborated by :func:`netdae.netlist.load` (it keeps its netlist).
    alter : tuple of Alteration
        An analysis card's ``alter``.
    cache : dict, optional
        Circuits already built, by ``alter`` (the analyses of a loop that changes nothing between them
        share one).

    Returns
    -------
    Circuit

    Raises
    ------
    NetlistError
        A change the circuit refuses (a zero resistance, a parameter the model does not have ...),
        located at its command.
    """
    if not alter:
        return circuit
    if cache is not None and alter in cache:
        return cache[alter]
    if circuit.netlist is None:
        raise NetlistError("the circuit was not elaborated from a netlist: netdae cannot alter it",
                           alter[0].location)
    from ..netlist.control import waveform
    from ..netlist.elaborate import elaborate

    values: dict[str, float] = {}
    functions: list[Alteration] = []
    instance: list[Alteration] = []
    for change in alter:
        if change.target == "model":
            values[f"{change.name}({change.param})"] = change.value
        elif change.target == "instance":
            instance.append(change)
        elif change.param is None:
            values[change.name] = change.value
        else:
            functions.append(change)
    try:
        out = elaborate(_with_instance_parameters(circuit.netlist, instance), params=circuit.overrides,
                        values=values, max_elements=circuit.max_elements, sample=circuit.sample, seed=circuit.seed)
    except NetlistError as exc:
        if not exc.message.startswith("values: "):  # a value the command set (else: located where it is wrong)
            raise
        change = next((c for c in alter if exc.message.startswith("values: ") and (
            f"'{c.name}'" in exc.message or f"{c.name}(" in exc.message)), alter[-1])
        raise NetlistError(f".control: '{change.command}': {exc.message.removeprefix('values: ')}", change.location,
                           hint=exc.hint) from None
    elements = {el.name: el for el in out.elements}
    for change in functions:
        el = elements[change.name]
        if change.param == "acmag":
            el.source = dataclasses.replace(el.source, ac_mag=change.value, ac_given=True)
        else:
            el.source = dataclasses.replace(el.source, tran=waveform(change.param, change.value))
    out.diagnostics = list(circuit.diagnostics)
    if cache is not None:
        cache[alter] = out
    return out


def _with_instance_parameters(net, changes: list[Alteration]):
    """``net`` with the instance parameters ``changes`` sets written on its top-level element cards
    (as if the card had said ``area=2``), for elaboration to read as it reads the card's own."""
    if not changes:
        return net
    from ..netlist.statements import ElementCard

    items = list(net.top.items)
    for change in changes:
        for k, item in enumerate(items):
            if type(item) is ElementCard and item.name == change.name:
                offset = item.params.get(change.param, (None, 0))[1]
                items[k] = dataclasses.replace(item, params={**item.params, change.param: (change.value, offset)})
                break
    return dataclasses.replace(net, top=dataclasses.replace(net.top, items=items))
