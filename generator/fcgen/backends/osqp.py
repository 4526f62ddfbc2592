"""The OSQP backend: OSQP 1.1.3 (the Python package for the reference, embedded mode 2 in the generated C).

Python side: :class:`Backend` (setup, update, warm start, solve, status map) and the settings both sides share. The
exported C (OSQP's workspace and library) is :mod:`.osqp_export`'s; the solver's part of it, ``codegen/osqp_files.py``
(the context of ``templates/backends/osqp.c.j2`` and the folder's files).
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import osqp

from . import (
    QP_DUAL_INFEASIBLE,
    QP_MAX_ITER,
    QP_NONCONVEX,
    QP_OTHER,
    QP_PRIMAL_INFEASIBLE,
    QP_SOLVED,
    QP_SOLVED_INACCURATE,
    QpResult,
)
from .osqp_export import restore_osqp_library

if TYPE_CHECKING:  # pragma: no cover
    from ..dsl import QpOptions
    from ..qp import QpLayout

LABEL = "OSQP 1.1.3 (embedded mode 2)"
"""How the generated header and README name this backend."""

RAW_STATUS = {
    1: QP_SOLVED,
    2: QP_SOLVED_INACCURATE,
    3: QP_PRIMAL_INFEASIBLE,
    4: QP_PRIMAL_INFEASIBLE,
    5: QP_DUAL_INFEASIBLE,
    6: QP_DUAL_INFEASIBLE,
    7: QP_MAX_ITER,
    8: QP_OTHER,
    9: QP_NONCONVEX,
    10: QP_OTHER,
    11: QP_OTHER,
}
"""OSQP 1.x ``status_val`` (1 solved, 2 solved inaccurate, 3/4 primal infeasible (inaccurate), 5/6 dual
infeasible (inaccurate), 7 max iter, 8 time limit, 9 non-convex, 10 sigint, 11 unsolved) -> generic QP_* status."""


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


def osqp_sigma(opts: QpOptions, use_float: bool = False) -> float:
    """The ``sigma`` a build uses: ``qp.sigma``, in a float build at least :data:`FLOAT_SIGMA_MIN`."""
    return max(opts.sigma, FLOAT_SIGMA_MIN) if use_float else opts.sigma


def osqp_settings(opts: QpOptions, use_float: bool = False) -> dict:
    """OSQP settings, identical for the Python package and the generated code of that precision (only ``sigma``
    depends on it, :func:`osqp_sigma`; the Python reference computes in double with the double build's settings)."""
    return dict(
        max_iter=opts.max_iter,
        eps_abs=opts.eps_abs,
        eps_rel=opts.eps_rel,
        eps_prim_inf=1e-5,
        eps_dual_inf=1e-5,
        rho=opts.rho,
        sigma=osqp_sigma(opts, use_float),
        alpha=opts.alpha,
        adaptive_rho=opts.adaptive_rho,
        scaling=opts.scaling,
        check_termination=opts.check_termination,
        check_dualgap=False,
        warm_starting=opts.warm_start,
        polishing=False,
        verbose=False,
    )


def setup_data(lay: QpLayout) -> tuple:
    """The QP OSQP is set up (and the C workspace exported) with: q = 0, l = min(L, 0), u = max(U, 0)."""
    return (
        lay.P_matrix(),
        np.zeros(lay.n),
        lay.A_pattern(np.ones(lay.nnz_A)),
        np.minimum(lay.L, 0.0),
        np.maximum(lay.U, 0.0),
    )


class Backend:
    """OSQP through its Python package, with the calls the generated C makes, in the same order."""

    name = "osqp"

    def __init__(self, layout: QpLayout, opts: QpOptions):
        self.lay = layout
        self.opts = opts
        self.settings = osqp_settings(opts)
        self.reset()

    def reset(self) -> None:
        self.solver = osqp.OSQP()
        self.solver.setup(*setup_data(self.lay), **self.settings)

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
        return QpResult(
            status=generic_status(raw),
            raw_status=raw,
            iter=int(res.info.iter),
            z=None if res.x is None else np.array(res.x, dtype=float),
            y=None if res.y is None else np.array(res.y, dtype=float),
        )


def restore_library(out_dir: Path, use_float: bool) -> list[str]:
    """Bring the git-ignored OSQP library of a folder that uses this backend up to date (nothing for another folder).

    Always synced, never trusted because it exists: a copy left by an older fcgen (unprefixed, unpatched QDLDL that
    writes into what is now const data) would build and crash. Only changed files are written (~0.3 s).
    """
    out_dir = Path(out_dir)
    if not list((out_dir / "osqp").glob("*workspace.c")):
        return []
    return restore_osqp_library(out_dir, use_float)
