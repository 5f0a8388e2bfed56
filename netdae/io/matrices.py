"""Export the MNA matrices ``E``, ``H``, ``B`` of a circuit (``E x' = H x + B u(t)``).

``.npz``: one NumPy archive with the CSC parts of each matrix (``E_data``,
``E_indices``, ``E_indptr``, ``E_shape``, likewise ``H`` and ``B``), the
unknown names (``names``), the source names (``sources``), their DC values
(``u_dc``) and ``linearized`` (true when the circuit is nonlinear and the
matrices are its linearisation at the DC operating point, ``x_op`` then saved
too). Load with :func:`load_npz_matrices`.

``.mtx``: MatrixMarket files ``<stem>.E.mtx``, ``<stem>.H.mtx``,
``<stem>.B.mtx`` and ``<stem>.names.txt`` (one unknown name per line, then a
blank line and the source names) next to the given path.
"""

from __future__ import annotations

from contextlib import ExitStack
from pathlib import Path

import numpy as np
import scipy.io
import scipy.sparse as sp

from ..errors import NetdaeError
from .files import atomic_output

__all__ = ["matrices_of", "export_matrices", "load_npz_matrices"]


def matrices_of(circuit) -> dict:
    """E, H, B (CSC), names, sources, u_dc and, if nonlinear, the operating point."""
    from ..analyses.op import solve_operating_point
    from ..analyses.prepared import prepare
    from ..mna import MODE_DC

    prepared = prepare(circuit, mode=MODE_DC)
    system = prepared.system
    out = {
        "names": list(system.names),
        "sources": list(system.sources.names),
        "u_dc": system.sources.values(0.0).copy(),
        "B": sp.csc_matrix(system.B),
        "linearized": not system.linear,
    }
    if system.linear:
        out["E"], out["H"] = system.E, system.H
    else:
        op = solve_operating_point(prepared)
        out["E"], out["H"] = system.jacobians(op.x, 0.0)
        out["x_op"] = op.x
    return out


def export_matrices(circuit, path: str | Path) -> list[Path]:
    """Write the matrices of ``circuit`` to ``path`` (``.npz`` or ``.mtx``); returns the files written.

    The files appear together or not at all: each is written to a temporary
    file first and all are renamed once every one is complete.

    Raises
    ------
    NetdaeError
        For another file extension.
    OutputFileError
        When a file cannot be written (disk full, file-size limit, no
        permission); none of the files is left behind.
    """
    path = Path(path)
    if path.suffix not in (".npz", ".mtx"):
        raise NetdaeError(f"--export: unknown format '{path.suffix}' (use a .npz or .mtx path)")
    m = matrices_of(circuit)
    if path.suffix == ".npz":
        arrays = {"names": np.array(m["names"]), "sources": np.array(m["sources"]),
                  "u_dc": m["u_dc"], "linearized": np.array(m["linearized"])}
        if "x_op" in m:
            arrays["x_op"] = m["x_op"]
        for key in ("E", "H", "B"):
            mat = sp.csc_matrix(m[key])
            arrays[f"{key}_data"] = mat.data
            arrays[f"{key}_indices"] = mat.indices
            arrays[f"{key}_indptr"] = mat.indptr
            arrays[f"{key}_shape"] = np.array(mat.shape)
        with atomic_output(path) as handle:
            np.savez(handle, **arrays)
        return [path]
    stem = path.with_suffix("")
    comment = "netdae: E x' = H x + B u(t)" + (" (linearised at the DC operating point)" if m["linearized"] else "")
    files = [Path(f"{stem}.{key}.mtx") for key in ("E", "H", "B")] + [Path(f"{stem}.names.txt")]
    with ExitStack() as stack:
        for key, f in zip(("E", "H", "B"), files):
            scipy.io.mmwrite(stack.enter_context(atomic_output(f)), sp.coo_matrix(m[key]), precision=17,
                             comment=comment)
        names = "\n".join(m["names"]) + "\n\n" + "\n".join(m["sources"]) + "\n"
        stack.enter_context(atomic_output(files[-1])).write(names.encode("utf-8"))
    return files


def load_npz_matrices(path: str | Path) -> dict:
    """Read a ``.npz`` written by :func:`export_matrices` back into CSC matrices and lists."""
    with np.load(path) as z:
        out = {"names": [str(s) for s in z["names"]], "sources": [str(s) for s in z["sources"]],
               "u_dc": z["u_dc"], "linearized": bool(z["linearized"])}
        for key in ("E", "H", "B"):
            out[key] = sp.csc_matrix((z[f"{key}_data"], z[f"{key}_indices"], z[f"{key}_indptr"]),
                                     shape=tuple(z[f"{key}_shape"]))
        if "x_op" in z:
            out["x_op"] = z["x_op"]
    return out
