"""The stage-structured view of a ``QpLayout``: per stage its states, inputs and slacks, and its rows by class
(dynamics, init, stage equalities, box rows, general rows), padded to common sizes for a Riccati-type solver."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..ocp import INF
from .layout import QpLayout


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
    nu: np.ndarray  # (N+1,) inputs of stage k
    ns: np.ndarray  # (N+1,) slacks of stage k
    vmap: np.ndarray  # (N+1, nx+NU+NS) global variable of local slot v, or -1
    dyn_rows: np.ndarray  # (N, nx) global row of the dynamics row i of stage k
    dyn_next: np.ndarray  # (N, nx) data index of the x_{k+1}[i] coefficient of that row
    dyn_ptr: np.ndarray  # (N+1,) stage k's [A B] non-zeros: dyn_i/dyn_j/dyn_a[dyn_ptr[k]:dyn_ptr[k+1]]
    dyn_i: np.ndarray  # row i (0..nx-1)
    dyn_j: np.ndarray  # local slot v in [x, u]
    dyn_a: np.ndarray  # data index
    init_a: np.ndarray  # (nx,) data index of the x_0[i] coefficient of init row i
    gen_rows: np.ndarray  # (N+1, NG) global general inequality row, or -1
    gen_ptr: np.ndarray  # ((N+1) NG + 1,) non-zeros of slot (k, r): gen_v/gen_a[gen_ptr[k NG + r]:...]
    gen_v: np.ndarray  # local slot v (x, inputs or the one slack)
    gen_a: np.ndarray  # data index
    eq_rows: np.ndarray  # (N+1, NE) global stage-equality row, or -1
    eq_ptr: np.ndarray  # ((N+1) NE + 1,)
    eq_j: np.ndarray  # input index 0..NU-1
    eq_a: np.ndarray  # data index
    box_rows: np.ndarray  # global row of each box row
    box_var: np.ndarray  # its variable
    box_a: np.ndarray  # its data index
    side_row: np.ndarray  # inequality sides: global row
    side_sign: np.ndarray  # +1: lower side (a'z >= l), -1: upper side (a'z <= u)
    eq_all: np.ndarray  # every equality row (init, dynamics, stage equalities), ascending

    @property
    def NV(self) -> int:
        return self.nx + self.NU + self.NS


def _stage_sizes(lay: QpLayout, nx: int, is_slack: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Inputs and slacks of each stage; raises AssertionError unless each stage is ordered [x, inputs, slacks]."""
    N = len(lay.var_off) - 2
    nu = np.zeros(N + 1, dtype=np.int64)
    ns = np.zeros(N + 1, dtype=np.int64)
    for k in range(N + 1):
        o0, o1 = lay.var_off[k], lay.var_off[k + 1]
        sl = is_slack[o0:o1]
        ns[k] = int(sl.sum())
        nu[k] = o1 - o0 - nx - ns[k]
        if np.any(sl[:nx]) or (ns[k] and not np.all(sl[o1 - o0 - ns[k] :])):
            raise AssertionError(f"stage {k}: variables must be ordered [x, inputs, slacks]")
    return nu, ns


def _local_slots(
    lay: QpLayout, nx: int, nu: np.ndarray, ns: np.ndarray, NU: int, NS: int
) -> tuple[np.ndarray, np.ndarray]:
    """The global variable of each stage's padded local slot (-1: padding), and each variable's local slot."""
    N = len(lay.var_off) - 2
    vmap = -np.ones((N + 1, nx + NU + NS), dtype=np.int64)
    local = np.zeros(lay.n, dtype=np.int64)
    for k in range(N + 1):
        o = lay.var_off[k]
        slots = np.r_[np.arange(nx + nu[k]), nx + NU + np.arange(ns[k])]
        vmap[k, slots] = o + np.arange(nx + nu[k] + ns[k])
        local[o : o + nx + nu[k] + ns[k]] = slots
    return vmap, local


class _RowClasses:
    """The rows of a layout sorted into the stage view's classes, stage by stage (``stage_view`` fills it)."""

    def __init__(self, N: int, nx: int):
        self.dyn_rows = np.zeros((N, nx), dtype=np.int64)
        self.dyn_next = np.zeros((N, nx), dtype=np.int64)
        self.dyn_i: list[int] = []
        self.dyn_j: list[int] = []
        self.dyn_a: list[int] = []
        self.dyn_ptr = [0]
        self.init_a = np.zeros(nx, dtype=np.int64)
        self.gen: list[list] = [[] for _ in range(N + 1)]
        self.eqs: list[list] = [[] for _ in range(N + 1)]
        self.box: list[tuple] = []
        self.sides_row: list[int] = []
        self.sides_sign: list[int] = []


def _classify_stage_rows(
    lay: QpLayout,
    A,
    k: int,
    nx: int,
    stage_of_var: np.ndarray,
    is_slack: np.ndarray,
    local: np.ndarray,
    rc: _RowClasses,
) -> None:
    """Sort stage k's rows into init, dynamics, stage-equality, box and general rows (and their inequality sides);
    raises AssertionError where a row fits none."""
    N = len(lay.var_off) - 2
    init_set = set(int(r) for r in lay.init_rows)
    fixed = lay.L == lay.U
    n_dyn = 0
    for r in range(lay.row_off[k], lay.row_off[k + 1]):
        cols = A.indices[A.indptr[r] : A.indptr[r + 1]]
        dat = A.data[A.indptr[r] : A.indptr[r + 1]].astype(np.int64)
        st = stage_of_var[cols]
        if r in init_set:
            i = r - lay.row_off[0]
            if len(cols) != 1 or cols[0] != lay.var_off[0] + i:
                raise AssertionError(f"init row {r} must hold x_0[{i}] only")
            rc.init_a[i] = dat[0]
        elif np.any(st != k):
            nxt = cols[st != k]
            if (
                k == N
                or n_dyn >= nx
                or np.any(st[st != k] != k + 1)
                or len(nxt) != 1
                or nxt[0] != lay.var_off[k + 1] + n_dyn
                or not fixed[r]
                or np.any(is_slack[cols[st == k]])
            ):
                raise AssertionError(f"row {lay.row_names[r]}: not a dynamics row x_{{k+1}}[i] = f(x_k, u_k)")
            rc.dyn_rows[k, n_dyn] = r
            rc.dyn_next[k, n_dyn] = dat[st != k][0]
            for c, a in zip(cols[st == k], dat[st == k]):
                rc.dyn_i.append(n_dyn)
                rc.dyn_j.append(local[c])
                rc.dyn_a.append(a)
            n_dyn += 1
        elif fixed[r]:
            if np.any(local[cols] < nx) or np.any(is_slack[cols]):
                raise AssertionError(f"row {lay.row_names[r]}: a stage equality may hold inputs only")
            rc.eqs[k].append((r, [(local[c] - nx, a) for c, a in zip(cols, dat)]))
        else:
            if len(cols) == 1:
                rc.box.append((r, cols[0], dat[0]))
            else:
                if int(is_slack[cols].sum()) > 1:
                    raise AssertionError(f"row {lay.row_names[r]}: a general row may hold one slack only")
                rc.gen[k].append((r, [(local[c], a) for c, a in zip(cols, dat)]))
            for sign, side in ((1, lay.L[r] > -INF), (-1, lay.U[r] < INF)):
                if side:
                    rc.sides_row.append(r)
                    rc.sides_sign.append(sign)
    if k < N and n_dyn != nx:
        raise AssertionError(f"stage {k}: {n_dyn} dynamics rows, expected {nx}")
    rc.dyn_ptr.append(len(rc.dyn_a))


def _slots(groups: list[list], width: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Per stage ``width`` padded row slots from ``groups[k]`` = [(row, [(column, data index), ...]), ...]: the
    slots' rows (-1: padding), the pointer into the entries of each slot, the entries' columns and data indices."""
    rows = -np.ones((len(groups), width), dtype=np.int64)
    ptr, cj, ca = [0], [], []
    for k in range(len(groups)):
        for s in range(width):
            if s < len(groups[k]):
                r, nz = groups[k][s]
                rows[k, s] = r
                cj += [c for c, _ in nz]
                ca += [a for _, a in nz]
            ptr.append(len(cj))
    return rows, np.array(ptr, dtype=np.int64), np.array(cj, dtype=np.int64), np.array(ca, dtype=np.int64)


def stage_view(lay: QpLayout) -> StageView:
    """Classify variables and rows stage by stage; raises AssertionError if the layout breaks the structure."""
    N = len(lay.var_off) - 2
    nx = len(lay.init_rows)
    A = lay.A_pattern(np.arange(lay.nnz_A, dtype=float)).tocsr()  # data = CSC data index
    A.sort_indices()
    stage_of_var = np.repeat(np.arange(N + 1), np.diff(lay.var_off))
    is_slack = np.array([nm.startswith("sigma") for nm in lay.var_names])
    nu, ns = _stage_sizes(lay, nx, is_slack)
    NU, NS = int(nu.max()), int(ns.max())
    vmap, local = _local_slots(lay, nx, nu, ns, NU, NS)
    rc = _RowClasses(N, nx)
    for k in range(N + 1):
        _classify_stage_rows(lay, A, k, nx, stage_of_var, is_slack, local, rc)
    NG = max(len(g) for g in rc.gen)
    NE = max(len(e) for e in rc.eqs)
    gen_rows, gen_ptr, gen_v, gen_a = _slots(rc.gen, NG)
    eq_rows, eq_ptr, eq_j, eq_a = _slots(rc.eqs, NE)
    order = np.lexsort((-np.array(rc.sides_sign), np.array(rc.sides_row)))
    box_arr = np.array(rc.box, dtype=np.int64).reshape(-1, 3)
    eq_all = np.sort(np.r_[lay.init_rows, rc.dyn_rows.ravel(), eq_rows[eq_rows >= 0]]).astype(np.int64)
    if len(eq_all) + len(box_arr) + int((gen_rows >= 0).sum()) != lay.m:
        raise AssertionError("stage view: rows left unclassified")

    def as_int(v) -> np.ndarray:
        return np.array(v, dtype=np.int64)

    return StageView(
        N,
        nx,
        NU,
        NS,
        NG,
        NE,
        nu,
        ns,
        vmap,
        rc.dyn_rows,
        rc.dyn_next,
        as_int(rc.dyn_ptr),
        as_int(rc.dyn_i),
        as_int(rc.dyn_j),
        as_int(rc.dyn_a),
        rc.init_a,
        gen_rows,
        gen_ptr,
        gen_v,
        gen_a,
        eq_rows,
        eq_ptr,
        eq_j,
        eq_a,
        box_arr[:, 0].copy(),
        box_arr[:, 1].copy(),
        box_arr[:, 2].copy(),
        as_int(rc.sides_row)[order],
        as_int(rc.sides_sign)[order],
        eq_all,
    )


def slack_bound_sides(sv: StageView) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The inequality sides on a slack's bound (a box row on a slack variable): the side, the slack's variable and the
    data index of the bound row's coefficient. An interior-point start gives such a side without a warm multiplier the
    slack's cost over that coefficient, the multiplier it carries while the slack's row is inactive."""
    slack = {int(v) for v in sv.vmap[:, sv.nx + sv.NU :].ravel() if v >= 0}
    box = {int(r): (int(v), int(a)) for r, v, a in zip(sv.box_rows, sv.box_var, sv.box_a) if int(v) in slack}
    sides = [j for j, r in enumerate(sv.side_row) if int(r) in box]
    var = [box[int(sv.side_row[j])][0] for j in sides]
    dat = [box[int(sv.side_row[j])][1] for j in sides]
    return np.array(sides, dtype=np.int64), np.array(var, dtype=np.int64), np.array(dat, dtype=np.int64)
