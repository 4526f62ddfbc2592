"""The IPM backend's C side of one problem: the context of ``templates/backends/ipm.c.j2``.

That template renders the problem header (``ipm_problem.h.j2``: every size as a macro, the stage view's index tables,
the settings, the workspace struct, the kernels of ``ipm_kernels`` written out) and puts the hand-written algorithm
(``csrc/ipm/``, the same for every problem) after it, into ``<name>_solver.c``. The C treats the soft rows
(``qp.split_soft_rows``) in loops of their own and the rest of the stage view with the generic tables.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..backends import QP_STATUSES, BackendFiles
from ..backends.ipm import RAW_STATUS, RAW_TO_QP, ipm_settings
from ..backends.ipm_tables import IpmTables
from ..c_literals import c_list, c_real
from ..qp import QpLayout, SoftRows, StageView, slack_bound_sides, split_soft_rows, stage_view
from .ipm_kernels import dense_kernels, fg_kernels, gen_kernels, sr_kernels, u_kernels
from .ipm_layout import (
    SR_FIELDS,
    U_KERNEL_MAX,
    fg_bands,
    generic_A,
    input_blocks,
    padded_runs,
    slack_entries,
    split_A,
    sr_lanes,
    workspace_bytes,
    workspace_members,
    xu_ranges,
)
from .render import csrc_dir

if TYPE_CHECKING:  # pragma: no cover
    from ..dsl import QpOptions

#: the tables the C indexes ``[k][s]`` (no index arithmetic with a size that may be 1: MISRA 2.2); the rest is flat
TABLES_2D = (
    "IPM_UB",
    "IPM_VMAP_S",
    "IPM_SG_BEG",
    "IPM_SG_END",
    "IPM_SE_BEG",
    "IPM_SE_END",
    "IPM_SR_RUN_V",
    "IPM_SR_A",
    "IPM_SR_HLO",
    "IPM_SR_HHI",
)

CORE = "ipm/ipm_core.c"
"""The hand-written IPM (in ``csrc/``): one translation unit that includes its parts in order."""
_PART = re.compile(r'^#include "(ipm_\w+\.c)".*\n', re.M)


def _table(name: str, kind: str, values, doc: str) -> dict:
    """A C table: flat, or (``TABLES_2D``) a 2-D array with a row per first index."""
    a = np.asarray(values).astype(np.int64)
    if name in TABLES_2D:
        if not a.size:  # an empty table keeps its two dimensions (padding -1: the loops never read it)
            a = -np.ones((max(1, a.shape[0]), max(1, a.shape[1])), dtype=np.int64)
        rows = ",\n  ".join("{" + c_list([int(x) for x in r]) + "}" for r in a)
        return {"name": name, "kind": kind, "dims": f"[{a.shape[0]}][{a.shape[1]}]", "doc": doc, "body": rows}
    return {
        "name": name,
        "kind": kind,
        "dims": f"[{max(1, a.size)}]",
        "doc": doc,
        "body": c_list([int(x) for x in a.ravel()]),
    }


@dataclass(frozen=True)
class _Plan:
    """What the problem header's tables and sizes are made of (``ipm_layout``'s storage plan of one QP layout)."""

    sv: StageView
    sr: SoftRows
    tab: IpmTables
    gen_e: np.ndarray  # [k][g]: data index of general slot g's slack entry (-1: none)
    generic_a: tuple  # generic_A: rows, row pointers, columns, data indices; column pointers, rows, data indices
    ub: np.ndarray  # input_blocks
    gvars: np.ndarray  # the variables but the soft rows' slacks
    split: dict  # split_A
    se_ptr: np.ndarray  # slack_entries
    se_a: np.ndarray
    gen_pat: np.ndarray  # gen_kernels' flags and bodies
    gen_k: dict
    run_ptr: np.ndarray  # padded_runs
    pad: Callable[..., np.ndarray]
    sb: tuple  # slack_bound_sides: side, slack, data index


def _plan(layout: QpLayout) -> _Plan:
    """The storage plan of ``layout`` (checks what the C assumes of it)."""
    sv, sr = split_soft_rows(layout, stage_view(layout))
    tab = IpmTables(layout, sv)
    N, NS, NG = sv.N, sv.NS, sv.NG
    gen_e = np.where(tab.gen_e < layout.nnz_A, tab.gen_e, -1)
    ar = generic_A(layout, sr, sv)
    gvars = np.setdiff1d(np.arange(layout.n), sr.svar)
    split = split_A(tab, sv, (*ar, gvars), gen_e.ravel())
    se_ptr, se_a = slack_entries(tab, N, NS, NG)
    gen_pat, gen_k = gen_kernels(sv, tab, se_ptr, gen_e)
    run_ptr, pad = padded_runs(sr)
    if sv.N and not np.all(np.diff(sv.dyn_rows, axis=1) == 1):  # the C reads a stage's c_k in place (ipm_stage_c)
        raise AssertionError("the IPM needs each stage's dynamics rows consecutive in the QP layout")
    pairs = tab.in_ptr[:-1][np.diff(tab.in_ptr) == 2]
    if not (np.all(sv.side_sign[pairs] > 0) and np.all(sv.side_sign[pairs + 1] < 0)):
        raise ValueError("a two-sided inequality row's sides must be lower, then upper (the C's pair loops assume it)")
    return _Plan(
        sb=slack_bound_sides(sv),
        sv=sv,
        sr=sr,
        tab=tab,
        gen_e=gen_e,
        generic_a=ar,
        ub=input_blocks(sv, sr),
        gvars=gvars,
        split=split,
        se_ptr=se_ptr,
        se_a=se_a,
        gen_pat=gen_pat,
        gen_k=gen_k,
        run_ptr=run_ptr,
        pad=pad,
    )


def _stage_tables(layout: QpLayout, p: _Plan) -> list[tuple[str, Any, str]]:
    """The index tables of A and of the stage view but the soft rows: (name, values, doc)."""
    sv, tab, split = p.sv, p.tab, p.split
    N, NS, NE1, nxu = sv.N, sv.NS, max(sv.NE, 1), sv.nx + sv.NU
    ar_row, ar_p, ar_j, ar_k, a_p, a_i, a_k = p.generic_a
    gptr, gv, ga = tab.gen_xu_ptr, tab.gen_xu_v, tab.gen_xu_a
    eq_row = -np.ones((N + 1, NE1), dtype=np.int64)
    eq_row[:, : sv.NE] = sv.eq_rows
    xu_lo, xu_hi, xu_v = xu_ranges(sv)
    return [
        ("IPM_A_P", a_p, "column pointers of A without the soft rows"),
        ("IPM_A_I", a_i, "their rows"),
        ("IPM_A_K", a_k, "their data index"),
        ("IPM_AR_ROW", ar_row, "rows of A without the soft rows"),
        ("IPM_AR_P", ar_p, "their entries (row-major)"),
        ("IPM_AR_J", ar_j, "column of row-major entry p"),
        ("IPM_AR_K", ar_k, "its data index"),
        ("IPM_AR_OTHER", split["ar_other"], "the rows i of IPM_AR_ROW that are neither box nor general rows"),
        ("IPM_A_COL0", split["col0"], "generic variables without an entry in the generic A"),
        ("IPM_A_COL1", split["col1"], "generic variables with one entry"),
        ("IPM_A_COL1_I", split["col1_row"], "its row"),
        ("IPM_A_COL1_K", split["col1_k"], "its data index"),
        ("IPM_A_COLM", split["colm"], "generic variables with several entries (IPM_A_P)"),
        ("IPM_VMAP_XU", sv.vmap[:, :nxu], "[k][v]: variable of stage k's x/input slot v"),
        ("IPM_XU_LO", xu_lo, "stage k's first slot with a variable"),
        ("IPM_XU_HI", xu_hi, "one past its last"),
        ("IPM_XU_V", xu_v, "the variable of slot IPM_XU_LO[k] (the others follow it)"),
        ("IPM_VMAP_S", sv.vmap[:, nxu:].reshape(N + 1, NS), "[k][s]: variable of stage k's slack s"),
        ("IPM_GEN_ROW", sv.gen_rows, "[k][g]: general inequality row"),
        ("IPM_GEN_PTR", gptr, "entries of general slot k NG + g"),
        ("IPM_GEN_V", gv, "stage slot v of the entry"),
        ("IPM_GEN_A", ga, "data index of the entry"),
        ("IPM_GEN_VAR", tab.gen_var, "variable of the entry"),
        ("IPM_GEN_E", p.gen_e, "data index of the slot's slack entry"),
        ("IPM_GEN_SVAR", tab.gen_svar, "variable of the slot's slack"),
        ("IPM_SG_BEG", tab.sg_ptr[:-1].reshape(N + 1, NS), "[k][s]: general slots of stage k's slack s (first)"),
        ("IPM_SG_END", tab.sg_ptr[1:].reshape(N + 1, NS), "[k][s]: (one past the last)"),
        ("IPM_SG_G", tab.sg_g, "the general slot (in its stage)"),
        ("IPM_SE_BEG", p.se_ptr[:-1].reshape(N + 1, NS), "[k][s]: the (x, u) entries of stage k's slack s's rows"),
        ("IPM_SE_END", p.se_ptr[1:].reshape(N + 1, NS), "[k][s]: (one past the last)"),
        ("IPM_SE_V", np.asarray(gv, dtype=np.int64)[p.se_a], "its stage slot v"),
        ("IPM_IN_ROW", tab.in_rows, "inequality row i (ascending)"),
        ("IPM_IN_PTR", tab.in_ptr, "sides of row i"),
        ("IPM_DYN_ROWS", sv.dyn_rows, "[k][i]: dynamics row i of stage k"),
        ("IPM_DYN_NEXT", sv.dyn_next, "[k][i]: data index of its x_{k+1}[i] coefficient"),
        ("IPM_DYN_PTR", sv.dyn_ptr, "[A B] entries of stage k"),
        ("IPM_DYN_I", sv.dyn_i, "row i"),
        ("IPM_DYN_A", sv.dyn_a, "data index"),
        ("IPM_DYN_B", fg_bands(sv)[3], "its place in the stage's packed [F G] (IPM_W.fgb, fg_bands)"),
        ("IPM_INIT_ROWS", layout.init_rows, "init row of x_0[i]"),
        ("IPM_INIT_A", sv.init_a, "its data index"),
        ("IPM_EQ_ROW", eq_row, "[k][e]: stage equality row"),
        ("IPM_EQ_PTR", sv.eq_ptr, "entries of slot k NE + e"),
        ("IPM_EQ_J", sv.eq_j, "input index"),
        ("IPM_EQ_A", sv.eq_a, "data index"),
        ("IPM_BOX_ROW", sv.box_rows, "box row"),
        ("IPM_BOX_VAR", sv.box_var, "its variable"),
        ("IPM_BOX_A", sv.box_a, "its data index"),
        ("IPM_SB_SIDE", p.sb[0], "the sides on a slack's bound (qp.slack_bound_sides)"),
        ("IPM_SB_VAR", p.sb[1], "the slack"),
        ("IPM_SB_A", p.sb[2], "the data index of the bound's coefficient"),
        ("IPM_SIDE_ROW", sv.side_row, "row of inequality side j"),
        ("IPM_EQ_ALL", sv.eq_all, "equality rows"),
        ("IPM_FREE", np.flatnonzero(tab.free_inputs), "inputs without cost (proximal weight)"),
        ("IPM_UB", p.ub, "[k][b]: stage k's input block b: inputs IPM_UB[k][b] .. IPM_UB[k][b + 1] - 1"),
        ("IPM_GV", p.gvars, "the variables but the soft rows' slacks"),
    ]


def _soft_row_tables(p: _Plan) -> list[tuple[str, Any, str]]:
    """The index tables of the soft rows (their storage padded to whole lanes): (name, values, doc)."""
    sr, pad = p.sr, p.pad
    run_v = sr.run_v.reshape(-1, sr.NA)
    hq_a, hq_b = run_v[:, np.triu_indices(sr.NA)[0]], run_v[:, np.triu_indices(sr.NA)[1]]  # a run's upper triangle
    return [
        ("IPM_SR_RPTR", sr.rptr, "runs of soft rows of stage k"),
        ("IPM_SR_RUN_PTR", p.run_ptr, "soft rows of run r (rows on the same slots; padded to IPM_LANES rows)"),
        ("IPM_SR_RUN_V", run_v, "[r][p]: stage slot of the run's (x, u) entry p"),
        ("IPM_SR_ROW", pad(sr.row), "soft row j's row (-1: a padding row)"),
        ("IPM_SR_A", pad(sr.a.reshape(-1, sr.NA)), "[j][p]: its data index (-1: padding)"),
        ("IPM_SR_SVAR", pad(sr.svar), "its slack"),
        ("IPM_SR_E", pad(sr.e), "data index of the slack's coefficient"),
        ("IPM_SR_BROW", pad(sr.brow), "the slack's bound row"),
        ("IPM_SR_BA", pad(sr.ba), "data index of the bound row's coefficient"),
        (
            "IPM_SR_HLO",
            np.minimum(hq_a, hq_b),
            "[r][q]: the Newton block's row of entry q of run r's upper triangle (row-major; on or above the diagonal)",
        ),
        ("IPM_SR_HHI", np.maximum(hq_a, hq_b), "[r][q]: its column"),
    ]


def _sign_tables(p: _Plan) -> list[dict]:
    """The tables of signs and flags (``signed char``), and the sides' signs as reals."""
    sv, sr, pad = p.sv, p.sr, p.pad
    second = np.r_[False, sv.side_row[1:] == sv.side_row[:-1]] if len(sv.side_row) else np.zeros(0, dtype=bool)
    out = [
        _table(nm, "sign", t, doc)
        for nm, t, doc in (
            ("IPM_SR_SIGN", pad(sr.sign, 0), "soft row j's side: +1 lower, -1 upper (0: a padding row)"),
            ("IPM_SR_BSIGN", pad(sr.bsign, 0), "its slack's bound side"),
            ("IPM_SIDE_SIGN", sv.side_sign, "+1: lower side (a'z >= l), -1: upper side (a'z <= u)"),
            ("IPM_SIDE_2ND", second, "1: the second side of its row (the per-row sums add, the first side sets)"),
            ("IPM_IN_TWO", np.diff(p.tab.in_ptr) == 2, "1: inequality row i has two sides (lower, then upper), 0: one"),
            *(
                [("IPM_GEN_PAT", p.gen_pat, "1: stage k's general rows follow the written-out pattern (gen_kernels)")]
                if p.gen_pat.any()
                else []
            ),
        )
    ]
    sg = np.asarray(sv.side_sign, dtype=np.int64)  # the sides' signs in the real type: a multiply, no conversion
    out.append(
        {
            "name": "IPM_SIDE_SG",
            "kind": "real",
            "dims": f"[{max(1, sg.size)}]",
            "doc": "IPM_SIDE_SIGN as a real",
            "body": ", ".join(("IPM_SG_P" if v > 0 else "IPM_SG_M") for v in sg) or "IPM_SG_P",
        }
    )
    return out


def _sizes(layout: QpLayout, p: _Plan) -> dict[str, Any]:
    """The problem header's size macros (``IPM_<key>``) and the soft rows' weight expression."""
    sv, sr, tab, split = p.sv, p.sr, p.tab, p.split
    fg_a0, _, fg_off, _ = fg_bands(sv)
    return {
        "N": sv.N,
        "NX": sv.nx,
        "NU": sv.NU,
        "NS": sv.NS,
        "NG": sv.NG,
        "NE": sv.NE,
        "NE1": max(sv.NE, 1),
        "RS": tab.slack_rows.shape[2],
        "NSIDE": len(sv.side_row),
        "NIN": len(tab.in_rows),
        "NEQ": len(sv.eq_all),
        "NBOX": len(sv.box_rows),
        "NSB": len(p.sb[0]),
        "NGA": len(tab.gen_xu_v),
        "NSR": sr.count,
        "NSRP": int(p.run_ptr[-1]),
        "LANES": sr_lanes(sr),
        "sr_weight": "(IPM_SR.w[i])" if p.run_ptr[-1] > sr.count else "(IPM_ONE)",  # 1 without padding rows
        "NUB": p.ub.shape[1] - 1,
        "NV": layout.n,
        "NGV": len(p.gvars),
        "NFGC": len(fg_a0),
        "NFGB": int(fg_off[-1]),
        "NA": sr.NA,
        "NRUN": len(sr.run_ptr) - 1,
        "NAR": len(p.generic_a[0]),
        "sr_fields": SR_FIELDS,
        "NAR_OTHER": len(split["ar_other"]),
        "NCOL0": len(split["col0"]),
        "NCOL1": len(split["col1"]),
        "NCOLM": len(split["colm"]),
        "NFREE": int(np.count_nonzero(tab.free_inputs)),
    }


def _settings(opts: QpOptions) -> dict[str, Any]:
    """The IPM's settings as C literals (``IPM_TOL``, ...)."""
    st = ipm_settings(opts)
    return {
        "prox": c_real(st.prox),
        "tol": c_real(st.tol),
        "tau": c_real(st.tau),
        "reg": c_real(st.reg),
        "t_min": c_real(st.t_min),
        "lam_center": c_real(st.lam_center),
        "lam_min": c_real(st.lam_min),
        "lam_max": c_real(st.lam_max),
        "alpha_min": c_real(st.alpha_min),
        "warm": int(st.warm),
        "scaled_start": int(st.scaled_start),
    }


def codegen_context(ocp, layout: QpLayout, opts: QpOptions) -> dict:
    """What ``templates/backends/ipm.c.j2`` needs (rendered under the key ``backend``): the problem header's sizes,
    settings, tables, workspace and written-out kernels, and the hand-written algorithm's parts."""
    p = _plan(layout)
    sv, NX, NU = p.sv, p.sv.nx, p.sv.NU
    tables = _stage_tables(layout, p) + _soft_row_tables(p)
    if sv.NE == 0:  # the C has the stage-equality code only with stage equalities
        tables = [t for t in tables if not t[0].startswith("IPM_EQ_") or t[0] == "IPM_EQ_ALL"]
    if not ipm_settings(opts).scaled_start:  # the slack bounds' cold start is the scaled start's
        tables = [t for t in tables if not t[0].startswith("IPM_SB_")]
    u_dense = NU <= U_KERNEL_MAX
    if u_dense:  # R factored for all inputs at once (u_kernels): the blocks' table is not read
        tables = [t for t in tables if t[0] != "IPM_UB"]
    top = max(int(np.max(np.asarray(t), initial=0)) for _, t, _ in tables)
    out = [_table(nm, "idx", t, doc) for nm, t, doc in tables] + _sign_tables(p)
    return {
        **_sizes(layout, p),
        **_settings(opts),
        "idx_ctype": "int16_t" if top < 2**15 else "int32_t",
        "tables": out,
        "members": workspace_members(sv, layout),
        "raw_status": [(i + 1, QP_STATUSES[RAW_TO_QP[i] - 1]) for i in range(len(RAW_STATUS))],
        "U_DENSE": int(u_dense),
        "GEN_WRITTEN": int(p.gen_pat.any()),
        "kernels": {**fg_kernels(sv), **dense_kernels(NX, NU), **sr_kernels(p.sr.NA), **u_kernels(NU, NX), **p.gen_k},
        "core_parts": core_parts(),
    }


def core_parts() -> list[str]:
    """The hand-written IPM (``csrc/ipm/ipm_core.c``) as the texts the solver file puts after the problem header: the
    core's own text without its ``#include`` lines, then each part it includes, in its order."""
    core = csrc_dir() / CORE
    text = core.read_text()
    parts = _PART.findall(text)
    if not parts:
        raise AssertionError(f"{core}: no part included")
    return [_PART.sub("", text)] + [(core.parent / name).read_text() for name in parts]


def core_files() -> list[Path]:
    """The files of the hand-written IPM: ``ipm_core.c`` and its parts."""
    core = csrc_dir() / CORE
    return [core] + [core.parent / name for name in _PART.findall(core.read_text())]


def write_files(ocp, layout: QpLayout, opts: QpOptions, out_dir, use_float: bool) -> BackendFiles:
    """The IPM is all in the solver's C file: no extra files; its RAM is the workspace struct."""
    sv, sr = split_soft_rows(layout, stage_view(layout))
    ws = workspace_bytes(workspace_members(sv, layout), sr, 4 if use_float else 8)
    return BackendFiles(
        sources=(),
        headers=(),
        library_sources=(),
        library_headers=(),
        include_dirs=(),
        private_include_dirs=(),
        cflags=(),
        link_libs=(),
        array_bytes=ws,
        struct_bytes=0,
        memory_init_note=": one struct, every array written before it is read",
        memory_note="its index tables (the stage view of the QP layout) are `static const` (flash)",
        reset_note="The QP backend's workspace (the IPM's one static struct) is zeroed before its next "
        "use; the IPM keeps no scaling\nand starts every QP from z = 0 and the previous "
        "multipliers (the dual warm start): nothing else is carried over.",
    )
