"""The compiled kernel of OSDI devices: the modules' own functions called through their addresses.

An OSDI module is machine code already; the compiled engine calls it like
the numpy family does (:class:`netdae.devices.osdi.family.OsdiFamily`), but
from compiled code: the descriptor's function pointers are integers in the
packed arrays, called through small numba intrinsics that cast an address to
a C function type (:func:`call_eval`, :func:`call_load`,
:func:`call_jacobian_resist`, :func:`call_jacobian_react`). Addresses are
arguments, not constants, so the compiled code is cached on disk like every
other kernel and serves any module loaded in any process.

    flags, bad = eval_osdi(x, t, mode, vold, vnew, inst, fns, slots, info_i, info_f, xbuf, fbuf, qbuf,
                           jr, jc, q, phi, dq, dphi, jacobian)

- ``mode``, ``vold``, ``vnew``: as for every family kernel: ``MODE_EVALUATE``
  evaluates at ``x``; ``MODE_LIMIT`` lets the modules limit (``$limit``)
  against their state vector ``vold`` (the limited values of the previous
  iteration), the residuals continued linearly to ``x`` with the modules'
  limiting right-hand sides; ``MODE_INITIAL`` starts from the modules' initial
  values (``INIT_LIM``) when ``x`` is zero, else evaluates at ``x``. The
  modules write their new state into ``vnew`` (float64[S], S >= 1);

- ``inst``: int64[N, N_INST]: per instance its handle, the addresses of its
  instance and model data, its module's row in ``fns``, the range of its
  Jacobian entries in ``jr``/``jc``/``slots`` and the address of its
  ``$bound_step`` value (0: its module has none);
- ``fns``: int64[M, N_FNS]: per module the addresses of ``eval``,
  ``load_residual_resist``, ``load_residual_react``, ``load_jacobian_resist``
  and ``load_jacobian_react``;
- ``slots``: int64[E]: every Jacobian entry's position in ``dq``/``dphi``;
- ``info_i``, ``info_f``: the ``OsdiSimInfo`` the modules read, as int64 and
  float64 views of one buffer (its parameter pointers set by the family),
  followed by netdae's words the modules do not see: the call's shortest
  ``$bound_step`` (``info_f[W_BOUND]``, inf: none), and the ``$finish`` /
  ``$stop`` flags of the call (``info_i[W_STOP]``) with the first instance
  that raised one (``info_i[W_STOP_INST]``);
- ``xbuf`` (the iterate the modules read through their node mapping),
  ``fbuf``, ``qbuf`` (residuals, float64[n + 1]), ``jr``, ``jc`` (Jacobian
  entries, float64[E]): the family's buffers, whose addresses the instances
  hold (node mapping, Jacobian pointers set by ``OsdiFamily.bind``).

The kernel ADDS ``-f`` to ``phi``, ``q`` to ``q`` and, when ``jacobian``,
``-df/dx`` and ``dq/dx`` through ``slots``; flags bit 0 marks a module that
limited, bit 1 a non-finite value or a module's fatal error.
"""

from __future__ import annotations

import math

from llvmlite import ir
from numba import types
from numba.extending import intrinsic

from ...dae.compiled import kernel
from . import FLAG_LIMITED, FLAG_NONFINITE, MODE_INITIAL, MODE_LIMIT

__all__ = ["eval_osdi", "call_eval", "call_load", "call_jacobian_resist", "call_jacobian_react", "load_double",
           "N_INST", "N_FNS", "INFO_WORDS", "W_BOUND", "W_STOP", "W_STOP_INST"]

# inst columns
I_HANDLE, I_INST, I_MODEL, I_MODULE, I_JAC0, I_JAC1, I_BOUND = range(7)
N_INST = 7
# fns columns
F_EVAL, F_RES_RESIST, F_RES_REACT, F_JAC_RESIST, F_JAC_REACT, F_LIM_RESIST, F_LIM_REACT = range(7)
N_FNS = 7
# OsdiSimInfo as 8-byte words: paras (4 pointers), abstime, prev_solve, prev_state, next_state, flags,
# history_ctx, query_past_state
W_ABSTIME, W_PREV_SOLVE, W_PREV_STATE, W_NEXT_STATE, W_FLAGS = 4, 5, 6, 7, 8
# netdae's words after the OsdiSimInfo (11 words): the call's shortest $bound_step, its $finish/$stop flags
# (EVAL_RET_FLAG_FINISH | EVAL_RET_FLAG_STOP) and the first instance that raised one
W_BOUND, W_STOP, W_STOP_INST = 11, 12, 13
INFO_WORDS = 14
#: eval() flags: both residuals and Jacobians, a transient (abi.CALC_* | abi.ANALYSIS_TRAN)
FLAGS_JACOBIAN = 1 | 2 | 4 | 8 | 8192
FLAGS_RESIDUAL = 1 | 2 | 8192
#: ENABLE_LIM | CALC_RESIST_LIM_RHS | CALC_REACT_LIM_RHS, and with INIT_LIM
FLAGS_LIMIT = 256 | 64 | 128
FLAGS_LIMIT_INITIAL = FLAGS_LIMIT | 512
EVAL_RET_FLAG_LIM = 1
EVAL_RET_FLAG_FATAL = 2
#: $finish, $stop (EVAL_RET_FLAG_FINISH | EVAL_RET_FLAG_STOP)
EVAL_RET_FLAGS_END = 4 | 8

_PTR = ir.IntType(8).as_pointer()


def _pointers(builder, values):
    return [builder.inttoptr(v, _PTR) for v in values]


@intrinsic
def call_eval(typingctx, addr, handle, inst, model, info):
    """``uint32 eval(void *handle, void *inst, void *model, OsdiSimInfo *info)`` at ``addr``."""
    sig = types.int64(types.int64, types.int64, types.int64, types.int64, types.int64)

    def codegen(context, builder, signature, args):
        fnty = ir.FunctionType(ir.IntType(32), [_PTR] * 4)
        fn = builder.inttoptr(args[0], fnty.as_pointer())
        ret = builder.call(fn, _pointers(builder, args[1:]))
        return builder.zext(ret, ir.IntType(64))

    return sig, codegen


@intrinsic
def load_double(typingctx, addr):
    """The ``double`` at address ``addr`` (a module's ``$bound_step`` in its instance data)."""
    sig = types.float64(types.int64)

    def codegen(context, builder, signature, args):
        return builder.load(builder.inttoptr(args[0], ir.DoubleType().as_pointer()))

    return sig, codegen


@intrinsic
def call_load(typingctx, addr, inst, model, dst):
    """``void load_residual_*(void *inst, void *model, double *dst)`` at ``addr``."""
    sig = types.void(types.int64, types.int64, types.int64, types.int64)

    def codegen(context, builder, signature, args):
        fnty = ir.FunctionType(ir.VoidType(), [_PTR] * 3)
        builder.call(builder.inttoptr(args[0], fnty.as_pointer()), _pointers(builder, args[1:]))
        return context.get_dummy_value()

    return sig, codegen


@intrinsic
def call_jacobian_resist(typingctx, addr, inst, model):
    """``void load_jacobian_resist(void *inst, void *model)`` at ``addr``."""
    sig = types.void(types.int64, types.int64, types.int64)

    def codegen(context, builder, signature, args):
        fnty = ir.FunctionType(ir.VoidType(), [_PTR] * 2)
        builder.call(builder.inttoptr(args[0], fnty.as_pointer()), _pointers(builder, args[1:]))
        return context.get_dummy_value()

    return sig, codegen


@intrinsic
def call_jacobian_react(typingctx, addr, inst, model, alpha):
    """``void load_jacobian_react(void *inst, void *model, double alpha)`` at ``addr``."""
    sig = types.void(types.int64, types.int64, types.int64, types.float64)

    def codegen(context, builder, signature, args):
        fnty = ir.FunctionType(ir.VoidType(), [_PTR, _PTR, ir.DoubleType()])
        fn = builder.inttoptr(args[0], fnty.as_pointer())
        builder.call(fn, _pointers(builder, args[1:3]) + [args[3]])
        return context.get_dummy_value()

    return sig, codegen


@kernel
def eval_osdi(x, t, mode, vold, vnew, inst, fns, slots, info_i, info_f, xbuf, fbuf, qbuf, jr, jc, q, phi, dq, dphi,
              jacobian):
    """Every OSDI instance at the extended iterate ``x``; adds into ``q``, ``phi``, ``dq``, ``dphi``."""
    n1 = x.size
    zero = True
    for i in range(n1):
        xbuf[i] = x[i]
        fbuf[i] = 0.0
        qbuf[i] = 0.0
        if x[i] != 0.0:
            zero = False
    lim = 0
    if mode == MODE_LIMIT:
        lim = FLAGS_LIMIT
    elif mode == MODE_INITIAL and zero:
        lim = FLAGS_LIMIT_INITIAL
    # a state a module does not write this time keeps its value (ngspice updates the states in place)
    for i in range(vnew.size):
        vnew[i] = vold[i] if mode == MODE_LIMIT else 0.0
    info_f[W_ABSTIME] = t
    info_i[W_PREV_SOLVE] = xbuf.ctypes.data
    info_i[W_PREV_STATE] = vold.ctypes.data
    info_i[W_NEXT_STATE] = vnew.ctypes.data
    info_i[W_FLAGS] = (FLAGS_JACOBIAN if jacobian else FLAGS_RESIDUAL) | lim
    if jacobian:
        for e in range(jr.size):
            jr[e] = 0.0
            jc[e] = 0.0
    info = info_i.ctypes.data
    fptr = fbuf.ctypes.data
    qptr = qbuf.ctypes.data
    flags = 0
    bad = -1
    bound = math.inf
    ends = 0
    info_i[W_STOP_INST] = -1
    for k in range(inst.shape[0]):
        m = inst[k, I_MODULE]
        ip = inst[k, I_INST]
        mp = inst[k, I_MODEL]
        ret = call_eval(fns[m, F_EVAL], inst[k, I_HANDLE], ip, mp, info)
        if ret & EVAL_RET_FLAG_FATAL:
            flags |= FLAG_NONFINITE
            if bad < 0:
                bad = k
        if ret & EVAL_RET_FLAG_LIM:
            flags |= FLAG_LIMITED
        if ret & EVAL_RET_FLAGS_END:
            if ends == 0:
                info_i[W_STOP_INST] = k
            ends |= ret & EVAL_RET_FLAGS_END
        if inst[k, I_BOUND] != 0:
            b = load_double(inst[k, I_BOUND])
            if b > 0.0 and b < bound:  # a module that set none this call leaves it at inf (or 0)
                bound = b
        call_load(fns[m, F_RES_RESIST], ip, mp, fptr)
        call_load(fns[m, F_RES_REACT], ip, mp, qptr)
        if lim != 0:
            call_load(fns[m, F_LIM_RESIST], ip, mp, fptr)
            call_load(fns[m, F_LIM_REACT], ip, mp, qptr)
        if jacobian:
            call_jacobian_resist(fns[m, F_JAC_RESIST], ip, mp)
            call_jacobian_react(fns[m, F_JAC_REACT], ip, mp, 1.0)
    for i in range(n1):
        f = fbuf[i]
        c = qbuf[i]
        if not (math.isfinite(f) and math.isfinite(c)):
            flags |= FLAG_NONFINITE
        phi[i] -= f
        q[i] += c
    if jacobian:
        for e in range(slots.size):
            s = slots[e]
            g = jr[e]
            c = jc[e]
            # an infinite slope at a finite value (a square root at 0) is taken as 0, as the behavioural
            # sources take theirs: Newton goes on with the other entries; a non-finite value stops it above
            if not math.isfinite(g):
                g = 0.0
            if not math.isfinite(c):
                c = 0.0
            dphi[s] -= g
            dq[s] += c
    info_f[W_BOUND] = bound
    info_i[W_STOP] = ends
    return flags, bad
