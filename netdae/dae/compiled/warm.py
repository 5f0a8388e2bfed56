"""Compile (or load from numba's cache) the transient engine: ``python -m netdae.dae.compiled.warm``.

The ``make`` targets run this during set-up so that the first simulation of a
fresh install does not pay the compilation. It also writes the package's
Python bytecode (``compileall``): where ``PYTHONDONTWRITEBYTECODE`` is set, or
the package directory is written only at install time, every run would
otherwise compile netdae's sources again (about 0.1 s of each start).
Prints the time it took.
"""

from __future__ import annotations

import time

#: A small circuit that exercises every compiled path of the engine.
_WARM_NETLIST = """engine warm-up
V1 in 0 PULSE(0 1 1n 1n 1n 5n 10n)
V2 s 0 SIN(0 1 100meg)
I1 0 s2 PWL(0 0 1n 1m 2n 0)
R2 s2 0 1k
V3 e 0 EXP(0 1 1n 2n 5n 2n)
V4 f 0 SFFM(0 1 100meg 1 10meg)
V5 a 0 AM(1 0.5 10meg 100meg)
R1 in out 1k
C1 out 0 1p
L1 out 0 1u
.tran 0.1n 20n
.end
"""
#: A nonlinear circuit: its operating point runs the compiled Newton (``compiled/steady.py``), its
#: measurement the compiled peak search (``compiled/dense.py``).
_WARM_NONLINEAR = """engine warm-up, nonlinear
V1 in 0 SIN(0 1 1k)
R1 in a 1k
D1 a 0 dm
C1 a 0 1n
.model dm d(is=1e-14)
.tran 10u 1m
.meas tran vmax max v(a)
.end
"""

#: A linear circuit above the dense .ac limit: its .ac runs the sparse LU's complex kernels.
_WARM_AC = "engine warm-up, .ac\nV1 n0 0 DC 0 AC 1\n" + "".join(
    f"R{k} n{k} n{k + 1} 10\nC{k} n{k + 1} 0 1n\n" for k in range(20)) + ".ac dec 2 1k 1meg\n.end\n"


def warm() -> float:
    """Run the warm-up circuit; returns the wall time [s]."""
    import netdae

    t0 = time.perf_counter()
    netdae.simulate(netdae.load(_WARM_NETLIST))
    netdae.run(netdae.load(_WARM_NONLINEAR))
    netdae.run(netdae.load(_WARM_AC))
    return time.perf_counter() - t0


def bytecode() -> bool:
    """Write the bytecode of every netdae module (``compileall``); False when a file could not be written."""
    import compileall
    from pathlib import Path

    package = Path(__file__).resolve().parents[2]
    return bool(compileall.compile_dir(str(package), quiet=1))


if __name__ == "__main__":
    bytecode()
    print(f"netdae: compiled engine ready ({warm():.1f} s)")
