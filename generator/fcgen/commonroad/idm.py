"""The intelligent driver model (IDM; Treiber, Hennecke & Helbing, Phys. Rev. E 62, 1805, 2000): a follower's
acceleration from its speed ``v``, the bumper-to-bumper gap ``s`` to its leader and the closing speed ``dv`` (positive
when approaching):

    a_IDM = a [1 - (v / v0)^delta - (s*(v, dv) / s)^2],   s*(v, dv) = s0 + max(0, v T + v dv / (2 sqrt(a b)))

Without a leader the last term is left out. The parameters (``IdmParams()``) are the highway set of Treiber & Kesting,
*Traffic Flow Dynamics* (Springer, 2013), Table 11.2: v0 = 120 km/h, T = 1.0 s, s0 = 2 m, delta = 4, a = 1.0 m/s^2,
b = 1.5 m/s^2; a braking is at most ``b_max`` = 9 m/s^2 (about what a car's tyres give on dry asphalt: the IDM itself
has no bound and asks for more in a cut-in closer than its gap). Pure functions; tested against the closed-form
steady state (``equilibrium_gap``) in tests/test_commonroad_reactive.py.
"""

from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True)
class IdmParams:
    """The IDM's parameters (module docstring): desired speed ``v0`` (m/s), time gap ``T`` (s), jam distance ``s0``
    (m), acceleration exponent ``delta``, maximum acceleration ``a``, comfortable deceleration ``b`` and the largest
    braking ``b_max`` (m/s^2)."""

    v0: float = 120.0 / 3.6
    T: float = 1.0
    s0: float = 2.0
    delta: float = 4.0
    a: float = 1.0
    b: float = 1.5
    b_max: float = 9.0

    def __post_init__(self) -> None:
        for name in ("v0", "T", "s0", "delta", "a", "b", "b_max"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0.0):
                raise ValueError(f"IdmParams.{name} = {v}: must be a finite number > 0")


def desired_gap(p: IdmParams, v: float, dv: float) -> float:
    """s*(v, dv): the gap the driver wants at speed ``v`` closing in at ``dv`` (m)."""
    return p.s0 + max(0.0, v * p.T + v * dv / (2.0 * math.sqrt(p.a * p.b)))


def acceleration(p: IdmParams, v: float, gap: float | None = None, dv: float = 0.0) -> float:
    """a_IDM (m/s^2) at speed ``v`` (m/s); ``gap`` (m, bumper to bumper) and ``dv`` = v - v_leader to the leader,
    ``gap`` None: a free road. A gap at or below 0 (contact) gives an unbounded braking: -inf."""
    free = p.a * (1.0 - (max(v, 0.0) / p.v0) ** p.delta)
    if gap is None:
        return free
    if gap <= 0.0:
        return -math.inf
    return free - p.a * (desired_gap(p, v, dv) / gap) ** 2


def equilibrium_gap(p: IdmParams, v: float) -> float:
    """The steady-state gap s_e(v) = (s0 + v T) / sqrt(1 - (v / v0)^delta) at which a follower at ``v`` behind a
    leader at the same speed keeps that speed (0 <= v < v0)."""
    if not 0.0 <= v < p.v0:
        raise ValueError(f"equilibrium_gap: v = {v} m/s must lie in [0, v0 = {p.v0}) m/s")
    return (p.s0 + v * p.T) / math.sqrt(1.0 - (v / p.v0) ** p.delta)


def step(v: float, acc: float, dt: float) -> tuple[float, float]:
    """One step of length ``dt`` at constant acceleration ``acc`` from speed ``v``, never reversing (a stop within the
    step ends there): (distance travelled, speed at the end)."""
    if v + acc * dt >= 0.0:
        return v * dt + 0.5 * acc * dt * dt, v + acc * dt
    return (-0.5 * v * v / acc if acc < 0.0 else 0.0), 0.0
