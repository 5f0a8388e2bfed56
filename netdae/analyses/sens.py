"""Sensitivity analysis (``.sens outvar [dc]``, ``.sens outvar ac dec|oct|lin n fstart fstop``).

The derivative of one output (``v(a)``, ``v(a,b)`` or ``i(vsrc)``) with
respect to every parameter ngspice 39 perturbs: element values, their
multipliers, source values and AC magnitudes, and the model and instance
parameters of diodes, BJTs, MOSFETs (level 1) and JFETs. Not normalised:
``d out / d p`` in the output's unit per the parameter's unit, as ngspice.

Method (adjoint, at the operating point ``x`` of the unperturbed circuit,
which stays fixed, as in ngspice's ``cktsens.c``):

DC
    ``phi(x, p) = 0`` defines ``x(p)``; ``dx/dp = -H^-1 dphi/dp`` with
    ``H = dphi/dx`` the DC Jacobian, so with the adjoint ``H^T w = c``
    (``c`` selects the output) ``d out/dp = -w . dphi/dp``: one solve for
    every parameter.
AC
    ``Y X = b`` with ``Y = j w E - H_ac`` at the operating point; ``dX/dp =
    Y^-1 (db/dp - dY/dp X)``, and with ``Y^T w = c`` (one solve per
    frequency) ``d out/dp = w . (db/dp - dY/dp X)``, complex. The operating
    point is not re-solved (a DC source's value has sensitivity 0 here).

``dphi/dp``, ``dE/dp``, ``dH/dp`` and ``db/dp`` are the element's own
stamp and device evaluation at ``x``: the circuit is assembled with the
parameter at ``p +- h`` and evaluated at the fixed ``x`` (one owner of every
stamp and device equation; no second model of them). ``h`` is
:data:`RELATIVE_STEP` times ``|p|`` (a temperature's in kelvin), central
differences: the truncation error is ``O(h^2)``, about ``1e-12``
relative, none for the linear elements (their residual is linear in
``1/R``, ``C``, a source value...), and the rounding of the difference
about ``eps / h``, 1e-10 relative (measured on a divider and an RC against
their closed forms: 1.7e-10 and 6e-11). ngspice's own one-sided difference
leaves about ``1e-6`` relative. A parameter that is zero is stepped
forward by :data:`ABSOLUTE_STEP`, as ngspice steps it.

Which parameters, and their names (ngspice 39, measured):

=================  ===========================================  ==========================
element            DC                                           AC adds
=================  ===========================================  ==========================
R                  ``r1`` ``r1_m`` ``r1_scale`` ``r1_l``        ``r1_ac``
                   ``r1_w`` ``r1_bv_max`` ``r1:bv_max``
                   ``r1:ef`` ``r1:lf`` ``r1:wf``
C                  ``c1_m`` ``c1_scale`` ``c1_bv_max``          ``c1`` ``c1_w``
                   ``c1:bv_max``
L                  ``l1_m`` ``l1_scale``                        ``l1`` ``l1:mu``
K                  --                                           ``k1``
V, I               ``v1``; ``i1`` ``i1_m``                      ``v1_acmag``, ``i1_acmag``
E F G H            ``e1_gain``                                  --
D Q M J            the model's parameters as ``d1:is`` (the     the given charge
                   model perturbed for that instance alone),    parameters (``d1:cjo``,
                   instance ones as ``d1_area``, ``d1_temp``    ``q1:cje``, ``m1:cgso``)
=================  ===========================================  ==========================

Noise and safe-operating-area parameters (``bv_max``, ``ef``, ``lf``,
``wf``, ``af``, ``kf``...) do not enter the solution: their sensitivity is 0,
as ngspice's. A parameter ngspice lists that netdae does not implement, or
whose change changes the circuit's unknowns (a series resistance that is
zero: an internal node would appear), is reported as NaN with a note naming
it, never dropped.
"""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..circuit import ABSOLUTE_ZERO, AcAnalysis, Circuit, Element, SensAnalysis
from ..devices.model_names import SENS_AC_ONLY, SENS_MODEL_PARAMETERS, SENS_SPELLING
from ..errors import CircuitError, NetdaeError
from ..kinds import KINDS, Kind, resolve
from ..results import Result, Statistics
from .op import op_result
from .tf import output_selector

__all__ = ["sens_analysis", "sens_parameters", "SensParameter", "RELATIVE_STEP", "ABSOLUTE_STEP"]

#: Central-difference step relative to the parameter's value (its kelvin value for a temperature).
RELATIVE_STEP = 1e-6
#: Forward step of a parameter whose value is zero (ngspice's ``Sens_Abs_Delta``).
ABSOLUTE_STEP = 1e-6
_KELVIN = -ABSOLUTE_ZERO

_INERT = "noise and safe-operating-area parameters"


@dataclass(frozen=True)
class SensParameter:
    """One parameter of a sensitivity analysis.

    Attributes
    ----------
    name : str
        ngspice's name (``r1``, ``r1_m``, ``d1:is``, ``q1_area``).
    element : str
        The element it belongs to.
    how : str
        ``"value"``, ``"param:<key>"`` (an instance parameter), ``"model:<key>"``,
        ``"dc"``, ``"ac"``, ``"source_m"``, ``"inert"`` (no effect: 0) or
        ``"absent"`` (not computed: NaN, ``why`` says why).
    base : float
        Its value in the circuit (a temperature in degC).
    kelvin : bool
        A temperature: stepped relative to its kelvin value.
    why : str
        For ``"inert"`` and ``"absent"``: the reason.
    """

    name: str
    element: str
    how: str
    base: float = 0.0
    kelvin: bool = False
    why: str = ""


def _table(kind: str):
    """The :class:`~netdae.devices.modelcard.ParameterTable` of a device kind (``ElementKind.parameters``)."""
    return resolve(KINDS[kind].parameters)


def _canonical(table, name: str) -> str:
    return table.aliases.get(name, name)


def _model_parameters(circuit: Circuit, el: Element, ac: bool) -> list[SensParameter]:
    model = circuit.models[el.model]
    family = el.kind
    table = _table(family)
    spelling = SENS_SPELLING.get(family, {})
    back = {v: k for k, v in spelling.items()}
    given = {_canonical(table, k): v for k, v in model.params.items()}
    names = [_canonical(table, back.get(n, n)) for n in SENS_MODEL_PARAMETERS[family]]
    for key in given:  # the equation selectors (integers) are not listed by ngspice
        if key in names or key in ("level", "tlev") or key in table.inert and key not in names:
            continue
        if key in SENS_AC_ONLY[family] and not ac:
            continue
        if key in table.defaults:
            names.append(key)
    out = []
    temp_defaults = {"tnom": circuit.options.tnom}
    for key in names:
        shown = f"{el.name}:{spelling.get(key, key)}"
        if key in table.inert:
            out.append(SensParameter(shown, el.name, "inert", why=_INERT))
            continue
        if key not in table.defaults:
            out.append(SensParameter(shown, el.name, "absent", why=f"not implemented by netdae's {table.device}"))
            continue
        base = given.get(key, table.defaults[key])
        if base is None:
            base = temp_defaults.get(key)
        if base is None and key in ("rbm", "nbv"):  # their defaults: rb, n
            other = "rb" if key == "rbm" else "n"
            base = given.get(other, table.defaults[other])
        if base is None:
            out.append(SensParameter(shown, el.name, "absent", why="no value in the model and no default"))
            continue
        out.append(SensParameter(shown, el.name, f"model:{key}", float(base), kelvin=key == "tnom"))
    for suffix, _, _ in KINDS[family].sens:
        out.append(_instance_parameter(circuit, el, suffix[1:]))
    return out


def _instance_parameter(circuit: Circuit, el: Element, key: str) -> SensParameter:
    p = el.params
    if key == "temp":
        base = p["temp"] if "temp" in p else circuit.options.temp + p.get("dtemp", 0.0)
        return SensParameter(f"{el.name}_temp", el.name, "param:temp", float(base), kelvin=True)
    if key in ("l", "w"):
        from ..devices.mosfet import DEFAULT_L, DEFAULT_W

        default = circuit.options.extra.get("defl" if key == "l" else "defw", DEFAULT_L if key == "l" else DEFAULT_W)
        return SensParameter(f"{el.name}_{key}", el.name, f"param:{key}", float(p.get(key, default)))
    if key in ("areab", "areac"):
        return SensParameter(f"{el.name}_{key}", el.name, f"param:{key}", float(p.get(key, p.get("area", 1.0))))
    if key == "area" and "area" not in p:  # the model's area where it has one (diodes, JFETs), else 1
        model = circuit.models.get(el.model or "")
        area = model.params.get("area", 1.0) if model is not None else 1.0
        return SensParameter(f"{el.name}_area", el.name, "param:area", float(area))
    default = {"m": 1.0, "nrd": 1.0, "nrs": 1.0, "area": 1.0}[key]
    return SensParameter(f"{el.name}_{key}", el.name, f"param:{key}", float(p.get(key, default)))


def sens_parameters(circuit: Circuit, ac: bool = False) -> tuple[list[SensParameter], list[str]]:
    """The parameters a sensitivity analysis reports, named as ngspice 39 names them.

    Parameters
    ----------
    circuit : Circuit
    ac : bool
        The AC sensitivity (it lists the AC values and the charge parameters too).

    Returns
    -------
    parameters : list of SensParameter
        Sorted by name, as ngspice's vectors are listed.
    notes : list of str
        Elements whose parameters are not listed (kinds netdae has no
        sensitivity of), one note each.

    Examples
    --------
    >>> from netdae.circuit import Circuit, Element, SourceSpec
    >>> ckt = Circuit("d", nodes=["1"], elements=[Element("i1", "isource", ("0", "1"), source=SourceSpec(dc=1.0)),
    ...                                           Element("r1", "resistor", ("1", "0"), 1e3)])
    >>> [p.name for p in sens_parameters(ckt)[0]]
    ['i1', 'i1_m', 'r1', 'r1:bv_max', 'r1:ef', 'r1:lf', 'r1:wf', 'r1_bv_max', 'r1_l', 'r1_m', 'r1_scale', 'r1_w']
    """
    out: list[SensParameter] = []
    notes: list[str] = []
    for el in circuit.elements:
        kind = KINDS[el.kind]
        if kind.sens and kind.parameters is None:
            for suffix, how, ac_only in kind.sens:
                if ac_only and not ac:
                    continue
                name = el.name + suffix
                if how == "inert":
                    out.append(SensParameter(name, el.name, how, why=_INERT))
                elif how == "geometry":
                    if el.model is None:
                        out.append(SensParameter(name, el.name, "inert",
                                                 why="geometry of an element without a model"))
                    else:
                        out.append(SensParameter(name, el.name, "absent", why="the value is computed from the "
                                                 "model once, when the circuit is read"))
                elif how == "value":
                    out.append(SensParameter(name, el.name, how, float(el.value if el.value is not None else 0.0)))
                elif how.startswith("param:"):
                    key = how[6:]
                    default = el.value if key == "ac" else 1.0
                    out.append(SensParameter(name, el.name, how, float(el.params.get(key, default))))
                elif how == "dc":
                    out.append(SensParameter(name, el.name, how, float(el.source.dc_value())))
                elif how == "ac":
                    out.append(SensParameter(name, el.name, how, float(el.source.ac_mag)))
                else:  # source_m
                    out.append(SensParameter(name, el.name, how, 1.0))
            if el.kind == Kind.RESISTOR:
                out.extend(_temperature_coefficients(circuit, el))
        elif kind.parameters is not None:
            model = circuit.models.get(el.model or "")
            if model is None or el.kind == Kind.MOSFET and int(model.params.get("level", 1.0)) != 1:
                where = f"{el.location}: " if el.location else ""
                notes.append(f"{where}{el.name}: netdae computes the sensitivities of level-1 MOSFETs only "
                             "(ngspice lists this one's parameters)")
                continue
            if el.kind not in SENS_MODEL_PARAMETERS:
                where = f"{el.location}: " if el.location else ""
                notes.append(f"{where}{el.name}: netdae computes no sensitivities to the model parameters of a "
                             f"{el.kind} (ngspice lists them)")
                continue
            out.extend(_model_parameters(circuit, el, ac))
        else:
            where = f"{el.location}: " if el.location else ""
            notes.append(f"{where}{el.name}: netdae computes no sensitivity of {el.kind} parameters (ngspice may "
                         "list some)")
    out.sort(key=lambda p: p.name)
    return out, notes


def _temperature_coefficients(circuit: Circuit, el: Element) -> list[SensParameter]:
    """A resistor's ``tc1`` and ``tc2`` given on its card, as ngspice 39 lists them (``r1_tc``, ``r1_tc2``).

    ngspice lists an instance's temperature coefficients where the card gives them; a value
    that comes from the resistor's model (the same in both) is not an instance parameter.
    """
    model = circuit.models.get(el.model or "")
    out = []
    for key, suffix in (("tc1", "_tc"), ("tc2", "_tc2")):
        if key in el.params and not (model is not None and model.params.get(key) == el.params[key]):
            out.append(SensParameter(el.name + suffix, el.name, "param:" + key, float(el.params[key])))
    return out


def _perturbed(circuit: Circuit, p: SensParameter, value: float) -> Circuit:
    """A copy of ``circuit`` with parameter ``p`` set to ``value`` (a model parameter for that instance alone)."""
    elements = list(circuit.elements)
    k = next(i for i, el in enumerate(elements) if el.name == p.element)
    el = elements[k]
    new = dataclasses.replace(el, params=dict(el.params))
    models = circuit.models
    how = p.how
    if how == "value":
        new.value = value
    elif how.startswith("param:"):
        new.params[how[6:]] = value
    elif how in ("dc", "ac", "source_m"):
        spec = dataclasses.replace(el.source)
        if how == "dc":
            spec.dc = value
        elif how == "ac":
            spec.ac_mag = value
        else:
            spec.dc = el.source.dc_value() * value
            spec.ac_mag = el.source.ac_mag * value
        new.source = spec
    else:  # model:<key>
        key = how[6:]
        model = circuit.models[el.model]
        table = _table(el.kind)
        params = {k: v for k, v in model.params.items() if _canonical(table, k) != key}
        params[key] = value
        copy = dataclasses.replace(model, name=f"{model.name}~{el.name}", params=params)
        models = {**circuit.models, copy.name: copy}
        new.model = copy.name
    elements[k] = new
    return dataclasses.replace(circuit, elements=elements, models=models)


@dataclass
class _Evaluation:
    phi: np.ndarray
    E: sp.spmatrix | None
    H: sp.spmatrix | None
    b: np.ndarray | None


def _evaluate(circuit: Circuit, x: np.ndarray, names: tuple, ac: bool) -> _Evaluation:
    from ..mna import MODE_DC, assemble

    system = assemble(circuit, mode=MODE_DC)
    if tuple(system.names) != tuple(names):
        raise _Structural()
    steady = system.steady_form()
    ev = steady.evaluate(x, 0.0, jacobian=ac)
    if not ac:
        return _Evaluation(ev.phi, None, None, None)
    E = steady.pattern.matrix(ev.dq.copy())
    H = steady.pattern.matrix(ev.dphi.copy()) + system.H_ac
    return _Evaluation(ev.phi, E, H, system.B @ system.sources.ac)


class _Structural(Exception):
    """The perturbed circuit has other unknowns."""


def _step(p: SensParameter) -> tuple[float, bool]:
    """The step of ``p`` and whether it is central."""
    if p.kelvin:
        return RELATIVE_STEP * (p.base + _KELVIN), True
    if p.base == 0.0:
        return ABSOLUTE_STEP, False
    return RELATIVE_STEP * abs(p.base), True


def sens_analysis(circuit: Circuit, card: SensAnalysis, **overrides) -> Result:
    """Run a ``.sens`` analysis.

    Parameters
    ----------
    circuit : Circuit
    card : SensAnalysis
    **overrides
        Operating-point tolerances (``reltol``, ...).

    Returns
    -------
    Result
        ``analysis == "sens"``; one signal per parameter named as ngspice
        names it (:func:`sens_parameters`): one real value for the DC
        sensitivity, complex values over the axis ``frequency`` [Hz] for the
        AC one. NaN where netdae does not compute the parameter (a note says
        why); ``operating_point`` the operating point, ``card`` the card.

    Raises
    ------
    CircuitError, ConvergenceError
        No operating point, or a singular DC matrix (with its reason).
    """
    from .ac import frequencies, linearize

    t0 = time.perf_counter()
    lin = linearize(circuit, **overrides)
    system = lin.system
    if system.delays is not None:
        raise CircuitError(".sens: netdae computes no sensitivity of a circuit with transmission lines",
                           hint="simulate the sensitivity in ngspice")
    x = lin.op.x
    c, _ = output_selector(system, card.output)
    params, notes = sens_parameters(circuit, card.is_ac)
    notes = list(system.notes) + notes
    ac = card.is_ac
    if ac:
        freqs = frequencies(AcAnalysis(card.variation, card.points, card.fstart, card.fstop))
        E0, H0 = lin.E, lin.H_ac
        b0 = system.B @ system.sources.ac
        Y = [sp.csc_matrix(2j * math.pi * f * E0 - H0, dtype=complex) for f in freqs]
        try:
            lus = [spla.splu(y) for y in Y]
        except RuntimeError:
            raise CircuitError(".sens: the AC matrix is singular at a frequency of the sweep",
                               hint="a node without a path to ground at that frequency") from None
        X = np.array([lu.solve(b0.astype(complex)) for lu in lus])
        W = np.array([lu.solve(c.astype(complex), trans="T") for lu in lus])
    else:
        try:
            lu = spla.splu(sp.csc_matrix(lin.H, dtype=float))
        except RuntimeError:
            from ..topology import dc_singularity_explanation

            why = dc_singularity_explanation(circuit)
            if why is not None:
                raise CircuitError(f".sens: the DC matrix is singular: {why.message}", elements=why.elements,
                                   nodes=why.nodes, hint=why.hint) from None
            raise CircuitError(".sens: the DC matrix of the linearised circuit is singular",
                               hint="a node without a DC path to ground, or a loop of voltage sources") from None
        w = lu.solve(c, trans="T")
    base = None
    signals: dict[str, np.ndarray] = {}
    absent: dict[str, list[str]] = {}
    inert: dict[str, list[str]] = {}
    for p in params:
        if p.how in ("inert", "absent"):
            shape = freqs.size if ac else 1
            value = 0.0 if p.how == "inert" else math.nan
            signals[p.name] = np.full(shape, value, dtype=complex if ac else float)
            (inert if p.how == "inert" else absent).setdefault(p.why, []).append(p.name)
            continue
        h, central = _step(p)
        try:
            plus = _evaluate(_perturbed(circuit, p, p.base + h), x, system.names, ac)
            if central:
                minus = _evaluate(_perturbed(circuit, p, p.base - h), x, system.names, ac)
                width = 2.0 * h
            else:
                if base is None:
                    base = _evaluate(circuit, x, system.names, ac)
                minus, width = base, h
        except _Structural:
            absent.setdefault("changing it changes the circuit's unknowns: an internal node appears or vanishes; "
                              "ngspice keeps the nodes it set up", []).append(p.name)
            signals[p.name] = np.full(freqs.size if ac else 1, math.nan, dtype=complex if ac else float)
            continue
        except (CircuitError, NetdaeError, ValueError) as exc:
            absent.setdefault(f"the circuit cannot be built with it changed: {exc}", []).append(p.name)
            signals[p.name] = np.full(freqs.size if ac else 1, math.nan, dtype=complex if ac else float)
            continue
        if not ac:
            dphi = (plus.phi - minus.phi) / width
            signals[p.name] = np.array([-float(w @ dphi)])
        else:
            dE = (plus.E - minus.E) / width
            dH = (plus.H - minus.H) / width
            db = (plus.b - minus.b) / width
            # w_f . (db - (j w_f dE - dH) X_f) for every frequency f at once
            rhs = db[:, None] - (2j * math.pi * freqs) * (dE @ X.T) + dH @ X.T
            signals[p.name] = np.einsum("fn,nf->f", W, rhs)
    at = f"{card.location}: " if card.location else ""
    for why, names in inert.items():
        notes.append(f"{at}sensitivity 0, {why} (no effect on the solution; ngspice's is 0 too): {', '.join(names)}")
    for why, names in absent.items():
        notes.append(f"{at}not computed (NaN), {why}: {', '.join(names)}")
    return Result(
        "sens",
        axes={"frequency": freqs} if ac else {},
        signals=signals,
        stats=Statistics(points=int(freqs.size) if ac else 1, wall_time=time.perf_counter() - t0,
                         newton_iterations=lin.op.iterations, **system.describe()),
        message="ok",
        tolerances={"reltol": lin.options.reltol, "vntol": lin.options.vntol, "abstol": lin.options.abstol},
        notes=notes,
        operating_point=op_result(system, lin.op, 0.0, lin.options), card=card,
    )
