"""ngspice's lossy transmission lines (O: LTRA, Y: TXL, P: CPL) as sections of netdae's elements.

A uniform line of length ``len`` obeys the telegrapher's equations

    dv/dz = -(R + L d/dt) i,        di/dz = -(G + C d/dt) v

with per-unit-length ``R, L, G, C`` (N x N matrices for N coupled conductors, CPL). ngspice
39 integrates them with convolutions (LTRA) or recursive fits of the line's impulse
responses (TXL, CPL); netdae realises each line when elaborating, in one place (here), as
``n`` sections made of the element kinds it already has, so that the assembly, the
topology, the index analysis, ``.op``, ``.ac`` and the transient need nothing new:

* **a single line with inductance** (LTRA ``l > 0``, TXL): ``n`` lossless lines (``tline``,
  exact delays ``td / n``, ``z0 = sqrt(L/C)``) with the losses lumped between them by the
  trapezoidal rule: a series resistance ``R len / n`` and a shunt conductance
  ``G len / n`` at each of the ``n - 1`` joints, half of each at the two ends, each joint
  symmetric (half its shunt on either side of its resistance). The wave delay is exact; the
  lumping is second order in ``1/n``. A lossless line is one
  ``tline``.
* **an RC line** (LTRA ``l = 0``; TXL with ``r / l > 1.6e10``, which ngspice 39 itself turns
  into an RC network and so ignores ``l``): a ladder of ``n`` series resistances with the
  capacitance (and conductance) lumped trapezoidally at the ``n + 1`` nodes.
* **an RG line** (LTRA ``l = c = 0``): exact at every frequency, as one T network
  (series arms ``Zc tanh(gamma len / 2)``, shunt ``Zc / sinh(gamma len)``,
  ``gamma = sqrt(R G)``, ``Zc = sqrt(R / G)``).
* **coupled lines** (CPL): their propagation modes (:func:`modes`): per section one
  lossless line per mode, ideal multiport transformers (:func:`_transform`) at the two
  ends, the conductors' series resistances ``R_ii len / n`` and the conductance matrix
  lumped trapezoidally: half at the ends in the conductors (Maxwell form: conductor ``i``
  to ground ``sum_j G_ij``, between ``i`` and ``j`` ``-G_ij``), whole at the inner joints
  in the modes, each joint symmetric (:func:`_modal_lump`); the capacitance and inductance are all in the modal
  lines.

At DC every form is the line's series resistance between its ports with its shunt
conductance (exact when ``G = 0``, which all of ngspice's LTRA forms but RG have).

The number of sections (:func:`section_count`) follows from the line and the circuit's
finest time scale (:func:`resolution`: a transient's ``min(tstep, (tstop - tstart)/50)``,
``1 / (2 pi fstop)`` of an ``.ac`` or ``.noise``): a section's lumped losses reflect at most
:data:`LUMP_REFLECTION` (:attr:`LineParameters.reflection`, per mode for coupled lines);
at a time scale, when the whole line's would reflect more, the section delay ``td / n`` is at
most :data:`SECTION_FRACTION` of the scale (the lumps' echoes merge into the line's; lumps
half a wavelength apart reflect together), and when less, either that or a section's lumps
reflect at most :data:`LUMP_ECHO` (their echoes stand alone), whichever takes fewer; an
RC ladder's delay and diffusion time ``R C len^2 / n^2`` at most :data:`LADDER_FRACTION`;
``sqrt(R G) len / n`` at most :data:`DC_STEP`; at most :data:`MAX_SECTIONS`.
The internal nodes are ``<line>#<tag>`` (``u``, ``w``: a single line's joints; ``j``, ``h``,
``x``, ``y``, ``s``, ``e``: a coupled line's joints, modal ports and transformer chains), the
internal elements ``<line>#...``, named like the line (nodes ``x1.o1#u3`` inside ``x1``).

Examples
--------
>>> p = LineParameters("ltra", *(np.array([[v]]) for v in (1.0, 1e-9, 0.0, 1e-12)), length=1.0)
>>> round(p.delay * 1e9, 6), round(p.impedance, 3)
(0.031623, 31.623)
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..circuit import STAMP_MAGNITUDES, AcAnalysis, Element, NoiseAnalysis, SourceSpec, TranAnalysis
from ..kinds import KINDS, Kind

__all__ = ["LINE_KINDS", "MODEL_FORMS", "NUMERICAL_CONTROLS", "NGSPICE_FORMS", "LineParameters", "LossyLineError",
           "line_parameters", "check_magnitudes", "resolution", "section_count", "realise", "realisation_note",
           "SECTION_FRACTION", "LADDER_FRACTION", "LUMP_REFLECTION", "LUMP_ECHO", "DC_STEP", "MAX_SECTIONS",
           "CPL_MIN_RESISTANCE", "TXL_RC_RATIO"]

#: The element kinds this module realises.
LINE_KINDS = frozenset(k for k, spec in KINDS.items() if spec.realised_by == __name__)
#: The model cards' forms, for messages.
MODEL_FORMS = {
    "ltra": ".model mname ltra r=ohm/len l=H/len g=S/len c=F/len len=length [rel= abs= nocontrol steplimit "
            "compactrel= compactabs= truncnr truncdontcut ...]",
    "txl": ".model mname txl r=ohm/len l=H/len g=S/len c=F/len length=length",
    "cpl": ".model mname cpl r=r11 r12 .. r1N r22 .. rNN l=... g=... c=... length=length (upper triangles, row "
           "by row)",
}
#: An LTRA model's numerical controls (ngspice's convolution and its time step): read and ignored.
NUMERICAL_CONTROLS = {"ltra": frozenset({"rel", "abs", "nocontrol", "steplimit", "nosteplimit", "lininterp",
                                         "quadinterp", "mixedinterp", "truncnr", "truncdontcut", "compactrel",
                                         "compactabs"})}
#: Largest section delay of a line of lossless sections whose lumped losses reflect more than
#: :data:`LUMP_REFLECTION` in all (less: unless its lumps reflect at most :data:`LUMP_ECHO`),
#: and its sections' diffusion time, as a fraction of the circuit's time scale (:func:`resolution`).
SECTION_FRACTION = 0.25
#: The same for an RC line's ladder (its sections are lumped: finer; at 0.1 a ladder driven through
#: 50 ohm by a step of four time scales erred by 0.8 of the tolerance 1e-3 at its near end, at
#: 0.025, twice the sections, by 0.25: tests/test_lossy_lines.py).
LADDER_FRACTION = 0.025
#: Largest reflection of one section's lumped losses, ``(R len / (2 z0) + G len z0 / 2) / n``.
LUMP_REFLECTION = 0.02
#: Largest reflection of one section's lumped losses on a line whose losses reflect at most
#: :data:`LUMP_REFLECTION` in all, when the section's delay is longer than
#: :data:`SECTION_FRACTION` of the time scale: an edge then leaves one echo per lump, about a
#: fifth of its reflection, and the line's error is that echo, first order in ``1 / n``
#: (two coupled low-loss lines, ``R len / (2 z0) = 0.009``: 1.9e-3, 6.2e-4, 2.9e-4, 1.4e-4 of
#: the step at 1, 3, 6, 12 sections; 5e-4 keeps it near 1e-4).
LUMP_ECHO = 5e-4
#: Largest ``sqrt(R G) len / n`` (the DC attenuation per section, trapezoidal error ~ its square / 12).
DC_STEP = 0.1
#: Most sections of one line (a line that needs more gets this many and a warning).
MAX_SECTIONS = 400
#: ngspice 39's CPL raises every resistance entry below this to it (``cplsetup.c``).
CPL_MIN_RESISTANCE = 1e-4
#: ngspice 39 reads a TXL with ``r / l`` above this as an RC network (``inp2y.c``), ignoring ``l``.
TXL_RC_RATIO = 1.6e10


class LossyLineError(ValueError):
    """A line's model or card that cannot be realised.

    Attributes
    ----------
    param : str or None
        The model parameter (``"c"``) or, with ``on_card``, the card's parameter (``"len"``)
        the error is about; None: the card.
    on_card : bool
    hint : str or None
    """

    def __init__(self, message: str, param: str | None = None, *, on_card: bool = False,
                 hint: str | None = None) -> None:
        super().__init__(message)
        self.param, self.on_card, self.hint = param, on_card, hint


@dataclass(frozen=True)
class LineParameters:
    """One line's per-unit-length matrices (N x N) and length, as ngspice reads them.

    Attributes
    ----------
    kind : str
        ``"ltra"``, ``"txl"`` or ``"cpl"``.
    r, l, g, c : ndarray, shape (N, N)
        Resistance, inductance, conductance, capacitance per unit length (``r``
        diagonal; ``g``, ``c`` Maxwell matrices).
    length : float
    form : str
        ``"lc"`` (sections of lossless lines), ``"rc"`` (a ladder without inductance),
        ``"rg"`` (the exact T network) or ``"modal"`` (coupled lines).
    """

    kind: str
    r: np.ndarray
    l: np.ndarray
    g: np.ndarray
    c: np.ndarray
    length: float
    form: str = "lc"

    @property
    def conductors(self) -> int:
        """N."""
        return self.r.shape[0]

    @property
    def delay(self) -> float:
        """The slowest mode's delay [s]: ``len sqrt(max eig(L C))``."""
        if not self.l.any() or not self.c.any():
            return 0.0
        return self.length * math.sqrt(max(float(np.max(np.linalg.eigvals(self.l @ self.c).real)), 0.0))

    @property
    def reflection(self) -> float:
        """What the whole line's losses reflect when lumped in one place, ``R len / (2 z0) + G len z0 / 2``.

        For coupled lines the largest over the modes (:func:`modes`), with the losses seen by
        each mode, ``T_v^-1 R T_v^-T`` and ``T_v^T G T_v`` (invariant under the modes' scaling).
        """
        if self.form == "lc":
            z0 = self.impedance
            return self.length * (float(self.r[0, 0]) / (2.0 * z0) + float(self.g[0, 0]) * z0 / 2.0)
        tv, lm, cm = modes(self.l, self.c)
        inv = np.linalg.inv(tv)
        z0 = np.sqrt(lm / cm)
        rm, gm = np.diag(inv @ self.r @ inv.T), np.diag(tv.T @ self.g @ tv)
        return self.length * float(np.max(rm / (2.0 * z0) + gm * z0 / 2.0))

    @property
    def impedance(self) -> float:
        """A single line's characteristic impedance at high frequency, ``sqrt(L / C)`` (0: none)."""
        l, c = float(self.l[0, 0]), float(self.c[0, 0])
        return math.sqrt(l / c) if l > 0 and c > 0 else 0.0


def _scalar(model, name: str, *, required: bool, default: float = 0.0) -> float | None:
    value = model.params.get(name)
    if value is None and name in model.vectors:
        raise LossyLineError(f"{name}= takes one value on a {model.type.upper()} model, found "
                             f"{len(model.vectors[name])}", name)
    if value is None:
        if required:
            return None
        return default
    if not value >= 0.0 or not math.isfinite(value):
        raise LossyLineError(f"{name}={value:g}: must be finite and not negative", name)
    return float(value)


def _length(el: Element, model, name: str) -> float:
    """The card's ``len=`` (when given), else the model's length (checked given by the caller)."""
    value = el.params.get("len")
    if value is not None:
        if not value > 0.0 or not math.isfinite(value):
            raise LossyLineError(f"len={value:g}: the line's length must be positive", "len", on_card=True)
        return float(value)
    value = model.params[name]
    if not value > 0.0 or not math.isfinite(value):
        raise LossyLineError(f"{name}={value:g}: the line's length must be positive", name)
    return float(value)


def _one(v: float) -> np.ndarray:
    return np.array([[float(v)]])


def check_magnitudes(p: LineParameters) -> None:
    """Refuse a line whose whole resistance, inductance, conductance or capacitance (per unit length times
    the length) lies outside netdae's range of element values (:data:`netdae.circuit.STAMP_MAGNITUDES`).

    The sections' elements are these totals divided by at most :data:`MAX_SECTIONS`, and the rules of
    :func:`section_count` multiply two of them (the diffusion time ``R C len^2``): ``c=1e300`` made that
    product infinite.

    Raises
    ------
    LossyLineError
        Naming the model parameter.
    """
    low, high = STAMP_MAGNITUDES
    what = {"r": "resistance", "l": "inductance", "g": "conductance", "c": "capacitance"}
    for name in "rlgc":
        per = float(np.max(np.abs(getattr(p, name))))
        total = per * p.length
        if per != 0.0 and not low <= total <= high:
            raise LossyLineError(f"{name}={per:g} per unit length over a length of {p.length:g}: the line's "
                                 f"{what[name]} of {total:g} is beyond netdae's range of element values "
                                 f"({low:g} to {high:g})", name,
                                 hint="check the value and its unit: r, l, g, c are per unit of the length")


def line_parameters(el: Element, model) -> tuple[LineParameters, list[tuple[str, str | None]]]:
    """The line an element and its model describe, with ngspice 39's rules.

    Parameters
    ----------
    el : Element
        Kind ``ltra``, ``txl`` or ``cpl`` (a Y card with a CPL model is a one-conductor ``cpl``).
    model : Model
        Its model (type checked by the caller).

    Returns
    -------
    LineParameters
    notes : list of (str, str or None)
        Warnings, each with the model parameter it is about.

    Raises
    ------
    LossyLineError
        A required parameter missing, a negative value, a form ngspice 39 refuses (LTRA:
        RL lines, ``g > 0`` with ``l`` or ``c``), a matrix of the wrong size, not positive
        definite (``l``, ``c``) or semi-definite (``g``), or with mutual resistances.
    """
    notes: list[tuple[str, str | None]] = []
    if el.kind == Kind.LTRA:
        if "len" not in model.params:
            raise LossyLineError("the line's length len= is missing (ngspice 39: 'lossy line length must be "
                                 "given')", None, hint="add len=<length> to the .model card (r, l, g, c are per "
                                 "unit of that length)")
        vals = {}
        for name in ("r", "l", "g", "c"):
            vals[name] = _scalar(model, name, required=name == "c")
        if vals["c"] is None:
            raise LossyLineError("the capacitance c= is missing (ngspice 39: 'lossy line parallel capacitance "
                                 "not given')", None, hint="add c=<capacitance per unit length>")
        for name, what in (("r", "series resistance"), ("l", "series inductance")):
            if name not in model.params:
                notes.append((f"lossy line {what} {name}= not given, assumed zero (as ngspice 39)", None))
        r, l, g, c = (vals[k] for k in "rlgc")
        length = _length(el, model, "len")
        if r != 0 and c == 0 and l != 0:
            raise LossyLineError("an RL line (c=0) is not supported (ngspice 39: 'RL line not supported yet')",
                                 "c")
        if g != 0 and (c != 0 or l != 0):
            raise LossyLineError(f"g={g:g} with {'c' if c else 'l'}: ngspice 39's LTRA supports a shunt "
                                 "conductance only in an RG line (l=0, c=0)", "g",
                                 hint="use a TXL model (Y card), which takes g with l and c")
        if l == 0 and c == 0 and not (r > 0 and g > 0):
            raise LossyLineError("a line without l and c needs both r and g (ngspice 39's RG line)", "r")
        if l == 0 and c != 0 and r == 0:
            raise LossyLineError("a line with c but neither l nor r has no LTRA form in ngspice 39", "r")
        form = "rg" if l == 0 and c == 0 else "rc" if l == 0 else "lc"
        return LineParameters("ltra", _one(r), _one(l), _one(g), _one(c), length, form), notes
    if el.kind == Kind.TXL:
        vals = {}
        for name in ("r", "g", "l", "c", "length"):
            vals[name] = _scalar(model, name, required=True)
            if vals[name] is None:
                what = {"r": "series resistance", "g": "parallel conductance", "l": "series inductance",
                        "c": "parallel capacitance", "length": "length"}[name]
                raise LossyLineError(f"{name}= ({what}) is missing: ngspice 39's TXL needs r, g, l, c and "
                                     "length on its model", None,
                                     hint="the card's len= overrides the length, but the model must give one"
                                     if name == "length" else "give it, 0 if there is none")
        r, g, l, c = (vals[k] for k in "rglc")
        length = _length(el, model, "length")
        if c == 0:
            raise LossyLineError("c=0: a TXL line needs a capacitance", "c")
        if l > 0 and r / l > TXL_RC_RATIO:
            notes.append((f"r/l = {r / l:.3g} > {TXL_RC_RATIO:g}: an RC line (l ignored), as ngspice 39 reads it",
                          "l"))
            l = 0.0
        elif l == 0:
            raise LossyLineError("l=0: ngspice 39's TXL needs an inductance", "l",
                                 hint="an RC line is an LTRA model with l=0 on an O card")
        return LineParameters("txl", _one(r), _one(l), _one(g), _one(c), length, "lc" if l > 0 else "rc"), notes
    # cpl
    n = (len(el.nodes) - 2) // 2
    mats = {}
    for name in ("r", "g", "l", "c"):
        values = model.vectors.get(name)
        if values is None:
            if name not in model.params:
                what = {"r": "series resistance", "g": "parallel conductance", "l": "series inductance",
                        "c": "parallel capacitance"}[name]
                raise LossyLineError(f"{name}= ({what}) is missing: ngspice 39's CPL needs r, g, l, c and length "
                                     "on its model", None, hint="give the upper triangle of each N x N matrix")
            values = (model.params[name],)
        mats[name] = _triangle(name, values, n)
    if "length" not in model.params:
        raise LossyLineError("length= is missing: ngspice 39's CPL model needs it", None,
                             hint="the card's len= overrides the length, but the model must give one")
    length = _length(el, model, "length")
    r = mats["r"]
    off = r - np.diag(np.diag(r))
    if np.any(np.abs(off) > CPL_MIN_RESISTANCE):
        raise LossyLineError("mutual resistances (off-diagonal r) are not supported by netdae", "r",
                             hint="give r as the diagonal (the conductors' own resistances), zeros elsewhere")
    diag = np.maximum(np.diag(r), CPL_MIN_RESISTANCE)
    for name in ("l", "c"):
        if not _definite(mats[name], strict=True):
            raise LossyLineError(f"the {name} matrix is not positive definite", name,
                                 hint="a physical line's inductance and Maxwell capacitance matrices are "
                                 "(capacitance: positive diagonal, negative mutual terms, each row's sum "
                                 "positive)")
    if mats["g"].any() and not _definite(mats["g"], strict=False):
        raise LossyLineError("the g matrix is not positive semi-definite", "g")
    return LineParameters("cpl", np.diag(diag), mats["l"], mats["g"], mats["c"], length, "modal"), notes


def _triangle(name: str, values, n: int) -> np.ndarray:
    """ngspice's symmetric N x N matrix from its upper triangle read row by row.

    A full ``N * N`` matrix is read too when it is symmetric (ngspice 39 would read its
    first ``N (N + 1) / 2`` numbers as the triangle, so it is refused otherwise).
    """
    values = [float(v) for v in values]
    for v in values:
        if not math.isfinite(v):
            raise LossyLineError(f"{name}: a value is not finite", name)
    need = n * (n + 1) // 2
    if len(values) == n * n and n > 1:
        full = np.array(values).reshape(n, n)
        if not np.allclose(full, full.T, rtol=1e-12, atol=0.0):
            raise LossyLineError(f"the {name} matrix (given in full, {n} x {n}) is not symmetric", name,
                                 hint=f"give the upper triangle, row by row ({need} numbers), as ngspice reads it")
        raise LossyLineError(f"{name}: {n * n} numbers, a full {n} x {n} matrix: ngspice 39 reads the upper "
                             f"triangle row by row, {need} numbers, and would misread these", name,
                             hint=f"give the upper triangle: {need} numbers")
    if len(values) != need:
        raise LossyLineError(f"{name}: {len(values)} number(s) for {n} conductor(s): ngspice 39 reads the upper "
                             f"triangle of the {n} x {n} matrix row by row, {need} numbers", name,
                             hint="the node count sets N: a P card has N inputs, a reference, N outputs, a "
                             "reference")
    out = np.zeros((n, n))
    out[np.triu_indices(n)] = values
    return out + np.triu(out, 1).T


def _definite(m: np.ndarray, *, strict: bool) -> bool:
    w = np.linalg.eigvalsh(m)
    scale = float(np.max(np.abs(w))) if w.size else 0.0
    return bool(scale > 0 and (w.min() > 1e-12 * scale if strict else w.min() >= -1e-12 * scale))


def resolution(analyses) -> float | None:
    """The finest time scale of a circuit's analyses [s] (None: DC only).

    A transient's ``min(tstep, (tstop - tstart) / 50)`` (its printing step; ``tmax`` caps the
    integrator's steps, not the signals' content), an ``.ac``'s or ``.noise``'s
    ``1 / (2 pi fstop)``.
    """
    scales = []
    for a in analyses:
        if isinstance(a, TranAnalysis):
            t = min(a.tstep, (a.tstop - a.tstart) / 50.0) if a.tstop > a.tstart else a.tstep
            if t > 0:
                scales.append(t)
        elif isinstance(a, (AcAnalysis, NoiseAnalysis)) and a.fstop > 0:
            scales.append(1.0 / (2.0 * math.pi * a.fstop))
    return min(scales) if scales else None


def section_count(p: LineParameters, scale: float | None) -> tuple[int, int]:
    """The sections a line gets at the time scale ``scale`` (see the module's rules).

    Returns
    -------
    n : int
        At most :data:`MAX_SECTIONS`.
    wanted : int
        What the rules ask (more than ``n`` when the cap cut it).
    """
    if p.form == "rg":
        return 1, 1
    tot = {k: float(np.max(np.abs(np.diag(getattr(p, k))))) * p.length for k in "rlgc"}
    need = [1.0]
    if tot["g"] > 0 and tot["r"] > 0:
        need.append(math.sqrt(tot["r"] * tot["g"]) / DC_STEP)
    fraction = LADDER_FRACTION if p.form == "rc" else SECTION_FRACTION
    if p.form in ("lc", "modal"):
        if tot["r"] == 0 and tot["g"] == 0:
            return 1, 1  # lossless: one exact line
        need.append(p.reflection / LUMP_REFLECTION)
    if scale is not None:
        if p.form == "rc" or p.reflection > LUMP_REFLECTION:
            # sections short against the time scale: the lumps' echoes merge into the line's own,
            # and lumps a half wavelength apart, which reflect together, stay above the signals'
            # frequencies (the steps, at most a section's delay, follow the scale too)
            need.append(p.delay / (fraction * scale))
        else:
            # a low-loss line: either that, or sections so long that each lump's echo of an edge
            # stands alone (about a fifth of its reflection), each lump reflecting at most LUMP_ECHO
            need.append(min(p.delay / (fraction * scale), p.reflection / LUMP_ECHO))
        diffusion = max(float(np.max(np.diag(p.r))) * p.length, 0.0) * float(np.max(np.diag(p.c))) * p.length
        need.append(math.sqrt(diffusion / (fraction * scale)))
    elif p.form == "rc":
        need.append(2.0)
    wanted = int(math.ceil(max(need) - 1e-9))
    return min(wanted, MAX_SECTIONS), wanted


#: What ngspice 39's own form of each line does, measured against the exact solution of the
#: line equations (docs/netlist.md "Lossy transmission lines"), for the realisation's note.
NGSPICE_FORMS = {
    Kind.LTRA: "ngspice 39's LTRA convolves the line's impulse responses on its own time steps: its error "
               "shrinks with the step only, not with its model's numerical controls (a lossy line driven by a "
               "0.2 ns step: 4e-3 of the swing at reltol=1e-3, 1e-3 at 1e-5)",
    Kind.TXL: "ngspice 39's TXL replaces the line's responses by Pade approximations of a few poles: its error "
              "does not shrink with the tolerances (a lossy line driven by a 0.2 ns step: 3e-2 of the swing)",
    Kind.CPL: "ngspice 39's CPL replaces the line's responses by Pade approximations of a few poles: its error "
              "does not shrink with the tolerances (2 % of the swing on its four coupled lines cpl3_4_line, "
              "70 % on one lossy conductor)",
}


def realisation_note(kind: str, lines: list[tuple[str, LineParameters, int]]) -> str:
    """What netdae made of the lines of one kind and what to expect of ngspice 39's form of them.

    Parameters
    ----------
    kind : str
        ``"ltra"``, ``"txl"`` or ``"cpl"``.
    lines : list of (str, LineParameters, int)
        Each line's name, parameters and sections.

    Returns
    -------
    str
        One sentence for the runs' notes.
    """
    names = ", ".join(f"{name} ({n} sections)" if p.form != "rg" else f"{name} (T network)"
                      for name, p, n in lines[:6])
    more = f" and {len(lines) - 6} more" if len(lines) > 6 else ""
    text = (f"{kind.upper()} line{'s' if len(lines) > 1 else ''} {names}{more} realised as sections "
            "(docs/netlist.md), within 3e-4 of the swing of the line equations' exact solution where measured")
    if all(not p.r.any() and not p.g.any() or p.form == "rg" for _, p, _ in lines):
        return text
    return f"{text}; a larger difference from ngspice is ngspice's: {NGSPICE_FORMS[kind]}"


def realise(el: Element, p: LineParameters, n: int) -> tuple[list[Element], list[str]]:
    """The elements that make the line ``el`` out of ``n`` sections, and its internal nodes.

    Parameters
    ----------
    el : Element
        The line (its name and nodes name the parts).
    p : LineParameters
    n : int
        Sections (:func:`section_count`).

    Returns
    -------
    elements : list of Element
        Resistors, capacitors, inductors, couplings and lossless lines named ``<line>#...``.
    nodes : list of str
        The internal nodes, ``<line>#...`` (inside a subcircuit with its path, as its other nodes).
    """
    parts = el.name.split(".")
    own = parts[-1]
    prefix = "".join(f"{q}." for q in parts[1:-1])
    made = _Builder(el, f"{prefix}{own}#")
    if p.kind == Kind.CPL:
        _modal(made, p, n)
    elif p.form == "rg":
        _rg(made, p)
    elif p.form == "rc":
        _rc(made, p, n)
    else:
        _lc(made, p, n)
    return made.elements, made.nodes


class _Builder:
    """Names and collects the parts of one line."""

    def __init__(self, el: Element, node_prefix: str) -> None:
        self.el, self.node_prefix = el, node_prefix
        self.elements: list[Element] = []
        self.nodes: list[str] = []

    def node(self, tag: str) -> str:
        name = f"{self.node_prefix}{tag}"
        self.nodes.append(name)
        return name

    def add(self, tag: str, kind: str, nodes: tuple, value: float | None = None, **kw) -> Element:
        part = Element(f"{self.el.name}#{tag}", kind, nodes, value=value, location=self.el.location,
                       instance_path=self.el.instance_path, **kw)
        self.elements.append(part)
        return part

    def shunt(self, tag: str, node: str, ref: str, g: float, c: float) -> None:
        if g > 0:
            self.add(f"g{tag}", "resistor", (node, ref), 1.0 / g)
        if c > 0:
            self.add(f"c{tag}", "capacitor", (node, ref), c)


def _lc(made: _Builder, p: LineParameters, n: int) -> None:
    """``n`` lossless lines, ``R/n`` and ``G/n`` lumped at the joints (half at each end).

    Each joint is symmetric, half its shunt on either side of its series resistance (the
    sections' trapezoidal lumps: a whole shunt on one side would err by ``R G len^2 / n^2`` per
    joint, first order in ``1 / n`` over the line).
    """
    a, ra, b, rb = made.el.nodes
    R, G = float(p.r[0, 0]) * p.length, float(p.g[0, 0]) * p.length
    z0, td = p.impedance, p.delay
    if R == 0 and G == 0:
        made.add("t1", "tline", (a, ra, b, rb), params={"z0": z0, "td": td})
        return
    node = a
    for k in range(n):
        weight = 0.5 if k == 0 else 1.0
        if R > 0:
            if k > 0:  # the joint's shunt split around its resistance: each section symmetric
                made.shunt(f"{k}w", node, ra, 0.5 * G / n, 0.0)
            into = made.node(f"u{k}")
            made.add(f"r{k}", "resistor", (node, into), weight * R / n)
            node = into
            made.shunt(str(k), node, ra, 0.5 * G / n, 0.0)
        else:
            made.shunt(str(k), node, ra, weight * G / n, 0.0)
        last = k == n - 1
        out = b if last and R == 0 else made.node(f"w{k + 1}")
        made.add(f"t{k + 1}", "tline", (node, ra, out, rb if last else ra), params={"z0": z0, "td": td / n})
        node = out
    made.shunt(str(n), node, rb, 0.5 * G / n, 0.0)
    if R > 0:
        made.add(f"r{n}", "resistor", (node, b), 0.5 * R / n)


def _rc(made: _Builder, p: LineParameters, n: int) -> None:
    """A ladder of ``n`` resistances ``R/n``, ``C`` and ``G`` lumped at the nodes (half at the ends)."""
    a, ra, b, rb = made.el.nodes
    R, G, C = (float(m[0, 0]) * p.length for m in (p.r, p.g, p.c))
    node = a
    for k in range(n + 1):
        weight = 0.5 if k in (0, n) else 1.0
        made.shunt(str(k), node, rb if k == n else ra, weight * G / n, weight * C / n)
        if k < n:
            nxt = b if k == n - 1 else made.node(f"u{k + 1}")
            made.add(f"r{k + 1}", "resistor", (node, nxt), R / n)
            node = nxt


def _rg(made: _Builder, p: LineParameters) -> None:
    """The RG line's exact T network."""
    a, ra, b, _ = made.el.nodes  # the shunt returns to the first port's reference
    R, G = float(p.r[0, 0]) * p.length, float(p.g[0, 0]) * p.length
    gamma, zc = math.sqrt(R * G), math.sqrt(R / G)
    mid = made.node("m")
    arm = zc * math.tanh(gamma / 2.0)
    made.add("r1", "resistor", (a, mid), arm)
    made.add("r2", "resistor", (mid, b), arm)
    made.add("g", "resistor", (mid, ra), zc / math.sinh(gamma))


#: Entries of a mode's voltage vector (scaled to a largest entry of 1) at or below this are rounding.
MODE_ROUNDING = 64.0 * np.finfo(float).eps


def modes(l: np.ndarray, c: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The propagation modes of coupled lossless lines: ``T_v``, the modes' ``L_m``, ``C_m``.

    With ``C = K K^T`` (Cholesky) and ``K^T L K = Q diag(lambda) Q^T``, the voltages
    ``v = T_v v_m`` and currents ``i = T_v^-T i_m`` with ``T_v = K^-T Q`` (columns scaled to
    a largest entry of 1) decouple the lines: ``L_m = T_v^-1 L T_v^-T`` and ``C_m = T_v^T C T_v``
    are diagonal (returned as their diagonals).
    """
    k = np.linalg.cholesky(c)
    _, q = np.linalg.eigh(k.T @ l @ k)
    tv = np.linalg.solve(k.T, q)
    tv = tv / np.max(np.abs(tv), axis=0)
    # an entry at the rounding of the column's largest (1) is an exact zero of the mode (a symmetric
    # line's odd mode on its middle conductor): kept, it would couple a floating conductor to the rest
    # by 1e-15 and make its DC matrix's rank a matter of the BLAS kernel's rounding
    tv[np.abs(tv) <= MODE_ROUNDING] = 0.0
    inv = np.linalg.inv(tv)
    return tv, np.diag(inv @ l @ inv.T).copy(), np.diag(tv.T @ c @ tv).copy()


def _transform(made: _Builder, tag: str, phys: list[str], modal: list[str], tv: np.ndarray, *,
               port: bool) -> None:
    """An ideal multiport transformer: ``v(phys) = T_v v(modal)``, ``i_modal = T_v^T i_phys``.

    On one side a 0 V source per line senses the current and a chain of VCVSs sets the voltage;
    on the other CCCSs carry the transformed currents. Next to a port (``port``) the VCVSs
    are on the modal side, so that the port's node sees only currents (a capacitor the
    circuit puts there closes no loop of voltage sources); inside the line they are on the
    physical side, so that every joint has a path to ground. The power entering one side
    leaves the other.
    """
    m = len(phys)
    if port:  # v(modal) = T_v^-1 v(phys); the physical nodes draw (T_v^-T i_modal)
        setters, takers, gains = modal, phys, np.linalg.inv(tv)
    else:  # v(phys) = T_v v(modal); the modal nodes receive T_v^T i_phys
        setters, takers, gains = phys, modal, tv
    senses = []
    for a in range(m):
        top = made.node(f"s{tag}_{a + 1}")
        senses.append(made.add(f"v{tag}_{a + 1}", "vsource", (setters[a], top), source=SourceSpec(dc=0.0)).name)
        for b in range(m):
            gain = float(gains[a, b])
            if gain == 0.0 and b < m - 1:
                continue
            below = "0" if b == m - 1 else made.node(f"e{tag}_{a + 1}_{b + 1}")
            made.add(f"e{tag}_{a + 1}_{b + 1}", "vcvs", (top, below, takers[b], "0"), gain)
            top = below
    for b in range(m):
        for a in range(m):
            gain = float(gains[a, b])
            if gain != 0.0:  # the current the setter side draws, delivered to (drawn from) the taker
                made.add(f"f{tag}_{b + 1}_{a + 1}", "cccs", (takers[b], "0"), -gain, controls=(senses[a],))


def _modal(made: _Builder, p: LineParameters, n: int) -> None:
    """Coupled lines: per section one lossless line per mode (:func:`modes`); the losses lumped
    at the joints, half at the ends (in the conductors, before the transformers that lead to the
    modes) and whole inside (in the modes: ``T_v^-1 R T_v^-T`` in series, ``T_v^T G T_v`` shunt,
    :func:`_modal_lump`, which is the two transformers and the conductors' lump between them)."""
    nodes = made.el.nodes
    m = p.conductors
    ins, outs = list(nodes[:m]), list(nodes[m + 1: 2 * m + 1])
    tv, lm, cm = modes(p.l, p.c)
    u = np.linalg.inv(tv)
    rm, gm = u @ p.r @ u.T, tv.T @ p.g @ tv
    z0, td = np.sqrt(lm / cm), p.length * np.sqrt(lm * cm) / n
    d = p.length / n
    first = [made.node(f"j{i + 1}_0") for i in range(m)]
    for i in range(m):
        made.add(f"r{i + 1}_0", "resistor", (ins[i], first[i]), 0.5 * float(p.r[i, i]) * d)
    _shunts(made, "0", first, 0.5 * p.g * d, None)
    left = [made.node(f"x{i + 1}_1") for i in range(m)]
    _transform(made, "a", first, left, tv, port=True)
    for k in range(1, n + 1):
        right = [made.node(f"y{i + 1}_{k}") for i in range(m)]
        for i in range(m):
            made.add(f"t{i + 1}_{k}", "tline", (left[i], "0", right[i], "0"),
                     params={"z0": float(z0[i]), "td": float(td[i])})
        if k == n:
            break
        left = [made.node(f"x{i + 1}_{k + 1}") for i in range(m)]
        _modal_lump(made, str(k), right, left, rm * d, gm * d)
    last = [made.node(f"h{i + 1}_{n}") for i in range(m)]
    _transform(made, "b", last, right, tv, port=True)
    for i in range(m):
        made.add(f"r{i + 1}_{n}", "resistor", (last[i], outs[i]), 0.5 * float(p.r[i, i]) * d)
    _shunts(made, str(n), last, 0.5 * p.g * d, None)  # inside the end's resistance, mirroring the start


def _modal_lump(made: _Builder, tag: str, a: list[str], b: list[str], rm: np.ndarray, gm: np.ndarray) -> None:
    """A series resistance matrix from ``a`` to ``b`` (0 V sensing sources and CCVS chains:
    ``v(a_i) - v(b_i) = sum_k rm[i, k] i_k``) and a shunt conductance matrix, half at ``a`` and
    half at ``b`` (VCCSs).

    The halves make the joint symmetric, as the sections are: a joint with the whole shunt on
    one side of the series resistance errs by ``R G len^2 / n^2``, and the ``n - 1`` joints add
    that up to a first-order error in ``1 / n``.
    """
    m = len(a)
    senses = []
    tops = []
    for i in range(m):
        top = made.node(f"s{tag}_{i + 1}")
        senses.append(made.add(f"v{tag}_{i + 1}", "vsource", (a[i], top), source=SourceSpec(dc=0.0)).name)
        tops.append(top)
    for i in range(m):
        top = tops[i]
        ks = [k for k in range(m) if rm[i, k] != 0.0] or [i]
        for n_k, k in enumerate(ks):
            below = b[i] if n_k == len(ks) - 1 else made.node(f"r{tag}_{i + 1}_{k + 1}")
            made.add(f"h{tag}_{i + 1}_{k + 1}", "ccvs", (top, below), float(rm[i, k]), controls=(senses[k],))
            top = below
        for k in range(m):
            if gm[i, k] != 0.0:  # half on each side of the series resistance: the joint symmetric
                made.add(f"g{tag}_{i + 1}_{k + 1}", "vccs", (b[i], "0", b[k], "0"), 0.5 * float(gm[i, k]))
                made.add(f"g{tag}a_{i + 1}_{k + 1}", "vccs", (a[i], "0", a[k], "0"), 0.5 * float(gm[i, k]))


def _shunts(made: _Builder, tag: str, at: list[str], g: np.ndarray, c: np.ndarray | None) -> None:
    """Maxwell matrices lumped at nodes: conductor i to ground ``sum_j M_ij``, i to j ``-M_ij``."""
    m = len(at)
    for i in range(m):
        made.shunt(f"{i + 1}_{tag}", at[i], "0", float(g[i].sum()), float(c[i].sum()) if c is not None else 0.0)
        for j in range(i + 1, m):
            gij = -float(g[i, j])
            cij = -float(c[i, j]) if c is not None else 0.0
            if gij != 0:
                made.add(f"g{i + 1}_{j + 1}_{tag}", "resistor", (at[i], at[j]), 1.0 / gij)
            if cij != 0:
                made.add(f"c{i + 1}_{j + 1}_{tag}", "capacitor", (at[i], at[j]), cij)
