"""A structure-exploiting primal-dual interior-point QP backend: the Python reference of the generated C.

The C is hand-written (``csrc/ipm/``) and sized per problem by ``codegen/ipm_header.py`` (its tables and workspace)
and ``codegen/ipm_kernels.py`` (its written-out kernels); it runs the same algorithm in the same order of operations.

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

from ..qp import QpLayout, slack_bound_sides, split_soft_rows, stage_view
from . import QP_MAX_ITER, QP_NONFINITE, QP_NUMERICAL, QP_PRIMAL_INFEASIBLE, QP_SOLVED, QpResult
from .ipm_tables import IpmTables

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
QP's solution). 1e-7 keeps a margin over these and stays 1e3 below the IPM's own stopping tolerance (1e-4). Where a
sample's QP amplifies rounding beyond it, ``VERIFY_ENVELOPE`` holds that sample to its measured envelope instead."""

VERIFY_ENVELOPE = True
"""fcgen verify may solve a lockstep sample's QP again (this backend keeps nothing between solves): where the C's
solution parts from the reference's beyond ``VERIFY_SOLUTION_TOL``, the reference solves it again with its measured
state changed at rounding level (``verify_envelope.solution_envelope``) and the sample passes within twice how far its
own solution moved. Some warm QPs of truck_conventional_hyperplane_ipm_safe (penalties 1e8, 3e8) move that much (200
samples, measured at a3cce0f): C vs Python up to 5.3e-5 in the iterate (seed 3, sample 3), the reference from itself
there 3.4e-5 under a 1e-15 change of its measured state (docs/verification.md)."""

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

    tol: float = 1e-4  # stationarity, primal residuals and every complementarity product t lam
    tau: float = 0.995  # fraction to the boundary
    reg: float = 1e-9  # regularization of the input block of the Newton matrix
    prox: float = 1e-6  # proximal weight on inputs without cost (hyperplanes: not unique, else they drift)
    t_min: float = 0.1  # floor of an initial side slack
    lam_min: float = 0.1  # floor of an initial side multiplier
    lam_center: float = 0.5  # then each initial lam at least lam_center mean(t lam) / t: no product far below the mean
    lam_max: float = 1e10  # a multiplier beyond it: primal infeasible
    alpha_min: float = 1e-12  # a step below it: numerical trouble
    warm: bool = True  # initial multipliers from the shifted duals (else lam = lam_min, nu = 0)
    scaled_start: bool = False  # lam = max(lw, lam_min / max(1, -b)) on every side and a soft row's slack bound at
    # t = max(-b, t_min / max(1, lam)) (lw the warm multiplier, -b the slack at z = 0); else lam_min and t_min floors


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
        X[i] = (X[i] - L[i + 1 :, i] @ X[i + 1 :]) / L[i, i]
    return X


def ipm_settings(opts: QpOptions) -> IpmSettings:
    """The IPM's settings of a problem's QpOptions."""
    return IpmSettings(tol=opts.ipm_tol, scaled_start=opts.ipm_scaled_start)


class Backend:
    """Riccati-based Mehrotra predictor-corrector IPM on the layout's QP (see the module docstring)."""

    name = "ipm"

    def __init__(self, layout: QpLayout, opts: QpOptions, settings: IpmSettings | None = None):
        self.lay = layout
        self.sv = stage_view(layout)
        self.tab = IpmTables(layout, self.sv)
        self.set = settings or ipm_settings(opts)
        # the sides of the soft rows' slack bounds (the C's IPM_SR t2): where scaled_start applies
        self.slack_bound_side = np.isin(self.sv.side_row, split_soft_rows(layout, self.sv)[1].brow)
        self.slack_sides = slack_bound_sides(self.sv)  # every slack's bound: a cold start's lam (cold_slack_lam)
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
        self.Cxu = ax[tab.gen_xu]  # (N+1, NG, nx+NU)
        self.Ce = ax[tab.gen_e]  # (N+1, NG) slack coefficient
        E = ax[sv.dyn_next]  # (N, nx)
        self.Einv = 1.0 / E
        AB = -ax[tab.dyn_ab] * self.Einv[:, :, None]  # x_{k+1} = F x + G u + c
        self.F = AB[:, :, : sv.nx]
        self.G = AB[:, :, sv.nx :]
        self.einit = ax[sv.init_a]
        self.D = ax[tab.eq_d]  # (N+1, NE, NU)
        self.box_a2 = ax[sv.box_a] ** 2

    # -- the Newton matrix: side weights, slack elimination, Riccati factorization ---------------------
    def _factor(self, W: np.ndarray) -> bool:
        """Factor the Newton matrix of the side weights W (per row); False if a pivot is not positive."""
        return self._riccati(self._stage_blocks(W))

    def _stage_blocks(self, W: np.ndarray) -> np.ndarray:
        """The stages' Newton blocks H over (x_k, u_k), the slacks eliminated (their couplings c, pivots d kept)."""
        sv, tab = self.sv, self.tab
        N, nx = sv.N, sv.nx
        hd = np.r_[self.Pd, 1.0]
        np.add.at(hd, sv.box_var, W[sv.box_rows] * self.box_a2)
        # general rows; a slack's rows (its group) are eliminated with it, without cancellation: row i of the
        # group weighs W_i (hd_s + sum_{j != i} W_j e_j^2) / d_s, two rows couple by -W_i e_i W_j e_j / d_s,
        # d_s = hd_s + sum_i W_i e_i^2 (hd_s: the slack's own curvature, cost and its bound row)
        pad = np.zeros((N + 1, 1))
        Wg = np.concatenate([W[tab.gen_row], pad], axis=1)  # (N+1, NG+1); dummy slot: W = 0
        w = Wg * np.concatenate([self.Ce, pad], axis=1)  # W e
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
        return H

    def _riccati(self, H: np.ndarray) -> bool:
        """The Riccati recursion over the stage blocks H (k = N..0); False if a pivot is not positive."""
        sv, tab, st = self.sv, self.tab, self.set
        N, nx = sv.N, sv.nx
        none = np.empty(0)  # a stage's entry before the sweep sets it
        self.Lr: list[np.ndarray] = [none] * (N + 1)
        self.W1: list[np.ndarray] = [none] * (N + 1)
        self.Pk: list[np.ndarray] = [none] * (N + 1)
        self.UD: list[np.ndarray] = [none] * (N + 1)
        self.LM: list[np.ndarray] = [none] * (N + 1)
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
        cdyn = -rr[sv.dyn_rows] * self.Einv  # (N, nx)
        deq = -rr[tab.eq_row]  # (N+1, NE)
        none = np.empty(0)  # a stage's entry before the backward sweep sets it
        lr, kk, p = [none] * (N + 1), [none] * (N + 1), [none] * (N + 1)
        pn = np.zeros(nx)  # p_{k+1}, read from k = N - 1 on
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
            p[k] = qb - self.W1[k].T @ t  # = qb + S_bar' kk
            pn = p[k]
        dz = np.zeros(lay.n + 1)
        dnu = np.zeros(lay.m + 1)
        dx = -rr[lay.init_rows] / self.einit
        for k in range(N + 1):
            w = self.W1[k] @ dx  # du = K dx + kk, K = -L^-T (W1 - UD M^-1 UD' W1)
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
        return dz[: lay.n], dnu[: lay.m]

    # -- feedback phase ------------------------------------------------------------------------------
    def solve(self, q, l, u, y_warm, max_iter: int) -> QpResult:
        sv = self.sv
        q = np.asarray(q, dtype=float)
        rows, sign = sv.side_row, sv.side_sign.astype(float)
        b = np.where(sign > 0, l[rows], -u[rows])
        b_eq = l[sv.eq_all]
        z, t, lam, nu = self._start(q, b, y_warm)
        raw = 2
        it = 0
        while True:
            r_d, r_eq, r_p, mu = self._residuals(q, b, b_eq, z, t, lam, nu)
            raw = self._check(r_d, r_eq, r_p, t, lam, mu, it, max_iter)
            if raw == 4:
                return QpResult(RAW_TO_QP[3], 4, it, None, None)
            if raw != 0:
                break
            raw, step = self._step(t, lam, r_d, r_eq, r_p, mu)
            if raw == 4:
                return QpResult(RAW_TO_QP[3], 4, it, None, None)
            if raw != 0:
                break
            alpha, dz, dnu, dt, dlam = step
            z = z + alpha * dz
            nu = nu + alpha * dnu[sv.eq_all]
            t = t + alpha * dt
            lam = lam + alpha * dlam
            it += 1
        return QpResult(RAW_TO_QP[raw - 1], raw, it, z, self._compose_y(lam, nu))

    def _start(self, q, b: np.ndarray, y_warm) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The initial iterate z = 0, the sides' t and lam (a centred start, lam from the warm duals), the equality
        rows' nu."""
        sv, st = self.sv, self.set
        rows, sign = sv.side_row, sv.side_sign.astype(float)
        yw = np.zeros(self.lay.m) if y_warm is None or not st.warm else np.asarray(y_warm, dtype=float)
        lw = -sign * yw[rows]
        if st.scaled_start:  # a floored lam scaled by its side's slack at z = 0; a slack bound's t by its lam
            lw, cold = cold_slack_lam(lw, sign, q, self.Ax, self.slack_sides)
            lam = np.maximum(lw, st.lam_min / np.maximum(1.0, -b))
            t = np.maximum(-b, np.where(self.slack_bound_side | cold, st.t_min / np.maximum(1.0, lam), st.t_min))
        else:
            lam = np.maximum(lw, st.lam_min)
            t = np.maximum(-b, st.t_min)
        lam = np.maximum(lam, (st.lam_center * (float(t @ lam) / len(rows))) / t)  # a centred start (IpmSettings)
        return np.zeros(self.lay.n), t, lam, yw[sv.eq_all].copy()

    def _compose_y(self, lam: np.ndarray, nu: np.ndarray) -> np.ndarray:
        """The row multipliers: nu on the equality rows, lam_upper - lam_lower on the inequality rows."""
        sv = self.sv
        y = np.zeros(self.lay.m)
        y[sv.eq_all] = nu
        np.add.at(y, sv.side_row, -sv.side_sign.astype(float) * lam)
        return y

    def _residuals(self, q, b, b_eq, z, t, lam, nu) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
        """Stationarity r_d, equality residuals r_eq (on the equality rows), the sides' r_p and mu = mean(t lam)."""
        sv, m = self.sv, self.lay.m
        eq, rows, sign = sv.eq_all, sv.side_row, sv.side_sign.astype(float)
        y = self._compose_y(lam, nu)
        Az = self.A @ z
        r_d = self.Pd * z + q + self.AT @ y
        r_eq = np.zeros(m)
        r_eq[eq] = Az[eq] - b_eq
        r_p = sign * Az[rows] - b - t
        return r_d, r_eq, r_p, float(t @ lam) / len(rows)

    def _check(self, r_d, r_eq, r_p, t, lam, mu: float, it: int, max_iter: int) -> int:
        """The stopping tests: the raw status the QP stops with (4 non-finite, 1 solved, 3 infeasible, 2 at the
        iteration cap), 0 to go on."""
        st = self.set
        if not (np.all(np.isfinite(r_d)) and np.isfinite(mu)):
            return 4
        if self.trace is not None:
            self.trace.append(
                (
                    float(np.max(np.abs(r_d))),
                    float(np.max(np.abs(r_eq))),
                    float(np.max(np.abs(r_p))),
                    float(np.max(t * lam)),
                    mu,
                )
            )
        if max(np.max(np.abs(r_d)), np.max(np.abs(r_eq)), np.max(np.abs(r_p)), np.max(t * lam)) <= st.tol:
            return 1
        if np.max(lam) > st.lam_max:
            return 3
        return 2 if it >= max_iter else 0

    def _step(self, t, lam, r_d, r_eq, r_p, mu: float) -> tuple[int, tuple]:
        """One predictor-corrector step: (0, (alpha, dz, dnu, dt, dlam)), or the raw status it stops with (5
        numerical, 4 non-finite) and ()."""
        sv, st = self.sv, self.set
        inv_t = 1.0 / t
        W = np.zeros(self.lay.m + 1)
        np.add.at(W, sv.side_row, lam * inv_t)
        if not self._factor(W):
            return 5, ()
        _, _, dt_a, dl_a = self._direction(t * lam, lam, inv_t, r_d, r_eq, r_p)
        a_aff = _max_step(t, lam, dt_a, dl_a)
        mu_aff = float((t + a_aff * dt_a) @ (lam + a_aff * dl_a)) / len(t)
        ratio = mu_aff / mu
        sigma = ratio * ratio * ratio
        dz, dnu, dt, dlam = self._direction(t * lam + dt_a * dl_a - sigma * mu, lam, inv_t, r_d, r_eq, r_p)
        alpha = min(1.0, st.tau * _max_step(t, lam, dt, dlam))
        if not np.all(np.isfinite(dz)):
            return 4, ()
        if alpha < st.alpha_min:
            return 5, ()
        return 0, (alpha, dz, dnu, dt, dlam)

    def _direction(self, rc, lam, inv_t, r_d, r_eq, r_p) -> tuple[np.ndarray, ...]:
        """The Newton direction (dz, dnu, dt, dlam) for the complementarity target rc."""
        sv, tab = self.sv, self.tab
        rows, sign = sv.side_row, sv.side_sign.astype(float)
        g = np.zeros(self.lay.m)
        np.add.at(g, rows, sign * (rc + lam * r_p) * inv_t)
        h = r_d.copy()  # r_d + A_in' g, entry by entry as the C
        np.add.at(h, tab.ent_var, self.Ax[tab.ent_a] * g[tab.ent_row])
        dz, dnu = self._newton(h, r_eq)
        adz = np.zeros(self.lay.m)
        np.add.at(adz, tab.ent_row, self.Ax[tab.ent_a] * dz[tab.ent_var])
        dt = sign * adz[rows] + r_p
        dlam = -(rc + lam * dt) * inv_t
        return dz, dnu, dt, dlam


def cold_slack_lam(lw: np.ndarray, sign: np.ndarray, q, ax: np.ndarray, slack_sides) -> tuple[np.ndarray, np.ndarray]:
    """The sides' warm multipliers ``lw``, where a slack's bound has none (0: a cold start) its slack's cost over the
    bound's coefficient, the multiplier the bound carries while the slack's row is inactive (``slack_bound_sides``);
    and the mask of those sides (the C's ``ipm_start_slack_bounds`` and ``ipm_start_soft_rows``)."""
    side, var, dat = slack_sides
    c = sign[side] * ax[dat]
    hit = (lw[side] == 0.0) & (c > 0.0)
    out, cold = lw.copy(), np.zeros(lw.shape, dtype=bool)
    out[side[hit]] = np.asarray(q, dtype=float)[var[hit]] / c[hit]
    cold[side[hit]] = True
    return out, cold


def _max_step(t: np.ndarray, lam: np.ndarray, dt: np.ndarray, dlam: np.ndarray) -> float:
    """The largest step in [0, 1] that keeps t + a dt and lam + a dlam non-negative."""
    a = 1.0
    neg = dt < 0
    if np.any(neg):
        a = min(a, float(np.min(-t[neg] / dt[neg])))
    neg = dlam < 0
    if np.any(neg):
        a = min(a, float(np.min(-lam[neg] / dlam[neg])))
    return a


def restore_library(out_dir, use_float: bool) -> list[str]:
    """Nothing to restore: the IPM has no library (its C is in the solver's file)."""
    return []
