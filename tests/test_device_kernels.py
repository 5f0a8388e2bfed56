"""The compiled device kernels against the numpy families and finite differences.

Each kernel (netdae.devices.kernels) must add exactly what its numpy family's
``evaluate`` adds through an Accumulator: charges, currents, both Jacobians,
the new limiting state and the flags, for every mode (no history, limiting
against a previous state, SPICE's initial junction state), on the example
netlists and on random model cards and random iterates. Where no limiting is
active the kernel's Jacobians must also match central differences of its own
q and phi.
"""

from __future__ import annotations

import re

from pathlib import Path

import numpy as np
import pytest

from netdae.devices.base import Accumulator, SlotMap
from netdae.devices.bjt import BjtFamily
from netdae.devices.companion import LimitState
from netdae.devices.diode import DiodeFamily
from netdae.devices.jfet import JfetFamily
from netdae.devices.kernels import FLAG_LIMITED, FLAG_NONFINITE, MODE_EVALUATE, MODE_INITIAL, MODE_LIMIT
from netdae.devices.mosfet import MosfetFamily
from netdae.devices.switch import SwitchFamily
from netdae.devices.vdmos import VdmosFamily
from netdae.mna import assemble
from netdae.netlist import load

NETLISTS = Path(__file__).resolve().parent.parent / "netlists"
EPS = np.finfo(float).eps
#: Agreement with the numpy family: a few ulps of each entry, or this fraction of the array's largest entry
#: (the two scatter the same terms in a different order).
ULPS = 8.0
SPREAD = 1e-14


# --- the two evaluations -------------------------------------------------------------

class Case:
    """A circuit's family, packed for its kernel, and both evaluations of it."""

    def __init__(self, text: str, family_cls, kernel, to_state):
        self.system = assemble(load(text))
        self.family = next(f for f in self.system.families if isinstance(f, family_cls))
        self.n = self.system.n
        self.nnz = self.system.pattern.nnz
        self.par, self.idx, self.vold0 = self.family.compiled(SlotMap(self.system.pattern), self.n)
        self.kernel = kernel
        self.to_state = to_state

    def extended(self, x):
        return np.append(np.asarray(x, dtype=float), 0.0)

    def numpy(self, xe, mode, vold, jacobian=True):
        acc = Accumulator(self.n, self.nnz)
        acc.reset(np.zeros(self.n), np.zeros(self.n), np.zeros(self.nnz), np.zeros(self.nnz))
        state = None if mode == MODE_EVALUATE else self.to_state(vold, mode == MODE_INITIAL)
        with np.errstate(all="ignore"):
            new = self.family.evaluate(xe, 0.0, acc, state, jacobian)
        return acc, new

    def compiled(self, xe, mode, vold, jacobian=True):
        q, phi = np.zeros(self.n + 1), np.zeros(self.n + 1)
        dq, dphi = np.zeros(self.nnz + 1), np.zeros(self.nnz + 1)
        vnew = np.full_like(vold, np.nan)
        flags, bad = self.kernel(xe, mode, self.par, self.idx, vold, vnew, q, phi, dq, dphi, jacobian)
        return q, phi, dq, dphi, vnew, flags, bad

    def compare(self, x, mode, vold, jacobian=True):
        """Assert the kernel equals the numpy family at ``x``; returns the kernel's flags."""
        xe = self.extended(x)
        acc, new = self.numpy(xe, mode, vold, jacobian)
        q, phi, dq, dphi, vnew, flags, bad = self.compiled(xe, mode, vold, jacobian)
        assert bool(flags & FLAG_LIMITED) == acc.limited
        assert bool(flags & FLAG_NONFINITE) == (not acc.ok)
        assert (bad >= 0) == (not acc.ok)
        if not acc.ok:
            return flags
        close(vnew, self.state_columns(new), "state")
        pairs = [(q[:-1], acc.q[:-1], "q"), (phi[:-1], acc.phi[:-1], "phi")]
        if jacobian:
            pairs += [(dq[:-1], acc.dq[:-1], "dq"), (dphi[:-1], acc.dphi[:-1], "dphi")]
        else:
            assert not dq.any() and not dphi.any()
        for got, want, name in pairs:
            close(got, want, name)
        return flags

    def state_columns(self, state):
        cols = state.v.T
        if state.extra is not None:
            cols = np.column_stack([cols, state.extra])
        return cols

    def jacobians_match_differences(self, x, rtol=2e-6):
        """The kernel's dq, dphi (mode 0) against central differences of its q, phi."""
        xe = self.extended(x)
        vold = self.vold0
        q, phi, dq, dphi, *_ = self.compiled(xe, MODE_EVALUATE, vold)
        pattern = self.system.pattern
        E = pattern.matrix(dq[:-1]).toarray()
        H = pattern.matrix(dphi[:-1]).toarray()
        fd_q, fd_phi = np.zeros_like(E), np.zeros_like(H)
        for j in range(self.n):
            step = 1e-7 * max(1.0, abs(x[j]))
            xp, xm = xe.copy(), xe.copy()
            xp[j] += step
            xm[j] -= step
            qp, pp, *_ = self.compiled(xp, MODE_EVALUATE, vold, False)
            qm, pm, *_ = self.compiled(xm, MODE_EVALUATE, vold, False)
            fd_q[:, j] = (qp[:-1] - qm[:-1]) / (2 * step)
            fd_phi[:, j] = (pp[:-1] - pm[:-1]) / (2 * step)
        np.testing.assert_allclose(H, fd_phi, rtol=rtol, atol=rtol * np.abs(H).max())
        np.testing.assert_allclose(E, fd_q, rtol=rtol, atol=rtol * max(np.abs(E).max(), 1e-30))


def close(got, want, name):
    """Equal within ULPS ulps of each entry or SPREAD of the largest entry."""
    got, want = np.asarray(got), np.asarray(want)
    assert got.shape == want.shape, name
    tol = ULPS * EPS * np.abs(want) + SPREAD * (np.abs(want).max() if want.size else 0.0)
    err = np.abs(got - want)
    worst = int(np.argmax(err - tol)) if err.size else 0
    assert np.all(err <= tol), f"{name}[{worst}]: kernel {got.flat[worst]!r}, numpy {want.flat[worst]!r}"


def netlists_with(letter: str, model: str | None = None, without: str | None = None) -> list[Path]:
    """Example netlists with at least one element card starting with ``letter`` (and a ``.model`` of
    type ``model``, or none of type ``without``); netlists whose cards run as compiled ports of ngspice's
    models (a ``level=`` other than 1: netdae.devices.osdi.spice_models) are not the families'."""
    out = []
    for path in sorted(NETLISTS.glob("*.cir")):
        lines = path.read_text().lower().splitlines()[1:]
        if any(re.search(r"\blevel\s*=\s*(?!1\b)\d", ln) for ln in lines if ln.startswith((".model", "+"))):
            continue
        cards = [ln for ln in lines if ln[:1] == letter.lower()]
        types = {ln.replace("(", " ").split()[2] for ln in lines if ln.startswith(".model") and len(ln.split()) > 2}
        if cards and (model is None or model in types) and (without is None or without not in types):
            out.append(path)
    return out


def exercise(case: Case, rng, x_scale, vold_scale, draws=6):
    """Every mode at random iterates (and the zero iterate of a solve from scratch)."""
    seen_limited = False
    nodes = case.n
    case.compare(np.zeros(nodes), MODE_INITIAL, case.vold0)
    case.compare(np.zeros(nodes), MODE_EVALUATE, case.vold0)
    for _ in range(draws):
        x = rng.uniform(-1.0, 1.0, nodes) * x_scale(rng, nodes)
        vold = rng.uniform(-1.0, 1.0, case.vold0.shape) * vold_scale(rng, case.vold0.shape)
        case.compare(x, MODE_EVALUATE, vold)
        case.compare(x, MODE_INITIAL, case.vold0)
        case.compare(x, MODE_EVALUATE, vold, jacobian=False)
        flags = case.compare(x, MODE_LIMIT, vold)
        seen_limited |= bool(flags & FLAG_LIMITED)
        case.compare(x, MODE_LIMIT, vold, jacobian=False)
    return seen_limited


def scales(*choices):
    return lambda rng, shape: rng.choice(np.asarray(choices, dtype=float), size=shape)


# --- diode ----------------------------------------------------------------------------------

def diode_state(vold, initial):
    return LimitState(vold.T.copy(), initial=initial)


def diode_case(text):
    from netdae.devices.kernels.diode import eval_diode
    return Case(text, DiodeFamily, eval_diode, diode_state)


def random_diodes(rng, count=6) -> str:
    """A netlist of ``count`` diodes with random model cards between five nodes and ground."""
    nodes = ["0", "n1", "n2", "n3", "n4", "n5"]
    lines = ["random diodes"]
    for k in range(count):
        a, c = rng.choice(nodes, size=2, replace=False)
        card = [f"is={10 ** rng.uniform(-16, -6):.6g}", f"n={rng.uniform(0.8, 2.0):.6g}"]
        if rng.random() < 0.5:
            card.append(f"rs={10 ** rng.uniform(-1, 2):.6g}")
        if rng.random() < 0.6:
            card += [f"cjo={10 ** rng.uniform(-13, -10):.6g}", f"vj={rng.uniform(0.4, 1.2):.6g}",
                     f"m={rng.uniform(0.2, 0.95):.6g}", f"fc={rng.uniform(0.1, 0.95):.6g}"]
        if rng.random() < 0.4:
            card.append(f"tt={10 ** rng.uniform(-12, -8):.6g}")
        if rng.random() < 0.5:
            card += [f"bv={rng.uniform(2, 60):.6g}", f"ibv={10 ** rng.uniform(-6, -2):.6g}"]
            if rng.random() < 0.5:
                card.append(f"nbv={rng.uniform(0.8, 3):.6g}")
        inst = f"D{k} {a} {c} dm{k} {rng.uniform(0.5, 3):.4g} m={rng.integers(1, 4)}"
        if rng.random() < 0.3:
            inst += f" temp={rng.uniform(-40, 125):.5g}"
        if rng.random() < 0.15:
            inst += " off"
        lines += [inst, f".model dm{k} d ({' '.join(card)})"]
    return "\n".join(lines + [".end", ""])


@pytest.mark.parametrize("path", netlists_with("D"), ids=lambda p: p.stem)
def test_diode_kernel_equals_the_family_on_the_netlists(path):
    case = diode_case(path.read_text())
    rng = np.random.default_rng(1)
    assert exercise(case, rng, scales(0.3, 1.0, 3.0, 30.0), scales(0.5, 1.0, 5.0))


@pytest.mark.parametrize("seed", range(12))
def test_diode_kernel_equals_the_family_on_random_cards(seed):
    rng = np.random.default_rng(seed)
    case = diode_case(random_diodes(rng))
    # forward, reverse, breakdown and overflowing iterates; old states near and far
    exercise(case, rng, scales(0.2, 0.8, 2.0, 20.0, 80.0, 400.0), scales(0.3, 0.8, 5.0, 60.0), draws=10)


@pytest.mark.parametrize("seed", range(4))
def test_diode_kernel_jacobians_match_differences(seed):
    rng = np.random.default_rng(100 + seed)
    case = diode_case(random_diodes(rng))
    for scale in (0.3, 0.7, 5.0, 50.0):
        x = rng.uniform(-1.0, 1.0, case.n) * scale
        xe = case.extended(x)
        *_, flags, _ = case.compiled(xe, MODE_EVALUATE, case.vold0)
        if flags & FLAG_NONFINITE:
            continue
        case.jacobians_match_differences(x)


def test_diode_kernel_in_each_region_with_private_nodes():
    # one diode per anode node, cathodes at ground: the junction voltages are set directly, in
    # forward bias, around the reverse knee, at and beyond the breakdown, from old states near and far
    rng = np.random.default_rng(7)
    count = 8
    lines = ["regions"]
    for k in range(count):
        lines += [f"D{k} a{k} 0 dm{k} m={1 + k % 2}",
                  f".model dm{k} d (is={10 ** rng.uniform(-15, -9):.4g} n={rng.uniform(1, 2):.4g} "
                  f"bv={rng.uniform(3, 40):.4g} ibv={10 ** rng.uniform(-5, -3):.4g} cjo=1p tt=1n"
                  + (" rs=2" if k % 3 == 0 else "") + ")"]
    case = diode_case("\n".join(lines + [".end", ""]))
    fam = case.family
    anodes = [case.system.node_index(f"a{k}") for k in range(count)]
    kinds = {"forward": lambda r: r.uniform(0.3, 1.5), "knee": lambda r: -3.0 * float(np.mean(fam.vte)) * r.uniform(0.5, 2),
             "reverse": lambda r: r.uniform(-2.0, -0.1)}
    breakdown_limited = 0
    for trial in range(40):
        x = np.zeros(case.n)
        vd = np.empty(count)
        for k in range(count):
            region = trial % 4
            if region == 3:  # breakdown: around -BV'
                vd[k] = -fam.bv[k] - rng.uniform(-0.5, 1.5)
            else:
                vd[k] = list(kinds.values())[region](rng)
        x[anodes] = vd
        for k in range(count):
            if fam.gs[k] > 0:
                x[case.system.node_index(f"d{k}#internal")] = vd[k]
        vold = (vd + rng.normal(0.0, 1.0, count) * rng.choice([0.01, 0.3, 3.0]))[:, None]
        flags = case.compare(x, MODE_LIMIT, vold)
        case.compare(x, MODE_EVALUATE, vold)
        if trial % 4 == 3 and flags & FLAG_LIMITED:
            breakdown_limited += 1
    assert breakdown_limited > 0


# --- BJT ------------------------------------------------------------------------------------

def bjt_case(text):
    from netdae.devices.kernels.bjt import eval_bjt
    return Case(text, BjtFamily, eval_bjt, diode_state)


def random_bjts(rng, count=6, irb=True) -> str:
    """``count`` NPN and PNP transistors with random Gummel-Poon cards between six nodes and ground.

    ``irb=False`` leaves out IRB, whose base-resistance formula (ngspice's) loses
    half the digits at small ``ib/IRB``: central differences of it are noise there.
    """
    nodes = ["0", "n1", "n2", "n3", "n4", "n5", "n6"]
    lines = ["random bjts"]

    def maybe(p, text):
        return [text] if rng.random() < p else []

    for k in range(count):
        terms = rng.choice(nodes, size=4, replace=False)
        card = [f"is={10 ** rng.uniform(-17, -12):.5g}", f"bf={rng.uniform(20, 300):.5g}",
                f"nf={rng.uniform(0.9, 1.3):.4g}", f"br={rng.uniform(0.5, 5):.4g}", f"nr={rng.uniform(0.9, 1.3):.4g}"]
        card += maybe(0.6, f"vaf={rng.uniform(10, 200):.5g}") + maybe(0.4, f"var={rng.uniform(5, 50):.5g}")
        card += maybe(0.5, f"ikf={10 ** rng.uniform(-4, -1):.5g}") + maybe(0.4, f"ikr={10 ** rng.uniform(-4, -1):.5g}")
        card += maybe(0.3, f"nkf={rng.uniform(0.3, 0.8):.4g}")
        card += maybe(0.5, f"ise={10 ** rng.uniform(-16, -12):.5g} ne={rng.uniform(1.2, 2.5):.4g}")
        card += maybe(0.5, f"isc={10 ** rng.uniform(-16, -12):.5g} nc={rng.uniform(1.2, 2.5):.4g}")
        if rng.random() < 0.6:
            card.append(f"rb={rng.uniform(10, 500):.5g}")
            card += maybe(0.6, f"rbm={rng.uniform(1, 10):.5g}") + maybe(0.5 if irb else 0.0, f"irb={10 ** rng.uniform(-5, -2):.5g}")
        card += maybe(0.5, f"re={rng.uniform(0.1, 5):.4g}") + maybe(0.5, f"rc={rng.uniform(1, 50):.4g}")
        card += maybe(0.6, f"cje={10 ** rng.uniform(-13, -11):.5g} vje={rng.uniform(0.5, 1.0):.4g} "
                           f"mje={rng.uniform(0.2, 0.5):.4g}")
        card += maybe(0.6, f"cjc={10 ** rng.uniform(-13, -11):.5g} vjc={rng.uniform(0.5, 1.0):.4g} "
                           f"mjc={rng.uniform(0.2, 0.5):.4g} xcjc={rng.uniform(0.3, 1.0):.4g}")
        card += maybe(0.4, f"cjs={10 ** rng.uniform(-13, -11):.5g} vjs={rng.uniform(0.5, 1.0):.4g} "
                           f"mjs={rng.uniform(0.0, 0.5):.4g}")
        card += maybe(0.5, f"tf={10 ** rng.uniform(-11, -9):.5g}") + maybe(0.4, f"tr={10 ** rng.uniform(-9, -7):.5g}")
        card += maybe(0.4, f"xtf={rng.uniform(0.5, 10):.4g} vtf={rng.uniform(1, 10):.4g}")
        card += maybe(0.4, f"itf={10 ** rng.uniform(-3, -1):.4g}")
        card += maybe(0.3, f"xtb={rng.uniform(0.5, 2):.4g}") + maybe(0.3, f"fc={rng.uniform(0.2, 0.9):.4g}")
        card += maybe(0.2, f"subs={rng.choice([-1, 1])}")
        kind = rng.choice(["npn", "pnp"])
        inst = f"Q{k} {' '.join(terms if rng.random() < 0.6 else terms[:3])} qm{k}"
        inst += f" {rng.uniform(0.5, 3):.4g}" if rng.random() < 0.5 else ""
        inst += f" areab={rng.uniform(0.5, 3):.4g}" if rng.random() < 0.3 else ""
        inst += f" areac={rng.uniform(0.5, 3):.4g}" if rng.random() < 0.3 else ""
        inst += f" m={rng.integers(1, 4)}" if rng.random() < 0.4 else ""
        inst += f" temp={rng.uniform(-40, 125):.5g}" if rng.random() < 0.3 else ""
        inst += " off" if rng.random() < 0.15 else ""
        lines += [inst, f".model qm{k} {kind} ({' '.join(card)})"]
    return "\n".join(lines + [".end", ""])


@pytest.mark.parametrize("path", netlists_with("Q"), ids=lambda p: p.stem)
def test_bjt_kernel_equals_the_family_on_the_netlists(path):
    case = bjt_case(path.read_text())
    rng = np.random.default_rng(2)
    assert exercise(case, rng, scales(0.3, 1.0, 3.0, 15.0), scales(0.3, 0.8, 5.0))


@pytest.mark.parametrize("seed", range(16))
def test_bjt_kernel_equals_the_family_on_random_cards(seed):
    rng = np.random.default_rng(1000 + seed)
    case = bjt_case(random_bjts(rng))
    # forward active, reverse, saturation (both junctions forward), cutoff, overflow
    exercise(case, rng, scales(0.3, 0.8, 1.0, 5.0, 40.0, 400.0), scales(0.2, 0.8, 5.0, 60.0), draws=10)


@pytest.mark.parametrize("seed", range(6))
def test_bjt_kernel_jacobians_match_differences(seed):
    rng = np.random.default_rng(2000 + seed)
    case = bjt_case(random_bjts(rng, irb=False))
    for scale in (0.3, 0.8, 3.0, 20.0):
        x = rng.uniform(-1.0, 1.0, case.n) * scale
        *_, flags, _ = case.compiled(case.extended(x), MODE_EVALUATE, case.vold0)
        if flags & FLAG_NONFINITE:
            continue
        case.jacobians_match_differences(x)


def test_bjt_base_resistance_derivative_matches_differences():
    # the IRB form of the base resistance where differences of it are well conditioned (ib/IRB from
    # 1e-3 to 1e3; below, tan(z) - z cancels and differences are noise)
    from netdae.devices.kernels import bjt as kb
    par = np.zeros((1, kb.N_PAR))
    par[0, kb.P_RB], par[0, kb.P_RBM], par[0, kb.P_IRB] = 200.0, 5.0, 1e-4
    for ratio in np.logspace(-3, 3, 13):
        ib = ratio * 1e-4
        gx, dgx, _ = kb.base_resistance(ib, 1.0, 0.0, 1.0, 0.0, 0.0, par, 0)
        step = 1e-4 * ib
        up = kb.base_resistance(ib + step, 1.0, 0.0, 1.0, 0.0, 0.0, par, 0)[0]
        down = kb.base_resistance(ib - step, 1.0, 0.0, 1.0, 0.0, 0.0, par, 0)[0]
        assert dgx == pytest.approx((up - down) / (2 * step), rel=1e-6)
        assert 1.0 / 200.0 < gx < 1.0 / 5.0


# --- MOSFET ---------------------------------------------------------------------------------

def mosfet_state(vold, initial):
    return LimitState(vold[:, :3].T.copy(), initial=initial, extra=vold[:, 3].copy())


def mosfet_case(text):
    from netdae.devices.kernels.mosfet import eval_mosfet
    return Case(text, MosfetFamily, eval_mosfet, mosfet_state)


def random_mosfets(rng, count=6) -> str:
    """``count`` NMOS and PMOS level-1 transistors with random cards between six nodes and ground."""
    nodes = ["0", "n1", "n2", "n3", "n4", "n5", "n6"]
    lines = ["random mosfets"]

    def maybe(p, text):
        return [text] if rng.random() < p else []

    for k in range(count):
        d, g, s, b = rng.choice(nodes, size=4, replace=rng.random() < 0.3)
        kind = rng.choice(["nmos", "pmos"])
        sign = 1 if kind == "nmos" else -1
        card = ["level=1"] + maybe(0.8, f"vto={sign * rng.uniform(-0.5, 1.5):.4g}")
        card += maybe(0.7, f"kp={10 ** rng.uniform(-5, -3):.4g}") + maybe(0.6, f"gamma={rng.uniform(0, 1):.4g}")
        card += maybe(0.5, f"phi={rng.uniform(0.4, 0.9):.4g}") + maybe(0.6, f"lambda={rng.uniform(0, 0.1):.4g}")
        card += maybe(0.3, f"rd={rng.uniform(1, 100):.4g}") + maybe(0.3, f"rs={rng.uniform(1, 100):.4g}")
        card += maybe(0.2, f"rsh={rng.uniform(1, 50):.4g}")
        card += maybe(0.3, f"cbd={10 ** rng.uniform(-15, -13):.4g}") + maybe(0.3, f"cbs={10 ** rng.uniform(-15, -13):.4g}")
        card += maybe(0.4, f"cj={10 ** rng.uniform(-4, -3):.4g} mj={rng.uniform(0.3, 0.6):.4g}")
        card += maybe(0.4, f"cjsw={10 ** rng.uniform(-10, -9):.4g} mjsw={rng.uniform(0.2, 0.5):.4g}")
        card += maybe(0.5, f"is={10 ** rng.uniform(-16, -12):.4g}") + maybe(0.3, f"js={10 ** rng.uniform(-5, -3):.4g}")
        card += maybe(0.4, f"pb={rng.uniform(0.5, 1.0):.4g} fc={rng.uniform(0.2, 0.9):.4g}")
        card += maybe(0.5, f"cgso={10 ** rng.uniform(-11, -9):.4g} cgdo={10 ** rng.uniform(-11, -9):.4g}")
        card += maybe(0.3, f"cgbo={10 ** rng.uniform(-11, -9):.4g}") + maybe(0.4, f"ld={rng.uniform(0, 0.1):.3g}u")
        if rng.random() < 0.5:
            card.append(f"tox={rng.uniform(5, 50):.4g}n")
            card += maybe(0.4, f"nsub={10 ** rng.uniform(15, 17):.4g}") + maybe(0.3, f"u0={rng.uniform(200, 700):.4g}")
        inst = f"M{k} {d} {g} {s} {b} mm{k} w={rng.uniform(1, 20):.3g}u l={rng.uniform(0.5, 5):.3g}u"
        inst += f" ad={rng.uniform(1, 20):.3g}p as={rng.uniform(1, 20):.3g}p" if rng.random() < 0.5 else ""
        inst += f" pd={rng.uniform(2, 20):.3g}u ps={rng.uniform(2, 20):.3g}u" if rng.random() < 0.5 else ""
        inst += f" m={rng.integers(1, 4)}" if rng.random() < 0.3 else ""
        inst += f" temp={rng.uniform(-40, 125):.5g}" if rng.random() < 0.3 else ""
        inst += " off" if rng.random() < 0.1 else ""
        inst += f" icvds={rng.uniform(-2, 2):.3g}" if rng.random() < 0.1 else ""
        lines += [inst, f".model mm{k} {kind} ({' '.join(card)})"]
    return "\n".join(lines + [".end", ""])


@pytest.mark.parametrize("path", netlists_with("M", without="vdmos"), ids=lambda p: p.stem)
def test_mosfet_kernel_equals_the_family_on_the_netlists(path):
    case = mosfet_case(path.read_text())
    rng = np.random.default_rng(3)
    assert exercise(case, rng, scales(0.3, 1.0, 3.0, 10.0), scales(0.3, 1.0, 5.0))


@pytest.mark.parametrize("seed", range(16))
def test_mosfet_kernel_equals_the_family_on_random_cards(seed):
    rng = np.random.default_rng(3000 + seed)
    case = mosfet_case(random_mosfets(rng))
    # cutoff, linear, saturation, reverse mode (vds < 0), forward bulk junctions, overflow
    exercise(case, rng, scales(0.2, 0.6, 1.0, 3.0, 10.0, 50.0), scales(0.2, 0.6, 3.0, 20.0), draws=10)


def test_mosfet_kernel_limits_quiet_and_moving_families():
    # from the state of a previous iterate, small moves (every control within 0.5 V: the family
    # skips fetlim/limvds) and large ones (fetlim and limvds act), in normal and reverse mode
    rng = np.random.default_rng(3100)
    case = mosfet_case(random_mosfets(rng, count=8))
    limited = {}
    for _ in range(30):
        x0 = rng.uniform(-3, 5, case.n)
        *_, vold, _, _ = case.compiled(case.extended(x0), MODE_EVALUATE, case.vold0)
        for step in (0.02, 0.1, 2.0, 8.0):
            flags = case.compare(x0 + rng.uniform(-step, step, case.n), MODE_LIMIT, vold)
            limited[step] = limited.get(step, 0) + bool(flags & FLAG_LIMITED)
    assert limited[8.0] > 0 and limited[0.02] < limited[8.0]


@pytest.mark.parametrize("seed", range(6))
def test_mosfet_kernel_jacobians_match_differences(seed):
    rng = np.random.default_rng(4000 + seed)
    case = mosfet_case(random_mosfets(rng))
    for scale in (0.5, 1.5, 4.0):
        x = rng.uniform(-1.0, 1.0, case.n) * scale
        *_, flags, _ = case.compiled(case.extended(x), MODE_EVALUATE, case.vold0)
        if flags & FLAG_NONFINITE:
            continue
        case.jacobians_match_differences(x)


# --- JFET -----------------------------------------------------------------------------------

def jfet_case(text):
    from netdae.devices.kernels.jfet import eval_jfet
    return Case(text, JfetFamily, eval_jfet, diode_state)


def random_jfets(rng, count=6) -> str:
    """``count`` N- and P-channel JFETs with random cards between five nodes and ground."""
    nodes = ["0", "n1", "n2", "n3", "n4", "n5"]
    lines = ["random jfets"]

    def maybe(p, text):
        return [text] if rng.random() < p else []

    for k in range(count):
        d, g, s = rng.choice(nodes, size=3, replace=rng.random() < 0.2)
        kind = rng.choice(["njf", "pjf"])
        card = maybe(0.8, f"vto={rng.uniform(-4, 0.5):.4g}") + maybe(0.7, f"beta={10 ** rng.uniform(-5, -2):.4g}")
        card += maybe(0.6, f"lambda={rng.uniform(0, 0.1):.4g}") + maybe(0.6, f"b={rng.uniform(0.3, 1.5):.4g}")
        card += maybe(0.4, f"rd={rng.uniform(1, 100):.4g}") + maybe(0.4, f"rs={rng.uniform(1, 100):.4g}")
        card += maybe(0.5, f"cgs={10 ** rng.uniform(-13, -11):.4g}") + maybe(0.5, f"cgd={10 ** rng.uniform(-13, -11):.4g}")
        card += maybe(0.5, f"is={10 ** rng.uniform(-16, -10):.4g}") + maybe(0.4, f"pb={rng.uniform(0.5, 1.2):.4g}")
        card += maybe(0.4, f"fc={rng.uniform(0.1, 0.99):.4g}")
        card += maybe(0.3, f"tcv={rng.uniform(-3e-3, 3e-3):.4g}") + maybe(0.2, f"vtotc={rng.uniform(-3e-3, 3e-3):.4g}")
        card += maybe(0.3, f"bex={rng.uniform(-2, 0):.4g}") + maybe(0.2, f"betatce={rng.uniform(-1, 0):.4g}")
        card += maybe(0.3, f"xti={rng.uniform(1, 4):.4g}") + maybe(0.2, f"tnom={rng.uniform(0, 60):.4g}")
        inst = f"J{k} {d} {g} {s} jm{k}"
        inst += f" {rng.uniform(0.5, 3):.4g}" if rng.random() < 0.5 else ""
        inst += f" m={rng.integers(1, 4)}" if rng.random() < 0.3 else ""
        inst += f" temp={rng.uniform(-40, 125):.5g}" if rng.random() < 0.3 else ""
        inst += " off" if rng.random() < 0.15 else ""
        lines += [inst, f".model jm{k} {kind} ({' '.join(card)})"]
    return "\n".join(lines + [".end", ""])


@pytest.mark.parametrize("path", netlists_with("J"), ids=lambda p: p.stem)
def test_jfet_kernel_equals_the_family_on_the_netlists(path):
    case = jfet_case(path.read_text())
    rng = np.random.default_rng(6)
    assert exercise(case, rng, scales(0.3, 1.0, 3.0, 15.0), scales(0.3, 1.0, 5.0))


@pytest.mark.parametrize("seed", range(12))
def test_jfet_kernel_equals_the_family_on_random_cards(seed):
    rng = np.random.default_rng(6000 + seed)
    case = jfet_case(random_jfets(rng))
    # cutoff, linear, saturation, both modes, forward gate junctions, fetlim and pnjlim steps, overflow
    exercise(case, rng, scales(0.2, 0.6, 1.0, 3.0, 10.0, 50.0), scales(0.2, 0.6, 3.0, 20.0), draws=10)


def test_jfet_kernel_limits_small_and_large_steps():
    rng = np.random.default_rng(6100)
    case = jfet_case(random_jfets(rng, count=8))
    limited = {}
    for _ in range(30):
        x0 = rng.uniform(-4, 4, case.n)
        *_, vold, _, _ = case.compiled(case.extended(x0), MODE_EVALUATE, case.vold0)
        for step in (0.01, 0.2, 3.0, 12.0):
            flags = case.compare(x0 + rng.uniform(-step, step, case.n), MODE_LIMIT, vold)
            limited[step] = limited.get(step, 0) + bool(flags & FLAG_LIMITED)
    assert limited[12.0] > 0 and limited[0.01] < limited[12.0]


@pytest.mark.parametrize("seed", range(6))
def test_jfet_kernel_jacobians_match_differences(seed):
    rng = np.random.default_rng(6200 + seed)
    case = jfet_case(random_jfets(rng))
    for scale in (0.3, 1.5, 5.0):
        x = rng.uniform(-1.0, 1.0, case.n) * scale
        *_, flags, _ = case.compiled(case.extended(x), MODE_EVALUATE, case.vold0)
        if flags & FLAG_NONFINITE:
            continue
        case.jacobians_match_differences(x)


# --- VDMOS ----------------------------------------------------------------------------------

def vdmos_case(text):
    from netdae.devices.kernels.vdmos import eval_vdmos
    return Case(text, VdmosFamily, eval_vdmos, diode_state)


def random_vdmos(rng, count=6) -> str:
    """``count`` n- and p-channel VDMOS with random cards between five nodes and ground."""
    nodes = ["0", "n1", "n2", "n3", "n4", "n5"]
    lines = ["random vdmos"]

    def maybe(p, text):
        return [text] if rng.random() < p else []

    for k in range(count):
        d, g, s = rng.choice(nodes, size=3, replace=rng.random() < 0.2)
        card = maybe(0.4, "pchan") + maybe(0.8, f"vto={rng.uniform(-1, 4):.4g}")
        card += maybe(0.8, f"kp={10 ** rng.uniform(-2, 1.5):.4g}") + maybe(0.6, f"lambda={rng.uniform(0, 0.05):.4g}")
        card += maybe(0.3, f"theta={rng.uniform(0, 0.2):.4g}") + maybe(0.4, f"mtriode={rng.uniform(0.5, 2):.4g}")
        card += maybe(0.5, f"ksubthres={rng.uniform(0.02, 0.3):.4g}") + maybe(0.3, f"subshift={rng.uniform(-0.3, 0.3):.4g}")
        card += maybe(0.5, f"rd={10 ** rng.uniform(-3, 0):.4g}") + maybe(0.5, f"rs={10 ** rng.uniform(-3, 0):.4g}")
        card += maybe(0.4, f"rg={rng.uniform(0.5, 10):.4g}") + maybe(0.3, f"rb={10 ** rng.uniform(-3, 0):.4g}")
        card += maybe(0.4, f"rq={rng.uniform(0.01, 1):.4g} vq={rng.uniform(0.5, 5):.4g}")
        card += maybe(0.3, f"rds={10 ** rng.uniform(3, 7):.4g}")
        card += maybe(0.6, f"cgdmax={10 ** rng.uniform(-10, -8.5):.4g} cgdmin={10 ** rng.uniform(-12, -10.5):.4g}")
        card += maybe(0.5, f"a={rng.uniform(0.1, 1):.4g}") + maybe(0.6, f"cgs={10 ** rng.uniform(-10, -8):.4g}")
        card += maybe(0.6, f"cjo={10 ** rng.uniform(-11, -9):.4g}") + maybe(0.4, f"vj={rng.uniform(0.5, 1.2):.4g}")
        card += maybe(0.4, f"m={rng.uniform(0.2, 0.9):.4g}") + maybe(0.4, f"fc={rng.uniform(0.1, 0.99):.4g}")
        card += maybe(0.5, f"is={10 ** rng.uniform(-14, -9):.4g}") + maybe(0.4, f"n={rng.uniform(1, 1.8):.4g}")
        card += maybe(0.4, f"tt={10 ** rng.uniform(-9, -7):.4g}")
        card += maybe(0.4, f"bv={rng.uniform(3, 60):.4g} ibv={10 ** rng.uniform(-6, -3):.4g}")
        card += maybe(0.2, f"nbv={rng.uniform(1, 3):.4g}")
        card += maybe(0.3, f"tcvth={rng.uniform(-5e-3, 5e-3):.4g}") + maybe(0.3, f"mu={rng.uniform(-2, 0):.4g}")
        card += maybe(0.2, f"texp0={rng.uniform(0.5, 2):.4g}") + maybe(0.2, f"trs1={rng.uniform(0, 5e-3):.4g}")
        card += maybe(0.2, f"tksubthres1={rng.uniform(0, 5e-3):.4g}") + maybe(0.2, f"tnom={rng.uniform(0, 60):.4g}")
        inst = f"M{k} {d} {g} {s} vm{k}"
        inst += f" m={rng.integers(1, 4)}" if rng.random() < 0.3 else ""
        inst += f" temp={rng.uniform(-40, 125):.5g}" if rng.random() < 0.3 else ""
        inst += " off" if rng.random() < 0.15 else ""
        inst += f" ic={rng.uniform(-5, 5):.3g},{rng.uniform(-5, 5):.3g}" if rng.random() < 0.15 else ""
        lines += [inst, f".model vm{k} vdmos ({' '.join(card)})"]
    return "\n".join(lines + [".end", ""])


@pytest.mark.parametrize("path", netlists_with("M", model="vdmos"), ids=lambda p: p.stem)
def test_vdmos_kernel_equals_the_family_on_the_netlists(path):
    case = vdmos_case(path.read_text())
    rng = np.random.default_rng(7)
    assert exercise(case, rng, scales(0.3, 1.0, 3.0, 15.0), scales(0.3, 1.0, 5.0))


@pytest.mark.parametrize("seed", range(12))
def test_vdmos_kernel_equals_the_family_on_random_cards(seed):
    rng = np.random.default_rng(7000 + seed)
    case = vdmos_case(random_vdmos(rng))
    # subthreshold, triode, saturation, both modes, the body diode forward and in breakdown, overflow
    exercise(case, rng, scales(0.2, 0.6, 1.0, 3.0, 10.0, 50.0), scales(0.2, 0.6, 3.0, 20.0), draws=10)


def test_vdmos_kernel_limits_small_and_large_steps():
    rng = np.random.default_rng(7100)
    case = vdmos_case(random_vdmos(rng, count=8))
    limited = {}
    for _ in range(30):
        x0 = rng.uniform(-4, 6, case.n)
        *_, vold, _, _ = case.compiled(case.extended(x0), MODE_EVALUATE, case.vold0)
        for step in (0.01, 0.2, 3.0, 12.0):
            flags = case.compare(x0 + rng.uniform(-step, step, case.n), MODE_LIMIT, vold)
            limited[step] = limited.get(step, 0) + bool(flags & FLAG_LIMITED)
    assert limited[12.0] > 0 and limited[0.01] < limited[12.0]


@pytest.mark.parametrize("seed", range(6))
def test_vdmos_kernel_jacobians_match_differences(seed):
    rng = np.random.default_rng(7200 + seed)
    case = vdmos_case(random_vdmos(rng))
    for scale in (0.3, 1.5, 5.0):
        x = rng.uniform(-1.0, 1.0, case.n) * scale
        *_, flags, _ = case.compiled(case.extended(x), MODE_EVALUATE, case.vold0)
        if flags & FLAG_NONFINITE:
            continue
        case.jacobians_match_differences(x)


# --- switch ---------------------------------------------------------------------------------

def switch_state(vold, initial):
    return LimitState(vold.T.copy(), initial=initial)


def switch_case(text):
    from netdae.devices.kernels.switch import eval_switch
    return Case(text, SwitchFamily, eval_switch, switch_state)


def random_switches(rng, count=8) -> str:
    """``count`` S and W switches with random models and flags between five nodes and ground.

    The W switches sense the currents of three 0 V sources; thresholds and hysteresis
    (positive, zero, negative) within +-1, where the random iterates put the controls.
    """
    nodes = ["0", "n1", "n2", "n3", "n4", "n5"]
    lines = ["random switches", "VA n1 n6 0", "VB n2 n7 0", "VC n3 0 0", "RA n6 0 1", "RB n7 0 1"]
    for k in range(count):
        vt = rng.uniform(-0.8, 0.8)
        vh = rng.choice([0.0, rng.uniform(0.05, 0.4), -rng.uniform(0.05, 0.4)])
        card = [f"ron={10 ** rng.uniform(-2, 2):.5g}"]
        if rng.random() < 0.7:
            card.append(f"roff={10 ** rng.uniform(4, 12):.5g}")
        flag = rng.choice(["", " on", " off"])
        a, b = rng.choice(nodes, size=2, replace=False)
        if rng.random() < 0.5:
            cp, cm = rng.choice(nodes, size=2, replace=False)
            lines += [f"S{k} {a} {b} {cp} {cm} sm{k}{flag}", f".model sm{k} sw vt={vt:.5g} vh={vh:.5g} {' '.join(card)}"]
        else:
            ctl = rng.choice(["va", "vb", "vc"])
            lines += [f"W{k} {a} {b} {ctl} wm{k}{flag}", f".model wm{k} csw it={vt:.5g} ih={vh:.5g} {' '.join(card)}"]
    return "\n".join(lines + [".end", ""])


def switch_states(rng, count, hold):
    """Random switch states (ngspice's four) with the hold flags ``hold`` (0, 1, or None: random)."""
    flags = rng.integers(0, 2, count) if hold is None else np.full(count, hold)
    return np.column_stack([rng.integers(0, 4, count).astype(float), flags.astype(float)])


@pytest.mark.parametrize("seed", range(8))
def test_switch_kernel_equals_the_family_on_random_cards(seed):
    rng = np.random.default_rng(5000 + seed)
    case = switch_case(random_switches(rng))
    count = case.vold0.shape[0]
    case.compare(np.zeros(case.n), MODE_INITIAL, case.vold0)
    case.compare(np.zeros(case.n), MODE_EVALUATE, case.vold0)
    limited = 0
    for _ in range(12):
        x = rng.uniform(-1.0, 1.0, case.n) * rng.choice([0.3, 1.0, 3.0])
        # without history the numpy family has no held state (hold 0); with a state, any mix
        case.compare(x, MODE_EVALUATE, switch_states(rng, count, 0))
        case.compare(x, MODE_INITIAL, switch_states(rng, count, None))
        flags = case.compare(x, MODE_LIMIT, switch_states(rng, count, None))
        limited += bool(flags & FLAG_LIMITED)
        case.compare(x, MODE_LIMIT, switch_states(rng, count, None), jacobian=False)
    assert limited > 0


def test_switch_kernel_holds_what_the_family_holds():
    # a transient's held states (SwitchFamily.held) are the kernel's vold with the hold flag, in every mode
    rng = np.random.default_rng(5100)
    case = switch_case(random_switches(rng, count=10))
    count = case.vold0.shape[0]
    for _ in range(6):
        x = rng.uniform(-2.0, 2.0, case.n)
        held = switch_states(rng, count, 1)
        case.family.held = held[:, 0].copy()
        try:
            for mode in (MODE_EVALUATE, MODE_LIMIT, MODE_INITIAL):
                xe = case.extended(x)
                acc, new = case.numpy(xe, mode, switch_states(rng, count, 0))
                q, phi, dq, dphi, vnew, flags, bad = case.compiled(xe, mode, held)
                np.testing.assert_array_equal(vnew, new.v.T)
                close(phi[:-1], acc.phi[:-1], "phi")
                close(dphi[:-1], acc.dphi[:-1], "dphi")
                assert flags == 0 and not acc.limited
        finally:
            case.family.held = None


def test_switch_decisions_equal_the_familys():
    from netdae.devices import switch as sw
    from netdae.devices.kernels import switch as ks

    rng = np.random.default_rng(5200)
    case = switch_case(random_switches(rng, count=12))
    fam = case.family
    count = case.vold0.shape[0]
    for _ in range(20):
        xe = case.extended(rng.uniform(-1.5, 1.5, case.n))
        old = switch_states(rng, count, 1)
        new = np.zeros_like(old)
        changes = ks.switch_decide(xe, case.par, case.idx, old, new)
        want = sw.decide(fam.control(xe), old[:, 0], fam.vt, fam.vh)
        np.testing.assert_array_equal(new[:, 0], want)
        assert changes == int(np.sum(sw.conducting(want) != sw.conducting(old[:, 0])))
        # the operating point's decision without history, as the family's
        for k in range(count):
            assert ks.dc_state(float(fam.control(xe)[k]), -1.0, case.par, k) == fam.dc_state(fam.control(xe), None)[k]


def test_switch_thresholds_and_the_states_past_them():
    # watch() gives the threshold a state's conductance changes at, switched() the state just past it,
    # which decide() confirms just beyond the threshold and contradicts just before it
    from netdae.devices.kernels import switch as ks

    for vh in (0.3, 0.0, -0.3):
        for s in (ks.REALLY_OFF, ks.REALLY_ON, ks.HYST_OFF, ks.HYST_ON):
            theta, direction = ks.watch(s, 0.5, vh)
            past = ks.switched(s, vh)
            assert ks.conducting(past) != ks.conducting(s)
            beyond = ks.decide(theta + direction * 1e-9, s, 0.5, vh)
            assert ks.conducting(beyond) == ks.conducting(past)
            if vh != 0.0:  # (with VH = 0 the band is one point: just beyond it the state is REALLY_*)
                assert beyond == past
            assert ks.conducting(ks.decide(theta - direction * 1e-9, s, 0.5, vh)) == ks.conducting(s)


@pytest.mark.parametrize("seed", range(3))
def test_switch_kernel_jacobians_match_differences(seed):
    rng = np.random.default_rng(5300 + seed)
    case = switch_case(random_switches(rng))
    for scale in (0.5, 2.0):
        case.jacobians_match_differences(rng.uniform(-1.0, 1.0, case.n) * scale)
