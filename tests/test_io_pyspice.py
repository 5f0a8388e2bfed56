"""PySpice circuits in netdae: ``from_pyspice`` reads the text PySpice writes.

The oracle for the meaning is the closed form of the circuit PySpice built:
an RC low-pass charged from 0 V by a 1 V source, v(out) = 1 - exp(-t / RC),
measured in units of the transient's own tolerance. Errors must name the
PySpice circuit and the line of ``str(circuit)``.
"""

from __future__ import annotations

import numpy as np
import pytest

from netdae.errors import NetdaeError, NetlistError
from netdae.io.pyspice import from_pyspice

pytest.importorskip("PySpice")

from PySpice.Spice.Netlist import Circuit  # noqa: E402
from PySpice.Unit import u_kOhm, u_uF, u_V  # noqa: E402

R, C = 1e3, 1e-6
TAU = R * C


def _rc(value=1 @ u_kOhm) -> Circuit:
    circuit = Circuit("RC from PySpice")
    circuit.V("in", "inp", circuit.gnd, 1 @ u_V)
    circuit.R(1, "inp", "out", value)
    circuit.C(1, "out", circuit.gnd, 1 @ u_uF, initial_condition=0 @ u_V)
    return circuit


def test_a_pyspice_rc_charges_as_the_closed_form():
    from netdae import simulate

    circuit = from_pyspice(_rc(), ".tran 10u 5m uic")
    assert circuit.title == "RC from PySpice"
    assert sorted(circuit.nodes) == ["inp", "out"]
    result = simulate(circuit)
    t = np.linspace(0.0, 5 * TAU, 2001)
    got = result.dense(t)["v(out)"]
    exact = 1 - np.exp(-t / TAU)
    reltol, vntol = result.tolerances["reltol"], result.tolerances["vntol"]
    # the local error test holds each step to reltol * |v| + vntol; the global
    # error of a stable RC stays within a few of those units
    units = np.max(np.abs(got - exact) / (reltol * np.abs(exact) + vntol))
    assert units < 10, units
    np.testing.assert_allclose(result["i(vin)"][-1], -np.exp(-result.t[-1] / TAU) * 1e-3, atol=1e-3 * reltol * 10)


def test_errors_name_the_pyspice_circuit_and_the_line_of_its_text():
    circuit = _rc(value="oops")
    line = next(k for k, text in enumerate(str(circuit).splitlines(), 1) if text.startswith("R1"))
    with pytest.raises(NetlistError, match=rf"^<PySpice circuit 'RC from PySpice'>:{line}:\d+: r1"):
        from_pyspice(circuit)
    second_card = len(str(_rc()).splitlines()) + 2
    with pytest.raises(NetlistError, match=rf"^<PySpice circuit 'RC from PySpice'>:{second_card}:\d+: \.tran"):
        from_pyspice(_rc(), [".options reltol=1e-4", ".tran 10u"])


def test_cards_reach_a_pyspice_simulator_whose_text_ends_with_end():
    # str(circuit.simulator()) ends with '.end': cards appended after it were never read
    # ("no analysis card"), while ngspice reads on past '.end'
    from netdae import simulate

    # the subprocess simulator: its text is the same, and it loads no ngspice library in this process
    simulator = _rc().simulator(simulator="ngspice-subprocess", temperature=25, nominal_temperature=25)
    assert str(simulator).split()[-1] == ".end"
    circuit = from_pyspice(simulator, ".tran 10u 5m uic")
    result = simulate(circuit)
    t = np.linspace(0.0, 5 * TAU, 501)
    exact = 1 - np.exp(-t / TAU)
    reltol, vntol = result.tolerances["reltol"], result.tolerances["vntol"]
    assert np.max(np.abs(result.dense(t)["v(out)"] - exact) / (reltol * np.abs(exact) + vntol)) < 10
    # the cards keep their line numbers: str(simulator)'s lines, then the cards
    second_card = len(str(simulator).splitlines()) + 2
    with pytest.raises(NetlistError, match=rf"^<PySpice circuit 'RC from PySpice'>:{second_card}:\d+: \.tran"):
        from_pyspice(simulator, [".options reltol=1e-4", ".tran 10u"])


def test_only_pyspice_objects_are_accepted():
    with pytest.raises(NetdaeError, match="expected a PySpice Circuit, got str .for netlist text or a file use netdae.load"):
        from_pyspice("R1 a 0 1\n")
