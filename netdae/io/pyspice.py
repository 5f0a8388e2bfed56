"""PySpice circuits as netdae circuits, through the netlist text PySpice writes.

PySpice builds a circuit in Python (``circuit.R(1, "in", "out", 1@u_kOhm)``)
and turns it into an ngspice netlist with ``str(circuit)``. netdae reads that
text with its own reader, so a PySpice circuit means in netdae what it means
in ngspice, and PySpice is never imported here.

Errors in the text are :class:`~netdae.errors.NetlistError` located in
``<PySpice circuit 'title'>:line:column``, where the lines are those of
``str(circuit)`` followed by the ``cards`` given to :func:`from_pyspice`.
"""

from __future__ import annotations

from ..errors import NetdaeError

__all__ = ["from_pyspice", "pyspice_netlist"]

#: PySpice writes the title as a ``.title`` card on the first line.
_TITLE_CARD = ".title"


def pyspice_netlist(circuit, cards=()) -> tuple[str, str]:
    """The netlist text of a PySpice circuit and the name errors will show.

    Parameters
    ----------
    circuit : PySpice.Spice.Netlist.Circuit or CircuitSimulator
        Anything of PySpice's whose ``str()`` is a netlist.
    cards : str or sequence of str
        Further cards appended to the text (analyses such as ``.tran 10u 5m``,
        ``.options``, ``.save``). When the text ends with ``.end`` (``str()``
        of a ``CircuitSimulator``), the cards go before it and that line
        becomes a comment (``* .end``), so every line keeps its number.

    Returns
    -------
    text : str
    source : str
        ``<PySpice circuit 'title'>``.

    Raises
    ------
    NetdaeError
        When ``circuit`` is not a PySpice object.

    Examples
    --------
    >>> class Circuit:  # what PySpice's Circuit offers: a title and str()
    ...     __module__ = "PySpice.Spice.Netlist"
    ...     title = "rc"
    ...     def __str__(self):
    ...         return ".title rc\\nR1 in out 1kOhm\\nC1 out 0 1uF\\n"
    >>> text, source = pyspice_netlist(Circuit(), ".tran 10u 5m")
    >>> print(text, end=""); source
    rc
    R1 in out 1kOhm
    C1 out 0 1uF
    .tran 10u 5m
    "<PySpice circuit 'rc'>"
    """
    module = type(circuit).__module__ or ""
    if not module.startswith("PySpice"):
        raise NetdaeError(
            f"from_pyspice: expected a PySpice Circuit, got {type(circuit).__name__}"
            + (" (for netlist text or a file use netdae.load)" if isinstance(circuit, str) else "")
        )
    text = str(circuit)
    lines = text.splitlines()
    # ngspice takes a first line '.title x' as the title 'x'; keep the line count
    if lines and lines[0].strip().lower().startswith(_TITLE_CARD):
        lines[0] = lines[0].strip()[len(_TITLE_CARD):].strip()
    if isinstance(cards, str):
        cards = [cards]
    cards = list(cards)
    end = _end_line(lines)
    if cards and end is not None:
        # a simulator's text ends with '.end': the cards go before it (netdae's reader stops
        # there), and the '.end' line becomes a comment so the lines keep their numbers
        lines[end:] = ["* " + line if k == 0 else line for k, line in enumerate(lines[end:])]
        lines += cards + [".end"]
    else:
        lines += cards
    title = getattr(circuit, "title", None) or (lines[0] if lines else "")
    return "\n".join(lines) + "\n", f"<PySpice circuit {str(title)!r}>"


def _end_line(lines: list[str]) -> int | None:
    """The index of the last ``.end`` line (``str()`` of a PySpice simulator ends with one), or None.

    Examples
    --------
    >>> _end_line(["t", "R1 a 0 1", ".options TEMP = 27C", ".end", ""]), _end_line(["t", ".ends sub"])
    (3, None)
    """
    for k in range(len(lines) - 1, -1, -1):
        words = lines[k].split()
        if words and words[0].lower() == ".end":
            return k
    return None


def from_pyspice(circuit, cards=()):
    """Turn a PySpice circuit into a netdae :class:`~netdae.circuit.Circuit`.

    Parameters
    ----------
    circuit : PySpice.Spice.Netlist.Circuit or CircuitSimulator
        The circuit (a simulator adds its ``.options`` and initial conditions).
    cards : str or sequence of str
        Further netlist cards, e.g. the analysis ``".tran 10u 5m"`` that
        :func:`netdae.simulate` runs (PySpice keeps analyses out of the circuit).

    Returns
    -------
    Circuit

    Raises
    ------
    NetlistError
        Anything wrong in the text, located in ``<PySpice circuit 'title'>``
        by the line of ``str(circuit)`` (then of ``cards``).
    NetdaeError
        When ``circuit`` is not a PySpice object.

    Notes
    -----
    PySpice is not imported: the circuit's ``str()`` is its netlist. Values
    carry PySpice's units (``1kOhm``, ``1uF``, ``27C``), which the SPICE number
    syntax reads as ngspice does (letters after a scale suffix are ignored).
    Relative ``.include`` paths resolve against the current directory.
    """
    from ..netlist import load

    text, source = pyspice_netlist(circuit, cards)
    return load(text, path=source)
