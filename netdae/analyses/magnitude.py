"""A warning when a result holds a voltage or current no physical circuit reaches.

ngspice's behavioural sources divide by zero without an error: a zero denominator
is moved to ``1e-32`` (its fudge, ``gmin * 1e-20``), so ``V = v(a)/0`` "converges" to
``3e32`` V (netdae computes the same, deliberately). Such a value is a fault of the
netlist, not a result: every node voltage and branch current beyond
:data:`ABSURD_MAGNITUDE` gets a warning among the result's notes, naming the
behavioural sources that divide (located at their cards).
"""

from __future__ import annotations

import numpy as np

from ..circuit import Circuit
from ..netlist import expr as ex

#: Beyond this a voltage [V] or current [A] is no circuit's: a numerator above ``1e-12``
#: (the default abstol) divided by ngspice's fudged zero (1e-32) exceeds it, while the
#: largest voltages engineered are about 1e7 V.
ABSURD_MAGNITUDE = 1e20


def _dividing_sources(circuit: Circuit) -> list[str]:
    """The behavioural sources whose expression divides, as ``name (location)``."""
    out = []
    for el in circuit.elements:
        if el.expr is not None and any(type(n) is ex.Binary and n.op == "/" for n in ex.walk(el.expr)):
            out.append(f"{el.name} ({el.location})" if el.location is not None else el.name)
    return out


def absurd_values_note(circuit: Circuit, signals: dict[str, np.ndarray]) -> str | None:
    """A warning naming the voltages and currents beyond :data:`ABSURD_MAGNITUDE`, or None.

    Parameters
    ----------
    circuit : Circuit
    signals : dict of str to ndarray
        A result's real signals (``v(...)`` and ``i(...)``; the others are not looked at).

    Examples
    --------
    >>> import numpy as np
    >>> c = Circuit("t")
    >>> absurd_values_note(c, {"v(b)": np.array([3e32]), "v(a)": np.array([1.0])}).split(", beyond")[0]
    'warning: v(b) reaches 3e+32'
    >>> absurd_values_note(c, {"v(a)": np.array([1.0])}) is None
    True
    """
    big = []
    for name, values in signals.items():
        if name[:2] not in ("v(", "i(") or not np.isrealobj(values) or not len(values):
            continue
        peak = float(np.max(np.abs(values)))
        if peak > ABSURD_MAGNITUDE:
            big.append((peak, name))
    if not big:
        return None
    big.sort(reverse=True)
    named = ", ".join(f"{name} reaches {peak:.3g}" for peak, name in big[:3])
    more = f" (and {len(big) - 3} more)" if len(big) > 3 else ""
    dividing = _dividing_sources(circuit)
    hint = ("a behavioural source that divides by zero: ngspice (and netdae) replace a zero denominator by 1e-32; "
            "it divides in " + ", ".join(dividing[:3]) if dividing else
            "a runaway expression or a value with a wrong unit suffix")
    return (f"warning: {named}{more}, beyond any physical circuit (|value| > {ABSURD_MAGNITUDE:g}): the result is "
            f"not to be trusted (hint: look for {hint})")
