"""Transient source functions: PULSE, SIN, EXP, PWL, SFFM, AM, TRNOISE, TRRANDOM, as ngspice.

Each waveform is built from the numbers written on the card (``None`` for a
parameter not given). Several ngspice defaults depend on the ``.tran`` step
TSTEP and stop time TSTOP; :meth:`Waveform.resolved` fills them in:

========  ============================================  =====================================
kind      parameters (ngspice order)                    defaults (a 0 counts as "not given"*)
========  ============================================  =====================================
PULSE     v1 v2 td tr tf pw per np                      td 0; tr*, tf* TSTEP; pw*, per* TSTOP;
                                                        np (number of pulses) 0 = unlimited
SIN       vo va freq td theta phase                     freq* 1/TSTOP; td, theta, phase 0
EXP       v1 v2 td1 tau1 td2 tau2                       td1*, tau1*, tau2* TSTEP; td2* td1+TSTEP
SFFM      vo va fc mdi fs phasec phases                 fc*, fs* 1/TSTOP; mdi, phases 0
AM        va vo mf fc td phasec phases                  mf* 1/TSTOP; fc, td, phases 0
PWL       t1 v1 t2 v2 ... [r=trep] [td=delay]           no repeat, no delay
TRNOISE   na nt nalpha namp rtsam rtscapt rtsemt        all 0 (no such part)
TRRANDOM  type ts td param1 param2                      td 0, param1 1, param2 0
========  ============================================  =====================================

Formulas (time ``t``; phases in degrees) as in ngspice 39 ``vsrcload.c``:

- PULSE: ``tau = t - td``; after ``np`` pulses (``t > td + np*per``, inside the
  last pulse when ``np`` is fractional: a breakpoint) the value is v1; else ``tau`` is reduced modulo ``per`` when ``tau > per``; v1 for
  ``tau <= 0`` or ``tau >= tr+pw+tf``, v2 on ``[tr, tr+pw]``, linear ramps
  in between. The period a time lies in is the ``k`` with ``td + k*per <= t < td + (k+1)*per``
  computed as the breakpoints are (:func:`pulse_period`): where a pulse outlasts its period the
  value jumps at ``td + k*per``, and it must jump exactly at that breakpoint (``floor(tau/per)``
  alone puts it a few ulps to either side, and a step landing on the breakpoint would see the
  jump inside it).
- SIN: ``vo + va*sin(phase)`` for ``t <= td``, else
  ``vo + va*sin(2 pi freq (t-td) + phase) * exp(-theta (t-td))``.
- EXP: v1 up to td1, then ``+ (v2-v1)(1 - exp(-(t-td1)/tau1))`` up to td2,
  then additionally ``+ (v1-v2)(1 - exp(-(t-td2)/tau2))``.
- SFFM: ``vo + va*sin(2 pi fc t + phasec + mdi*sin(2 pi fs t + phases))``.
- AM: 0 for ``t <= td``, else
  ``va*(vo + sin(2 pi mf tau + phases))*sin(2 pi fc tau + phases)``,
  ``tau = t - td``. (ngspice 39 uses ``phases`` for the carrier too and
  ignores ``phasec``; netdae does the same so that both agree.)
- PWL: ``tau = t - td``; the first value before the first point, the last
  after the last point, linear in between; at a time listed twice (a step)
  the first value is taken at that instant. With ``r=trep`` the part from
  the point at ``trep`` to the last point repeats for ever (``trep`` must be
  one of the time points); at the end of the list the repeat starts at once.

- TRNOISE, TRRANDOM (:class:`RandomSource`): random functions drawn once
  for the whole transient from the source's seeded stream, and returned by
  ``resolved`` as the PWL of their realisation (:class:`Trnoise`,
  :class:`Trrandom`; the card's DC value is added, as ngspice does).

:meth:`Waveform.derivative` gives exact derivatives of any order (closed
forms; SFFM by the Leibniz recurrence of sin/cos of the phase), and at a
corner the one-sided derivative valid just after ``t``. Times within a
relative :data:`CORNER_RTOL` of a corner count as on it, so that a time
returned by :meth:`Waveform.breakpoints` lands on its corner despite
rounding.

:class:`SourceBank` evaluates many waveforms at one time with one numpy
call per waveform class, for the MNA source vector ``c(t)``.

Examples
--------
>>> p = Pulse(0, 1, 1, 0.5, 0.5, 2, 4).resolved(0.01, 10)
>>> p.value([0, 1.25, 2, 3.75, 5.25]).tolist()
[0.0, 0.5, 1.0, 0.5, 0.5]
>>> p.derivative([1, 1.5, 3.5, 4]).tolist()
[2.0, 0.0, -2.0, 0.0]
>>> p.breakpoints(0, 6).tolist()
[1.0, 1.5, 3.5, 4.0, 5.0, 5.5]
"""

from __future__ import annotations

import bisect
import math
from typing import ClassVar, Sequence

import numpy as np

__all__ = [
    "CORNER_RTOL",
    "Waveform",
    "Pulse",
    "Sin",
    "Exp",
    "Pwl",
    "Sffm",
    "Am",
    "RandomSource",
    "Trnoise",
    "Trrandom",
    "flicker_noise",
    "MAX_RANDOM_POINTS",
    "WAVEFORMS",
    "SourceBank",
]

#: Relative distance (to max(|t|, the waveform's time scale)) within which a
#: time is taken to be on a corner: breakpoints computed as td + k*per + tr
#: differ from the corner found by reducing t modulo per by a few ulps.
CORNER_RTOL = 1e-12

#: A PWL time within this many ulps of a point is on the point (ngspice's AlmostEqualUlps).
_PWL_EQUAL_ULPS = 3
#: Longest PWL whose points the scalar kernel reads as Python lists.
_PWL_LIST_POINTS = 4096

_TWO_PI = 2.0 * math.pi
_DEG = math.pi / 180.0


def _overflowing(fn, x: float) -> float:
    """``fn(x)`` (``math.exp``, ``math.expm1``), infinity where it overflows, as the waveforms' numpy forms
    give (``math`` raises): a SIN whose damping factor is negative grows, and ``theta = -1e9`` passes 1e308
    within a microsecond."""
    try:
        return fn(x)
    except OverflowError:
        return math.inf


def _as_times(t) -> tuple[np.ndarray, tuple]:
    arr = np.asarray(t, dtype=float)
    return arr.reshape(-1), arr.shape


def _shape_out(values: np.ndarray, shape: tuple):
    out = values.reshape(shape)
    return float(out) if shape == () else out



def _check_span(tstep: float, tstop: float) -> None:
    """The ``.tran`` step and stop time a waveform is resolved for must be positive.

    Raises
    ------
    ValueError
    """
    if not (tstep > 0 and tstop > 0):
        raise ValueError(f"tstep and tstop must be > 0, got {tstep}, {tstop}")

class Waveform:
    """Base class: a transient function with ngspice's parameters and defaults.

    Parameters
    ----------
    *args : float or None
        The numbers written on the card, in ngspice's order; ``None`` (or
        fewer arguments) for parameters not given.

    Raises
    ------
    ValueError
        Too few or too many parameters, or values ngspice would misread
        (negative times); the message names the parameter.
    """

    #: Lower-case name as written on a card.
    kind: ClassVar[str] = ""
    #: Parameter names in card order.
    names: ClassVar[tuple[str, ...]] = ()
    #: Number of parameters that must be given.
    required: ClassVar[int] = 2

    def __init__(self, *args: float | None) -> None:
        if len(args) < self.required:
            raise ValueError(
                f"{self.kind.upper()} needs at least {self.required} parameters "
                f"({' '.join(self.names[:self.required])}), got {len(args)}"
            )
        if len(args) > len(self.names):
            raise ValueError(
                f"{self.kind.upper()} takes at most {len(self.names)} parameters "
                f"({' '.join(self.names)}), got {len(args)}"
            )
        self.given = tuple(None if a is None else float(a) for a in args) + (None,) * (
            len(self.names) - len(args)
        )
        self._check()
        self._P: np.ndarray | None = None
        self.tstep: float | None = None
        self.tstop: float | None = None

    def _check(self) -> None:
        """Validate the given parameters (raise ValueError)."""

    def _arg(self, i: int, default: float, zero_is_default: bool = False) -> float:
        v = self.given[i]
        if v is None or (zero_is_default and v == 0.0):
            return default
        return v

    # -- resolution -------------------------------------------------------
    @property
    def is_resolved(self) -> bool:
        """True when every parameter has a value (see :meth:`resolved`)."""
        return self._P is not None

    def determined_at(self, t: float) -> bool:
        """True when the value at time ``t`` does not wait for the TSTEP/TSTOP defaults.

        Always true once resolved; before, true up to the waveform's start
        (a negative delay moves that start before t = 0, and then even the
        value at t = 0 depends on defaults such as PULSE's period).
        """
        return self._P is not None or t <= self._safe_until()

    def resolved(self, tstep: float, tstop: float) -> "Waveform":
        """A copy with ngspice's TSTEP/TSTOP-dependent defaults filled in.

        Parameters
        ----------
        tstep, tstop : float
            The ``.tran`` step and stop time [s], both > 0.

        Returns
        -------
        Waveform
        """
        _check_span(tstep, tstop)
        new = object.__new__(type(self))
        new.__dict__.update(self.__dict__)
        new.tstep, new.tstop = float(tstep), float(tstop)
        new._P = np.array(self._resolve(new.tstep, new.tstop), dtype=float)[:, None]
        return new

    def _resolve(self, tstep: float, tstop: float) -> list[float]:
        raise NotImplementedError

    def _safe_until(self) -> float:
        """Time up to which the value does not depend on TSTEP/TSTOP defaults."""
        return math.inf

    def _params(self) -> np.ndarray:
        """Parameter column (nparams, 1) for the kernels."""
        return self._P

    # -- evaluation -------------------------------------------------------
    def value(self, t):
        """Value at time(s) ``t``.

        Parameters
        ----------
        t : float or array_like
            Times [s].

        Returns
        -------
        float or ndarray
            Same shape as ``t``.

        Raises
        ------
        ValueError
            When the waveform is not resolved and a value at ``t`` depends
            on TSTEP/TSTOP (values up to the start of the waveform do not,
            so ``value(0.0)`` works unless a negative delay starts the
            waveform before t = 0: :meth:`determined_at`).
        """
        tt, shape = _as_times(t)
        if self._P is None:
            if tt.size and float(np.max(tt)) > self._safe_until():
                raise ValueError(
                    f"{self.kind.upper()}: the value at t={float(np.max(tt)):g} depends on the "
                    ".tran step/stop defaults; call resolved(tstep, tstop) first"
                )
            P = np.array(self._resolve(1.0, 1.0), dtype=float)[:, None]
        else:
            P = self._params()
        return _shape_out(self._value(P, tt), shape)

    def derivative(self, t, order: int = 1):
        """Exact ``order``-th time derivative, one-sided (just after ``t``) at corners.

        Parameters
        ----------
        t : float or array_like
        order : int
            >= 1.

        Returns
        -------
        float or ndarray
        """
        if order < 1:
            raise ValueError(f"order must be >= 1, got {order}")
        self._require_resolved("derivative")
        tt, shape = _as_times(t)
        return _shape_out(self._derivative(self._params(), tt, int(order)), shape)

    def breakpoints(self, t0: float, t1: float) -> np.ndarray:
        """Sorted times in ``[t0, t1]`` where the waveform or a derivative jumps.

        Returns
        -------
        ndarray, shape (m,)
        """
        self._require_resolved("breakpoints")
        return _finish_breakpoints(self._breakpoints(self._params(), float(t0), float(t1)), t0, t1)

    def _require_resolved(self, what: str) -> None:
        if self._P is None:
            raise ValueError(f"{self.kind.upper()}.{what}() needs resolved(tstep, tstop) first")

    # -- kernels, vectorised over sources (columns of P) and times ------------
    @staticmethod
    def _value(P, t):
        raise NotImplementedError

    @staticmethod
    def _derivative(P, t, order):
        raise NotImplementedError

    @staticmethod
    def _breakpoints(P, t0, t1):
        raise NotImplementedError

    #: Scalar twin of ``_value`` for a single waveform at a scalar time,
    #: ``_value_scalar(p, t) -> float`` with ``p`` the tuple of parameters
    #: (None: the class has none and :class:`SourceBank` uses ``_value``).
    #: The same operations in the same order on Python floats: the results
    #: agree with ``_value`` to the last bit up to the last-ulp differences
    #: between libm and numpy's sin/exp.
    _value_scalar = None

    def _scalar_params(self) -> tuple:
        """Parameters for ``_value_scalar``."""
        return tuple(float(v) for v in self._P[:, 0])

    @classmethod
    def _stack(cls, waveforms: Sequence["Waveform"]):
        """Parameters of several resolved waveforms side by side."""
        return np.concatenate([w._P for w in waveforms], axis=1)

    def __repr__(self) -> str:
        shown = ", ".join(f"{n}={v:g}" for n, v in zip(self.names, self.given) if v is not None)
        state = f", tstep={self.tstep:g}, tstop={self.tstop:g}" if self._P is not None else ""
        return f"{type(self).__name__}({shown}{state})"

    def __eq__(self, other) -> bool:
        return type(other) is type(self) and self.given == other.given and (
            self.tstep, self.tstop) == (other.tstep, other.tstop)

    __hash__ = None


def _finish_breakpoints(points: np.ndarray, t0: float, t1: float) -> np.ndarray:
    points = np.asarray(points, dtype=float).reshape(-1)
    points = points[(points >= t0) & (points <= t1)]
    return np.unique(points)


def pulse_period(t, td, per):
    """The period of a pulse train that time ``t`` lies in, in the breakpoints' arithmetic.

    Parameters
    ----------
    t, td, per : float or ndarray
        Times, the delay and the period (broadcast together; ``per > 0``).

    Returns
    -------
    k : float or ndarray
        ``k`` with ``td + k*per <= t < td + (k+1)*per``, each bound computed in floating point as
        :meth:`Pulse._breakpoints` computes the corners (``floor((t - td)/per)`` corrected by one
        where rounding puts it in the neighbouring period); except that the first period ends
        at ``td + per`` inclusive, as in ngspice (``tau`` is reduced only when ``tau > per``: a
        pulse cut by its period, ``PULSE(-1 2)`` with ``per = tstop``, is ``v2`` at that instant).
    """
    k = np.floor((t - td) / per)
    k = np.where(td + k * per > t, k - 1.0, k)
    k = np.where(td + (k + 1.0) * per <= t, k + 1.0, k)
    return np.where((k == 1.0) & (t == td + per), 0.0, k)


def _pulse_phase_scalar(t, td, per):
    """Scalar :func:`pulse_period`: the time since the start of ``t``'s period (``t - td`` in the first)."""
    k = math.floor((t - td) / per)
    if td + k * per > t:
        k -= 1
    elif td + (k + 1) * per <= t:
        k += 1
    return t - td if k <= 0 or (k == 1 and t == td + per) else t - (td + k * per)


def _snap(x: np.ndarray, corner, scale) -> np.ndarray:
    """``x`` moved onto ``corner`` where it is within the corner tolerance."""
    return np.where(np.abs(x - corner) <= CORNER_RTOL * scale, corner, x)


# ---------------------------------------------------------------------------
class Pulse(Waveform):
    """``PULSE(v1 v2 [td [tr [tf [pw [per [np]]]]]])``: trapezoidal pulse train."""

    kind = "pulse"
    names = ("v1", "v2", "td", "tr", "tf", "pw", "per", "np")

    def _check(self) -> None:
        for i in (3, 4, 5, 6, 7):
            v = self.given[i]
            if v is not None and v < 0:
                raise ValueError(f"PULSE {self.names[i]} must be >= 0, got {v:g}")

    def _resolve(self, tstep, tstop):
        return [
            self._arg(0, 0.0), self._arg(1, 0.0), self._arg(2, 0.0),
            self._arg(3, tstep, True), self._arg(4, tstep, True),
            self._arg(5, tstop, True), self._arg(6, tstop, True), self._arg(7, 0.0),
        ]

    def _safe_until(self) -> float:
        return self._arg(2, 0.0)

    @staticmethod
    def _value(P, t):
        v1, v2, td, tr, tf, pw, per, npulse = P
        time = t - td
        after = (npulse > 0) & (t > td + npulse * per)
        k = pulse_period(t, td, per)
        time = np.where(k >= 1, t - (td + k * per), time)
        top = tr + pw
        out = np.where(
            (time <= 0) | (time >= top + tf), v1,
            np.where((time >= tr) & (time <= top), v2,
                     np.where(time < tr, v1 + (v2 - v1) * time / tr,
                              v2 + (v1 - v2) * (time - top) / tf)))
        return np.where(after, v1, out)

    @staticmethod
    def _value_scalar(p, t):
        v1, v2, td, tr, tf, pw, per, npulse = p
        if npulse > 0 and t > td + npulse * per:
            return v1
        time = _pulse_phase_scalar(t, td, per)
        top = tr + pw
        if time <= 0 or time >= top + tf:
            return v1
        if tr <= time <= top:
            return v2
        if time < tr:
            return v1 + (v2 - v1) * time / tr
        return v2 + (v1 - v2) * (time - top) / tf

    @staticmethod
    def _derivative(P, t, order):
        v1, v2, td, tr, tf, pw, per, npulse = P
        time = t - td
        scale = np.maximum(np.abs(t), per)
        time = _snap(time, 0.0, scale)
        k = np.floor(time / per)
        phase = time - k * per
        phase = _snap(phase, per, scale)
        wrap = phase >= per
        k = np.where(wrap, k + 1, k)
        phase = np.where(wrap, 0.0, phase)
        top = tr + pw
        phase = _snap(_snap(_snap(phase, tr, scale), top, scale), top + tf, scale)
        active = (time >= 0) & ~((npulse > 0) & ((k >= npulse) | (time > npulse * per)))
        if order > 1:
            return np.zeros(np.broadcast(t, v1).shape)
        slope = np.where((phase >= 0) & (phase < tr), (v2 - v1) / tr,
                         np.where((phase >= top) & (phase < top + tf), (v1 - v2) / tf, 0.0))
        return np.where(active, slope, 0.0)

    @staticmethod
    def _breakpoints(P, t0, t1):
        v1, v2, td, tr, tf, pw, per, npulse = P
        end = tr + pw + tf
        kmin = np.maximum(np.floor((t0 - td - end) / per), 0.0)
        kmax = np.floor((t1 - td) / per)
        kmax = np.where(npulse > 0, np.minimum(kmax, npulse - 1), kmax)
        counts = np.maximum(kmax - kmin + 1, 0).astype(np.int64)
        src = np.repeat(np.arange(counts.size), counts)
        first = np.repeat(np.cumsum(counts) - counts, counts)
        k = kmin[src] + (np.arange(src.size) - first)
        base = td[src] + k * per[src]
        corners = np.stack([base, base + tr[src], base + tr[src] + pw[src], base + end[src]])
        # a corner at or past the period's end is not one: the next period has begun (a pulse cut by
        # its period jumps at the next base instead; ulps from it, such a corner would be a step of ulps)
        within = np.stack([np.ones_like(base, dtype=bool), tr[src] < per[src], tr[src] + pw[src] < per[src],
                           end[src] < per[src]])
        corners = np.where(within, corners, np.nan)
        corners = corners[~np.isnan(corners)]
        # the train ends at td + np*per (v1 after it): a jump when np is not a whole number, as ngspice cuts
        # the last pulse there (or when a pulse outlasts its period)
        cuts = (npulse > 0) & ((npulse != np.floor(npulse)) | (end > per))
        cut = (td + npulse * per)[cuts]
        return np.concatenate([corners, cut])


# ---------------------------------------------------------------------------
def _sin_derivative(amp, omega, phase, n: int, tau):
    """n-th derivative of ``amp*sin(omega*tau + phase)``."""
    return amp * omega**n * np.sin(omega * tau + phase + n * (math.pi / 2))


class Sin(Waveform):
    """``SIN(vo va [freq [td [theta [phase]]]])``: damped sinusoid."""

    kind = "sin"
    names = ("vo", "va", "freq", "td", "theta", "phase")

    def _resolve(self, tstep, tstop):
        return [self._arg(0, 0.0), self._arg(1, 0.0), self._arg(2, 1.0 / tstop, True),
                self._arg(3, 0.0), self._arg(4, 0.0), self._arg(5, 0.0)]

    def _safe_until(self) -> float:
        return self._arg(3, 0.0) if self._arg(2, 0.0, True) == 0.0 else math.inf

    @staticmethod
    def _value(P, t):
        vo, va, freq, td, theta, phase = P
        tau = t - td
        ph = phase * _DEG
        pos = np.maximum(tau, 0.0)
        wave = vo + va * np.sin(_TWO_PI * freq * pos + ph) * np.exp(-pos * theta)
        return np.where(tau <= 0, vo + va * np.sin(ph), wave)

    @staticmethod
    def _value_scalar(p, t):
        vo, va, freq, td, theta, phase = p
        tau = t - td
        ph = phase * _DEG
        if tau <= 0:
            return vo + va * math.sin(ph)
        return vo + va * math.sin(_TWO_PI * freq * tau + ph) * _overflowing(math.exp, -tau * theta)

    @staticmethod
    def _derivative(P, t, order):
        vo, va, freq, td, theta, phase = P
        tau = _snap(t - td, 0.0, np.abs(t))
        pos = np.maximum(tau, 0.0)
        s = 1j * _TWO_PI * freq - theta
        d = va * np.imag(s**order * np.exp(s * pos + 1j * phase * _DEG))
        return np.where(tau >= 0, d, 0.0)

    @staticmethod
    def _breakpoints(P, t0, t1):
        return P[3]


# ---------------------------------------------------------------------------
class Exp(Waveform):
    """``EXP(v1 v2 [td1 [tau1 [td2 [tau2]]]])``: exponential rise and fall."""

    kind = "exp"
    names = ("v1", "v2", "td1", "tau1", "td2", "tau2")

    def _check(self) -> None:
        for i in (3, 5):
            v = self.given[i]
            if v is not None and v < 0:
                raise ValueError(f"EXP {self.names[i]} must be >= 0, got {v:g}")

    def _resolve(self, tstep, tstop):
        td1 = self._arg(2, tstep, True)
        return [self._arg(0, 0.0), self._arg(1, 0.0), td1, self._arg(3, tstep, True),
                self._arg(4, td1 + tstep, True), self._arg(5, tstep, True)]

    def _safe_until(self) -> float:
        if self._arg(2, 0.0, True) == 0.0:
            return 0.0
        if any(self._arg(i, 0.0, True) == 0.0 for i in (3, 4, 5)):
            return self._arg(2, 0.0)
        return math.inf

    @staticmethod
    def _value(P, t):
        v1, v2, td1, tau1, td2, tau2 = P
        rise = (v2 - v1) * -np.expm1(-np.maximum(t - td1, 0.0) / tau1)
        fall = (v1 - v2) * -np.expm1(-np.maximum(t - td2, 0.0) / tau2)
        return np.where(t <= td1, v1, np.where(t <= td2, v1 + rise, v1 + rise + fall))

    @staticmethod
    def _value_scalar(p, t):
        v1, v2, td1, tau1, td2, tau2 = p
        if t <= td1:
            return v1
        rise = (v2 - v1) * -_overflowing(math.expm1, -(t - td1) / tau1)
        if t <= td2:
            return v1 + rise
        return v1 + rise + (v1 - v2) * -_overflowing(math.expm1, -(t - td2) / tau2)

    @staticmethod
    def _derivative(P, t, order):
        v1, v2, td1, tau1, td2, tau2 = P
        a = _snap(t - td1, 0.0, np.abs(t))
        b = _snap(t - td2, 0.0, np.abs(t))
        sign = -1.0 if order % 2 == 0 else 1.0
        rise = np.where(a >= 0, sign * (v2 - v1) / tau1**order * np.exp(-np.maximum(a, 0.0) / tau1), 0.0)
        fall = np.where(b >= 0, sign * (v1 - v2) / tau2**order * np.exp(-np.maximum(b, 0.0) / tau2), 0.0)
        return rise + fall

    @staticmethod
    def _breakpoints(P, t0, t1):
        return np.concatenate([P[2], P[4]])


# ---------------------------------------------------------------------------
def _sin_of_phase_derivatives(u_derivs: list[np.ndarray], order: int) -> np.ndarray:
    """d^order/dt^order sin(u(t)) from u, u', ..., u^(order) (Leibniz recurrence).

    With s_n = (sin u)^(n), c_n = (cos u)^(n):
    s_n = sum_k C(n-1, k) c_k u^(n-k), c_n = -sum_k C(n-1, k) s_k u^(n-k).
    """
    s = [np.sin(u_derivs[0])]
    c = [np.cos(u_derivs[0])]
    for n in range(1, order + 1):
        sn = 0.0
        cn = 0.0
        for k in range(n):
            w = math.comb(n - 1, k) * u_derivs[n - k]
            sn = sn + w * c[k]
            cn = cn - w * s[k]
        s.append(sn)
        c.append(cn)
    return s[order]


class Sffm(Waveform):
    """``SFFM(vo va [fc [mdi [fs [phasec [phases]]]]])``: single-frequency FM."""

    kind = "sffm"
    names = ("vo", "va", "fc", "mdi", "fs", "phasec", "phases")

    def _resolve(self, tstep, tstop):
        return [self._arg(0, 0.0), self._arg(1, 0.0), self._arg(2, 1.0 / tstop, True),
                self._arg(3, 0.0), self._arg(4, 1.0 / tstop, True), self._arg(5, 0.0),
                self._arg(6, 0.0)]

    def _safe_until(self) -> float:
        return 0.0 if (self._arg(2, 0.0, True) == 0.0 or self._arg(4, 0.0, True) == 0.0) else math.inf

    @staticmethod
    def _value(P, t):
        vo, va, fc, mdi, fs, phc, phs = P
        return vo + va * np.sin(_TWO_PI * fc * t + phc * _DEG + mdi * np.sin(_TWO_PI * fs * t + phs * _DEG))

    @staticmethod
    def _value_scalar(p, t):
        vo, va, fc, mdi, fs, phc, phs = p
        return vo + va * math.sin(_TWO_PI * fc * t + phc * _DEG + mdi * math.sin(_TWO_PI * fs * t + phs * _DEG))

    @staticmethod
    def _derivative(P, t, order):
        vo, va, fc, mdi, fs, phc, phs = P
        wc, ws = _TWO_PI * fc, _TWO_PI * fs
        inner = ws * t + phs * _DEG
        u = [wc * t + phc * _DEG + mdi * np.sin(inner)]
        for k in range(1, order + 1):
            uk = _sin_derivative(mdi, ws, phs * _DEG, k, t)
            u.append(uk + wc if k == 1 else uk)
        return va * _sin_of_phase_derivatives(u, order)

    @staticmethod
    def _breakpoints(P, t0, t1):
        return np.empty(0)


# ---------------------------------------------------------------------------
class Am(Waveform):
    """``AM(va vo [mf [fc [td [phasec [phases]]]]])``: amplitude modulation."""

    kind = "am"
    names = ("va", "vo", "mf", "fc", "td", "phasec", "phases")

    def _resolve(self, tstep, tstop):
        return [self._arg(0, 0.0), self._arg(1, 0.0), self._arg(2, 1.0 / tstop, True),
                self._arg(3, 0.0), self._arg(4, 0.0, True), self._arg(5, 0.0), self._arg(6, 0.0)]

    def _safe_until(self) -> float:
        return self._arg(4, 0.0) if self._arg(2, 0.0, True) == 0.0 else math.inf

    @staticmethod
    def _value(P, t):
        va, vo, mf, fc, td, phc, phs = P
        tau = t - td
        ph = phs * _DEG
        wave = va * (vo + np.sin(_TWO_PI * mf * tau + ph)) * np.sin(_TWO_PI * fc * tau + ph)
        return np.where(tau <= 0, 0.0, wave)

    @staticmethod
    def _value_scalar(p, t):
        va, vo, mf, fc, td, phc, phs = p
        tau = t - td
        if tau <= 0:
            return 0.0
        ph = phs * _DEG
        return va * (vo + math.sin(_TWO_PI * mf * tau + ph)) * math.sin(_TWO_PI * fc * tau + ph)

    @staticmethod
    def _derivative(P, t, order):
        va, vo, mf, fc, td, phc, phs = P
        wm, wc = _TWO_PI * mf, _TWO_PI * fc
        tau = _snap(t - td, 0.0, np.abs(t))
        ph = phs * _DEG
        total = 0.0
        for k in range(order + 1):
            fk = va * (vo + np.sin(wm * tau + ph)) if k == 0 else _sin_derivative(va, wm, ph, k, tau)
            total = total + math.comb(order, k) * fk * _sin_derivative(1.0, wc, ph, order - k, tau)
        return np.where(tau >= 0, total, 0.0)

    @staticmethod
    def _breakpoints(P, t0, t1):
        return P[4]


# ---------------------------------------------------------------------------
def _count_before(times: np.ndarray, x: np.ndarray, side: str) -> np.ndarray:
    """Per entry of ``x``: how many points of its row of ``times`` are before it.

    ``times`` holds one sorted row per source (one row: shared by every
    entry of ``x``, else one row per entry); ``side="left"`` counts the
    points ``< x``, ``"right"`` those ``<= x``. Binary searches, so a
    sampled noise source of millions of points costs O(log n) per value.
    """
    if times.shape[0] == 1:
        return np.searchsorted(times[0], x, side=side)
    return np.array([np.searchsorted(row, v, side=side) for row, v in zip(times, x)], dtype=np.int64)


class Pwl(Waveform):
    """``PWL(t1 v1 t2 v2 ...) [r=trep] [td=delay]``: piecewise linear.

    Parameters
    ----------
    times, values : sequence of float
        The corner points (times non-decreasing; a time listed twice is a step).
    repeat : float or None
        ``r=``: the time point from which the list repeats; None (or a value
        below -0.5, as ngspice) for no repetition.
    delay : float
        ``td=``: shift of the whole waveform.
    """

    kind = "pwl"
    names = ("times", "values", "repeat", "delay")

    def __init__(self, times: Sequence[float], values: Sequence[float],
                 repeat: float | None = None, delay: float = 0.0) -> None:
        t = np.asarray(times, dtype=float).reshape(-1)
        v = np.asarray(values, dtype=float).reshape(-1)
        if t.size < 1 or t.size != v.size:
            raise ValueError("PWL needs pairs of time and value (at least one pair)")
        steps = np.diff(t)
        if np.any(steps < 0):
            i = int(np.argmax(steps < 0))
            raise ValueError(f"PWL time points must not decrease: {t[i + 1]:g} follows {t[i]:g}")
        if repeat is not None and repeat < -0.5:
            repeat = None
        self.times, self.values = t, v
        self.repeat = None if repeat is None else float(repeat)
        self.delay = float(delay)
        self.given = (tuple(t), tuple(v), self.repeat, self.delay)
        self.start = 0
        if self.repeat is not None:
            hits = np.nonzero(t == self.repeat)[0]
            if self.repeat >= t[-1]:
                raise ValueError(f"PWL repeat time r={self.repeat:g} must be smaller than the last "
                                 f"time point {t[-1]:g}")
            if hits.size == 0:
                raise ValueError(f"PWL repeat time r={self.repeat:g} does not match any time point")
            self.start = int(hits[0])
        self.tstep = self.tstop = None
        self._P = (t[None, :], v[None, :], np.array([self.delay]),
                   np.array([self.repeat is not None]), np.array([t[self.start]]),
                   np.array([t[-1] - t[self.start]]))

    @property
    def has_steps(self) -> bool:
        """True when a time point is listed twice (the value jumps there)."""
        return bool(np.any(np.diff(self.times) == 0))

    def resolved(self, tstep: float, tstop: float) -> "Pwl":
        """PWL has no TSTEP/TSTOP-dependent defaults: returns itself."""
        return self

    @classmethod
    def _stack(cls, waveforms):
        n = max(w.times.size for w in waveforms)
        times = np.empty((len(waveforms), n))
        values = np.empty((len(waveforms), n))
        for i, w in enumerate(waveforms):
            m = w.times.size
            times[i, :m], times[i, m:] = w.times, w.times[-1]
            values[i, :m], values[i, m:] = w.values, w.values[-1]
        cols = [np.concatenate([w._P[j] for w in waveforms]) for j in range(2, 6)]
        return (times, values, *cols)

    @staticmethod
    def _local_time(P, t, exact: bool):
        times, values, delay, rep, tstart, period = P
        tau = t - delay
        scale = np.maximum(np.abs(t), np.abs(times[:, -1]))
        over = rep & (tau >= times[:, -1] - (0.0 if exact else CORNER_RTOL * scale))
        safe_period = np.where(period > 0, period, 1.0)
        rem = np.fmod(np.maximum(tau - tstart, 0.0), safe_period)
        if not exact:
            rem = np.where(safe_period - rem <= CORNER_RTOL * scale, 0.0, rem)
        return np.where(over, tstart + rem, tau), scale

    @staticmethod
    def _value(P, t):
        times, values = P[0], P[1]
        tau, _ = Pwl._local_time(P, t, exact=True)
        times = np.broadcast_to(times, (tau.size, times.shape[1]))
        values = np.broadcast_to(values, times.shape)
        n = times.shape[1]
        tol = _PWL_EQUAL_ULPS * np.spacing(np.abs(tau))
        left = _count_before(P[0], tau - tol, "left")  # first point not before tau
        rows = np.arange(tau.size)
        li = np.minimum(left, n - 1)
        on_point = (left < n) & (times[rows, li] <= tau + tol)
        lo = np.maximum(left - 1, 0)
        t_lo, t_hi = times[rows, lo], times[rows, li]
        v_lo, v_hi = values[rows, lo], values[rows, li]
        span = np.where(t_hi > t_lo, t_hi - t_lo, 1.0)
        inner = v_lo + (tau - t_lo) / span * (v_hi - v_lo)
        return np.where(on_point | (left == 0), values[rows, li],
                        np.where(left >= n, values[:, -1], inner))

    def _scalar_params(self) -> tuple:
        t0 = float(self.times[self.start])
        # Python lists index fastest; a long list (a noise realisation) stays an array, which bisect
        # reads as well, rather than costing 32 bytes a point as Python floats
        if self.times.size <= _PWL_LIST_POINTS:
            times, values = self.times.tolist(), self.values.tolist()
        else:
            times, values = self.times, self.values
        return (times, values, self.delay, self.repeat is not None, t0, float(self.times[-1]) - t0)

    @staticmethod
    def _value_scalar(p, t):
        times, values, delay, rep, tstart, period = p
        tau = t - delay
        if rep and tau >= times[-1]:
            tau = tstart + math.fmod(max(tau - tstart, 0.0), period if period > 0 else 1.0)
        tol = _PWL_EQUAL_ULPS * math.ulp(abs(tau))
        n = len(times)
        left = bisect.bisect_left(times, tau - tol)  # first point not before tau
        li = min(left, n - 1)
        if left == 0 or (left < n and times[li] <= tau + tol):
            return values[li]
        if left >= n:
            return values[-1]
        lo = left - 1
        t_lo, t_hi = times[lo], times[li]
        span = t_hi - t_lo if t_hi > t_lo else 1.0
        return values[lo] + (tau - t_lo) / span * (values[li] - values[lo])

    @staticmethod
    def _derivative(P, t, order):
        times, values = P[0], P[1]
        tau, scale = Pwl._local_time(P, t, exact=False)
        times = np.broadcast_to(times, (tau.size, times.shape[1]))
        values = np.broadcast_to(values, times.shape)
        if order > 1:
            return np.zeros(tau.size)
        n = times.shape[1]
        j = _count_before(P[0], tau + CORNER_RTOL * scale, "right") - 1
        rows = np.arange(tau.size)
        valid = (j >= 0) & (j < n - 1)
        jj = np.clip(j, 0, max(n - 2, 0))
        if n < 2:
            return np.zeros(tau.size)
        dt = times[rows, jj + 1] - times[rows, jj]
        dv = values[rows, jj + 1] - values[rows, jj]
        return np.where(valid & (dt > 0), dv / np.where(dt > 0, dt, 1.0), 0.0)

    @staticmethod
    def _breakpoints(P, t0, t1):
        times, values, delay, rep, tstart, period = P
        out = [(times + delay[:, None]).reshape(-1)]
        if np.any(rep):
            rows = np.nonzero(rep)[0]
            # repeat k = 1, 2, ... shifts the points in [tstart, tend] by k*period
            kmax = np.floor((t1 - delay[rows] - tstart[rows]) / period[rows])
            kmin = np.maximum(np.floor((t0 - delay[rows] - times[rows, -1]) / period[rows]), 1.0)
            counts = np.maximum(kmax - kmin + 1, 0).astype(np.int64)
            src = np.repeat(rows, counts)
            first = np.repeat(np.cumsum(counts) - counts, counts)
            k = np.repeat(kmin, counts) + (np.arange(src.size) - first)
            shifted = times[src] + (delay[src] + k * period[src])[:, None]
            mask = times[src] >= tstart[src][:, None]
            out.append(shifted[mask])
        return np.concatenate(out)

    def __repr__(self) -> str:
        shown = 8 if self.times.size > 16 else self.times.size
        pts = " ".join(f"{a:g} {b:g}" for a, b in zip(self.times[:shown], self.values[:shown]))
        if shown < self.times.size:
            pts += f" ... ({self.times.size} points)"
        extra = (f", r={self.repeat:g}" if self.repeat is not None else "") + (
            f", td={self.delay:g}" if self.delay else "")
        return f"Pwl({pts}{extra})"


# ---------------------------------------------------------------------------
#: Most points a random source keeps for one transient: its realisation is drawn once for the
#: whole run and kept (16 bytes a point, twice: the reference and the compiled engine's copy),
#: and every point is a breakpoint, so a time step.
MAX_RANDOM_POINTS = 4_000_000


class RandomSource(Waveform):
    """Base of TRNOISE and TRRANDOM: a random function, drawn once per transient.

    Parameters
    ----------
    *args : float or None
        The numbers written on the card, in ngspice's order.
    dc : float
        The card's DC value: ngspice adds it to the random function.
    key : sequence of int
        The key of the source's random stream
        (:meth:`netdae.netlist.montecarlo.Draws.source_key`).
    name : str
        The source's name, for messages.
    location : SourceLocation or None
        Where the function is written, for messages.

    Notes
    -----
    :meth:`resolved` draws the realisation over ``[0, TSTOP]`` from the
    stream ``key`` and returns it as a :class:`Pwl` (sample instants and
    jumps are its points, so they are breakpoints), which both engines then
    evaluate as any PWL source: the same key and TSTOP give the same
    realisation in every process. Unresolved, the value is known up to the
    start of the randomness (``value(0.0)``: the operating point).
    """

    def __init__(self, *args: float | None, dc: float = 0.0, key: Sequence[int] = (1, 0), name: str = "",
                 location=None) -> None:
        super().__init__(*args)
        self.dc = float(dc)
        self.key = tuple(int(k) for k in key)
        self.name = name
        self.location = location

    def _start(self) -> tuple[float, float]:
        """(time up to which the value is fixed, that value without the DC part)."""
        raise NotImplementedError

    def value(self, t):
        """Value at time(s) ``t`` up to the start of the randomness (else: resolve first).

        Raises
        ------
        ValueError
            For a time after that start (the value there is drawn by :meth:`resolved`).
        """
        tt, shape = _as_times(t)
        until, start = self._start()
        if tt.size and float(np.max(tt)) > until:
            raise ValueError(f"{self.kind.upper()}: the value at t={float(np.max(tt)):g} is random, drawn for a "
                             "transient; call resolved(tstep, tstop) first")
        return _shape_out(np.full(tt.shape, self.dc + start), shape)

    def resolved(self, tstep: float, tstop: float) -> "Pwl":
        """The realisation over ``[0, tstop]`` as a PWL (its last value holds after it).

        Parameters
        ----------
        tstep, tstop : float
            The ``.tran`` step and stop time [s], both > 0.

        Returns
        -------
        Pwl

        Raises
        ------
        NetlistError
            (a ``ValueError``) When the realisation would need more than
            :data:`MAX_RANDOM_POINTS` points; located at the function.
        """
        from .montecarlo import generator

        _check_span(tstep, tstop)
        times, values = self._realise(generator(self.key), float(tstop))
        return Pwl(times, values + self.dc)

    def _realise(self, rng, tstop: float) -> tuple[np.ndarray, np.ndarray]:
        """Times (non-decreasing, a time twice at a jump) and values, without the DC part."""
        raise NotImplementedError

    def check_size(self, tstop: float) -> None:
        """Refuse a transient to ``tstop`` whose realisation would need too many points.

        Raises
        ------
        NetlistError
            (a ``ValueError``) Located at the function, with a hint; the
            telegraph's count is its expected one (:meth:`resolved` checks
            the drawn one).
        """
        raise NotImplementedError

    def _check_count(self, count: int, what: str, hint: str) -> None:
        if count > MAX_RANDOM_POINTS:
            from ..errors import NetlistError

            label = f"{self.name}: " if self.name else ""
            raise NetlistError(f"{label}{self.kind.upper()} {what} needs {count:,} points, more than the "
                               f"{MAX_RANDOM_POINTS:,} netdae keeps for one source", self.location,
                               hint=hint + "; the realisation is drawn for the whole transient and kept, and "
                               "every point is a time step")

    def __eq__(self, other) -> bool:
        return Waveform.__eq__(self, other) and (self.dc, self.key) == (other.dc, other.key)

    __hash__ = None


def flicker_noise(rng, n: int, alpha: float, amplitude: float) -> np.ndarray:
    """``n`` samples of 1/f^alpha noise by Kasdin's filter on white noise.

    White noise ``w_k`` of rms ``amplitude`` goes through the causal filter
    with the coefficients of ``(1 - z^-1)^(-alpha/2)``: ``h_0 = 1``,
    ``h_k = h_(k-1) (alpha/2 + k - 1) / k``; the convolution is computed with
    FFTs zero-padded to at least ``2n - 1`` points (a linear convolution, no
    wrap-around). The output's spectrum is
    ``amplitude^2 / |2 sin(pi f dt)|^alpha`` per sample (two-sided, f in
    cycles per sample), so 1/f^alpha well below the Nyquist frequency
    (N. J. Kasdin, Proc. IEEE 83(5), 1995, the method of ngspice's
    generator).

    Parameters
    ----------
    rng : numpy.random.Generator
    n : int
        Number of samples, >= 1.
    alpha : float
        Exponent, in (0, 2].
    amplitude : float
        rms of the white innovations.

    Returns
    -------
    ndarray, shape (n,)

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> x = flicker_noise(rng, 8, 2.0, 1.0)   # alpha = 2: h_k = 1, a random walk
    >>> w = np.random.default_rng(0).standard_normal(8)
    >>> bool(np.allclose(x, np.cumsum(w)))
    True
    """
    from scipy import fft

    w = amplitude * rng.standard_normal(n)
    h = np.ones(n)
    if n > 1:
        k = np.arange(1, n, dtype=float)
        h[1:] = np.cumprod((0.5 * alpha + k - 1.0) / k)
    m = fft.next_fast_len(2 * n - 1, real=True)
    return fft.irfft(fft.rfft(h, m) * fft.rfft(w, m), m)[:n]


def _telegraph(rng, tstop: float, capture: float, emission: float, check) -> np.ndarray:
    """Switching instants of a random telegraph signal from 0 up to the first one after ``tstop``.

    The signal starts low; low and high dwell times are exponential with means
    ``capture`` and ``emission``, drawn in pairs (a capture, an emission).
    """
    chunk = int(min(max(16.0, 1.2 * tstop / (capture + emission) + 16.0), MAX_RANDOM_POINTS))
    parts, t, count = [], 0.0, 0
    while t <= tstop:
        dwell = np.empty(2 * chunk)
        dwell[0::2] = rng.exponential(capture, chunk)
        dwell[1::2] = rng.exponential(emission, chunk)
        s = t + np.cumsum(dwell)
        parts.append(s)
        count += s.size
        t = float(s[-1])
        if t <= tstop:
            check(2 * count)
    s = np.concatenate(parts)
    return s[: int(np.searchsorted(s, tstop, side="right")) + 1]


class Trnoise(RandomSource):
    """``TRNOISE(NA NT [NALPHA [NAMP [RTSAM [RTSCAPT [RTSEMT]]]]])``: ngspice's transient noise.

    The sum of

    - white noise: gaussian samples of rms ``NA`` every ``NT`` (the sample at
      t = 0 is 0), linearly interpolated;
    - 1/f^NALPHA noise on the same instants: :func:`flicker_noise` with
      amplitude ``NAMP``, minus its first sample (ngspice reads ``NAMP`` only
      when ``NALPHA`` is not 0);
    - random telegraph noise: 0, then ``RTSAM`` after an exponential time of
      mean ``RTSCAPT`` (capture), back to 0 after one of mean ``RTSEMT``
      (emission), and so on;

    plus the card's DC value. Each part is drawn in that order from the
    source's stream; the value at a jump of the telegraph is its left value.
    """

    kind = "trnoise"
    names = ("na", "nt", "nalpha", "namp", "rtsam", "rtscapt", "rtsemt")

    def _check(self) -> None:
        na, nt, nalpha, namp, rtsam, capt, emt = (0.0 if v is None else v for v in self.given)
        for i in (0, 1, 3, 4):
            v = self.given[i]
            if v is not None and v < 0:
                raise ValueError(f"TRNOISE {self.names[i].upper()} must be >= 0, got {v:g}")
        if not 0.0 <= nalpha <= 2.0:
            raise ValueError(f"TRNOISE NALPHA (the 1/f exponent) must be in [0, 2], got {nalpha:g}")
        if nt == 0.0 and (na > 0.0 or (nalpha > 0.0 and namp > 0.0)):
            raise ValueError("TRNOISE NT (the sampling interval) is 0: ngspice then draws no white or 1/f noise; "
                             "give NT > 0")
        if rtsam > 0.0 and not (capt > 0.0 and emt > 0.0):
            raise ValueError(f"TRNOISE RTSCAPT and RTSEMT (mean capture and emission times) must be > 0 with "
                             f"RTSAM = {rtsam:g}, got {capt:g} and {emt:g}: ngspice 39 accepts zero times and then "
                             "switches its telegraph at every time step (an artefact of its step size, not a noise); "
                             "netdae refuses them: give both times, or RTSAM = 0")

    def _start(self):
        return 0.0, 0.0

    def _values(self) -> tuple[float, ...]:
        """The seven parameters, 0 for those not given (NAMP 0 with NALPHA 0, as ngspice reads it)."""
        na, nt, nalpha, namp, rtsam, capt, emt = (0.0 if v is None else v for v in self.given)
        return na, nt, nalpha, namp if nalpha != 0.0 else 0.0, rtsam, capt, emt

    def _samples(self, tstop: float) -> int:
        """Number of white/1f samples up to ``tstop`` (0: no such noise); refuses too many."""
        na, nt, nalpha, namp = self._values()[:4]
        if not (nt > 0.0 and (na > 0.0 or namp > 0.0)):
            return 0
        n = int(math.floor(min(tstop / nt, 1e18))) + 2  # the interval holding tstop closed
        self._check_count(n, f"NT={nt:g} s up to TSTOP={tstop:g} s",
                          f"NT = {nt:g} s is {tstop / nt:.3g} times smaller than TSTOP; a larger NT or a "
                          "shorter transient")
        return n

    def _switch_check(self, tstop: float):
        """The check of a telegraph's point count (a function of the count)."""
        capt, emt = self._values()[5:]

        def check(count):
            self._check_count(count, f"RTSCAPT={capt:g} s, RTSEMT={emt:g} s up to TSTOP={tstop:g} s",
                              "longer capture and emission times or a shorter transient")
        return check

    def check_size(self, tstop: float) -> None:
        n = self._samples(tstop)
        rtsam, capt, emt = self._values()[4:]
        if rtsam > 0.0:  # the expected number of points of the telegraph
            self._switch_check(tstop)(int(min(4.0 * tstop / (capt + emt), 1e18)) + n)

    def _realise(self, rng, tstop):
        na, nt, nalpha, namp, rtsam, capt, emt = self._values()
        n = self._samples(tstop)
        if n:
            times = np.arange(n) * nt
            values = np.zeros(n)
            if na > 0.0:
                values[1:] = na * rng.standard_normal(n - 1)
            if namp > 0.0:
                flick = flicker_noise(rng, n, nalpha, namp)
                values[1:] += flick[1:] - flick[0]
        else:
            times, values = np.zeros(1), np.zeros(1)
        if rtsam > 0.0:
            check = self._switch_check(tstop)
            switches = _telegraph(rng, tstop, capt, emt, check)
            check(2 * switches.size + times.size)
            times, values = _add_telegraph(times, values, switches, rtsam)
        return times, values


def _add_telegraph(times: np.ndarray, values: np.ndarray, switches: np.ndarray,
                   amplitude: float) -> tuple[np.ndarray, np.ndarray]:
    """A PWL's points plus a telegraph signal starting low and switching at ``switches``."""
    after = np.where(np.arange(switches.size) % 2 == 0, amplitude, 0.0)
    before = amplitude - after
    base = np.interp(switches, times, values)
    keep = ~np.isin(times, switches)
    level = np.where(np.searchsorted(switches, times[keep], side="right") % 2 == 1, amplitude, 0.0)
    t = np.concatenate([times[keep], switches, switches])
    v = np.concatenate([values[keep] + level, base + before, base + after])
    rank = np.concatenate([np.zeros(int(keep.sum())), np.zeros(switches.size), np.ones(switches.size)])
    order = np.lexsort((rank, t))
    return t[order], v[order]


class Trrandom(RandomSource):
    """``TRRANDOM(TYPE TS [TD [PARAM1 [PARAM2]]])``: ngspice's random value held for TS.

    ``PARAM2`` up to ``TD``, then a new draw every ``TS`` (the first at TD,
    taking effect just after it), held: a step function whose value at a
    jump is its left value. Distributions (defaults PARAM1 = 1, PARAM2 = 0):

    ====  ===========  ===================================================
    TYPE  name         value
    ====  ===========  ===================================================
    1     uniform      PARAM2 + PARAM1 * u, u uniform on [-1, 1)
    2     gaussian     PARAM2 + PARAM1 * z, z standard normal
    3     exponential  PARAM2 + an exponential draw of mean PARAM1
    4     poisson      PARAM2 + a Poisson draw of mean (lambda) PARAM1
    ====  ===========  ===================================================

    plus the card's DC value.
    """

    kind = "trrandom"
    names = ("type", "ts", "td", "param1", "param2")

    def _check(self) -> None:
        kind, ts, td, p1 = self.given[0], self.given[1], self._arg(2, 0.0), self._arg(3, 1.0)
        if kind not in (1.0, 2.0, 3.0, 4.0):
            raise ValueError(f"TRRANDOM TYPE must be 1 (uniform), 2 (gaussian), 3 (exponential) or 4 (poisson), "
                             f"got {kind:g}")
        if ts is None or not ts > 0.0:
            raise ValueError(f"TRRANDOM TS (the time a value is held) must be > 0, got {ts:g}")
        if td < 0.0:
            raise ValueError(f"TRRANDOM TD (the delay) must be >= 0, got {td:g}")
        if kind == 2.0 and p1 < 0.0:
            raise ValueError(f"TRRANDOM type 2: PARAM1 (the standard deviation) must be >= 0, got {p1:g}")
        if kind == 3.0 and not p1 > 0.0:
            raise ValueError(f"TRRANDOM type 3: PARAM1 (the mean) must be > 0, got {p1:g}")
        if kind == 4.0 and p1 < 0.0:
            raise ValueError(f"TRRANDOM type 4: PARAM1 (lambda, the mean) must be >= 0, got {p1:g}")

    def _start(self):
        return self._arg(2, 0.0), self._arg(4, 0.0)

    def _draws(self, tstop: float) -> int:
        """Number of values drawn up to ``tstop``; refuses too many."""
        ts, td = self.given[1], self._arg(2, 0.0)
        if td >= tstop:
            return 0
        n = int(math.floor(min((tstop - td) / ts, 1e18))) + 1  # draw k holds on (td + k ts, td + (k+1) ts]
        self._check_count(2 * n, f"TS={ts:g} s up to TSTOP={tstop:g} s",
                          f"TS = {ts:g} s is {(tstop - td) / ts:.3g} times smaller than TSTOP - TD; a larger TS or a "
                          "shorter transient")
        return n

    def check_size(self, tstop: float) -> None:
        self._draws(tstop)

    def _realise(self, rng, tstop):
        kind, ts = int(self.given[0]), self.given[1]
        td, p1, p2 = self._arg(2, 0.0), self._arg(3, 1.0), self._arg(4, 0.0)
        n = self._draws(tstop)
        if n == 0:
            return np.zeros(1), np.full(1, p2)
        if kind == 1:
            draws = p1 * rng.uniform(-1.0, 1.0, n) + p2
        elif kind == 2:
            draws = p1 * rng.standard_normal(n) + p2
        elif kind == 3:
            draws = rng.exponential(p1, n) + p2
        else:
            draws = rng.poisson(p1, n) + p2
        jumps = td + np.arange(n) * ts
        times = np.repeat(jumps, 2)
        values = np.empty(2 * n)
        values[0::2] = np.concatenate([[p2], draws[:-1]])
        values[1::2] = draws
        return times, values


#: Waveform classes by the name written on a card.
WAVEFORMS: dict[str, type[Waveform]] = {
    cls.kind: cls for cls in (Pulse, Sin, Exp, Pwl, Sffm, Am, Trnoise, Trrandom)
}


class SourceBank:
    """Many resolved waveforms evaluated together.

    Parameters
    ----------
    waveforms : sequence of Waveform
        Resolved waveforms (:meth:`Waveform.resolved`); their order is the
        order of the returned values.

    Notes
    -----
    Waveforms are grouped by class once; :meth:`values` then makes one
    vectorised kernel call per class present (at most six), whatever the
    number of sources: O(k) numpy work, O(1) Python work per call. PWL
    sources are padded to the longest point list (cost O(k * n_max)).

    Examples
    --------
    >>> bank = SourceBank([Sin(0, 1, 1e3).resolved(1e-6, 1e-3), Exp(0, 2, 0, 1e-3).resolved(1e-6, 1e-3)])
    >>> bank.values(0.0).tolist(), bank.values(0.0, derivative=1).round(6).tolist()
    ([0.0, 0.0], [6283.185307, 0.0])
    """

    def __init__(self, waveforms: Sequence[Waveform]) -> None:
        self.size = len(waveforms)
        groups: dict[type, list[int]] = {}
        for i, w in enumerate(waveforms):
            if not w.is_resolved:
                raise ValueError(f"waveform {i} ({w!r}) is not resolved")
            groups.setdefault(type(w), []).append(i)
        self._groups = [
            (cls, np.asarray(idx), cls._stack([waveforms[i] for i in idx]))
            for cls, idx in groups.items()
        ]
        # a class with one waveform is evaluated by its scalar kernel (no numpy call overhead)
        self._scalar = [
            (idx[0], cls._value_scalar, waveforms[idx[0]]._scalar_params())
            for cls, idx in groups.items() if len(idx) == 1 and cls._value_scalar is not None
        ]
        self._vector = [g for g in self._groups if g[1].size > 1 or g[0]._value_scalar is None]

    def values(self, t: float, derivative: int = 0) -> np.ndarray:
        """Values (or their ``derivative``-th time derivatives) at time ``t``.

        Returns
        -------
        ndarray, shape (k,)

        Notes
        -----
        Values: one vectorised kernel call per class with several waveforms,
        the scalar kernel for a class with one (about 1 us instead of the
        20-100 us of some 30 numpy calls on one-element arrays).
        """
        out = np.zeros(self.size)
        t = float(t)
        if derivative == 0:
            for i, kernel, p in self._scalar:
                out[i] = kernel(p, t)
            for cls, idx, P in self._vector:
                out[idx] = cls._value(P, np.full(idx.size, t))
            return out
        for cls, idx, P in self._groups:
            out[idx] = cls._derivative(P, np.full(idx.size, t), int(derivative))
        return out

    def breakpoints(self, t0: float, t1: float) -> np.ndarray:
        """All sources' breakpoints in ``[t0, t1]``, sorted, without duplicates."""
        parts = [cls._breakpoints(P, float(t0), float(t1)) for cls, _, P in self._groups]
        return _finish_breakpoints(np.concatenate(parts) if parts else np.empty(0), t0, t1)
