"""The plan check (``PlanCheck``) after the QP, in the reference: the a_lat guard on get_u0 and the plan's verdict
on its clearance to the opponents; the generated C does the same (``a_lat_guard``, ``plan_check`` in solver.c.j2).

The formulas they act with (braking, the guard's steering rate, a_lat) are ``fcgen.reactions``'s, shared with the C.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np

from .dsl import PlanCheck, Problem
from .reactions import (
    BEND_SLACK,
    DRIVE_SLACK,
    bend_brake_limit,
    braking_force,
    drive_limit,
    guard_steering_rate,
    lag_command,
    lagged_rate,
    lateral_acceleration,
    load_transfer_gain,
    understeer_drive_limit,
)


def a_lat_guard(
    problem: Problem,
    x0: np.ndarray,
    u: np.ndarray,
    lo: float,
    hi: float,
    plant_step: Callable[[], Sequence[float]],
    slack: float = 0.0,
    f_last: float = math.inf,
    lag_e: float = 0.0,
) -> int:
    """Where the plant's step from x0 with get_u0 ``u`` ends above ``a_lat_max`` in tyre-aware |a_lat|
    (``tyre_a_lat``), the steering rate that ends at ``a_lat_max - a_lat_margin`` in it (status 1; with wind the speed,
    and so the end, moves a little with the rate: the margin covers it), and where the step with that rate still ends
    above the bound (the rate bound ``[lo, hi]`` cut it short), braking as the plan check does (2); where the rate
    sufficed, with ``plan_check.drive_limit``, a drive force above ``reactions.drive_limit`` at that step's end is cut
    to it, and where the guard steers the rate is set again for the end of the step with the cut force, which is
    slower (status 1 still), and where the plan also holds a slack above ``reactions.BEND_SLACK`` (``slack``: the
    plan's largest, the C's ``max_slack()``) the force is capped to brake for the plan's path (``bend_cap``); with
    ``drive_rise`` the force rises at most ``m drive_rise`` above ``f_last``, the drive force handed out last (inf:
    none known), which ``brake_memory`` also takes into the load transfer (``hard_force``); with ``Problem.steer_lag``
    the rates are the commanded ones whose lagged rates from the lag ``lag_e`` the step applies (``guard_rate``);
    0: the guard is off or did not act. ``u`` is changed in place; ``plant_step()`` is the plant's state one sample
    after x0 under ``u`` as it is then. The C's operations in the C's order (the C runs the three steps in every
    feedback and keeps the plan's rate where the first ends within the bound: the same control and status)."""
    if not problem.plan_check.a_lat_guard:
        return 0
    b, pc = problem.bounds, problem.plan_check
    x1, status = plant_step(), 0
    xa = x1  # the step with the plan's rate
    if tyre_a_lat(problem, x1, hard_force(pc, u[0], f_last)) > b.a_lat_max:
        d = tyre_gain(problem, x1[3], hard_force(pc, u[0], f_last))
        u[1] = guard_rate(problem, x1[3], x1[4], float(x0[4]), (b.a_lat_max - b.a_lat_margin) * d, lo, hi, lag_e)
        x1, status = plant_step(), 1
        if tyre_a_lat(problem, x1, hard_force(pc, u[0], f_last)) > b.a_lat_max:
            u[0] = braking_control(problem, x0)
            return 2
    if pc.drive_limit:  # a vehicle with tyres turns less than the formula says while it drives
        a = abs(lateral_acceleration(x1[3], x1[4], problem.ego.l))
        cap = drive_limit(a, b.a_lat_max - b.a_lat_margin, b.F_d_max) if status == 1 else understeer_cap(problem, x1, a)
        if status == 1 and slack > BEND_SLACK:  # too fast for the plan's path, the plan in slack: brake for it
            cap = min(cap, bend_cap(problem, xa))
        rise = problem.ego.m * pc.drive_rise
        if rise > 0.0 and f_last + rise < cap:  # from braking to driving over samples
            cap = f_last + rise
        if u[0] > cap:
            u[0] = cap
            status = status or 3
            if status == 1:  # the rate was set for the speed of the uncut force: set again for the slower step's end
                x2 = plant_step()
                a_to = (b.a_lat_max - b.a_lat_margin) * tyre_gain(problem, x2[3], hard_force(pc, u[0], f_last))
                u[1] = guard_rate(problem, x2[3], x2[4], float(x0[4]), a_to, lo, hi, lag_e)
    return status


def hard_force(pc: PlanCheck, f_d: float, f_last: float) -> float:
    """The drive force whose braking the tyre-aware a_lat takes: with ``brake_memory`` the harder (smaller) of ``f_d``
    and ``f_last``, the force handed out last; else ``f_d``."""
    return f_last if pc.brake_memory and f_last < f_d else f_d


def has_f_last(problem: Problem) -> bool:
    """Whether the guard needs the drive force handed out last (``brake_memory``, ``drive_rise``; the C's f_last)."""
    pc = problem.plan_check
    return pc.a_lat_guard and (pc.brake_memory or pc.drive_rise > 0)


def lag_constants(problem: Problem) -> tuple[float, float] | None:
    """``(tau, exp(-dt / tau))`` of ``Problem.steer_lag``'s actuator (``reactions.lag_error``); None without a lag."""
    tau = problem.steer_lag
    return (tau, math.exp(-problem.horizon.dt / tau)) if tau > 0 else None


def guard_rate(
    problem: Problem, v: float, delta: float, delta0: float, a_to: float, lo: float, hi: float, lag_e: float
) -> float:
    """``reactions.guard_steering_rate`` from ``delta0``; with a steering lag the commanded rate within ``[lo, hi]``
    whose lagged rate from ``lag_e`` is that rate (``reactions.lag_command``), the rate clipped to the lagged rates
    of ``lo`` and ``hi`` first."""
    l, dt, lag = problem.ego.l, problem.horizon.dt, lag_constants(problem)
    if lag is None:
        return guard_steering_rate(v, delta, delta0, a_to, l, dt, lo, hi)
    tau, decay = lag
    lo_e, hi_e = lagged_rate(lo, lag_e, tau, decay, dt), lagged_rate(hi, lag_e, tau, decay, dt)
    r = lag_command(guard_steering_rate(v, delta, delta0, a_to, l, dt, lo_e, hi_e), lag_e, tau, decay, dt)
    return lo if r < lo else (hi if r > hi else r)


def bend_cap(problem: Problem, xa: Sequence[float]) -> float:
    """``reactions.bend_brake_limit`` at the end of the step with the plan's control (its speed and steering angle)."""
    b, pc = problem.bounds, problem.plan_check
    a_to = b.a_lat_max - b.a_lat_margin
    return bend_brake_limit(
        xa[3], xa[4], problem.ego.l, a_to, pc.bend_brake, problem.ego.m, problem.horizon.dt, b.F_d_max
    )


def understeer_cap(problem: Problem, x: Sequence[float], a: float) -> float:
    """``reactions.understeer_drive_limit`` at state x with the formula's |a_lat| ``a`` and the problem's tyres."""
    pc, e = problem.plan_check, problem.ego
    return understeer_drive_limit(
        a, x[3], tyre_k(problem), e.l_f, e.l_r, pc.h_cg, DRIVE_SLACK, problem.bounds.F_d_max, e.m
    )


def tyre_gain(problem: Problem, v: float, f_d: float) -> float:
    """``reactions.load_transfer_gain`` at speed v under drive force ``f_d`` with the problem's tyres (1: none)."""
    pc, e = problem.plan_check, problem.ego
    return load_transfer_gain(v, f_d / e.m, tyre_k(problem), e.l_f, e.l_r, pc.h_cg)


def tyre_k(problem: Problem) -> float:
    """``1 / (l c)`` of ``load_transfer_gain`` (``c``: ``plan_check.tyre_stiffness``; 0 without tyres)."""
    c = problem.plan_check.tyre_stiffness
    return 1.0 / (problem.ego.l * c) if c > 0 else 0.0


def tyre_a_lat(problem: Problem, x: Sequence[float], f_d: float) -> float:
    """The guard's tyre-aware |a_lat| at state x under drive force ``f_d``: |formula| / ``tyre_gain``."""
    return abs(lateral_acceleration(x[3], x[4], problem.ego.l)) / tyre_gain(problem, x[3], f_d)


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
