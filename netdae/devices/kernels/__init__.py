"""Compiled device kernels: one numba function per nonlinear family, all instances in one loop.

Each kernel is the compiled twin of a numpy family's ``evaluate``
(:mod:`netdae.devices.diode`, :mod:`~netdae.devices.bjt`,
:mod:`~netdae.devices.mosfet`, :mod:`~netdae.devices.jfet`, which stay the reference), for the compiled
Newton loop. The interface, the same for every family::

    flags, bad = eval_<family>(x, mode, par, idx, vold, vnew, q, phi, dq, dphi, jacobian)

- ``x``: float64[n + 1], the extended iterate (``x[n] == 0`` is ground);
- ``mode``: :data:`MODE_EVALUATE` (at x's own voltages), :data:`MODE_LIMIT`
  (limit against ``vold``), :data:`MODE_INITIAL` (SPICE's ``MODEINITJCT``:
  ``vold`` when x is all zero, else x's own voltages);
- ``par``: float64[N, P], per-instance parameters at temperature, columns
  named by the kernel module's ``P_*`` constants;
- ``idx``: int64[N, K], extended node indices (``I_*``) and Jacobian slots
  into ``dq``/``dphi`` (``S_*``: four per (output, control) dependence, in the
  order (a, p), (a, m), (b, p), (b, m) of
  :class:`~netdae.devices.companion.BranchStamps`; slot nnz is the dummy);
- ``vold`` (in), ``vnew`` (out): float64[N, V], the limited control
  voltages (type-normalised, ``V_*`` columns) and any extra state;
- ``q``, ``phi`` (float64[n + 1]), ``dq``, ``dphi`` (float64[nnz + 1]):
  the kernel ADDS the family's charges, currents and, when ``jacobian``,
  their derivatives, with the companion-model continuation where limited;
- returns ``flags`` (:data:`FLAG_LIMITED`, :data:`FLAG_NONFINITE`) and ``bad``,
  the first instance with a non-finite value (-1: none).

The kernels allocate nothing; a family's ``compiled(slots, n)`` packs
``(par, idx, vold0)`` once, after ``bind``.
"""

MODE_EVALUATE = 0
MODE_LIMIT = 1
MODE_INITIAL = 2
FLAG_LIMITED = 1
FLAG_NONFINITE = 2

__all__ = ["MODE_EVALUATE", "MODE_LIMIT", "MODE_INITIAL", "FLAG_LIMITED", "FLAG_NONFINITE"]
