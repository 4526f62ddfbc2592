"""The OSQP backend: OSQP 1.1.3 (the Python package for the reference, embedded mode 2 in the generated C).

Python side: :class:`Backend` (setup, update, warm start, solve, status map). C side: ``templates/backends/osqp.c.j2``
with the tables of :func:`codegen_context`; :func:`write_files` exports OSQP's workspace and library into a folder.
"""
from __future__ import annotations

import re
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import osqp

from . import (QP_STATUSES, QP_DUAL_INFEASIBLE, QP_MAX_ITER, QP_NONCONVEX, QP_OTHER, QP_PRIMAL_INFEASIBLE, QP_SOLVED,
               QP_SOLVED_INACCURATE, BackendFiles, BackendLibrary, QpResult)
from ..codegen.osqp_export import export_osqp, restore_osqp_library

if TYPE_CHECKING:  # pragma: no cover
    from ..dsl import QpOptions
    from ..ocp import Ocp
    from ..qp import QpLayout

LABEL = "OSQP 1.1.3 (embedded mode 2)"
"""How the generated header and README name this backend."""

RAW_STATUS = {1: QP_SOLVED, 2: QP_SOLVED_INACCURATE, 3: QP_PRIMAL_INFEASIBLE, 4: QP_PRIMAL_INFEASIBLE,
              5: QP_DUAL_INFEASIBLE, 6: QP_DUAL_INFEASIBLE, 7: QP_MAX_ITER, 8: QP_OTHER, 9: QP_NONCONVEX,
              10: QP_OTHER, 11: QP_OTHER}
"""OSQP 1.x ``status_val`` (1 solved, 2 solved inaccurate, 3/4 primal infeasible (inaccurate), 5/6 dual
infeasible (inaccurate), 7 max iter, 8 time limit, 9 non-convex, 10 sigint, 11 unsolved) -> generic QP_* status."""

OSQP_STRUCT_BYTES = {False: 1808, True: 1668}
"""OSQP's bookkeeping structs in a workspace (solver, settings, info, vectors, matrices, ...): a fixed set whose size
does not depend on the problem (with the alignment padding between the mutable arrays); measured for osqp 1.1.3
with gcc 12 on x86-64 (LP64), double / float, truck_lifted_ellipse."""

_OSQP_ARRAY = re.compile(r"^(OSQPFloat|OSQPInt|QDLDL_int|QDLDL_bool|QDLDL_float)\s+\w+\[(\d+)\]", re.M)


def generic_status(raw: int) -> int:
    """The generic QP_* status of an OSQP ``status_val`` (QP_OTHER for a value OSQP does not define)."""
    return RAW_STATUS.get(int(raw), QP_OTHER)


FLOAT_SIGMA_MIN = 1e-3
"""The smallest OSQP ``sigma`` of a float build (the generator raises ``qp.sigma`` to it; double builds keep it).

Measured on the QPs of a truck_lifted_ellipse closed loop (``scripts/float_kkt_diagnosis.py``; docs/performance.md,
"Single precision in closed loop"): at the converged solution one KKT solve (OSQP's QDLDL factorization of the
quasi-definite KKT matrix) should give the solution back; in float it is off by 5.2e-3 (scaled step, median; up to
1.8e-2) with sigma = 1e-6, 7.6e-4 with 1e-4 and 7.1e-5 with 1e-3 (double: 6e-10 for all three). sigma sets the
smallest pivots of the LDL' factorization (2e-5 with sigma = 1e-6, 1e-3 with 1e-3), and the pivots they leave in the
constraint block grow to |d| = 1e6 (1.3e3 with 1e-3): element growth, a backward error (one step of iterative
refinement in float brings the 5.2e-3 to 8e-5, at the cost of a second solve per iteration). The noise this
injects at every ADMM iteration kept the capped float solve 8e-3 (median) from the double one and the closed loop
+1.1 % from double's progress. With sigma = 1e-3 the capped float solve is 1.4e-4 from the double solve of the same
sigma and 4e-4 from the double build's (sigma = 1e-6 to 1e-3 moves the double solve by 4e-4), the closed loop is
within 0.01 % of double, at no cost per iteration. The error does not depend on rho (0.2 or 1); a smaller rho_eq
(1e2 rho) slows both precisions."""


def osqp_sigma(opts: "QpOptions", use_float: bool = False) -> float:
    """The ``sigma`` a build uses: ``qp.sigma``, in a float build at least :data:`FLOAT_SIGMA_MIN`."""
    return max(opts.sigma, FLOAT_SIGMA_MIN) if use_float else opts.sigma


def osqp_settings(opts: "QpOptions", use_float: bool = False) -> dict:
    """OSQP settings, identical for the Python package and the generated code of that precision (only ``sigma``
    depends on it, :func:`osqp_sigma`; the Python reference computes in double with the double build's settings)."""
    return dict(max_iter=opts.max_iter, eps_abs=opts.eps_abs, eps_rel=opts.eps_rel, eps_prim_inf=1e-5,
                eps_dual_inf=1e-5, rho=opts.rho, sigma=osqp_sigma(opts, use_float), alpha=opts.alpha,
                adaptive_rho=opts.adaptive_rho, scaling=opts.scaling,
                check_termination=opts.check_termination, check_dualgap=False, warm_starting=opts.warm_start,
                polishing=False, verbose=False)


def _setup_data(lay: "QpLayout") -> tuple:
    """The QP OSQP is set up (and the C workspace exported) with: q = 0, l = min(L, 0), u = max(U, 0)."""
    return (lay.P_matrix(), np.zeros(lay.n), lay.A_pattern(np.ones(lay.nnz_A)), np.minimum(lay.L, 0.0),
            np.maximum(lay.U, 0.0))


class Backend:
    """OSQP through its Python package, with the calls the generated C makes, in the same order."""

    name = "osqp"

    def __init__(self, layout: "QpLayout", opts: "QpOptions"):
        self.lay = layout
        self.opts = opts
        self.settings = osqp_settings(opts)
        self.reset()

    def reset(self) -> None:
        self.solver = osqp.OSQP()
        self.solver.setup(*_setup_data(self.lay), **self.settings)

    def set_matrices(self, P_x: np.ndarray, A_x: np.ndarray, q: np.ndarray) -> None:
        # q first (osqp's update loads vectors before matrices): OSQP recomputes its scaling in update_data_mat
        # from the q it holds, so it is this sample's q, not the previous sample's
        self.solver.update(q=q, Px=P_x, Ax=A_x)

    def solve(self, q: np.ndarray, l: np.ndarray, u: np.ndarray, y_warm: np.ndarray, max_iter: int) -> QpResult:
        s = self.solver
        s.update(q=q, l=l, u=u)
        s.warm_start(x=np.zeros(self.lay.n), y=y_warm)
        budget = max_iter != self.opts.max_iter
        if budget:
            s.update_settings(max_iter=max_iter)
        res = s.solve(raise_error=False)
        if budget:
            s.update_settings(max_iter=self.opts.max_iter)
        raw = int(res.info.status_val)
        return QpResult(status=generic_status(raw), raw_status=raw, iter=int(res.info.iter),
                        z=None if res.x is None else np.array(res.x, dtype=float),
                        y=None if res.y is None else np.array(res.y, dtype=float))


# -- generated code ----------------------------------------------------------------------------------------------

def codegen_context(ocp: "Ocp", layout: "QpLayout", opts: "QpOptions") -> dict[str, Any]:
    """What ``templates/backends/osqp.c.j2`` needs (rendered under the key ``backend``)."""
    prefix = f"{ocp.problem.name}_"
    settings = osqp_settings(opts)
    raw = [(k, QP_STATUSES[v - 1]) for k, v in sorted(RAW_STATUS.items())]
    return {"workspace_header": f"{prefix}workspace.h", "solver_name": f"{prefix}solver",
            "workspace_reset": f"{prefix}workspace_reset", "max_iter": settings["max_iter"],
            "raw_status": raw, "n_raw": max(RAW_STATUS) + 1}


def _array_bytes(workspace_c: str, real_size: int) -> int:
    sizes = {"OSQPFloat": real_size, "QDLDL_float": real_size, "OSQPInt": 4, "QDLDL_int": 4, "QDLDL_bool": 4}
    return sum(sizes[t] * int(n) for t, n in _OSQP_ARRAY.findall(workspace_c))


FLOAT_LIBRARY_CFLAGS = ("-fsingle-precision-constant",)
"""Extra flags of OSQP's library sources in a float build: their unsuffixed literals (``1.0 / OSQP_INFTY``,
``sca == 1.``, ``? 1.0 : v``) would otherwise make the compiler compute those expressions in double (software
routines on a single-precision FPU)."""
FLOAT_LIBRARY_REASON = "float build: OSQP's unsuffixed literals as float, no double arithmetic"


def write_files(ocp: "Ocp", layout: "QpLayout", opts: "QpOptions", out_dir: Path, use_float: bool) -> BackendFiles:
    """Export OSQP's workspace (problem-specific) and library into ``out_dir/osqp``; returns the folder's files."""
    out_dir = Path(out_dir)
    P, q, A, l, u = _setup_data(layout)
    name = ocp.problem.name
    exp = export_osqp(P, A, q, l, u, osqp_settings(opts, use_float), out_dir, f"{name}_", use_float)
    private = ", ".join(f"`{d}`" for d in exp.private_include_dirs)
    lib_flags = FLOAT_LIBRARY_CFLAGS if use_float else ()
    library = BackendLibrary(
        suffix="osqp", label="OSQP", opt_var="OSQP_OPTFLAGS", opt_flags="-O3",
        opt_reason="the ADMM iterations are most of the run time",
        cflags=lib_flags, cflags_reason=FLOAT_LIBRARY_REASON if use_float else "",
        sources_note=f"OSQP's own files get `{' '.join(exp.cflags)}` and the private include folder {private}"
                     + (f"; its library sources also `{' '.join(lib_flags)}` ({FLOAT_LIBRARY_REASON})" if lib_flags
                        else "") + ".\n"
                     "The OSQP library sources in `osqp/lib/` are not committed: `fcgen build` restores them from the "
                     "installed osqp package.",
        symbols_note=f"OSQP's and QDLDL's included (`{name}_osqp_solve`, ...:\n`osqp/{name}_osqp_rename.h`, included "
                     "by `osqp_configure.h`, renames them in every file that includes an OSQP\nheader)")
    sigma = osqp_sigma(opts, use_float)
    precision = "" if sigma == opts.sigma else (
        f"**Single precision.** This float build runs OSQP with `sigma = {sigma:g}` (`qp.sigma` = {opts.sigma:g}, "
        "which the double build\nand the Python reference use): with a smaller sigma the float factorization of "
        "OSQP's KKT matrix is\nunstable (tiny pivots), which kept the capped ADMM about 8e-3 (scaled step, median) "
        "from the double solve on\ntruck_lifted_ellipse (fcgen's docs/performance.md); with it, about 4e-4.")
    return BackendFiles(
        sources=exp.workspace_sources, headers=exp.workspace_headers,
        library_sources=exp.library_sources, library_headers=exp.library_headers,
        include_dirs=exp.include_dirs, private_include_dirs=exp.private_include_dirs, cflags=exp.cflags,
        link_libs=exp.link_libs,
        array_bytes=_array_bytes((out_dir / exp.workspace_sources[0]).read_text(), 4 if use_float else 8),
        struct_bytes=OSQP_STRUCT_BYTES[use_float],
        memory_note="the arrays OSQP only\n  reads (matrix patterns, KKT maps, permutation, elimination tree, the factor's "
                    "pattern) are `const` (flash) and\n  have no RAM copy", library=library,
        memory_init_note="; its initial values are `static const` copies in flash",
        reset_note=f"The QP backend's workspace is restored from constant data (OSQP: `{name}_workspace_reset()` from "
                   "`static const`\ncopies) before its next use. A QP's scaling is computed from that sample's data: "
                   "OSQP recomputes it inside\n`osqp_update_data_mat` from the `q` it holds, so this sample's `q` is "
                   "loaded first (the only trace of the previous\nsample left is one scale/unscale rounding of `q`: the "
                   "step then differs by about 1e-11, where the previous order\nleft up to 0.3).",
        precision_note=precision)


def restore_library(out_dir: Path, use_float: bool) -> list[str]:
    """Bring the git-ignored OSQP library of a folder that uses this backend up to date (nothing for another folder).

    Always synced, never trusted because it exists: a copy left by an older fcgen (unprefixed, unpatched QDLDL that
    writes into what is now const data) would build and crash. Only changed files are written (~0.3 s).
    """
    out_dir = Path(out_dir)
    if not list((out_dir / "osqp").glob("*workspace.c")):
        return []
    return restore_osqp_library(out_dir, use_float)
