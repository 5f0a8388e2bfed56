"""Benchmark circuits: netlist generators with their sizes and reference solutions.

Every generator returns a :class:`Bench`: the netlist text both simulators
run (the same text; only netdae's ideal op-amp extension is translated for
ngspice), the signals compared (``.save``d on both sides, so memory reflects
what a user asks for), the expected sizes, and the reference the accuracy is
measured against:

- linear circuits have closed forms: the modal solution of the MNA equations
  for a piecewise-linear input (:mod:`benchmarks.exact`), with analytic
  eigenvectors for the uniform RC ladder and the RC mesh and a dense
  eigendecomposition for the RLC line; the differentiator's output is
  ``-(L/R) V'(t)``;
- nonlinear circuits have none: their reference is ngspice at reltol 1e-8
  (``REFERENCE_RELTOL``; netdae at that tolerance does not finish every
  circuit yet). The runner also runs netdae at reltol 1e-8 where it can and
  reports how far it lies from ngspice's reference (model differences), and
  measures each simulator against its own tight run ("self" error: the
  integration error alone).

Sizes are chosen so that the time scales do not change with the number of
sections (the totals R, C, L are fixed and divided among the sections): a
larger circuit is a finer discretisation of the same physics, so the work
per unit of simulated time grows only through the stiffness and the size.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from . import exact

__all__ = [
    "Bench",
    "Pulse",
    "rc_ladder",
    "rc_mesh",
    "rlc_line",
    "differentiator",
    "bridge_rectifier",
    "voltage_multiplier",
    "pulse_train",
    "ring_oscillator",
    "GENERATORS",
    "REFERENCE_RELTOL",
    "TIGHT_RELTOL",
]

ROOT = Path(__file__).resolve().parent.parent
#: Tolerance of netdae's own reference run for circuits without a closed form.
REFERENCE_RELTOL = 1e-8
#: The "tight" variant of every benchmark sets this reltol on both sides.
TIGHT_RELTOL = 1e-6
#: Gain of the VCVS standing for the ideal op-amp in ngspice (default, tight):
#: 1e6 keeps the model error 1e-6 of the noise gain, 1e9 for the tight runs
#: (``netdae.ngspice.translate.OPAMP_GAIN``).
OPAMP_GAINS = (1e6, 1e9)

Reference = Callable[[np.ndarray], dict[str, np.ndarray]]


def num(x: float) -> str:
    """A float written so that both readers get the same double back."""
    return repr(float(x))


@dataclass(frozen=True)
class Pulse:
    """``PULSE(v1 v2 td tr tf pw per)`` with its corners as a piecewise-linear function."""

    v1: float
    v2: float
    td: float
    tr: float
    tf: float
    pw: float
    per: float

    def card(self) -> str:
        return "PULSE(" + " ".join(num(v) for v in (self.v1, self.v2, self.td, self.tr, self.tf, self.pw,
                                                      self.per)) + ")"

    def knots(self, tstop: float) -> tuple[np.ndarray, np.ndarray]:
        """Times and values of the corners in [0, tstop] (value v1 before td)."""
        ts, vs = [0.0], [self.v1]
        k = 0
        while self.td + k * self.per <= tstop:
            base = self.td + k * self.per
            for dt, v in ((0.0, self.v1), (self.tr, self.v2), (self.tr + self.pw, self.v2),
                          (self.tr + self.pw + self.tf, self.v1)):
                ts.append(base + dt)
                vs.append(v)
            k += 1
        t = np.array(ts)
        v = np.array(vs)
        keep = np.concatenate([[True], np.diff(t) > 0])
        return t[keep], v[keep]


@dataclass
class Bench:
    """One benchmark circuit.

    Attributes
    ----------
    name : str
        Unique name, e.g. ``rc_ladder_10000``.
    family : str
        Generator name (``rc_ladder``).
    category : str
        Which target applies: ``linear`` (large linear), ``mesh``,
        ``many-steps`` (small circuit, many steps), ``nonlinear``.
    text : str
        Netlist text netdae runs (without tolerance options).
    signals : tuple of str
        Saved signals (``v(n1)``), on both sides.
    unknowns : int
        Number of MNA unknowns netdae assembles.
    elements : int
        Number of circuit elements.
    tstop : float
    reference : callable or None
        ``reference(t) -> {signal: values}`` (closed form), or None when the
        reference is ngspice at :data:`REFERENCE_RELTOL`.
    reference_kind : str
        What the reference is, for the report.
    t_skip : float
        Errors are measured for ``t >= t_skip`` (after a start-up transient
        that one simulator resolves by design and the other not).
    ngspice_translate : bool
        The netlist uses netdae's ideal op-amp (translated to a VCVS for ngspice).
    notes : list of str
    compare : tuple of str, optional
        Compared signals (default ``signals``); ``v(a,b)`` is the difference
        of the saved ``v(a)`` and ``v(b)``.
    """

    name: str
    family: str
    category: str
    text: str
    signals: tuple[str, ...]
    unknowns: int
    elements: int
    tstop: float
    reference: Reference | None
    reference_kind: str
    t_skip: float = 0.0
    ngspice_translate: bool = False
    notes: list[str] = field(default_factory=list)
    compare: tuple[str, ...] | None = None

    @property
    def compared(self) -> tuple[str, ...]:
        """The signals whose errors are measured."""
        return self.compare or self.signals

    def netlist(self, tight: bool, simulator: str) -> str:
        """The netlist of a variant for ``simulator`` ("netdae" or "ngspice").

        The tight variant adds ``.options reltol=TIGHT_RELTOL``; ngspice's copy
        gets ``.options acct`` (its step and iteration counts; netdae ignores
        the option) and, where needed, the op-amp translation.
        """
        lines = self.text.rstrip().splitlines()
        assert lines[-1].strip().lower() == ".end"
        extra = []
        if tight:
            extra.append(f".options reltol={num(TIGHT_RELTOL)}")
        if simulator == "ngspice":
            extra.append(".options acct")
        text = "\n".join(lines[:-1] + extra + [".end"]) + "\n"
        if simulator == "ngspice" and self.ngspice_translate:
            from netdae.ngspice.translate import translate_for_ngspice

            text, _ = translate_for_ngspice(text, opamp_gain=OPAMP_GAINS[1 if tight else 0])
        return text


def signal_values(saved: dict, name: str) -> np.ndarray:
    """A compared signal from the saved ones: ``v(a,b) = v(a) - v(b)``."""
    if name in saved:
        return saved[name]
    a, b = name[2:-1].split(",")
    return saved[f"v({a})"] - saved[f"v({b})"]


def _save_line(signals) -> str:
    return ".save " + " ".join(signals)


# ---------------------------------------------------------------------------------- RC ladder
def rc_ladder(n: int, *, r_total: float = 1e3, c_total: float = 1e-9, tstop: float = 10e-6,
              pulse: Pulse | None = None, tstep: float | None = None, tmax: float | None = None,
              name: str | None = None, category: str = "linear") -> Bench:
    """A uniform RC ladder of ``n`` sections driven by a PULSE voltage source.

    ``V1 in 0 PULSE``; section k: ``Rk n(k-1) nk`` and ``Ck nk 0`` with
    ``n0 = in``; the far end is open. Totals ``r_total``, ``c_total`` are
    split evenly, so the line's diffusion time ``r_total * c_total`` (1 us)
    does not depend on ``n``.

    Unknowns: ``n + 1`` node voltages and ``i(v1)``. Reference: the exact
    modal solution (:func:`benchmarks.exact.ladder_modes`).
    """
    pulse = pulse or Pulse(0.0, 1.0, 0.1e-6, 50e-9, 50e-9, 1.9e-6, 4e-6)
    r, c = r_total / n, c_total / n
    tstep = tstep if tstep is not None else tstop / 200
    probes = sorted({1, max(n // 2, 1), n})
    signals = tuple(f"v(n{k})" for k in probes)
    lines = [f"RC ladder, {n} sections (R total {num(r_total)}, C total {num(c_total)})",
             f"V1 n0 0 {pulse.card()}"]
    rs, cs = num(r), num(c)
    lines += [f"R{k} n{k - 1} n{k} {rs}\nC{k} n{k} 0 {cs}" for k in range(1, n + 1)]
    lines.append(_save_line(signals))
    tran = f".tran {num(tstep)} {num(tstop)}" + (f" 0 {num(tmax)}" if tmax is not None else "")
    lines += [tran, ".end"]
    modes = exact.ladder_modes(n, r, c, np.array(probes))
    t_knots, u_knots = pulse.knots(tstop)

    def reference(t):
        y = exact.modal_pwl_response(modes.mu, modes.gain, modes.weights, t_knots, u_knots, t)
        return dict(zip(signals, y))

    return Bench(
        name=name or f"rc_ladder_{n}", family="rc_ladder", category=category, text="\n".join(lines) + "\n",
        signals=signals, unknowns=n + 2, elements=2 * n + 1, tstop=tstop, reference=reference,
        reference_kind="closed form (modal solution)",
    )


# ---------------------------------------------------------------------------------- RC mesh
def rc_mesh(n: int, *, r: float = 100.0, c_total: float = 10e-9, r_leak_total: float = 10e3,
            tstop: float = 10e-6, amplitude: float = 1e-3) -> Bench:
    """An ``n x n`` RC mesh: resistors between neighbours, C and a leak to ground at every node.

    A PULSE current source feeds the corner node ``n0_0``. The node
    capacitance ``c_total / n^2`` and leak ``r_leak_total * n^2`` keep the
    diffusion time ``r * c_total`` (1 us) independent of ``n``. Uniform
    leaks keep the equations separable: the reference is the exact modal
    solution with the eigenvectors of the 2-D Neumann Laplacian
    (:func:`benchmarks.exact.mesh_modes`).

    Unknowns: ``n^2`` node voltages. Elements: ``2 n (n - 1)`` resistors,
    ``n^2`` capacitors, ``n^2`` leaks, one source.
    """
    pulse = Pulse(0.0, amplitude, 0.1e-6, 50e-9, 50e-9, 1.9e-6, 4e-6)
    c = c_total / n**2
    r_leak = r_leak_total * n**2
    probes = [(0, 0), (n // 2, n // 2), (n - 1, n - 1)]
    signals = tuple(dict.fromkeys(f"v(n{i}_{j})" for i, j in probes))
    rs, cs, rl = num(r), num(c), num(r_leak)
    lines = [f"RC mesh {n}x{n} (R {rs} between neighbours, C total {num(c_total)}, leak total "
             f"{num(r_leak_total)})", f"I1 0 n0_0 {pulse.card()}"]
    for i in range(n):
        for j in range(n):
            node = f"n{i}_{j}"
            if j + 1 < n:
                lines.append(f"RH{i}_{j} {node} n{i}_{j + 1} {rs}")
            if i + 1 < n:
                lines.append(f"RV{i}_{j} {node} n{i + 1}_{j} {rs}")
            lines.append(f"C{i}_{j} {node} 0 {cs}")
            lines.append(f"RG{i}_{j} {node} 0 {rl}")
    lines += [_save_line(signals), f".tran {num(tstop / 200)} {num(tstop)}", ".end"]
    modes = exact.mesh_modes(n, r, c, r_leak, probes)
    t_knots, u_knots = pulse.knots(tstop)
    keys = [f"v(n{i}_{j})" for i, j in probes]

    def reference(t):
        y = exact.modal_pwl_response(modes.mu, modes.gain, modes.weights, t_knots, u_knots, t)
        return dict(zip(keys, y))

    return Bench(
        name=f"rc_mesh_{n}x{n}", family="rc_mesh", category="mesh", text="\n".join(lines) + "\n",
        signals=signals, unknowns=n * n, elements=2 * n * (n - 1) + 2 * n * n + 1, tstop=tstop,
        reference=reference, reference_kind="closed form (modal solution)",
    )


# ---------------------------------------------------------------------------------- RLC line
def rlc_line(n: int, *, l_total: float = 250e-9, c_total: float = 100e-12, r_total: float = 10.0,
             r_source: float = 50.0, r_load: float = 1e3, tstop: float = 60e-9) -> Bench:
    """A lossy transmission line as ``n`` RLC sections, mismatched at the load (ringing).

    ``V1 in 0 PULSE``, ``RS in a0``; section k: ``RKk a(k-1) mk``,
    ``LKk mk ak``, ``CKk ak 0``; load ``RL an 0``. Characteristic impedance
    ``sqrt(l_total / c_total)`` = 50 Ohm, delay 5 ns; the 1 kOhm load reflects.
    Index 1 (every inductor current is a state, no CV-loop, no LI-cutset).

    Reference: the exact modal solution of the state equations (inductor
    currents, capacitor voltages) by a dense eigendecomposition.
    """
    pulse = Pulse(0.0, 1.0, 1e-9, 0.5e-9, 0.5e-9, 10e-9, 40e-9)
    lk, ck, rk = l_total / n, c_total / n, r_total / n
    probes = sorted({max(n // 2, 1), n})
    signals = tuple(f"v(a{k})" for k in probes)
    lines = [f"RLC line, {n} sections (L total {num(l_total)}, C total {num(c_total)}, R total {num(r_total)})",
             f"V1 in 0 {pulse.card()}", f"RS in a0 {num(r_source)}"]
    for k in range(1, n + 1):
        lines += [f"RK{k} a{k - 1} m{k} {num(rk)}", f"LK{k} m{k} a{k} {num(lk)}", f"CK{k} a{k} 0 {num(ck)}"]
    lines += [f"RL a{n} 0 {num(r_load)}", _save_line(signals), f".tran {num(tstop / 600)} {num(tstop)}", ".end"]
    model = exact.line_modes(n, rk, lk, ck, r_source, r_load, probes)
    t_knots, u_knots = pulse.knots(tstop)

    def reference(t):
        y = exact.modal_pwl_response(model.mu, model.gain, model.weights, t_knots, u_knots, t)
        return dict(zip(signals, y.real))

    return Bench(
        name=f"rlc_line_{n}", family="rlc_line", category="linear", text="\n".join(lines) + "\n",
        signals=signals, unknowns=(2 * n + 2) + (n + 1), elements=3 * n + 3, tstop=tstop, reference=reference,
        reference_kind="closed form (modal solution, dense eigendecomposition)",
    )


# ---------------------------------------------------------------------------------- differentiator
def differentiator() -> Bench:
    """``netlists/differentiator.cir`` (ideal op-amp, index 2), saving v(out).

    Reference: ``v(out) = -(L1/R1) V1'(t)`` with ``V1 = sin(2 pi 1k t)``.
    ngspice runs the op-amp as a VCVS of gain 1e6 (1e9 in the tight
    variant) and starts from the inconsistent operating point v(out) = 0;
    errors are measured after the first 1 % of the interval, where both
    have left the start behind.
    """
    text = (ROOT / "netlists" / "differentiator.cir").read_text()
    lines = [ln for ln in text.rstrip().splitlines() if ln.strip().lower() != ".end"]
    lines += [".save v(out)", ".end"]
    r1, l1, f = 100.0, 10e-3, 1e3

    def reference(t):
        return {"v(out)": -(l1 / r1) * 2 * math.pi * f * np.cos(2 * math.pi * f * np.asarray(t))}

    return Bench(
        name="differentiator", family="differentiator", category="many-steps", text="\n".join(lines) + "\n",
        signals=("v(out)",), unknowns=6, elements=4, tstop=3e-3, reference=reference,
        reference_kind="closed form -(L/R) V'(t)", t_skip=3e-5, ngspice_translate=True,
        notes=["ngspice: ideal op-amp as a VCVS (gain 1e6, 1e9 when tight); errors after t = 30 us"],
    )


# ---------------------------------------------------------------------------------- diodes
_D1N4007 = (".model d1n4007 d (is=7.02767n rs=0.0341512 n=1.80803 eg=1.05743 xti=5 bv=1000 ibv=0.1 "
            "cjo=10p vj=0.7 m=0.5 fc=0.5 tt=100n)")
_D1N4148 = ".model d1n4148 d (is=2.52n rs=0.568 n=1.752 cjo=4p m=0.4 vj=0.75 tt=20n bv=100 ibv=100u)"


def bridge_rectifier(cycles: int, *, category: str = "nonlinear") -> Bench:
    """``netlists/bridge_rectifier.cir`` over ``cycles`` mains periods (50 Hz, tstep 50 us).

    ``category="long"`` marks the long run whose target is the whole process
    (start-up included) rather than the transient alone.

    Compared: the output ``v(pos,neg)`` and the bridge input ``v(acs)``. The
    output floats: its common-mode voltage is set only by the diodes'
    reverse currents while all four are off (a mode with a time constant of
    seconds), so ``v(pos)`` and ``v(neg)`` alone are ill-determined in both
    simulators (they differ by volts between tolerances) while their
    difference is not.
    """
    tstop = cycles / 50.0
    signals = ("v(pos)", "v(neg)", "v(acs)")
    lines = [f"Full-wave bridge rectifier, {cycles} mains cycles",
             "V1 ac 0 DC 12 SIN(0 12 50)", "RS ac acs 1",
             "D1 acs pos d1n4007", "D2 0 pos d1n4007", "D3 neg acs d1n4007", "D4 neg 0 d1n4007",
             "C1 pos neg 470u", "RL pos neg 1k", _D1N4007, _save_line(signals),
             f".tran 50u {num(tstop)}", ".end"]
    return Bench(
        name=f"bridge_{cycles}cyc", family="bridge_rectifier", category=category,
        text="\n".join(lines) + "\n", signals=signals, unknowns=9, elements=8, tstop=tstop, reference=None,
        reference_kind=f"ngspice reltol {REFERENCE_RELTOL:g}", compare=("v(pos,neg)", "v(acs)"),
    )


def voltage_multiplier(stages: int, cycles: int) -> Bench:
    """A Cockcroft-Walton multiplier of ``stages`` stages (2 diodes, 2 capacitors each), 1 kHz.

    Pumping column ``in = a0, a1, ...`` (capacitors ``CAk a(k-1) ak``), DC
    column ``b0 = 0, b1, ...`` (``CBk b(k-1) bk``), diodes ``b(k-1) -> ak ->
    bk``, load ``RL b<stages> 0 100k``: the output approaches ``2 * stages``
    times the source amplitude minus the diode drops.
    """
    tstop = cycles * 1e-3
    out = f"b{stages}"
    signals = (f"v({out})", "v(a1)")
    lines = [f"Cockcroft-Walton multiplier, {stages} stages, {cycles} cycles", "V1 a0 0 DC 0 SIN(0 10 1k)"]
    for k in range(1, stages + 1):
        bprev = "0" if k == 1 else f"b{k - 1}"
        lines += [f"CA{k} a{k - 1} a{k} 10u", f"CB{k} {bprev} b{k} 10u",
                  f"DA{k} {bprev} a{k} d1n4148", f"DB{k} a{k} b{k} d1n4148"]
    lines += [f"RL {out} 0 100k", _D1N4148, _save_line(signals), f".tran 5u {num(tstop)}", ".end"]
    return Bench(
        name=f"multiplier_{stages}st_{cycles}cyc", family="voltage_multiplier", category="nonlinear",
        text="\n".join(lines) + "\n", signals=signals, unknowns=1 + 2 * stages + 2 * stages + 1,
        elements=4 * stages + 2, tstop=tstop, reference=None, reference_kind=f"ngspice reltol {REFERENCE_RELTOL:g}",
    )


# ---------------------------------------------------------------------------------- RC pulse train
def pulse_train(periods: int, *, tmax: float = 1e-9) -> Bench:
    """One RC section (tau 0.1 us) driven by a 1 us pulse train, largest step forced to ``tmax``.

    At least ``periods * 1 us / tmax`` steps: measures the cost of a step.
    Reference: the exact solution (the one-section ladder).
    """
    pulse = Pulse(0.0, 1.0, 0.0, 10e-9, 10e-9, 0.49e-6, 1e-6)
    tstop = periods * 1e-6
    bench = rc_ladder(1, r_total=1e3, c_total=100e-12, tstop=tstop, pulse=pulse, tstep=tmax, tmax=tmax,
                      name=f"pulse_train_{periods}per", category="many-steps")
    bench.family = "pulse_train"
    return bench


# ---------------------------------------------------------------------------------- ring oscillator
_MOS_MODELS = """.model nmos1 nmos (level=1 vto=0.7 kp=110u gamma=0.4 phi=0.7 lambda=0.04 ld=0.05u
+ cgso=0.3n cgdo=0.3n cgbo=0.1n cj=0.56m mj=0.45 cjsw=0.35n mjsw=0.2 pb=0.9)
.model pmos1 pmos (level=1 vto=-0.8 kp=50u gamma=0.5 phi=0.7 lambda=0.05 ld=0.05u
+ cgso=0.3n cgdo=0.3n cgbo=0.1n cj=0.94m mj=0.5 cjsw=0.32n mjsw=0.3 pb=0.9)"""


def ring_oscillator(stages: int, tstop: float) -> Bench:
    """A CMOS ring oscillator of ``stages`` level-1 inverters (``netlists/ring_oscillator_notox.cir``).

    ``.ic v(n1)=0`` holds n1 in the operating point (the metastable state
    otherwise) and starts the oscillation. Reference: ngspice at reltol 1e-8.
    """
    if stages % 2 == 0 or stages < 3:
        raise ValueError("a ring oscillator needs an odd number (>= 3) of stages")
    signals = ("v(n1)", "v(n2)")
    lines = [f"CMOS ring oscillator, {stages} stages, level 1 without TOX", "VDD vdd 0 5"]
    for k in range(1, stages + 1):
        a, b = f"n{k}", f"n{k % stages + 1}"
        lines += [f"MN{k} {b} {a} 0 0 nmos1 w=2u l=1u ad=4p as=4p pd=6u ps=6u",
                  f"MP{k} {b} {a} vdd vdd pmos1 w=4u l=1u ad=8p as=8p pd=8u ps=8u",
                  f"C{k} {a} 0 20f"]
    lines += [_MOS_MODELS, ".ic v(n1)=0", _save_line(signals), f".tran 0.01n {num(tstop)}", ".end"]
    return Bench(
        name=f"ring_osc_{stages}st", family="ring_oscillator", category="nonlinear", text="\n".join(lines) + "\n",
        signals=signals, unknowns=stages + 2, elements=3 * stages + 1, tstop=tstop, reference=None,
        reference_kind=f"ngspice reltol {REFERENCE_RELTOL:g}",
    )


#: A 130 nm-like BSIM4 card pair (as tests/test_osdi_bsim4.py): BSIM4's defaults and a handful of parameters.
_BSIM4_MODELS = """.model nch nmos level=54 version=4.8 toxe=2.5n toxp=2.0n toxm=2.5n vth0=0.42 k1=0.55 u0=0.03 vsat=1.1e5
+ rdsw=150 ndep=2e18 cgso=2.5e-10 cgdo=2.5e-10 cgbo=1e-12 cjs=1.2e-3 cjsws=1.5e-10 cjswgs=2e-10 mjs=0.4
+ mjsws=0.3 pbsws=0.8
.model pch pmos level=54 version=4.8 toxe=2.6n toxp=2.1n toxm=2.6n vth0=-0.40 k1=0.50 u0=0.01 vsat=0.9e5
+ rdsw=300 ndep=2e18 cgso=2.5e-10 cgdo=2.5e-10 cgbo=1e-12 cjs=1.3e-3 cjsws=1.6e-10 cjswgs=2e-10 mjs=0.4
+ mjsws=0.3 pbsws=0.8"""


def bsim4_ring_oscillator(stages: int, tstop: float) -> Bench:
    """A ring oscillator of ``stages`` BSIM4 inverters (level-54 cards; netdae runs them through OSDI).

    Needs ``netdae[models]`` on netdae's side; ngspice runs its built-in
    BSIM4 in one thread (``.options num_threads=1``: its default two OpenMP
    threads spin at barriers on a busy machine). Reference: ngspice at reltol 1e-8.
    """
    if stages % 2 == 0 or stages < 3:
        raise ValueError("a ring oscillator needs an odd number (>= 3) of stages")
    signals = ("v(n1)", "v(n2)")
    lines = [f"BSIM4 ring oscillator, {stages} stages", ".options num_threads=1", "VDD vdd 0 1.2"]
    for k in range(1, stages + 1):
        a, b = f"n{k}", f"n{k % stages + 1}"
        lines += [f"MN{k} {b} {a} 0 0 nch l=0.13u w=1u ad=0.5p as=0.5p pd=3u ps=3u",
                  f"MP{k} {b} {a} vdd vdd pch l=0.13u w=2u ad=1p as=1p pd=4u ps=4u",
                  f"C{k} {a} 0 2f"]
    lines += [_BSIM4_MODELS, ".ic v(n1)=0", _save_line(signals), f".tran 0.01n {num(tstop)}", ".end"]
    return Bench(
        name=f"bsim4_ring_{stages}st", family="bsim4_ring_oscillator", category="nonlinear",
        text="\n".join(lines) + "\n", signals=signals, unknowns=stages + 2, elements=3 * stages + 1, tstop=tstop,
        reference=None, reference_kind=f"ngspice reltol {REFERENCE_RELTOL:g}",
    )


def bsim4_inverter_chain(stages: int, tstop: float) -> Bench:
    """A chain of ``stages`` BSIM4 inverters driven by a 1.2 V pulse (20 ps edges, 1 ns period), 2 fF per stage.

    Needs ``netdae[models]`` on netdae's side; ngspice runs its built-in BSIM4
    in one thread, as for :func:`bsim4_ring_oscillator`. Reference: ngspice at reltol 1e-8.
    """
    if stages < 1:
        raise ValueError("an inverter chain needs at least one stage")
    signals = ("v(n1)", f"v(n{stages + 1})")
    lines = [f"BSIM4 inverter chain, {stages} stages", ".options num_threads=1", "VDD vdd 0 1.2",
             "VIN n1 0 PULSE(0 1.2 0.1n 20p 20p 0.48n 1n)"]
    for k in range(1, stages + 1):
        a, b = f"n{k}", f"n{k + 1}"
        lines += [f"MN{k} {b} {a} 0 0 nch l=0.13u w=1u ad=0.5p as=0.5p pd=3u ps=3u",
                  f"MP{k} {b} {a} vdd vdd pch l=0.13u w=2u ad=1p as=1p pd=4u ps=4u",
                  f"C{k} {b} 0 2f"]
    lines += [_BSIM4_MODELS, _save_line(signals), f".tran 0.01n {num(tstop)}", ".end"]
    return Bench(
        name=f"bsim4_chain_{stages}st", family="bsim4_inverter_chain", category="nonlinear",
        text="\n".join(lines) + "\n", signals=signals, unknowns=stages + 4, elements=3 * stages + 2, tstop=tstop,
        reference=None, reference_kind=f"ngspice reltol {REFERENCE_RELTOL:g}",
    )


#: Generator of each family, by name (for ``--only``).
GENERATORS = {
    "rc_ladder": rc_ladder,
    "rc_mesh": rc_mesh,
    "rlc_line": rlc_line,
    "differentiator": differentiator,
    "bridge_rectifier": bridge_rectifier,
    "voltage_multiplier": voltage_multiplier,
    "pulse_train": pulse_train,
    "ring_oscillator": ring_oscillator,
    "bsim4_ring_oscillator": bsim4_ring_oscillator,
    "bsim4_inverter_chain": bsim4_inverter_chain,
}
