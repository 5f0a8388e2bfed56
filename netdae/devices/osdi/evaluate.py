"""Evaluating one OSDI instance at given node voltages (the loader's reference evaluation).

:class:`InstanceEvaluator` connects an :class:`~.instance.OsdiInstance` to
local arrays: its unknowns are the instance's terminals, then the internal
nodes that survive collapse (the vector ``eval`` reads, with one more entry
for ground), its Jacobian entries go into two scratch arrays which
:meth:`InstanceEvaluator.evaluate` sums into dense matrices over those
unknowns. OSDI's residual form is ``f(x) + d/dt q(x) = 0`` with ``f`` the
currents *leaving* each node through the device: netdae's charge form with
``phi = -f`` (see :mod:`netdae.devices.base`).

This is the reference the device family and its compiled twin are tested
against; it allocates nothing per call but is driven from Python (a few
microseconds of ctypes overhead per call).
"""

from __future__ import annotations

import ctypes as C
from dataclasses import dataclass

import numpy as np

from . import abi
from .instance import OsdiInstance

__all__ = ["OsdiEvaluation", "InstanceEvaluator", "ANALYSES", "eval_flags"]

#: eval() analysis flags by netdae's analysis name.
ANALYSES = {"dc": abi.ANALYSIS_DC | abi.ANALYSIS_STATIC, "tran": abi.ANALYSIS_TRAN, "ac": abi.ANALYSIS_AC}
_CALC_ALL = (abi.CALC_RESIST_RESIDUAL | abi.CALC_REACT_RESIDUAL | abi.CALC_RESIST_JACOBIAN
             | abi.CALC_REACT_JACOBIAN)


def eval_flags(analysis: str = "tran", operating_point: bool = False) -> int:
    """The ``OsdiSimInfo.flags`` of a full evaluation (residuals and both Jacobians) for an analysis."""
    return _CALC_ALL | ANALYSES[analysis] | (abi.CALC_OP if operating_point else 0)


@dataclass(frozen=True)
class OsdiEvaluation:
    """One evaluation over an instance's unknowns (terminals, then surviving internal nodes).

    Attributes
    ----------
    names : tuple of str
        The unknowns' node names.
    f, q : ndarray, shape (m,)
        Resistive residual (currents leaving each node) and reactive residual (charges).
    df, dq : ndarray, shape (m, m)
        Their Jacobians with respect to the unknowns.
    flags : int
        What ``eval`` returned (``EVAL_RET_FLAG_*``).
    """

    names: tuple[str, ...]
    f: np.ndarray
    q: np.ndarray
    df: np.ndarray
    dq: np.ndarray
    flags: int


class InstanceEvaluator:
    """Evaluates one instance at node voltages given over its non-collapsed nodes.

    Parameters
    ----------
    instance : OsdiInstance
        Set up, not yet connected (this object connects it).
    """

    def __init__(self, instance: OsdiInstance) -> None:
        self.instance = inst = instance
        mod = inst.module
        reps = inst.node_classes()
        kept = [i for i in range(len(mod.nodes)) if reps[i] == i]
        self.names = tuple(mod.nodes[i].name for i in kept)
        self.m = m = len(kept)
        local = {node: k for k, node in enumerate(kept)}
        self.mapping = np.array([m if r < 0 else local[r] for r in reps], dtype=np.uint32)
        nj = len(mod.jacobian)
        self.solve = np.zeros(m + 1)
        self.resid_f = np.zeros(m + 1)
        self.resid_q = np.zeros(m + 1)
        self.jr = np.zeros(max(nj, 1))
        self.jc = np.zeros(max(nj, 1))
        ns = max(mod.num_states, 1)
        self.prev_state = np.zeros(ns)
        self.next_state = np.zeros(ns)
        inst.connect(self.mapping, self.jr, self.jc)
        self.rows = np.array([self.mapping[e.row] for e in mod.jacobian], dtype=np.int64)
        self.cols = np.array([self.mapping[e.col] for e in mod.jacobian], dtype=np.int64)
        d = mod.descriptor
        self._eval = abi.EVAL(d.eval)
        self._res_f = abi.LOAD_RESIDUAL(d.load_residual_resist)
        self._res_q = abi.LOAD_RESIDUAL(d.load_residual_react)
        self._jac_f = abi.LOAD_JACOBIAN_RESIST(d.load_jacobian_resist)
        self._jac_q = abi.LOAD_JACOBIAN_REACT(d.load_jacobian_react)
        self.info = abi.OsdiSimInfo()
        self.info.paras = inst.model.sim.struct
        self.info.prev_solve = self.solve.ctypes.data_as(C.POINTER(C.c_double))
        self.info.prev_state = self.prev_state.ctypes.data_as(C.POINTER(C.c_double))
        self.info.next_state = self.next_state.ctypes.data_as(C.POINTER(C.c_double))

    def evaluate(self, v, *, analysis: str = "tran", t: float = 0.0, operating_point: bool = False) -> OsdiEvaluation:
        """Residuals and Jacobians at the unknowns ``v`` (shape (m,), ground is 0).

        ``operating_point`` also computes the module's operating-point
        variables (read them with ``instance.value("gm")``).

        Raises
        ------
        RuntimeError
            The module reported a fatal error (``$fatal``) during evaluation.
        """
        inst = self.instance
        self.solve[: self.m] = v
        self.solve[self.m] = 0.0
        self.info.abstime = float(t)
        self.info.flags = eval_flags(analysis, operating_point)
        ret = self._eval(inst.handle, inst.ptr, inst.model.ptr, C.byref(self.info))
        if ret & abi.EVAL_RET_FLAG_FATAL:
            raise RuntimeError(f"{inst.name}: OSDI module {inst.module.name} stopped with a fatal error")
        self.resid_f[:] = 0.0
        self.resid_q[:] = 0.0
        self.jr[:] = 0.0
        self.jc[:] = 0.0
        rf, rq = self.resid_f.ctypes.data, self.resid_q.ctypes.data
        self._res_f(inst.ptr, inst.model.ptr, rf)
        self._res_q(inst.ptr, inst.model.ptr, rq)
        self._jac_f(inst.ptr, inst.model.ptr)
        self._jac_q(inst.ptr, inst.model.ptr, 1.0)
        m = self.m
        df = np.zeros((m + 1, m + 1))
        dq = np.zeros((m + 1, m + 1))
        nj = len(self.rows)
        np.add.at(df, (self.rows, self.cols), self.jr[:nj])
        np.add.at(dq, (self.rows, self.cols), self.jc[:nj])
        return OsdiEvaluation(self.names, self.resid_f[:m].copy(), self.resid_q[:m].copy(), df[:m, :m], dq[:m, :m],
                              int(ret))
