"""The IPM's C storage plan of a problem's QP: how the hand-written C (``csrc/ipm/``) finds its data.

The soft rows' runs padded to whole SIMD lanes, [F G]'s column bands, each stage's (x, u) range and input blocks, the
generic A without the rows that have loops of their own, the slacks' entries, and the workspace struct's real
arrays (with its size on an LP64 target). ``codegen/ipm_header.py`` writes them as the problem header's tables.
"""

from __future__ import annotations

import numpy as np

from ..backends.ipm_tables import IpmTables
from ..qp import QpLayout, SoftRows, StageView

#: the largest NU for which R's factor and solves are written out for all inputs at once (``ipm_kernels.u_kernels``)
U_KERNEL_MAX = 4


def workspace_members(sv: StageView, lay: QpLayout) -> list[dict]:
    """The real arrays of the C workspace struct (name, dims, doc), in declaration order."""
    N, NX, NU, NS, NG = sv.N, sv.nx, sv.NU, sv.NS, sv.NG
    NE1, NXU, n, m, ns = max(sv.NE, 1), sv.nx + sv.NU, lay.n, lay.m, len(sv.side_row)
    NFGB = int(fg_bands(sv)[2][-1])
    spec = [
        ("Einv", (N, NX), "1 / coefficient of x_{k+1}[i] in dynamics row i"),
        ("fgb", (N, NFGB), "[F G] of stage k (x_{k+1} = F x + G u + c), column j's band at IPM_FG_OFF[j] (fg_bands)"),
        ("einit", (NX,), "coefficient of x_0[i] in init row i"),
        ("z", (n,), "iterate"),
        ("r_d", (n,), "stationarity residual"),
        ("h", (n,), "Newton right-hand side"),
        ("hd", (n,), "the Newton matrix's diagonal: P + box weights"),
        ("dz", (n,), "Newton step"),
        ("aff", (4,), "the soft rows' sums of t lam, t dlam + lam dt, dt dlam (predictor); their pending step"),
        ("y", (m,), "row multipliers (result; the equality rows' multipliers all along)"),
        ("wc", (len(slack_entries(IpmTables(lay, sv), N, NS, NG)[1]),), "W e a per entry of IPM_SE (slack rows)"),
        ("gax", (int(np.count_nonzero(sv.gen_v < NXU)),), "a per (x, u) entry of the general rows (prepare)"),
        ("gex", ((N + 1) * NG,), "e (slack coefficient) per general slot (prepare; 0: no slack)"),
        ("bax", (len(sv.box_rows),), "coefficient per box row (prepare)"),
        ("ar", (m,), "per inequality row: its right-hand side g, then a'dz"),
        ("it", (ns,), "1 / t per inequality side"),
        ("bs", (ns,), "b per inequality side"),
        ("wg", ((N + 1) * NG,), "W e per general slot (0: no slack)"),
        ("wr", (m,), "A z, then residuals on equality rows and weights lam / t on the others"),
        ("gd", (m,), "the multiplier step on the equality rows"),
        *[(f, (ns,), "per inequality side") for f in ("t", "lam", "r_p", "dt", "dlam")],
        ("L", (N + 1, NU, NU), "Cholesky factor of R_bar"),
        ("W1", (N + 1, NU, NX), "L^-1 S_bar"),
        ("P", (N + 1, NX, NX), "cost-to-go Hessian (on and below the diagonal)"),
        ("UD", (N + 1, NU, NE1), "L^-1 D'"),
        ("LM", (N + 1, NE1, NE1), "Cholesky factor of UD' UD"),
        ("d", (N + 1, NS), "slack pivots"),
        ("lr", (N + 1, NU), "L^-1 r_bar"),
        ("kk", (N + 1, NU), "feedforward"),
        ("p", (N + 1, NX), "cost-to-go gradient"),
        ("H", (NXU, NXU), "stage Newton block (scratch)"),
        ("R", (NU, NU), "scratch"),
        ("Weff", (NG,), "scratch"),
        ("D", (NE1, NU), "scratch"),
        ("M", (NE1, NE1), "scratch"),
        ("W2", (NE1, NX), "scratch"),
    ]
    if sv.NE == 0:  # the stage-equality arrays exist only with stage equalities (the C's code too)
        spec = [m for m in spec if m[0] not in ("UD", "LM", "D", "M", "W2")]
        if sv.NU <= U_KERNEL_MAX:  # IPM_U_FUSED: L^-1 r_bar lives in the backward sweep's registers
            spec = [m for m in spec if m[0] != "lr"]
    return [{"name": nm, "dims": [max(1, int(d)) for d in dims], "doc": doc or nm} for nm, dims, doc in spec]


#: the real arrays of the C's soft-row struct besides its NA coefficients (``ipm_sr_t`` in the problem header)
SR_FIELDS = (
    "e",
    "bb",
    "b1",
    "b2",
    "t1",
    "l1",
    "t2",
    "l2",
    "it1",
    "it2",
    "rp1",
    "rp2",
    "id",
    "c",
    "dt1",
    "dl1",
    "dt2",
    "dl2",
    "zs",
    "dzs",
    "rds",
    "hs",
    "ps",
    "qs",
    "w",
)


#: rows the C reads at a time in a run of soft rows (its SIMD lanes: 4 doubles in 256 bits) ...
SR_LANES = 4
#: ... when padding the runs to a multiple of it adds at most this fraction of rows (else 1 lane: no padding)
SR_PAD_MAX = 0.125


def sr_lanes(sr: SoftRows) -> int:
    """Lanes of the C's soft-row loops: ``SR_LANES`` for long runs (the circles' rows: 27-147 per run), 1 where padding
    would add many rows of no work (the ellipse's 3 rows per run: +33 %)."""
    n = np.diff(sr.run_ptr)
    padded = int(np.sum(-(-n // SR_LANES) * SR_LANES))
    return SR_LANES if padded <= (1 + SR_PAD_MAX) * max(1, sr.count) else 1


def padded_runs(sr: SoftRows):
    """The C's storage of the soft rows: run by run, each padded with rows of no data to a multiple of
    ``sr_lanes(sr)`` rows (so that a run's loop reads whole groups of lanes, no remainder). Returns the runs' pointers
    into the storage and ``pad(values, fill=-1)``, which places per-row values at their rows' storage and ``fill`` on
    the padding."""
    lanes = sr_lanes(sr)
    n = np.diff(sr.run_ptr)
    ptr = np.r_[0, np.cumsum(-(-n // lanes) * lanes)].astype(np.int64)
    pos = np.concatenate([ptr[r] + np.arange(n[r]) for r in range(len(n))] + [np.zeros(0, dtype=np.int64)])

    def pad(values, fill: int = -1) -> np.ndarray:
        v = np.asarray(values)
        out = np.full((int(ptr[-1]), *v.shape[1:]), fill, dtype=np.int64)
        out[pos] = v
        return out

    return ptr, pad


def workspace_bytes(members: list[dict], sr: SoftRows, real_size: int) -> int:
    """sizeof the C workspace struct on an LP64 target (two pointers, the real arrays, the soft rows' arrays and their
    runs' sums)."""
    size = 16 + sum(int(np.prod(m["dims"])) * real_size for m in members)
    size += max(1, int(padded_runs(sr)[0][-1])) * (sr.NA + len(SR_FIELDS)) * real_size
    size += max(1, len(sr.run_ptr) - 1) * (sr.NA * (sr.NA + 1) // 2 + 3 * sr.NA) * real_size
    return -(-size // 8) * 8


def slack_entries(tab: IpmTables, N: int, NS: int, NG: int) -> tuple[np.ndarray, np.ndarray]:
    """The (x, u) entries of every slack's rows, slack by slack (stage k's slack s: ``ptr[k NS + s]`` on), each as its
    general-entry index: the slack elimination's loops in the order of the slots' loops, one level flatter."""
    ptr: list[int] = [0]
    ent: list[int] = []
    for ks in range((N + 1) * NS):
        for p in range(tab.sg_ptr[ks], tab.sg_ptr[ks + 1]):
            gi = (ks // NS) * NG + int(tab.sg_g[p])
            ent.extend(range(tab.gen_xu_ptr[gi], tab.gen_xu_ptr[gi + 1]))
        ptr.append(len(ent))
    return np.array(ptr, dtype=np.int64), np.array(ent, dtype=np.int64)


def xu_ranges(sv: StageView) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per stage, the (x, u) slots with a variable: lo .. hi - 1, on consecutive variables from v (the layout puts a
    stage's variables together; raises if not, as the C gathers a stage's (x, u) by a range)."""
    nxu = sv.nx + sv.NU
    lo, hi, v = (np.zeros(sv.N + 1, dtype=np.int64) for _ in range(3))
    for k in range(sv.N + 1):
        vm = sv.vmap[k, :nxu]
        pres = np.flatnonzero(vm >= 0)
        if not pres.size or not (np.all(np.diff(pres) == 1) and np.all(np.diff(vm[pres]) == 1)):
            raise AssertionError(f"stage {k}: its (x, u) variables must be consecutive slots and variables")
        lo[k], hi[k], v[k] = pres[0], pres[-1] + 1, vm[pres[0]]
    return lo, hi, v


def fg_bands(sv: StageView) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """[F G]'s columns as bands of rows, the same at every stage: column j's non-zeros (over all stages) lie in rows
    a0[j] .. a1[j] - 1 and are stored at off[j] .. in a stage's packed array (``IPM_W.fgb``); ``pos[e]``: where
    dynamics entry e goes. Dense kernels over bands read no index inside their loops."""
    nfgc = int(np.max(sv.dyn_j, initial=sv.nx - 1)) + 1
    a0 = np.zeros(nfgc, dtype=np.int64)
    a1 = np.zeros(nfgc, dtype=np.int64)
    for j in range(nfgc):
        rows = sv.dyn_i[sv.dyn_j == j]
        if rows.size:
            a0[j], a1[j] = int(rows.min()), int(rows.max()) + 1
    off = np.r_[0, np.cumsum(a1 - a0)].astype(np.int64)
    pos = off[sv.dyn_j] + sv.dyn_i - a0[sv.dyn_j]
    return a0, a1, off, pos


def generic_A(layout: QpLayout, sr: SoftRows, sv: StageView) -> tuple[np.ndarray, ...]:
    """A without the soft rows and their slacks' bound rows, the dynamics and the init rows (the C's generic A z
    and A' y; the others have loops of their own: the soft rows', and the stage kernels on [F G] for the dynamics):
    row-major (rows, pointers, columns, data indices) and column-major (pointers, rows, data indices)."""
    keep = np.ones(layout.m, dtype=bool)
    keep[sr.row] = False
    keep[sr.brow] = False
    keep[sv.dyn_rows.ravel()] = False
    keep[layout.init_rows] = False
    ent = np.flatnonzero(keep[layout.A_indices])  # CSC positions = data indices of the kept entries
    rows = layout.A_indices[ent]
    cols = np.repeat(np.arange(layout.n), np.diff(layout.A_indptr))[ent]
    a_p = np.r_[0, np.cumsum(np.bincount(cols, minlength=layout.n))]
    kept_rows = np.flatnonzero(keep)
    order = np.lexsort((cols, rows))
    ar_p = np.r_[0, np.cumsum(np.bincount(rows, minlength=layout.m)[kept_rows])]
    return kept_rows, ar_p, cols[order], ent[order], a_p, rows, ent


def split_A(tab: IpmTables, sv: StageView, ar: tuple[np.ndarray, ...], gen_e: np.ndarray) -> dict[str, np.ndarray]:
    """The generic A's rows and columns by kind, so that A z and A' y run without an inner loop where there is one
    entry: rows that are neither box nor general rows (stage equalities; box and general rows go through their own
    tables, IPM_BOX_* and IPM_GEN_*, in the CSR's order of entries, checked here, so the sums are the CSR loop's)
    and the generic variables' columns with no entry, one entry (its row and data index), several (the CSC)."""
    ar_row, ar_p, ar_j, ar_k, a_p, a_i, a_k, gvars = ar
    pos = {int(r): i for i, r in enumerate(ar_row)}
    gen_rows = [int(r) for r in sv.gen_rows.ravel() if r >= 0]
    for a, r in enumerate(sv.box_rows):
        i = pos[int(r)]
        if ar_p[i + 1] - ar_p[i] != 1 or ar_k[ar_p[i]] != sv.box_a[a] or ar_j[ar_p[i]] != sv.box_var[a]:
            raise AssertionError("a box row is not one entry of the generic A")
    for gs, r in enumerate(sv.gen_rows.ravel()):
        if r < 0:
            continue
        i = pos[int(r)]
        gen = list(tab.gen_var[tab.gen_xu_ptr[gs] : tab.gen_xu_ptr[gs + 1]])
        gen += [int(tab.gen_svar[gs])] if gen_e[gs] >= 0 else []
        if gen != [int(v) for v in ar_j[ar_p[i] : ar_p[i + 1]]]:
            raise AssertionError("a general row's entries are not in the generic A's order")
    own = set(sv.box_rows.tolist()) | set(gen_rows)  # rows with tables of their own
    other = [i for i, r in enumerate(ar_row) if int(r) not in own]
    counts = np.diff(a_p)[gvars]
    one = gvars[counts == 1]
    return {
        "ar_other": np.array(other, dtype=np.int64),
        "col0": gvars[counts == 0],
        "col1": one,
        "col1_row": a_i[a_p[one]],
        "col1_k": a_k[a_p[one]],
        "colm": gvars[counts > 1],
    }


def input_blocks(sv: StageView, sr: SoftRows) -> np.ndarray:
    """Per stage, the boundaries of the blocks of consecutive inputs over which R_bar = H_uu + G' P G is block
    diagonal: inputs that a row or the dynamics couple are in one block (e.g. the controls; each opponent's
    hyperplane variables). Row k: ``[0, b1, ..., NU]``, padded with NU (empty blocks) to the longest row."""
    nx, NU = sv.nx, sv.NU
    rows = []
    for k in range(sv.N + 1):
        parent = list(range(NU))

        def find(i, parent=parent):
            while parent[i] != i:
                i = parent[i]
            return i

        def couple(slots, parent=parent):
            us = [int(v) - nx for v in slots if nx <= v < nx + NU]
            for a in us[1:]:
                parent[find(a)] = find(us[0])

        if k < sv.N:
            couple(sv.dyn_j[sv.dyn_ptr[k] : sv.dyn_ptr[k + 1]])  # G' P G couples every input with dynamics
        for g in range(k * sv.NG, (k + 1) * sv.NG):
            couple(sv.gen_v[sv.gen_ptr[g] : sv.gen_ptr[g + 1]])
        for j in range(sr.ptr[k], sr.ptr[k + 1]):
            couple(sr.v[j][sr.a[j] >= 0])
        hi: dict[int, int] = {}
        for i in range(NU):
            hi[find(i)] = max(hi.get(find(i), i), i)
        ends, end = [0], 0
        for i in range(NU):  # blocks: the components' hulls, merged where they overlap
            end = max(end, hi[find(i)] + 1)
            if i + 1 == end:
                ends.append(end)
        rows.append(ends)
    width = max(len(r) for r in rows)
    return np.array([r + [NU] * (width - len(r)) for r in rows], dtype=np.int64)
