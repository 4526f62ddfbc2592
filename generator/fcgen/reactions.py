"""The solver's reactions on get_u0 after the QP as formulas: the braking control of the plan check and the a_lat
guard, the guard's steering rate, the lateral acceleration it tests.

The Python reference (``fcgen.reference``) calls these; the generated C has one static function of the same name
and the same operations in the same order for each (``templates/solver.c.j2``), so the two agree bit for bit in
double (``tests/test_reactions.py``). Pure functions of floats, no fcgen import.
"""

from __future__ import annotations

import math


def braking_force(v0: float, m_per_dt: float, f_max: float) -> float:
    """The braking control ``F_d = -min(f_max, m_per_dt max(v0, 0))``, ``m_per_dt = m / dt``: the force that stops the
    ego within one sample, at most ``F_d_max`` (a NaN speed brakes with 0)."""
    v = v0 if v0 > 0.0 else 0.0
    f = m_per_dt * v
    return -(f if f < f_max else f_max)


def lateral_acceleration(v: float, delta: float, l: float) -> float:
    """The lateral acceleration ``v^2 tan(delta) / l`` at the rear axle (``models.a_lat``'s formula, on floats)."""
    return v * v * math.tan(delta) / l


def guard_steering_rate(
    v: float, delta: float, delta0: float, a_to: float, l: float, dt: float, lo: float, hi: float
) -> float:
    """The a_lat guard's steering rate: from ``delta0`` in one sample time ``dt`` to the steering angle at which speed
    ``v`` on wheelbase ``l`` gives ``|a_lat| = a_to``, on ``delta``'s side, clipped to ``[lo, hi]``; 0 (clipped) for
    ``v = 0``, where ``|a_lat|`` is 0 whatever the angle."""
    r = 0.0
    if v != 0.0:
        r = (math.copysign(math.atan((a_to * l) / (v * v)), delta) - delta0) / dt
    return lo if r < lo else (hi if r > hi else r)


def load_transfer_gain(v: float, a_x: float, k: float, l_f: float, l_r: float, h: float) -> float:
    """The divisor ``d`` of the a_lat guard's tyre-aware lateral acceleration ``v^2 tan(delta) / (l d)``: the linear
    single-track model's steady-state yaw gain under a longitudinal acceleration ``a_x`` (tyres of one cornering
    stiffness per unit load on both axles, the load moved by ``a_x h / l``), ``d = 1 + K v^2`` with
    ``K = k (l_r / (g l_r - a_x h) - l_f / (g l_f + a_x h))``, ``k = 1 / (l c)``; braking (``a_x < 0``) moves load onto
    the front axle: ``K < 0``, the vehicle turns more than the kinematic formula says. ``d`` is at most 1 (the guard
    never allows more than the formula) and at least ``GAIN_MIN`` (beyond the critical speed, ``d <= 0``); ``k = 0``:
    1 (the kinematic formula)."""
    kk = k * (l_r / (G * l_r - a_x * h) - l_f / (G * l_f + a_x * h))
    d = 1.0 + kk * v * v
    return GAIN_MIN if d < GAIN_MIN else (1.0 if d > 1.0 else d)


def drive_limit(a_lat: float, a_max: float, f_max: float) -> float:
    """The combined-acceleration limit on the drive force: a friction ellipse with the semi-axes ``f_max`` (the drive
    force's bound) and ``a_max`` (the lateral acceleration's), ``f_max sqrt(1 - (a_lat / a_max)^2)``, 0 where
    ``|a_lat| >= a_max``: driving while cornering moves load off the front axle and the vehicle turns less than the
    kinematic formula says (understeer), out of the plan's path."""
    r = a_lat / a_max
    q = 1.0 - r * r
    return f_max * math.sqrt(q if q > 0.0 else 0.0)


def understeer_drive_limit(
    a_lat: float, v: float, k: float, l_f: float, l_r: float, h: float, slack: float, f_max: float, m: float
) -> float:
    """The drive force at which the tyres turn at most ``slack`` less than the formula's ``a_lat`` at speed ``v``
    (``load_transfer_gain``'s model, linearized in ``a_x``: ``K = k h a_x l / (g^2 l_f l_r)``, and ``a_lat (1 - 1/d)
    <= slack``: ``a_x <= slack g^2 l_f l_r / (k l h v^2 (a_lat - slack))``), at most ``f_max``; ``f_max`` where
    ``|a_lat| <= slack``, at standstill or without tyres (``k h = 0``)."""
    e = a_lat - slack
    q = k * (l_f + l_r) * h * v * v * e
    if e <= 0.0 or q <= 0.0:
        return f_max
    f = m * slack * G * G * l_f * l_r / q
    return f if f < f_max else f_max


def understeer_excess(a_over, v, a_x, c: float, l_f: float, l_r: float, h: float):
    """How much less than the formula the tyres turn under the acceleration ``a_x`` at speed ``v`` beyond
    ``DRIVE_SLACK``'s share, in ``understeer_drive_limit``'s linear model (``c``: the tyres' cornering stiffness per
    unit load; ``a_over``: the formula's ``|a_lat|`` beyond ``DRIVE_SLACK``, at least 0): ``a_x h v^2 a_over / (c g^2
    l_f l_r)``, at most ``DRIVE_SLACK`` where that limit lets ``a_x`` through; negative when braking. Plain
    arithmetic: floats and CasADi symbols alike."""
    return a_x * h * v * v * a_over / (c * G * G * l_f * l_r)


def bend_brake_limit(
    v: float, delta: float, l: float, a_to: float, a_brake: float, m: float, dt: float, f_max: float
) -> float:
    """The a_lat guard's braking where it steers: too fast for the path the plan turns onto (curvature ``|tan(delta)| /
    l``) at ``|a_lat| = a_to``, the drive force's cap ``-m min(a_brake, (v - v_bend) / dt)``, ``v_bend = sqrt(a_to l /
    |tan(delta)|)``, at least ``-f_max``: the speed falls towards the one that path allows, at most at ``a_brake``;
    ``f_max`` (no cap) where ``v`` is within it or ``a_brake`` is 0."""
    k = abs(math.tan(delta)) / l
    if a_brake <= 0.0 or v * v * k <= a_to:
        return f_max
    a = (v - math.sqrt(a_to / k)) / dt
    a = -m * (a if a < a_brake else a_brake)
    return a if a > -f_max else -f_max


def lag_error(r: float, e: float, tau: float, decay: float) -> float:
    """A first-order steering actuator of time constant ``tau`` (``decay = exp(-dt / tau)``): the commanded minus the
    actual steering angle one sample after ``e`` under the commanded rate ``r``, ``e1 = r tau + (e - r tau) decay``
    (``e' = r - e / tau`` solved over the sample)."""
    rt = r * tau
    return rt + (e - rt) * decay


def lagged_rate(r: float, e: float, tau: float, decay: float, dt: float) -> float:
    """The constant rate at which the actual steering angle moves over the sample under the commanded rate ``r`` from
    the lag ``e``: ``r + (e - e1) / dt`` (``lag_error``'s ``e1``; the closed loop's steering actuator)."""
    return r + (e - lag_error(r, e, tau, decay)) / dt


def lag_command(r_eff: float, e: float, tau: float, decay: float, dt: float) -> float:
    """The commanded rate whose ``lagged_rate`` from ``e`` is ``r_eff``: ``lagged_rate`` is affine in ``r``,
    ``r (1 - tau g / dt) + e g / dt`` with ``g = 1 - decay`` (its slope in (0, 1))."""
    g = 1.0 - decay
    return (r_eff - e * g / dt) / (1.0 - tau * g / dt)


G = 9.81
"""Gravity (m/s^2) of the load transfer (CommonRoad's single-track model's)."""
DRIVE_SLACK = 0.25
"""m/s^2 the tyres may turn less than the formula says while the vehicle drives (``understeer_drive_limit``)."""
BEND_SLACK = 1.0
"""The plan's largest slack above which the a_lat guard, where it steers, also brakes for the plan's path
(``bend_brake_limit``): a plan that cannot keep its rows, too fast for where it goes."""
GAIN_MIN = 0.1
"""The smallest divisor ``load_transfer_gain`` gives: beyond the critical speed the guard takes the tyre-aware a_lat as
10 times the formula's (it then steers towards straight ahead)."""
