"""Netlist dialect details found by comparing netdae with ngspice 39 card by card.

Each test names the ngspice behaviour it pins down; those that need ngspice run the
same netlist in ``ngspice -b`` (``print`` with 12 digits) and in netdae.
"""

from __future__ import annotations

import re
import subprocess
from pathlib import Path

import pytest

import netdae
from netdae.errors import NetlistError
from netdae.netlist import load


def ngspice_print(netlist: str, names: list[str], tmp_path: Path) -> dict[str, float]:
    """Run ``netlist`` in ``ngspice -b`` and return the printed real values of ``names``.

    Parameters
    ----------
    netlist : str
        The netlist without ``.end``.
    names : list of str
        ngspice vector names to print.
    tmp_path : Path
        Directory for the netlist file.

    Returns
    -------
    dict of str to float
    """
    text = netlist.rstrip() + "\n.control\nset numdgt=12\nrun\nprint " + " ".join(names) + "\n.endc\n.end\n"
    cir = tmp_path / "p.cir"
    cir.write_text(text)
    proc = subprocess.run(["ngspice", "-b", str(cir)], capture_output=True, text=True, timeout=60, cwd=tmp_path)
    out: dict[str, float] = {}
    for line in proc.stdout.splitlines():
        m = re.match(r"\s*(\S+) = (\S+?)\s*$", line)
        if m and m.group(1) in names:
            out[m.group(1)] = float(m.group(2))
    assert set(out) == set(names), proc.stdout + proc.stderr
    return out


def op_values(netlist: str, names: list[str]) -> dict[str, float]:
    """netdae's operating point values of ``names`` (``v(n)``, ``i(v1)``)."""
    result = netdae.run(load(netlist))[0]
    return {name: float(result.signals[name][-1]) for name in names}


# -- nested conditionals in parameter expressions ---------------------------------------------

NESTED = "c1 ? c2 ? a : b : e"


@pytest.mark.parametrize("card", [
    ".param p={1 ? 0 ? 10 : 20 : 30}\nV1 n 0 {p}",
    "V1 n 0 {1 ? 0 ? 10 : 20 : 30}",
    "V1 n 0 '(7 > 1) ? 7 < 5 ? 10 : 20 : 30'",
    ".func h(x) = {x > 1 ? x < 5 ? 10 : 20 : 30}\nV1 n 0 {h(7)}",
    ".model dd d is={1 ? 0 ? 1e-14 : 2e-14 : 3e-14}\nD1 n 0 dd\nV1 n 0 0.6",
])
def test_unparenthesised_conditional_in_a_true_branch_is_refused_in_parameters(card):
    # ngspice 39's parameter evaluator gives 10 for 1 ? 0 ? 10 : 20 : 30 (the first value
    # whenever the outer condition holds), where C reads 20: netdae refuses the form
    with pytest.raises(NetlistError, match="unparenthesised in the true branch") as info:
        load(f"t\n{card}\nR1 n 0 1k\n.op\n")
    assert "c1 ? (c2 ? a : b) : e" in info.value.hint


def test_conditionals_that_both_read_alike_are_accepted():
    values = op_values("t\n.param x=7\n"
                       "V1 n1 0 {x > 1 ? (x < 5 ? 10 : 20) : 30}\n"   # parenthesised: 20
                       "V2 n2 0 {x < 1 ? 10 : x < 5 ? 20 : 30}\n"     # chained in the false branch: 30
                       "V3 n3 0 {1 ? max(0 ? 1 : 2, 0) : 3}\n"       # inside a call's parentheses: 2
                       "B1 n4 0 V={v(n1) > 1 ? v(n1) < 5 ? 10 : 20 : 30}\n"  # B source: C's reading, 20
                       "R1 n4 0 1k\n.op\n", ["v(n1)", "v(n2)", "v(n3)", "v(n4)"])
    assert values == {"v(n1)": 20.0, "v(n2)": 30.0, "v(n3)": 2.0, "v(n4)": 20.0}


@pytest.mark.ngspice
def test_ngspice_reads_the_nested_conditional_otherwise_and_the_parenthesised_one_as_c(tmp_path):
    ref = ngspice_print("t\nV1 n1 0 {1 ? 0 ? 10 : 20 : 30}\nV2 n2 0 {1 ? (0 ? 10 : 20) : 30}\n"
                        "V3 n3 0 {0 ? 2 : 0 ? 4 : 5}\nR1 n1 0 1\nR2 n2 0 1\nR3 n3 0 1\n.op",
                        ["v(n1)", "v(n2)", "v(n3)"], tmp_path)
    assert ref == {"v(n1)": 10.0, "v(n2)": 20.0, "v(n3)": 5.0}
    got = op_values("t\nV2 n2 0 {1 ? (0 ? 10 : 20) : 30}\nV3 n3 0 {0 ? 2 : 0 ? 4 : 5}\n"
                    "R2 n2 0 1\nR3 n3 0 1\n.op\n", ["v(n2)", "v(n3)"])
    assert got == {"v(n2)": 20.0, "v(n3)": 5.0}
