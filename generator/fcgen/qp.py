"""QpLayout: the one QP layout shared by the Python reference and the generated C.

Variables and rows are stored stage after stage. Every non-zero of the constraint matrix comes from exactly one
stage function's Jacobian output, so filling ``A`` is one gather: ``A.data = concat_k(J_k.nonzeros())[a_src]``.
The index tables below are emitted verbatim as ``static const`` arrays into the C solver.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from .ocp import INF, Ocp


@dataclass(frozen=True, eq=False)
class QpLayout:
    """Sizes, offsets, constant data and index maps of the sparse multiple-shooting QP."""

    n: int
    m: int
    var_off: np.ndarray        # (N+2,) first variable of stage k; var_off[N+1] = n
    row_off: np.ndarray        # (N+2,) first row of stage k
    jac_off: np.ndarray        # (N+2,) first Jacobian non-zero of stage k in the stacked vector
    A_indptr: np.ndarray
    A_indices: np.ndarray
    a_src: np.ndarray          # A.data[i] = stacked_J[a_src[i]]
    P_diag: np.ndarray         # constant diagonal Hessian
    L: np.ndarray              # constant row bounds (init rows are overwritten at feedback)
    U: np.ndarray
    D: np.ndarray              # variable scale: w = w_guess + D z
    q_ds0: np.ndarray          # d q / d s0 at the measured s0
    init_rows: np.ndarray      # rows holding x_0 = measured state
    s_vars: np.ndarray         # index of s_k for k = 0..N
    var_shift: np.ndarray      # shifted guess: w_new[i] = w_old[var_shift[i]]
    row_shift: np.ndarray      # shifted duals: y_new[i] = y_old[row_shift[i]]
    var_names: tuple[str, ...]
    row_names: tuple[str, ...]

    @property
    def nnz_A(self) -> int:
        return len(self.A_indices)

    def A_pattern(self, data: np.ndarray | None = None) -> sp.csc_matrix:
        """A as scipy CSC with this layout's fixed pattern (explicit zeros kept)."""
        d = np.zeros(self.nnz_A) if data is None else data
        return sp.csc_matrix((d, self.A_indices, self.A_indptr), shape=(self.m, self.n))

    def P_matrix(self) -> sp.csc_matrix:
        """The constant upper-triangular (diagonal) Hessian as CSC, zeros kept structurally."""
        idx = np.arange(self.n)
        return sp.csc_matrix((self.P_diag.copy(), idx, np.arange(self.n + 1)), shape=(self.n, self.n))


def build_layout(ocp: Ocp) -> QpLayout:
    """Compute the stage-wise ordering, the fixed CSC pattern of A and all index maps."""
    N = ocp.N
    stages = [ocp.stage(k) for k in range(N + 1)]
    var_off = np.zeros(N + 2, dtype=np.int64)
    row_off = np.zeros(N + 2, dtype=np.int64)
    jac_off = np.zeros(N + 2, dtype=np.int64)
    for k, st in enumerate(stages):
        var_off[k + 1] = var_off[k] + st.nw
        row_off[k + 1] = row_off[k] + st.nrows
        jac_off[k + 1] = jac_off[k] + st.jac_sparsity.nnz()
    n, m = int(var_off[-1]), int(row_off[-1])

    rows, cols, src = [], [], []
    for k, st in enumerate(stages):
        sparsity = st.jac_sparsity
        r_loc = np.array(sparsity.row(), dtype=np.int64)
        colind = np.array(sparsity.colind(), dtype=np.int64)
        c_loc = np.repeat(np.arange(sparsity.size2()), np.diff(colind))
        own = c_loc < st.nw
        if k == N and np.any(~own):
            raise AssertionError("the last stage has no successor state")
        c_glob = np.where(own, var_off[k] + c_loc, var_off[min(k + 1, N)] + (c_loc - st.nw))
        rows.append(row_off[k] + r_loc)
        cols.append(c_glob)
        src.append(jac_off[k] + np.arange(len(r_loc)))
    rows, cols, src = np.concatenate(rows), np.concatenate(cols), np.concatenate(src)
    order = np.lexsort((rows, cols))
    rows, cols, src = rows[order], cols[order], src[order]
    if np.any((np.diff(cols) == 0) & (np.diff(rows) == 0)):
        raise AssertionError("two stage functions write the same entry of A")
    indptr = np.zeros(n + 1, dtype=np.int64)
    np.add.at(indptr, cols + 1, 1)
    indptr = np.cumsum(indptr)

    cat = np.concatenate
    P_diag = cat([st.P_diag for st in stages])
    L = cat([st.L for st in stages])
    U = cat([st.U for st in stages])
    D = cat([st.D for st in stages])
    q_ds0 = cat([st.q_ds0 for st in stages])
    init_rows = np.arange(ocp.nx, dtype=np.int64) + row_off[0]
    s_vars = var_off[:N + 1].copy()

    # shift by one stage; stages of the same type shift one to one, the boundaries map by name
    def shift(offsets, names_of):
        out = np.arange(offsets[-1], dtype=np.int64)
        for k in range(N + 1):
            src_k = min(k + 1, N)
            src_names = {nm: i for i, nm in enumerate(names_of(stages[src_k]))}
            for i, nm in enumerate(names_of(stages[k])):
                if nm in src_names:
                    out[offsets[k] + i] = offsets[src_k] + src_names[nm]
        return out

    var_shift = shift(var_off, lambda st: st.var_names)
    row_shift = shift(row_off, lambda st: st.row_names)
    var_names = tuple(f"{nm}[{k}]" for k, st in enumerate(stages) for nm in st.var_names)
    row_names = tuple(f"{nm}[{k}]" for k, st in enumerate(stages) for nm in st.row_names)
    return QpLayout(n, m, var_off, row_off, jac_off, indptr, rows.astype(np.int64), src.astype(np.int64),
                    P_diag, L, U, D, q_ds0, init_rows, s_vars, var_shift, row_shift, var_names, row_names)


def assert_finite_bounds(L: np.ndarray, U: np.ndarray) -> None:
    """Rows must have L <= U, infinite sides written as +-INF."""
    if np.any(L > U):
        raise AssertionError("row with lower bound above upper bound")
    if np.any(np.abs(L) > INF) or np.any(np.abs(U) > INF):
        raise AssertionError("bounds beyond OSQP_INFTY")
