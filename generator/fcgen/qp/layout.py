"""QpLayout: the sparse multiple-shooting QP's order, CSC pattern and index maps, and how a plan moves by a sample.

Variables and rows are stored stage after stage. Every non-zero of the constraint matrix comes from exactly one
stage function's Jacobian output, so filling ``A`` is one gather: ``A.data = concat_k(J_k.nonzeros())[a_src]``.
The index tables below are emitted verbatim as ``static const`` arrays into the C solver.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from ..ocp import INF, STATE_SCALE, Ocp
from ..road_rows import BAND_SIDES, band_ahead

# Rows whose bound comes from the road's drivable band (Road.n_min/n_max) at the stage's s when the road has one:
# row name -> the sides it takes (0: lower <- n_min, 1: upper <- n_max); every such row is the rear axle's or a
# chassis corner's n / BAND_SCALE (+ slack; road_rows).
BAND_ROW_SIDES = {"bound_n": (0, 1)} | BAND_SIDES
BAND_SCALE = STATE_SCALE["n"]


@dataclass(frozen=True, eq=False)
class QpLayout:
    """Sizes, offsets, constant data and index maps of the sparse multiple-shooting QP."""

    n: int
    m: int
    var_off: np.ndarray  # (N+2,) first variable of stage k; var_off[N+1] = n
    row_off: np.ndarray  # (N+2,) first row of stage k
    jac_off: np.ndarray  # (N+2,) first Jacobian non-zero of stage k in the stacked vector
    A_indptr: np.ndarray
    A_indices: np.ndarray
    a_src: np.ndarray  # A.data[i] = stacked_J[a_src[i]]
    P_diag: np.ndarray  # constant diagonal Hessian
    L: np.ndarray  # constant row bounds (init rows are overwritten at feedback)
    U: np.ndarray
    D: np.ndarray  # variable scale: w = w_guess + D z
    q_ds0: np.ndarray  # d q / d s0 at the measured s0
    init_rows: np.ndarray  # rows holding x_0 = measured state
    s_vars: np.ndarray  # index of s_k for k = 0..N
    var_shift: np.ndarray  # shifted guess: w_new[i] = w_old[var_shift[i]] (stride 1; ``shifted``)
    row_shift: np.ndarray  # shifted duals: y_new[i] = y_old[row_shift[i]] (stride 1; ``shifted``)
    var_names: tuple[str, ...]
    row_names: tuple[str, ...]
    band_rows: np.ndarray  # (rows, 3): [row, stage k, side] taking the road band at s_k + band_ds (BAND_ROW_SIDES)
    band_ds: np.ndarray  # (rows,): how far ahead of s_k each takes it (road_rows.band_ahead: a corner's own s)
    band_scale: float = BAND_SCALE
    shift_fraction: float = 1.0  # a sample is this fraction of a coarse interval: 1 / stride (1: none)
    shift_split_var: int = 0  # the variables before it (fine stages) take the next stage's entry exactly
    shift_split_row: int = 0  # ... and the rows

    def shift_vars(self, w: np.ndarray) -> np.ndarray:
        """The plan one sample later (``shifted``)."""
        return shifted(w, self.var_shift, self.shift_fraction, self.shift_split_var)

    def shift_duals(self, y: np.ndarray) -> np.ndarray:
        """The duals one sample later (``shifted``)."""
        return shifted(y, self.row_shift, self.shift_fraction, self.shift_split_row)

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


def _a_pattern(
    stages: list, var_off: np.ndarray, row_off: np.ndarray, jac_off: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A's CSC pattern from the stages' Jacobian sparsities: column pointers, row indices and, per entry, its index in
    the stacked stage Jacobians' nonzeros."""
    N = len(stages) - 1
    row_parts, col_parts, src_parts = [], [], []
    for k, st in enumerate(stages):
        sparsity = st.jac_sparsity
        r_loc = np.array(sparsity.row(), dtype=np.int64)
        colind = np.array(sparsity.colind(), dtype=np.int64)
        c_loc = np.repeat(np.arange(sparsity.size2()), np.diff(colind))
        own = c_loc < st.nw
        if k == N and np.any(~own):
            raise AssertionError("the last stage has no successor state")
        c_glob = np.where(own, var_off[k] + c_loc, var_off[min(k + 1, N)] + (c_loc - st.nw))
        row_parts.append(row_off[k] + r_loc)
        col_parts.append(c_glob)
        src_parts.append(jac_off[k] + np.arange(len(r_loc)))
    rows, cols, src = np.concatenate(row_parts), np.concatenate(col_parts), np.concatenate(src_parts)
    order = np.lexsort((rows, cols))
    rows, cols, src = rows[order], cols[order], src[order]
    if np.any((np.diff(cols) == 0) & (np.diff(rows) == 0)):
        raise AssertionError("two stage functions write the same entry of A")
    indptr = np.zeros(int(var_off[-1]) + 1, dtype=np.int64)
    np.add.at(indptr, cols + 1, 1)
    return np.cumsum(indptr), rows, src


def _shift_map(stages: list, offsets: np.ndarray, names_of) -> np.ndarray:
    """Shift by one stage: entry i of the shifted vector takes entry ``out[i]``; stages of the same type shift one to
    one, the boundaries map by name (an entry without a source keeps its own)."""
    N = len(stages) - 1
    out = np.arange(offsets[-1], dtype=np.int64)
    for k in range(N + 1):
        src_k = min(k + 1, N)
        src_names = {nm: i for i, nm in enumerate(names_of(stages[src_k]))}
        for i, nm in enumerate(names_of(stages[k])):
            if nm in src_names:
                out[offsets[k] + i] = offsets[src_k] + src_names[nm]
    return out


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
    indptr, rows, src = _a_pattern(stages, var_off, row_off, jac_off)

    cat = np.concatenate
    P_diag = cat([st.P_diag for st in stages])
    L = cat([st.L for st in stages])
    U = cat([st.U for st in stages])
    D = cat([st.D for st in stages])
    q_ds0 = cat([st.q_ds0 for st in stages])
    init_rows = np.arange(ocp.nx, dtype=np.int64) + row_off[0]
    s_vars = var_off[: N + 1].copy()

    var_shift = _shift_map(stages, var_off, lambda st: st.var_names)
    row_shift = _shift_map(stages, row_off, lambda st: st.row_names)
    var_names = tuple(f"{nm}[{k}]" for k, st in enumerate(stages) for nm in st.var_names)
    row_names = tuple(f"{nm}[{k}]" for k, st in enumerate(stages) for nm in st.row_names)
    band = [
        (row_off[k] + i, k, side)
        for k, st in enumerate(stages)
        for i, nm in enumerate(st.row_names)
        for side in BAND_ROW_SIDES.get(nm, ())
    ]
    band_rows = np.array(band, dtype=np.int64).reshape(-1, 3)
    names = [st.row_names for st in stages]
    band_ds = np.array([band_ahead(ocp.problem, names[k][r - row_off[k]]) for r, k, _ in band], dtype=float)
    return QpLayout(
        n,
        m,
        var_off,
        row_off,
        jac_off,
        indptr,
        rows.astype(np.int64),
        src.astype(np.int64),
        P_diag,
        L,
        U,
        D,
        q_ds0,
        init_rows,
        s_vars,
        var_shift,
        row_shift,
        var_names,
        row_names,
        band_rows,
        band_ds,
        **shift_fields(ocp.problem.horizon, var_off, row_off),
    )


def shift_fields(hz, var_off: np.ndarray, row_off: np.ndarray) -> dict:
    """How a plan moves by one sample: a fine stage takes the next stage's entries, a coarse one moves 1 / stride of
    the way to them."""
    if hz.n_fine == hz.N:
        return {"shift_fraction": 1.0}
    return {
        "shift_fraction": 1.0 / hz.stride,
        "shift_split_var": int(var_off[hz.n_fine]),
        "shift_split_row": int(row_off[hz.n_fine]),
    }


def shifted(v: np.ndarray, index: np.ndarray, fraction: float, split: int = 0) -> np.ndarray:
    """A plan (or its duals) one sample later: ``v[index]`` (the next stage's entries) where a sample is a whole
    shooting interval (the entries before ``split``, or all for ``fraction`` 1); beyond ``split`` interpolated a
    ``fraction`` of the way to them, ``v + fraction (v[index] - v)`` (the C's operations)."""
    if fraction == 1.0:
        return v[index]
    out = v + fraction * (v[index] - v)
    out[:split] = v[index[:split]]
    return out


def assert_finite_bounds(L: np.ndarray, U: np.ndarray) -> None:
    """Rows must have L <= U, infinite sides written as +-INF."""
    if np.any(L > U):
        raise AssertionError("row with lower bound above upper bound")
    if np.any(np.abs(L) > INF) or np.any(np.abs(U) > INF):
        raise AssertionError("bounds beyond OSQP_INFTY")
