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

**The leader's rows** (``lead_shape``): the reference is a wish the NMPC trades against its obstacle rows. Squeezed
(a vehicle in the next lane coming level from behind, whose safe ellipse reaches across the ego's lane), the plan
drives at full force towards its leader whatever the reference, until the leader's own ellipse binds about 0.9 m
bumper to bumper. So the leader's rectangle the solver gets (its rows and the plan check) is also lengthened backwards
by ``t_row`` times the speed by which the ego closes in on it (rounded up to ``row_step``): at that closing speed the
rows bind at a time to collision of more than ``t_row``; at the leader's speed or slower it is the vehicle as it is.
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
    t_row: float = 1.5  # s: the leader's rectangle lengthened by this times the closing speed (module docstring)
    row_step: float = 0.5  # m: the lengthening rounded up to a multiple of this (fewer shapes to compute)

    def __post_init__(self) -> None:
        for name in ("t_gap", "s0", "t_close", "t_row", "row_step"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0.0):
                raise ValueError(f"Following.{name} = {v!r}: must be a finite number > 0")

    def speed(self, gap: float, v_lead: float) -> float:
        """v_follow (module docstring) for a bumper-to-bumper ``gap`` (m) to a vehicle ahead at ``v_lead`` (m/s)."""
        return max(0.0, v_lead + max(0.0, gap - self.s0 - self.t_gap * v_lead) / self.t_close)

    def extension(self, v_ego: float, v_lead: float) -> float:
        """How far (m) the leader's rectangle is lengthened backwards: ``t_row`` (v_ego - v_lead), at least 0,
        rounded up to a multiple of ``row_step``."""
        g = self.t_row * max(0.0, v_ego - v_lead)
        return self.row_step * math.ceil(g / self.row_step - 1e-9)


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


def lead_shape(rule: Following, sc, step: int, ids, shapes: np.ndarray, ego, x: np.ndarray) -> tuple:
    """The opponent slots' shapes (length, width, offset) with the leader's lengthened backwards (module docstring),
    and whether it was: the nearest occupant ahead in the ego's corridor (``vehicle_ahead`` among the slots' vehicles
    at scenario step ``step``; ``x``: the ego's rear-axle state on ``sc.road``, ``ego``: its ``Vehicle``).
    ``shapes`` as it is without one or when the ego does not close in on it."""
    from .lanes import traffic_at

    by_id = {int(ob.id): ob for ob in sc.obstacles}
    slots = [j for j, i in enumerate(ids) if i is not None and int(i) in by_id]
    traffic = traffic_at([by_id[int(ids[j])] for j in slots], sc.road, step, sc.dt)
    if len(traffic.s) != len(slots):  # an occupant without a pose at the step: its slot's index is unknown
        return shapes, False
    half = ego.l / 2
    s_c, n_c = float(x[0]) + half * math.cos(float(x[2])), float(x[1]) + half * math.sin(float(x[2]))
    lead = vehicle_ahead(traffic, s_c, (n_c,), ego.l_ch)
    g = 0.0 if lead is None else rule.extension(float(x[3]), lead[1])
    if lead is None or g <= 0.0:
        return shapes, False
    out = np.array(shapes, dtype=float)
    j = slots[lead[2]]
    out[j] = (out[j, 0] + g, out[j, 1], out[j, 2] - g / 2)  # the front where it is, the rear g further back
    return out, True


def follow_speed(rule: Following, traffic: Traffic, s: float, lanes_n: tuple[float, ...], ego_length: float):
    """The reference speed's cap behind the vehicle ahead (``Following.speed``), None without a vehicle ahead."""
    lead = vehicle_ahead(traffic, s, lanes_n, ego_length)
    return None if lead is None else rule.speed(lead[0], lead[1])


def profile_following(problem) -> Following | None:
    """The driver's rule of ``problem``'s profile: ``Following()`` for the safe profile (its curve speed on,
    ``Reference.curve_a_lat > 0``), None for the paper's (``presets.PAPER_CURVE_A_LAT = 0``: the reference as
    given)."""
    return Following() if problem.reference.curve_a_lat > 0.0 else None
