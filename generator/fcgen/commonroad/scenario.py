"""Load a CommonRoad scenario as what fcgen drives: the road with its band, the ego's start and reference speed, the
obstacles; or refuse it with one line naming the reason.

- **Ego**: the planning problem's initial state (CommonRoad's position is the vehicle's centre: fcgen's state is the
  rear axle, half the ego's wheelbase behind it), its speed, steering angle 0; its heading relative to the road in
  [-pi, pi] (CommonRoad allows any real orientation: -3.351 on a road heading 2.932 is alpha -0.019, not -6.302).
- **Reference speed** (``v_ref_source``): the goal's (``goal.goal_speed``): the initial speed (the ego keeps the
  traffic's speed where the goal allows it: the recorded traffic does not react to an ego that slows down) brought
  into the speeds that reach the goal position within its time window, into the goal's speed interval, at most the
  initial lanelet's speed limit and ``v_max``.
- **Samples** (``samples_source``): to the end of the goal's time interval, else to the last recorded obstacle step,
  at least 1.
"""

from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..dsl import Vehicle
from ..extras import require
from ..road import Road, wrap_angle
from .drivable import check_drivable, check_goal_ahead
from .goal import goal_centres, goal_extent, goal_frenet, goal_speed, speed_limit, timing_of
from .reference_path import build_road, initial_lanelet, lanelet_chain
from .traffic import CrObstacle, ScenarioRefused, obstacle_from


@dataclass(frozen=True, eq=False)
class CrScenario:
    """A CommonRoad scenario as fcgen drives it."""

    name: str
    dt: float
    first_step: int  # the planning problem's initial time step: closed-loop sample j is step first_step + j
    samples: int
    road: Road  # with the drivable band n_min / n_max
    x0: np.ndarray  # ego Frenet state of the rear axle [s, n, alpha, v, delta]
    v_ref: float
    v_ref_source: str  # "speed limit", "goal velocity" or "initial speed"
    samples_source: str  # "goal time" or "recording"
    obstacles: tuple[CrObstacle, ...]
    ego_length: float
    ego_width: float
    planning_problem_id: int
    road_info: dict = field(default_factory=dict)
    scenario: object = None  # the commonroad-io Scenario (checker, writer, renderer)
    planning_problem: object = None
    file: str = ""  # the XML's file name and sha256 (a suite keeps a copy; regress finds it by them)
    sha256: str = ""
    goal_sn: tuple[float, float] | None = None  # the goal position's centre (s, n) on the road (None: no position)
    v_goal: float = 0.0  # the reference speed once the goal is within the horizon's reach (goal.goal_speed)
    v_goal_source: str = ""
    goal_timing: object = None  # goal.GoalTiming: the per-sample reference speed's goal (None: none)
    goal_extent: tuple | None = None  # goal.goal_extent: the goal position's extent on the road (None: no position)


def load_scenario(
    path: str | Path,
    planning_problem_id: int | None = None,
    *,
    ego: Vehicle,
    ds: float = 2.0,
    horizon_s: float = 4.0,
    v_max: float = 40.0,
    window_m: float = 280.0,
    behind_m: float = 50.0,
    kappa_max: float | None = None,  # the car's largest curvature (what it can drive: ``drivable``; None: not checked)
) -> CrScenario:
    """Read ``path`` (CommonRoad XML) for an ego ``ego`` on fcgen's road grid ``ds``. The reference path must reach
    the horizon (``horizon_s`` at the larger of the initial and the reference speed) ahead of the ego's start; the road
    reaches as far as the run can take the ego at ``v_max`` plus the solver's road ``window_m``. Raises
    ``ScenarioRefused``."""
    scenario, pp, planning_problem_id = _read(path, planning_problem_id)
    name = str(scenario.scenario_id)
    dt = float(scenario.dt)
    listed = sorted([*scenario.dynamic_obstacles, *scenario.static_obstacles], key=lambda o: o.obstacle_id)
    obstacles = tuple(obstacle_from(ob, dt) for ob in listed)
    st = pp.initial_state
    heading, centre = float(st.orientation), np.asarray(st.position, dtype=float)
    rear = centre - (ego.l / 2) * np.array([math.cos(heading), math.sin(heading)])
    net = scenario.lanelet_network
    first = initial_lanelet(net, centre, heading)
    goals = {lid for ids in (pp.goal.lanelets_of_goal_position or {}).values() for lid in ids}
    v0 = float(getattr(st, "velocity", 0.0) or 0.0)
    limit = speed_limit(net, first)
    ahead = [float(np.hypot(*(c - centre))) for c in goal_centres(pp)]
    v_ref, v_src = goal_speed(pp, v0, dt, ahead[0] if ahead else None, limit, v_max)
    step0 = int(st.time_step)
    samples, s_src = run_length(pp, obstacles, step0)
    horizon_m = horizon_s * max(v0, v_ref)
    chain = lanelet_chain(net, first, goals, horizon_m, behind_m, centre)
    road, info = build_road(net, chain, centre, ds, behind_m, horizon_m, samples * dt * v_max + window_m)
    goal_sn, extent = goal_frenet(pp, road), goal_extent(pp, road)
    s_centre = float(road.to_frenet(np.array([centre[0]]), np.array([centre[1]]), np.array([0.0]))[0][0])
    v_goal, g_src = v_ref, v_src
    timing = timing_of(pp, dt, None if extent is None else extent[0], v0, limit, v_max)
    if goal_sn is not None:  # the distance along the reference path (the straight line's above only sized the horizon)
        v_goal, g_src = goal_speed(pp, v0, dt, goal_sn[0] - s_centre, limit, v_max)
        v_ref, v_src = goal_speed(pp, v0, dt, goal_sn[0] - s_centre, limit, v_max, near=False)
    if info["path_ahead_m"] < horizon_m:
        raise ScenarioRefused(
            f"{name}: the reference path reaches {info['path_ahead_m']:.0f} m ahead of the ego, "
            f"shorter than the horizon's {horizon_m:.0f} m",
            kind="path shorter than the horizon",
        )
    s, n, a = road.to_frenet(np.array([rear[0]]), np.array([rear[1]]), np.array([heading]))
    x0 = np.array([float(s[0]), float(n[0]), wrap_angle(float(a[0])), v0, 0.0])  # a heading given with whole turns
    reach_m, steps = samples * dt * max(v0, v_ref) + horizon_m, range(step0, step0 + samples + 1)
    check_drivable(net, road, first, goals, obstacles, float(x0[0]), reach_m, steps, kappa_max, ego)
    check_goal_ahead(None if extent is None else extent[0], s_centre)
    digest = hashlib.sha256(Path(path).read_bytes()).hexdigest()
    return CrScenario(
        name,
        dt,
        step0,
        samples,
        road,
        x0,
        v_ref,
        v_src,
        s_src,
        obstacles,
        ego.l_ch,
        ego.w_ch,
        int(planning_problem_id),
        info,
        scenario,
        pp,
        Path(path).name,
        digest,
        goal_sn,
        v_goal,
        g_src,
        timing,
        extent,
    )


def _read(path: str | Path, planning_problem_id: int | None):
    """The commonroad-io scenario of ``path``, its planning problem ``planning_problem_id`` (default: the lowest id)
    and that id. Raises ``ScenarioRefused``."""
    with require("commonroad", "reading a CommonRoad scenario"):
        from commonroad.common.file_reader import CommonRoadFileReader

    try:
        scenario, pps = CommonRoadFileReader(str(path)).open()
    except Exception as exc:  # noqa: BLE001 - whatever commonroad-io raises on a file it cannot read
        raise ScenarioRefused(
            f"{Path(path).name}: not a readable CommonRoad file ({type(exc).__name__}: "
            f"{str(exc).splitlines()[0] if str(exc) else ''})",
            kind="unreadable file",
        ) from None
    name = str(scenario.scenario_id)
    problems = pps.planning_problem_dict
    if not problems:
        raise ScenarioRefused(f"{name}: no planning problem", kind="no planning problem")
    if planning_problem_id is None:
        planning_problem_id = sorted(problems)[0]
    if planning_problem_id not in problems:
        raise ScenarioRefused(
            f"{name}: no planning problem {planning_problem_id} (it has {sorted(problems)})", kind="no planning problem"
        )
    if not problems[planning_problem_id].goal.state_list:
        raise ScenarioRefused(f"{name}: planning problem {planning_problem_id} has no goal state", kind="no goal")
    return scenario, problems[planning_problem_id], planning_problem_id


def run_length(pp, obstacles, step0: int) -> tuple[int, str]:
    """Closed-loop samples (module docstring)."""
    ends = [int(gs.time_step.end) for gs in pp.goal.state_list if getattr(gs, "time_step", None) is not None]
    if ends:
        return max(1, max(ends) - step0), "goal time"
    last = max((ob.last_step for ob in obstacles if not ob.static), default=step0 + 1)
    return max(1, last - step0), "recording"
