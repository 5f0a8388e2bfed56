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
  Jacobian pairs in ``jr``/``jc``/``slots``, the address of its
  ``$bound_step`` value (0: its module has none), and the bypass's words
  (``I_NODES`` ...);
- ``fns``: int64[M, N_FNS]: per module the addresses of ``eval``,
  ``load_residual_resist``, ``load_residual_react``, ``load_jacobian_resist``
  and ``load_jacobian_react``;
- ``slots``: int64[P]: every Jacobian pair's position in ``dq``/``dphi``
  (a pair: an instance's entries of one (row, column), which its module
  loads into one place; all its entries with a ground row or column are
  one more pair, in the dummy slot);
- ``info_i``, ``info_f``: the ``OsdiSimInfo`` the modules read, as int64 and
  float64 views of one buffer (its parameter pointers set by the family),
  followed by netdae's words the modules do not see: the call's shortest
  ``$bound_step`` (``info_f[W_BOUND]``, inf: none), and the ``$finish`` /
  ``$stop`` flags of the call (``info_i[W_STOP]``) with the first instance
  that raised one (``info_i[W_STOP_INST]``), the bypass's switch, tolerances
  and count (``W_BYPASS`` ...), then its per-instance words;
- ``xbuf`` (the iterate the modules read through their node mapping),
  ``fbuf``, ``qbuf`` (residuals, float64[n + 1]), ``jr``, ``jc`` (Jacobian
  pairs, float64[P]): the family's buffers, whose addresses the instances
  hold (node mapping, Jacobian pointers set by ``OsdiFamily.bind``).

The kernel ADDS ``-f`` to ``phi``, ``q`` to ``q`` and, when ``jacobian``,
``-df/dx`` and ``dq/dx`` through ``slots``; flags bit 0 marks a module that
limited, bit 1 a non-finite value or a module's fatal error.

Device bypass (``info_i[W_BYPASS]``, set per analysis by
:func:`netdae.devices.osdi.family.set_bypass` with the analysis' tolerances:
a transient's, unless ``.options bypass=0`` or ``NETDAE_OSDI_BYPASS=0``): an
instance whose nodes all moved less than ``reltol`` of their voltage plus
``vntol`` since its last evaluation *at the same time* ``t``, and whose
currents and charges that evaluation's Jacobians then change by less than
``reltol`` of them plus ``abstol`` (``chgtol``), is not evaluated: its
residuals are that evaluation's continued to ``x`` to first order, its
Jacobians and limiting states are that evaluation's. These are ngspice's
bypass tests (``.options bypass``, off by default in ngspice, which keeps
the last load's linearisation just so); the first evaluation at each time
point and every ``MODE_INITIAL`` one are never bypassed; an instance
continues only from an evaluation within a Newton iteration (``MODE_LIMIT``)
where it did not limit, end or fail, and only an instance whose unknowns are
all potentials in volts (``I_NN`` >= 0, the family's choice) is bypassed.
Those evaluations load the Jacobians whatever ``jacobian`` says (OpenVAF's
``eval`` computes them whatever the flags ask, so this costs the loads).
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
#: the bypass's words (:func:`_bypass`): the instance's distinct nodes (offset of their extended indices in
#: ``info_i``, their count; -1: never bypassed), its reference block (offset in ``info_f``), its states
#: (first, count), and per Jacobian pair of its range its place ``row * count + column`` on those nodes
#: (-1: the pair of a ground row or column; offset in ``info_i``)
I_NODES, I_NN, I_REF, I_S0, I_NS, I_PLACE = range(7, 13)
N_INST = 13
# fns columns
F_EVAL, F_RES_RESIST, F_RES_REACT, F_JAC_RESIST, F_JAC_REACT, F_LIM_RESIST, F_LIM_REACT = range(7)
N_FNS = 7
# OsdiSimInfo as 8-byte words: paras (4 pointers), abstime, prev_solve, prev_state, next_state, flags,
# history_ctx, query_past_state
W_ABSTIME, W_PREV_SOLVE, W_PREV_STATE, W_NEXT_STATE, W_FLAGS = 4, 5, 6, 7, 8
# netdae's words after the OsdiSimInfo (11 words): the call's shortest $bound_step, its $finish/$stop flags
# (EVAL_RET_FLAG_FINISH | EVAL_RET_FLAG_STOP) and the first instance that raised one
W_BOUND, W_STOP, W_STOP_INST = 11, 12, 13
#: the bypass: on (1) or off (0), its tolerances (reltol, vntol, abstol, chgtol), a count of the
#: evaluations it saved and the most nodes of an instance; then that many words of work, then the
#: instances' words (at the ``I_NODES``, ``I_PLACE`` and ``I_REF`` offsets)
W_BYPASS, W_RTOL, W_VTOL, W_ITOL, W_QTOL, W_BYPASSED, W_MAXNODES = range(14, 21)
INFO_WORDS = 21
#: an instance's reference block: the time, whether it holds an evaluation, then per node its voltage,
#: current and charge, the instance's states, its Jacobian pairs (resistive, reactive) and per node the
#: continuation's changes of its current and charge
REF_T, REF_OK, REF_V = 0, 1, 2
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
    # with the bypass, the evaluations within a Newton iteration (MODE_LIMIT) are kept as the points a bypass
    # continues from, with their Jacobians (the modules compute them whatever the flags say); one without
    # limiting (MODE_EVALUATE: the charges at a converged point, the last of its time) may be bypassed but is
    # not kept
    keep = info_i[W_BYPASS] != 0 and mode == MODE_LIMIT
    loads = keep or jacobian
    info_i[W_FLAGS] = (FLAGS_JACOBIAN if loads else FLAGS_RESIDUAL) | lim
    info = info_i.ctypes.data
    fptr = fbuf.ctypes.data
    qptr = qbuf.ctypes.data
    flags = 0
    bad = -1
    bound = math.inf
    ends = 0
    info_i[W_STOP_INST] = -1
    may_bypass = info_i[W_BYPASS] != 0 and mode != MODE_INITIAL
    rtol = info_f[W_RTOL]
    vtol = info_f[W_VTOL]
    itol = info_f[W_ITOL]
    qtol = info_f[W_QTOL]
    dv = info_f[INFO_WORDS:INFO_WORDS + info_i[W_MAXNODES]]
    for k in range(inst.shape[0]):
        m = inst[k, I_MODULE]
        ip = inst[k, I_INST]
        mp = inst[k, I_MODEL]
        nn = inst[k, I_NN]
        j0 = inst[k, I_JAC0]
        j1 = inst[k, I_JAC1]
        if may_bypass and nn >= 0 and _bypass(k, t, x, inst, info_i, info_f, rtol, vtol, itol, qtol, dv):
            _continue(k, inst, info_i, info_f, fbuf, qbuf, jr, jc, vnew, jacobian)
            info_i[W_BYPASSED] += 1
        else:
            nodes = inst[k, I_NODES]
            ref = inst[k, I_REF]
            if keep and nn >= 0:  # the residuals of the instances before it, subtracted below
                for j in range(nn):
                    node = info_i[nodes + j]
                    info_f[ref + REF_V + j] = x[node]
                    info_f[ref + REF_V + nn + j] = fbuf[node]
                    info_f[ref + REF_V + 2 * nn + j] = qbuf[node]
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
            call_load(fns[m, F_RES_RESIST], ip, mp, fptr)
            call_load(fns[m, F_RES_REACT], ip, mp, qptr)
            if lim != 0:
                call_load(fns[m, F_LIM_RESIST], ip, mp, fptr)
                call_load(fns[m, F_LIM_REACT], ip, mp, qptr)
            if loads:
                for e in range(j0, j1):
                    jr[e] = 0.0
                    jc[e] = 0.0
                call_jacobian_resist(fns[m, F_JAC_RESIST], ip, mp)
                call_jacobian_react(fns[m, F_JAC_REACT], ip, mp, 1.0)
            if keep and nn >= 0:
                _remember(k, t, ret, mode, inst, info_i, info_f, fbuf, qbuf, jr, jc, vnew)
        if inst[k, I_BOUND] != 0:
            b = load_double(inst[k, I_BOUND])
            if b > 0.0 and b < bound:  # a module that set none this call leaves it at inf (or 0)
                bound = b
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


@kernel
def _remember(k, t, ret, mode, inst, info_i, info_f, fbuf, qbuf, jr, jc, vnew):
    """Instance ``k``'s evaluation as the point a bypass continues from: its residuals (this call's
    loads less what the instances before it loaded), its states, its Jacobian pairs (kept apart: the
    numpy family's evaluations load theirs into the same ``jr``, ``jc``) and the time; not when the
    module limited, ended or failed, nor from scratch (``MODE_INITIAL``), nor when a value is not finite."""
    nn = inst[k, I_NN]
    nodes = inst[k, I_NODES]
    v0 = inst[k, I_REF] + REF_V
    ok = ret == 0 and mode != MODE_INITIAL
    for j in range(nn):
        node = info_i[nodes + j]
        f = fbuf[node] - info_f[v0 + nn + j]
        c = qbuf[node] - info_f[v0 + 2 * nn + j]
        info_f[v0 + nn + j] = f
        info_f[v0 + 2 * nn + j] = c
        if not (math.isfinite(f) and math.isfinite(c)):
            ok = False
    ns = inst[k, I_NS]
    s0 = inst[k, I_S0]
    for i in range(ns):
        info_f[v0 + 3 * nn + i] = vnew[s0 + i]
    j0 = inst[k, I_JAC0]
    nc = inst[k, I_JAC1] - j0
    g0 = v0 + 3 * nn + ns
    for c in range(nc):
        g = jr[j0 + c]
        q = jc[j0 + c]
        if not (math.isfinite(g) and math.isfinite(q)):
            ok = False
        info_f[g0 + c] = g
        info_f[g0 + nc + c] = q
    info_f[v0 - REF_V + REF_T] = t
    info_f[v0 - REF_V + REF_OK] = 1.0 if ok else 0.0


@kernel
def _bypass(k, t, x, inst, info_i, info_f, rtol, vtol, itol, qtol, dv):
    """Whether instance ``k`` may keep its last evaluation, continued to ``x`` to first order (ngspice's
    device bypass): that evaluation was made at this time ``t`` (never the first evaluation of a time
    point), every node of the instance within ``rtol`` of its voltage there plus ``vtol``, and the
    continuation changes each residual by no more than ``rtol`` of it plus ``itol`` (currents) or
    ``qtol`` (charges). ``dv`` is work (at least the instance's node count); the residuals' changes are
    left in the instance's block."""
    ref = inst[k, I_REF]
    if info_f[ref + REF_OK] == 0.0 or info_f[ref + REF_T] != t:
        return False
    nn = inst[k, I_NN]
    nodes = inst[k, I_NODES]
    v0 = ref + REF_V
    for j in range(nn):
        v = x[info_i[nodes + j]]
        vr = info_f[v0 + j]
        d = v - vr
        if abs(d) > rtol * max(abs(v), abs(vr)) + vtol:
            return False
        dv[j] = d
    nc = inst[k, I_JAC1] - inst[k, I_JAC0]
    place = inst[k, I_PLACE]
    g0 = v0 + 3 * nn + inst[k, I_NS]
    w = g0 + 2 * nc
    for j in range(2 * nn):
        info_f[w + j] = 0.0
    for c in range(nc):
        rc = info_i[place + c]
        if rc >= 0:
            row = rc // nn
            d = dv[rc - row * nn]
            info_f[w + row] += info_f[g0 + c] * d
            info_f[w + nn + row] += info_f[g0 + nc + c] * d
    for j in range(nn):
        f = info_f[v0 + nn + j]
        c = info_f[v0 + 2 * nn + j]
        df = info_f[w + j]
        dc = info_f[w + nn + j]
        if abs(df) > rtol * max(abs(f), abs(f + df)) + itol or abs(dc) > rtol * max(abs(c), abs(c + dc)) + qtol:
            return False
    return True


@kernel
def _continue(k, inst, info_i, info_f, fbuf, qbuf, jr, jc, vnew, jacobian):
    """Instance ``k``'s residuals continued from its last evaluation by the changes :func:`_bypass` left,
    its states there and, with ``jacobian``, its Jacobian pairs there."""
    nn = inst[k, I_NN]
    nodes = inst[k, I_NODES]
    v0 = inst[k, I_REF] + REF_V
    ns = inst[k, I_NS]
    j0 = inst[k, I_JAC0]
    nc = inst[k, I_JAC1] - j0
    g0 = v0 + 3 * nn + ns
    w = g0 + 2 * nc
    for j in range(nn):
        node = info_i[nodes + j]
        fbuf[node] += info_f[v0 + nn + j] + info_f[w + j]
        qbuf[node] += info_f[v0 + 2 * nn + j] + info_f[w + nn + j]
    s0 = inst[k, I_S0]
    for i in range(ns):
        vnew[s0 + i] = info_f[v0 + 3 * nn + i]
    if jacobian:
        for c in range(nc):
            jr[j0 + c] = info_f[g0 + c]
            jc[j0 + c] = info_f[g0 + nc + c]
