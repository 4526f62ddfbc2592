"""QpLayout: the one QP layout shared by the Python reference and the generated C.

Variables and rows are stored stage after stage. Every non-zero of the constraint matrix comes from exactly one
stage function's Jacobian output, so filling ``A`` is one gather: ``A.data = concat_k(J_k.nonzeros())[a_src]``.
The index tables below are emitted verbatim as ``static const`` arrays into the C solver.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from .ocp import INF, STATE_SCALE, Ocp

# Rows whose bound comes from the road's drivable band (Road.n_min/n_max) at the stage's s when the road has one:
# row name -> the sides it takes (0: lower <- n_min, 1: upper <- n_max); every such row is n / BAND_SCALE (+ slack).
BAND_ROW_SIDES = {"bound_n": (0, 1), "road_lo": (0,), "road_hi": (1,)}
BAND_SCALE = STATE_SCALE["n"]


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
    var_shift: np.ndarray      # shifted guess: w_new[i] = w_old[var_shift[i]] (stride 1; ``shifted``)
    row_shift: np.ndarray      # shifted duals: y_new[i] = y_old[row_shift[i]] (stride 1; ``shifted``)
    var_names: tuple[str, ...]
    row_names: tuple[str, ...]
    band_rows: np.ndarray      # (rows, 3): [row, stage k, side] taking the road band at s_k (BAND_ROW_SIDES)
    band_scale: float = BAND_SCALE
    shift_fraction: float = 1.0  # a sample is this fraction of a coarse interval: 1 / stride (1: none)
    shift_split_var: int = 0     # the variables before it (fine stages) take the next stage's entry exactly
    shift_split_row: int = 0     # ... and the rows

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
    band = [(row_off[k] + i, k, side) for k, st in enumerate(stages) for i, nm in enumerate(st.row_names)
            for side in BAND_ROW_SIDES.get(nm, ())]
    band_rows = np.array(band, dtype=np.int64).reshape(-1, 3)
    return QpLayout(n, m, var_off, row_off, jac_off, indptr, rows.astype(np.int64), src.astype(np.int64),
                    P_diag, L, U, D, q_ds0, init_rows, s_vars, var_shift, row_shift, var_names, row_names, band_rows,
                    **shift_fields(ocp.problem.horizon, var_off, row_off))


def shift_fields(hz, var_off: np.ndarray, row_off: np.ndarray) -> dict:
    """How a plan moves by one sample: a fine stage takes the next stage's entries, a coarse one moves 1 / stride of
    the way to them."""
    if hz.n_fine == hz.N:
        return {"shift_fraction": 1.0}
    return {"shift_fraction": 1.0 / hz.stride, "shift_split_var": int(var_off[hz.n_fine]),
            "shift_split_row": int(row_off[hz.n_fine])}


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


@dataclass(frozen=True, eq=False)
class StageView:
    """The stage-structured view of a ``QpLayout`` (additive: the CSC view is unchanged).

    Stage k holds ``x_k`` (``nx``), inputs ``u_k`` (controls and hyperplane variables, ``nu[k]``) and slacks
    (``ns[k]``). Every stage is padded to the same sizes ``NU``, ``NS``, ``NG``, ``NE``; a padded slot holds -1.
    Local index ``v`` of a stage variable: ``x`` at ``0..nx-1``, inputs at ``nx..nx+NU-1``, slacks at
    ``nx+NU..nx+NU+NS-1``. Row classes: dynamics (``nx`` rows per stage k < N, the only rows reaching ``x_{k+1}``,
    whose coefficient is diagonal), init (``x_0``), stage equalities (inputs only), box rows (one variable) and
    general inequality rows (stage variables, at most one slack). Non-zeros are named by their index in A's CSC data.
    """

    N: int
    nx: int
    NU: int
    NS: int
    NG: int
    NE: int
    nu: np.ndarray          # (N+1,) inputs of stage k
    ns: np.ndarray          # (N+1,) slacks of stage k
    vmap: np.ndarray        # (N+1, nx+NU+NS) global variable of local slot v, or -1
    dyn_rows: np.ndarray    # (N, nx) global row of the dynamics row i of stage k
    dyn_next: np.ndarray    # (N, nx) data index of the x_{k+1}[i] coefficient of that row
    dyn_ptr: np.ndarray     # (N+1,) stage k's [A B] non-zeros: dyn_i/dyn_j/dyn_a[dyn_ptr[k]:dyn_ptr[k+1]]
    dyn_i: np.ndarray       # row i (0..nx-1)
    dyn_j: np.ndarray       # local slot v in [x, u]
    dyn_a: np.ndarray       # data index
    init_a: np.ndarray      # (nx,) data index of the x_0[i] coefficient of init row i
    gen_rows: np.ndarray    # (N+1, NG) global general inequality row, or -1
    gen_ptr: np.ndarray     # ((N+1) NG + 1,) non-zeros of slot (k, r): gen_v/gen_a[gen_ptr[k NG + r]:...]
    gen_v: np.ndarray       # local slot v (x, inputs or the one slack)
    gen_a: np.ndarray       # data index
    eq_rows: np.ndarray     # (N+1, NE) global stage-equality row, or -1
    eq_ptr: np.ndarray      # ((N+1) NE + 1,)
    eq_j: np.ndarray        # input index 0..NU-1
    eq_a: np.ndarray        # data index
    box_rows: np.ndarray    # global row of each box row
    box_var: np.ndarray     # its variable
    box_a: np.ndarray       # its data index
    side_row: np.ndarray    # inequality sides: global row
    side_sign: np.ndarray   # +1: lower side (a'z >= l), -1: upper side (a'z <= u)
    eq_all: np.ndarray      # every equality row (init, dynamics, stage equalities), ascending

    @property
    def NV(self) -> int:
        return self.nx + self.NU + self.NS


def stage_view(lay: QpLayout) -> StageView:
    """Classify variables and rows stage by stage; raises AssertionError if the layout breaks the structure."""
    N = len(lay.var_off) - 2
    nx = len(lay.init_rows)
    A = lay.A_pattern(np.arange(lay.nnz_A, dtype=float)).tocsr()   # data = CSC data index
    A.sort_indices()
    stage_of_var = np.repeat(np.arange(N + 1), np.diff(lay.var_off))
    is_slack = np.array([nm.startswith("sigma") for nm in lay.var_names])
    nu = np.zeros(N + 1, dtype=np.int64)
    ns = np.zeros(N + 1, dtype=np.int64)
    for k in range(N + 1):
        o0, o1 = lay.var_off[k], lay.var_off[k + 1]
        sl = is_slack[o0:o1]
        ns[k] = int(sl.sum())
        nu[k] = o1 - o0 - nx - ns[k]
        if np.any(sl[:nx]) or (ns[k] and not np.all(sl[o1 - o0 - ns[k]:])):
            raise AssertionError(f"stage {k}: variables must be ordered [x, inputs, slacks]")
    NU, NS = int(nu.max()), int(ns.max())
    vmap = -np.ones((N + 1, nx + NU + NS), dtype=np.int64)
    local = np.zeros(lay.n, dtype=np.int64)
    for k in range(N + 1):
        o = lay.var_off[k]
        slots = np.r_[np.arange(nx + nu[k]), nx + NU + np.arange(ns[k])]
        vmap[k, slots] = o + np.arange(nx + nu[k] + ns[k])
        local[o:o + nx + nu[k] + ns[k]] = slots
    init_set = set(int(r) for r in lay.init_rows)
    dyn_rows = np.zeros((N, nx), dtype=np.int64)
    dyn_next = np.zeros((N, nx), dtype=np.int64)
    dyn_i, dyn_j, dyn_a, dyn_ptr = [], [], [], [0]
    init_a = np.zeros(nx, dtype=np.int64)
    gen, eqs, box = [[] for _ in range(N + 1)], [[] for _ in range(N + 1)], []
    sides_row, sides_sign = [], []
    fixed = lay.L == lay.U
    for k in range(N + 1):
        n_dyn = 0
        for r in range(lay.row_off[k], lay.row_off[k + 1]):
            cols = A.indices[A.indptr[r]:A.indptr[r + 1]]
            dat = A.data[A.indptr[r]:A.indptr[r + 1]].astype(np.int64)
            st = stage_of_var[cols]
            if r in init_set:
                i = r - lay.row_off[0]
                if len(cols) != 1 or cols[0] != lay.var_off[0] + i:
                    raise AssertionError(f"init row {r} must hold x_0[{i}] only")
                init_a[i] = dat[0]
            elif np.any(st != k):
                nxt = cols[st != k]
                if k == N or n_dyn >= nx or np.any(st[st != k] != k + 1) or len(nxt) != 1 \
                        or nxt[0] != lay.var_off[k + 1] + n_dyn or not fixed[r] \
                        or np.any(is_slack[cols[st == k]]):
                    raise AssertionError(f"row {lay.row_names[r]}: not a dynamics row x_{{k+1}}[i] = f(x_k, u_k)")
                dyn_rows[k, n_dyn] = r
                dyn_next[k, n_dyn] = dat[st != k][0]
                for c, a in zip(cols[st == k], dat[st == k]):
                    dyn_i.append(n_dyn); dyn_j.append(local[c]); dyn_a.append(a)
                n_dyn += 1
            elif fixed[r]:
                if np.any(local[cols] < nx) or np.any(is_slack[cols]):
                    raise AssertionError(f"row {lay.row_names[r]}: a stage equality may hold inputs only")
                eqs[k].append((r, [(local[c] - nx, a) for c, a in zip(cols, dat)]))
            else:
                if len(cols) == 1:
                    box.append((r, cols[0], dat[0]))
                else:
                    if int(is_slack[cols].sum()) > 1:
                        raise AssertionError(f"row {lay.row_names[r]}: a general row may hold one slack only")
                    gen[k].append((r, [(local[c], a) for c, a in zip(cols, dat)]))
                for sign, side in ((1, lay.L[r] > -INF), (-1, lay.U[r] < INF)):
                    if side:
                        sides_row.append(r); sides_sign.append(sign)
        if k < N and n_dyn != nx:
            raise AssertionError(f"stage {k}: {n_dyn} dynamics rows, expected {nx}")
        dyn_ptr.append(len(dyn_a))
    NG = max(len(g) for g in gen)
    NE = max(len(e) for e in eqs)

    def slots(groups, width, col_shift=0):
        rows = -np.ones((N + 1, width), dtype=np.int64)
        ptr, cj, ca = [0], [], []
        for k in range(N + 1):
            for s in range(width):
                if s < len(groups[k]):
                    r, nz = groups[k][s]
                    rows[k, s] = r
                    cj += [c for c, _ in nz]; ca += [a for _, a in nz]
                ptr.append(len(cj))
        return rows, np.array(ptr, dtype=np.int64), np.array(cj, dtype=np.int64), np.array(ca, dtype=np.int64)

    gen_rows, gen_ptr, gen_v, gen_a = slots(gen, NG)
    eq_rows, eq_ptr, eq_j, eq_a = slots(eqs, NE)
    order = np.lexsort((-np.array(sides_sign), np.array(sides_row)))
    box_arr = np.array(box, dtype=np.int64).reshape(-1, 3)
    eq_all = np.sort(np.r_[lay.init_rows, dyn_rows.ravel(), eq_rows[eq_rows >= 0]]).astype(np.int64)
    if len(eq_all) + len(box_arr) + int((gen_rows >= 0).sum()) != lay.m:
        raise AssertionError("stage view: rows left unclassified")
    return StageView(N, nx, NU, NS, NG, NE, nu, ns, vmap, dyn_rows, dyn_next, np.array(dyn_ptr, dtype=np.int64),
                     np.array(dyn_i, dtype=np.int64), np.array(dyn_j, dtype=np.int64),
                     np.array(dyn_a, dtype=np.int64), init_a, gen_rows, gen_ptr, gen_v, gen_a, eq_rows, eq_ptr,
                     eq_j, eq_a, box_arr[:, 0].copy(), box_arr[:, 1].copy(), box_arr[:, 2].copy(),
                     np.array(sides_row, dtype=np.int64)[order], np.array(sides_sign, dtype=np.int64)[order],
                     eq_all)


@dataclass(frozen=True)
class SoftRows:
    """The soft rows of a stage view (the obstacle rows): a general row with one finite side and a slack of its own
    whose only other row is the slack's bound (a box row with one finite side). An interior-point method can treat
    such a row, its slack and the bound as one unit: two complementarity pairs and a scalar slack pivot per row,
    nothing shared with other rows. Padded entries have slot 0 and data index -1 (coefficient 0)."""

    NA: int                 # (x, u) entries of a soft row (at most)
    ptr: np.ndarray         # (N+2,) soft rows of stage k: ptr[k] .. ptr[k+1] - 1
    rptr: np.ndarray        # (N+2,) runs of stage k: rptr[k] .. rptr[k+1] - 1 (a run: rows on the same slots)
    run_ptr: np.ndarray     # (nrun+1,) soft rows of run r: run_ptr[r] .. run_ptr[r+1] - 1 (ascending rows)
    run_v: np.ndarray       # (nrun, NA) the run's slots (= v of each of its rows)
    row: np.ndarray         # (nsr,) global row
    sign: np.ndarray        # its finite side: +1 lower, -1 upper
    v: np.ndarray           # (nsr, NA) local slot in [x, inputs] of each (x, u) entry
    a: np.ndarray           # (nsr, NA) data index of each (x, u) entry, -1: padding
    svar: np.ndarray        # (nsr,) the slack's variable
    e: np.ndarray           # data index of the slack's coefficient in the row
    brow: np.ndarray        # the slack's bound row
    bsign: np.ndarray       # the bound row's finite side
    ba: np.ndarray          # data index of the bound row's coefficient

    @property
    def count(self) -> int:
        return len(self.row)


def split_soft_rows(lay: QpLayout, sv: StageView) -> tuple[StageView, SoftRows]:
    """``sv`` without its soft rows (``SoftRows``), their slacks and their slacks' bound rows, and those soft rows.

    The returned view's slacks are renumbered per stage and its sides, box rows and general rows are those of ``sv``
    that are not part of a soft row; dynamics, init and stage-equality rows are unchanged."""
    nxu = sv.nx + sv.NU
    sides = np.bincount(sv.side_row, minlength=lay.m)
    col_rows = [lay.A_indices[lay.A_indptr[j]:lay.A_indptr[j + 1]] for j in range(lay.n)]
    box_of = {int(r): i for i, r in enumerate(sv.box_rows)}
    # general slots by slack variable: a soft row's slack has one general row
    slack_rows: dict[int, int] = {}
    for k in range(sv.N + 1):
        for g in range(sv.NG):
            vs = sv.gen_v[sv.gen_ptr[k * sv.NG + g]:sv.gen_ptr[k * sv.NG + g + 1]]
            for v in vs[vs >= nxu]:
                var = int(sv.vmap[k, v])
                slack_rows[var] = slack_rows.get(var, 0) + 1
    soft, gen = [[] for _ in range(sv.N + 1)], [[] for _ in range(sv.N + 1)]
    drop_rows: set[int] = set()
    for k in range(sv.N + 1):
        for g in range(sv.NG):
            r = int(sv.gen_rows[k, g])
            if r < 0:
                continue
            sl = slice(sv.gen_ptr[k * sv.NG + g], sv.gen_ptr[k * sv.NG + g + 1])
            ent = list(zip(sv.gen_v[sl].tolist(), sv.gen_a[sl].tolist()))
            s_ent = [(v, a) for v, a in ent if v >= nxu]
            unit = None
            if len(s_ent) == 1 and sides[r] == 1:
                var = int(sv.vmap[k, s_ent[0][0]])
                others = [int(x) for x in col_rows[var] if x != r]
                if slack_rows[var] == 1 and len(others) == 1 and others[0] in box_of and sides[others[0]] == 1:
                    unit = (r, var, s_ent[0][1], others[0], box_of[others[0]])
            if unit is None:
                gen[k].append((r, ent))
                continue
            r, var, e_a, rb, bi = unit
            xu = [(v, a) for v, a in ent if v < nxu]
            soft[k].append((r, xu, var, e_a, rb, int(sv.box_a[bi])))
            drop_rows.update((r, rb))
    # the rest as a stage view: general slots and slacks renumbered per stage
    NG = max([len(g) for g in gen] + [0])
    slack_slot = [dict() for _ in range(sv.N + 1)]
    for k in range(sv.N + 1):
        for _, ent in gen[k]:
            for v, _ in ent:
                if v >= nxu and v not in slack_slot[k]:
                    slack_slot[k][v] = len(slack_slot[k])
    ns = np.array([len(s) for s in slack_slot], dtype=np.int64)
    NS = int(ns.max(initial=0))
    vmap = -np.ones((sv.N + 1, nxu + NS), dtype=np.int64)
    vmap[:, :nxu] = sv.vmap[:, :nxu]
    gen_rows = -np.ones((sv.N + 1, NG), dtype=np.int64)
    gptr, gv, ga = [0], [], []
    for k in range(sv.N + 1):
        for old, new in slack_slot[k].items():
            vmap[k, nxu + new] = sv.vmap[k, old]
        for g in range(NG):
            if g < len(gen[k]):
                r, ent = gen[k][g]
                gen_rows[k, g] = r
                for v, a in ent:
                    gv.append(v if v < nxu else nxu + slack_slot[k][v])
                    ga.append(a)
            gptr.append(len(gv))
    keep_box = np.array([int(r) not in drop_rows for r in sv.box_rows], dtype=bool)
    keep_side = np.array([int(r) not in drop_rows for r in sv.side_row], dtype=bool)
    rest = StageView(sv.N, sv.nx, sv.NU, NS, NG, sv.NE, sv.nu, ns, vmap, sv.dyn_rows, sv.dyn_next, sv.dyn_ptr,
                     sv.dyn_i, sv.dyn_j, sv.dyn_a, sv.init_a, gen_rows, np.array(gptr, dtype=np.int64),
                     np.array(gv, dtype=np.int64), np.array(ga, dtype=np.int64), sv.eq_rows, sv.eq_ptr, sv.eq_j,
                     sv.eq_a, sv.box_rows[keep_box], sv.box_var[keep_box], sv.box_a[keep_box],
                     sv.side_row[keep_side], sv.side_sign[keep_side], sv.eq_all)
    # the soft rows, stage by stage, in runs of rows on the same slots (first appearance order, rows ascending)
    NA = max([len(u[1]) for sk in soft for u in sk] + [1])
    flat, rptr, run_ptr, run_v = [], [0], [0], []
    for sk in soft:
        runs: dict[tuple, list] = {}
        for u in sk:
            runs.setdefault(tuple(vv for vv, _ in u[1]), []).append(u)
        for slots_, us in runs.items():
            flat += us
            run_ptr.append(len(flat))
            run_v.append(list(slots_) + [0] * (NA - len(slots_)))
        rptr.append(len(run_v))
    v = np.zeros((len(flat), NA), dtype=np.int64)
    a = -np.ones((len(flat), NA), dtype=np.int64)
    for i, u in enumerate(flat):
        for p, (vv, aa) in enumerate(u[1]):
            v[i, p], a[i, p] = vv, aa
    side_sign = {int(r): int(s) for r, s in zip(sv.side_row, sv.side_sign)}
    col = lambda j: np.array([u[j] for u in flat], dtype=np.int64)  # noqa: E731
    rows, brows = col(0), col(4)
    sr = SoftRows(NA, np.r_[0, np.cumsum([len(sk) for sk in soft])].astype(np.int64),
                  np.array(rptr, dtype=np.int64), np.array(run_ptr, dtype=np.int64),
                  np.array(run_v, dtype=np.int64).reshape(-1, NA), rows,
                  np.array([side_sign[int(r)] for r in rows], dtype=np.int64), v, a, col(2), col(3), brows,
                  np.array([side_sign[int(r)] for r in brows], dtype=np.int64), col(5))
    return rest, sr
