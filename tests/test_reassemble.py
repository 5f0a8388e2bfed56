"""Circuits that differ only in linear values assembled on a template (netdae/mna/assemble.reassemble).

A sweep's rows share their first row's unknowns, pattern and device families; each row's
linear stamps are made again. The system must be the one ``assemble`` builds on its own,
value for value, and a circuit that differs in anything else must be assembled on its own.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import netdae
from netdae.analyses.prepared import prepare, reusing
from netdae.mna.assemble import Template, assemble, reassemble
from netdae.mna.sources import MODE_TRAN

BRIDGE = """bridge
.param rl=1k cf=470u
V1 ac 0 DC 12 SIN(0 12 50)
RS ac acs 1
D1 acs pos dm
D2 0 pos dm
D3 neg acs dm
D4 neg 0 dm
C1 pos neg {cf}
RL pos neg {rl}
.model dm d(is=7n rs=0.05 n=1.8 cjo=10p tt=100n)
.tran 100u 40m
.meas tran ripple pp v(pos,neg) from=20m to=40m
"""

ARGS = dict(mode=MODE_TRAN, tstep=100e-6, tstop=40e-3)


def _same_system(a, b) -> None:
    assert a.names == b.names
    for name in ("E", "H", "B", "H_ac"):
        ma, mb = getattr(a, name), getattr(b, name)
        assert ma.shape == mb.shape
        np.testing.assert_array_equal(ma.toarray(), mb.toarray())
    np.testing.assert_array_equal(a.pattern.rows, b.pattern.rows)
    np.testing.assert_array_equal(a.pattern.cols, b.pattern.cols)
    for name in ("_dq_lin", "_dphi_lin", "_E_mv", "_H_mv", "_b_full"):  # what evaluate and the engine read
        ma, mb = getattr(a, name), getattr(b, name)
        ma, mb = (m.toarray() if hasattr(m, "toarray") else m for m in (ma, mb))
        np.testing.assert_array_equal(ma, mb)
        assert np.signbit(ma).tolist() == np.signbit(mb).tolist()
    x = np.linspace(-1.0, 1.0, a.n)
    ea, eb = a.evaluate(x, 1e-3, jacobian=True, state=None), b.evaluate(x, 1e-3, jacobian=True, state=None)
    for field in ("q", "phi", "dq", "dphi"):
        np.testing.assert_array_equal(getattr(ea, field), getattr(eb, field))


def test_other_linear_values_give_the_system_assemble_gives():
    base = netdae.load(BRIDGE)
    template = Template.of(base, assemble(base, **ARGS), **ARGS)
    other = netdae.load(BRIDGE, params={"rl": 820.0, "cf": 330e-6})
    system = reassemble(template, other)
    assert system is not None and system.families == template.system.families
    assert system.placement() is template.system.placement()  # filled on the template's structure
    _same_system(system, assemble(other, **ARGS))
    assert not np.array_equal(system.E.toarray(), template.system.E.toarray())
    # the rows the shared families store charge in, found on the template's system once
    alone = assemble(other, **ARGS)
    rows, timed = template.system.nonlinear_charge_rows(), template.system.time_charge_rows()
    again = reassemble(template, other)
    assert again.nonlinear_charge_rows() is rows and again.time_charge_rows() is timed
    assert np.array_equal(rows, alone.nonlinear_charge_rows()) and rows.size == 6  # the junctions: 4 inner nodes, 2 cathodes
    assert np.array_equal(timed, alone.time_charge_rows())


@pytest.mark.parametrize("change", [
    lambda text: text.replace("is=7n", "is=8n"),            # a device model parameter
    lambda text: text.replace("D4 neg 0 dm", "D4 neg 0 dm area=2"),  # a device instance parameter
    lambda text: text.replace("RL pos neg {rl}", "RL pos mid {rl}\nRM mid neg 1"),  # another node
    lambda text: text.replace("RS ac acs 1", "LS ac acs 1u"),  # another element kind
    lambda text: text + ".options gmin=1e-10\n",          # an option the families read
])
def test_a_circuit_that_differs_in_more_than_linear_values_is_assembled_on_its_own(change):
    base = netdae.load(BRIDGE)
    template = Template.of(base, assemble(base, **ARGS), **ARGS)
    assert reassemble(template, netdae.load(change(BRIDGE))) is None


def test_families_with_held_states_are_not_shared():
    text = BRIDGE.replace("RS ac acs 1", "S1 ac acs ac 0 sw\n.model sw sw vt=-100")
    base = netdae.load(text)
    assert Template.of(base, assemble(base, **ARGS), **ARGS) is None


def test_prepare_within_reusing_shares_the_first_circuits_parts_and_nothing_else():
    store: dict = {}
    with reusing(store):
        first = prepare(netdae.load(BRIDGE), **ARGS)
        row = prepare(netdae.load(BRIDGE, params={"rl": 900.0}), **ARGS)
        dc = prepare(netdae.load(BRIDGE))  # other arguments: its own template
        model = prepare(netdae.load(BRIDGE.replace("is=7n", "is=9n")), **ARGS)
    assert row.system.families is first.system.families
    assert dc.system.families is not first.system.families
    assert model.system.families is not first.system.families
    _same_system(row.system, assemble(netdae.load(BRIDGE, params={"rl": 900.0}), **ARGS))
    assert prepare(netdae.load(BRIDGE), **ARGS).system.families is not first.system.families  # outside: none


MC = BRIDGE.replace(".param rl=1k cf=470u", ".param rl={agauss(1k, 50, 1)} cf={agauss(470u, 23.5u, 1)}")


@pytest.mark.parametrize("text, shared_rows", [
    (MC, 4),                                                                  # every later row shares
    (MC.replace("D4 neg 0 dm", "D4 neg 0 dm area={agauss(1, 0.05, 1)}"), 0),  # each row its own diode
])
def test_a_monte_carlo_sweep_gives_bit_for_bit_what_rows_assembled_on_their_own_give(monkeypatch, text,
                                                                                      shared_rows):
    import importlib

    import netdae.sweeps.worker as worker

    module = importlib.import_module("netdae.mna.assemble")
    made = []
    real = module.reassemble
    monkeypatch.setattr(module, "reassemble", lambda t, c: made.append(real(t, c)) or made[-1])
    circuit = netdae.load(text)
    shared = netdae.sweep(circuit, samples=5, seed=3, workers=1, save=["v(pos,neg)"])
    assert sum(system is not None for system in made) == shared_rows
    monkeypatch.setattr(worker, "_templates", lambda job: None)
    alone = netdae.sweep(circuit, samples=5, seed=3, workers=1, save=["v(pos,neg)"])
    assert shared.failed == alone.failed == 0
    np.testing.assert_array_equal(shared.measures["ripple"], alone.measures["ripple"])
    np.testing.assert_array_equal(shared.waves[("tran", "v(pos,neg)")], alone.waves[("tran", "v(pos,neg)")])
    assert np.unique(shared.measures["ripple"]).size == 5


@pytest.mark.parametrize("entries", [3, 0])
def test_csc_sums_after_the_first_are_scipys_matrices_with_their_own_arrays(entries):
    """A CscSum's later matrices copy its first one's checked structure: each equals the matrix scipy's
    constructor makes of the same sums, dtypes included, and owns its arrays (changing one's indices or
    values in place changes no other)."""
    import scipy.sparse as sp

    from netdae.devices.stamps import CscSum

    rows = np.array([0, 2, 0, 1][:entries], dtype=np.int64)
    cols = np.array([1, 1, 1, 0][:entries], dtype=np.int64)
    s = CscSum(rows, cols, 3, 3)
    made = [s.matrix(np.arange(entries, dtype=float) + k) for k in range(3)]
    for k, m in enumerate(made):
        want = sp.coo_matrix((np.arange(entries, dtype=float) + k, (rows, cols)), shape=(3, 3)).tocsc()
        assert sp.isspmatrix_csc(m) and m.shape == (3, 3) and m.data.dtype == np.float64
        assert np.array_equal(m.toarray(), want.toarray())
        assert m.indices.dtype == made[0].indices.dtype and m.indptr.dtype == made[0].indptr.dtype
    for a in made:
        for b in made:
            if a is not b:
                assert not any(np.shares_memory(x, y) for x in (a.data, a.indices, a.indptr)
                               for y in (b.data, b.indices, b.indptr))
    if entries:
        before = [m.toarray() for m in made]
        made[1].data[:] = 0.0
        made[1].eliminate_zeros()
        assert made[1].nnz == 0 and made[0].nnz == made[2].nnz == 2
        assert np.array_equal(made[0].toarray(), before[0]) and np.array_equal(made[2].toarray(), before[2])
        # the next matrix still has every stored entry (the one changed in place shared no structure)
        assert np.array_equal(s.matrix(np.ones(entries)).toarray(), [[0, 2, 0], [0, 0, 0], [0, 1, 0]])


def test_a_cards_kept_locations_follow_its_file_and_spans():
    from netdae.netlist.lines import Card

    card = Card("r1 a b 1k", "one.cir", [(0, 3, 1)])
    first = card.location(3)
    assert card.location(3) is first and (first.file, first.line, first.column) == ("one.cir", 3, 4)
    card.spans = [(0, 7, 2)]
    assert (card.location(3).line, card.location(3).column) == (7, 5)
    card.file = "two.cir"
    assert card.location(3).file == "two.cir"


def _same_sources(a, b) -> None:
    """Two systems' source vectors give the same values, made as made."""
    assert a.names == b.names and a.sources.names == b.sources.names and a.kinds.tolist() == b.kinds.tolist()
    for name in ("u0", "ac", "timed"):
        np.testing.assert_array_equal(getattr(a.sources, name), getattr(b.sources, name))
    for t in (0.0, 1.3e-3, 7.7e-3):
        for d in (0, 1):
            np.testing.assert_array_equal(a.sources.values(t, d), b.sources.values(t, d))
    np.testing.assert_array_equal(a.sources.breakpoints(0.0, 0.04), b.sources.breakpoints(0.0, 0.04))


def test_a_reassembled_row_shares_the_templates_waveforms_only_where_its_sources_are_the_same():
    text = BRIDGE.replace("SIN(0 12 50)", "SIN(0 {amp} 50)").replace(".param rl=1k", ".param amp=12 rl=1k")
    base = netdae.load(text)
    template = Template.of(base, assemble(base, **ARGS), **ARGS)
    same = netdae.load(text, params={"rl": 820.0})
    system = reassemble(template, same)
    assert system.sources.bank is template.system.sources.bank and system.sources is not template.system.sources
    _same_sources(system, assemble(same, **ARGS))
    moved = netdae.load(text, params={"amp": 10.0})  # the source's waveform differs: its own
    system = reassemble(template, moved)
    assert system is not None and system.sources.bank is not template.system.sources.bank
    _same_sources(system, assemble(moved, **ARGS))
    assert system.sources.values(5e-3)[0] != template.system.sources.values(5e-3)[0]


def test_a_reassembled_row_gets_its_sources_values_as_made_after_a_dc_sweep_set_the_templates():
    text = BRIDGE.replace("SIN(0 12 50)", "")
    base = netdae.load(text)
    dc = dict(mode="dc", tstep=None, tstop=None)
    template = Template.of(base, assemble(base, **dc), **dc)
    template.system.sources.set_value("v1", 3.0)  # a .dc sweep's point, in place
    other = netdae.load(text, params={"rl": 820.0})
    system = reassemble(template, other)
    assert system.sources.u0.tolist() == [12.0]
    _same_sources(system, assemble(other, **dc))
