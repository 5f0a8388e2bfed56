"""Print the numbers of docs/theory.md: the differentiator from netlist to Kronecker form.

Run from the repository root::

    .venv/bin/python scripts/theory_numbers.py            # everything, ngspice included when installed
    .venv/bin/python scripts/theory_numbers.py --no-ngspice

Every number in ``docs/theory.md`` comes from this script: the MNA matrices
``E``, ``H``, ``B`` of ``netlists/differentiator.cir`` (the op-amp
differentiator of the lecture notes, Section 1.3), the notes' construction of
the Kronecker form for a regular ``H`` (``H^-1 E`` nilpotent), the SVD form
(2.3) and its semi-explicit split (2.4)/(2.5), netdae's Weierstrass form (2.9)
and the decoupled solution (2.11)/(2.12) written back in circuit unknowns,
the oracles (Drazin index, SLICOT ``ag08bd``), the index report with the
classification of the unknowns, the consistency check of the DC operating
point at t0, the transient against the closed form ``v(out) = -L G V'(t)``,
the finite-gain variant and, when ngspice is installed, the comparison.

The script only reads netlists and prints; it changes nothing.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
NETLIST = ROOT / "netlists" / "differentiator.cir"
FINITE_GAIN = ROOT / "netlists" / "differentiator_finite_gain.cir"
#: Element values of netlists/differentiator.cir, for the closed forms.
R1, L1, FREQ = 100.0, 10e-3, 1e3
#: Gains of the finite-gain variant shown on the page (10 is the bundled netlist's).
GAINS = (10.0, 1e3, 1e6, 1e9)
#: The transient's error is also reported from this time on (after ngspice-style initial jumps).
AFTER_START = 1e-5
#: Entries below this are printed as 0 (rounding residue of orthogonal transformations).
PRINT_ZERO = 1e-13


def section(title: str) -> None:
    print()
    print(f"## {title}")
    print()


def fmt(v: float) -> str:
    return "0" if abs(v) < PRINT_ZERO else f"{v:.6g}"


def matrix(M, rows=None, cols=None) -> str:
    """A labelled matrix as aligned text."""
    M = np.asarray(M.toarray() if hasattr(M, "toarray") else M, dtype=float)
    rows = rows if rows is not None else [""] * M.shape[0]
    cols = cols if cols is not None else [str(j) for j in range(M.shape[1])]
    cells = [[fmt(v) for v in row] for row in M]
    width = max([len(c) for c in cols] + [len(c) for row in cells for c in row] + [1])
    rw = max([len(r) for r in rows] + [0])
    lines = [" " * rw + "  " + " ".join(f"{c:>{width}}" for c in cols)]
    for r, row in zip(rows, cells):
        lines.append(f"{r:<{rw}}  " + " ".join(f"{c:>{width}}" for c in row))
    return "\n".join(lines)


def equation(coeffs, names) -> str:
    """``a x1 + b x2 ...`` from a coefficient row."""
    terms = []
    for a, nm in zip(coeffs, names):
        if abs(a) < PRINT_ZERO:
            continue
        sign = "-" if a < 0 else "+"
        mag = "" if abs(abs(a) - 1.0) < 1e-15 else f"{abs(a):g} "
        terms.append(f"{sign} {mag}{nm}")
    if not terms:
        return "0"
    text = " ".join(terms)
    return text[2:] if text.startswith("+ ") else "-" + text[2:]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--no-ngspice", action="store_true", help="skip the comparison with ngspice")
    args = parser.parse_args()

    import scipy.linalg as sla

    import netdae
    from netdae.analyses.op import solve_operating_point
    from netdae.dae.pencil import drazin_index, svd_form, weierstrass_form
    from netdae.io.matrices import matrices_of
    from netdae.mna import MODE_TRAN, assemble

    np.set_printoptions(precision=6, suppress=True, linewidth=120)
    circuit = netdae.load(str(NETLIST))
    card = circuit.analyses[0]
    system = assemble(circuit, mode=MODE_TRAN, tstep=card.tstep, tstop=card.tstop)
    names = list(system.names)
    E, H, B = system.E.toarray(), system.H.toarray(), system.B.toarray()

    section("1. netlist")
    print("\n".join(ln for ln in NETLIST.read_text().splitlines()[1:] if ln and not ln.startswith("*")))

    section("2. MNA: E x' = H x + c(t), c(t) = B u(t)")
    kinds = {0: "V", 1: "A", 2: "-"}
    print("unknowns x:", ", ".join(f"{nm} [{kinds[int(k)]}]" for nm, k in zip(names, system.kinds)))
    print("sources u:", ", ".join(system.sources.names))
    print("\nE =")
    print(matrix(E, names, names))
    print("\nH =")
    print(matrix(H, names, names))
    print("\nB =")
    print(matrix(B, names, list(system.sources.names)))
    same = matrices_of(circuit)
    print("\nnetdae.io.matrices.matrices_of (what `netdae run --export` writes) gives the same E, H, B:",
          bool(np.array_equal(same["E"].toarray(), E) and np.array_equal(same["H"].toarray(), H)
               and np.array_equal(same["B"].toarray(), B)))
    print("\nthe rows as equations (row of the node or branch: (E x')_i = (H x)_i + c_i):")
    u_names = [f"{s}(t)" for s in system.sources.names]
    for i, nm in enumerate(names):
        lhs = equation(E[i], [f"d/dt {n}" for n in names])
        rhs = equation(np.concatenate([H[i], B[i]]), names + u_names)
        print(f"  {nm:<9} {lhs} = {rhs}")
    w = 2 * np.pi * FREQ
    for t in (0.0, 0.25e-3):
        print(f"c({t:g}) = {system.source(t).tolist()},  c'({t:g}) = {system.source(t, 1).tolist()}")
    print(f"(V(t) = sin(2 pi {FREQ:g} t): V'(0) = 2 pi {FREQ:g} = {w:.6f})")

    section("3. the notes' construction for a regular H (mu = 0): M = H^-1 E")
    print(f"det H = {np.linalg.det(H):.6g}  (H regular: the pencil is regular)")
    M = np.linalg.solve(H, E)
    print("M = H^-1 E =")
    print(matrix(M, names, names))
    print(f"rank M = {np.linalg.matrix_rank(M)}, max|M^2| = {np.max(np.abs(M @ M)):.3g}: "
          "M is nilpotent of degree 2, no Jordan block of a non-zero eigenvalue (no finite part)")
    K0 = -np.linalg.inv(H)
    K1 = -np.linalg.solve(H, E @ np.linalg.inv(H))
    print("x(t) = -H^-1 c(t) - H^-1 E H^-1 c'(t):")
    print(matrix(np.column_stack([K0 @ B, K1 @ B]), names, ["V(t)", "V'(t)"]))

    section("4. SVD form (2.3) and semi-explicit split (2.4)/(2.5)")
    sv = svd_form(E, H, balance=False)
    print(f"balance=False (orthogonal U, V): orthogonal = {sv.orthogonal}, n_y = {sv.n_y}, n_z = {sv.n_z}, "
          f"Sigma = {sv.sigma.tolist()}")
    print("U (rows pick the equations) =")
    print(matrix(sv.U, [f"row {i}" for i in range(len(names))], names))
    print("V (columns pick the unknowns) =")
    print(matrix(sv.V, names, [f"w{j}" for j in range(len(names))]))
    print("U E V =")
    print(matrix(sv.U @ E @ sv.V))
    new = [names[int(np.argmax(np.abs(sv.V[:, j])))] for j in range(len(names))]
    y, z = new[: sv.n_y], new[sv.n_y :]
    print(f"y = {y}, z = {z}")
    A11, A12, A21, A22 = sv.semi_explicit()
    c_rot = sv.U @ B
    print("semi-explicit (2.5): y' = A11 y + A12 z + Sigma^-1 (U c)_1,  0 = A21 y + A22 z + (U c)_2")
    print("A11 =", A11.tolist(), " A12 =")
    print(matrix(A12, y, z))
    print("A21, A22 (rows: the algebraic equations) =")
    print(matrix(np.hstack([A21, A22]), [f"eq {i}" for i in range(sv.n_z)], y + z))
    print("(U B)_2 =", c_rot[sv.n_y :, 0].tolist())
    print(f"A22 is singular: rank {np.linalg.matrix_rank(A22)} of {sv.n_z}, so (2.14) fails: not index 1")
    svb = svd_form(E, H)
    print(f"balanced (netdae's default): Sigma = {svb.sigma.tolist()} (U, V scaled by powers of two), "
          f"n_y = {svb.n_y}")

    section("5. Weierstrass form (2.9) and the decoupled solution (2.11)/(2.12)")
    wf = weierstrass_form(E, H)
    print(f"n_finite = {wf.n_finite}, n_infinite = {wf.n_infinite}, blocks (Jordan blocks of size > i) = "
          f"{wf.blocks}, index = {wf.index}, finite_method = {wf.finite_method}")
    print(f"C = {wf.C.tolist()} (no finite part), eigenvalues = {wf.eigenvalues.tolist()}")
    print("N =")
    print(matrix(wf.N))
    print(f"rank N = {np.linalg.matrix_rank(wf.N)}, max|N^2| = {np.max(np.abs(wf.N @ wf.N)):.3g}")
    nf = wf.n_finite
    target_E = sla.block_diag(np.eye(nf), wf.N)
    target_H = sla.block_diag(wf.C, np.eye(wf.n_infinite))
    print(f"max|U E V - diag(I, N)| = {np.max(np.abs(wf.U @ E @ wf.V - target_E)):.2g}, "
          f"max|U H V - diag(C, I)| = {np.max(np.abs(wf.U @ H @ wf.V - target_H)):.2g}")
    G0 = -wf.V2 @ wf.U2 @ B
    G1 = -wf.V2 @ wf.N @ wf.U2 @ B
    print("x = V2 z, z = -theta - N theta', theta = U2 c  =>  x(t) = g0 V(t) + g1 V'(t):")
    print(matrix(np.column_stack([G0, G1]), names, ["g0", "g1"]))
    print(f"same as section 3: max|g0 + H^-1 B| = {np.max(np.abs(G0 - K0 @ B)):.2g}, "
          f"max|g1 + H^-1 E H^-1 B| = {np.max(np.abs(G1 - K1 @ B)):.2g}")
    print(f"v(out) = {G1[2, 0]:.6g} V'(t); -L G = -L1/R1 = {-L1 / R1:.6g}")

    print("a perturbation delta(t) of Kirchhoff's current law at node minus (a current source I2 into it):")
    perturbed = netdae.load(NETLIST.read_text().replace(".tran", "I2 0 minus 0\n.tran"))
    ps = assemble(perturbed, mode=MODE_TRAN, tstep=card.tstep, tstop=card.tstop)
    Hp, Ep, Bp = ps.H.toarray(), ps.E.toarray(), ps.B.toarray()
    gp0 = -np.linalg.solve(Hp, Bp)
    gp1 = -np.linalg.solve(Hp, Ep @ np.linalg.solve(Hp, Bp))
    cols = [f"{s}(t)" for s in ps.sources.names] + [f"{s}'(t)" for s in ps.sources.names]
    print(matrix(np.hstack([gp0, gp1]), list(ps.names), cols))

    section("6. oracles")
    dz = drazin_index(E, H)
    print(f"Drazin index of (mu E - H)^-1 E: {dz.index}, ranks {dz.ranks}")
    try:
        import slycot
    except ImportError:
        print("slycot not installed: ag08bd skipped")
    else:
        n = E.shape[0]
        out = slycot.ag08bd(n, n, 0, 0, np.asfortranarray(H), np.asfortranarray(E), np.zeros((n, 1)),
                            np.zeros((1, n)), np.zeros((1, 1)))
        print(f"SLICOT ag08bd: infe = {sorted(out[6].tolist(), reverse=True)}, finite eigenvalues = "
              f"{out[0].shape[0]}, index = max(infe) = {max(out[6].tolist())}")

    section("7. netdae.analyze_index")
    rep = netdae.analyze_index(circuit)
    print(f"index = {rep.index}, regular = {rep.regular}, method = {rep.method}, rank_E = {rep.rank_E}, "
          f"n_dynamic = {rep.n_dynamic}, infinite_blocks = {rep.infinite_blocks}, "
          f"finite_eigenvalues = {rep.finite_eigenvalues.tolist()}")
    print("unknowns:", rep.unknowns)
    print("derivative_order:", rep.derivative_order)
    print(f"topology: applicable = {rep.topology.applicable}, topological_index = {rep.topology.topological_index}")
    print("  " + rep.topology.not_applicable_reason)
    for d in rep.pencil.evidence[:4]:
        print(f"  {d.what}: rank {d.rank}, tol {d.tol:.3g}, kept {list(d.kept)}, dropped {list(d.dropped)}")
    print("  warnings:", list(rep.pencil.warnings))

    section("8. consistency of the DC operating point at t0")
    op = solve_operating_point(system, transient=True)
    print("x_op(t0) =", dict(zip(names, op.x.tolist())))
    cons = rep.consistency
    print(f"consistent = {cons.consistent}, violation by constraint order = "
          f"{[float(f'{v:.3g}') for v in cons.violation_by_order]}, affected = {[names[i] for i in cons.affected]}")
    print("x_consistent =", {nm: float(f"{v:.9g}") for nm, v in zip(names, cons.x_consistent)})
    print(f"-L G V'(0) = {-L1 / R1 * w:.9g}")

    section("9. the transient")
    exact = lambda t: -L1 / R1 * w * np.cos(w * t)  # noqa: E731
    for label, opts in (("netlist options", {}), ("reltol=1e-6", {"reltol": 1e-6}),
                        ("initial='ngspice'", {"initial": "ngspice"})):
        r = netdae.simulate(circuit, **opts)
        err = np.abs(r["v(out)"] - exact(r.t))
        s = r.stats
        print(f"{label}: {r.message}; index {r.transient.index}, index2 {r.transient.index2}, "
              f"excluded from the error test: {r.tolerances['index_excluded']}")
        print(f"  steps {s['steps']}, rejected {s['rejected']}, newton {s['newton_iterations']}, "
              f"factorizations {s['factorizations']}, max order {s['integrator']['max_order_used']}, "
              f"h_min {s['integrator']['h_min']:.3g}, h_max {s['integrator']['h_max']:.3g}")
        print(f"  v(out): first values {r['v(out)'][:3].tolist()}; max |error| {err.max():.3g} V "
              f"({err.max() / (2 * L1 / R1 * w):.3g} of the range), after t = {AFTER_START:g}: "
              f"{err[r.t >= AFTER_START].max():.3g} V")
        for note in r.notes:
            print(f"  note: {note}")

    section("10. finite gain A: index 1, eigenvalue -R (1 + A) / L")
    text = FINITE_GAIN.read_text()
    for gain in GAINS:
        variant = netdae.load(text.replace("E1 out 0 0 minus 10", f"E1 out 0 0 minus {gain:g}"))
        rf = netdae.analyze_index(variant)
        lam = rf.finite_eigenvalues
        print(f"A = {gain:g}: index {rf.index}, n_dynamic {rf.n_dynamic}, eigenvalues {lam.tolist()}, "
              f"-R(1+A)/L = {-R1 * (1 + gain) / L1:.6g}, tau = {L1 / (R1 * (1 + gain)):.3g} s, "
              f"v(out) {rf.unknowns['v(out)']}")
    rfin = netdae.simulate(str(FINITE_GAIN), reltol=1e-6)
    print(f"A = 10 transient: {rfin.message}; notes: {rfin.notes}")

    if not args.no_ngspice:
        section("11. netdae compare (ngspice)")
        from netdae.comparison import compare
        from netdae.errors import NgspiceError

        try:
            cmp_default = compare(str(NETLIST))
            cmp_tight = compare(str(NETLIST), tight=True)
        except NgspiceError as exc:
            print(f"skipped: {exc}")
        else:
            for label, c in (("netlist options", cmp_default), ("tight", cmp_tight)):
                a = c.analysis("tran")
                worst = a.worst
                vout = next(s for s in a.signals if s.name == "v(out)")
                print(f"{label}: pass {c.passed}, op-amp gain {c.opamp_gain:g}, "
                      f"window from {a.window['from']:g} s, worst {worst.name} max_rel {worst.max_rel:.3g}, "
                      f"v(out) at t0: netdae {vout.jump['netdae']:.6g}, ngspice {vout.jump['ngspice']:.6g}, "
                      f"whole interval max_rel {vout.whole['max_rel']:.3g}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
