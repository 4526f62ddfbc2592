"""A closed loop on a CommonRoad scenario (``fcgen.commonroad``): its road with the drivable band, its recorded
traffic as the opponents' predictions, its ego start and speed; judged by fcgen's own rectangle check and by the
CommonRoad drivability checker.

Per sample ``j`` (scenario time step ``sc.first_step + j``): the ``NOPP`` most relevant obstacles
(``commonroad.select_opponents``) fill the solver's opponent slots with their predicted centre poses over the horizon
and their shapes (``set_opponent_shapes`` when a slot's occupant changes); the road window and its band go to the
solver as in the paper's loop; the plant is the same kinematic model. The reference is ``set_reference(v_ref,
n_ref)``: the goal's speed and the target lane's centre (``commonroad.lanes``), per stage during a planned lane change
(``set_reference_stages``).

The solver's lateral bound (``Bounds.road_bound``) on the chassis' corners gets the drivable band shrunk by
``CORNER_MARGIN`` (each corner's row takes it at the corner's own ``s``); on the rear axle, the band shrunk by half the
ego's width plus ``HEADING_MARGIN`` (what a heading of up to ~4 degrees adds at the chassis' front corners). The
problem's road band ``Bounds.n_min``/``n_max`` stays what it is: where the scenario's band is wider, the solver gets it
cut to that (stated in the log's ``extra.commonroad.band_cut``). A scenario's time step must be the problem's ``dt``
(else the scenario is refused).
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Protocol

import numpy as np

from .. import extras
from .. import obstacles as obs
from ..dsl import Problem
from ..ocp import Ocp, build_ocp
from ..road import Road
from .closedloop import Controller, PlanLog, Plant, ReferenceController, dims, solver_window
from .commonroad_judge import driven, judge_drive
from .commonroad_plant import ScenarioPlant
from .commonroad_status import _plain, goal_line, goal_status, unsolved_status
from .cr_prediction import seen_traffic
from .plants import PlantSpec
from .runlog import RunLog, make_meta

if TYPE_CHECKING:
    from ..commonroad.follow import Following, LeadRows

__all__ = ["CommonRoadRun", "goal_line", "goal_status", "run_commonroad", "scenario_road", "unsolved_status"]


class ScenarioController(Controller, Protocol):
    """A controller a CommonRoad run drives: it also takes the scenario's reference speed and its occupants' shapes."""

    def set_reference(self, v_ref: float, n_ref: float) -> int: ...

    def set_reference_stages(self, v_ref, n_ref) -> int: ...

    def set_opponent_shapes(self, shapes: np.ndarray) -> int: ...


@dataclass(frozen=True, eq=False)
class CommonRoadRun:
    """One run on a scenario: the run log (its ``extra.commonroad`` holds the verdicts) and the verdicts."""

    log: RunLog
    checker: dict  # the drivability checker's verdict (``commonroad.drivability_verdict``)
    fcgen: dict  # fcgen's rectangle check against every obstacle (``commonroad.fcgen_collisions``)
    responsibility: str  # of the first collision by fcgen's check ("" without one; rule: sim/collision_kind.py)
    ego_centres: np.ndarray  # (K + 1, 3) the ego's chassis centre poses (the solution file's and the checker's)
    scenario: object = None  # the CrScenario as driven (reactive traffic: the vehicles' driven trajectories)

    @property
    def ego_states(self) -> np.ndarray:
        """(K + 1, 5): the ego's chassis centre [x, y, phi] (CommonRoad's position), speed and steering angle per
        sample (the solution file's)."""
        f = np.asarray(self.log.ego_frenet)
        return np.column_stack([self.ego_centres, f[:, 3], f[:, 4]])

    @property
    def agree(self) -> bool:
        """Whether the two checks give the same collision verdict."""
        return bool(self.checker["collision"]) == bool(self.fcgen["collision"])


HEADING_MARGIN = 0.25  # m: the rear axle's band's extra shrink for the chassis' corners at a small heading
CORNER_MARGIN = 0.15  # m: the corners' band's shrink (the linearisation at the previous plan, the samples between)
LANE_DRIFT = 0.05  # m: the lateral reference follows its lane's centre when it moves more than this


def band_inset(problem: Problem) -> float:
    """How far the solver's band lies inside the drivable band: ``CORNER_MARGIN`` for the chassis' corners, half the
    ego's width plus ``HEADING_MARGIN`` for its rear axle (``Bounds.road_bound``)."""
    if problem.bounds.road_bound == "corners":
        return CORNER_MARGIN
    return problem.ego.w_ch / 2 + HEADING_MARGIN


def scenario_road(problem: Problem, sc) -> tuple[Road, float]:
    """The scenario's road with the band the solver's road rows get (``band_inset``), cut to the problem's ``Bounds``
    (the solver refuses a wider one); and how much was cut at most (m, 0: none)."""
    road, b = sc.road, problem.bounds
    inset = band_inset(problem)
    lo0, hi0 = road.n_min + inset, road.n_max - inset
    lo, hi = np.maximum(lo0, b.n_min), np.minimum(hi0, b.n_max)
    cut = float(max(np.max(lo - lo0), np.max(hi0 - hi), 0.0))
    if np.any(lo >= hi):
        i = int(np.flatnonzero(lo >= hi)[0])
        from ..commonroad import ScenarioRefused

        raise ScenarioRefused(
            f"scenario {sc.name}: the drivable band at s = {road.s[i]:.1f} m lies outside the problem's "
            f"[{b.n_min}, {b.n_max}] m",
            kind="band outside the bounds",
        )
    return Road(road.s0, road.ds, road.kappa, road.phi, road.gx, road.gy, lo, hi), cut


def run_commonroad(
    problem: Problem,
    sc,
    controller: ScenarioController | None = None,
    ocp: Ocp | None = None,
    plan: str = "none",
    progress: bool = False,
    states: np.ndarray | None = None,
    change_time: float | None = None,
    traffic: str = "recorded",
    band: str = "lanes",
    plant: PlantSpec | None = None,
    criticality: bool = True,
    follow: Following | str | None = "profile",
) -> CommonRoadRun:
    """Run ``sc.samples`` samples of a loaded CommonRoad scenario (``fcgen.commonroad.load_scenario``). ``states``
    (K + 1, 5): a replay (``fcgen regress``): the controller gets these measured states instead of the
    plant's, sample by sample, and the log keeps them. ``change_time``: a lane change's per-stage ``n_ref`` over that
    many seconds (default ``commonroad.lanes.CHANGE_TIME``; 0: the target's centre at once on every stage).
    ``traffic``: ``recorded`` (the recordings) or ``reactive`` (``commonroad.reactive``: the run is judged on what the
    vehicles drove). ``band``: the solver's lateral band (``commonroad.band.BAND_RULES``). ``plant``: the plant and
    its perturbations (``sim.commonroad_plant``; default fcgen's model). ``criticality``: False: not measured.
    ``follow``: the speed reference behind the vehicle ahead and the lane rule's gap ahead (``commonroad.follow``);
    ``"profile"``: the problem's profile's (``follow.profile_following``: the safe profile's, none for the paper's);
    None: neither."""
    from .. import commonroad as cr
    from ..commonroad.reactive import ReactiveTraffic, check_traffic

    if not math.isclose(sc.dt, problem.horizon.dt, rel_tol=1e-9):
        raise cr.ScenarioRefused(
            f"scenario {sc.name}: its time step {sc.dt} s is not the problem's dt {problem.horizon.dt} s",
            kind="time step",
        )
    if controller is None:
        ocp = ocp or build_ocp(problem)
        controller = ReferenceController(ocp)
    road, cut = scenario_road(problem, sc)
    model = Plant(problem, ocp.road_params.samples if ocp is not None else build_ocp(problem).road_params.samples)
    spec = plant or PlantSpec()
    world_plant = ScenarioPlant(problem, spec, model, sc.x0, road)
    world = ReactiveTraffic(sc, problem.ego.l_ch) if check_traffic(traffic) == "reactive" else None
    from ..commonroad.follow import follow_log, profile_following

    rule = profile_following(problem) if isinstance(follow, str) and follow == "profile" else follow
    if isinstance(rule, str):
        raise ValueError(f"follow = {follow!r}: allowed 'profile', None or a commonroad.follow.Following")
    loop = _drive(problem, sc, controller, road, world_plant, plan, progress, states, change_time, world, band, rule)
    sc = driven(sc, world)  # judged on what the vehicles drove
    v = judge_drive(problem, sc, road, loop.xs, criticality=criticality)
    checker, own, who, centres = v.checker, v.fcgen, v.responsibility, v.centres
    extra = {
        **_loop_extra(loop, spec, world_plant),
        "commonroad": {
            "scenario": sc.name,
            "file": sc.file,
            "sha256": sc.sha256,
            "planning_problem": sc.planning_problem_id,
            "v_ref": float(sc.v_ref),
            "v_ref_samples": loop.v_refs,
            "n_ref": float(loop.lane_changes[0][1]) if loop.lane_changes else 0.0,
            "lane_changes": loop.lane_changes,
            "band_cut": cut,
            "band": {"rule": band, "way_back_samples": loop.way_back},
            "follow": follow_log(rule, loop.followed, loop.lead_rows),
            "obstacle_ids": [int(ob.id) for ob in sc.obstacles],
            "slots": loop.slot_ids,
            "checker": _plain(checker),
            "fcgen": _plain(own),
            "responsibility": who,
            "agree": bool(checker["collision"]) == bool(own["collision"]),
            "unsolved": unsolved_status(loop.results),
            "goal": v.goal,
            "solution": v.solution,
            "traffic": {"mode": "recorded", "reactions": []} if world is None else world.log(),
            "criticality": v.criticality,
        },
    }
    hits = np.asarray((v.pen > 0.0).any(axis=1), dtype=bool)
    log = _run_log(problem, sc, controller.kind, road, loop, v.ego_cart, v.opp_cart, hits, extra)
    return CommonRoadRun(log, checker, own, who, centres, sc)


def _loop_extra(loop, spec: PlantSpec, plant: ScenarioPlant) -> dict:
    """The run log's ``extra`` entries of the loop itself: the samples with an exit code, the plan check's reactions,
    the a_lat guards and (another plant than fcgen's model) the plant and its cut samples."""
    out: dict = {
        "exit_codes_nonzero": int(np.count_nonzero(loop.planlog.exit_code)),
        "plan_reactions": int(sum(r.plan_reaction for r in loop.results)),
        "a_lat_guards": int(sum(r.a_lat_guard > 0 for r in loop.results)),
    }
    if not spec.is_default:
        out.update(plant=spec.as_meta(), plant_cut_samples=int(np.count_nonzero(plant.cut)))
    return out


@dataclass(eq=False)
class _Loop:
    """What the closed loop on a scenario leaves: the ego's states and controls, each sample's step result, the
    scenario obstacles in the solver's slots and the plan log."""

    xs: np.ndarray  # (K + 1, 5) Frenet states
    us: np.ndarray  # (K, 2) controls
    results: list  # each sample's StepResult
    slot_ids: list  # per sample the obstacle id in each opponent slot (-1: empty)
    planlog: PlanLog
    lane_changes: list = field(default_factory=list)  # [sample, n_ref, reason] where the lateral reference changed
    way_back: list = field(default_factory=list)  # the samples whose band the way back widened (commonroad.band)
    v_refs: list = field(default_factory=list)  # the reference speed per sample (commonroad.goal.speed_now)
    followed: int = 0  # the samples whose reference speed the vehicle ahead capped (commonroad.follow)
    lead_rows: LeadRows | None = None  # the leader's rectangle lengthened by the closing speed (commonroad.follow)

    def end_at(self, j: int) -> None:
        """End the run at sample ``j`` (its state the last): ``j`` controls, ``j + 1`` states."""
        self.xs, self.us = self.xs[: j + 1], self.us[:j]
        pl = self.planlog
        pl.K, pl.exit_code = j, pl.exit_code[:j]
        pl.states, pl.controls = pl.states[:j], pl.controls[:j]


def _drive(
    problem: Problem,
    sc,
    controller: ScenarioController,
    road: Road,
    plant: ScenarioPlant,
    plan: str,
    progress: bool,
    states: np.ndarray | None,
    change_time: float | None = None,
    world=None,
    band_rule: str = "lanes",
    follow: Following | None = None,
) -> _Loop:
    """The closed loop: per sample the scenario's opponents into the solver's slots (their shapes when an occupant
    changes), one controller step, one plant step (or the replayed state)."""
    from .. import commonroad as cr
    from ..commonroad.goal import change_time as goal_change
    from ..commonroad.goal import lateral_reference, reached
    from ..commonroad.lanes import CHANGE_TIME, GOAL_LANE, SETTLED, target_lane, traffic_at

    N, n_slots = problem.horizon.N, problem.opponents.count
    K = sc.samples if states is None else len(states) - 1
    loop = _Loop(np.zeros((K + 1, 5)), np.zeros((K, 2)), [], [], PlanLog(K, N, plan))
    loop.xs[:] = sc.x0 if states is None else states  # (a run's later states are the plant's)
    goal_n = None if sc.goal_sn is None else lateral_reference(sc.goal_sn, road)[0]
    bounds = (problem.bounds.n_min, problem.bounds.n_max)
    lane = target_lane(sc, problem.ego.l_ch, goal_n, float(sc.x0[1]), follow is not None, bounds)
    band = solver_band(problem, sc, lane.lanes, band_rule)
    n_ref, v_ref, n_now = None, sc.v_ref, 0.0
    ramp: tuple[float, int, float] | None = None  # a lane change under way: (stage 0's n_ref, its sample, duration)
    change = CHANGE_TIME if change_time is None else change_time
    shapes_in = _SlotShapes(problem, sc, controller, follow, loop)
    it: Iterable[int] = range(K)
    if progress:
        it = extras.progress(it, desc=f"{problem.name} {sc.name}", unit="sample", leave=False)
    half_l, offsets, corners = problem.ego.l / 2, problem.horizon.offsets, problem.bounds.road_bound == "corners"
    goal = sc.planning_problem if states is None else None
    seen = seen_traffic(plant.spec, sc)  # the obstacles as the solver sees them at a sample (``sim.cr_prediction``)
    for j in it:
        x = loop.xs[j]
        rx, ry, rphi = (float(v) for v in road.to_cartesian(x[0], x[1], x[2]))
        centre = (rx + half_l * math.cos(rphi), ry + half_l * math.sin(rphi))
        if j and goal is not None and reached(goal, sc.first_step + j, centre, rphi, float(x[3])):
            loop.end_at(j)  # the goal is reached: the run ends there
            break
        if world is not None:  # reactive traffic: the vehicles' switches and IDM steps from this sample's state
            world.update(j, float(x[0]) + half_l, float(x[1]), float(x[3]))
            sc = world.scenario()
        traffic = traffic_at(sc.obstacles, sc.road, sc.first_step + j, sc.dt)
        n_new, why = lane.update(float(x[0]) + half_l, float(x[1]), float(x[3]), traffic)
        if n_ref is None or abs(n_new - n_ref) > SETTLED:
            loop.lane_changes.append([j, n_new, why])
        t_j = j * problem.horizon.dt
        v_new = _speed_reference(sc, problem, x, t_j, follow, traffic, loop)
        if n_ref is not None and abs(n_new - n_ref) > SETTLED and change > 0.0:  # a new target: planned from now
            ramp = (n_now, j, goal_change(sc.goal_timing, t_j, change) if why == GOAL_LANE else change)
        if n_ref is None or abs(n_new - n_ref) > LANE_DRIFT or v_new != v_ref or ramp is not None:
            n_ref, v_ref = n_new, v_new  # (the lane's centre moves with s)
            since = 0.0 if ramp is None else (j - ramp[1]) * problem.horizon.dt
            ramp = ramp if ramp is not None and since < ramp[2] else None
            n_now = _set_lateral(
                controller, sc.name, problem, v_ref, n_ref, None if ramp is None else (ramp[0], since, ramp[2])
            )
        loop.v_refs.append(float(v_ref))
        ego = (float(x[3]), rphi)  # the relevance rule's speed and heading (``select_opponents``)
        poses, shapes, ids = cr.opponent_horizon(seen(sc, j), j, centre, n_slots, N, offsets, ego, corners)
        shapes_in.set(j, shapes, sc, ids, x)
        loop.slot_ids.append([-1 if i is None else int(i) for i in ids])
        xm = plant.measure(x) if states is None else x  # what the controller measures
        win = solver_window(problem, road, xm)
        if band.set(win, xm, lane.n, bool(loop.results and loop.results[-1].exit_code)):
            loop.way_back.append(j)
        r = controller.step(xm, win, poses)
        loop.us[j] = r.u
        loop.planlog.add(j, controller, r)
        loop.results.append(r)
        if states is None:
            loop.xs[j + 1] = plant.step(x, loop.us[j], road)
    return loop


def solver_band(problem: Problem, sc, lanes: list, rule: str):
    """The rule that makes the solver's band at each sample (``commonroad.band``): the lanes' band shrunk by
    ``band_inset``, cut to the problem's ``Bounds``."""
    from ..commonroad.band import SolverBand

    ego, b = problem.ego, problem.bounds
    corners = b.road_bound == "corners"
    bounds = (b.n_min, b.n_max)
    return SolverBand(rule, lanes, sc.road, band_inset(problem), bounds, ego.l_ch / 2, ego.w_ch / 2, ego.l / 2, corners)


def _set_lateral(controller, name: str, problem: Problem, v_ref: float, n_ref: float, ramp) -> float:
    """``set_reference(v_ref, n_ref)``, or during a lane change (``ramp`` = (n_from, seconds since, duration)) the
    per-stage n_ref of ``lane_change_profile``; returns stage 0's n_ref."""
    from ..commonroad.lanes import lane_change_profile

    if ramp is None:
        rc, n0 = controller.set_reference(v_ref, n_ref), n_ref
    else:
        prof = lane_change_profile(ramp[0], n_ref, ramp[1], problem.horizon.times, ramp[2])
        rc, n0 = controller.set_reference_stages(np.full(len(prof), v_ref), prof), float(prof[0])
    if rc:
        from ..commonroad import ScenarioRefused

        raise ScenarioRefused(
            f"scenario {name}: the solver refuses the reference v_ref {v_ref:.2f} m/s, n_ref {n_ref:.2f} m "
            f"(exit code {rc}; the problem's band [{problem.bounds.n_min}, {problem.bounds.n_max}] m)",
            kind="reference refused",
        )
    return n0


def _speed(sc, t: float, s_c: float, near: bool, traffic, n: float, length: float) -> float:
    """The reference speed at time ``t`` with the ego's centre at ``s_c`` (``commonroad.goal.speed_now``; a scenario
    loaded without the goal's timing: its start's reference, the goal's once near), raised to a faster vehicle's
    closing in from behind in the ego's lane (``commonroad.lanes.keep_ahead``; at most the lane's limit and
    ``v_max``)."""
    from ..commonroad.goal import speed_now
    from ..commonroad.lanes import keep_ahead

    g = sc.goal_timing
    v = (sc.v_goal if near else sc.v_ref) if g is None else speed_now(g, t, s_c, near)[0]
    v_behind = keep_ahead(traffic, n, s_c, v, length)
    if v_behind is None:
        return v
    cap = math.inf if g is None else min(g.v_max, math.inf if g.limit is None else g.limit)
    return max(v, min(v_behind, cap))


def _speed_reference(sc, problem: Problem, x: np.ndarray, t: float, follow: Following | None, traffic, loop: _Loop):
    """The reference speed at state ``x`` and time ``t`` (``_speed``), at most ``follow``'s behind the vehicle ahead
    in the ego's corridor (within half a lane of its centre's ``n``; ``loop.followed`` counts the samples it caps)."""
    half_l = problem.ego.l / 2
    near = _goal_near(sc, problem, x, half_l)
    v = _speed(sc, t, float(x[0]) + half_l, near, traffic, float(x[1]), problem.ego.l_ch)
    if follow is None:
        return v
    from ..commonroad.follow import follow_speed

    s_c, n_c = float(x[0]) + half_l * math.cos(float(x[2])), float(x[1]) + half_l * math.sin(float(x[2]))
    cap = follow_speed(follow, traffic, s_c, (n_c,), problem.ego.l_ch)
    if cap is None or cap >= v:
        return v
    loop.followed += 1
    return cap


def _goal_near(sc, problem: Problem, x: np.ndarray, half_l: float) -> bool:
    """Whether the goal position is within the horizon's reach of the ego's centre (its speed interval applies)."""
    if sc.goal_sn is None or not sc.v_goal:
        return False
    reach = problem.horizon.N * problem.horizon.dt * max(float(x[3]), sc.v_goal) + 2 * half_l
    return sc.goal_sn[0] - (float(x[0]) + half_l) <= reach


class _SlotShapes:
    """The opponent slots' shapes as the controller has them: ``set_opponent_shapes`` only when an occupant's
    (length, width, offset) changes, each shape's values computed once; with ``follow`` the leader's lengthened
    (``commonroad.follow.LeadRows``, kept in ``loop.lead_rows``)."""

    def __init__(self, problem: Problem, sc, controller: ScenarioController, follow=None, loop=None):
        from ..commonroad.follow import LeadRows

        self.problem, self.sc, self.controller = problem, sc, controller
        self.cache: dict[tuple, np.ndarray] = {}
        self.now: tuple | None = None
        self.rows = None if follow is None else LeadRows(follow, problem.horizon.dt)
        if loop is not None:
            loop.lead_rows = self.rows

    def set(self, j: int, shapes, sc=None, ids=(), x=None) -> None:
        """Give the controller the slots' (length, width, offset) of sample ``j`` if they changed (the leader's
        lengthened: ``sc`` as driven at ``j``, the slots' obstacle ids ``ids``, the ego's state ``x``)."""
        if self.rows is not None and sc is not None:
            shapes = self.rows.shapes(sc, sc.first_step + j, ids, shapes, self.problem.ego, x)
        key = tuple(map(tuple, np.asarray(shapes, dtype=float)))
        if key == self.now:
            return
        pb, vals = self.problem, []
        for length, width, offset in key:
            v = self.cache.get((length, width, offset))
            if v is None:
                v = self.cache[(length, width, offset)] = obs.opponent_shape(
                    pb.obstacles, pb.ego, length, width, offset
                )
            vals.append(v)
        rc = self.controller.set_opponent_shapes(np.array(vals).reshape(pb.opponents.count, -1))
        if rc:
            raise ValueError(f"scenario {self.sc.name}: set_opponent_shapes refused at sample {j} (exit code {rc})")
        self.now = key


def _run_log(
    problem: Problem,
    sc,
    controller_kind: str,
    road: Road,
    loop: _Loop,
    ego_cart: np.ndarray,
    opp_cart: np.ndarray,
    collision: np.ndarray,
    extra: dict,
) -> RunLog:
    """The run's log: the ego's states and poses, every scenario obstacle (Cartesian and on the road's Frenet frame,
    NaN where not recorded), the solver's statistics and the verdicts in ``extra``."""
    from ..commonroad.judge import centre_dims

    xs, ego = loop.xs, problem.ego
    opp_dims = [centre_dims(ob.length, ob.width) for ob in sc.obstacles]
    opp_fr = np.full_like(opp_cart, np.nan)
    ok = np.isfinite(opp_cart[..., 0])
    if ok.any():
        s, n, a = road.to_frenet(opp_cart[..., 0][ok], opp_cart[..., 1][ok], opp_cart[..., 2][ok])
        opp_fr[ok] = np.stack([s, n, a], axis=-1)
    meta = make_meta(
        problem=problem.name,
        formulation=problem.formulation.kind,
        obstacle_model=problem.obstacles.kind,
        scenario=sc.name,
        seed=0,
        N=problem.horizon.N,
        dt=problem.horizon.dt,
        controller=controller_kind,
        n_bound=problem.bounds.n_max,
        extra=extra,
    )
    road_dict = {
        "s": road.s,
        "kappa": road.kappa,
        "gamma_x": road.gx,
        "gamma_y": road.gy,
        "phi_gamma": road.phi,
        "ds": road.ds,
    }
    a_lat = xs[:, 3] ** 2 * np.tan(xs[:, 4]) / ego.l
    stats = {
        key: np.array([getattr(r, key) for r in loop.results])
        for key in ("time_prepare", "time_feedback", "qp_iter", "qp_status", "max_slack")
    }
    return RunLog(
        meta=meta,
        road=road_dict,
        opponents=opp_dims,
        t=np.arange(len(xs)) * sc.dt,
        ego_frenet=xs,
        ego_cartesian=ego_cart,
        opp_cartesian=opp_cart,
        opp_frenet=opp_fr,
        collision=collision,
        a_lat=a_lat,
        control=loop.us,
        time_prepare=stats["time_prepare"],
        time_feedback=stats["time_feedback"],
        time_total=stats["time_prepare"] + stats["time_feedback"],
        qp_iter=stats["qp_iter"],
        qp_status=stats["qp_status"],
        max_slack=stats["max_slack"],
        ego=dims(ego),
        **loop.planlog.fields(),
    )
