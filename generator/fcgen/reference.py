"""The Python reference: SQP real-time iterations (prepare/feedback) on the shared QpLayout, plus converged solves.

It performs exactly the steps the generated C performs, in the same order, with CasADi's functions, scipy sparse
matrices and the QP backend's Python side (``fcgen.backends``), so C and reference can be compared number for number.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass

import casadi as ca
import numpy as np

from .backends import make_backend
from .dsl import QpOptions, SeparatingHyperplane
from .ocp import Ocp, build_ocp
from .qp import QpLayout, build_layout
from .road import Road


EXIT_CODES = ("OK", "ERR_NOT_PREPARED", "ERR_NO_STATE", "ERR_NONFINITE_STATE", "ERR_NONFINITE_OPPONENTS",
              "ERR_NONFINITE_ROAD", "ERR_ROAD_WINDOW", "ERR_ROAD_SIZE", "ERR_QP")
"""Exit codes shared by the reference and the generated C API (``<NAME>_<code>``), in enum order."""


class SolverError(RuntimeError):
    """A solver call that cannot proceed (bad input or wrong call order); the solver stays usable."""

    def __init__(self, code: str, message: str):
        super().__init__(f"{code}: {message}")
        self.code = code
        self.exit_code = EXIT_CODES.index(code)


@dataclass
class Status:
    """What one sample's solve reports (mirrors the C status struct)."""

    exit_code: int = 0
    qp_status: int = 0      # generic QP_* status (fcgen.backends.QP_STATUSES; 0: no QP solved)
    qp_raw_status: int = 0  # the backend's own status value
    qp_iter: int = 0
    time_prepare: float = 0.0
    time_feedback: float = 0.0


def cold_max_iter(opts: QpOptions) -> int:
    """Iteration budget of a cold-started QP (no shifted guess): never below the warm one."""
    return max(opts.max_iter, opts.max_iter_cold)


def theta_init(ocp: Ocp) -> ca.Function:
    """Initial separating hyperplanes: normal from the ego centre to the opponent centre, through the midpoint."""
    from . import obstacles as obs
    from .dsl import Conventional
    from .road import casadi_to_cartesian
    x = ca.SX.sym("x", ocp.nx)
    p = ca.SX.sym("p", ocp.np_stage)
    pb = ocp.problem
    if not isinstance(pb.obstacles, SeparatingHyperplane):
        return ca.Function("theta_init", [x, p], [ca.SX(0, 1)])
    rp = ocp.road_params
    out = []
    for j in range(pb.opponents.count):
        pj = p[ocp.p_opp][j * ocp.n_opp_par:(j + 1) * ocp.n_opp_par]
        if isinstance(pb.formulation, Conventional):
            ego = obs.frenet_ego_shape(x[0], x[1], x[2], 1.0, pb.ego)
            co = (pj[0], pj[1])
        else:
            pose = (x[5], x[6], x[7]) if ocp.state_kind == "lifted" else casadi_to_cartesian(
                x[0], x[1], x[2], p[ocp.p_road], rp.samples)
            ego = obs.chassis_shape(*pose, pb.ego)
            opp = obs.chassis_shape(pj[0], pj[1], pj[2], pb.opponents.vehicle)
            co = (opp.cx, opp.cy)
        dx, dy = co[0] - ego.cx, co[1] - ego.cy
        d = ca.sqrt(dx * dx + dy * dy + 1e-12)
        out += [dx / d, dy / d, d / 2]
    return ca.Function("theta_init", [x, p], [ca.vertcat(*out)])


class RtiSolver:
    """SQP-RTI: ``prepare()`` linearizes at the shifted guess, ``feedback()`` embeds x0 and solves one QP."""

    def __init__(self, ocp: Ocp, layout: QpLayout | None = None, qp: QpOptions | None = None):
        self.ocp = ocp
        self.lay = layout or build_layout(ocp)
        self.qp_opts = qp or ocp.problem.qp
        N = ocp.N
        self._fun_first = ocp.first.fun
        self._fun_mid = ocp.middle.fun.map(N - 1) if N > 1 else None
        self._fun_last = ocp.last.fun
        self._theta_init = theta_init(ocp)
        self.road: Road | None = None
        self.opp = np.zeros((N + 1, ocp.problem.opponents.count * ocp.n_opp_par))
        self.x0: np.ndarray | None = None
        self.w: np.ndarray | None = None
        self.y = np.zeros(self.lay.m)
        self.prepared = False
        self.cold = False
        self.status = Status()
        lay = self.lay
        self.q = np.zeros(lay.n)
        self.l = lay.L.copy()
        self.u = lay.U.copy()
        self.g = np.zeros(lay.m)
        self.A_data = np.zeros(lay.nnz_A)
        self.s0_guess = 0.0
        self.qp = make_backend(lay, self.qp_opts)

    # -- inputs -----------------------------------------------------------------------------------
    def set_road(self, road: Road) -> None:
        if road.size > self.ocp.problem.road.samples:
            raise SolverError("ERR_ROAD_SIZE", f"road window has {road.size} samples; allowed at most {self.ocp.problem.road.samples}")
        self.road = road

    def set_opponents(self, params: np.ndarray) -> None:
        """Per-stage opponent parameters, shape (N+1, n_opp, n_opp_par)."""
        params = np.asarray(params, dtype=float)
        n_opp = self.ocp.problem.opponents.count
        if params.shape != (self.ocp.N + 1, n_opp, self.ocp.n_opp_par):
            raise SolverError("ERR_NONFINITE_OPPONENTS", f"opponents: shape {params.shape}, expected {(self.ocp.N + 1, n_opp, self.ocp.n_opp_par)}")
        if not np.all(np.isfinite(params)):
            raise SolverError("ERR_NONFINITE_OPPONENTS", "opponents: NaN or infinite pose")
        self.opp = params.reshape(self.ocp.N + 1, -1)

    def set_state(self, x0) -> None:
        x0 = np.asarray(x0, dtype=float)
        if x0.shape != (5,) or not np.all(np.isfinite(x0)):
            raise SolverError("ERR_NONFINITE_STATE", "state: expected 5 finite values [s, n, alpha, v, delta]")
        self.x0 = x0

    # -- parameters --------------------------------------------------------------------------------
    def _road_params(self, s: float) -> np.ndarray:
        road, rp = self.road, self.ocp.road_params
        if road is None:
            raise SolverError("ERR_ROAD_WINDOW", "road window not set")
        if not math.isfinite(s):
            raise SolverError("ERR_NONFINITE_STATE", "non-finite s in the guess")
        i0 = int(math.floor((s - road.s0) / road.ds)) - 1
        if i0 < 0 or i0 + rp.samples > road.size:
            raise SolverError("ERR_ROAD_WINDOW", f"road window [{road.s0:.1f}, {road.s_end:.1f}] does not cover s = {s:.1f}")
        return rp.pack(road, i0)

    def stage_params(self, k: int, s: float) -> np.ndarray:
        pb = self.ocp.problem
        xref = [self.s0_guess + k * self.ocp.dt * pb.reference.v_ref, pb.reference.n_ref, 0.0,
                pb.reference.v_ref, 0.0]
        return np.concatenate([self._road_params(s), xref, self.opp[k]])

    def _stage_w(self, k: int) -> np.ndarray:
        return self.w[self.lay.var_off[k]:self.lay.var_off[k + 1]]

    # -- initial guess -----------------------------------------------------------------------------
    def initial_guess(self) -> None:
        """Roll the model out from x0 with zero input; hyperplanes between ego and opponents; zero slacks."""
        if self.x0 is None:
            raise SolverError("ERR_NO_STATE", "state not set before the first prepare")
        ocp, lay = self.ocp, self.lay
        w = np.zeros(lay.n)
        self.s0_guess = self.x0[0]
        x = np.array(ocp.init_state(self.x0, self.stage_params(0, self.x0[0]))).ravel()
        for k in range(ocp.N + 1):
            o = lay.var_off[k]
            w[o:o + ocp.nx] = x
            p = self.stage_params(k, x[0])
            if k >= 1 and ocp.n_theta:
                w[o + ocp.nx + ocp.nu * (k < ocp.N):][:ocp.n_theta] = np.array(self._theta_init(x, p)).ravel()
            if k < ocp.N:
                x = np.array(ocp.dynamics(x, np.zeros(ocp.nu), p)).ravel()
        self.w = w  # only a complete guess is kept
        self.y[:] = 0.0

    # -- the two phases -----------------------------------------------------------------------------
    def prepare(self, shift: bool = True) -> None:
        """Shift the previous solution, linearize, build the QP (all but x0), load the backend's matrices."""
        t0 = time.perf_counter()
        self.prepared = False
        ocp, lay = self.ocp, self.lay
        self.cold = self.w is None
        if self.w is None:
            self.initial_guess()
        elif shift:
            self.w = self.w[lay.var_shift]
            self.y = self.y[lay.row_shift]
        w = self.w
        N = ocp.N
        self.s0_guess = w[lay.s_vars[0]]
        P = np.stack([self.stage_params(k, w[lay.s_vars[k]]) for k in range(N + 1)], axis=1)
        Xn = np.stack([w[lay.var_off[k + 1]:lay.var_off[k + 1] + ocp.nx] for k in range(N)], axis=1)
        g, J, q = [], [], []
        out = self._fun_first(self._stage_w(0), Xn[:, 0], P[:, 0])
        g.append(out[0]); J.append(out[1]); q.append(out[2])
        if N > 1:
            Wm = np.stack([self._stage_w(k) for k in range(1, N)], axis=1)
            out = self._fun_mid(Wm, Xn[:, 1:], P[:, 1:N])
            g.append(out[0]); J.append(out[1]); q.append(out[2])
        out = self._fun_last(self._stage_w(N), np.zeros(ocp.nx), P[:, N])
        g.append(out[0]); J.append(out[1]); q.append(out[2])
        self.g = np.concatenate([np.array(a).ravel(order="F") for a in g])
        jac = np.concatenate([np.array(a.nonzeros()) for a in J])
        self.q = np.concatenate([np.array(a).ravel(order="F") for a in q])
        self.A_data = jac[lay.a_src]
        self.l = lay.L - self.g
        self.u = lay.U - self.g
        self.qp.set_matrices(lay.P_diag, self.A_data, self.q)
        self.prepared = True
        self.status = Status(time_prepare=time.perf_counter() - t0)

    def feedback(self) -> np.ndarray:
        """Embed the measured x0, solve the QP, take the full step; returns u_0."""
        t0 = time.perf_counter()
        if not self.prepared:
            raise SolverError("ERR_NOT_PREPARED", "feedback called before prepare")
        if self.x0 is None:
            raise SolverError("ERR_NO_STATE", "state not set")
        ocp, lay = self.ocp, self.lay
        x0_full = np.array(ocp.init_state(self.x0, self.stage_params(0, self.x0[0]))).ravel()
        ir = lay.init_rows
        self.l[ir] = x0_full / lay.D[:ocp.nx] - self.g[ir]
        self.u[ir] = self.l[ir]
        q = self.q + lay.q_ds0 * (self.x0[0] - self.s0_guess)
        self.q_fb = q
        res = self.qp.solve(q, self.l, self.u, self.y,
                            cold_max_iter(self.qp_opts) if self.cold else self.qp_opts.max_iter)
        self.prepared = False
        st = self.status
        st.qp_status = res.status
        st.qp_raw_status = res.raw_status
        st.qp_iter = res.iter
        z = res.z
        if z is None or not np.all(np.isfinite(z)):
            st.exit_code = EXIT_CODES.index("ERR_QP")
            st.time_feedback = time.perf_counter() - t0
            raise SolverError("ERR_QP", f"QP failed (status {st.qp_status}, raw {st.qp_raw_status})")
        self.z = z
        self.w = self.w + lay.D * z
        self.y = res.y
        st.time_feedback = time.perf_counter() - t0
        return self.u0()

    # -- outputs ------------------------------------------------------------------------------------
    def u0(self) -> np.ndarray:
        o = self.lay.var_off[0] + self.ocp.nx
        return self.w[o:o + self.ocp.nu].copy()

    def states(self) -> np.ndarray:
        return np.stack([self._stage_w(k)[:self.ocp.nx] for k in range(self.ocp.N + 1)])

    def controls(self) -> np.ndarray:
        return np.stack([self._stage_w(k)[self.ocp.nx:self.ocp.nx + self.ocp.nu] for k in range(self.ocp.N)])

    def slacks(self) -> np.ndarray:
        ocp = self.ocp
        out = []
        for k in range(1, ocp.N + 1):
            wk = self._stage_w(k)
            out.append(wk[-ocp.n_sigma:])
        return np.stack(out)

    def step(self, x0) -> np.ndarray:
        """One RTI sample: prepare (first time with the given state), then feedback with it."""
        if self.w is None:
            self.set_state(x0)
        self.prepare()
        self.set_state(x0)
        return self.feedback()

    def solve_converged(self, x0, max_sqp: int = 100, tol: float = 1e-9) -> int:
        """Iterate SQP (no shift) at a fixed x0 until the step is below tol; returns the iteration count."""
        self.set_state(x0)
        if self.w is None:
            self.initial_guess()
        for it in range(1, max_sqp + 1):
            self.prepare(shift=False)
            self.feedback()
            if np.max(np.abs(self.z)) < tol:
                return it
        return max_sqp


def make_reference(problem) -> RtiSolver:
    """Build the OCP, layout and reference solver of a problem."""
    return RtiSolver(build_ocp(problem))
