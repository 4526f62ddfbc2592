"""The safe profile's tyre-aware a_lat guard and its drive limit (``PlanCheck.tyre_stiffness``, ``h_cg``,
``drive_limit``) on get_u0, with the plant's step given: the flags, the steering rate and the drive force worked out by
hand from the single-track yaw gain and the friction ellipse (docs/safe_profile.md)."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from fcgen.dsl import PlanCheck, Problem
from fcgen.plan_check import a_lat_guard
from fcgen.presets import SAFE_PLAN_CHECK, preset

SAFE = Problem(name="car_safe", plan_check=SAFE_PLAN_CHECK)  # the safe profile's: a = b = 1.7 m, m = 1160 kg
NO_BEND = SAFE  # the safe profile brakes for no bend (bend_brake = 0)
BEND = SAFE.with_(plan_check=replace(SAFE.plan_check, bend_brake=2.0))
L, DT, A_TO = 3.4, 0.1, 4.95


def _delta(v: float, a: float) -> float:
    """The steering angle at which the formula gives a_lat = a at speed v."""
    return math.atan(a * L / (v * v))


def _guard(problem: Problem, x1: list[float], u: list[float], slack: float = 0.0) -> tuple[int, np.ndarray]:
    """The guard on control u from x0 = (.., v1, 0.03), its plant step ending at x1 with the plan's rate u[1] and at
    the steering angle 0.03 + r dt with another rate r (the speed x1's)."""
    uu = np.array(u, dtype=float)
    x0 = np.array([0.0, 0.0, 0.0, x1[3], 0.03])
    r_plan = float(uu[1])

    def step() -> list[float]:
        return list(x1) if uu[1] == r_plan else [*x1[:4], 0.03 + float(uu[1]) * DT]

    return a_lat_guard(problem, x0, uu, -0.39, 0.39, step, slack), uu


def test_braking_in_a_bend_the_guard_steers_to_the_tyre_aware_target():
    """18 m/s at the formula's 4.5 m/s^2 (within the bound) while braking at 8 m/s^2: load transfer a_x h = -4.912,
    g l_r = g l_f = 16.677, so K = (1.7 / 21.589 - 1.7 / 11.765) / (3.4 * 21.92) = -8.825e-4 and d = 1 - 0.286 = 0.714:
    the tyres give 6.3 m/s^2. The guard steers to 4.95 d = 3.53 m/s^2 of the formula (status 1), the force kept."""
    v, f_d = 18.0, -8.0 * 1160.0
    x1 = [0.0, 0.0, 0.0, v, _delta(v, 4.5)]
    status, u = _guard(SAFE, x1, [f_d, 0.1])
    k = (1.7 / (9.81 * 1.7 + 8.0 * 0.614) - 1.7 / (9.81 * 1.7 - 8.0 * 0.614)) / (L * 21.92)
    d = 1.0 + k * v * v
    assert d == pytest.approx(0.714, abs=1e-3)
    assert status == 1 and u[0] == f_d
    assert u[1] == pytest.approx((_delta(v, A_TO * d) - 0.03) / DT, rel=1e-12)
    # without tyres (the paper's guard) the same step passes: 4.5 <= 5
    no_tyres = SAFE.with_(
        plan_check=replace(SAFE.plan_check, tyre_stiffness=0.0, drive_limit=False, bend_brake=0.0, drive_rise=0.0)
    )
    assert _guard(no_tyres, x1, [f_d, 0.1]) == (0, pytest.approx(np.array([f_d, 0.1])))


def _gain(a_x: float) -> float:
    """The guard's divisor d at 20 m/s under the longitudinal acceleration a_x (a = b = 1.7 m, h = 0.614 m,
    c = 21.92): the linear single-track model's yaw gain by hand."""
    k = (1.7 / (9.81 * 1.7 - a_x * 0.614) - 1.7 / (9.81 * 1.7 + a_x * 0.614)) / (L * 21.92)
    return 1.0 + k * 400.0


def test_where_the_guard_steers_it_does_not_drive():
    """20 m/s, the plan's step ending at 5.5 m/s^2 while driving with 5,000 N: the guard steers to 4.95 m/s^2 and the
    friction ellipse leaves no drive force at its target (F_d_max sqrt(1 - 1) = 0); without the bend braking (0) that
    is all (status 1), and without the drive limit the force is kept where the guard steers."""
    v = 20.0
    status, u = _guard(NO_BEND, [0.0, 0.0, 0.0, v, _delta(v, 5.5)], [5000.0, 0.1])
    assert status == 1 and u[0] == pytest.approx(0.0, abs=1e-2)
    assert u[1] == pytest.approx((_delta(v, A_TO) - 0.03) / DT, rel=1e-12)
    free = SAFE.with_(plan_check=replace(SAFE.plan_check, drive_limit=False, bend_brake=0.0, drive_rise=0.0))
    assert _guard(free, [0.0, 0.0, 0.0, v, _delta(v, 5.5)], [5000.0, 0.1])[1][0] == 5000.0


def test_where_the_guard_steers_too_fast_for_the_plans_path_it_brakes():
    """The same step with the bend braking at 2 m/s^2, the plan holding a slack of 5 (above
    reactions.BEND_SLACK = 1; with 0.5 the force is cut to 0 as above): the plan's path, 5.5 m/s^2 at 20 m/s, allows
    20 sqrt(4.95 / 5.5) = 18.97 m/s at the guard's target, 10.3 m/s^2 of braking away in one sample: the force becomes
    -2 m = -2,320 N, and the rate is set again for that step at the tyre-aware target under 2 m/s^2 of braking,
    4.95 d (d = 1 + 400 (1.7 / 17.905 - 1.7 / 15.449) / 74.528 = 0.919: the tyres turn 9 % more), status 1. A plan
    braking harder keeps its force; where the plan's path allows the speed (4.94 m/s^2 of the formula, the tyre-aware
    a_lat above 5 only through the plan's braking) nothing is added."""
    v = 20.0
    status, u = _guard(BEND, [0.0, 0.0, 0.0, v, _delta(v, 5.5)], [5000.0, 0.1], slack=0.5)
    assert status == 1 and u[0] == pytest.approx(0.0, abs=1e-2)
    status, u = _guard(BEND, [0.0, 0.0, 0.0, v, _delta(v, 5.5)], [5000.0, 0.1], slack=5.0)
    d = _gain(-2.0)
    assert d == pytest.approx(0.919, abs=1e-3)
    assert status == 1 and u[0] == pytest.approx(-2320.0, rel=1e-12)
    assert u[1] == pytest.approx((_delta(v, A_TO * d) - 0.03) / DT, rel=1e-12)
    status, u = _guard(BEND, [0.0, 0.0, 0.0, v, _delta(v, 5.5)], [-3000.0, 0.1], slack=5.0)
    assert status == 1 and u[0] == -3000.0
    status, u = _guard(BEND, [0.0, 0.0, 0.0, v, _delta(v, 4.94)], [-3000.0, 0.1], slack=5.0)  # 4.94 / d(3 kN) > 5
    assert status == 1 and u[0] == -3000.0


def test_where_the_guard_steers_and_cuts_the_drive_it_steers_for_the_slower_step():
    """A plant step whose end speed follows the force, v1 = 20 + F_d / m dt: the plan drives with 5,000 N (v1 =
    20.431 m/s) and its step ends at 5.5 m/s^2. The rate set for 4.95 at 20.431 m/s would end at 4.95 (20 / 20.431)^2
    = 4.74 m/s^2 once the ellipse has cut the force to 0 and the step ends at 20 m/s; the guard sets the rate again for
    that step: (delta(20, 4.95) - 0.03) / dt, status 1 (without the bend braking, which the next test adds)."""
    v0, m = 20.0, 1160.0
    x0 = np.array([0.0, 0.0, 0.0, v0, 0.03])
    uu = np.array([5000.0, (_delta(v0 + 5000.0 / m * DT, 5.5) - 0.03) / DT])

    def step() -> list[float]:
        return [0.0, 0.0, 0.0, v0 + float(uu[0]) / m * DT, 0.03 + float(uu[1]) * DT]

    status = a_lat_guard(NO_BEND, x0, uu, -0.39, 0.39, step)
    assert status == 1 and uu[0] == pytest.approx(0.0, abs=1e-2)
    assert uu[1] == pytest.approx((_delta(v0 + uu[0] / m * DT, A_TO) - 0.03) / DT, rel=1e-9)
    first = (_delta(v0 + 5000.0 / m * DT, A_TO) - 0.03) / DT  # the rate for the uncut force's step
    a_first = v0**2 * math.tan(0.03 + first * DT) / L
    assert a_first == pytest.approx(A_TO * (v0 / (v0 + 5000.0 / m * DT)) ** 2, rel=1e-9) and a_first < 4.75


def test_within_the_bound_the_drive_force_keeps_the_understeer_within_its_slack():
    """20 m/s at the formula's 4.9 m/s^2 (the guard does not steer): driving with 5,000 N would make the tyres turn
    0.25 m/s^2 less at m 0.25 g^2 l_f l_r / (k l h v^2 (4.9 - 0.25)) = 290 * 96.2361 * 2.89 / (0.02801 * 400 * 4.65)
    = 1,548 N (k = 1 / (3.4 * 21.92)): cut to it, status 3; 1,000 N is kept (0), braking too (the guard steers:
    the tyres turn more); straight ahead the whole force."""
    v = 20.0
    status, u = _guard(SAFE, [0.0, 0.0, 0.0, v, _delta(v, 4.9)], [5000.0, 0.1])
    k = 1.0 / (L * 21.92)
    assert status == 3 and u[1] == 0.1
    assert u[0] == pytest.approx(1160.0 * 0.25 * 9.81**2 * 1.7 * 1.7 / (k * L * 0.614 * v * v * (4.9 - 0.25)), rel=1e-9)
    assert u[0] == pytest.approx(1548.0, abs=1.0)
    assert _guard(SAFE, [0.0, 0.0, 0.0, v, _delta(v, 4.9)], [1000.0, 0.1]) == (0, pytest.approx(np.array([1e3, 0.1])))
    status, u = _guard(SAFE, [0.0, 0.0, 0.0, v, _delta(v, 4.9)], [-3000.0, 0.1])  # braking: the tyres turn more
    assert status == 1 and u[0] == -3000.0
    assert _guard(SAFE, [0.0, 0.0, 0.0, v, 0.0], [1e4, 0.0]) == (0, pytest.approx(np.array([1e4, 0.0])))


def test_profiles():
    """The safe presets carry the tyre-aware guard and the drive limit; the paper's have neither; neither brakes for
    the bend."""
    safe, paper = preset("car_lifted_ellipse_ipm_safe"), preset("car_lifted_ellipse")
    assert safe.plan_check == SAFE_PLAN_CHECK and safe.plan_check.tyre_stiffness > 0 and safe.plan_check.drive_limit
    assert paper.plan_check.tyre_stiffness == 0 and not paper.plan_check.drive_limit
    assert safe.plan_check.bend_brake == 0.0 and paper.plan_check.bend_brake == 0.0


def test_braking_for_the_plans_path_on_a_step_that_follows_the_force():
    """The step of the test above (v1 = 20 + F_d / m dt) with the bend braking (a slack of 5): the plan's path at
    5.5 m/s^2 and 20.431 m/s allows 20.431 sqrt(0.9) = 19.38 m/s, so the force is capped to -2 m = -2,320 N (v1 =
    19.8 m/s) and the rate set for that step's end at the tyre-aware target under 2 m/s^2 of braking:
    (delta(19.8, 4.95 d) - 0.03) / dt, d = 1 + 19.8^2 (1.7 / 17.905 - 1.7 / 15.449) / 74.528."""
    v0, m = 20.0, 1160.0
    x0 = np.array([0.0, 0.0, 0.0, v0, 0.03])
    uu = np.array([5000.0, (_delta(v0 + 5000.0 / m * DT, 5.5) - 0.03) / DT])

    def step() -> list[float]:
        return [0.0, 0.0, 0.0, v0 + float(uu[0]) / m * DT, 0.03 + float(uu[1]) * DT]

    assert a_lat_guard(BEND, x0, uu, -0.39, 0.39, step, 5.0) == 1
    assert uu[0] == pytest.approx(-2320.0, rel=1e-12)
    d = 1.0 + 19.8**2 * (1.7 / (9.81 * 1.7 + 2.0 * 0.614) - 1.7 / (9.81 * 1.7 - 2.0 * 0.614)) / (L * 21.92)
    assert uu[1] == pytest.approx((_delta(19.8, A_TO * d) - 0.03) / DT, rel=1e-9)


def test_bend_brake_needs_the_drive_limit_and_a_range():
    """``bend_brake`` caps the drive force where the drive limit does: refused without it, and outside [0, 10]."""
    with pytest.raises(ValueError, match=r"plan_check\.bend_brake"):
        PlanCheck(drive_limit=False, bend_brake=2.0, drive_rise=0.0)
    with pytest.raises(ValueError, match=r"plan_check\.bend_brake.*\[0, 10\]"):
        PlanCheck(bend_brake=-1.0)
    assert PlanCheck(drive_limit=False, bend_brake=0.0, drive_rise=0.0).bend_brake == 0.0


def test_the_guard_remembers_the_last_braking():
    """18 m/s at the formula's 4.5 m/s^2, the control easing from 8 m/s^2 of braking (handed out last: -9,280 N) to
    -2,000 N: under -2,000 N alone d = 1 + 324 (1.7 / (16.677 + 1.0586) - 1.7 / (16.677 - 1.0586)) / 74.528 = 0.9436
    and the tyres' 4.77 m/s^2 pass (status 0); with the brake memory the load transfer is the last sample's
    (d = 0.714, 6.3 m/s^2, the test above): the guard steers to 4.95 d (status 1), the force kept (without the drive
    force's rise limit, which would also slow the easing: the next test)."""
    v, f_last = 18.0, -8.0 * 1160.0
    x1 = [0.0, 0.0, 0.0, v, _delta(v, 4.5)]
    x0 = np.array([0.0, 0.0, 0.0, v, 0.03])
    k = (1.7 / (9.81 * 1.7 + 8.0 * 0.614) - 1.7 / (9.81 * 1.7 - 8.0 * 0.614)) / (L * 21.92)
    d = 1.0 + k * v * v

    def run(problem: Problem) -> tuple[int, np.ndarray]:
        uu = np.array([-2000.0, 0.1])
        step = lambda: list(x1) if uu[1] == 0.1 else [*x1[:4], 0.03 + float(uu[1]) * DT]
        return a_lat_guard(problem, x0, uu, -0.39, 0.39, step, 0.0, f_last), uu

    a_x = -2000.0 / 1160.0
    d_now = 1.0 + v * v * (1.7 / (9.81 * 1.7 - a_x * 0.614) - 1.7 / (9.81 * 1.7 + a_x * 0.614)) / (L * 21.92)
    assert d_now == pytest.approx(0.9436, abs=1e-4) and 4.5 / d_now < 5.0
    memory = SAFE.with_(plan_check=replace(SAFE.plan_check, drive_rise=0.0))
    forget = SAFE.with_(plan_check=replace(SAFE.plan_check, brake_memory=False, drive_rise=0.0))
    assert run(forget)[0] == 0
    status, u = run(memory)
    assert status == 1 and u[0] == -2000.0
    assert u[1] == pytest.approx((_delta(v, A_TO * d) - 0.03) / DT, rel=1e-12)


def test_the_drive_force_rises_at_most_drive_rise_a_sample():
    """Straight ahead at 20 m/s (no a_lat): after full braking (-10,000 N handed out last) a plan asking for full drive
    gets -10,000 + 3 m = -6,520 N (status 3); after 5,000 N, 8,480 N; braking that eases from -10,000 N to -3,000 N
    eases to -6,520 N too; braking harder is never limited; without drive_rise the whole force."""
    x1 = [0.0, 0.0, 0.0, 20.0, 0.0]
    rise = SAFE.with_(plan_check=replace(SAFE.plan_check, drive_rise=3.0))  # 3 m/s^2 a sample: 3,480 N

    def run(problem: Problem, f: float, f_last: float) -> tuple[int, float]:
        uu = np.array([f, 0.0])
        return a_lat_guard(problem, np.array(x1), uu, -0.39, 0.39, lambda: list(x1), 0.0, f_last), float(uu[0])

    assert run(rise, 1e4, -1e4) == (3, pytest.approx(-10000.0 + 3.0 * 1160.0, rel=1e-15))
    assert run(rise, 1e4, 5000.0) == (3, pytest.approx(8480.0, rel=1e-15))
    assert run(rise, -3000.0, 1e4) == (0, -3000.0)
    assert run(rise, -3000.0, -1e4) == (3, pytest.approx(-6520.0, rel=1e-15))
    assert run(rise, -9000.0, -1e4) == (0, -9000.0)  # a rise of 1,000 N: within 3,480
    free = SAFE.with_(plan_check=replace(SAFE.plan_check, drive_rise=0.0))
    assert run(free, 1e4, -1e4) == (0, 1e4)
    with pytest.raises(ValueError, match=r"plan_check\.drive_rise.*\[0, 100\]"):
        PlanCheck(drive_rise=-1.0)
    with pytest.raises(ValueError, match=r"plan_check\.drive_rise"):
        PlanCheck(drive_limit=False, bend_brake=0.0, drive_rise=3.0)


def test_with_a_steering_lag_the_guard_commands_the_rate_the_lag_turns_into_its_target():
    """The first test's step (18 m/s, braking at 8 m/s^2, the tyre-aware target 4.95 d) on a vehicle whose steering
    actuator lags by tau = 0.1 s (Problem.steer_lag), 0.004 rad of lag carried in: the guard commands the rate whose
    lagged rate ends the step at the target's angle. Checked with the closed loop's actuator
    (``sim.plants.actuation``, commanded angle = actual + lag), the second method: its applied rate over the sample
    ends at delta(18, 4.95 d)."""
    from fcgen.sim.plants import PlantSpec
    from fcgen.sim.plants.actuation import Actuation

    v, f_d, e, delta0 = 18.0, -8.0 * 1160.0, 0.004, 0.03
    lagged = SAFE.with_(steer_lag=0.1)
    k = (1.7 / (9.81 * 1.7 + 8.0 * 0.614) - 1.7 / (9.81 * 1.7 - 8.0 * 0.614)) / (L * 21.92)
    target = _delta(v, A_TO * (1.0 + k * v * v))
    uu = np.array([f_d, 0.1])
    x0 = np.array([0.0, 0.0, 0.0, v, delta0])

    def applied(r: float) -> float:
        act = Actuation(PlantSpec(steer_lag=0.1), 0, DT)
        act._delta_cmd = delta0 + e  # the lag carried in
        return float(act.actuate([f_d, r], delta0)[1])

    def step() -> list[float]:
        return [0.0, 0.0, 0.0, v, delta0 + applied(float(uu[1])) * DT]

    uu[1] = (_delta(v, 4.5) - delta0) / (applied(1.0) - applied(0.0)) / DT  # a plan rate ending at 4.5: linear in r
    uu[1] -= applied(0.0) / (applied(1.0) - applied(0.0))
    assert delta0 + applied(float(uu[1])) * DT == pytest.approx(_delta(v, 4.5), rel=1e-12)
    status = a_lat_guard(lagged, x0, uu, -0.39, 0.39, step, 0.0, f_d, e)
    assert status == 1 and uu[0] == f_d
    assert delta0 + applied(float(uu[1])) * DT == pytest.approx(target, rel=1e-12)
    # the guard without the lag in its model sets the rate for an actuator without lag: the lagging one misses the
    # target by more than a tenth of the angle's step
    r_plain = (target - delta0) / DT
    assert abs(delta0 + applied(r_plain) * DT - target) > 0.1 * abs(target - delta0)
