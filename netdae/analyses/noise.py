"""Small-signal noise analysis (``.noise v(out[,ref]) src dec|oct|lin N fstart fstop [pts_per_summary]``).

The circuit is linearised at its DC operating point (:func:`netdae.analyses.ac.linearize`,
the one linearisation of ``.ac``, ``.pz`` and ``.tf``). Every noise source is
a current generator between two unknowns with a power spectral density
``S(f) = white + coefficient / f**exponent`` [A^2/Hz], computed at the
operating point by its device (:meth:`netdae.devices.base.DeviceFamily.noise`,
:func:`netdae.devices.linear.resistor_noise`): thermal ``4 k T G``, shot
``2 q |I|``, flicker ``KF |I|^AF / f``.

At each frequency, with ``A = j omega E - H`` the AC matrix and ``c`` the
output's selector (``v(out) - v(ref)``), the *adjoint* system
``A^T y = c`` is solved once; a unit current entering unknown ``p`` and
leaving ``m`` then reaches the output as ``y[p] - y[m]``. The output noise
density is ``sum_g |y[p_g] - y[m_g]|^2 S_g(f)`` [V^2/Hz]; the input-referred
density divides it by ``|G|^2``, the gain from a unit AC value of ``src``
to the output (one forward solve; ``|G|^2`` at least 1e-20, as ngspice's
``N_MINGAIN``): V^2/Hz for a V source, A^2/Hz for an I source. Both are
reported as their square roots, ngspice's ``onoise_spectrum`` and
``inoise_spectrum`` (V/sqrt(Hz), and V or A/sqrt(Hz)).

The totals ``onoise_total`` and ``inoise_total`` (V, or A) are the square
roots of the integrated densities. As ngspice's ``Nintegrate``, each
generator's output density is integrated separately between neighbouring
points as a power law ``a f^k`` through the two points (flat when
``|k| < 1e-10``, logarithmic when ``|k + 1| < 1e-10``), and the pieces
summed; the input-referred piece is the output piece times ``1/|G|^2`` at
the interval's upper point (ngspice takes the power law of the output
density for both).

With ``pts_per_summary`` (ngspice's summary) the result also holds every
generator's output density ``onoise_<device><_source>`` and each device's
total ``onoise_<device>`` (V/sqrt(Hz)), at every ``pts_per_summary``-th
point only (so does ngspice), and the per-generator totals
``onoise_total_<device><_source>`` / ``inoise_total_...``. Each device's
share of ``onoise_total`` is always kept (``noise.contributions``) and
the largest are named in the notes.
"""

from __future__ import annotations

import time

import numpy as np

from ..circuit import Circuit, NoiseAnalysis
from ..errors import CircuitError, count_text
from ..kinds import Kind
from ..metadata import NoiseInfo
from ..results import Result, Statistics
from .op import op_result

__all__ = ["noise_analysis", "integrate_power_law", "collect_noise_sources", "NOISE_MINGAIN", "NOISE_MINLOG",
           "is_noise_name", "NOISE_SPECTRA", "NOISE_TOTALS"]

#: The smallest squared gain the input-referred noise divides by (ngspice's ``N_MINGAIN``).
NOISE_MINGAIN = 1e-20
#: The smallest density whose logarithm is taken (ngspice's ``N_MINLOG``).
NOISE_MINLOG = 1e-38
#: Below this slope (log-log) an interval is integrated as flat (``N_INTFTHRESH``) ...
_FLAT = 1e-10
#: ... and within this of -1 as ``a ln f`` (``N_INTUSELOG``).
_LOG = 1e-10
#: The spectra and totals ngspice names.
NOISE_SPECTRA = ("onoise_spectrum", "inoise_spectrum")
NOISE_TOTALS = ("onoise_total", "inoise_total")
#: Notes name the devices contributing at least this fraction of the output noise power.
_NOTED_SHARE = 0.01


def is_noise_name(name: str) -> bool:
    """Whether ``name`` is one of a noise result's vectors (``onoise_...``, ``inoise_...``).

    >>> is_noise_name("onoise_spectrum"), is_noise_name("inoise_total_r1"), is_noise_name("v(out)")
    (True, True, False)
    """
    key = name.strip().lower()
    return key.startswith(("onoise_", "inoise_"))


def integrate_power_law(density: np.ndarray, freqs: np.ndarray) -> np.ndarray:
    """Integrals of densities between neighbouring frequencies, each interval a power law through its two points.

    ngspice's ``Nintegrate``: on ``[f0, f1]`` the density is ``a f^k`` with
    ``k = ln(S1/S0) / ln(f1/f0)`` (logarithms of densities floored at
    1e-38); flat (``S1 (f1 - f0)``) when ``|k| < 1e-10``, ``a ln(f1/f0)``
    when ``|k + 1| < 1e-10``, else ``a (f1^(k+1) - f0^(k+1)) / (k + 1)``.

    Parameters
    ----------
    density : ndarray, shape (m, g)
        Densities at the ``m`` frequencies, one column per generator.
    freqs : ndarray, shape (m,)
        Positive, increasing.

    Returns
    -------
    ndarray, shape (m - 1, g)
        The integral of each column over each interval.

    Examples
    --------
    White noise, and ``1/f`` noise (``ln(f1/f0)`` per interval):

    >>> f = np.array([1.0, 10.0, 100.0])
    >>> integrate_power_law(np.array([[2.0, 1.0], [2.0, 0.1], [2.0, 0.01]]), f).sum(axis=0).round(6).tolist()
    [198.0, 4.60517]
    """
    density = np.asarray(density, dtype=float)
    f = np.asarray(freqs, dtype=float)
    if f.size < 2:
        return np.zeros((0,) + density.shape[1:])
    lnf = np.log(np.maximum(f, NOISE_MINLOG))
    lnd = np.log(np.maximum(density, NOISE_MINLOG))
    d_lnf = np.diff(lnf)[:, None]
    k = np.diff(lnd, axis=0) / d_lnf
    hi_f, lo_f = lnf[1:, None], lnf[:-1, None]
    top = np.exp(lnd[1:])  # the upper point's density (floored as its logarithm)
    k1 = k + 1.0
    with np.errstate(over="ignore", invalid="ignore"):
        # ngspice's a (f1^(k+1) - f0^(k+1)) / (k+1) with a = S1 / f1^k, written S1 f1 (1 - (f0/f1)^(k+1)) / (k+1):
        # equal where ngspice's is finite, and finite where its exponentials would overflow (a steep
        # rise from a density at the floor)
        power = top * np.exp(hi_f) * -np.expm1(k1 * (lo_f - hi_f)) / np.where(np.abs(k1) < _LOG, 1.0, k1)
        logarithmic = np.exp(lnd[1:] - k * hi_f) * (hi_f - lo_f)
    pieces = np.where(np.abs(k) < _FLAT, density[1:] * np.diff(f)[:, None],
                      np.where(np.abs(k1) < _LOG, logarithmic, power))
    return pieces


def collect_noise_sources(prepared, x: np.ndarray):
    """Every noise generator of a prepared circuit (:class:`~netdae.analyses.prepared.Prepared`) at its
    operating point ``x``.

    Resistors first (:func:`~netdae.devices.linear.resistor_noise`), then each
    nonlinear family's (:meth:`~netdae.devices.base.DeviceFamily.noise`).

    Raises
    ------
    CircuitError
        A device without a noise model (an OSDI device).
    """
    from ..devices.base import NoiseSources
    from ..devices.junction import KELVIN
    from ..devices.linear import resistor_noise

    circuit, system = prepared.circuit, prepared.system
    xe = np.append(np.asarray(x, dtype=float), 0.0)
    temp = circuit.options.temp + KELVIN
    resistors = [el for el in circuit.elements if el.kind == Kind.RESISTOR]
    parts = [resistor_noise(resistors, circuit, system.layout, xe)]
    parts += [fam.noise(xe, temp) for fam in system.families]
    return NoiseSources.concatenate(parts)


def _instances(sources) -> list[tuple[str, list[int]]]:
    """The generators' indices grouped by instance, in order."""
    groups: dict[str, list[int]] = {}
    for k, name in enumerate(sources.element):
        groups.setdefault(name, []).append(k)
    return list(groups.items())


def noise_analysis(circuit: Circuit, card: NoiseAnalysis, *, freqs=None, **overrides) -> Result:
    """Run a ``.noise`` analysis.

    Parameters
    ----------
    circuit : Circuit
    card : NoiseAnalysis
    freqs : array_like, optional
        Frequencies to use instead of the card's grid (increasing; the
        comparison with ngspice passes ngspice's own).
    **overrides
        Operating-point tolerances (``reltol``, ...).

    Returns
    -------
    Result
        ``analysis == "noise"``, axis ``frequency`` [Hz], real signals
        ``onoise_spectrum`` [V/sqrt(Hz)] and ``inoise_spectrum`` [V or
        A/sqrt(Hz)] (with ``pts_per_summary``, each generator's and device's
        output density first, ngspice's names); ``noise`` (:class:`netdae.metadata.NoiseInfo`): ``totals`` the
        integrated noise ``{"onoise_total": V, "inoise_total": V or A, ...}``
        as ngspice's "Integrated Noise" plot (empty at a single frequency,
        fstart == fstop or ``lin`` with one point, as ngspice writes none), ``contributions`` each device's
        ``onoise_total`` and share of the output noise power,
        ``input_unit`` ``"V"`` or ``"A"``; ``operating_point`` the
        operating point, ``card`` the ``.noise`` card.

    Raises
    ------
    CircuitError, ConvergenceError
        No operating point, a singular AC matrix, a device without a noise
        model (OSDI devices).
    """
    from .ac import frequencies, linearize, solve_ac

    t0 = time.perf_counter()
    lin = linearize(circuit, **overrides)
    system = lin.system
    n = system.n
    sources = collect_noise_sources(lin.prepared, lin.op.x)
    # one frequency when fstart == fstop, or lin with one point (ngspice then writes no integrated noise)
    single = card.fstart == card.fstop or (card.variation == "lin" and card.points == 1)
    if freqs is not None:
        freqs = np.asarray(freqs, dtype=float)
        single = single or freqs.size == 1
    else:
        freqs = np.array([card.fstart]) if single else frequencies(card)
    # the output selector and the input's unit AC column
    c = np.zeros(n)
    for node, sign in ((card.output, 1.0), (card.reference, -1.0)):
        k = system.node_index(node)
        if k >= 0:
            c[k] += sign
    col = list(system.sources.names).index(card.source)
    b = np.asarray(system.B[:, [col]].toarray(), dtype=complex).ravel()
    E, H = lin.E, lin.H_ac
    delays = lin.delays
    gain = solve_ac(E, H, b, freqs, delays) @ c
    adjoint = solve_ac(E.T.tocsc(), H.T.tocsc(), c.astype(complex), freqs,
                       [(tau, D.T.tocsc()) for tau, D in delays])
    ext = np.concatenate([adjoint, np.zeros((freqs.size, 1), dtype=complex)], axis=1)  # column -1: ground
    transfer = ext[:, sources.pos] - ext[:, sources.neg]
    with np.errstate(divide="ignore", invalid="ignore"):
        density = np.abs(transfer) ** 2 * sources.density(freqs)  # [V^2/Hz], (m, g)
    if not np.all(np.isfinite(density)):
        raise CircuitError(".noise: a noise density is not finite (a device's operating point gives an infinite "
                           "or undefined noise source)", hint="check the operating point of the circuit")
    gain_sq_inv = 1.0 / np.maximum(np.abs(gain) ** 2, NOISE_MINGAIN)
    onoise = density.sum(axis=1)
    input_unit = "V" if circuit.element(card.source).kind == Kind.VSOURCE else "A"
    groups = _instances(sources)

    # the spectra (with a summary: every generator and device first, every summary-th point)
    keep = np.arange(freqs.size)
    signals: dict[str, np.ndarray] = {}
    if card.summary:  # a summary beyond the sweep keeps its first frequency (a modulus numpy can hold)
        keep = keep[keep % min(card.summary, freqs.size) == 0]
        for name, idx in groups:
            for k in idx:
                signals[f"onoise_{name}{sources.suffix[k]}"] = np.sqrt(density[keep, k])
            if len(idx) > 1 or sources.suffix[idx[0]]:
                signals[f"onoise_{name}"] = np.sqrt(density[keep][:, idx].sum(axis=1))
    signals["onoise_spectrum"] = np.sqrt(onoise[keep])
    signals["inoise_spectrum"] = np.sqrt(onoise[keep] * gain_sq_inv[keep])

    # the totals
    pieces = integrate_power_law(density, freqs)  # (m - 1, g)
    out_int = pieces.sum(axis=0)
    in_int = (pieces * gain_sq_inv[1:, None]).sum(axis=0)
    totals: dict[str, float] = {}
    if not single:
        if card.summary:
            for name, idx in groups:
                for k in idx:
                    totals[f"onoise_total_{name}{sources.suffix[k]}"] = float(np.sqrt(out_int[k]))
                    totals[f"inoise_total_{name}{sources.suffix[k]}"] = float(np.sqrt(in_int[k]))
                if len(idx) > 1 or sources.suffix[idx[0]]:
                    totals[f"onoise_total_{name}"] = float(np.sqrt(out_int[idx].sum()))
                    totals[f"inoise_total_{name}"] = float(np.sqrt(in_int[idx].sum()))
        totals["onoise_total"] = float(np.sqrt(out_int.sum()))
        totals["inoise_total"] = float(np.sqrt(in_int.sum()))

    # each device's share of the output noise power (over the band, or at the one frequency)
    power = out_int if freqs.size > 1 else density[0]
    whole = float(power.sum())
    contributions = {name: {"onoise_total": float(np.sqrt(power[idx].sum())),
                            "share": float(power[idx].sum() / whole) if whole > 0 else 0.0}
                     for name, idx in groups}
    notes = list(system.notes)
    notes.append(f"output v({card.output}{',' + card.reference if card.reference != '0' else ''}); input "
                 f"{card.source} ({'V' if input_unit == 'V' else 'A'}/sqrt(Hz) input-referred noise); "
                 f"{len(sources)} noise generator(s) in {len(groups)} device(s)")
    ranked = sorted(contributions.items(), key=lambda item: -item[1]["share"])
    named = [f"{name} {100 * v['share']:.3g} %" for name, v in ranked if v["share"] >= _NOTED_SHARE][:5]
    if named:
        notes.append("largest contributors to the output noise power: " + ", ".join(named))
    if not len(sources):
        notes.append("no device of the circuit generates noise: every density is zero")
    if card.summary >= freqs.size > 1:
        notes.append(f"pts_per_summary = {count_text(card.summary)} is not below the sweep's {freqs.size} frequencies: "
                     "the spectra hold the first one only, as ngspice writes them (the totals integrate over every "
                     "frequency)")
    elif card.summary > 1:
        notes.append(f"pts_per_summary = {card.summary}: the spectra hold every {card.summary}-th frequency, as "
                     "ngspice writes them (the totals integrate over every frequency)")
    return Result(
        "noise",
        axes={"frequency": freqs[keep]},
        signals=signals,
        stats=Statistics(points=int(keep.size), wall_time=time.perf_counter() - t0,
                         newton_iterations=lin.op.iterations, generators=len(sources), **system.describe()),
        message="ok",
        tolerances={"reltol": lin.options.reltol, "vntol": lin.options.vntol, "abstol": lin.options.abstol},
        notes=notes,
        operating_point=op_result(system, lin.op, 0.0, lin.options), card=card,
        noise=NoiseInfo(totals=totals, contributions=contributions, input_unit=input_unit),
    )
