"""Rows of a linear circuit's ``.ac`` sweep solved together.

When the circuit is linear and small (at most :data:`BATCH_LIMIT`
unknowns) and its only analyses are ``.ac``, the rows of a chunk are solved
in one batched dense solve of ``(j w E_r - H_r) X = B_r U_r`` over all rows
and frequencies (:func:`netdae.dae.shifted.shifted_solves`: one generalized
Schur form per row, then triangular solves for all rows and frequencies at
once) and measured together (:func:`netdae.analyses.measure.evaluate_measure_rows`;
a ``Result`` per row only when waveforms are saved). The sweep's first row
runs the ordinary analysis (operating point included), so that a circuit the
ordinary path refuses is refused the same way; what it prepares is kept for
the sweep's later chunks in the process (by ``Job.token``; a worker process
prepares from the same first row). The other rows get their matrices in one
of two ways:

- **replayed** (most rows): the first row's elaboration is recorded
  (:class:`~netdae.netlist.params.Trace`) and repeated for each row's
  sample and parameter values (:class:`~netdae.netlist.params.Replay`: the
  same evaluations, the same draws from the sample's stream), which gives
  every element field that depends on the row. Each element whose field
  varies adds ``s_r * D`` to the first row's matrices, ``D`` its stamp's
  change (:func:`netdae.devices.linear.stamp_linear` of that element alone)
  and ``s_r`` the field's relative change when the stamp is proportional to
  the field (a capacitance, a gain, an AC magnitude) or to its reciprocal (a
  resistance), found by stamping it at 1, 2 and 4 times its value; the changes
  are added in field order, so a row's matrices do not depend on the other rows
  of its chunk (the same numbers whatever the chunking and the workers);
- **elaborated**: a row whose replay cannot be shown equivalent (an
  evaluation that differs from the recorded one in what it does, an
  analysis card, model or measure value that changes, a field whose stamp
  is neither proportional nor reciprocal, a zero or sign change, an element
  with a field the trace did not see) is elaborated and stamped on its own.

A row whose DC matrix is numerically singular (:data:`RANK_TOLERANCE`),
whose structure or frequency grid differs, or whose batch solve fails runs
the ordinary path and gets its message.
"""

from __future__ import annotations

import dataclasses
import threading
import time
from dataclasses import dataclass

import numpy as np

from ..circuit import AcAnalysis
from ..errors import NetdaeError
from ..kinds import Kind
from .plan import Row
from .worker import Job, Outcome, elaborate_row, record, run_row

__all__ = ["ac_batch", "RANK_TOLERANCE", "MAX_BATCH_ENTRIES"]

#: A row whose DC matrix has sigma_min <= RANK_TOLERANCE * n * eps * sigma_max goes the ordinary way.
RANK_TOLERANCE = 1e3
#: Largest number of complex solution entries one batched solve holds (about 320 MB).
MAX_BATCH_ENTRIES = 20_000_000
#: Most unknowns of a circuit whose rows are solved in one batched dense solve (above, each
#: row's .ac runs on its own, with the sparse LU of :func:`netdae.analyses.ac.solve_ac`).
BATCH_LIMIT = 64

#: The stamp laws of a field: its stamp changes in proportion to the field or to its reciprocal.
PROPORTIONAL, RECIPROCAL = "proportional", "reciprocal"


def _linear_ac(job: Job, row: Row, trace=None):
    """``(circuit, system, frequencies)`` when the batch path applies to ``job``, else None."""
    from ..analyses.ac import frequencies
    from ..mna import assemble

    try:
        circuit = elaborate_row(job, row, trace=trace)
    except (NetdaeError, ValueError, ArithmeticError):
        return None
    cards = circuit.analyses
    if not cards or not all(isinstance(a, AcAnalysis) for a in cards) or len(cards) != 1:
        return None
    try:
        system = assemble(circuit)
    except NetdaeError:
        return None
    if system.families or system.delays is not None or system.n > BATCH_LIMIT or system.n == 0:
        return None
    return circuit, system, frequencies(cards[0])


def _dense(st, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Dense E, H, H_ac (H with the resistors' ``ac=`` values) and B U_ac of linear stamps."""
    from ..mna.sources import SourceVector

    E = st.E.dense(n)
    H = st.H.dense(n)
    H_ac = H + st.H_ac.dense(n)
    b = st.B.dense(n, len(st.sources)) @ SourceVector(st.sources).ac if st.sources else np.zeros(n, complex)
    return E, H, H_ac, b


def _matrices(circuit, layout, n: int):
    """Dense E, H, H_ac, B U_ac of a row on the first row's layout."""
    from ..devices.linear import stamp_linear
    from ..mna.assemble import group_by_kind

    return _dense(stamp_linear(circuit, layout, group_by_kind(circuit)), n)


# -- replayed rows -----------------------------------------------------------------------------
def _fields(el) -> dict[tuple, float]:
    """The numeric fields of an element a trace can bind, by key (``("value",)``, ``("param", k)`` ...)."""
    out: dict[tuple, float] = {}
    if el.value is not None:
        out[("value",)] = el.value
    for k, v in el.params.items():
        out[("param", k)] = v
    if el.source is not None:
        if el.source.dc is not None:
            out[("dc",)] = el.source.dc
        out[("ac_mag",)] = el.source.ac_mag
        out[("ac_phase",)] = el.source.ac_phase
    return out


#: A source's fields that elaboration leaves at these values when its card does not give them.
_SOURCE_DEFAULTS = {("ac_mag",): 0.0, ("ac_phase",): 0.0}


def _with_field(el, key: tuple, value: float):
    """A copy of ``el`` with the field ``key`` set to ``value``."""
    if key[0] == "value":
        return dataclasses.replace(el, value=value)
    if key[0] == "param":
        return dataclasses.replace(el, params={**el.params, key[1]: value})
    return dataclasses.replace(el, source=dataclasses.replace(el.source, **{key[0]: value}))


class _Values:
    """Every row's element fields from the first row's recorded elaboration.

    Parameters
    ----------
    job : Job
    trace : Trace
        The first row's elaboration.
    circuit : Circuit
        The first row's circuit.
    row : Row
        The first row.
    """

    def __init__(self, job: Job, trace, circuit, row: Row) -> None:
        from ..netlist.params import INFO, OTHER, Replay

        self.job = job
        self.replay = Replay(trace, job.seed)
        self.nominal = [e.value for e in trace.events]
        self.checked = [k for k, e in enumerate(trace.events) if e.role == OTHER]
        bound = {e.role: k for k, e in enumerate(trace.events) if e.role not in (INFO, OTHER)}
        _, stepped = job.plan.overrides(row)
        self.fields: list[tuple[str, tuple]] = []  # (element, key)
        self.source: list[tuple[str, int]] = []    # ("event", k) or ("step", element)
        self.trusted: set[str] = set()             # elements whose every field is known per row
        for el in circuit.elements:
            fields = _fields(el)
            known = True
            for key, value in fields.items():
                step_key = ("dc",) if el.source is not None else ("value",)
                if el.name in stepped and key == step_key:
                    where = ("step", el.name)
                elif (el.name, *key) in bound and self.nominal[bound[(el.name, *key)]] == value:
                    where = ("event", bound[(el.name, *key)])
                elif (el.name, *key) not in bound and _SOURCE_DEFAULTS.get(key) == value:
                    continue  # not on the card: the same in every row
                else:
                    known = False
                    continue
                self.fields.append((el.name, key))
                self.source.append(where)
            if known:
                self.trusted.add(el.name)
        used = {where[1] for where in self.source if where[0] == "event"}
        # a value bound to a field the circuit no longer has as it was (a realised element, a field
        # rewritten after elaboration) must not move
        self.checked += sorted(k for k in bound.values() if k not in used)
        self.f0 = np.array([_fields(circuit.element(name))[key] for name, key in self.fields])

    def row(self, row: Row) -> np.ndarray | None:
        """The fields of ``row`` (in :attr:`fields` order), or None when its replay is not the recorded one."""
        from ..netlist.params import ReplayMismatch

        params, stepped = self.job.plan.overrides(row)
        try:
            events = self.replay.values(row.sample if row.sample is not None else 0,
                                        {**self.job.overrides, **params})
        except (NetdaeError, ReplayMismatch, ValueError, ArithmeticError):
            return None
        nominal = self.nominal
        if any(events[k] != nominal[k] for k in self.checked):
            return None
        return np.array([events[where[1]] if where[0] == "event" else float(stepped[where[1]])
                         for where in self.source])

    def rows(self, rows: list[Row]) -> tuple[np.ndarray, list[Row], list[Row]]:
        """The fields of many rows (rows x fields, in :attr:`fields` order), the rows they are of, and the
        rows whose replay is not the recorded one.

        The rows' expressions are evaluated together (:meth:`~netdae.netlist.params.Replay.rows`); a row
        the vectorised pass cannot vouch for is replayed on its own (:meth:`row`). Each row's fields are
        the numbers :meth:`row` gives it, bit for bit, whatever rows are computed with it.
        """
        got: list[Row] = []
        rest: list[Row] = []
        stepped_rows, params_rows = [], []
        for row in rows:
            params, stepped = self.job.plan.overrides(row)
            params_rows.append({**self.job.overrides, **params})
            stepped_rows.append(stepped)
        F = np.empty((len(rows), len(self.source)))
        replayed = same = np.zeros(len(rows), dtype=bool)
        if rows:
            events, replayed = self.replay.rows([row.sample if row.sample is not None else 0 for row in rows],
                                                params_rows)
            same = np.ones(len(rows), dtype=bool)  # the values that must not move did not
            nominal = self.nominal
            for k in self.checked:
                value = events[k]
                if value is None or nominal[k] is None:
                    same &= value is None and nominal[k] is None
                else:
                    same &= np.asarray(value) == nominal[k]
            for j, where in enumerate(self.source):
                if where[0] == "event":
                    value = events[where[1]]
                    F[:, j] = np.nan if value is None else value
                else:
                    F[:, j] = [float(stepped[where[1]]) for stepped in stepped_rows]
        fields = []
        for r, row in enumerate(rows):
            if replayed[r]:  # its own replay: the same numbers
                if same[r]:
                    got.append(row)
                    fields.append(F[r])
                else:
                    rest.append(row)
                continue
            f = self.row(row)
            if f is None:
                rest.append(row)
            else:
                got.append(row)
                fields.append(f)
        return np.array(fields).reshape(len(got), len(self.source)), got, rest


@dataclass
class _Law:
    """How the matrices of a circuit change with one element field."""

    column: int
    law: str
    delta: np.ndarray  # the stamp at twice the field minus the stamp at the field, flattened


def _law(circuit, layout, n: int, el, key: tuple, value: float) -> tuple[str, np.ndarray] | None:
    """The stamp law of ``el``'s field ``key`` at ``value`` and the stamp's change at twice it (None: neither)."""
    from ..devices.linear import stamp_linear

    def stamp(v):
        return np.concatenate([np.ravel(m) for m in _dense(stamp_linear(circuit, layout, {el.kind: [_with_field(
            el, key, v)]}), n)]).astype(complex)

    try:
        c1, c2, c4 = stamp(value), stamp(2.0 * value), stamp(4.0 * value)
    except (NetdaeError, ValueError, ArithmeticError):
        return None
    d1, d2 = c2 - c1, c4 - c2
    if np.array_equal(d2, 2.0 * d1):
        return PROPORTIONAL, d1
    if np.array_equal(d1, 2.0 * d2):
        return RECIPROCAL, d1
    return None


class _LinearMap:
    """Every replayed row's dense matrices as the first row's plus a matrix product."""

    def __init__(self, values: _Values, circuit, layout, n: int, base) -> None:
        self.values, self.circuit, self.layout, self.n = values, circuit, layout, n
        self.base = np.concatenate([np.ravel(m) for m in base]).astype(complex)
        coupled = {name for el in circuit.elements if el.kind == Kind.COUPLING for name in el.controls}
        self.blocked = coupled | {el.name for el in circuit.elements if el.kind == Kind.COUPLING}
        self.laws: dict[int, _Law | None] = {}

    def _law(self, j: int) -> _Law | None:
        if j not in self.laws:
            name, key = self.values.fields[j]
            v0 = float(self.values.f0[j])
            law = None
            if name in self.values.trusted and name not in self.blocked and v0 != 0.0:
                found = _law(self.circuit, self.layout, self.n, self.circuit.element(name), key, v0)
                if found is not None:
                    law = _Law(j, *found)
            self.laws[j] = law
        return self.laws[j]

    def matrices(self, F: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(ok, M)``: which rows of the fields ``F`` (rows x fields) the map covers, and their matrices.

        ``M`` has shape (covered rows, 3 n^2 + n): E, H, H_ac, B U_ac flattened. Each row's
        matrices are the reference row's plus its fields' changes added in field order, the same
        arithmetic whatever other rows are computed with it (a field that does not move adds zero).
        """
        f0 = self.values.f0
        ok = np.ones(F.shape[0], dtype=bool)
        scale_cols, laws = [], []
        moving = np.any(F != f0[None, :], axis=0)
        owners: dict[str, list[int]] = {}
        for j in np.flatnonzero(moving):
            owners.setdefault(self.values.fields[j][0], []).append(int(j))
        for cols in owners.values():  # two fields of one element: their changes multiply, they do not add
            if len(cols) > 1:
                ok &= np.sum(F[:, cols] != f0[cols], axis=1) <= 1
        for j in np.flatnonzero(moving):
            law = self._law(int(j))
            moved = F[:, j] != f0[j]
            if law is None:
                ok &= ~moved
                continue
            v0 = f0[j]
            v = F[:, j]
            ok &= (v != 0.0) & (np.sign(v) == np.sign(v0))
            with np.errstate(divide="ignore", invalid="ignore"):
                s = (v - v0) / v0 if law.law == PROPORTIONAL else 2.0 * (1.0 - v0 / v)
            scale_cols.append(np.where(moved, s, 0.0))
            laws.append(law)
        M = np.broadcast_to(self.base, (int(ok.sum()), self.base.size))
        for scale, law in zip(scale_cols, laws):
            M = M + scale[ok][:, None] * law.delta[None, :]
        return ok, M


@dataclass
class _Stamped:
    """Rows ready for the batched solve: their circuit and their dense matrices, stacked."""

    rows: list[Row]
    circuit: object  # every row's (the first row's circuit for replayed rows)
    E: np.ndarray     # (rows, n, n)
    H: np.ndarray
    H_ac: np.ndarray
    b: np.ndarray     # (rows, n)
    seconds: float    # per row


def _replayed(job: Job, rows: list[Row], values: _Values | None, linear: _LinearMap | None, circuit0, n: int):
    """The rows the linear map covers as one :class:`_Stamped` of the first row's circuit (None: no row), and
    the others."""
    if values is None or linear is None or not rows:
        return None, rows
    t0 = time.perf_counter()
    F, got, rest = values.rows(rows)
    if not got:
        return None, rest
    ok, M = linear.matrices(F)
    nn = n * n
    k = M.shape[0]
    rest.extend(r for r, good in zip(got, ok) if not good)
    rest.sort(key=lambda r: r.index)
    if k == 0:
        return None, rest
    block = _Stamped([r for r, good in zip(got, ok) if good], circuit0, M[:, :nn].real.reshape(k, n, n),
                     M[:, nn:2 * nn].real.reshape(k, n, n), M[:, 2 * nn:3 * nn].real.reshape(k, n, n),
                     M[:, 3 * nn:], (time.perf_counter() - t0) / len(rows))
    return block, rest


def _regular(H: np.ndarray) -> np.ndarray:
    """Which DC matrices ``H`` (stacked) are not numerically singular (:data:`RANK_TOLERANCE`).

    The test is on the singular values, ``sigma_min > RANK_TOLERANCE * n * eps * sigma_max``. A matrix
    whose ``|H|_F |H^-1|_F`` (a bound of ``sigma_max / sigma_min`` from above) is far below the
    threshold's reciprocal passes without its SVD: its inverse, computed to about that ratio times eps,
    cannot be wrong enough to matter (a factor 2 kept for it). The others are decided by their SVD.
    """
    m, n = H.shape[0], H.shape[-1]
    threshold = RANK_TOLERANCE * n * np.finfo(float).eps
    undecided = np.ones(m, dtype=bool)
    try:
        with np.errstate(all="ignore"):
            inverse = np.linalg.inv(H)
            bound = np.sqrt(np.einsum("rij,rij->r", H, H) * np.einsum("rij,rij->r", inverse, inverse))
        undecided = ~(bound < 0.5 / threshold)  # NaN and inf undecided
    except np.linalg.LinAlgError:  # an exactly singular one among them: every one by its SVD
        pass
    regular = ~undecided
    if undecided.any():
        sv = np.linalg.svd(H[undecided], compute_uv=False)
        regular[undecided] = sv[:, -1] > threshold * sv[:, 0]
    return regular


def _measured(job: Job, circuit, freqs: np.ndarray, names, X: np.ndarray) -> list[Outcome]:
    """The outcomes of rows of ``circuit`` from their phasors ``X`` (rows, frequencies, unknowns), measured
    together (:func:`netdae.analyses.measure.evaluate_measure_columns`); only measures, no waveforms."""
    from ..analyses.measure import evaluate_measure_columns
    from ..results import Result

    res = Result("ac", axes={"frequency": freqs}, signals={name: X[:, :, i] for i, name in enumerate(names)},
                 message="ok")
    # as the runner attaches measures: to a result of their analysis; a name measured again: the last card
    # counts (as PARAM= reads it)
    columns = [c for c in evaluate_measure_columns(circuit.measures, {"ac": res}, X.shape[0]) if c.analysis == "ac"]
    values = [c.values.tolist() for c in columns]
    outs = []
    for r in range(X.shape[0]):
        out = Outcome(-1)
        for c, v in zip(columns, values):
            why = c.reasons[r]
            out.measures[c.name] = v[r]  # NaN where it failed
            if why is not None:
                out.reasons[c.name] = why or "failed"
            else:
                out.reasons.pop(c.name, None)
        outs.append(out)
    return outs


@dataclass
class _Prepared:
    """What every chunk of a sweep's linear AC rows shares (built from the sweep's first row)."""

    circuit: object
    system: object
    freqs: np.ndarray
    key: object
    values: _Values | None
    linear: _LinearMap | None
    lock: threading.Lock = dataclasses.field(default_factory=threading.Lock)  # the replay's scopes are reused


#: What this process prepared per sweep (``Job.token``; None: the batch path does not apply), the last few.
_PREPARED: dict[str, _Prepared | None] = {}
#: How many sweeps' preparations a process keeps.
KEEP_PREPARED = 4


def _prepare(job: Job, row: Row) -> tuple[_Prepared | None, Outcome | None]:
    """The shared part of the batch path from ``row`` and that row's ordinary outcome (None: no batch path)."""
    from ..netlist.params import Trace
    from ..topology.graph import structure_key

    trace = Trace()
    probe = _linear_ac(job, row, trace)
    if probe is None:
        return None, None
    circuit, system, freqs = probe
    first = run_row(job, row)  # the ordinary path: the operating point and its checks
    if first.error is not None:
        return None, None
    values = linear = None
    if trace.broken is None and not any(a.target in ("temp", "model") for a in job.plan.axes):
        values = _Values(job, trace, circuit, row)
        linear = _LinearMap(values, circuit, system.layout, system.n, _matrices(circuit, system.layout, system.n))
    return _Prepared(circuit, system, freqs, structure_key(circuit), values, linear), first


def ac_batch(job: Job, rows: list[Row]) -> list[Outcome] | None:
    """The outcomes of ``rows`` from one batched solve, or None when the batch path does not apply.

    Raises
    ------
    KeyboardInterrupt
        Ctrl-C: a new one whose ``finished`` attribute lists the outcomes of the rows done
        before it (the reference row, rows run one by one, the parts of the batch solved and
        measured), as :func:`netdae.sweeps.worker.run_rows` hands them on.
    """
    outcomes: dict[int, Outcome] = {}
    try:
        return _ac_batch(job, rows, outcomes)
    except KeyboardInterrupt:
        stop = KeyboardInterrupt()
        stop.finished = list(outcomes.values())
        raise stop from None


def _ac_batch(job: Job, rows: list[Row], outcomes: dict[int, Outcome]) -> list[Outcome] | None:
    """:func:`ac_batch`, each row's outcome put into ``outcomes`` as soon as it is known."""
    from ..analyses.ac import frequencies
    from ..analyses.runner import measure
    from ..dae.shifted import shifted_solves
    from ..results import Result, Statistics
    from ..topology.graph import structure_key

    prep = _PREPARED.get(job.token) if job.token else None
    if prep is None:
        if len(rows) < 2 or job.token in _PREPARED:
            return None
        first_row = job.plan.rows[0]  # the same reference row in every process and chunk
        prep, first = _prepare(job, first_row)
        if job.token:
            while len(_PREPARED) >= KEEP_PREPARED:
                del _PREPARED[next(iter(_PREPARED))]
            _PREPARED[job.token] = prep
        if prep is None:
            return None
        if any(row.index == first_row.index for row in rows):
            outcomes[first_row.index] = first
    rows_left = [row for row in rows if row.index not in outcomes]
    circuit0, freqs, key, n, names = prep.circuit, prep.freqs, prep.key, prep.system.n, prep.system.names
    with prep.lock:
        block, rest = _replayed(job, rows_left, prep.values, prep.linear, circuit0, n)
    blocks = [block] if block is not None else []
    for row in rest:
        t0 = time.perf_counter()
        try:
            circuit = elaborate_row(job, row)
        except (NetdaeError, ValueError, ArithmeticError):
            circuit = None
        if (circuit is None or structure_key(circuit) != key
                or not np.array_equal(frequencies(circuit.analyses[0]), freqs)):
            outcomes[row.index] = run_row(job, row)
            continue
        E, H, H_ac, b = _matrices(circuit, prep.system.layout, n)
        blocks.append(_Stamped([row], circuit, E[None], H[None], H_ac[None], b[None], time.perf_counter() - t0))
    if blocks:
        batch = [row for blk in blocks for row in blk.rows]
        circuits = [blk.circuit for blk in blocks for _ in blk.rows]
        seconds = np.concatenate([np.full(len(blk.rows), blk.seconds) for blk in blocks])
        E, H, H_ac, b = (np.concatenate([getattr(blk, name) for blk in blocks]) for name in ("E", "H", "H_ac", "b"))
        regular = _regular(H)
        for k in np.flatnonzero(~regular):
            outcomes[batch[k].index] = run_row(job, batch[k])
        keep = np.flatnonzero(regular)
        w = 2j * np.pi * freqs
        per = max(1, MAX_BATCH_ENTRIES // max(w.size * n, 1))
        for start in range(0, keep.size, per):
            part = keep[start:start + per]
            t0 = time.perf_counter()
            X, singular = shifted_solves(E[part], H_ac[part], b[part], w)
            for k in np.flatnonzero(singular):
                outcomes[batch[part[k]].index] = run_row(job, batch[part[k]])
            share = (time.perf_counter() - t0) / part.size
            good = [k for k in range(part.size) if not singular[k]]
            shared = [k for k in good if circuits[part[k]] is circuit0]
            if shared and not job.save:  # one measurement of all rows of the first row's circuit
                t1 = time.perf_counter()
                outs = _measured(job, circuit0, freqs, names, X[shared])
                each = (time.perf_counter() - t1) / len(shared)
                for k, out in zip(shared, outs):
                    out.row = batch[part[k]].index
                    out.seconds = seconds[part[k]] + share + each
                    outcomes[out.row] = out
                good = sorted(set(good) - set(shared))
            for k in good:
                row, circuit = batch[part[k]], circuits[part[k]]
                t1 = time.perf_counter()
                res = Result("ac", axes={"frequency": freqs},
                             signals={name: X[k, :, i] for i, name in enumerate(names)},
                             stats=Statistics(points=int(freqs.size), batched=int(part.size)), message="ok")
                measure(circuit, [res])
                out = Outcome(row.index)
                record(job, circuit, [res], out)
                out.seconds = seconds[part[k]] + share + time.perf_counter() - t1
                outcomes[row.index] = out
    return [outcomes[row.index] for row in rows]
