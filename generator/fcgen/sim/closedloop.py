"""Closed loop: plant (the same RK4 Frenet model), opponents, a controller (Python reference or compiled C), log."""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol

import casadi as ca
import numpy as np

from .. import models
from ..dsl import Problem, Vehicle
from ..ocp import Ocp, build_ocp
from ..reference import RtiSolver, SolverError
from ..road import Road, RoadWindowParams, casadi_road
from .collision import collisions_over_run
from .runlog import RunLog, make_meta
from .scenario import OpponentParams, Scenario

WINDOW_BEHIND = 10.0  # m of road the solver's window keeps behind the ego


@dataclass
class StepResult:
    """What a controller returns for one sample."""

    u: np.ndarray
    exit_code: int
    qp_status: int
    qp_iter: int
    time_prepare: float
    time_feedback: float
    max_slack: float


class Controller(Protocol):
    """One closed-loop controller: the Python reference or a compiled C solver."""

    kind: str

    def step(self, x0: np.ndarray, road: Road, opp: np.ndarray) -> StepResult: ...


class ReferenceController:
    """The Python reference SQP-RTI as a closed-loop controller."""

    kind = "python-reference"

    def __init__(self, ocp: Ocp, solver: RtiSolver | None = None):
        self.solver = solver or RtiSolver(ocp)

    def prepare_phase(self, x0: np.ndarray, road: Road, opp: np.ndarray) -> int:
        """Inputs, then the preparation phase (the state only before the first one); returns the exit code."""
        sv = self.solver
        try:
            sv.set_road(road)
            sv.set_opponents(opp)
            if sv.w is None:
                sv.set_state(x0)
            sv.prepare()
        except SolverError as exc:
            return exc.exit_code
        return 0

    def feedback_phase(self, x0: np.ndarray, rc: int = 0) -> StepResult:
        """The measured state, then the feedback phase; ``rc``: the exit code of ``prepare_phase``."""
        sv = self.solver
        if not rc:
            try:
                sv.set_state(x0)
                u = sv.feedback()
                st = sv.status
                return StepResult(u, 0, st.qp_status, st.qp_iter, st.time_prepare, st.time_feedback,
                                  float(np.max(sv.slacks(), initial=0.0)))
            except SolverError as exc:
                rc = exc.exit_code
        st = sv.status  # the control after an error: the fallback (unusable QP) or the last one (rejected call)
        return StepResult(sv.u0(), rc, st.qp_status, st.qp_iter, st.time_prepare, st.time_feedback, math.nan)

    def step(self, x0: np.ndarray, road: Road, opp: np.ndarray) -> StepResult:
        return self.feedback_phase(x0, self.prepare_phase(x0, road, opp))


def plant_function(problem: Problem, samples: int) -> ca.Function:
    """One RK4 step of the 5-state Frenet model with a road window parameter (same formula as the NLP)."""
    rp = RoadWindowParams(samples)
    x, u, p = ca.SX.sym("x", 5), ca.SX.sym("u", 2), ca.SX.sym("p", rp.size)
    f = models.ode("frenet", lambda s: casadi_road(s, p, samples)[:2], problem.ego, problem.wind)
    return ca.Function("plant", [x, u, p], [models.rk4(f, x, u, problem.horizon.dt)])


def dims(v: Vehicle) -> dict:
    return {"l_f": v.l_f, "l_r": v.l_r, "l_r_ch": v.l_r_ch, "l_f_ch": v.l_f_ch, "w_ch": v.w_ch}


def run_closed_loop(problem: Problem, sc: Scenario, controller: Controller | None = None,
                    ocp: Ocp | None = None, progress: bool = False) -> RunLog:
    """Simulate ``sc.samples`` samples; returns the run log (SPEC section 7 metrics)."""
    ocp = ocp or build_ocp(problem)
    controller = controller or ReferenceController(ocp)
    plant = plant_function(problem, ocp.road_params.samples)
    rp = ocp.road_params
    opp_params = OpponentParams(problem, sc)
    K = sc.samples
    road = sc.road
    xs = np.zeros((K + 1, 5))
    xs[0] = sc.x0
    us = np.zeros((K, 2))
    tp, tf = np.zeros(K), np.zeros(K)
    qi, qs = np.zeros(K, dtype=np.int64), np.zeros(K, dtype=np.int64)
    slack = np.zeros(K)
    exit_codes = np.zeros(K, dtype=np.int64)
    it = range(K)
    if progress:
        from tqdm import tqdm
        it = tqdm(it, desc=f"{problem.name} seed {sc.seed}", unit="sample", leave=False)
    for j in it:
        x = xs[j]
        window = road.window(x[0] - WINDOW_BEHIND, problem.road.samples)
        r = controller.step(x, window, opp_params.horizon(j))
        us[j], exit_codes[j] = r.u, r.exit_code
        tp[j], tf[j], qi[j], qs[j], slack[j] = r.time_prepare, r.time_feedback, r.qp_iter, r.qp_status, r.max_slack
        i0 = int(math.floor((x[0] - road.s0) / road.ds)) - 1
        xs[j + 1] = np.array(plant(x, us[j], rp.pack(road, i0))).ravel()
    t = np.arange(K + 1) * sc.dt
    ex, ey, ephi = road.to_cartesian(xs[:, 0], xs[:, 1], xs[:, 2])
    ego_cart = np.stack([ex, ey, ephi], axis=1)
    opp_cart = sc.opp_cartesian(t)
    opp_fr = sc.opp_frenet(t)
    opp_dims = [dims(problem.opponents.vehicle)] * len(sc.opp_s0)
    coll = collisions_over_run(ego_cart, dims(problem.ego), opp_cart, opp_dims).any(axis=1)
    a_lat = xs[:, 3] ** 2 * np.tan(xs[:, 4]) / problem.ego.l
    meta = make_meta(problem=problem.name, formulation=problem.formulation.kind,
                     obstacle_model=problem.obstacles.kind, scenario=sc.name, seed=sc.seed,
                     N=problem.horizon.N, dt=problem.horizon.dt, controller=controller.kind,
                     n_bound=problem.bounds.n_max,
                     extra={"exit_codes_nonzero": int(np.count_nonzero(exit_codes))})
    road_dict = {"s": road.s, "kappa": road.kappa, "gamma_x": road.gx, "gamma_y": road.gy,
                 "phi_gamma": road.phi, "ds": road.ds}
    return RunLog(meta=meta, road=road_dict, opponents=opp_dims, t=t, ego_frenet=xs, ego_cartesian=ego_cart,
                  opp_cartesian=opp_cart, opp_frenet=opp_fr, collision=coll, a_lat=a_lat, control=us,
                  time_prepare=tp, time_feedback=tf, time_total=tp + tf, qp_iter=qi, qp_status=qs,
                  max_slack=slack, ego=dims(problem.ego))
