"""Small CommonRoad scenarios the tests write themselves with commonroad-io: multi-lane roads (straight or a constant
radius bend), a lane that ends, obstacles with given trajectories."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

LANE = 3.5


def _lane_polylines(centre: np.ndarray, normal: np.ndarray, offset: float):
    """Left, centre, right vertices of a lane whose centre is ``offset`` left of the reference ``centre``."""
    c = centre + offset * normal
    return c + 0.5 * LANE * normal, c, c - 0.5 * LANE * normal


def reference(length: float = 400.0, radius: float | None = None, step: float = 2.0):
    """Points and left normals of a straight reference line along x (or a left bend of ``radius`` from the origin)."""
    s = np.arange(0.0, length + 1e-9, step)
    if radius is None:
        pts = np.stack([s, np.zeros_like(s)], axis=1)
        nrm = np.tile([0.0, 1.0], (len(s), 1))
    else:
        th = s / radius
        pts = np.stack([radius * np.sin(th), radius * (1.0 - np.cos(th))], axis=1)
        nrm = np.stack([-np.sin(th), np.cos(th)], axis=1)
    return pts, nrm


def write_scenario(
    path: Path,
    *,
    lanes: int = 3,
    ego_lane: int = 1,
    length: float = 400.0,
    radius: float | None = None,
    ego_x: float = 50.0,
    ego_v: float = 20.0,
    obstacles=(),
    goal_steps: tuple[int, int] = (30, 40),
    end_lane: tuple[int, float] | None = None,
    shape: str = "rectangle",
    speed_limit: float | None = None,
    dt: float = 0.1,
    statics=(),
    goal: dict | None = None,
    ego_n: float = 0.0,
    ego_turns: int = 0,
    crack: tuple[float, float, bool] | None = None,
) -> Path:
    """Write a scenario: ``lanes`` lanes of 3.5 m (lane 0 the rightmost), the ego on ``ego_lane`` at arc length
    ``ego_x``; ``obstacles``: (id, lane, s0, speed, steps, length, width[, first_step]) driving their lane's centre at
    constant speed for ``steps`` recorded steps (speed 0: standing); ``end_lane``: (lane, s) that lane ends at s;
    ``statics``: (id, lane, s, length, width) static obstacles; ``speed_limit``: a MAX_SPEED sign on the ego's lane;
    ``goal``: a goal position ``lane``, ``s`` (a rectangle ``length`` x ``width``, default 6 x 3 m) and optionally a
    ``velocity`` (lo, hi) and an ``orientation`` (lo, hi) interval beside the time steps ``goal_steps``; ``ego_n``:
    the ego's start this far left of its lane's centre; ``ego_turns``: its orientation given with this many whole
    turns (2 pi each) added, the same pose (CommonRoad allows any real orientation); ``crack``: (gap, s, adjacent)
    lane 0 lies ``gap`` m right of lane 1 at s = 0, the gap closing linearly to none at ``s`` (an on-ramp beside the
    road), the two adjacent in the map or not."""
    from commonroad.common.file_writer import CommonRoadFileWriter, OverwriteExistingFile
    from commonroad.geometry.shape import Circle, Rectangle
    from commonroad.planning.goal import GoalRegion
    from commonroad.planning.planning_problem import PlanningProblem, PlanningProblemSet
    from commonroad.prediction.prediction import TrajectoryPrediction
    from commonroad.scenario.lanelet import Lanelet, LaneletNetwork
    from commonroad.scenario.obstacle import DynamicObstacle, ObstacleType, StaticObstacle
    from commonroad.scenario.scenario import Scenario, ScenarioID
    from commonroad.scenario.state import InitialState, KSState
    from commonroad.scenario.traffic_sign import TrafficSign, TrafficSignElement, TrafficSignIDGermany
    from commonroad.scenario.trajectory import Trajectory

    pts, nrm = reference(length, radius)
    lls = []
    for i in range(lanes):
        left, centre, right = _lane_polylines(pts, nrm, (i - ego_lane) * LANE)
        if crack is not None and i == 0:
            gap = crack[0] * np.clip(1.0 - np.arange(len(pts)) * 2.0 / crack[1], 0.0, 1.0)[:, None] * nrm
            left, centre, right = left - gap, centre - gap, right - gap
        linked = crack is None or crack[2]  # lanes 0 and 1 adjacent in the map
        has_left, has_right = i + 1 < lanes and (linked or i > 0), i > 0 and (linked or i > 1)
        if end_lane is not None and end_lane[0] == i:
            keep = int(end_lane[1] / 2.0) + 1
            left, centre, right = left[:keep], centre[:keep], right[:keep]
        lls.append(
            Lanelet(
                left,
                centre,
                right,
                100 + i,
                adjacent_left=100 + i + 1 if has_left else None,
                adjacent_left_same_direction=True if has_left else None,
                adjacent_right=100 + i - 1 if has_right else None,
                adjacent_right_same_direction=True if has_right else None,
            )
        )
    net = LaneletNetwork.create_from_lanelet_list(lls)
    sc = Scenario(dt, scenario_id=ScenarioID(country_id="ZAM", map_name="Fcgen", map_id=1))
    sc.add_objects(net)
    if speed_limit is not None:
        sign = TrafficSign(
            900,
            [TrafficSignElement(TrafficSignIDGermany.MAX_SPEED, [str(speed_limit)])],
            {100 + ego_lane},
            pts[0] + 0.0,
        )
        sc.add_objects(sign, {100 + ego_lane})

    def pose(lane: int, s: float):
        th = 0.0 if radius is None else s / radius
        base = np.array([s, 0.0]) if radius is None else np.array([radius * math.sin(th), radius * (1 - math.cos(th))])
        nv = np.array([-math.sin(th), math.cos(th)])
        return base + (lane - ego_lane) * LANE * nv, th

    for ob in obstacles:
        oid, lane, s0, v, steps, ln, wd = ob[:7]
        first = ob[7] if len(ob) > 7 else 0
        st = []
        for k in range(steps):
            xy, th = pose(lane, s0 + v * k * dt)
            st.append((xy, th))
        init = InitialState(
            position=st[0][0],
            orientation=st[0][1],
            velocity=v,
            time_step=first,
            yaw_rate=0.0,
            slip_angle=0.0,
            acceleration=0.0,
        )
        traj = [
            KSState(position=xy, orientation=th, velocity=v, steering_angle=0.0, time_step=first + k)
            for k, (xy, th) in enumerate(st)
            if k > 0
        ]
        shp = Rectangle(ln, wd) if shape == "rectangle" or oid != obstacles[0][0] else Circle(ln / 2)
        pred = TrajectoryPrediction(Trajectory(first + 1, traj), shp) if traj else None
        sc.add_objects(DynamicObstacle(oid, ObstacleType.CAR if ln < 6 else ObstacleType.TRUCK, shp, init, pred))
    for oid, lane, s0, ln, wd in statics:
        xy, th = pose(lane, s0)
        sc.add_objects(
            StaticObstacle(
                oid,
                ObstacleType.PARKED_VEHICLE,
                Rectangle(ln, wd),
                InitialState(
                    position=xy,
                    orientation=th,
                    velocity=0.0,
                    time_step=0,
                    yaw_rate=0.0,
                    slip_angle=0.0,
                    acceleration=0.0,
                ),
            )
        )
    exy, eth = pose(ego_lane + ego_n / LANE, ego_x)
    pp = PlanningProblem(
        1,
        InitialState(
            position=exy,
            orientation=eth + 2.0 * math.pi * ego_turns,
            velocity=ego_v,
            time_step=0,
            yaw_rate=0.0,
            slip_angle=0.0,
            acceleration=0.0,
        ),
        GoalRegion([_goal_state(goal, goal_steps, pose)]),
    )
    CommonRoadFileWriter(
        sc, PlanningProblemSet([pp]), "fcgen tests", "fcgen", "written by the tests", set()
    ).write_to_file(str(path), OverwriteExistingFile.ALWAYS)
    return path


def _goal_state(goal: dict | None, steps: tuple[int, int], pose):
    """The goal state: the time steps, and where ``goal`` gives them a position, a velocity and an orientation."""
    from commonroad.common.util import AngleInterval, Interval
    from commonroad.geometry.shape import Rectangle
    from commonroad.scenario.state import CustomState

    kw: dict = {"time_step": Interval(*steps)}
    if goal is not None:
        xy, th = pose(goal["lane"], goal["s"])
        kw["position"] = Rectangle(goal.get("length", 6.0), goal.get("width", 3.0), xy, th)
        if "velocity" in goal:
            kw["velocity"] = Interval(*goal["velocity"])
        if "orientation" in goal:
            kw["orientation"] = AngleInterval(*goal["orientation"])
    return CustomState(**kw)
