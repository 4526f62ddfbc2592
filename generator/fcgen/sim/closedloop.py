"""Closed loop: plant (the same RK4 Frenet model), opponents, a controller (Python reference or compiled C), log."""

from __future__ import annotations

import math
import threading
from collections.abc import Iterable
from functools import lru_cache
from typing import Protocol

import numpy as np

from .. import extras
from ..collision import collisions_over_run
from ..contract import StepResult
from ..dsl import Problem, Vehicle
from ..ocp import Ocp, build_ocp, road_window_samples
from ..plant import plant_function
from ..reference import RtiSolver, SolverError
from ..road import LeftRoad, Road, RoadWindowParams, check_frenet
from .perturbed import PerturbedRun, left_road, perturbed_fields, perturbed_meta, run_perturbed
from .plants import PlantSpec
from .prediction import opponent_horizon
from .runlog import RunLog, make_meta
from .scenario import OpponentParams, Scenario
from .standstill import rolls_back, stopped

WINDOW_BEHIND = 50.0  # m of road the solver's window keeps behind the ego (covers an opponent being overtaken)

#: what ``run_closed_loop``/``replay`` log of each sample's planned trajectory (optional run-log fields)
PLAN_LEVELS: tuple[str, ...] = ("none", "controls", "full")


class Controller(Protocol):
    """One closed-loop controller: the Python reference or a compiled C solver.

    A controller may also offer ``window_stepper(road, samples)``: a function ``step(x0, s_start, opp)`` that does
    what ``step(x0, road.window(s_start, samples), opp)`` does, for many samples on one road (``CSolver``: without
    building each window); ``run_closed_loop`` uses it when it is there."""

    kind: str

    def step(self, x0: np.ndarray, road: Road, opp: np.ndarray) -> StepResult: ...


def solver_window(problem: Problem, road: Road, x: np.ndarray) -> Road:
    """The road window the solver gets at measured state ``x``: from ``WINDOW_BEHIND`` m behind the ego on, from the
    road's start at the latest (raises ``road.LeftRoad`` past its end)."""
    return road.window(max(float(x[0]) - WINDOW_BEHIND, road.s0), problem.road.samples)


def _solver_call(problem: Problem, road: Road, controller, step, horizon):
    """``solve(j, x)``: the controller's step at sample ``j`` on measured state ``x`` with ``solver_window``'s window
    (through the controller's ``window_stepper`` ``step`` where it has one: the same window without building it)."""

    def solve(j: int, x: np.ndarray) -> StepResult:
        s_start = max(x.item(0) - WINDOW_BEHIND, road.s0)
        if step is not None:
            return step(x, s_start, horizon(j + problem.delay))
        return controller.step(x, road.window(s_start, problem.road.samples), horizon(j + problem.delay))

    return solve


class PlanLog:
    """Collects the optional run-log fields of each sample: exit code and (``plan``) the planned trajectory."""

    def __init__(self, K: int, N: int, plan: str = "none"):
        if plan not in PLAN_LEVELS:
            raise ValueError(f"plan = {plan!r} is invalid: allowed {', '.join(PLAN_LEVELS)}")
        self.plan, self.K, self.N = plan, K, N
        self.exit_code = np.zeros(K, dtype=np.int64)
        self.states: list[np.ndarray] = []
        self.controls: list[np.ndarray] = []

    def add(self, j: int, controller, r: StepResult) -> None:
        """Record sample ``j``: its exit code and the controller's plan (NaN when the call failed)."""
        self.exit_code[j] = r.exit_code
        if self.plan == "none":
            return
        xs, us = controller.plan()
        if r.exit_code:
            xs, us = np.full_like(xs, np.nan), np.full_like(us, np.nan)
        self.controls.append(np.asarray(us, dtype=float))
        if self.plan == "full":
            self.states.append(np.asarray(xs, dtype=float))

    def truncate(self, K: int) -> None:
        """Keep the first ``K`` samples (a run that ended early)."""
        self.K, self.exit_code = K, self.exit_code[:K]
        del self.states[K:], self.controls[K:]

    def fields(self) -> dict:
        """The optional ``RunLog`` fields."""
        out: dict = {"exit_code": self.exit_code}
        if self.plan != "none":
            out["plan_controls"] = np.array(self.controls).reshape(self.K, self.N, -1)
        if self.plan == "full":
            out["plan_states"] = np.array(self.states).reshape(self.K, self.N + 1, -1)
        return out


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
                return StepResult(
                    u,
                    0,
                    st.qp_status,
                    st.qp_iter,
                    st.time_prepare,
                    st.time_feedback,
                    float(np.max(sv.slacks(), initial=0.0)),
                    st.plan_reaction,
                    st.a_lat_guard,
                )
            except SolverError as exc:
                rc = exc.exit_code
        st = sv.status  # the control after an error: the fallback (unusable QP) or the last one (rejected call)
        return StepResult(
            sv.u0(),
            rc,
            st.qp_status,
            st.qp_iter,
            st.time_prepare,
            st.time_feedback,
            math.nan,
            st.plan_reaction,
            st.a_lat_guard,
        )

    def step(self, x0: np.ndarray, road: Road, opp: np.ndarray) -> StepResult:
        return self.feedback_phase(x0, self.prepare_phase(x0, road, opp))

    def set_opponent_shapes(self, shapes: np.ndarray) -> int:
        """Every opponent's shape values (``obstacles.shape_names``); returns the exit code (as the C's)."""
        try:
            self.solver.set_opponent_shapes(shapes)
        except SolverError as exc:
            return exc.exit_code
        return 0

    def set_reference(self, v_ref: float, n_ref: float) -> int:
        """The tracking reference's speed and lateral offset; returns the exit code (as the C's)."""
        try:
            self.solver.set_reference(v_ref, n_ref)
        except SolverError as exc:
            return exc.exit_code
        return 0

    def set_reference_stages(self, v_ref, n_ref) -> int:
        """The reference per node (N+1 values each; ``fcgen.stage_inputs``); returns the exit code (as the C's)."""
        return self._code(self.solver.set_reference_stages, v_ref, n_ref)

    def set_obstacle_margins(self, margins) -> int:
        """The obstacle margin per stage (N+1 values, >= 0); returns the exit code (as the C's)."""
        return self._code(self.solver.set_obstacle_margins, margins)

    @staticmethod
    def _code(call, *args) -> int:
        try:
            call(*args)
        except SolverError as exc:
            return exc.exit_code
        return 0

    def plan(self) -> tuple[np.ndarray, np.ndarray]:
        """The planned trajectory of the last solution: states (N+1, nx), controls (N, nu)."""
        return self.solver.states(), self.solver.controls()


class Plant:
    """``plant_function`` evaluated through a CasADi ``FunctionBuffer``: the same SX evaluation as ``plant(x, u, p)``
    (bit for bit) without its per-call conversions to and from ``DM`` (~1 us instead of ~65 us a sample); a sample
    that would take ``v >= 0`` below 0 stops the vehicle instead (``standstill``)."""

    def __init__(self, problem: Problem, samples: int):
        self.problem, self.samples = problem, samples
        self.function = plant_function(problem, samples)
        self.road_params = RoadWindowParams(samples)
        self._x, self._u, self._p, self._out = np.zeros(5), np.zeros(2), np.zeros(self.road_params.size), np.zeros(5)
        self._buf, self._eval = self.function.buffer()
        # casadi's stub asks for a size that its binding takes from the buffer
        for i, a in enumerate((self._x, self._u, self._p)):
            self._buf.set_arg(i, memoryview(a))  # type: ignore[call-arg, arg-type]
        self._buf.set_res(0, memoryview(self._out))  # type: ignore[call-arg, arg-type]

    def step(self, x: np.ndarray, u: np.ndarray, road: Road) -> np.ndarray:
        """The state one sample after ``x`` under control ``u`` on the whole ``road`` (window from one sample behind
        ``x``'s segment, as the NLP's stage parameters)."""
        i0 = math.floor((x[0] - road.s0) / road.ds) - 1
        self._x[:] = x
        self._u[:] = u
        self.road_params.pack_into(self._p, road, i0)
        self._eval()
        if rolls_back(x, self._out):  # standstill: the vehicle stops, it does not roll backwards
            return stopped(self.problem, self.samples, x, u, self._p, self._out)
        return self._out.copy()

    def road_stepper(self, road: Road):
        """``step`` on one road as a function ``step(x, u)`` (the same values, bit for bit) that copies the packed
        window parameters from a table of every window of ``road`` (built here, once) instead of packing them per
        call; it returns the plant's output buffer, overwritten by the next call. The closed loop's plant on the
        paper's roads: a state at the road's centre of curvature raises ``road.FrenetSingular``
        (``road.check_frenet``)."""
        rp, K = self.road_params, self.road_params.samples
        table = _window_table(road, K) if _frozen(road) else _build_window_table(road, K)
        n = len(table)
        xb, ub, pb, out, ev = self._x, self._u, self._p, self._out, self._eval
        s0, ds, floor, pr = road.s0, road.ds, math.floor, self.problem

        def step(x: np.ndarray, u: np.ndarray) -> np.ndarray:
            i0 = int(floor((x.item(0) - s0) / ds)) - 1  # a float's arithmetic: the same as on x[0]
            xb[:] = x
            ub[:] = u
            if 0 <= i0 < n:
                pb[:] = table[i0]
            else:
                rp.pack_into(pb, road, i0)  # raises road.LeftRoad
            check_frenet(x, pb)
            ev()
            if out.item(3) < 0.0 <= x.item(3):  # standstill (rolls_back): the vehicle stops, it does not roll back
                return stopped(pr, K, x, u, pb, out)
            return out

        return step


def _frozen(road: Road) -> bool:
    """Whether a road's arrays are read-only (``scenario.realistic_road``'s, kept per process): what is derived from
    it alone can be kept too."""
    return not any(np.asarray(a).flags.writeable for a in (road.kappa, road.phi, road.gx, road.gy))


def _build_window_table(road: Road, samples: int) -> np.ndarray:
    """Row i0: ``RoadWindowParams(samples).pack(road, i0)``, for every window inside the road (read-only)."""
    rp, K = RoadWindowParams(samples), samples
    n = road.size - K + 1
    cols = np.empty((rp.size, max(n, 0)))  # built column-wise (whole-road slices), used row-wise
    if n > 0:
        cols[0] = road.s0 + np.arange(n) * road.ds  # pack_into's road.s0 + i0 * road.ds, for every i0
        cols[1] = road.ds
        for j, a in enumerate((road.kappa, road.phi, road.gx, road.gy)):
            for k in range(K):
                cols[2 + j * K + k] = a[k : k + n]
    table = np.ascontiguousarray(cols.T)
    table.flags.writeable = False
    return table


@lru_cache(maxsize=32)
def _window_table(road: Road, samples: int) -> np.ndarray:
    """``_build_window_table`` of a read-only road, kept per process (a campaign's configurations drive one seed's
    road one after the other; the key holds the road, compared by identity)."""
    return _build_window_table(road, samples)


_OPP_TABLES: dict = {}
_OPP_LOCK = threading.Lock()


def opponent_params(problem: Problem, sc: Scenario) -> OpponentParams:
    """``OpponentParams(problem, sc)``; for a scenario on a read-only road kept per process (the last 32) and shared by
    the runs whose opponents' table is the same: same road object, opponents' start s and lanes, samples, dt and
    horizon (a campaign runs one seed's scenario in each of its configurations)."""
    if not _frozen(sc.road):
        return OpponentParams(problem, sc)
    a, b = np.asarray(sc.opp_s0), np.asarray(sc.opp_n)
    key = (
        sc.road,
        a.dtype.str,
        a.shape,
        a.tobytes(),
        b.dtype.str,
        b.shape,
        b.tobytes(),
        sc.samples,
        sc.dt,
        problem.horizon.offsets,
    )
    with _OPP_LOCK:
        op = _OPP_TABLES.pop(key, None)
    if op is None:
        op = OpponentParams(problem, sc)
    with _OPP_LOCK:
        _OPP_TABLES[key] = op
        while len(_OPP_TABLES) > 32:
            del _OPP_TABLES[next(iter(_OPP_TABLES))]
    return op


def dims(v: Vehicle) -> dict:
    return {"l_f": v.l_f, "l_r": v.l_r, "l_r_ch": v.l_r_ch, "l_f_ch": v.l_f_ch, "w_ch": v.w_ch}


def _meta(problem: Problem, sc: Scenario, kind: str, planlog: PlanLog, results: list[StepResult], more: dict) -> dict:
    """The run log's ``meta`` of a closed loop: the problem, the scenario, the controller and the counts of exit
    codes, plan reactions and a_lat guard actions (and ``more`` of them: a perturbed run's)."""
    return make_meta(
        problem=problem.name,
        formulation=problem.formulation.kind,
        obstacle_model=problem.obstacles.kind,
        scenario=sc.name,
        seed=sc.seed,
        N=problem.horizon.N,
        dt=problem.horizon.dt,
        controller=kind,
        n_bound=problem.bounds.n_max,
        extra={
            "exit_codes_nonzero": int(np.count_nonzero(planlog.exit_code)),
            "plan_reactions": int(sum(r.plan_reaction for r in results)),
            "a_lat_guards": int(sum(r.a_lat_guard > 0 for r in results)),
            **more,
        },
    )


def _run_log(
    problem: Problem,
    sc: Scenario,
    kind: str,
    xs: np.ndarray,
    us: np.ndarray,
    results: list[StepResult],
    planlog: PlanLog,
    opp_params: OpponentParams,
    store_exit_codes: bool,
    with_plan_fields: bool,
    pert: tuple[PlantSpec, PerturbedRun] | None = None,
    ended: dict | None = None,
) -> RunLog:
    """The run log of a finished closed loop: the per-sample statistics of ``results`` (and their exit codes into
    ``planlog`` when ``store_exit_codes``: no plan was logged), the Cartesian poses, the collisions on the true
    rectangles, a_lat, the meta data; ``planlog``'s fields when ``with_plan_fields``; ``pert``: a perturbed run's
    plant a_lat, meta entries and optional fields (``sim.perturbed``)."""
    K = len(results)
    road = sc.road
    tp, tf = np.zeros(K), np.zeros(K)
    qi, qs = np.zeros(K, dtype=np.int64), np.zeros(K, dtype=np.int64)
    slack = np.zeros(K)
    # the per-sample statistics, a list per array (assigned element by element, as one store per sample would)
    for a, key in (
        (tp, "time_prepare"),
        (tf, "time_feedback"),
        (qi, "qp_iter"),
        (qs, "qp_status"),
        (slack, "max_slack"),
    ) + (((planlog.exit_code, "exit_code"),) if store_exit_codes else ()):
        a[:] = [getattr(r, key) for r in results]
    t = np.arange(K + 1, dtype=np.float64) * np.float64(sc.dt)
    ex, ey, ephi = road.to_cartesian(xs[:, 0], xs[:, 1], xs[:, 2])
    ego_cart = np.stack([ex, ey, ephi], axis=1)
    # sc.opp_cartesian(t): the rows of the opponents' table the solver was given (the same values, not computed again)
    opp_cart = np.array(opp_params.samples(K))
    opp_fr = sc.opp_frenet(t)
    opp_dims = [dims(problem.opponents.vehicle)] * len(sc.opp_s0)
    coll = collisions_over_run(ego_cart, dims(problem.ego), opp_cart, opp_dims).any(axis=1)
    a_lat = xs[:, 3] ** 2 * np.tan(xs[:, 4]) / problem.ego.l if pert is None else np.asarray(pert[1].a_lat)
    more = perturbed_meta(*pert) if pert is not None else {}
    if ended is not None:
        more["ended_early"] = ended
    meta = _meta(problem, sc, kind, planlog, results, more)
    road_dict = {
        "s": road.s,
        "kappa": road.kappa,
        "gamma_x": road.gx,
        "gamma_y": road.gy,
        "phi_gamma": road.phi,
        "ds": road.ds,
    }
    return RunLog(
        meta=meta,
        road=road_dict,
        opponents=opp_dims,
        t=t,
        ego_frenet=xs,
        ego_cartesian=ego_cart,
        opp_cartesian=opp_cart,
        opp_frenet=opp_fr,
        collision=np.asarray(coll, dtype=bool),
        a_lat=a_lat,
        control=us,
        time_prepare=tp,
        time_feedback=tf,
        time_total=tp + tf,
        qp_iter=qi,
        qp_status=qs,
        max_slack=slack,
        ego=dims(problem.ego),
        **(planlog.fields() if with_plan_fields else {}),
        **(perturbed_fields(pert[1]) if pert is not None else {}),
    )


def _perturbed(problem: Problem, sc: Scenario, spec: PlantSpec, controller, solve, plant_step, add):
    """``run_closed_loop``'s samples with ``spec``'s plant and perturbations (``sim.perturbed``): the same controller
    calls (``solve``) on the measured state."""
    hook = (lambda j, r: add(j, controller, r)) if add else None
    return run_perturbed(problem, sc, spec, solve, lambda x, u: plant_step(x, u).copy(), hook)


def run_closed_loop(
    problem: Problem,
    sc: Scenario,
    controller: Controller | None = None,
    ocp: Ocp | None = None,
    progress: bool = False,
    exit_codes: bool = False,
    plan: str = "none",
    plant: PlantSpec | None = None,
) -> RunLog:
    """Simulate ``sc.samples`` samples; returns the run log (SPEC section 7 metrics).

    ``exit_codes``: log each sample's exit code (optional field ``exit_code``); ``plan`` (``PLAN_LEVELS``): also log
    the planned controls (``"controls"``) or controls and states (``"full"``) of every sample; either needs a
    controller with ``plan()``. ``plant``: another plant or perturbations (``sim.plants``, docs/plants.md); the
    default is fcgen's own model, measured exactly, without latency.
    """
    spec = plant or PlantSpec()
    if controller is None:
        ocp = ocp or build_ocp(problem)
        controller = ReferenceController(ocp)
    model_plant = Plant(problem, ocp.road_params.samples if ocp is not None else road_window_samples(problem))
    opp_params = opponent_params(problem, sc)
    K = sc.samples
    road = sc.road
    xs = np.zeros((K + 1, 5))
    xs[0] = sc.x0
    us = np.zeros((K, 2))
    planlog = PlanLog(K, problem.horizon.N, plan)
    it: Iterable[int] = range(K)
    if progress:
        it = extras.progress(it, desc=f"{problem.name} seed {sc.seed}", unit="sample", leave=False)
    stepper = getattr(controller, "window_stepper", None)
    step = stepper(road, problem.road.samples) if stepper is not None else None
    plant_step, results = model_plant.road_stepper(road), []
    horizon = opponent_horizon(problem, sc, spec, opp_params, controller)  # the truth, or its prediction
    add = planlog.add if plan != "none" else None  # without a plan: the exit codes are stored after the loop
    solve = _solver_call(problem, road, controller, step, horizon)
    pert = None if spec.is_default else _perturbed(problem, sc, spec, controller, solve, plant_step, add)
    if pert is not None:  # another plant or perturbations: that loop instead of this one
        xs, us, results, it = pert.xs, pert.us, pert.results, range(0)
    ended = None if pert is None else pert.ended
    for j in it:
        x = xs[j]
        try:
            r = solve(j, x)
            us[j] = r.u
            if add is not None:
                add(j, controller, r)
            results.append(r)
            xs[j + 1] = plant_step(x, us[j])
        except LeftRoad as exc:  # the solver's window or the plant's: the run ends at sample j
            ended = left_road(j, x, road, exc)
            break
    if ended is not None:  # the run ends with the last sample whose next state is known
        K = ended["sample"]
        xs, us, results = xs[: K + 1], us[:K], results[:K]
        planlog.truncate(K)
    with_plan_fields = exit_codes or plan != "none"
    return _run_log(
        problem,
        sc,
        controller.kind,
        xs,
        us,
        results,
        planlog,
        opp_params,
        add is None,
        with_plan_fields,
        None if pert is None else (spec, pert),
        ended,
    )
