"""Rows of a linear circuit's ``.ac`` sweep solved together.

When every row of a chunk has the same structure (:func:`netdae.topology.graph.structure_key`),
the circuit is linear and small (at most :data:`~netdae.analyses.ac.DENSE_AC_LIMIT`
unknowns) and its only analyses are ``.ac``, each row costs its elaboration
(the Monte Carlo draws) and its linear stamps on the layout of the first row;
the phasors of all rows at all frequencies come from one batched dense solve
of ``(j w E_r - H_r) X = B_r U_r``. The first row of a chunk runs the ordinary
analysis (operating point included), so that a circuit the ordinary path
refuses is refused the same way; a later row whose DC matrix is numerically
singular (:data:`RANK_TOLERANCE`), whose structure or frequency grid differs,
or whose batch solve fails runs the ordinary path too and gets its message.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from ..circuit import AcAnalysis
from ..errors import NetdaeError
from .plan import Row
from .worker import Job, Outcome, elaborate_row, record, run_row

__all__ = ["ac_batch", "RANK_TOLERANCE", "MAX_BATCH_ENTRIES"]

#: A row whose DC matrix has sigma_min <= RANK_TOLERANCE * n * eps * sigma_max goes the ordinary way.
RANK_TOLERANCE = 1e3
#: Largest number of complex matrix entries one batched solve holds (about 320 MB).
MAX_BATCH_ENTRIES = 20_000_000


def _linear_ac(job: Job, row: Row):
    """``(circuit, system, frequencies)`` when the batch path applies to ``job``, else None."""
    from ..analyses.ac import DENSE_AC_LIMIT, frequencies
    from ..mna import assemble

    try:
        circuit = elaborate_row(job, row)
    except (NetdaeError, ValueError, ArithmeticError):
        return None
    cards = circuit.analyses
    if not cards or not all(isinstance(a, AcAnalysis) for a in cards) or len(cards) != 1:
        return None
    try:
        system = assemble(circuit)
    except NetdaeError:
        return None
    if system.families or system.delays is not None or system.n > DENSE_AC_LIMIT or system.n == 0:
        return None
    return circuit, system, frequencies(cards[0])


def _matrices(circuit, layout, n: int):
    """Dense E, H (with the resistors' ``ac=`` values), B U_ac of a row on the first row's layout."""
    from ..devices.linear import stamp_linear
    from ..mna.assemble import group_by_kind
    from ..mna.sources import SourceVector

    st = stamp_linear(circuit, layout, group_by_kind(circuit))
    E = st.E.dense(n)
    H = st.H.dense(n)
    H_ac = H + st.H_ac.dense(n)
    b = st.B.dense(n, len(st.sources)) @ SourceVector(st.sources).ac
    return E, H, H_ac, b


@dataclass
class _Stamped:
    """A row ready for the batched solve: its circuit and dense matrices."""

    row: Row
    circuit: object
    E: np.ndarray
    H: np.ndarray
    H_ac: np.ndarray
    b: np.ndarray
    seconds: float


def ac_batch(job: Job, rows: list[Row]) -> list[Outcome] | None:
    """The outcomes of ``rows`` from one batched solve, or None when the batch path does not apply.

    Raises
    ------
    KeyboardInterrupt
        Passed on.
    """
    from ..analyses.ac import frequencies
    from ..analyses.runner import measure
    from ..results import Result, Statistics
    from ..topology.graph import structure_key

    if len(rows) < 2:
        return None
    probe = _linear_ac(job, rows[0])
    if probe is None:
        return None
    circuit0, system0, freqs = probe
    key = structure_key(circuit0)
    first = run_row(job, rows[0])  # the ordinary path: the operating point and its checks
    if first.error is not None:
        return None
    outcomes: dict[int, Outcome] = {rows[0].index: first}
    n, names = system0.n, system0.names
    batch: list[_Stamped] = []
    for row in rows[1:]:
        t0 = time.perf_counter()
        try:
            circuit = elaborate_row(job, row)
        except (NetdaeError, ValueError, ArithmeticError):
            circuit = None
        if (circuit is None or structure_key(circuit) != key
                or not np.array_equal(frequencies(circuit.analyses[0]), freqs)):
            outcomes[row.index] = run_row(job, row)
            continue
        E, H, H_ac, b = _matrices(circuit, system0.layout, n)
        batch.append(_Stamped(row, circuit, E, H, H_ac, b, time.perf_counter() - t0))
    if batch:
        sv = np.linalg.svd(np.stack([item.H for item in batch]), compute_uv=False)
        singular = sv[:, -1] <= RANK_TOLERANCE * n * np.finfo(float).eps * sv[:, 0]
        keep = []
        for item, bad in zip(batch, singular):
            if bad:
                outcomes[item.row.index] = run_row(job, item.row)
            else:
                keep.append(item)
        w = 2j * np.pi * freqs
        per = max(1, MAX_BATCH_ENTRIES // max(w.size * n * n, 1))
        for start in range(0, len(keep), per):
            part = keep[start:start + per]
            t0 = time.perf_counter()
            mats = w[None, :, None, None] * np.stack([item.E for item in part])[:, None] \
                - np.stack([item.H_ac for item in part])[:, None]
            bs = np.stack([item.b for item in part])
            try:
                X = np.linalg.solve(mats, np.broadcast_to(bs[:, None, :, None], mats.shape[:3] + (1,)))[..., 0]
            except np.linalg.LinAlgError:
                for item in part:
                    outcomes[item.row.index] = run_row(job, item.row)
                continue
            share = (time.perf_counter() - t0) / len(part)
            for k, item in enumerate(part):
                t1 = time.perf_counter()
                res = Result("ac", axes={"frequency": freqs},
                             signals={name: X[k, :, i] for i, name in enumerate(names)},
                             stats=Statistics(points=int(freqs.size), batched=len(part)), message="ok")
                measure(item.circuit, [res])
                out = Outcome(item.row.index)
                record(job, item.circuit, [res], out)
                out.seconds = item.seconds + share + time.perf_counter() - t1
                outcomes[item.row.index] = out
    return [outcomes[row.index] for row in rows]
