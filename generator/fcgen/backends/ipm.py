"""A structure-exploiting primal-dual interior-point QP backend (Python reference of ``templates/backends/ipm.c.j2``).

The QP is the layout's ``min 0.5 z'Pz + q'z  s.t.  l <= Az <= u`` (P diagonal). Rows fall into the classes of
``qp.stage_view``: equality rows (init, dynamics, stage equalities) keep their multipliers ``nu``; every finite side j
of an inequality row r is ``sign_j a_r'z - b_j = t_j >= 0`` with multiplier ``lam_j >= 0`` (``b = l`` for a lower,
``-u`` for an upper side). Mehrotra's predictor-corrector drives ``t lam`` to zero. The Newton system, after the sides
are eliminated (weights ``W_r = sum lam/t`` on ``A' W A``), is the KKT system of an equality-constrained multistage
QP: box rows add to the diagonal, the slacks (one per general row at most, a diagonal block) are eliminated by a
Schur complement into their stage, and a Riccati recursion over ``(x_k, u_k)`` solves what remains (stage equalities
by a small Schur complement of their own). Inputs without curvature (hyperplane variables) get a small
regularization ``reg`` in the Newton matrix only: residuals are exact, so the fixed point is the QP's solution.

Result in the interface's terms: ``z`` the step, ``y`` the row multipliers in OSQP's sign convention
(``y_r = nu_r`` on equality rows, ``lam_upper - lam_lower`` on inequality rows; y > 0 at an active upper bound).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..qp import QpLayout, SoftRows, StageView, split_soft_rows, stage_view
from . import (QP_MAX_ITER, QP_NONFINITE, QP_NUMERICAL, QP_PRIMAL_INFEASIBLE, QP_SOLVED, QP_STATUSES,
               BackendFiles, QpResult)

if TYPE_CHECKING:  # pragma: no cover
    from ..dsl import QpOptions

LABEL = "fcgen's Riccati interior-point method (Mehrotra predictor-corrector, static memory)"
"""How the generated header and README name this backend."""

VERIFY_SOLUTION_TOL = 1e-7
"""fcgen verify's tolerance of the QP solution, iterate and controls for this backend. C and Python agree to
rounding, not bit for bit (numpy's BLAS products vs the C's loops); the lockstep restarts the reference from the C's
iterate every sample, so the QP data agree bit for bit and the solutions to rounding, amplified by the iterations
(seed 0, 200 samples): truck_lifted_ellipse_ipm z 8.2e-14, y 5.6e-14, u0 6.7e-14; car_lifted_hyperplane_ipm z 3.0e-10;
car_conventional_hyperplane_ipm_safe z 1.3e-10; truck_conventional_hyperplane_ipm_safe z 1.8e-8, y 1.4e-8 (a warm QP
of 28 iterations ending at the real-time tolerance: the returned point is far more sensitive to rounding than the
QP's solution). 1e-7 keeps a margin over these and stays 1e3 below the IPM's own stopping tolerance (1e-4)."""

VERIFY_FREE_TOL = 1e-6
"""... and for the QP primal of variables without cost curvature (the paper's free hyperplanes): in those directions
the Newton matrix has only the proximal weight ``prox`` (1e-6), so on the same QP data the C's and numpy's rounding
part there up to ~1e6 times more than elsewhere: truck_direct_elimination_hyperplane_ipm, seed 0, 200 samples,
lockstep: 3.1e-8 on the planes, 1.7e-10 on the states and controls."""

RAW_STATUS = ("solved", "max_iter", "primal_infeasible", "nonfinite", "numerical")
"""The backend's own status values 1..5, in this order."""
RAW_TO_QP = (QP_SOLVED, QP_MAX_ITER, QP_PRIMAL_INFEASIBLE, QP_NONFINITE, QP_NUMERICAL)


@dataclass(frozen=True)
class IpmSettings:
    """Tolerances of the interior-point method (scaled QP units)."""

    tol: float = 1e-4        # stationarity, primal residuals and every complementarity product t lam
    tau: float = 0.995       # fraction to the boundary
    reg: float = 1e-9        # regularization of the input block of the Newton matrix
    prox: float = 1e-6       # proximal weight on inputs without cost (hyperplanes: not unique, else they drift)
    t_min: float = 0.1       # floor of an initial side slack
    lam_min: float = 0.1     # floor of an initial side multiplier
    lam_center: float = 0.5  # then each initial lam at least lam_center mean(t lam) / t: no product far below the mean
    lam_max: float = 1e10    # a multiplier beyond it: primal infeasible
    alpha_min: float = 1e-12 # a step below it: numerical trouble
    warm: bool = True        # initial multipliers from the shifted duals (else lam = lam_min, nu = 0)
    scaled_start: bool = False  # a soft row's slack bound starts at t = max(-b, t_min / max(1, lam)), not max(-b, t_min)


def _fwd(L: np.ndarray, B: np.ndarray) -> np.ndarray:
    """Solve L X = B, L lower triangular (row by row, as the C does)."""
    X = np.array(B, dtype=float, copy=True)
    for i in range(L.shape[0]):
        X[i] = (X[i] - L[i, :i] @ X[:i]) / L[i, i]
    return X


def _bwd(L: np.ndarray, B: np.ndarray) -> np.ndarray:
    """Solve L' X = B, L lower triangular."""
    X = np.array(B, dtype=float, copy=True)
    for i in range(L.shape[0] - 1, -1, -1):
        X[i] = (X[i] - L[i + 1:, i] @ X[i + 1:]) / L[i, i]
    return X


class _Tables:
    """Gather maps of the stage view, padded to fixed sizes (dummy index = one past the end)."""

    def __init__(self, lay: QpLayout, sv: StageView):
        N, nx, NU, NS, NG, NE = sv.N, sv.nx, sv.NU, sv.NS, sv.NG, sv.NE
        nz_dummy, nxu = lay.nnz_A, nx + NU
        self.vmap_xu = np.where(sv.vmap[:, :nxu] >= 0, sv.vmap[:, :nxu], lay.n)
        self.vmap_s = np.where(sv.vmap[:, nxu:] >= 0, sv.vmap[:, nxu:], lay.n)
        self.gen_row = np.where(sv.gen_rows >= 0, sv.gen_rows, lay.m)
        self.gen_xu = np.full((N + 1, NG, nxu), nz_dummy, dtype=np.int64)
        self.gen_e = np.full((N + 1, NG), nz_dummy, dtype=np.int64)
        self.gen_s = np.full((N + 1, NG), NS, dtype=np.int64)
        for k in range(N + 1):
            for g in range(NG):
                slot = k * NG + g
                for v, a in zip(sv.gen_v[sv.gen_ptr[slot]:sv.gen_ptr[slot + 1]],
                                sv.gen_a[sv.gen_ptr[slot]:sv.gen_ptr[slot + 1]]):
                    if v < nxu:
                        self.gen_xu[k, g, v] = a
                    else:
                        self.gen_e[k, g], self.gen_s[k, g] = a, v - nxu
        # inequality-row entries in the C's order (general slots: inputs/states, then the slack; then box rows)
        gptr, gv, ga, gvar, svar = [0], [], [], [], []
        ent_row, ent_var, ent_a = [], [], []
        for k in range(N + 1):
            for g in range(NG):
                slot = k * NG + g
                sl = slice(sv.gen_ptr[slot], sv.gen_ptr[slot + 1])
                row, s_var = sv.gen_rows[k, g], -1
                for v, a in zip(sv.gen_v[sl], sv.gen_a[sl]):
                    if v < nxu:
                        gv.append(int(v)); ga.append(int(a)); gvar.append(int(sv.vmap[k, v]))
                        ent_row.append(row); ent_var.append(int(sv.vmap[k, v])); ent_a.append(int(a))
                    else:
                        s_var, s_a = int(sv.vmap[k, v]), int(a)
                if s_var >= 0:
                    ent_row.append(row); ent_var.append(s_var); ent_a.append(s_a)
                gptr.append(len(gv))
                svar.append(s_var)
        ent_row += sv.box_rows.tolist(); ent_var += sv.box_var.tolist(); ent_a += sv.box_a.tolist()
        self.gen_xu_ptr, self.gen_xu_v, self.gen_xu_a, self.gen_var = gptr, gv, ga, gvar
        if any(gv[i] >= gv[i + 1] for p0, p1 in zip(gptr[:-1], gptr[1:]) for i in range(p0, p1 - 1)):
            raise AssertionError("stage view: a general row's stage slots must ascend")
        self.gen_svar = svar
        self.ent_row, self.ent_var, self.ent_a = (np.array(x, dtype=np.int64) for x in (ent_row, ent_var, ent_a))
        groups = [[[g for g in range(NG) if self.gen_s[k, g] == j] for j in range(NS)] for k in range(N + 1)]
        RS = max([1] + [len(gr) for gk in groups for gr in gk])
        self.slack_rows = np.full((N + 1, NS, RS), NG, dtype=np.int64)  # general slots of slack j; NG: none
        for k in range(N + 1):
            for j in range(NS):
                self.slack_rows[k, j, :len(groups[k][j])] = groups[k][j]
        # the same compactly (the C's loops): slack j of stage k holds the general slots sg_g[sg_ptr[k NS + j]:...]
        self.sg_g = np.array([g for gk in groups for gr in gk for g in gr], dtype=np.int64)
        self.sg_ptr = np.r_[0, np.cumsum([len(gr) for gk in groups for gr in gk])].astype(np.int64)
        # inequality rows (ascending): their sides are in_ptr[i]:in_ptr[i + 1] (the sides are sorted by row)
        self.in_rows, counts = np.unique(sv.side_row, return_counts=True)
        self.in_ptr = np.r_[0, np.cumsum(counts)].astype(np.int64)
        pos = {int(r): i for i, r in enumerate(self.in_rows)}
        self.gen_in = np.array([pos.get(int(r), -1) for r in sv.gen_rows.ravel()], dtype=np.int64)
        self.box_in = np.array([pos[int(r)] for r in sv.box_rows], dtype=np.int64)
        self.dyn_ab = np.full((N, nx, nxu), nz_dummy, dtype=np.int64)
        for k in range(N):
            sl = slice(sv.dyn_ptr[k], sv.dyn_ptr[k + 1])
            self.dyn_ab[k, sv.dyn_i[sl], sv.dyn_j[sl]] = sv.dyn_a[sl]
        self.eq_d = np.full((N + 1, NE, NU), nz_dummy, dtype=np.int64)
        self.eq_row = np.where(sv.eq_rows >= 0, sv.eq_rows, lay.m)
        for k in range(N + 1):
            for e in range(NE):
                slot = k * NE + e
                sl = slice(sv.eq_ptr[slot], sv.eq_ptr[slot + 1])
                self.eq_d[k, e, sv.eq_j[sl]] = sv.eq_a[sl]
        self.eq_pad = (sv.eq_rows < 0).astype(float)
        # inputs without cost (hyperplane variables): 1 where the proximal weight applies
        self.free_inputs = np.zeros(lay.n)
        for k in range(N + 1):
            v = sv.vmap[k, nx:nx + sv.nu[k]]
            self.free_inputs[v[lay.P_diag[v] == 0]] = 1.0


def ipm_settings(opts: "QpOptions") -> IpmSettings:
    """The IPM's settings of a problem's QpOptions."""
    return IpmSettings(tol=opts.ipm_tol, scaled_start=opts.ipm_scaled_start)


class Backend:
    """Riccati-based Mehrotra predictor-corrector IPM on the layout's QP (see the module docstring)."""

    name = "ipm"

    def __init__(self, layout: QpLayout, opts: "QpOptions", settings: IpmSettings | None = None):
        self.lay = layout
        self.sv = stage_view(layout)
        self.tab = _Tables(layout, self.sv)
        self.set = settings or ipm_settings(opts)
        # the sides of the soft rows' slack bounds (the C's IPM_SR t2): where scaled_start applies
        self.slack_bound_side = np.isin(self.sv.side_row, split_soft_rows(layout, self.sv)[1].brow)
        self.trace: list | None = None  # set to [] to record (|r_d|, |r_eq|, |r_p|, max t lam, mu) per iteration
        self.reset()

    _DERIVED = ("AT", "Cxu", "Ce", "Einv", "F", "G", "einit", "D", "box_a2", "c", "d", "Lr", "W1", "Pk", "UD", "LM")

    def reset(self) -> None:
        """Back to the state of a fresh backend: no sample's matrices (the IPM keeps nothing between solves)."""
        lay = self.lay
        self.Pd = np.zeros(lay.n)
        self.Ax = np.zeros(lay.nnz_A + 1)
        self.A = lay.A_pattern(self.Ax[:-1].copy())
        for key in self._DERIVED:
            self.__dict__.pop(key, None)

    # -- prepare phase: the sample's matrices in stage blocks ----------------------------------------
    def set_matrices(self, P_x, A_x, q) -> None:
        sv, tab = self.sv, self.tab
        self.Pd = np.array(P_x, dtype=float) + self.set.prox * self.tab.free_inputs
        self.Ax = np.r_[np.asarray(A_x, dtype=float), 0.0]
        self.A = self.lay.A_pattern(self.Ax[:-1].copy())
        self.AT = self.A.T.tocsr()
        ax = self.Ax
        self.Cxu = ax[tab.gen_xu]                       # (N+1, NG, nx+NU)
        self.Ce = ax[tab.gen_e]                         # (N+1, NG) slack coefficient
        E = ax[sv.dyn_next]                             # (N, nx)
        self.Einv = 1.0 / E
        AB = -ax[tab.dyn_ab] * self.Einv[:, :, None]    # x_{k+1} = F x + G u + c
        self.F = AB[:, :, :sv.nx]
        self.G = AB[:, :, sv.nx:]
        self.einit = ax[sv.init_a]
        self.D = ax[tab.eq_d]                           # (N+1, NE, NU)
        self.box_a2 = ax[sv.box_a] ** 2

    # -- the Newton matrix: side weights, slack elimination, Riccati factorization ---------------------
    def _factor(self, W: np.ndarray) -> bool:
        sv, tab, st = self.sv, self.tab, self.set
        N, nx = sv.N, sv.nx
        hd = np.r_[self.Pd, 1.0]
        np.add.at(hd, sv.box_var, W[sv.box_rows] * self.box_a2)
        # general rows; a slack's rows (its group) are eliminated with it, without cancellation: row i of the
        # group weighs W_i (hd_s + sum_{j != i} W_j e_j^2) / d_s, two rows couple by -W_i e_i W_j e_j / d_s,
        # d_s = hd_s + sum_i W_i e_i^2 (hd_s: the slack's own curvature, cost and its bound row)
        pad = np.zeros((N + 1, 1))
        Wg = np.concatenate([W[tab.gen_row], pad], axis=1)       # (N+1, NG+1); dummy slot: W = 0
        w = Wg * np.concatenate([self.Ce, pad], axis=1)          # W e
        we2 = w * np.concatenate([self.Ce, pad], axis=1)
        flat = tab.slack_rows.reshape(N + 1, -1)
        RS = tab.slack_rows.shape[2]
        g_we2 = np.take_along_axis(we2, flat, axis=1).reshape(tab.slack_rows.shape)
        g_w = np.take_along_axis(w, flat, axis=1).reshape(tab.slack_rows.shape)
        g_W = np.take_along_axis(Wg, flat, axis=1).reshape(tab.slack_rows.shape)
        hs_ = hd[tab.vmap_s]
        d = hs_.copy()
        for i in range(RS):
            d = d + g_we2[:, :, i]
        Weff = Wg.copy()
        for i in range(RS):
            others = hs_.copy()
            for j in range(RS):
                if j != i:
                    others = others + g_we2[:, :, j]
            np.put_along_axis(Weff, tab.slack_rows[:, :, i], g_W[:, :, i] * others / d, axis=1)
        Cp = np.concatenate([self.Cxu, np.zeros((N + 1, 1, nx + sv.NU))], axis=1)
        H = np.einsum("kgi,kgj->kij", Cp * Weff[:, :, None], Cp)
        idx = np.arange(nx + sv.NU)
        H[:, idx, idx] += hd[tab.vmap_xu]
        ga = [np.take_along_axis(Cp, tab.slack_rows[:, :, i, None], axis=1) for i in range(RS)]  # (N+1, NS, nxu)
        c = np.zeros((N + 1, sv.NS, nx + sv.NU))
        for i in range(RS):
            c = c + g_w[:, :, i, None] * ga[i]
            for j in range(i + 1, RS):
                M = -g_w[:, :, i] * g_w[:, :, j] / d
                Hij = np.einsum("ksa,ksb->kab", M[:, :, None] * ga[i], ga[j])
                H = H + Hij + Hij.transpose(0, 2, 1)
        self.c, self.d = c, d
        self.Lr, self.W1, self.Pk = [None] * (N + 1), [None] * (N + 1), [None] * (N + 1)
        self.UD, self.LM = [None] * (N + 1), [None] * (N + 1)
        P = None
        for k in range(N, -1, -1):
            Q, S, R = H[k, :nx, :nx], H[k, nx:, :nx], H[k, nx:, nx:]
            if k < N:
                PF = P @ self.F[k]
                PG = P @ self.G[k]
                Q = Q + self.F[k].T @ PF
                S = S + self.G[k].T @ PF
                R = R + self.G[k].T @ PG
            R = R + st.reg * np.eye(sv.NU)
            try:
                L = np.linalg.cholesky(R)
            except np.linalg.LinAlgError:
                return False
            W1 = _fwd(L, S)
            Pk = Q - W1.T @ W1
            if sv.NE:
                UD = _fwd(L, self.D[k].T)
                M = UD.T @ UD + np.diag(tab.eq_pad[k])
                try:
                    LM = np.linalg.cholesky(M)
                except np.linalg.LinAlgError:
                    return False
                W2 = _fwd(LM, UD.T @ W1)
                Pk = Pk + W2.T @ W2
                self.UD[k], self.LM[k] = UD, LM
            P = 0.5 * (Pk + Pk.T)
            if not np.all(np.isfinite(P)):
                return False
            self.Lr[k], self.W1[k], self.Pk[k] = L, W1, P
        return True

    def _newton(self, h: np.ndarray, r_eq_rows: np.ndarray):
        """Solve the factored Newton system for the right-hand side h (n) and equality residuals (m, at eq rows)."""
        sv, tab, lay = self.sv, self.tab, self.lay
        N, nx = sv.N, sv.nx
        he = np.r_[h, 0.0]
        hs = he[tab.vmap_s]
        ht = he[tab.vmap_xu] - np.einsum("ksi,ks->ki", self.c, hs / self.d)
        rr = np.r_[r_eq_rows, 0.0]
        cdyn = -rr[sv.dyn_rows] * self.Einv                 # (N, nx)
        deq = -rr[tab.eq_row]                               # (N+1, NE)
        lr, kk, p = [None] * (N + 1), [None] * (N + 1), [None] * (N + 1)
        pn = None
        for k in range(N, -1, -1):
            qb, rb = ht[k, :nx], ht[k, nx:]
            if k < N:
                pc = self.Pk[k + 1] @ cdyn[k] + pn
                qb = qb + self.F[k].T @ pc
                rb = rb + self.G[k].T @ pc
            lr[k] = _fwd(self.Lr[k], rb)
            t = lr[k]
            if sv.NE:
                nh = self.UD[k].T @ lr[k] + deq[k]
                nh = _bwd(self.LM[k], _fwd(self.LM[k], nh))
                t = lr[k] - self.UD[k] @ nh
            kk[k] = -_bwd(self.Lr[k], t)
            p[k] = qb - self.W1[k].T @ t            # = qb + S_bar' kk
            pn = p[k]
        dz = np.zeros(lay.n + 1)
        dnu = np.zeros(lay.m + 1)
        dx = -rr[lay.init_rows] / self.einit
        for k in range(N + 1):
            w = self.W1[k] @ dx                       # du = K dx + kk, K = -L^-T (W1 - UD M^-1 UD' W1)
            if sv.NE:
                w = w - self.UD[k] @ _bwd(self.LM[k], _fwd(self.LM[k], self.UD[k].T @ w))
            du = kk[k] - _bwd(self.Lr[k], w)
            lam = self.Pk[k] @ dx + p[k]
            if k == 0:
                dnu[lay.init_rows] = -lam / self.einit
            else:
                dnu[sv.dyn_rows[k - 1]] = -lam * self.Einv[k - 1]
            if sv.NE:
                nh = self.UD[k].T @ (self.W1[k] @ dx + lr[k]) + deq[k]
                nh = _bwd(self.LM[k], _fwd(self.LM[k], nh))
                dnu[tab.eq_row[k]] = -nh
            dv = np.r_[dx, du]
            ds = -(self.c[k] @ dv + hs[k]) / self.d[k]
            dz[tab.vmap_xu[k]] = dv
            dz[tab.vmap_s[k]] = ds
            if k < N:
                dx = self.F[k] @ dx + self.G[k] @ du + cdyn[k]
        return dz[:lay.n], dnu[:lay.m]

    # -- feedback phase ------------------------------------------------------------------------------
    def solve(self, q, l, u, y_warm, max_iter: int) -> QpResult:
        sv, lay, st, tab = self.sv, self.lay, self.set, self.tab
        n, m = lay.n, lay.m
        q = np.asarray(q, dtype=float)
        rows, sign = sv.side_row, sv.side_sign.astype(float)
        b = np.where(sign > 0, l[rows], -u[rows])
        eq = sv.eq_all
        b_eq = l[eq]
        ns = len(rows)
        yw = np.zeros(m) if y_warm is None or not st.warm else np.asarray(y_warm, dtype=float)
        z = np.zeros(n)
        lam = np.maximum(-sign * yw[rows], st.lam_min)
        t = np.maximum(-b, np.where(self.slack_bound_side, st.t_min / np.maximum(1.0, lam), st.t_min)
                       if st.scaled_start else st.t_min)
        lam = np.maximum(lam, (st.lam_center * (float(t @ lam) / ns)) / t)   # a centred start (see IpmSettings)
        nu = yw[eq].copy()
        raw = 2
        it = 0
        while True:
            y = np.zeros(m)
            y[eq] = nu
            np.add.at(y, rows, -sign * lam)
            Az = self.A @ z
            r_d = self.Pd * z + q + self.AT @ y
            r_eq = np.zeros(m)
            r_eq[eq] = Az[eq] - b_eq
            r_p = sign * Az[rows] - b - t
            mu = float(t @ lam) / ns
            if not (np.all(np.isfinite(r_d)) and np.isfinite(mu)):
                return QpResult(RAW_TO_QP[3], 4, it, None, None)
            if self.trace is not None:
                self.trace.append((float(np.max(np.abs(r_d))), float(np.max(np.abs(r_eq))), float(np.max(np.abs(r_p))),
                                   float(np.max(t * lam)), mu))
            if max(np.max(np.abs(r_d)), np.max(np.abs(r_eq)), np.max(np.abs(r_p)), np.max(t * lam)) <= st.tol:
                raw = 1
                break
            if np.max(lam) > st.lam_max:
                raw = 3
                break
            if it >= max_iter:
                break
            inv_t = 1.0 / t
            W = np.zeros(m + 1)
            np.add.at(W, rows, lam * inv_t)
            if not self._factor(W):
                raw = 5
                break

            def direction(rc):
                g = np.zeros(m)
                np.add.at(g, rows, sign * (rc + lam * r_p) * inv_t)
                h = r_d.copy()                          # r_d + A_in' g, entry by entry as the C
                np.add.at(h, tab.ent_var, self.Ax[tab.ent_a] * g[tab.ent_row])
                dz, dnu = self._newton(h, r_eq)
                adz = np.zeros(m)
                np.add.at(adz, tab.ent_row, self.Ax[tab.ent_a] * dz[tab.ent_var])
                dt = sign * adz[rows] + r_p
                dlam = -(rc + lam * dt) * inv_t
                return dz, dnu, dt, dlam

            def max_step(dt, dlam):
                a = 1.0
                neg = dt < 0
                if np.any(neg):
                    a = min(a, float(np.min(-t[neg] / dt[neg])))
                neg = dlam < 0
                if np.any(neg):
                    a = min(a, float(np.min(-lam[neg] / dlam[neg])))
                return a

            _, _, dt_a, dl_a = direction(t * lam)
            a_aff = max_step(dt_a, dl_a)
            mu_aff = float((t + a_aff * dt_a) @ (lam + a_aff * dl_a)) / ns
            ratio = mu_aff / mu
            sigma = ratio * ratio * ratio
            dz, dnu, dt, dlam = direction(t * lam + dt_a * dl_a - sigma * mu)
            alpha = min(1.0, st.tau * max_step(dt, dlam))
            if not np.all(np.isfinite(dz)):
                return QpResult(RAW_TO_QP[3], 4, it, None, None)
            if alpha < st.alpha_min:
                raw = 5
                break
            z = z + alpha * dz
            nu = nu + alpha * dnu[eq]
            t = t + alpha * dt
            lam = lam + alpha * dlam
            it += 1
        y = np.zeros(m)
        y[eq] = nu
        np.add.at(y, rows, -sign * lam)
        return QpResult(RAW_TO_QP[raw - 1], raw, it, z, y)


# -- generated code ----------------------------------------------------------------------------------------------

def _members(sv: StageView, lay: QpLayout) -> list[dict]:
    """The real arrays of the C workspace struct (name, dims, doc), in declaration order."""
    N, NX, NU, NS, NG = sv.N, sv.nx, sv.NU, sv.NS, sv.NG
    NE1, NXU, n, m, ns = max(sv.NE, 1), sv.nx + sv.NU, lay.n, lay.m, len(sv.side_row)
    NFGB = int(fg_bands(sv)[2][-1])
    spec = [
        ("Einv", (N, NX), "1 / coefficient of x_{k+1}[i] in dynamics row i"),
        ("fgb", (N, NFGB), "[F G] of stage k (x_{k+1} = F x + G u + c), column j's band at IPM_FG_OFF[j] (fg_bands)"),
        ("einit", (NX,), "coefficient of x_0[i] in init row i"),
        ("z", (n,), "iterate"), ("r_d", (n,), "stationarity residual"),
        ("h", (n,), "Newton right-hand side"), ("hd", (n,), "the Newton matrix's diagonal: P + box weights"),
        ("dz", (n,), "Newton step"),
        ("aff", (4,), "the soft rows' sums of t lam, t dlam + lam dt, dt dlam (predictor); their pending step"),
        ("y", (m,), "row multipliers (result; the equality rows' multipliers all along)"),
        ("wc", (len(_slack_entries(_Tables(lay, sv), N, NS, NG)[1]),), "W e a per entry of IPM_SE (slack rows)"),
        ("gax", (int(np.count_nonzero(sv.gen_v < NXU)),), "a per (x, u) entry of the general rows (prepare)"),
        ("gex", ((N + 1) * NG,), "e (slack coefficient) per general slot (prepare; 0: no slack)"),
        ("bax", (len(sv.box_rows),), "coefficient per box row (prepare)"),
        ("ar", (m,), "per inequality row: its right-hand side g, then a'dz"),
        ("it", (ns,), "1 / t per inequality side"), ("bs", (ns,), "b per inequality side"), ("wg", ((N + 1) * NG,), "W e per general slot (0: no slack)"),
        ("wr", (m,), "A z, then residuals on equality rows and weights lam / t on the others"),
        ("gd", (m,), "the multiplier step on the equality rows"),
        *[(f, (ns,), "per inequality side") for f in ("t", "lam", "r_p", "dt", "dlam")],
        ("L", (N + 1, NU, NU), "Cholesky factor of R_bar"), ("W1", (N + 1, NU, NX), "L^-1 S_bar"),
("P", (N + 1, NX, NX), "cost-to-go Hessian (on and below the diagonal)"),
        ("UD", (N + 1, NU, NE1), "L^-1 D'"), ("LM", (N + 1, NE1, NE1), "Cholesky factor of UD' UD"),
        ("d", (N + 1, NS), "slack pivots"),
        ("lr", (N + 1, NU), "L^-1 r_bar"), ("kk", (N + 1, NU), "feedforward"), ("p", (N + 1, NX), "cost-to-go gradient"),
        ("H", (NXU, NXU), "stage Newton block (scratch)"), ("R", (NU, NU), "scratch"),
        ("Weff", (NG,), "scratch"), ("D", (NE1, NU), "scratch"), ("M", (NE1, NE1), "scratch"),
        ("W2", (NE1, NX), "scratch"),
    ]
    if sv.NE == 0:  # the stage-equality arrays exist only with stage equalities (the template's code too)
        spec = [m for m in spec if m[0] not in ("UD", "LM", "D", "M", "W2")]
        if sv.NU <= U_KERNEL_MAX:  # IPM_U_FUSED: L^-1 r_bar lives in the backward sweep's registers
            spec = [m for m in spec if m[0] != "lr"]
    return [{"name": nm, "dims": [max(1, int(d)) for d in dims], "doc": doc or nm} for nm, dims, doc in spec]


#: the real arrays of the C's soft-row struct besides its NA coefficients (``ipm_sr_t`` in the template)
SR_FIELDS = ("e", "bb", "b1", "b2", "t1", "l1", "t2", "l2", "it1", "it2", "rp1", "rp2", "id", "c",
             "dt1", "dl1", "dt2", "dl2", "zs", "dzs", "rds", "hs", "ps", "qs", "w")


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
        out = np.full((int(ptr[-1]),) + v.shape[1:], fill, dtype=np.int64)
        out[pos] = v
        return out
    return ptr, pad


def _workspace_bytes(members: list[dict], sr: SoftRows, real_size: int) -> int:
    """sizeof the C workspace struct on an LP64 target (two pointers, the real arrays, the soft rows' arrays and their
    runs' sums)."""
    size = 16 + sum(int(np.prod(m["dims"])) * real_size for m in members)
    size += max(1, int(padded_runs(sr)[0][-1])) * (sr.NA + len(SR_FIELDS)) * real_size
    size += max(1, len(sr.run_ptr) - 1) * (sr.NA * (sr.NA + 1) // 2 + 3 * sr.NA) * real_size
    return -(-size // 8) * 8


def _slack_entries(tab: _Tables, N: int, NS: int, NG: int) -> tuple[np.ndarray, np.ndarray]:
    """The (x, u) entries of every slack's rows, slack by slack (stage k's slack s: ``ptr[k NS + s]`` on), each as its
    general-entry index: the slack elimination's loops in the order of the slots' loops, one level flatter."""
    ptr, ent = [0], []
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
    a0, a1, off, _ = fg_bands(sv)
    nx, nfgc = sv.nx, len(a0)
    nz = np.zeros((nx, nfgc), dtype=bool)  # the pattern over all stages (a band may hold a zero: skip it)
    nz[sv.dyn_i, sv.dyn_j] = True

    def el(b: int, j: int) -> str:
        return f"fg[{int(off[j] + b - a0[j])}]"

    # H[i][j] = FG_s' (P FG_d) with d the denser of columns i, j (a tie: j) and s the other: m_a_d = (P FG_d)[a] for
    # the rows a of the sparser columns s paired with d (the fewest products for [F G]'s pattern)
    cnt = nz.sum(axis=0)
    pairs = {d: [] for d in range(nfgc)}
    for i in range(nfgc):
        for j in range(i, nfgc):
            pairs[j if cnt[j] >= cnt[i] else i].append((i, j))
    ctg = []
    for d in range(nfgc):  # column by column: its m's, then the entries they serve (the m's in registers)
        other = {(i, j): (i if j == d else j) for i, j in pairs[d]}
        need = sorted({a for s in other.values() for a in np.flatnonzero(nz[:, s])})
        for a in need:
            terms = [f"({_lower('P', a, b)} * {el(b, d)})" for b in range(nx) if nz[b, d]]
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
    triangle read)."""
    pxs = [_c_sum([f"({_lower('P', i, j)} * x[{j}])" for j in range(nx)]) for i in range(nx)]  # (P x)[i]
    mv = [f"y[{i}] = {pxs[i]};" for i in range(nx)]
    wx = [f"y[{i}] = {_c_sum([f'(W[{i}][{j}] * x[{j}])' for j in range(nx)])};" for i in range(nu)]
    q_wtx = [f"y[{i}] = q[{i}] - {_c_sum([f'(W[{a}][{i}] * x[{a}])' for a in range(nu)])};" for i in range(nx)]
    pk = [f"Pk[{i}][{j}] = H[{j}][{i}] - {_c_sum([f'(W[{a}][{i}] * W[{a}][{j}])' for a in range(nu)])};"
          for i in range(nx) for j in range(i + 1)]
    mv_add = [ln for i in range(nx)
              for ln in (f"const ipm_real_t y{i} = {pxs[i]};", f"y[{i}] = y{i};", f"z[{i}] = y{i} + a[{i}];")]
    return {k: "\n  ".join(v) for k, v in (("mv", mv), ("mv_add", mv_add), ("wx", wx), ("q_wtx", q_wtx), ("pk", pk))}


#: the largest NU for which R's factor and solves are written out for all inputs at once (``u_kernels``)
U_KERNEL_MAX = 4


def u_kernels(nu: int, nx: int) -> dict[str, str]:
    """Bodies of the Cholesky factor of R (NU x NU, stride NU) and of the solves with it, written out for all NU
    inputs at once (``IPM_U_DENSE``, NU <= U_KERNEL_MAX): ``u_chol`` (0, or 1 if a pivot is not positive), ``u_fwd``:
    X := L^-1 X over m columns of stride ldx, ``u_bwd_sub``: out := base - L^-T x (-L^-T x without base, the
    solve in registers, x unchanged). The operations and their order per entry are
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
    fwd = [f"const ipm_real_t d{i} = IPM_ONE / {el('Lo', i, i)};" for i in range(nu)] + ["int c;",
           "for (c = 0; c < m; ++c) {"]
    for i in range(nu):
        for j in range(i):
            fwd.append(f"  {xr(i)} -= {el('Lo', i, j)} * {xr(j)};")
        fwd.append(f"  {xr(i)} *= d{i};")
    fwd.append("}")
    bwd = _u_back(nu, lambda i: f"x[{i}]", "r")
    bwd += ["if (base != NULL) {"] + [f"  out[{i}] = base[{i}] - r{i};" for i in range(nu)] + ["} else {"]
    bwd += [f"  out[{i}] = -r{i};" for i in range(nu)] + ["}"]
    return {"u_chol": "\n  ".join(chol), "u_fwd": "\n  ".join(fwd), "u_bwd_sub": "\n  ".join(bwd),
            **u_fused_kernels(nu, nx)}


def _u_back(nu: int, x, r: str) -> list[str]:
    """Statements r_i = (L^-T x)_i, i = NU-1 .. 0 (Lo row-major, stride NU), x_i the C expression ``x(i)``."""
    out = []
    for i in reversed(range(nu)):
        terms = [f"(Lo[{j * nu + i}] * {r}{j})" for j in range(i + 1, nu)]
        out.append(f"const ipm_real_t {r}{i} = ({x(i)} - {_c_sum(terms)}) / Lo[{i * nu + i}];" if terms
                   else f"const ipm_real_t {r}{i} = {x(i)} / Lo[{i * nu + i}];")
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


def gen_kernels(sv: StageView, tab: "_Tables", se_ptr: np.ndarray, gen_e: np.ndarray) -> tuple[np.ndarray, dict]:
    """The general rows' part of a stage's factorization written out for the stages that share the commonest pattern
    (the same rows present, the same (x, u) slots per row, the same slacks and their rows: the a_lat rows of every
    stage but the first, typically): per stage a flag (``IPM_GEN_PAT``) and three bodies taking k, with the generic
    loops' operations in their order (results unchanged), the data at the stage's offsets: ``gen_w`` (its rows'
    weights, slack pivots and slack entries: ipm_stage_weights), ``gen_h`` (the rows' W c c' into H), ``gen_c``
    (two rows of one slack coupled), ``gen_ax`` (A z on the rows: ipm_ineq_Ax), ``gen_atx`` (A' g: ipm_ineq_ATx),
    ``gen_rhs`` (the slacks eliminated from the right-hand side: ipm_stage_rhs) and ``gen_dz`` (their step:
    ipm_forward_stage). No such stage: all flags 0 and no bodies."""
    N, NG, NS, nxu = sv.N, sv.NG, sv.NS, sv.nx + sv.NU
    gptr, gv = tab.gen_xu_ptr, tab.gen_xu_v

    def signature(k: int) -> tuple:
        rows = tuple((bool(sv.gen_rows[k, g] >= 0), tuple(gv[gptr[k * NG + g]:gptr[k * NG + g + 1]]),
                      bool(gen_e[k, g] >= 0)) for g in range(NG))
        groups = tuple((tuple(int(g) for g in tab.sg_g[tab.sg_ptr[k * NS + j]:tab.sg_ptr[k * NS + j + 1]]),
                        bool(sv.vmap[k, nxu + j] >= 0)) for j in range(NS))
        return rows, groups

    sigs = [signature(k) for k in range(N + 1)]
    counts = {}
    for sg in sigs:
        if any(r[1] for r in sg[0]):  # a pattern worth writing out: some row with an (x, u) entry
            counts[sg] = counts.get(sg, 0) + 1
    if not counts:  # no general row with an (x, u) entry: nothing written out (IPM_GEN_WRITTEN 0)
        return np.zeros(N + 1, dtype=np.int64), {k: "" for k in GEN_KERNELS}
    pat = max(counts, key=lambda sg: (counts[sg], -sigs.index(sg)))
    flags = np.array([sg == pat for sg in sigs], dtype=np.int64)
    rows, groups = pat
    off, n = [], 0  # row g's first (x, u) entry from the stage's first
    for _, slots, _ in rows:
        off.append(n)
        n += len(slots)
    for k in np.flatnonzero(flags):  # the pattern's offsets (entries, slack entries) hold, else the generic loops
        if (any(gptr[k * NG + g] - gptr[k * NG] != off[g] for g in range(NG))
                or any(se_ptr[k * NS + j] - se_ptr[k * NS] != sum(len(rows[g][1]) for gr, _ in groups[:j] for g in gr)
                       for j in range(NS))):
            flags[k] = 0
    x = [f"x{e}" for e in range(n)]
    plus = lambda b, o: f"{b} + {o}" if o else b  # noqa: E731  (no "+ 0": MISRA 2.2)
    gs, at = "const int gs = k * IPM_NG;", "const int a = IPM_GEN_PTR[gs];"
    load = [f"const ipm_real_t {x[e]} = IPM_W.gax[{plus('a', e)}];" for e in range(n)]
    in_groups = sorted({g for gr, _ in groups for g in gr})
    w = [gs] + ([at] if any(rows[g][1] for g in in_groups) else [])
    stores = []  # the declarations first, then the stores
    for g, (present, _, slack) in enumerate(rows):
        if present:
            w.append(f"const ipm_real_t w{g} = IPM_W.wr[IPM_GEN_ROW[{plus('gs', g)}]];")
        if slack:
            w += [f"const ipm_real_t gx{g} = IPM_W.gex[{plus('gs', g)}];", f"const ipm_real_t wg{g} = w{g} * gx{g};"]
        stores += [f"IPM_W.Weff[{g}] = {f'w{g}' if present else 'REAL_0'};",
                   f"IPM_W.wg[{plus('gs', g)}] = {f'wg{g}' if slack else 'REAL_0'};"]
    w += stores
    for j, (gr, has_var) in enumerate(groups):
        dd = f"hs{j}"
        for g in gr:
            dd = f"({dd} + (wg{g} * gx{g}))"
        w += ["{", f"  const ipm_real_t hs{j} = {f'IPM_W.hd[IPM_VMAP_S[k][{j}]]' if has_var else 'IPM_ONE'};",
              f"  const ipm_real_t dd{j} = {dd};", f"  IPM_W.d[k][{j}] = dd{j};"]
        c = 0
        for g in gr:
            for e in range(len(rows[g][1])):
                w.append(f"  IPM_W.wc[{plus(f'IPM_SE_BEG[k][{j}]', c)}] = wg{g} * IPM_W.gax[{plus('a', off[g] + e)}];")
                c += 1
        for g in gr:
            others = f"hs{j}"
            for q in gr:
                if q != g:
                    others = f"({others} + (wg{q} * gx{q}))"
            w.append(f"  IPM_W.Weff[{g}] = (w{g} * {others}) / dd{j};")
        w.append("}")
    h = [gs, at] + load
    for g, (_, slots, _) in enumerate(rows):
        for i in range(len(slots)):
            h += ["{", f"  const ipm_real_t ca = IPM_W.Weff[{g}] * {x[off[g] + i]};"]
            h += [f"  IPM_W.H[{slots[i]}][{slots[jj]}] += ca * {x[off[g] + jj]};" for jj in range(i, len(slots))]
            h.append("}")
    cp = []
    for j, (gr, _) in enumerate(groups):
        for pi in range(len(gr)):
            for qi in range(pi + 1, len(gr)):
                gi, gj = gr[pi], gr[qi]
                cp += ["{", f"  const ipm_real_t m = ((-IPM_W.wg[{plus('gs', gi)}]) * IPM_W.wg[{plus('gs', gj)}]) / "
                            f"IPM_W.d[k][{j}];"]
                for xi, vx in enumerate(rows[gi][1]):
                    cp += ["  {", f"    const ipm_real_t cx = m * {x[off[gi] + xi]};"]
                    for yi, vy in enumerate(rows[gj][1]):
                        lo, hi = min(vx, vy), max(vx, vy)
                        cp += ["    {", f"      const ipm_real_t v = cx * {x[off[gj] + yi]};",
                               f"      IPM_W.H[{lo}][{hi}] += v;"]
                        cp += [f"      IPM_W.H[{lo}][{hi}] += v;"] if lo == hi else []
                        cp.append("    }")
                    cp.append("  }")
                cp.append("}")
    used = {e for ln in cp for e in range(n) if f"* {x[e]};" in ln}
    cp = ([gs, at] + [ln for e, ln in enumerate(load) if e in used] + cp) if cp else ["(void)k;"]
    ax, atx = [gs, at], [gs, at]  # A z and A' g on the stage's rows (ipm_ineq_Ax, ipm_ineq_ATx)
    for g, (present, slots, slack) in enumerate(rows):
        if not present:
            continue
        terms = [f"(IPM_W.gax[{plus('a', off[g] + e)}] * x[IPM_GEN_VAR[{plus('a', off[g] + e)}]])"
                 for e in range(len(slots))]
        terms += [f"(IPM_W.gex[{plus('gs', g)}] * x[IPM_GEN_SVAR[{plus('gs', g)}]])"] if slack else []
        sm = "REAL_0"
        for t in terms:
            sm = f"({sm} + {t})"
        ax.append(f"out[IPM_GEN_ROW[{plus('gs', g)}]] = {sm[1:-1] if terms else sm};")
        atx += ["{", f"  const ipm_real_t gv = IPM_W.ar[IPM_GEN_ROW[{plus('gs', g)}]];"]
        atx += [f"  IPM_W.h[IPM_GEN_VAR[{plus('a', off[g] + e)}]] += IPM_W.gax[{plus('a', off[g] + e)}] * gv;"
                for e in range(len(slots))]
        atx += [f"  IPM_W.h[IPM_GEN_SVAR[{plus('gs', g)}]] += IPM_W.gex[{plus('gs', g)}] * gv;"] if slack else []
        atx.append("}")
    rhs, dz = [], []  # the slacks eliminated from the right-hand side (ipm_stage_rhs), their step (ipm_forward_stage)
    for j, (gr, has_var) in enumerate(groups):
        ent = [(rows[g][1][e], c) for c, (g, e) in enumerate((g, e) for g in gr for e in range(len(rows[g][1])))]
        rhs.append(f"hs[{j}] = {f'IPM_W.h[IPM_VMAP_S[k][{j}]]' if has_var else 'REAL_0'};")
        if ent:
            rhs += ["{", f"  const ipm_real_t f = hs[{j}] / IPM_W.d[k][{j}];"]
            rhs += [f"  ht[{v}] -= IPM_W.wc[{plus(f'IPM_SE_BEG[k][{j}]', c)}] * f;" for v, c in ent] + ["}"]
        if has_var:
            acc = "REAL_0"
            for v, c in ent:
                acc = f"({acc} + (IPM_W.wc[{plus(f'IPM_SE_BEG[k][{j}]', c)}] * dv[{v}]))"
            dz.append(f"IPM_W.dz[IPM_VMAP_S[k][{j}]] = (-({acc} + hs[{j}])) / IPM_W.d[k][{j}];")
    if not dz:
        dz = ["(void)k;", "(void)dv;", "(void)hs;"]
    if not any(sl for _, sl, _ in rows):  # no (x, u) entry: a is not read
        ax, atx = [ln for ln in ax if ln != at], [ln for ln in atx if ln != at]
    bodies = {"gen_w": w, "gen_h": h, "gen_c": cp, "gen_ax": ax, "gen_atx": atx, "gen_rhs": rhs, "gen_dz": dz}
    return flags, {k: "\n  ".join(v) for k, v in bodies.items()}


def sr_kernels(na: int) -> dict[str, str]:
    """Bodies of the soft rows' per-row kernels for ``na`` (x, u) entries a row (``IPM_NA``), written out inside the
    core's loop over the lanes (row j + l on lane l; a_p = IPM_W.sr.a[p][j + l]): ``av``: out[l] = a'v;
    ``check``: ipm_sr_check's sums of a row into its lanes of acc ([4 + p] -= a_p l1, the upper triangle of
    weff a a' row-major from [4 + na], [4 + na + nt + p] += a_p f, [4 + 2 na + nt + p] += a_p fb); ``fwd``: the
    predictor's [3 + p] += a_p f. Each acc entry adds in the same order as a loop would: results are unchanged."""
    nt = na * (na + 1) // 2
    a = [f"a{p}" for p in range(na)]
    load = [f"const ipm_real_t a{p} = IPM_W.sr.a[{p}][j + l];" for p in range(na)]
    av = load + [f"out[l] = {_c_sum([f'(a{p} * v[{p}])' for p in range(na)])};"]
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


def _generic_A(layout: QpLayout, sr: SoftRows, sv: StageView) -> tuple[np.ndarray, ...]:
    """A without the soft rows and their slacks' bound rows, the dynamics and the init rows (the C's generic A z
    and A' y; the others have loops of their own: the soft rows', and the stage kernels on [F G] for the dynamics):
    row-major (rows, pointers, columns, data indices) and column-major (pointers, rows, data indices)."""
    keep = np.ones(layout.m, dtype=bool)
    keep[sr.row] = False
    keep[sr.brow] = False
    keep[sv.dyn_rows.ravel()] = False
    keep[layout.init_rows] = False
    ent = np.flatnonzero(keep[layout.A_indices])            # CSC positions = data indices of the kept entries
    rows = layout.A_indices[ent]
    cols = np.repeat(np.arange(layout.n), np.diff(layout.A_indptr))[ent]
    a_p = np.r_[0, np.cumsum(np.bincount(cols, minlength=layout.n))]
    kept_rows = np.flatnonzero(keep)
    order = np.lexsort((cols, rows))
    ar_p = np.r_[0, np.cumsum(np.bincount(rows, minlength=layout.m)[kept_rows])]
    return kept_rows, ar_p, cols[order], ent[order], a_p, rows, ent


def _split_A(tab: "_Tables", sv: StageView, ar: tuple[np.ndarray, ...], gen_e: np.ndarray) -> dict[str, np.ndarray]:
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
        gen = list(tab.gen_var[tab.gen_xu_ptr[gs]:tab.gen_xu_ptr[gs + 1]])
        gen += [int(tab.gen_svar[gs])] if gen_e[gs] >= 0 else []
        if gen != [int(v) for v in ar_j[ar_p[i]:ar_p[i + 1]]]:
            raise AssertionError("a general row's entries are not in the generic A's order")
    own = set(sv.box_rows.tolist()) | set(gen_rows)  # rows with tables of their own
    other = [i for i, r in enumerate(ar_row) if int(r) not in own]
    counts = np.diff(a_p)[gvars]
    one = gvars[counts == 1]
    return {"ar_other": np.array(other, dtype=np.int64), "col0": gvars[counts == 0], "col1": one,
            "col1_row": a_i[a_p[one]], "col1_k": a_k[a_p[one]], "colm": gvars[counts > 1]}


def input_blocks(sv: StageView, sr: SoftRows) -> np.ndarray:
    """Per stage, the boundaries of the blocks of consecutive inputs over which R_bar = H_uu + G' P G is block
    diagonal: inputs that a row or the dynamics couple are in one block (e.g. the controls; each opponent's
    hyperplane variables). Row k: ``[0, b1, ..., NU]``, padded with NU (empty blocks) to the longest row."""
    nx, NU = sv.nx, sv.NU
    rows = []
    for k in range(sv.N + 1):
        parent = list(range(NU))

        def find(i):
            while parent[i] != i:
                i = parent[i]
            return i

        def couple(slots):
            us = [int(v) - nx for v in slots if nx <= v < nx + NU]
            for a in us[1:]:
                parent[find(a)] = find(us[0])

        if k < sv.N:
            couple(sv.dyn_j[sv.dyn_ptr[k]:sv.dyn_ptr[k + 1]])   # G' P G couples every input with dynamics
        for g in range(k * sv.NG, (k + 1) * sv.NG):
            couple(sv.gen_v[sv.gen_ptr[g]:sv.gen_ptr[g + 1]])
        for j in range(sr.ptr[k], sr.ptr[k + 1]):
            couple(sr.v[j][sr.a[j] >= 0])
        hi = {}
        for i in range(NU):
            hi[find(i)] = max(hi.get(find(i), i), i)
        ends, end = [0], 0
        for i in range(NU):                   # blocks: the components' hulls, merged where they overlap
            end = max(end, hi[find(i)] + 1)
            if i + 1 == end:
                ends.append(end)
        rows.append(ends)
    width = max(len(r) for r in rows)
    return np.array([r + [NU] * (width - len(r)) for r in rows], dtype=np.int64)


#: the tables the C indexes ``[k][s]`` (no index arithmetic with a size that may be 1: MISRA 2.2); the rest is flat
TABLES_2D = ("IPM_UB", "IPM_VMAP_S", "IPM_SG_BEG", "IPM_SG_END", "IPM_SE_BEG", "IPM_SE_END", "IPM_SR_RUN_V", "IPM_SR_A",
             "IPM_SR_HLO", "IPM_SR_HHI")


def _table(name: str, kind: str, values, doc: str) -> dict:
    """A C table: flat, or (``TABLES_2D``) a 2-D array with a row per first index."""
    from ..codegen.generate import _c_list
    a = np.asarray(values).astype(np.int64)
    if name in TABLES_2D:
        if not a.size:  # an empty table keeps its two dimensions (padding -1: the loops never read it)
            a = -np.ones((max(1, a.shape[0]), max(1, a.shape[1])), dtype=np.int64)
        rows = ",\n  ".join("{" + _c_list([int(x) for x in r]) + "}" for r in a)
        return {"name": name, "kind": kind, "dims": f"[{a.shape[0]}][{a.shape[1]}]", "doc": doc, "body": rows}
    return {"name": name, "kind": kind, "dims": f"[{max(1, a.size)}]", "doc": doc,
            "body": _c_list([int(x) for x in a.ravel()])}


def codegen_context(ocp, layout: QpLayout, opts: "QpOptions") -> dict:
    """What ``templates/backends/ipm.c.j2`` needs (rendered under the key ``backend``): the problem header's sizes
    and tables, and the algorithm's plain C source. The C treats the soft rows
    (``qp.split_soft_rows``) in loops of their own and the rest of the stage view with the generic tables."""
    from ..codegen.generate import _c_list, _c_real
    sv, sr = split_soft_rows(layout, stage_view(layout))
    tab = _Tables(layout, sv)
    st = ipm_settings(opts)
    N, NX, NU, NS, NG, NE = sv.N, sv.nx, sv.NU, sv.NS, sv.NG, sv.NE
    NE1, nxu = max(NE, 1), sv.nx + sv.NU
    # general rows: the stage-variable entries (x, inputs) as lists; the slack entry apart
    gptr, gv, ga = tab.gen_xu_ptr, tab.gen_xu_v, tab.gen_xu_a
    gen_e = np.where(tab.gen_e < layout.nnz_A, tab.gen_e, -1)
    eq_row = -np.ones((N + 1, NE1), dtype=np.int64)
    eq_row[:, :NE] = sv.eq_rows
    ar_row, ar_p, ar_j, ar_k, a_p, a_i, a_k = _generic_A(layout, sr, sv)
    ub = input_blocks(sv, sr)
    gvars = np.setdiff1d(np.arange(layout.n), sr.svar)
    split = _split_A(tab, sv, (ar_row, ar_p, ar_j, ar_k, a_p, a_i, a_k, gvars), gen_e.ravel())
    se_ptr, se_a = _slack_entries(tab, N, NS, NG)
    gen_pat, gen_k = gen_kernels(sv, tab, se_ptr, gen_e)
    run_ptr, pad = padded_runs(sr)
    fg_a0, _, fg_off, fg_pos = fg_bands(sv)
    if sv.N and not np.all(np.diff(sv.dyn_rows, axis=1) == 1):  # the C reads a stage's c_k in place (ipm_stage_c)
        raise AssertionError("the IPM needs each stage's dynamics rows consecutive in the QP layout")
    xu_lo, xu_hi, xu_v = xu_ranges(sv)
    sr_weight = "(IPM_SR.w[i])" if run_ptr[-1] > sr.count else "(IPM_ONE)"  # a constant 1 without padding rows
    run_v = sr.run_v.reshape(-1, sr.NA)
    hq_a, hq_b = run_v[:, np.triu_indices(sr.NA)[0]], run_v[:, np.triu_indices(sr.NA)[1]]  # a run's upper triangle
    tables = [
        ("IPM_A_P", a_p, "column pointers of A without the soft rows"), ("IPM_A_I", a_i, "their rows"),
        ("IPM_A_K", a_k, "their data index"),
        ("IPM_AR_ROW", ar_row, "rows of A without the soft rows"), ("IPM_AR_P", ar_p, "their entries (row-major)"),
        ("IPM_AR_J", ar_j, "column of row-major entry p"), ("IPM_AR_K", ar_k, "its data index"),
        ("IPM_AR_OTHER", split["ar_other"], "the rows i of IPM_AR_ROW that are neither box nor general rows"),
        ("IPM_A_COL0", split["col0"], "generic variables without an entry in the generic A"),
        ("IPM_A_COL1", split["col1"], "generic variables with one entry"), ("IPM_A_COL1_I", split["col1_row"], "its row"),
        ("IPM_A_COL1_K", split["col1_k"], "its data index"),
        ("IPM_A_COLM", split["colm"], "generic variables with several entries (IPM_A_P)"),
        ("IPM_VMAP_XU", sv.vmap[:, :nxu], "[k][v]: variable of stage k's x/input slot v"),
        ("IPM_XU_LO", xu_lo, "stage k's first slot with a variable"), ("IPM_XU_HI", xu_hi, "one past its last"),
        ("IPM_XU_V", xu_v, "the variable of slot IPM_XU_LO[k] (the others follow it)"),
        ("IPM_VMAP_S", sv.vmap[:, nxu:].reshape(N + 1, NS), "[k][s]: variable of stage k's slack s"),
        ("IPM_GEN_ROW", sv.gen_rows, "[k][g]: general inequality row"),
        ("IPM_GEN_PTR", gptr, "entries of general slot k NG + g"), ("IPM_GEN_V", gv, "stage slot v of the entry"),
        ("IPM_GEN_A", ga, "data index of the entry"), ("IPM_GEN_VAR", tab.gen_var, "variable of the entry"),
        ("IPM_GEN_E", gen_e, "data index of the slot's slack entry"),
        ("IPM_GEN_SVAR", tab.gen_svar, "variable of the slot's slack"),
        ("IPM_SG_BEG", tab.sg_ptr[:-1].reshape(N + 1, NS), "[k][s]: general slots of stage k's slack s (first)"),
        ("IPM_SG_END", tab.sg_ptr[1:].reshape(N + 1, NS), "[k][s]: (one past the last)"),
        ("IPM_SG_G", tab.sg_g, "the general slot (in its stage)"),
        ("IPM_SE_BEG", se_ptr[:-1].reshape(N + 1, NS), "[k][s]: the (x, u) entries of stage k's slack s's rows"),
        ("IPM_SE_END", se_ptr[1:].reshape(N + 1, NS), "[k][s]: (one past the last)"),
        ("IPM_SE_V", np.asarray(gv, dtype=np.int64)[se_a], "its stage slot v"),
        ("IPM_IN_ROW", tab.in_rows, "inequality row i (ascending)"), ("IPM_IN_PTR", tab.in_ptr, "sides of row i"),
        ("IPM_DYN_ROWS", sv.dyn_rows, "[k][i]: dynamics row i of stage k"),
        ("IPM_DYN_NEXT", sv.dyn_next, "[k][i]: data index of its x_{k+1}[i] coefficient"),
        ("IPM_DYN_PTR", sv.dyn_ptr, "[A B] entries of stage k"), ("IPM_DYN_I", sv.dyn_i, "row i"),
        ("IPM_DYN_A", sv.dyn_a, "data index"),
        ("IPM_DYN_B", fg_pos, "its place in the stage's packed [F G] (IPM_W.fgb, fg_bands)"),
        ("IPM_INIT_ROWS", layout.init_rows, "init row of x_0[i]"), ("IPM_INIT_A", sv.init_a, "its data index"),
        ("IPM_EQ_ROW", eq_row, "[k][e]: stage equality row"), ("IPM_EQ_PTR", sv.eq_ptr, "entries of slot k NE + e"),
        ("IPM_EQ_J", sv.eq_j, "input index"), ("IPM_EQ_A", sv.eq_a, "data index"),
        ("IPM_BOX_ROW", sv.box_rows, "box row"), ("IPM_BOX_VAR", sv.box_var, "its variable"),
        ("IPM_BOX_A", sv.box_a, "its data index"),
        ("IPM_SIDE_ROW", sv.side_row, "row of inequality side j"), ("IPM_EQ_ALL", sv.eq_all, "equality rows"),
        ("IPM_FREE", np.flatnonzero(tab.free_inputs), "inputs without cost (proximal weight)"),
        ("IPM_UB", ub, "[k][b]: stage k's input block b: inputs IPM_UB[k][b] .. IPM_UB[k][b + 1] - 1"),
        ("IPM_GV", gvars, "the variables but the soft rows' slacks"),
        ("IPM_SR_RPTR", sr.rptr, "runs of soft rows of stage k"),
        ("IPM_SR_RUN_PTR", run_ptr, "soft rows of run r (rows on the same slots; padded to IPM_LANES rows)"),
        ("IPM_SR_RUN_V", sr.run_v.reshape(-1, sr.NA), "[r][p]: stage slot of the run's (x, u) entry p"),
        ("IPM_SR_ROW", pad(sr.row), "soft row j's row (-1: a padding row)"),
        ("IPM_SR_A", pad(sr.a.reshape(-1, sr.NA)), "[j][p]: its data index (-1: padding)"),
        ("IPM_SR_SVAR", pad(sr.svar), "its slack"),
        ("IPM_SR_E", pad(sr.e), "data index of the slack's coefficient"),
        ("IPM_SR_BROW", pad(sr.brow), "the slack's bound row"),
        ("IPM_SR_BA", pad(sr.ba), "data index of the bound row's coefficient"),
        ("IPM_SR_HLO", np.minimum(hq_a, hq_b), "[r][q]: the Newton block's row of entry q of run r's upper triangle "
         "(row-major; on or above the diagonal)"),
        ("IPM_SR_HHI", np.maximum(hq_a, hq_b), "[r][q]: its column"),
    ]
    if NE == 0:  # the template emits the stage-equality code only with stage equalities
        tables = [t for t in tables if not t[0].startswith("IPM_EQ_") or t[0] == "IPM_EQ_ALL"]
    u_dense = NU <= U_KERNEL_MAX
    if u_dense:  # R factored for all inputs at once (u_kernels): the blocks' table is not read
        tables = [t for t in tables if t[0] != "IPM_UB"]
    top = max(int(np.max(np.asarray(t), initial=0)) for _, t, _ in tables)
    idx_ctype = "int16_t" if top < 2 ** 15 else "int32_t"
    out = [_table(nm, "idx", t, doc) for nm, t, doc in tables]
    second = np.r_[False, sv.side_row[1:] == sv.side_row[:-1]] if len(sv.side_row) else np.zeros(0, dtype=bool)
    two = np.diff(tab.in_ptr) == 2
    pairs = tab.in_ptr[:-1][two]
    if not (np.all(sv.side_sign[pairs] > 0) and np.all(sv.side_sign[pairs + 1] < 0)):
        raise ValueError("a two-sided inequality row's sides must be lower, then upper (the C's pair loops assume it)")
    out += [_table(nm, "sign", t, doc) for nm, t, doc in (
        ("IPM_SR_SIGN", pad(sr.sign, 0), "soft row j's side: +1 lower, -1 upper (0: a padding row)"),
        ("IPM_SR_BSIGN", pad(sr.bsign, 0), "its slack's bound side"),
        ("IPM_SIDE_SIGN", sv.side_sign, "+1: lower side (a'z >= l), -1: upper side (a'z <= u)"),
        ("IPM_SIDE_2ND", second, "1: the second side of its row (the per-row sums add, the first side sets)"),
        ("IPM_IN_TWO", two, "1: inequality row i has two sides (lower, then upper), 0: one"),
        *([("IPM_GEN_PAT", gen_pat, "1: stage k's general rows follow the written-out pattern (gen_kernels)")]
          if gen_pat.any() else []))]
    sg = np.asarray(sv.side_sign, dtype=np.int64)  # the sides' signs in the real type: a multiply, no conversion
    out.append({"name": "IPM_SIDE_SG", "kind": "real", "dims": f"[{max(1, sg.size)}]",
                "doc": "IPM_SIDE_SIGN as a real", "body": ", ".join(("IPM_SG_P" if v > 0 else "IPM_SG_M") for v in sg)
                or "IPM_SG_P"})
    members = _members(sv, layout)
    return {"N": N, "NX": NX, "NU": NU, "NS": NS, "NG": NG, "NE": NE, "NE1": NE1, "RS": tab.slack_rows.shape[2],
            "NSIDE": len(sv.side_row), "NIN": len(tab.in_rows), "NEQ": len(sv.eq_all), "NBOX": len(sv.box_rows),
            "NGA": len(gv), "NSR": sr.count, "NSRP": int(run_ptr[-1]), "LANES": sr_lanes(sr), "sr_weight": sr_weight,
            "NUB": ub.shape[1] - 1, "NV": layout.n, "NGV": len(gvars), "NFGC": len(fg_a0), "NFGB": int(fg_off[-1]), "NA": sr.NA,
            "NRUN": len(sr.run_ptr) - 1, "NAR": len(ar_row), "sr_fields": SR_FIELDS,
            "NAR_OTHER": len(split["ar_other"]), "NCOL0": len(split["col0"]), "NCOL1": len(split["col1"]),
            "NCOLM": len(split["colm"]),
            "NFREE": int(np.count_nonzero(tab.free_inputs)), "prox": _c_real(st.prox),
            "tol": _c_real(st.tol), "tau": _c_real(st.tau), "reg": _c_real(st.reg), "t_min": _c_real(st.t_min), "lam_center": _c_real(st.lam_center),
            "lam_min": _c_real(st.lam_min), "lam_max": _c_real(st.lam_max), "alpha_min": _c_real(st.alpha_min),
            "warm": int(st.warm), "scaled_start": int(st.scaled_start), "idx_ctype": idx_ctype, "tables": out, "members": members,
            "raw_status": [(i + 1, QP_STATUSES[RAW_TO_QP[i] - 1]) for i in range(len(RAW_STATUS))],
            "U_DENSE": int(u_dense), "GEN_WRITTEN": int(gen_pat.any()),
            "kernels": {**fg_kernels(sv), **dense_kernels(NX, NU), **sr_kernels(sr.NA), **u_kernels(NU, NX), **gen_k},
            "core_source": core_source()}


def core_source() -> str:
    """The IPM's algorithm in plain C (``templates/backends/ipm_core.c``): the same for every problem, compiled after
    the problem header ``templates/backends/ipm_problem.h.j2`` renders."""
    from ..codegen.render import templates_dir
    return (templates_dir() / "backends" / "ipm_core.c").read_text()


def write_files(ocp, layout: QpLayout, opts: "QpOptions", out_dir, use_float: bool) -> BackendFiles:
    """The IPM is all in the solver's C file: no extra files; its RAM is the workspace struct."""
    sv, sr = split_soft_rows(layout, stage_view(layout))
    ws = _workspace_bytes(_members(sv, layout), sr, 4 if use_float else 8)
    return BackendFiles(sources=(), headers=(), library_sources=(), library_headers=(), include_dirs=(),
                        private_include_dirs=(), cflags=(), link_libs=(), array_bytes=ws, struct_bytes=0,
                        memory_init_note=": one struct, every array written before it is read",
                        memory_note="its index tables (the stage view of the QP layout) are `static const` (flash)",
                        reset_note="The QP backend's workspace (the IPM's one static struct) is zeroed before its next "
                                   "use; the IPM keeps no scaling\nand starts every QP from z = 0 and the previous "
                                   "multipliers (the dual warm start): nothing else is carried over.")


def restore_library(out_dir, use_float: bool) -> list[str]:
    """Nothing to restore: the IPM has no library."""
    return []
