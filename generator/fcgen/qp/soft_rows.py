"""The soft rows of a stage view taken apart: each obstacle row with its own slack and the slack's bound, a unit an
interior-point method treats on its own; the rest stays a stage view."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .layout import QpLayout
from .stage_view import StageView


@dataclass(frozen=True)
class SoftRows:
    """The soft rows of a stage view (the obstacle rows): a general row with one finite side and a slack of its own
    whose only other row is the slack's bound (a box row with one finite side). An interior-point method can treat
    such a row, its slack and the bound as one unit: two complementarity pairs and a scalar slack pivot per row,
    nothing shared with other rows. Padded entries have slot 0 and data index -1 (coefficient 0)."""

    NA: int  # (x, u) entries of a soft row (at most)
    ptr: np.ndarray  # (N+2,) soft rows of stage k: ptr[k] .. ptr[k+1] - 1
    rptr: np.ndarray  # (N+2,) runs of stage k: rptr[k] .. rptr[k+1] - 1 (a run: rows on the same slots)
    run_ptr: np.ndarray  # (nrun+1,) soft rows of run r: run_ptr[r] .. run_ptr[r+1] - 1 (ascending rows)
    run_v: np.ndarray  # (nrun, NA) the run's slots (= v of each of its rows)
    row: np.ndarray  # (nsr,) global row
    sign: np.ndarray  # its finite side: +1 lower, -1 upper
    v: np.ndarray  # (nsr, NA) local slot in [x, inputs] of each (x, u) entry
    a: np.ndarray  # (nsr, NA) data index of each (x, u) entry, -1: padding
    svar: np.ndarray  # (nsr,) the slack's variable
    e: np.ndarray  # data index of the slack's coefficient in the row
    brow: np.ndarray  # the slack's bound row
    bsign: np.ndarray  # the bound row's finite side
    ba: np.ndarray  # data index of the bound row's coefficient

    @property
    def count(self) -> int:
        return len(self.row)


def _slack_row_counts(sv: StageView, nxu: int) -> dict[int, int]:
    """The number of general rows each slack variable appears in (a soft row's slack has one)."""
    slack_rows: dict[int, int] = {}
    for k in range(sv.N + 1):
        for g in range(sv.NG):
            vs = sv.gen_v[sv.gen_ptr[k * sv.NG + g] : sv.gen_ptr[k * sv.NG + g + 1]]
            for v in vs[vs >= nxu]:
                var = int(sv.vmap[k, v])
                slack_rows[var] = slack_rows.get(var, 0) + 1
    return slack_rows


def _soft_units(lay: QpLayout, sv: StageView, nxu: int) -> tuple[list[list], list[list], set[int]]:
    """Per stage its soft units (row, (x, u) entries, slack, slack's data index, bound row, bound's data index) and its
    other general rows (row, entries), and the rows the units take out of the view (each row and its bound row)."""
    sides = np.bincount(sv.side_row, minlength=lay.m)
    col_rows = [lay.A_indices[lay.A_indptr[j] : lay.A_indptr[j + 1]] for j in range(lay.n)]
    box_of = {int(r): i for i, r in enumerate(sv.box_rows)}
    slack_rows = _slack_row_counts(sv, nxu)
    soft: list[list] = [[] for _ in range(sv.N + 1)]
    gen: list[list] = [[] for _ in range(sv.N + 1)]
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
    return soft, gen, drop_rows


def _without_soft_rows(sv: StageView, gen: list[list], drop_rows: set[int], nxu: int) -> StageView:
    """``sv`` with only the general rows ``gen`` (slots and slacks renumbered per stage) and without the box rows and
    sides of ``drop_rows``."""
    NG = max([len(g) for g in gen] + [0])
    slack_slot: list[dict] = [dict() for _ in range(sv.N + 1)]
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
    return StageView(
        sv.N,
        sv.nx,
        sv.NU,
        NS,
        NG,
        sv.NE,
        sv.nu,
        ns,
        vmap,
        sv.dyn_rows,
        sv.dyn_next,
        sv.dyn_ptr,
        sv.dyn_i,
        sv.dyn_j,
        sv.dyn_a,
        sv.init_a,
        gen_rows,
        np.array(gptr, dtype=np.int64),
        np.array(gv, dtype=np.int64),
        np.array(ga, dtype=np.int64),
        sv.eq_rows,
        sv.eq_ptr,
        sv.eq_j,
        sv.eq_a,
        sv.box_rows[keep_box],
        sv.box_var[keep_box],
        sv.box_a[keep_box],
        sv.side_row[keep_side],
        sv.side_sign[keep_side],
        sv.eq_all,
    )


def _soft_rows_table(sv: StageView, soft: list[list]) -> SoftRows:
    """The soft units as ``SoftRows``: stage by stage, in runs of rows on the same slots (first appearance order, rows
    ascending)."""
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

    def col(j: int) -> np.ndarray:
        return np.array([u[j] for u in flat], dtype=np.int64)

    rows, brows = col(0), col(4)
    return SoftRows(
        NA,
        np.r_[0, np.cumsum([len(sk) for sk in soft])].astype(np.int64),
        np.array(rptr, dtype=np.int64),
        np.array(run_ptr, dtype=np.int64),
        np.array(run_v, dtype=np.int64).reshape(-1, NA),
        rows,
        np.array([side_sign[int(r)] for r in rows], dtype=np.int64),
        v,
        a,
        col(2),
        col(3),
        brows,
        np.array([side_sign[int(r)] for r in brows], dtype=np.int64),
        col(5),
    )


def split_soft_rows(lay: QpLayout, sv: StageView) -> tuple[StageView, SoftRows]:
    """``sv`` without its soft rows (``SoftRows``), their slacks and their slacks' bound rows, and those soft rows.

    The returned view's slacks are renumbered per stage and its sides, box rows and general rows are those of ``sv``
    that are not part of a soft row; dynamics, init and stage-equality rows are unchanged."""
    nxu = sv.nx + sv.NU
    soft, gen, drop_rows = _soft_units(lay, sv, nxu)
    return _without_soft_rows(sv, gen, drop_rows, nxu), _soft_rows_table(sv, soft)
