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
