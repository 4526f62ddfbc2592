"""The safe profile's speed reference behind a vehicle ahead (tested in tests/test_commonroad_follow.py).

The goal's reference speed (``goal.goal_speed``) ignores the traffic: the NMPC then keeps its distance to a slower
vehicle ahead only where its obstacle rows bind, a few metres behind it, and closes in on it at the full speed
difference. With ``Following`` the reference speed is also at most

    v_follow = max(0, v_lead + max(0, gap - s0 - t_gap v_lead) / t_close)

for the nearest vehicle ahead in the ego's corridor: its centre ahead of the ego's centre and within half a lane
(``lanes.SAME_LANE``) across the road of the ego's centre (the vehicles the criticality measures ask about), ``gap``
bumper to bumper along the road (the centres' distance less the half lengths), ``v_lead`` its speed. Beyond the
gap ``s0 + t_gap v_lead`` the ego closes in at most at ``(gap - s0 - t_gap v_lead) / t_close``, so the time to
collision at the reference speed, ``gap / (v_ref - v_lead)``, is at least ``t_close`` (``gap t_close / (gap - s0 -
t_gap v_lead)``); within it the reference is the vehicle's speed (no closing in; the rule does not brake below it to
open the gap: the NMPC's obstacle rows keep the distance, and braking below the traffic's speed cost goals and drew
recorded followers into the ego in a first design, docs/commonroad.md).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .lanes import SAME_LANE, Traffic


@dataclass(frozen=True)
class Following:
    """The rule's parameters: the time gap ``t_gap`` (s) and standstill gap ``s0`` (m) it settles at, and the time
    ``t_close`` (s) over which it closes a larger gap (the smallest time to collision its reference asks for)."""

    t_gap: float = 1.0
    s0: float = 2.0
    t_close: float = 2.0

    def __post_init__(self) -> None:
        for name in ("t_gap", "s0", "t_close"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0.0):
                raise ValueError(f"Following.{name} = {v!r}: must be a finite number > 0")

    def speed(self, gap: float, v_lead: float) -> float:
        """v_follow (module docstring) for a bumper-to-bumper ``gap`` (m) to a vehicle ahead at ``v_lead`` (m/s)."""
        return max(0.0, v_lead + max(0.0, gap - self.s0 - self.t_gap * v_lead) / self.t_close)


def vehicle_ahead(
    traffic: Traffic, s: float, lanes_n: tuple[float, ...], ego_length: float
) -> tuple[float, float, int] | None:
    """The nearest vehicle ahead in the ego's corridor (module docstring): (gap bumper to bumper, speed, its index
    in ``traffic``), None without one. ``s``: the ego's centre; ``lanes_n``: the lateral offsets whose half lane is
    the corridor; ``ego_length``: the ego's chassis length; the vehicles' lengths are ``traffic.length``."""
    corridor = np.zeros(len(traffic.s), dtype=bool)
    for n in lanes_n:
        corridor |= np.abs(traffic.n - n) <= SAME_LANE
    m = corridor & (traffic.s > s)
    if not m.any():
        return None
    lengths = traffic.lengths()
    gaps = np.where(m, traffic.s - s - (lengths + ego_length) / 2, np.inf)
    i = int(np.argmin(gaps))
    return float(gaps[i]), float(traffic.v[i]), i


def follow_speed(rule: Following, traffic: Traffic, s: float, lanes_n: tuple[float, ...], ego_length: float):
    """The reference speed's cap behind the vehicle ahead (``Following.speed``), None without a vehicle ahead."""
    lead = vehicle_ahead(traffic, s, lanes_n, ego_length)
    return None if lead is None else rule.speed(lead[0], lead[1])


def profile_following(problem) -> Following | None:
    """The driver's rule of ``problem``'s profile: ``Following()`` for the safe profile (its curve speed on,
    ``Reference.curve_a_lat > 0``), None for the paper's (``presets.PAPER_CURVE_A_LAT = 0``: the reference as
    given)."""
    return Following() if problem.reference.curve_a_lat > 0.0 else None
