"""The IPM's kernels written out for one problem: C statement bodies at its sizes and sparsity.

A code generator for a fixed pattern writes them (acados', CasADi's way): no loop, no index, only the structural
non-zeros multiplied. The problem header (``templates/backends/ipm_problem.h.j2``) puts each body into its static
function; the hand-written C (``csrc/ipm/``) calls them. Every body does the generic loops' operations in their order,
so the results are unchanged: ``fg_kernels`` ([F G]'s pattern), ``dense_kernels`` (small dense stage products),
``u_kernels`` (R's factor and solves, NU <= ``ipm_layout.U_KERNEL_MAX``), ``gen_kernels`` (the general rows of the
stages of the commonest pattern), ``sr_kernels`` (a soft row's entries).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..backends.ipm_tables import IpmTables
from ..qp import StageView
from .ipm_layout import fg_bands


def _c_sum(terms: list[str]) -> str:
    """A C sum of terms, left to right, parenthesized when there are several (MISRA's explicit precedence)."""
    return " + ".join(terms) if len(terms) < 2 else "(" + " + ".join(terms) + ")"


def _lower(name: str, i: int, j: int) -> str:
    """Entry (i, j) of a symmetric matrix of which the C keeps the lower triangle only (the cost-to-go P)."""
    return f"{name}[{max(i, j)}][{min(i, j)}]"


def fg_kernels(sv: StageView) -> dict[str, str]:
    """Bodies of the stage kernels on [F G]'s sparsity (the same at every stage; column j's band packed at off[j]),
    written out statement by statement as a code generator for a fixed pattern does (acados', CasADi's): no loop,
    no index, only [F G]'s structural non-zeros multiplied. ``ctg``: H[i][j] = ([F G]' P [F G])[i][j] for i <= j
    (the whole upper triangle: 0 beyond column NFGC; P [F G] into locals, a column at a time; P read on and below
    its diagonal); ``tdot``: out[j] += ([F G]' x)[j]; ``axpy``: y += [F G] v. Each sum runs over the band's rows in
    ascending order (the order the Python reference's dense products need not share: verify compares within
    tolerances)."""
    a0, _a1, off, _ = fg_bands(sv)
    nx, nfgc = sv.nx, len(a0)
    nz = np.zeros((nx, nfgc), dtype=bool)  # the pattern over all stages (a band may hold a zero: skip it)
    nz[sv.dyn_i, sv.dyn_j] = True

    def el(b: int, j: int) -> str:
        return f"fg[{int(off[j] + b - a0[j])}]"

    # H[i][j] = FG_s' (P FG_d) with d the denser of columns i, j (a tie: j) and s the other: m_a_d = (P FG_d)[a] for
    # the rows a of the sparser columns s paired with d (the fewest products for [F G]'s pattern)
    cnt = nz.sum(axis=0)
    pairs: dict[int, list[tuple[int, int]]] = {d: [] for d in range(nfgc)}
    for i in range(nfgc):
        for j in range(i, nfgc):
            pairs[j if cnt[j] >= cnt[i] else i].append((i, j))
    ctg = []
    for d in range(nfgc):  # column by column: its m's, then the entries they serve (the m's in registers)
        other = {(i, j): (i if j == d else j) for i, j in pairs[d]}
        need = sorted({a for s in other.values() for a in np.flatnonzero(nz[:, s])})
        for a in need:
            terms = [f"({_lower('P', int(a), b)} * {el(b, d)})" for b in range(nx) if nz[b, d]]
            ctg.append(f"const ipm_real_t m{a}_{d} = {_c_sum(terms) if terms else 'REAL_0'};")
        for (i, j), s_ in other.items():
            terms = [f"({el(b, s_)} * m{b}_{d})" for b in range(nx) if nz[b, s_]]
            ctg.append(f"H[{i}][{j}] = {_c_sum(terms) if terms else 'REAL_0'};")
    ctg += [f"H[{i}][{j}] = REAL_0;" for j in range(nfgc, sv.nx + sv.NU) for i in range(j + 1)]
    tdot = []
    for j in range(nfgc):
        terms = [f"({el(b, j)} * x[{b}])" for b in range(nx) if nz[b, j]]
        if terms:
            tdot.append(f"out[{j}] += {_c_sum(terms)};")
    axpy = []
    for b in range(nx):
        terms = [f"({el(b, j)} * v[{j}])" for j in range(nfgc) if nz[b, j]]
        if terms:
            axpy.append(f"y[{b}] += {_c_sum(terms)};")
    return {"ctg": "\n  ".join(ctg), "tdot": "\n  ".join(tdot), "axpy": "\n  ".join(axpy)}


def dense_kernels(nx: int, nu: int) -> dict[str, str]:
    """Bodies of the small dense stage kernels at this problem's sizes, written out (every size a compile-time
    constant: a loop of 8 costs more in counting than in multiplying on a Cortex-M). ``mv``: y = P x (NX x NX, its
    lower triangle read); ``wx``: y = W1 x (NU x NX); ``q_wtx``: y = q - W1' x (p_k straight from the kernel: no
    copy that reads back values just stored); ``pk``: Pk = H[x][x] - W1' W1 on and below the diagonal (H's upper
    triangle read); ``pk_nf``: 0 times each entry of P's lower triangle (all the factorization writes), summed in four
    chains: NaN once one is not finite."""
    pxs = [_c_sum([f"({_lower('P', i, j)} * x[{j}])" for j in range(nx)]) for i in range(nx)]  # (P x)[i]
    mv = [f"y[{i}] = {pxs[i]};" for i in range(nx)]
    wx = [f"y[{i}] = {_c_sum([f'(W[{i}][{j}] * x[{j}])' for j in range(nx)])};" for i in range(nu)]
    q_wtx = [f"y[{i}] = q[{i}] - {_c_sum([f'(W[{a}][{i}] * x[{a}])' for a in range(nu)])};" for i in range(nx)]
    pk = [
        f"Pk[{i}][{j}] = H[{j}][{i}] - {_c_sum([f'(W[{a}][{i}] * W[{a}][{j}])' for a in range(nu)])};"
        for i in range(nx)
        for j in range(i + 1)
    ]
    mv_add = [
        ln
        for i in range(nx)
        for ln in (f"const ipm_real_t y{i} = {pxs[i]};", f"y[{i}] = y{i};", f"z[{i}] = y{i} + a[{i}];")
    ]
    low = [f"P[{i}][{j}]" for i in range(nx) for j in range(i + 1)]  # P_k's finiteness test: 0 x each, 4 chains
    chains = [low[c::4] for c in range(4)]
    pk_nf = [
        f"const ipm_real_t s{c} = {_c_sum([f'({e} * REAL_0)' for e in ch]) if ch else 'REAL_0'};"
        for c, ch in enumerate(chains)
    ]
    pk_nf.append("return (s0 + s1) + (s2 + s3);")
    return {
        k: "\n  ".join(v)
        for k, v in (("mv", mv), ("mv_add", mv_add), ("wx", wx), ("q_wtx", q_wtx), ("pk", pk), ("pk_nf", pk_nf))
    }


def u_kernels(nu: int, nx: int) -> dict[str, str]:
    """Bodies of the Cholesky factor of R (NU x NU, stride NU) and of the solves with it, written out for all NU
    inputs at once (``IPM_U_DENSE``, NU <= ``ipm_layout.U_KERNEL_MAX``): ``u_chol`` (0, or 1 if a pivot is not
    positive), ``u_fwd``: X := L^-1 X over m columns of stride ldx, ``u_bwd_sub``: out := base - L^-T x (-L^-T x
    without base, the solve in registers, x unchanged). The operations and their order per entry are
    the generic loops' (ipm_chol, ipm_fwd, ipm_bwd), but for the sums' leading 0; where a stage's R is block diagonal
    (IPM_UB) the dense factor's entries between blocks come out exactly 0 (each product has a factor 0), so the
    factor and the solves equal the blockwise ones for finite data."""

    def el(m: str, i: int, j: int) -> str:  # entry (i, j) of an NU x NU row-major array
        return f"{m}[{i * nu + j}]"

    chol = ["ipm_real_t s;"]
    for j in range(nu):
        terms = " - ".join([el("A", j, j)] + [f"({el('Lo', j, k)} * {el('Lo', j, k)})" for k in range(j)])
        chol.append(f"s = {_left(terms)};")
        chol += ["if (!(s > REAL_0)) {", "  return 1;", "}", "s = IPM_SQRT(s);", f"{el('Lo', j, j)} = s;"]
        for i in range(j + 1, nu):
            t = " - ".join([el("A", i, j)] + [f"({el('Lo', i, k)} * {el('Lo', j, k)})" for k in range(j)])
            chol.append(f"{el('Lo', i, j)} = ({_left(t)}) / s;")
        chol += [f"{el('Lo', i, j)} = REAL_0;" for i in range(j)]
    chol.append("return 0;")

    def xr(i: int) -> str:  # X's row i, column c (no multiplication by 0 or 1: MISRA 2.2)
        return "X[c]" if i == 0 else ("X[ldx + c]" if i == 1 else f"X[({i} * ldx) + c]")

    fwd = [f"const ipm_real_t d{i} = IPM_ONE / {el('Lo', i, i)};" for i in range(nu)] + [
        "int c;",
        "for (c = 0; c < m; ++c) {",
    ]
    for i in range(nu):
        for j in range(i):
            fwd.append(f"  {xr(i)} -= {el('Lo', i, j)} * {xr(j)};")
        fwd.append(f"  {xr(i)} *= d{i};")
    fwd.append("}")
    bwd = _u_back(nu, lambda i: f"x[{i}]", "r")
    bwd += ["if (base != NULL) {"] + [f"  out[{i}] = base[{i}] - r{i};" for i in range(nu)] + ["} else {"]
    bwd += [f"  out[{i}] = -r{i};" for i in range(nu)] + ["}"]
    return {
        "u_chol": "\n  ".join(chol),
        "u_fwd": "\n  ".join(fwd),
        "u_bwd_sub": "\n  ".join(bwd),
        **u_fused_kernels(nu, nx),
    }


def _u_back(nu: int, x, r: str) -> list[str]:
    """Statements r_i = (L^-T x)_i, i = NU-1 .. 0 (Lo row-major, stride NU), x_i the C expression ``x(i)``."""
    out = []
    for i in reversed(range(nu)):
        terms = [f"(Lo[{j * nu + i}] * {r}{j})" for j in range(i + 1, nu)]
        out.append(
            f"const ipm_real_t {r}{i} = ({x(i)} - {_c_sum(terms)}) / Lo[{i * nu + i}];"
            if terms
            else f"const ipm_real_t {r}{i} = {x(i)} / Lo[{i * nu + i}];"
        )
    return out


def u_fused_kernels(nu: int, nx: int) -> dict[str, str]:
    """The backward and forward sweeps' input steps without stage equalities (``IPM_U_FUSED``), each one kernel
    whose few-entry intermediates stay in registers (stored and read back, a vectorizing compiler pairs them into
    loads that wait on two stores): ``u_rhs``: l = L^-1 h_u, p = h_x - W1' l, kk = -L^-T l (u_fwd, q_wtx and
    u_bwd_sub in a row); ``u_du``: du = kk - L^-T (W1 x) (wx, then u_bwd_sub). The same operations in the same
    order as those kernels: results are unchanged."""
    rhs = []
    for i in range(nu):
        t = " - ".join([f"h[{nx + i}]"] + [f"(Lo[{i * nu + j}] * l{j})" for j in range(i)])
        rhs.append(f"const ipm_real_t l{i} = ({_left(t)}) * (IPM_ONE / Lo[{i * nu + i}]);")
    rhs += [f"p[{i}] = h[{i}] - {_c_sum([f'(W[{a}][{i}] * l{a})' for a in range(nu)])};" for i in range(nx)]
    rhs += _u_back(nu, lambda i: f"l{i}", "r") + [f"kk[{i}] = -r{i};" for i in range(nu)]
    du = [f"const ipm_real_t t{i} = {_c_sum([f'(W[{i}][{j}] * x[{j}])' for j in range(nx)])};" for i in range(nu)]
    du += _u_back(nu, lambda i: f"t{i}", "r") + [f"du[{i}] = kk[{i}] - r{i};" for i in range(nu)]
    return {"u_rhs": "\n  ".join(rhs), "u_du": "\n  ".join(du)}


def _left(expr: str) -> str:
    """``a - b - c`` parenthesized left to right, ``((a - b) - c)`` (MISRA's explicit precedence, a loop's order)."""
    parts = expr.split(" - ")
    out = parts[0]
    for p in parts[1:]:
        out = f"({out} - {p})"
    return out[1:-1] if len(parts) > 1 else out


#: the bodies ``gen_kernels`` writes out (the problem header renders them under ``#if IPM_GEN_WRITTEN``)
GEN_KERNELS = ("gen_w", "gen_h", "gen_c", "gen_ax", "gen_atx", "gen_rhs", "gen_dz")

_GS = "const int gs = k * IPM_NG;"  # the stage's first general slot
_AT = "const int a = IPM_GEN_PTR[gs];"  # its first (x, u) entry


def _plus(b: str, o: int) -> str:
    """``b + o``, or ``b`` for o = 0 (no "+ 0": MISRA 2.2)."""
    return f"{b} + {o}" if o else b


@dataclass(frozen=True)
class _GenPattern:
    """The general rows' pattern that ``gen_kernels`` writes out: per general slot g of the stage (present, its (x, u)
    slots, has a slack), per slack (its general slots, has a variable), and row g's first entry from the stage's."""

    rows: tuple
    groups: tuple
    off: tuple[int, ...]

    @property
    def n(self) -> int:
        """(x, u) entries of the stage's general rows."""
        return sum(len(slots) for _, slots, _ in self.rows)

    def x(self, e: int) -> str:
        """The local that holds entry e's coefficient."""
        return f"x{e}"

    def load(self) -> list[str]:
        """The declarations that load every entry's coefficient into its local."""
        return [f"const ipm_real_t {self.x(e)} = IPM_W.gax[{_plus('a', e)}];" for e in range(self.n)]


def gen_kernels(sv: StageView, tab: IpmTables, se_ptr: np.ndarray, gen_e: np.ndarray) -> tuple[np.ndarray, dict]:
    """The general rows' part of a stage's factorization written out for the stages that share the commonest pattern
    (the same rows present, the same (x, u) slots per row, the same slacks and their rows: the a_lat rows of every
    stage but the first, typically): per stage a flag (``IPM_GEN_PAT``) and the bodies taking k, with the generic
    loops' operations in their order (results unchanged), the data at the stage's offsets: ``gen_w`` (its rows'
    weights, slack pivots and slack entries: ipm_stage_weights), ``gen_h`` (the rows' W c c' into H), ``gen_c``
    (two rows of one slack coupled), ``gen_ax`` (A z on the rows: ipm_ineq_Ax), ``gen_atx`` (A' g: ipm_ineq_ATx),
    ``gen_rhs`` (the slacks eliminated from the right-hand side: ipm_stage_rhs) and ``gen_dz`` (their step:
    ipm_forward_stage). No such stage: all flags 0 and no bodies."""
    found = _gen_pattern(sv, tab, se_ptr, gen_e)
    if found is None:  # no general row with an (x, u) entry: nothing written out (IPM_GEN_WRITTEN 0)
        return np.zeros(sv.N + 1, dtype=np.int64), {k: "" for k in GEN_KERNELS}
    flags, p = found
    bodies = {
        "gen_w": _gen_weights(p),
        "gen_h": _gen_hessian(p),
        "gen_c": _gen_couple(p),
        **_gen_products(p),
        **_gen_slacks(p),
    }
    return flags, {k: "\n  ".join(bodies[k]) for k in GEN_KERNELS}


def _gen_pattern(
    sv: StageView, tab: IpmTables, se_ptr: np.ndarray, gen_e: np.ndarray
) -> tuple[np.ndarray, _GenPattern] | None:
    """The commonest pattern of the stages' general rows and the flags of the stages written out with it (its offsets
    of entries and slack entries hold there); None if no stage has a general row with an (x, u) entry."""
    N, NG, NS, nxu = sv.N, sv.NG, sv.NS, sv.nx + sv.NU
    gptr, gv = tab.gen_xu_ptr, tab.gen_xu_v

    def signature(k: int) -> tuple:
        rows = tuple(
            (bool(sv.gen_rows[k, g] >= 0), tuple(gv[gptr[k * NG + g] : gptr[k * NG + g + 1]]), bool(gen_e[k, g] >= 0))
            for g in range(NG)
        )
        groups = tuple(
            (
                tuple(int(g) for g in tab.sg_g[tab.sg_ptr[k * NS + j] : tab.sg_ptr[k * NS + j + 1]]),
                bool(sv.vmap[k, nxu + j] >= 0),
            )
            for j in range(NS)
        )
        return rows, groups

    sigs = [signature(k) for k in range(N + 1)]
    counts: dict = {}
    for sg in sigs:
        if any(r[1] for r in sg[0]):  # a pattern worth writing out: some row with an (x, u) entry
            counts[sg] = counts.get(sg, 0) + 1
    if not counts:
        return None
    pat = max(counts, key=lambda sg: (counts[sg], -sigs.index(sg)))
    flags = np.array([sg == pat for sg in sigs], dtype=np.int64)
    rows, groups = pat
    off, n = [], 0  # row g's first (x, u) entry from the stage's first
    for _, slots, _ in rows:
        off.append(n)
        n += len(slots)
    for k in np.flatnonzero(flags):  # the pattern's offsets (entries, slack entries) hold, else the generic loops
        if any(gptr[k * NG + g] - gptr[k * NG] != off[g] for g in range(NG)) or any(
            se_ptr[k * NS + j] - se_ptr[k * NS] != sum(len(rows[g][1]) for gr, _ in groups[:j] for g in gr)
            for j in range(NS)
        ):
            flags[k] = 0
    return flags, _GenPattern(rows, groups, tuple(off))


def _gen_weights(p: _GenPattern) -> list[str]:
    """``gen_w``: the rows' weights, the slack pivots and the slack entries W e a (ipm_stage_weights)."""
    rows, groups, off = p.rows, p.groups, p.off
    in_groups = sorted({g for gr, _ in groups for g in gr})
    w = [_GS] + ([_AT] if any(rows[g][1] for g in in_groups) else [])
    stores = []  # the declarations first, then the stores
    for g, (present, _, slack) in enumerate(rows):
        if present:
            w.append(f"const ipm_real_t w{g} = IPM_W.wr[IPM_GEN_ROW[{_plus('gs', g)}]];")
        if slack:
            w += [f"const ipm_real_t gx{g} = IPM_W.gex[{_plus('gs', g)}];", f"const ipm_real_t wg{g} = w{g} * gx{g};"]
        stores += [
            f"IPM_W.Weff[{g}] = {f'w{g}' if present else 'REAL_0'};",
            f"IPM_W.wg[{_plus('gs', g)}] = {f'wg{g}' if slack else 'REAL_0'};",
        ]
    w += stores
    for j, (gr, has_var) in enumerate(groups):
        dd = f"hs{j}"
        for g in gr:
            dd = f"({dd} + (wg{g} * gx{g}))"
        w += [
            "{",
            f"  const ipm_real_t hs{j} = {f'IPM_W.hd[IPM_VMAP_S[k][{j}]]' if has_var else 'IPM_ONE'};",
            f"  const ipm_real_t dd{j} = {dd};",
            f"  IPM_W.d[k][{j}] = dd{j};",
        ]
        c = 0
        for g in gr:
            for e in range(len(rows[g][1])):
                w.append(
                    f"  IPM_W.wc[{_plus(f'IPM_SE_BEG[k][{j}]', c)}] = wg{g} * IPM_W.gax[{_plus('a', off[g] + e)}];"
                )
                c += 1
        for g in gr:
            others = f"hs{j}"
            for q in gr:
                if q != g:
                    others = f"({others} + (wg{q} * gx{q}))"
            w.append(f"  IPM_W.Weff[{g}] = (w{g} * {others}) / dd{j};")
        w.append("}")
    return w


def _gen_hessian(p: _GenPattern) -> list[str]:
    """``gen_h``: the rows' W c c' into IPM_W.H (ipm_stage_hessian)."""
    h = [_GS, _AT, *p.load()]
    for g, (_, slots, _) in enumerate(p.rows):
        for i in range(len(slots)):
            h += ["{", f"  const ipm_real_t ca = IPM_W.Weff[{g}] * {p.x(p.off[g] + i)};"]
            h += [f"  IPM_W.H[{slots[i]}][{slots[jj]}] += ca * {p.x(p.off[g] + jj)};" for jj in range(i, len(slots))]
            h.append("}")
    return h


def _gen_couple(p: _GenPattern) -> list[str]:
    """``gen_c``: two rows of one slack coupled in IPM_W.H (ipm_stage_hessian); only the coefficients read load."""
    rows, off = p.rows, p.off
    cp = []
    for j, (gr, _) in enumerate(p.groups):
        for pi in range(len(gr)):
            for qi in range(pi + 1, len(gr)):
                gi, gj = gr[pi], gr[qi]
                cp += [
                    "{",
                    f"  const ipm_real_t m = ((-IPM_W.wg[{_plus('gs', gi)}]) * IPM_W.wg[{_plus('gs', gj)}]) / "
                    f"IPM_W.d[k][{j}];",
                ]
                for xi, vx in enumerate(rows[gi][1]):
                    cp += ["  {", f"    const ipm_real_t cx = m * {p.x(off[gi] + xi)};"]
                    for yi, vy in enumerate(rows[gj][1]):
                        lo, hi = min(vx, vy), max(vx, vy)
                        cp += [
                            "    {",
                            f"      const ipm_real_t v = cx * {p.x(off[gj] + yi)};",
                            f"      IPM_W.H[{lo}][{hi}] += v;",
                        ]
                        cp += [f"      IPM_W.H[{lo}][{hi}] += v;"] if lo == hi else []
                        cp.append("    }")
                    cp.append("  }")
                cp.append("}")
    used = {e for ln in cp for e in range(p.n) if f"* {p.x(e)};" in ln}
    return ([_GS, _AT] + [ln for e, ln in enumerate(p.load()) if e in used] + cp) if cp else ["(void)k;"]


def _gen_products(p: _GenPattern) -> dict[str, list[str]]:
    """``gen_ax``: A z on the stage's rows (ipm_ineq_Ax); ``gen_atx``: A' g over them (ipm_ineq_ATx)."""
    ax, atx = [_GS, _AT], [_GS, _AT]
    for g, (present, slots, slack) in enumerate(p.rows):
        if not present:
            continue
        first = p.off[g]
        terms = [
            f"(IPM_W.gax[{_plus('a', first + e)}] * x[IPM_GEN_VAR[{_plus('a', first + e)}]])" for e in range(len(slots))
        ]
        terms += [f"(IPM_W.gex[{_plus('gs', g)}] * x[IPM_GEN_SVAR[{_plus('gs', g)}]])"] if slack else []
        sm = "REAL_0"
        for t in terms:
            sm = f"({sm} + {t})"
        ax.append(f"out[IPM_GEN_ROW[{_plus('gs', g)}]] = {sm[1:-1] if terms else sm};")
        atx += ["{", f"  const ipm_real_t gv = IPM_W.ar[IPM_GEN_ROW[{_plus('gs', g)}]];"]
        atx += [
            f"  IPM_W.h[IPM_GEN_VAR[{_plus('a', first + e)}]] += IPM_W.gax[{_plus('a', first + e)}] * gv;"
            for e in range(len(slots))
        ]
        atx += [f"  IPM_W.h[IPM_GEN_SVAR[{_plus('gs', g)}]] += IPM_W.gex[{_plus('gs', g)}] * gv;"] if slack else []
        atx.append("}")
    if not any(sl for _, sl, _ in p.rows):  # no (x, u) entry: a is not read
        ax, atx = [ln for ln in ax if ln != _AT], [ln for ln in atx if ln != _AT]
    return {"gen_ax": ax, "gen_atx": atx}


def _gen_slacks(p: _GenPattern) -> dict[str, list[str]]:
    """``gen_rhs``: the slacks eliminated from the right-hand side (ipm_stage_rhs); ``gen_dz``: their step from the
    stage's (x, u) step (ipm_forward_stage)."""
    rows = p.rows
    rhs, dz = [], []
    for j, (gr, has_var) in enumerate(p.groups):
        ent = [(rows[g][1][e], c) for c, (g, e) in enumerate((g, e) for g in gr for e in range(len(rows[g][1])))]
        rhs.append(f"hs[{j}] = {f'IPM_W.h[IPM_VMAP_S[k][{j}]]' if has_var else 'REAL_0'};")
        if ent:
            rhs += ["{", f"  const ipm_real_t f = hs[{j}] / IPM_W.d[k][{j}];"]
            rhs += [f"  ht[{v}] -= IPM_W.wc[{_plus(f'IPM_SE_BEG[k][{j}]', c)}] * f;" for v, c in ent] + ["}"]
        if has_var:
            acc = "REAL_0"
            for v, c in ent:
                acc = f"({acc} + (IPM_W.wc[{_plus(f'IPM_SE_BEG[k][{j}]', c)}] * dv[{v}]))"
            dz.append(f"IPM_W.dz[IPM_VMAP_S[k][{j}]] = (-({acc} + hs[{j}])) / IPM_W.d[k][{j}];")
    if not dz:
        dz = ["(void)k;", "(void)dv;", "(void)hs;"]
    return {"gen_rhs": rhs, "gen_dz": dz}


def sr_kernels(na: int) -> dict[str, str]:
    """Bodies of the soft rows' per-row kernels for ``na`` (x, u) entries a row (``IPM_NA``), written out inside the
    core's loop over the lanes (row j + l on lane l; a_p = IPM_W.sr.a[p][j + l]): ``av``: out[l] = a'v;
    ``check``: ipm_sr_check's sums of a row into its lanes of acc ([4 + p] -= a_p l1, the upper triangle of
    weff a a' row-major from [4 + na], [4 + na + nt + p] += a_p f, [4 + 2 na + nt + p] += a_p fb); ``fwd``: the
    predictor's [3 + p] += a_p f. Each acc entry adds in the same order as a loop would: results are unchanged."""
    nt = na * (na + 1) // 2
    a = [f"a{p}" for p in range(na)]
    load = [f"const ipm_real_t a{p} = IPM_W.sr.a[{p}][j + l];" for p in range(na)]
    av = [*load, f"out[l] = {_c_sum([f'(a{p} * v[{p}])' for p in range(na)])};"]
    check = load + [f"const ipm_real_t w{p} = weff[l] * a{p};" for p in range(na)]
    check += [f"acc[{4 + p}][l] -= {a[p]} * l1v[l];" for p in range(na)]
    q = 0
    for p_ in range(na):
        for b in range(p_, na):
            check.append(f"acc[{4 + na + q}][l] += w{p_} * {a[b]};")
            q += 1
    check += [f"acc[{4 + na + nt + p}][l] += {a[p]} * f[l];" for p in range(na)]
    check += [f"acc[{4 + 2 * na + nt + p}][l] += {a[p]} * fb[l];" for p in range(na)]
    fwd = load + [f"acc[{3 + p}][l] += {a[p]} * f[l];" for p in range(na)]
    return {"sr_av": "\n    ".join(av), "sr_check": "\n    ".join(check), "sr_fwd": "\n    ".join(fwd)}
