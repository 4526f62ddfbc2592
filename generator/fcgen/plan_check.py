"""The plan check (``PlanCheck``) after the QP, in the reference: the a_lat guard on get_u0 and the plan's verdict
on its clearance to the opponents; the generated C does the same (``a_lat_guard``, ``plan_check`` in solver.c.j2).

The formulas they act with (braking, the guard's steering rate, a_lat) are ``fcgen.reactions``'s, shared with the C.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np

from .dsl import Problem
from .reactions import braking_force, guard_steering_rate, lateral_acceleration


def a_lat_guard(
    problem: Problem, x0: np.ndarray, u: np.ndarray, lo: float, hi: float, plant_step: Callable[[], Sequence[float]]
) -> int:
    """Where the plant's step from x0 with get_u0 ``u`` ends above ``a_lat_max`` in |a_lat|, the steering rate that
    ends at ``a_lat_max - a_lat_margin`` (status 1; with wind the speed, and so the end, moves a little with the rate:
    the margin covers it), and where the step with that rate still ends above the bound (the rate bound ``[lo, hi]``
    cut it short), braking as the plan check does (2); 0: the guard is off or did not act. ``u`` is changed in place;
    ``plant_step()`` is the plant's state one sample after x0 under ``u`` as it is then. The C's operations in the C's
    order (the C runs both steps in every feedback and keeps the plan's rate where the first ends within the bound:
    the same control and status)."""
    if not problem.plan_check.a_lat_guard:
        return 0
    b, l, dt = problem.bounds, problem.ego.l, problem.horizon.dt
    x1 = plant_step()
    if abs(lateral_acceleration(x1[3], x1[4], l)) <= b.a_lat_max:
        return 0
    u[1] = guard_steering_rate(x1[3], x1[4], float(x0[4]), b.a_lat_max - b.a_lat_margin, l, dt, lo, hi)
    x1 = plant_step()
    if abs(lateral_acceleration(x1[3], x1[4], l)) <= b.a_lat_max:
        return 1
    u[0] = braking_control(problem, x0)
    return 2


def plan_verdict(
    clearance: np.ndarray, ahead: np.ndarray, ok: Sequence[bool], react_stages: int
) -> tuple[float, int, bool]:
    """From each opponent's SAT clearance to the plan and its ``ahead`` value (> 0: its centre ahead of the ego's) at
    stages 0..N (arrays n_opp x (N + 1); ``ok``: the stages whose window the road covers, the others skipped): the
    smallest clearance, its stage (-1: none), and whether to brake: where an opponent's first overlap among stages
    1..react_stages has it ahead of the ego there or now, at stage 0 (braking opens that gap; for one beside or behind
    it closes it; a plan that overlaps an opponent on the way past it does not pass)."""
    best, best_k, react, met = math.inf, -1, False, set()
    for k in np.flatnonzero(ok):
        for j, (v, d) in enumerate(zip(clearance[:, k], ahead[:, k])):
            if v < best:
                best, best_k = float(v), int(k)
            if 1 <= k <= react_stages and v < 0.0 and j not in met:  # its first overlapping stage decides
                met.add(j)
                react = react or d > 0.0 or (bool(ok[0]) and ahead[j, 0] > 0.0)
    return best, best_k, react


def braking_control(problem: Problem, x0: np.ndarray) -> float:
    """The braking control of the plan check and the a_lat guard from x0: ``F_d = -min(F_d_max, m max(v0, 0) / dt)``
    (``reactions.braking_force``)."""
    return braking_force(float(x0[3]), problem.ego.m / problem.horizon.dt, problem.bounds.F_d_max)
