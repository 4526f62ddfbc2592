"""A run as a CommonRoad solution, and the drivability checker's verdict on it
(``commonroad_dc.feasibility.solution_checker``, the check commonroad.in.tum.de applies to a submission).

- **The solution**: planning problem ``sc.planning_problem_id``, the kinematic single-track model (KS), vehicle type
  BMW 320i, cost function SM1, one state per sample from the planning problem's initial time step: position (the
  chassis' centre: CommonRoad's position, the initial state's; the checker's KS puts its rear axle ``b`` behind it),
  orientation (with the initial state's whole turns: a problem that starts at -3.351 gets -3.351, not 2.932), speed,
  steering angle.
- **The verdict** (``solution_verdict``), each part checked on its own (the checker stops at the first failure):
  ``starts_at_initial_state`` (position and orientation within 0.1, speed within 2.0 of the planning problem's),
  ``feasible`` (every transition reachable by the named vehicle model within the checker's tolerances;
  ``infeasible_step``: the first sample that is not), ``goal_reached``, ``obstacle_collision`` (the checker's, with
  the named vehicle's rectangle) and ``road_departure`` (the named vehicle's rectangle against the road boundary as
  oriented rectangles, ``judge.drivability_verdict``: the checker's own boundary check needs the non-free
  ``triangle`` package, which fcgen does not install), ``valid`` (all of them: what a submission needs) and
  ``valid_but_goal`` (all but the goal).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ..extras import require
from .judge import drivability_verdict


def solution_of(sc, ego_states: np.ndarray):
    """The commonroad-io ``Solution`` of a run; ``ego_states`` (K + 1, 5): chassis centre [x, y, phi], speed,
    steering angle per sample."""
    with require("commonroad", "a CommonRoad solution"):
        from commonroad.common.solution import (
            CostFunction,
            PlanningProblemSolution,
            Solution,
            VehicleModel,
            VehicleType,
        )
        from commonroad.scenario.state import KSState
        from commonroad.scenario.trajectory import Trajectory

    xs = np.asarray(ego_states, dtype=float)
    turns = _turns(sc, float(xs[0, 2])) if len(xs) else 0.0
    states = [
        KSState(
            time_step=sc.first_step + j,
            position=np.array([x[0], x[1]]),
            orientation=float(x[2]) + turns,
            velocity=float(x[3]),
            steering_angle=float(x[4]),
        )
        for j, x in enumerate(xs)
    ]
    pps = PlanningProblemSolution(
        planning_problem_id=sc.planning_problem_id,
        vehicle_model=VehicleModel.KS,
        vehicle_type=VehicleType.BMW_320i,
        cost_function=CostFunction.SM1,
        trajectory=Trajectory(sc.first_step, states),
    )
    return Solution(sc.scenario.scenario_id, [pps])


def drive_power(mass: float) -> float:
    """The drive's power (W) of the solution's vehicle (the BMW 320i's longitudinal parameters) for a car of ``mass``:
    its acceleration above ``v_switch`` is at most ``a_max v_switch / v``, so ``F_d v <= m a_max v_switch``
    (``Bounds.P_d_max``)."""
    with require("commonroad", "the solution's vehicle parameters"):
        from vehiclemodels.parameters_vehicle2 import parameters_vehicle2  # type: ignore[import-untyped]

    lon = parameters_vehicle2().longitudinal
    return float(mass * lon.a_max * lon.v_switch)


def _turns(sc, phi0: float) -> float:
    """The whole turns (a multiple of 2 pi) that bring ``phi0`` nearest the planning problem's initial orientation
    (fcgen's heading is the road's plus alpha in [-pi, pi]; a problem may give it with whole turns: -3.351 for
    2.932)."""
    init = getattr(getattr(sc.planning_problem, "initial_state", None), "orientation", None)
    if init is None:
        return 0.0
    return 2.0 * math.pi * round((float(init) - phi0) / (2.0 * math.pi))


def write_solution(sc, ego_states: np.ndarray, path: str | Path) -> Path:
    """Write the run's CommonRoad solution file (``solution_of``) to ``path``."""
    with require("commonroad", "a CommonRoad solution file"):
        from commonroad.common.solution import CommonRoadSolutionWriter

    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(CommonRoadSolutionWriter(solution_of(sc, ego_states)).dump())
    return out


def _passes(fn, *args) -> tuple[bool, str]:
    """A solution-checker check that raises on failure, as (passed, the first line of its message)."""
    try:
        return bool(fn(*args)), ""
    except Exception as exc:  # noqa: BLE001 - the checker raises its own exception classes (and numerical ones)
        return False, f"{type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ''}"


def solution_verdict(sc, ego_states: np.ndarray) -> dict:
    """The drivability checker's verdict on the run's solution (module docstring)."""
    with require("commonroad", "the solution checker"):
        from commonroad.planning.planning_problem import PlanningProblemSet
        from commonroad_dc.feasibility import feasibility_checker as fc
        from commonroad_dc.feasibility import solution_checker as chk
        from commonroad_dc.feasibility.vehicle_dynamics import VehicleDynamics

    sol = solution_of(sc, ego_states)
    pps = PlanningProblemSet([sc.planning_problem])
    starts, why_start = _passes(chk.starts_at_correct_state, sol, pps)
    ps = sol.planning_problem_solutions[0]
    vd = VehicleDynamics.from_model(ps.vehicle_model, ps.vehicle_type)
    try:
        feasible, inputs = fc.trajectory_feasibility(ps.trajectory, vd, sc.dt)
        why_feasible = ""
        bad = None if feasible else len(inputs.state_list)  # the inputs up to the failing transition's
    except Exception as exc:  # noqa: BLE001 - the checker's own exceptions on a state outside its model's bounds
        feasible, bad, why_feasible = False, None, f"{type(exc).__name__}: {str(exc).splitlines()[0]}"
    goal, _ = _passes(chk.goal_reached, sc.scenario, pps, sol)
    free, _ = _passes(lambda *a: not chk.obstacle_collision(*a), sc.scenario, pps, sol)
    # the checker's own boundary check triangulates the road with the non-free ``triangle`` package: the road boundary
    # as oriented rectangles instead (``judge.drivability_verdict``), with the named vehicle's rectangle
    p = vd.parameters
    on_road = not drivability_verdict(sc, np.asarray(ego_states, dtype=float)[:, :3], p.l, p.w)["road_departure"]
    but_goal = starts and feasible and free and on_road
    return {
        "starts_at_initial_state": starts,
        "feasible": bool(feasible),
        "infeasible_step": bad,
        "goal_reached": goal,
        "obstacle_collision": not free,
        "road_departure": not on_road,
        "valid_but_goal": but_goal,
        "valid": but_goal and goal,
        "reason": why_start or why_feasible,
    }
