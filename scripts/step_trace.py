"""Per-attempt trace of the BDF step and order decisions on a netlist's transient.

Usage::

    python scripts/step_trace.py NETLIST [--json OUT] [--max-step S]

Runs the transient with the Python integrator (``NETDAE_ENGINE=python``: the
same formulas and decisions as the compiled loop, whose step counts agree to
a few per cent, docs/architecture.md) and records every step attempt: ``t``,
``h``, the order ``k``, accepted or why not (``error``, ``newton``), the
error estimates at orders k - 1, k, k + 1 (``err_km1``, ``err_k``,
``err_kp1``: IDA's, as :mod:`netdae.dae.bdf.controller` judges them), the
order proposed by the error test (``knew``) and chosen for the next step
(``knext``), the step factor ``eta`` after the growth rules, the unknown with
the largest weighted local error (``worst``) and each Newton solve of the
attempt as ``(fresh Jacobian, full Newton, converged, outcome, iterations)``;
a solve that converged and is followed by another in the same attempt was
rejected by the check of an iterate accepted with an older Jacobian
(docs/integrator.md). Then prints a summary: failures by kind and order,
Newton solves by outcome, order changes, the orders used and the unknowns
that limit the steps shorter than the largest step.

The trace wraps private methods of :class:`netdae.dae.bdf.stepper.BDF`; it is
a diagnostic, not an interface.
"""

from __future__ import annotations

import argparse
import collections
import json
import os
import sys
from pathlib import Path

os.environ["NETDAE_ENGINE"] = "python"
if __package__ in (None, ""):  # run as a script: make the package importable
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import numpy as np  # noqa: E402

import netdae  # noqa: E402
from netdae.dae.bdf import controller as ctl  # noqa: E402
from netdae.dae.bdf import corrector as cor  # noqa: E402
from netdae.dae.bdf import stepper  # noqa: E402


def _install(rows: list) -> None:
    """Wrap the integrator's attempt, Newton, order and growth decisions to append to ``rows``."""
    solves = []
    newton0 = cor.NonlinearCorrector._newton
    attempt0 = stepper.BDF._attempt
    select0 = stepper.BDF._select_order_and_step
    choose0 = ctl.choose_order
    hold0 = ctl.hold_growth

    def newton(self, fun, x_pred, cj, cjlast, setup, weights, full=False):
        res = newton0(self, fun, x_pred, cj, cjlast, setup, weights, full)
        solves.append((int(setup or full), int(full), int(res.converged), str(res.info), int(res.iterations)))
        return res

    def attempt(self, t_new, landing=False):
        solves.clear()
        k = self._hist.k
        accepted, kind, info = attempt0(self, t_new, landing)
        row = dict(t=self.t, h=t_new - self.t, k=k, accepted=bool(accepted), kind=kind,
                   newton_info=str(info.get("info", "")), knew=info.get("knew"), err_k=info.get("err_k"),
                   err_km1=info.get("err_km1"), newton=list(solves))
        ee = getattr(self, "_ee", None)
        if ee is not None and (accepted or kind == "error"):
            v = np.abs(ee[: self.n] * self._w_step_err)
            i = int(np.argmax(v))
            row["worst"], row["worst_weighted"] = self.system.names[i], float(v[i])
        rows.append(row)
        return accepted, kind, info

    def choose_order(k, err_km1, err_k, err_kp1):
        out = choose0(k, err_km1, err_k, err_kp1)
        rows[-1]["err_kp1"] = err_kp1
        return out

    def select(self, k, kdiff, info):
        eta = select0(self, k, kdiff, info)
        rows[-1]["knext"] = self._hist.k
        return eta

    def hold_growth(eta, retried, growth_failed, ns, k):
        out = hold0(eta, retried, growth_failed, ns, k)
        rows[-1]["eta"] = float(out[0])
        rows[-1]["growth_held"] = bool(out[0] != eta)
        return out

    cor.NonlinearCorrector._newton = newton
    stepper.BDF._attempt = attempt
    stepper.BDF._select_order_and_step = select
    ctl.choose_order = choose_order
    ctl.hold_growth = hold_growth


def summary(rows: list, max_step: float | None) -> str:
    """The trace's counts as text."""
    acc = [r for r in rows if r["accepted"]]
    failed = [r for r in rows if not r["accepted"]]
    out = [f"{len(rows)} attempts: {len(acc)} accepted, {len(failed)} failed"]
    by = collections.Counter((r["kind"], r["newton_info"], r["k"]) for r in failed)
    out.append("failed attempts (kind, Newton outcome, order): "
               + ", ".join(f"{key}: {n}" for key, n in by.most_common()))
    solves = collections.Counter()
    checked = 0
    for r in rows:
        s = r["newton"]
        solves.update((x[0], x[1], x[3]) for x in s)
        checked += sum(1 for i in range(len(s) - 1) if s[i][2])
    out.append("Newton solves (fresh, full, outcome): "
               + ", ".join(f"{key}: {n}" for key, n in solves.most_common())
               + f"; converged but rejected by the older-Jacobian check: {checked}")
    orders = np.bincount([r["k"] for r in acc], minlength=6)
    out.append("accepted steps by order 1-5: " + ", ".join(str(int(n)) for n in orders[1:]))
    changes = collections.Counter((r["k"], r["knext"]) for r in acc if r.get("knext", r["k"]) != r["k"])
    out.append("order changes after accepted steps: "
               + ", ".join(f"{a}->{b}: {n}" for (a, b), n in sorted(changes.items())))
    lowered = sum(1 for r in acc if r.get("knext", r["k"]) < r["k"] and r["knew"] == r["k"] - 1)
    out.append(f"  lowered by the error test's proposal: {lowered}, by the order selection: "
               f"{sum(n for (a, b), n in changes.items() if b < a) - lowered}")
    cap = max_step if max_step is not None else max((r["h"] for r in acc), default=0.0)
    short = [r for r in acc if r["h"] < (1.0 - 1e-3) * cap]
    limiting = collections.Counter(r.get("worst") for r in short).most_common(6)
    out.append(f"accepted steps shorter than {cap:.3g}: {len(short)}; their worst unknowns: "
               + ", ".join(f"{name}: {n}" for name, n in limiting))
    out.append("worst unknowns of the error-test failures: "
               + ", ".join(f"{name}: {n}" for name, n in
                           collections.Counter(r.get("worst") for r in failed if r["kind"] == "error").most_common(6)))
    return "\n".join(out)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("netlist")
    p.add_argument("--json", help="write the attempts as a JSON list")
    p.add_argument("--max-step", type=float, help="the largest step (default: the largest taken)")
    args = p.parse_args(argv)
    rows: list = []
    _install(rows)
    netdae.run(args.netlist)
    if args.json:
        Path(args.json).write_text(json.dumps(rows))
    print(summary(rows, args.max_step))
    return 0


if __name__ == "__main__":
    sys.exit(main())
